"""The local mixed-integer search of the surrogate (the paper's branch-and-bound supplement).

An RBF gives no valid lower bound, so the branches are heuristic integer assignments: the
best point's, the rounded minimiser of the relaxed (all-continuous) surrogate, and the best
unused unit-step neighbours of the best point by surrogate value. On each branch the
continuous part is minimised with L-BFGS-B from the best point. No random numbers are drawn:
the points depend on the surrogate and the best point only.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize

from .settings import LOCAL_MAXITER, N_BRANCHES


def local_search(ctx, movable: np.ndarray) -> np.ndarray:
    """Up to N_BRANCHES + 1 points, one per integer assignment, minimising the surrogate.

    Parameters
    ----------
    ctx : AskContext
        Its fitted ``surrogate``, ``best`` point and duplicate test (``is_taken``).
    movable : ndarray of bool (d,)
        The variables the search may change.

    Returns
    -------
    ndarray (k, d)
        Valid points of the space (k = 0 without a best point).
    """
    sp, best = ctx.space, ctx.best
    if best is None:
        return np.empty((0, sp.dim))
    minimise = _minimiser(ctx.surrogate)
    cont = np.flatnonzero(ctx.cont)
    ints = np.flatnonzero(ctx.int & movable)
    branches = [best[ints]]
    if len(ints):
        relaxed = sp.snap(sp.from_unit(minimise(sp.to_unit(best), np.flatnonzero(movable))))
        branches.append(relaxed[ints])
        nb = np.repeat(best[None, :], 2 * len(ints), axis=0)
        nb[np.arange(len(ints)), ints] += 1.0
        nb[len(ints) + np.arange(len(ints)), ints] -= 1.0
        nb = nb[np.all((nb >= sp.lb) & (nb <= sp.ub), axis=1)]
        if len(cont) == 0:
            nb = nb[~ctx.is_taken(nb)]
        order = np.argsort(ctx.surrogate(sp.to_unit(nb)), kind="stable")
        branches += [nb[j, ints] for j in order]
    pts, seen = [], set()
    for b in branches:
        key = tuple(np.asarray(b).tolist())
        if key in seen:
            continue
        seen.add(key)
        x0 = np.asarray(best, dtype=float).copy()
        x0[ints] = b
        pts.append(sp.snap(sp.from_unit(minimise(sp.to_unit(x0), cont))))
        if len(pts) >= N_BRANCHES + 1:
            break
    return np.array(pts).reshape(-1, sp.dim)


def _minimiser(surrogate):
    """``minimise(u0, dims)``: u0 (unit box) with the coordinates ``dims`` moved to a local
    minimum of the surrogate (L-BFGS-B within the unit box, LOCAL_MAXITER iterations)."""
    opts = {"maxiter": LOCAL_MAXITER}

    def minimise(u0: np.ndarray, dims: np.ndarray) -> np.ndarray:
        if len(dims) == 0:
            return u0
        u = u0.copy()

        def fg(z):
            u[dims] = z
            v, g = surrogate.value_and_gradient(u)
            return v, g[dims]

        res = scipy.optimize.minimize(fg, u0[dims], jac=True, method="L-BFGS-B",
                                      bounds=[(0.0, 1.0)] * len(dims), options=opts)
        out = u0.copy()
        out[dims] = np.clip(res.x, 0.0, 1.0)
        return out

    return minimise
