"""The surrogates a proposal is scored with (paper Step C).

* ``ScalarSurrogate``: one cubic RBF of the told values. Its tail (linear, paper Eq. 8, or
  quadratic) and whether the values are median-capped first (values above the median replaced
  by the median, as in Regis & Shoemaker) are chosen at every fit by leave-one-out
  cross-validation (``loo_scores``): how well each choice ranks the better half of the points.
  Capping keeps one huge value from flattening the surrogate where the good points are; a
  quadratic tail fits smooth, ill-conditioned problems that a linear tail leaves to the
  kernel, but it is only taken if it also ranks all the points better (on the better half
  alone it was a trade on the broad benchmark).
* ``CompositeSurrogate``: one cubic RBF per told output (e.g. per objective, per sleeper
  energy), evaluated as ``aggregate(predicted outputs)``: where the minimised value is a
  kinked function of smooth outputs (the ASF's max, E_max's max - min) the aggregate of
  smooth fits is a better model than an RBF of the kinks. The outputs are median-capped per
  output only when the aggregate declares itself ``increasing`` in every output (the ASF):
  for a spread (max - min) a high value matters as much as a low one.

Both are called on unit-box points and give ``value_and_gradient`` for the local search.
"""

from __future__ import annotations

import numpy as np

from .rbf import CubicRBF, distances

# Fewer points than this: no cross-validation (no capping, a linear tail).
_MIN_LOO_POINTS = 8


