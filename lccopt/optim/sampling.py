"""Space-filling initial design: integer-aware Latin hypercube without duplicates."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.distance import pdist

from .space import DesignSpace


def _lhs_unit(n: int, d: int, rng: np.random.Generator) -> np.ndarray:
    """One random Latin hypercube in [0, 1)^d: one point per stratum and dimension."""
    strata = np.stack([rng.permutation(n) for _ in range(d)], axis=1)
    return (strata + rng.random((n, d))) / n


def to_space(space: DesignSpace, u: np.ndarray) -> np.ndarray:
    """Points of [0, 1)^d to design points, each value of a variable with an equal share."""
    lb, ub, m = space.search_lb, space.search_ub, space.int_mask
    # Integers: stretch [0, 1] over [lb - 0.5, ub + 0.5] before rounding so that the end
    # values get a full-width stratum like the inner values (plain rounding halves them).
    # Log variables: strata of equal ratio (search coordinates).
    lo = np.where(m, lb - 0.5, lb)
    hi = np.where(m, ub + 0.5, ub)
    return space.snap(space.from_search(lo + u * (hi - lo)))


def _keys(X: np.ndarray) -> list[tuple]:
    return [tuple(r) for r in np.asarray(X, dtype=float).tolist()]


def latin_hypercube(space: DesignSpace, n: int, rng: np.random.Generator,
                    exclude: np.ndarray | None = None, tries: int = 10) -> np.ndarray:
    """``n`` distinct points of ``space`` (not in ``exclude``) from a Latin hypercube.

    The best of ``tries`` hypercubes by the maximin distance (in the unit box) is kept, a
    cheap guard against the clumped designs plain LHS sometimes gives. Points lost to
    duplicates (integer rounding, ``exclude``) are topped up from further hypercubes, and
    from the list of unused grid points for small all-integer spaces. Fewer than ``n``
    points come back only if the space has fewer unused points than that.
    """
    d = space.dim
    n = int(n)
    if n <= 0:
        return np.empty((0, d))
    taken = set(_keys(exclude)) if exclude is not None and len(exclude) else set()
    out: list[np.ndarray] = []

    def add(X: np.ndarray) -> None:
        for x, k in zip(X, _keys(X)):
            if len(out) < n and k not in taken:
                taken.add(k)
                out.append(x)

    best, best_score = None, -np.inf
    for _ in range(max(1, tries)):
        X = to_space(space, _lhs_unit(n, d, rng))
        # Score on distinct points only: duplicates are dropped anyway.
        Xu = np.unique(space.to_unit(X), axis=0)
        score = pdist(Xu).min() if len(Xu) > 1 else 0.0
        score += len(Xu)  # prefer designs that lose fewer points to rounding
        if score > best_score:
            best, best_score = X, score
    add(best)
    for _ in range(20):
        if len(out) >= n:
            break
        add(to_space(space, _lhs_unit(n - len(out), d, rng)))
    if len(out) < n and math.isfinite(space.n_grid):
        G = space.grid()
        free = np.array([k not in taken for k in _keys(G)], dtype=bool)
        G = G[free]
        if len(G):
            add(G[rng.permutation(len(G))[: n - len(out)]])
    return np.array(out, dtype=float).reshape(-1, d)
