"""The effective matrix of the Newmark steps, factorised once: A = UᵀU (banded Cholesky).

Dofs are numbered along the track, so A = K + 4/Δt² M + 2/Δt C is banded with a
half-bandwidth of a few dofs. Every step of every coupling solves with it in factored form:
one forward (U⁻ᵀ) and one backward (U⁻¹) banded triangular solve, with the low-rank terms of
the couplings (moving wheel contacts, sleepers off the ballast) applied between the two
through rows U⁻ᵀe_j (Sherman-Morrison, Woodbury). A row U⁻ᵀe_j is zero before j, so it is
solved from row j on only (exact, no truncation).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.linalg import blas, lapack

from .assembly import to_upper_banded


def forward_columns(chol: np.ndarray, dofs, out: np.ndarray) -> None:
    """Rows U⁻ᵀe_j into ``out`` (shape (len(dofs), n)), A = UᵀU factorised by ``dpbtrf``.

    Uᵀ is lower triangular, so U⁻ᵀe_j is zero before j and the solve starts at row j: the
    nearer j is to the end of the numbering, the cheaper (exact, no truncation)."""
    kd = chol.shape[0] - 1
    for row, j in zip(out, dofs):
        row[:j] = 0.0
        e = np.zeros(len(row) - j)
        e[0] = 1.0
        row[j:] = blas.dtbsv(kd, chol[:, j:], e, trans=1, overwrite_x=1)


class BandedFactor:
    """A = UᵀU of a symmetric positive definite banded sparse matrix (LAPACK ``dpbtrf``)."""

    def __init__(self, a: sp.spmatrix):
        ab, self.kd = to_upper_banded(a)
        chol, info = lapack.dpbtrf(ab, lower=0, overwrite_ab=1)
        if info != 0:
            raise np.linalg.LinAlgError(
                f"effective track matrix is not positive definite (dpbtrf info={info})")
        self.chol = np.asfortranarray(chol)
        self.n = self.chol.shape[1]

    def forward(self, b: np.ndarray) -> np.ndarray:
        """U⁻ᵀb, in place of b."""
        return blas.dtbsv(self.kd, self.chol, b, trans=1, overwrite_x=1)

    def backward(self, z: np.ndarray) -> np.ndarray:
        """U⁻¹z, in place of z."""
        return blas.dtbsv(self.kd, self.chol, z, overwrite_x=1)


class Rows:
    """Rows U⁻ᵀe_j of a :class:`BandedFactor`, solved once per dof and kept (``cache``) or
    solved each time asked (``cache=False``: a dof that is never met again)."""

    def __init__(self, factor: BandedFactor, cache: bool = True):
        self.factor = factor
        self.kept: dict[int, np.ndarray] | None = {} if cache else None

    def fill(self, out: np.ndarray, dofs) -> None:
        """Rows of ``dofs`` into ``out`` (shape (len(dofs), n))."""
        if self.kept is None:
            forward_columns(self.factor.chol, dofs, out)
            return
        for row, j in zip(out, dofs):
            got = self.kept.get(int(j))
            if got is None:
                forward_columns(self.factor.chol, [j], row[None, :])
                self.kept[int(j)] = row.copy()
            else:
                row[:] = got

    def get(self, dofs) -> np.ndarray:
        """Rows of ``dofs`` as a new array (len(dofs), n)."""
        out = np.empty((len(dofs), self.factor.n))
        self.fill(out, dofs)
        return out

    def forget_behind(self, lowest: int, highest: int, forward: bool) -> None:
        """Drop the kept rows behind the dofs [lowest, highest] still in use, for a travel
        towards higher dofs (``forward``) or lower ones: they are not met again."""
        for j in [j for j in self.kept if (j < lowest if forward else j > highest)]:
            del self.kept[j]
