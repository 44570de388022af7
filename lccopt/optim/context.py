"""What one ``ask`` works with: the points to keep away from and the fitted surrogate."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from scipy.spatial.distance import cdist

from .settings import DIST_TOL
from .space import DesignSpace


class AskContext:
    """Per-ask working data, built once per ``ask`` call (one surrogate fit for every point
    the call proposes; each proposal is added with ``add`` before the next is chosen).

    Parameters
    ----------
    space : DesignSpace
    taken : ndarray (n, d)
        Every point proposed so far (evaluated, failed or pending): never proposed again.
    near : ndarray (m, d)
        The points the merit's distance term keeps away from (the phase's and those in flight).
    """

    def __init__(self, space: DesignSpace, taken: np.ndarray, near: np.ndarray):
        self.space = space
        self.int = space.int_mask
        self.cont = ~self.int & (space.ub - space.lb > 0)
        self.tol = DIST_TOL * math.sqrt(max(1, int(self.cont.sum())))
        self.n_grid = space.n_grid
        self.taken = taken
        self.near_u = space.to_unit(near)
        self.best: np.ndarray | None = None  # the phase's best point
        self.ranked = np.empty((0, space.dim))  # the phase's told points, best first
        self.probing = False  # bound probes join the candidates (a phase from the best point)
        self.phase_x = np.empty((0, space.dim))  # the phase's points, with the one it went on from
        self.surrogate = None  # ScalarSurrogate's RBF or a CompositeSurrogate, once fitted
        self.local_search: Callable[["AskContext"], np.ndarray] | None = None
        self._local: np.ndarray | None = None

    def local(self) -> np.ndarray | None:
        """The local search's points (computed on first use: most proposals do not need them)."""
        if self._local is None and self.local_search is not None:
            self._local = self.local_search(self)
        return self._local

    def add(self, x: np.ndarray) -> None:
        """A point just proposed: taken, and near from now on."""
        self.taken = np.vstack([self.taken, x[None, :]])
        self.near_u = np.vstack([self.near_u, self.space.to_unit(x)[None, :]])

    def is_taken(self, C: np.ndarray) -> np.ndarray:
        """Per row of C: the same integer values as a used point and the continuous part
        within the duplicate radius of it."""
        nt = len(self.taken)
        if nt == 0 or len(C) == 0:
            return np.zeros(len(C), dtype=bool)
        if self.int.any():
            # Group rows by their integer part (exact float equality; + 0.0 makes -0.0 equal
            # to 0.0, as a comparison would) instead of comparing every pair.
            ints = np.vstack([self.taken[:, self.int], C[:, self.int]]) + 0.0
            key = np.unique(ints, axis=0, return_inverse=True)[1].ravel()
            kt, kc = key[:nt], key[nt:]
            match = np.isin(kc, kt)
        else:
            kt, kc = np.zeros(nt, dtype=int), np.zeros(len(C), dtype=int)
            match = np.ones(len(C), dtype=bool)
        if not self.cont.any() or not match.any():
            return match
        out = np.zeros(len(C), dtype=bool)
        Cu = self.space.to_unit(C[match])[:, self.cont]
        Tu = self.space.to_unit(self.taken)[:, self.cont]
        ci, kcm = np.flatnonzero(match), kc[match]
        for k in np.unique(kcm):  # continuous part within tol of a used point, same integers
            rows = kcm == k
            out[ci[rows]] = (cdist(Cu[rows], Tu[kt == k]) < self.tol).any(axis=1)
        return out


class CandidatePool:
    """The candidates of a block of proposals: drawn once and scored by the surrogate once;
    each point proposed (``add``) lowers the candidates' distances to the used points and
    takes its duplicates out, so the block's points spread apart as pySOT's batches do.

    Parameters
    ----------
    space : DesignSpace
    ctx : AskContext
        The block's context (its points to keep away from, duplicate radius and surrogate).
    C : ndarray (n, d)
        The candidates (unused points).
    src : list of str
        Their phase kinds ("adaptive", "local", "random").
    """

    def __init__(self, space: DesignSpace, ctx: AskContext, C: np.ndarray, src: list):
        self.space, self.C, self.src = space, C, list(src)
        self.Cu = space.to_unit(C) if len(C) else np.empty((0, space.dim))
        self.local = np.array([k == "local" for k in self.src], dtype=bool)
        self.free = np.ones(len(C), dtype=bool)
        self.dist = (cdist(self.Cu, ctx.near_u).min(axis=1) if len(ctx.near_u) and len(C)
                     else np.full(len(C), np.inf))
        self.value = (np.asarray(ctx.surrogate(self.Cu), dtype=float)
                      if ctx.surrogate is not None and len(C) else None)
        self.int, self.cont, self.tol = ctx.int, ctx.cont, ctx.tol

    def best(self, w: float, local: bool = True) -> int | None:
        """Index of the free candidate of lowest merit w * scaled surrogate value +
        (1 - w) * scaled distance term (the distance term alone without a surrogate);
        ``local``: the local search's points compete. None if none is free."""
        idx = np.flatnonzero(self.free if local else self.free & ~self.local)
        if not len(idx):
            return None
        d = self.dist[idx]
        d = np.where(np.isfinite(d), d, 1.0)  # nothing to keep away from yet
        dd = _scale(d.max() - d)
        if self.value is None:
            return int(idx[np.argmin(dd)])
        return int(idx[np.argmin(w * _scale(self.value[idx]) + (1.0 - w) * dd)])

    def add(self, x: np.ndarray) -> None:
        """A point just proposed: near from now on, and its duplicates are taken."""
        if not len(self.C):
            return
        xu = self.space.to_unit(x)
        diff = self.Cu - xu[None, :]
        self.dist = np.minimum(self.dist, np.sqrt(np.einsum("ij,ij->i", diff, diff)))
        same = np.all(self.C[:, self.int] == x[None, self.int], axis=1)
        if self.cont.any():
            dc = diff[:, self.cont]
            same &= np.sqrt(np.einsum("ij,ij->i", dc, dc)) < self.tol
        self.free &= ~same


def _scale(v: np.ndarray) -> np.ndarray:
    lo, hi = float(v.min()), float(v.max())
    return (v - lo) / (hi - lo) if hi > lo else np.zeros_like(v)