def loo_scores(fit: CubicRBF, f: np.ndarray, values: list) -> list:
    """How well the interpolants of ``fit``'s points and tail rank the points.

    For each vector of ``values`` (f, or f median-capped): the Spearman rank correlation of
    its leave-one-out predictions with f over the better half of the points (by f); then
    the same for the first vector over all the points. With fewer than 8 points: 0 for the
    first, -inf for the others (no choice can be judged).

    Parameters
    ----------
    fit : CubicRBF
        A fit to the points (its tail is the one judged).
    f : ndarray (n,)
        The told values.
    values : list of ndarray (n,)
        The vectors whose interpolants are judged.

    Returns
    -------
    list of float
        ``len(values) + 1`` scores, higher is better; -inf where a prediction is not finite.
    """
    n = len(f)
    if n < _MIN_LOO_POINTS:
        return [0.0] + [-np.inf] * (len(values) - 1) + [0.0]
    half = np.argsort(f, kind="stable")[: n // 2]
    residuals = fit.loo_residuals(values)
    scores = []
    for rows, vals, e in [(half, v, e) for v, e in zip(values, residuals)] + [
            (slice(None), values[0], residuals[0])]:
        pred = (vals - e)[rows]
        if not np.all(np.isfinite(pred)):
            scores.append(-np.inf)
            continue
        r = spearman(pred, f[rows])
        scores.append(r if np.isfinite(r) else -np.inf)
    return scores


def spearman(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman's rank correlation of a and b (ties: average ranks), NaN where either is
    constant: ``scipy.stats.spearmanr``'s value to the last bit (the same ranks, the same
    ``np.corrcoef``), without importing scipy.stats (half a second of every run's start)."""
    if len(a) < 2 or np.all(a == a[0]) or np.all(b == b[0]) or np.isnan(a).any() \
            or np.isnan(b).any():
        return np.nan
    return float(np.corrcoef(average_ranks(a), average_ranks(b))[1, 0])


def average_ranks(a: np.ndarray) -> np.ndarray:
    """Ranks 1..n of a's values, tied values sharing their average rank (as
    ``scipy.stats.rankdata``'s default)."""
    order = np.argsort(a, kind="mergesort")
    s = a[order]
    first = np.r_[True, s[1:] != s[:-1]]
    group = np.cumsum(first) - 1
    ends = np.r_[np.flatnonzero(first)[1:], len(a)]          # one past each group's last
    starts = np.flatnonzero(first)
    ranks = np.empty(len(a))
    ranks[order] = (0.5 * (starts + 1 + ends))[group]
    return ranks


def capping_helps(plain: CubicRBF, f: np.ndarray) -> bool:
    """Whether the median-capped values rank the better half of the points better than f
    does, by ``loo_scores`` of ``plain`` (the RBF fitted to f); ties: no capping."""
    scores = loo_scores(plain, f, [f, np.minimum(f, np.median(f))])
    return bool(scores[1] > scores[0])


class ScalarSurrogate:
    """Fits one cubic RBF of the values, its tail and capping chosen by cross-validation.

    The instance keeps the RBF between fits (a cache of the distance matrix: a refit with
    more points reuses it, bit-identically); it is never part of the optimiser's state.
    """

    def __init__(self):
        self.rbf = CubicRBF()

    def fit(self, X: np.ndarray, f: np.ndarray) -> CubicRBF:
        """The cubic RBF of (X, f) in the unit box with the tail and capping that rank the
        better half of the points best by leave-one-out (ties: linear before quadratic,
        uncapped before capped); a quadratic tail only when there are points enough to
        determine it and it also ranks all the points better than the linear one."""
        capped = np.minimum(f, np.median(f))
        best, choice, overall = -np.inf, None, {}
        fit = None
        for tail in ("linear", "quadratic"):
            fit = self.rbf.fit(X, f, tail)
            if tail == "quadratic" and not len(fit.quad_i):
                fit = None  # too few points for the quadratic tail: the linear fit stands
                break
            *scores, overall[tail] = loo_scores(fit, f, [f, capped])
            if tail == "quadratic" and not overall["quadratic"] > overall["linear"]:
                continue  # better on the better half only: not taken (a cost elsewhere)
            for cap, score in zip((False, True), scores):
                if choice is None or score > best:
                    best, choice = score, (tail, cap)
        tail, cap = choice
        if fit is not None and not cap and tail == "quadratic":
            return fit  # the last fit is the choice
        return self.rbf.fit(X, capped if cap else f, tail)


class CompositeSurrogate:
    """aggregate(one RBF per output): called and differentiated like a CubicRBF.

    Parameters
    ----------
    rbfs : list of CubicRBF
        One fit per output.
    aggregate : callable
        ``aggregate(F (n, k)) -> (n,)``, the value as a function of the outputs.
    """

    def __init__(self, rbfs: list, aggregate):
        self.rbfs, self.aggregate = rbfs, aggregate
        self._shared = None  # see _shared_points

    def _agg(self, F: np.ndarray) -> np.ndarray:
        return np.asarray(self.aggregate(F), dtype=float).reshape(len(F))

    def __call__(self, Xq: np.ndarray):
        """The aggregate of the predicted outputs at Xq (d,) -> float or (m, d) -> (m,)."""
        Xq = np.asarray(Xq, dtype=float)
        single = Xq.ndim == 1
        Xq = np.atleast_2d(Xq)
        shared = self._shared_points()
        if shared:  # one distance matrix for all the RBFs (same operations as each would do)
            r = distances(Xq, shared.X)
            r3 = r * r * r
            F = np.column_stack([rb.predict_from(Xq, r3) for rb in self.rbfs])
        else:
            F = np.column_stack([rb(Xq) for rb in self.rbfs])
        v = self._agg(F)
        return v[0] if single else v

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """Chain rule with forward differences of the aggregate in each output (a one-sided
        derivative at a kink of the aggregate, enough for the heuristic local search)."""
        return self.value_and_gradient(x)[1]

    def value_and_gradient(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """``(float(self(x)), gradient(x))`` at one point x (d,), the outputs predicted once
        for both (the local search asks for both at every step); the same numbers as the two
        calls give: the value is the aggregate of the same (1, k) row as ``__call__``'s."""
        x = np.asarray(x, dtype=float)
        shared = self._shared_points()
        if shared:  # the RBFs' distances to x computed once for all (same operations)
            xq = x[None, :]
            r = distances(xq, shared.X)
            r3 = r * r * r
            f = np.array([rb.predict_from(xq, r3)[0] for rb in self.rbfs], dtype=float)
        else:
            f = np.array([r(x) for r in self.rbfs], dtype=float)
        value = float(self._agg(f[None, :])[0])
        h = 1e-7 * np.maximum(1.0, np.abs(f))
        F = np.vstack([f[None, :], f[None, :] + np.diag(h)])
        a = self._agg(F)
        dA = (a[1:] - a[0]) / h
        g = np.zeros_like(x)
        diff = rn = None
        for j, rb in enumerate(self.rbfs):
            if dA[j] != 0.0:
                if not shared:
                    g += dA[j] * rb.gradient(x)
                    continue
                if diff is None:  # as CubicRBF.gradient computes them
                    diff = x[None, :] - shared.X
                    rn = np.sqrt(np.einsum("ij,ij->i", diff, diff))
                g += dA[j] * rb.gradient_from(diff, rn, x)
        return value, g

    def _shared_points(self):
        """The first RBF if every RBF was fitted to the same points (as ``CompositeFit``
        fits them: the same X, hence the same tail columns), else None."""
        if self._shared is None:
            r0 = self.rbfs[0] if self.rbfs else None
            ok = r0 is not None and all(
                np.array_equal(r.X, r0.X) and np.array_equal(r.tail_dims, r0.tail_dims)
                and np.array_equal(r.quad_i, r0.quad_i) and np.array_equal(r.quad_j, r0.quad_j)
                for r in self.rbfs)
            self._shared = (r0,) if ok else ()
        return self._shared[0] if self._shared else None


class CompositeFit:
    """Fits a ``CompositeSurrogate``; keeps one RBF per output between fits (a cache only)."""

    def __init__(self):
        self.rbfs: list[CubicRBF] = []

    def fit(self, X: np.ndarray, outputs: list, aggregate) -> CompositeSurrogate | None:
        """One RBF per output of the points X (unit box), or None if an output vector is
        missing, empty, of another length than the others or not finite (then the caller
        fits the scalar surrogate)."""
        if any(o is None for o in outputs) or len({len(o) for o in outputs}) != 1 \
                or len(outputs[0]) == 0:
            return None
        F = np.array(outputs, dtype=float)
        if not np.all(np.isfinite(F)):
            return None
        if getattr(aggregate, "increasing", False):
            F = np.minimum(F, np.median(F, axis=0)[None, :])
        while len(self.rbfs) < F.shape[1]:
            self.rbfs.append(CubicRBF())
        rbfs = [self.rbfs[j].fit(X, F[:, j]) for j in range(F.shape[1])]
        return CompositeSurrogate(rbfs, aggregate)
