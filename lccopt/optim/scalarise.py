"""Multi-objective helpers: the augmented Chebyshev ASF (paper Eq. 7) and Pareto masks.

Both are pure functions of objective vectors, so every objective of every evaluation can
be stored and re-scalarised later (another reference point, another rho) without
re-running anything.
"""

from __future__ import annotations

import numpy as np

# The ASF's settings where a case gives none (the case schema's defaults are these): the
# augmentation rho, and the reference point's improvement on the reference design, the
# paper's "20 % better" (Sec. 3.2).
RHO = 0.05
IMPROVEMENT = 0.2


def asf(F, ref_point, worst, rho: float = RHO) -> np.ndarray:
    """Augmented Chebyshev achievement scalarising function, Eq. (7), to be minimised.

        g(f) = max_i kappa_i (f_i - f_i^r) + rho * sum_i kappa_i (f_i - f_i^r),
        kappa_i = 1 / (f_i^max - f_i^r)

    F: objective vectors, shape (n, k) or (k,); ref_point f^r and worst f^max: shape (k,).
    Returns shape (n,) (or a 0-d array for a single vector). g < 0 exactly when every
    objective is better than its reference value; rho > 0 makes g strictly increasing in
    every objective (the max term alone ignores all but the worst-off objective).
    """
    F = np.asarray(F, dtype=float)
    ref = np.asarray(ref_point, dtype=float)
    worst = np.asarray(worst, dtype=float)
    if ref.shape != worst.shape or ref.ndim != 1:
        raise ValueError(f"ref_point {ref.shape} and worst {worst.shape} must be 1-D and alike")
    if F.shape[-1] != ref.shape[0]:
        raise ValueError(f"objective vectors have {F.shape[-1]} entries, "
                         f"ref_point has {ref.shape[0]}")
    if not np.all(worst > ref):
        raise ValueError("every worst value must exceed its reference value (kappa_i > 0)")
    if rho < 0:
        raise ValueError("rho must be >= 0")
    return _asf(F, ref, worst - ref, rho)


def _asf(F: np.ndarray, ref: np.ndarray, span: np.ndarray, rho: float) -> np.ndarray:
    dev = (F - ref) / span
    return dev.max(axis=-1) + rho * dev.sum(axis=-1)


class ASF:
    """``asf`` with fixed reference point, worst values and rho, as an aggregate F -> values
    (for a composite surrogate); compares equal to another with the same parameters."""

    # Never decreases when an objective grows (kappa_i > 0, rho >= 0), so a composite
    # surrogate may median-cap the objectives it fits (Strategy.set_aggregate).
    increasing = True

    def __init__(self, ref_point, worst, rho: float = RHO):
        self.ref_point = [float(v) for v in ref_point]
        self.worst = [float(v) for v in worst]
        self.rho = float(rho)
        asf(self.ref_point, self.ref_point, self.worst, self.rho)  # the parameters' checks, once
        # The composite surrogate's local search calls this ~30000 times per run with one or
        # a few rows: the same arithmetic as asf (same numbers), without re-checking.
        self._ref = np.asarray(self.ref_point, dtype=float)
        self._span = np.asarray(self.worst, dtype=float) - self._ref

    def __call__(self, F) -> np.ndarray:
        """The ASF of the objective vectors F (k,) or (n, k): an array (1,) or (n,)."""
        F = np.asarray(F, dtype=float)
        if F.ndim == 0 or F.shape[-1] != self._ref.shape[0]:
            return np.atleast_1d(asf(F, self.ref_point, self.worst, rho=self.rho))  # its error
        return np.atleast_1d(_asf(F, self._ref, self._span, self.rho))

    def __eq__(self, other) -> bool:
        return isinstance(other, ASF) and (self.ref_point, self.worst, self.rho) == (
            other.ref_point, other.worst, other.rho)

    def __repr__(self) -> str:
        return f"ASF(ref_point={self.ref_point}, worst={self.worst}, rho={self.rho})"


def improvement_target(f_reference, fraction: float = IMPROVEMENT) -> np.ndarray:
    """Reference point a given fraction better than a reference design's objectives
    (the paper's 20 %: f^r = 0.8 f(x_ref)); assumes positive objectives."""
    return (1.0 - fraction) * np.asarray(f_reference, dtype=float)


def pareto_mask(F) -> np.ndarray:
    """Boolean mask of the non-dominated rows of F (n, k), all objectives minimised.

    A row is dominated if another row is <= in every objective and < in at least one;
    equal rows do not dominate each other, so duplicates of a front point are all kept.
    Rows with a non-finite entry (failed evaluations) are never on the front.
    """
    F = np.asarray(F, dtype=float)
    if F.ndim == 1:
        F = F[:, None]
    ok = np.all(np.isfinite(F), axis=1)
    mask = ok.copy()
    idx = np.flatnonzero(ok)
    G = F[idx]
    # Chunked all-pairs comparison: O(n^2 k) work, O(chunk * n * k) memory.
    chunk = max(1, 2_000_000 // max(1, len(G) * F.shape[1]))
    for s in range(0, len(G), chunk):
        Q = G[s:s + chunk]
        le = np.all(G[None, :, :] <= Q[:, None, :], axis=2)
        lt = np.any(G[None, :, :] < Q[:, None, :], axis=2)
        mask[idx[s:s + chunk]] = ~np.any(le & lt, axis=1)
    return mask
