"""Finite elements and sparse assembly: Euler-Bernoulli beams, elastic foundations, springs.

Every element routine is vectorised over many elements at once. Dofs that are fixed carry
the index -1 and their rows and columns are dropped during assembly.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def beam_stiffness(ei, length) -> np.ndarray:
    """Euler-Bernoulli element stiffness, dofs (w1, th1, w2, th2); shape (n, 4, 4).

    ``ei`` and ``length`` are per element (arrays) or shared (scalars)."""
    ei, L = np.broadcast_arrays(np.asarray(ei, float), np.asarray(length, float))
    ei, L = ei.ravel(), L.ravel()
    one = np.ones_like(L)
    k = np.array([[12 * one, 6 * L, -12 * one, 6 * L],
                  [6 * L, 4 * L * L, -6 * L, 2 * L * L],
                  [-12 * one, -6 * L, 12 * one, -6 * L],
                  [6 * L, 2 * L * L, -6 * L, 4 * L * L]])      # (4, 4, n)
    return np.moveaxis(k, -1, 0) * (ei / L ** 3)[:, None, None]


def hermite_gram(length) -> np.ndarray:
    """∫ N Nᵀ dx over elements of the given lengths, shape (n, 4, 4): the consistent mass
    of unit mass per metre, and the consistent matrix k∫NNᵀ of a Winkler foundation of unit k."""
    L = np.atleast_1d(np.asarray(length, float))
    one = np.ones_like(L)
    g = np.array([[156 * one, 22 * L, 54 * one, -13 * L],
                  [22 * L, 4 * L * L, 13 * L, -3 * L * L],
                  [54 * one, 13 * L, 156 * one, -22 * L],
                  [-13 * L, -3 * L * L, -22 * L, 4 * L * L]])
    return np.moveaxis(g, -1, 0) * (L / 420.0)[:, None, None]


def hermite(xi, length) -> np.ndarray:
    """Hermite shape functions (Eq. A.8, standard form) at local coordinates xi in [0, L];
    shape (..., 4) for dofs (w1, th1, w2, th2)."""
    L = np.asarray(length, dtype=float)
    s = np.asarray(xi, dtype=float) / L
    s2, s3 = s * s, s * s * s
    return np.stack([1 - 3 * s2 + 2 * s3, L * (s - 2 * s2 + s3), 3 * s2 - 2 * s3, L * (s3 - s2)],
                    axis=-1)


class Assembler:
    """Collects element contributions as COO triplets; builds CSR matrices."""

    def __init__(self, n: int):
        self.n = n
        self._rows: list[np.ndarray] = []
        self._cols: list[np.ndarray] = []
        self._vals: list[np.ndarray] = []

    def add(self, dofs: np.ndarray, mats: np.ndarray) -> None:
        """Add element matrices ``mats`` (n_el, k, k) at dof indices ``dofs`` (n_el, k)."""
        dofs = np.asarray(dofs)
        if dofs.size == 0:
            return
        k = dofs.shape[1]
        rows = np.repeat(dofs, k, axis=1).ravel()
        cols = np.tile(dofs, (1, k)).ravel()
        vals = np.broadcast_to(mats, (dofs.shape[0], k, k)).reshape(-1)
        keep = (rows >= 0) & (cols >= 0)
        self._rows.append(rows[keep])
        self._cols.append(cols[keep])
        self._vals.append(vals[keep])

    def add_relative(self, dofs_a: np.ndarray, dofs_b: np.ndarray, mats: np.ndarray) -> None:
        """A layer between two sets of dofs acting on (u_a - u_b): [[m, -m], [-m, m]]."""
        m = np.broadcast_to(mats, (len(dofs_a),) + mats.shape[-2:])
        top = np.concatenate([m, -m], axis=2)
        full = np.concatenate([top, -top], axis=1)
        self.add(np.hstack([dofs_a, dofs_b]), full)

    def add_diagonal(self, dofs: np.ndarray, values: np.ndarray) -> None:
        dofs = np.asarray(dofs).reshape(-1, 1)
        self.add(dofs, np.asarray(values, dtype=float).reshape(-1, 1, 1))

    def build(self) -> sp.csr_matrix:
        if not self._rows:
            return sp.csr_matrix((self.n, self.n))
        rows = np.concatenate(self._rows)
        cols = np.concatenate(self._cols)
        vals = np.concatenate(self._vals)
        return sp.coo_matrix((vals, (rows, cols)), shape=(self.n, self.n)).tocsr()


def to_upper_banded(a: sp.spmatrix) -> tuple[np.ndarray, int]:
    """Upper band storage for LAPACK ?pbtrf: ab[kd + i - j, j] = A[i, j] for i <= j."""
    coo = sp.triu(a).tocoo()
    kd = int((coo.col - coo.row).max()) if coo.nnz else 0
    ab = np.zeros((kd + 1, a.shape[0]))
    ab[kd + coo.row - coo.col, coo.col] = coo.data
    return ab, kd
