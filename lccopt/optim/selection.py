"""How the surrogate phases choose their next point: the surrogates fitted to what is known,
candidates drawn around the best point (DYCORS), and the one with the best weighted score of
surrogate value and distance; a part of :class:`~lccopt.optim.strategy.Strategy`."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.distance import cdist

from .candidates import CandidateRequest, bound_probes, perturb_probability
from .context import AskContext, CandidatePool
from .local_search import local_search
from .sampling import to_space
from .settings import (
    ENUMERATE_LIMIT,
    WEIGHTS,
)


class CandidateSelection:
    """The candidate selection of :class:`~lccopt.optim.strategy.Strategy` (its state is the
    strategy's)."""

    def _prepare(self) -> AskContext:
        """The points to keep away from, the phase's best point and the surrogate."""
        sp, recs, ph = self.space, self.records, self.phase
        taken = np.array([r["x"] for r in recs]).reshape(-1, sp.dim)
        # Distance criterion: points of this phase (any status; with the point it went on
        # from) and everything in flight.
        own = [r["restart"] == ph.index or r["id"] == ph.anchor for r in recs]
        near = [r["x"] for r, o in zip(recs, own) if o or r["status"] == "pending"]
        ctx = AskContext(sp, taken, np.array(near).reshape(-1, sp.dim))
        ctx.probing = ph.anchor is not None and ph.frozen is None
        if ctx.probing:
            ctx.phase_x = np.array([r["x"] for r, o in zip(recs, own) if o]).reshape(-1, sp.dim)
        ok = sorted((r for r, o in zip(recs, own) if r["status"] == "ok" and o),
                    key=lambda r: r["id"])
        if ok:
            ranked = sorted(ok, key=lambda r: (r["value"], r["id"]))
            ctx.best = ranked[0]["x"]
            ctx.ranked = np.array([r["x"] for r in ranked])
        if ok and (ph.anchor is not None or self.settings.restart_keeps_points):
            ok = sorted((r for r in recs if r["status"] == "ok"), key=lambda r: r["id"])
        if len(ok) >= 2:
            X = sp.to_unit(np.array([r["x"] for r in ok]))
            ctx.surrogate = self._fit(X, ok)
            movable = self._movable()
            ctx.local_search = lambda c: local_search(c, movable)
        return ctx

    def _fit(self, X: np.ndarray, ok: list[dict]):
        """The composite surrogate if set up and every point has its outputs, else the
        scalar one."""
        if self.settings.composite and self._aggregate is not None:
            fit = self._composite.fit(X, [r.get("outputs") for r in ok], self._aggregate)
            if fit is not None:
                return fit
        return self._scalar.fit(X, np.array([r["value"] for r in ok]))

    def _select(self, ctx: AskContext):
        """Best candidate by the merit of Eq. (11), or None if the space is exhausted."""
        if math.isfinite(ctx.n_grid) and len(ctx.taken) >= ctx.n_grid:
            return None
        w = WEIGHTS[self._w_index % len(WEIGHTS)]
        C, src = self._free_candidates(ctx, w)
        if len(C) == 0:
            return None
        Cu = self.space.to_unit(C)
        dist = cdist(Cu, ctx.near_u).min(axis=1) if len(ctx.near_u) else np.ones(len(C))
        dd = _scale(dist.max() - dist)
        if ctx.surrogate is None:
            i = int(np.argmin(dd))  # no surrogate yet: pure space filling
        else:
            i = int(np.argmin(w * _scale(ctx.surrogate(Cu)) + (1.0 - w) * dd))
            self._w_index += 1
        self._n_adaptive += 1
        return C[i].copy(), src[i]

    def _pool(self, ctx: AskContext) -> "CandidatePool":
        """The candidates of a block, drawn once and scored by the surrogate once."""
        C, src = self._free_candidates(ctx, max(WEIGHTS))
        return CandidatePool(self.space, ctx, C, src)

    def _pick(self, ctx: AskContext, pool: "CandidatePool"):
        """The next point of a block from its pool by the merit of Eq. (11) at the next
        weight, or None when the pool is used up (the caller draws afresh)."""
        w = WEIGHTS[self._w_index % len(WEIGHTS)]
        i = pool.best(w, local=self.settings.local_weights == "all" or w == max(WEIGHTS))
        if i is None:
            return None
        if ctx.surrogate is not None:
            self._w_index += 1
        self._n_adaptive += 1
        return pool.C[i].copy(), pool.src[i]

    def _free_candidates(self, ctx: AskContext, w: float):
        """The candidates that are not used points, with their phase kinds: the generator's,
        the bound probes of a phase from a point; when all are taken, wider steps and uniform
        points, then (a small all-integer grid) every grid point."""
        sigma, n_uniform = self.sigma, 0
        probability = self._probability()
        movable = self._movable()
        for attempt in range(8):
            req = CandidateRequest(self.space, self.rng, ctx.best, sigma, probability, movable,
                                   w, attempt, ctx.local, ctx.ranked)
            parts = list(self.candidates(req))
            if attempt == 0 and ctx.best is not None and ctx.probing:
                parts.append((bound_probes(self.space, ctx.best, ctx.phase_x, self._free),
                              "adaptive"))
            if n_uniform > 0:
                parts.append((to_space(self.space, self.rng.random((n_uniform, self.space.dim))),
                              "random"))
            if attempt >= 3 and math.isfinite(ctx.n_grid) and ctx.n_grid <= ENUMERATE_LIMIT:
                parts.append((self.space.grid(), "random"))
            C = np.vstack([P for P, _ in parts]) if parts else np.empty((0, self.space.dim))
            src = [kind for P, kind in parts for _ in range(len(P))]
            free = ~ctx.is_taken(C)
            if free.any():
                return C[free], [t for t, f in zip(src, free) if f]
            # Everything near the best is used up: widen the steps, add more uniform points.
            sigma = min(1.0, 2.0 * sigma)
            n_uniform = max(2 * n_uniform, 100)
        return np.empty((0, self.space.dim)), []

    def _probability(self) -> float:
        """DYCORS's perturbation probability at this proposal (``settings``' schedule)."""
        ph = self.phase
        return perturb_probability(
            self.settings.probability_schedule, self.space.dim, self.n_asked,
            max(self.n_initial, len(self.space.given)), self.budget,
            self.budget - ph.start - ph.n_design, self._n_adaptive)


def _scale(v: np.ndarray) -> np.ndarray:
    lo, hi = float(v.min()), float(v.max())
    return (v - lo) / (hi - lo) if hi > lo else np.zeros_like(v)
