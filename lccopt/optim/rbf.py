"""Cubic radial basis function interpolant with a linear tail (paper Eqs. 8-10).

    s(x) = sum_k lambda_k ||x - x_k||^3 + b^T x + a

with lambda, b, a from the saddle system [[Phi, P], [P^T, 0]] [lambda; beta] = [f; 0]; with
``fit(..., tail="quadratic")`` the tail also has sum_{i<=j} c_ij (x_i - 1/2)(x_j - 1/2) (it
reproduces a quadratic exactly; the strategy chooses the tail by cross-validation).
The strategy fits it in the unit box. Guards:

* a tiny ridge on Phi (relative to its size) keeps near-duplicate points from making the
  system singular; r^3 is conditionally positive definite of order 2, so a positive ridge
  only smooths, it never makes the system indefinite;
* tail columns of coordinates that are constant over the data (fixed variables, an
  integer variable stuck at one value) are dropped, since they make P rank deficient;
* anything still singular or inaccurate falls back to a minimum-norm least-squares solve.

Refitting is cheap as points arrive: the distance matrix of the previous fit is reused
when the new data extend the old (same points first), and only new rows are computed.
All distances come from one elementwise routine, so an incremental fit is bit-identical
to a fresh one (needed for exact resume of the strategy).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg


def distances(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Euclidean distances between the rows of A (m, d) and B (n, d).

    Summed one coordinate at a time: every entry is computed by the same sequence of
    float operations whatever the shapes, which keeps cached and fresh fits identical.
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    m, n, d = A.shape[0], B.shape[0], A.shape[1]
    if 0 < d and m * n * d <= _BLOCK:
        # One broadcast instead of a Python loop over the coordinates (the local search calls
        # this ~16000 times per run with one point): add.accumulate sums the squares in the
        # same sequential order as the loop below (a reduce would sum pairwise), so the
        # result is bit-identical.
        diff = A[:, None, :] - B[None, :, :]
        return np.sqrt(np.add.accumulate(diff * diff, axis=2)[:, :, -1])
    acc = np.zeros((m, n))
    for k in range(d):
        diff = A[:, k, None] - B[None, :, k]
        acc += diff * diff
    return np.sqrt(acc)


_BLOCK = 1 << 19  # largest m * n * d done in one broadcast by ``distances``


class CubicRBF:
    """Cubic RBF interpolant with linear tail; ``fit(X, f)`` then ``s(Xq)``."""

    def __init__(self, ridge: float = 1e-10):
        self.ridge = float(ridge)
        self.X: np.ndarray | None = None
        self._D: np.ndarray | None = None
        self.lam: np.ndarray | None = None
        self.beta: np.ndarray | None = None  # [a, b_j for j in tail_dims]
        self.tail_dims: np.ndarray | None = None
        # Quadratic tail ("quadratic" fits): the pairs (i, j), i <= j, of its products
        # (u_i - 1/2)(u_j - 1/2), coefficients after the linear ones in beta.
        self.quad_i = np.empty(0, dtype=int)
        self.quad_j = np.empty(0, dtype=int)
        self.used_lstsq = False
        self._A: np.ndarray | None = None  # the saddle system of the last fit

    # -- fitting ------------------------------------------------------------
    def _distance_matrix(self, X: np.ndarray) -> np.ndarray:
        n0 = 0 if self.X is None else len(self.X)
        if 0 < n0 <= len(X) and self.X.shape[1] == X.shape[1] and np.array_equal(X[:n0], self.X):
            D = np.empty((len(X), len(X)))
            D[:n0, :n0] = self._D
            if len(X) > n0:
                new = distances(X[n0:], X)
                D[n0:, :] = new
                D[:, n0:] = new.T
            return D
        return distances(X, X)

    def fit(self, X: np.ndarray, f: np.ndarray, tail: str = "linear") -> "CubicRBF":
        """Interpolate f at the rows of X. ``tail`` "quadratic" adds the products of the
        centred coordinates to the linear tail (every pair, squares only of coordinates with
        more than two values in X) when X determines them (full column rank, more points
        than tail terms); otherwise, and with "linear", the tail is linear."""
        if tail not in ("linear", "quadratic"):
            raise ValueError("tail must be 'linear' or 'quadratic'")
        X = np.array(X, dtype=float, ndmin=2)
        f = np.asarray(f, dtype=float).ravel()
        n, d = X.shape
        if len(f) != n:
            raise ValueError(f"{n} points but {len(f)} values")
        if n == 0:
            raise ValueError("cannot fit an RBF to no points")
        if not np.all(np.isfinite(f)) or not np.all(np.isfinite(X)):
            raise ValueError("RBF data must be finite")
        D = self._distance_matrix(X)
        self.X, self._D = X, D
        Phi = D * D * D
        dims = np.flatnonzero(np.ptp(X, axis=0) > 0) if n > 1 else np.empty(0, dtype=int)
        P = np.hstack([np.ones((n, 1)), X[:, dims]])
        self.quad_i = self.quad_j = np.empty(0, dtype=int)
        if tail == "quadratic" and len(dims):
            qi, qj = np.triu_indices(len(dims))
            qi, qj = dims[qi], dims[qj]
            # A coordinate with two values has u^2 in the span of 1 and u: no square of it.
            two = (np.diff(np.sort(X, axis=0), axis=0) != 0).sum(axis=0) + 1 <= 2
            keep = (qi != qj) | ~two[qi]
            PQ = np.hstack([P, _products(X, qi[keep], qj[keep])])
            if n > PQ.shape[1] and np.linalg.matrix_rank(PQ) == PQ.shape[1]:
                P = PQ
                self.quad_i, self.quad_j = qi[keep], qj[keep]
        m = P.shape[1]
        A = np.zeros((n + m, n + m))
        A[:n, :n] = Phi
        A[np.arange(n), np.arange(n)] += self.ridge * max(1.0, float(Phi.max()))
        A[:n, n:] = P
        A[n:, :n] = P.T
        rhs = np.concatenate([f, np.zeros(m)])
        sol = None
        self.used_lstsq = False
        if np.linalg.matrix_rank(P) == m:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
                    sol = scipy.linalg.solve(A, rhs, assume_a="sym", check_finite=False)
                res = np.abs(A @ sol - rhs).max()
                if not np.isfinite(res) or res > 1e-8 * max(1.0, np.abs(f).max()):
                    sol = None
            except (np.linalg.LinAlgError, ValueError):
                sol = None
        if sol is None:
            self.used_lstsq = True
            sol = scipy.linalg.lstsq(A, rhs, check_finite=False, lapack_driver="gelsd")[0]
        self.lam, self.beta, self.tail_dims = sol[:n], sol[n:], dims
        self._A = A
        return self

    def loo_residuals(self, values: list) -> list:
        """Leave-one-out residuals f_i - s_{-i}(x_i) of interpolants of each value vector at
        the fitted points (same points, same system), by Rippa's formula: with c = A^-1 [f; 0],
        e_i = c_i / (A^-1)_ii. NaN where the system gives no such value."""
        n = len(self.X)
        try:
            with warnings.catch_warnings():  # ill-conditioned: the residuals are rough, no more
                warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
                inv = scipy.linalg.inv(self._A, check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            inv = np.linalg.pinv(self._A)
        diag = np.diag(inv)[:n]
        out = []
        with np.errstate(divide="ignore", invalid="ignore"):
            for f in values:
                e = (inv[:n, :n] @ np.asarray(f, dtype=float)) / diag
                out.append(np.where(np.isfinite(e), e, np.nan))
        return out

    # -- evaluation ------------------------------------------------------------
    def __call__(self, Xq: np.ndarray) -> np.ndarray:
        """The interpolant at points Xq (d,) -> float or (m, d) -> (m,)."""
        if self.lam is None:
            raise RuntimeError("RBF not fitted")
        Xq = np.asarray(Xq, dtype=float)
        single = Xq.ndim == 1
        Xq = np.atleast_2d(Xq)
        r = distances(Xq, self.X)
        s = self.predict_from(Xq, r * r * r)
        return s[0] if single else s

    def predict_from(self, Xq: np.ndarray, r3: np.ndarray) -> np.ndarray:
        """s at the rows of Xq (m, d) given r3 = distances(Xq, X)³ (m, n): RBFs fitted to the
        same points share r3 (a composite surrogate)."""
        t = len(self.tail_dims)
        s = r3 @ self.lam + self.beta[0] + Xq[:, self.tail_dims] @ self.beta[1:1 + t]
        if len(self.quad_i):
            s = s + _products(Xq, self.quad_i, self.quad_j) @ self.beta[1 + t:]
        return s

    def value_and_gradient(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """``(float(s(x)), gradient(x))`` at one point x (d,), as the two calls give them."""
        return float(self(x)), self.gradient(x)

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """Gradient at one point x (d,): d/dx ||x - x_k||^3 = 3 ||x - x_k|| (x - x_k)."""
        x = np.asarray(x, dtype=float)
        diff = x[None, :] - self.X
        return self.gradient_from(diff, np.sqrt(np.einsum("ij,ij->i", diff, diff)), x)

    def gradient_from(self, diff: np.ndarray, r: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Gradient at x given diff = x - X (n, d) and r = its row norms (shared as
        predict_from)."""
        g = 3.0 * (self.lam * r) @ diff
        t = len(self.tail_dims)
        g[self.tail_dims] += self.beta[1:1 + t]
        if len(self.quad_i):  # d/du_i (u_i - c)(u_j - c) = u_j - c, and the same for j
            c = self.beta[1 + t:]
            np.add.at(g, self.quad_i, c * (x[self.quad_j] - 0.5))
            np.add.at(g, self.quad_j, c * (x[self.quad_i] - 0.5))
        return g


def _products(X: np.ndarray, qi: np.ndarray, qj: np.ndarray) -> np.ndarray:
    """The quadratic tail's columns (u_i - 1/2)(u_j - 1/2) at the rows of X (unit box: centred
    for conditioning)."""
    return (X[:, qi] - 0.5) * (X[:, qj] - 0.5)
