"""Static rail deflection under a wheel load: how stiff a track form is (for checks and
benchmarks; the simulation itself starts from the coupled static equilibrium)."""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as sla

from .wheels import contact_vectors


def static_rail_deflection(track, load: float, positions) -> np.ndarray:
    """Rail deflection [m] under a static point ``load`` [N] placed at each of ``positions``."""
    _, idx, vals = contact_vectors(track, np.asarray(positions, dtype=float))
    lu = sla.splu(track.K.tocsc())
    out = np.empty(len(idx))
    for i, (dofs, n) in enumerate(zip(idx, vals)):
        f = np.zeros(track.n_dofs)
        np.add.at(f, dofs, load * n)
        out[i] = n @ lu.solve(f)[dofs]
    return out
