"""Statics of a track with unilateral sleeper supports, in the coordinates of those supports.

The settlement iteration needs, many times between two dynamic simulations, the sleeper loads
a settled track carries and how they change when a sleeper settles (a sleeper that settles
more sheds load to its neighbours). Both come from the statics of the track with its m
unilateral supports (``lccopt/vti/unilateral.py``'s convention: displacements u from the
void-free track's state under its own weight, gap g_j, rest deflection r_j, contact iff
u_j + r_j - g_j >= 0). With K the track's stiffness (every support in), factorised once, and
G = (K⁻¹)_ss its flexibility at the supports' dofs, a static state with the loads f is

    (I - G K_out) u_s = a + G K (c∘g + out∘r),     a = (K⁻¹ f)_s,

K = diag(k_b), c the contact set, out = not c (a support off the ballast loses its spring and
sets its weight share k_b r_j free). Only the few supports off the ballast make the system
differ from the identity, so each state costs a small dense solve per case (Woodbury),
all cases' at once.
The support force of a sleeper in contact is F_j = k_j (u_j + r_j - g_j).

Quasi-static wheel cases: the vehicle's static wheel loads, wheel w above sleeper i (the
moment the sleeper carries that axle's peak). The dynamic simulation corrects them
(:mod:`lccopt.degradation.iteration`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import lapack

from ..vti.assembly import to_upper_banded
from ..vti.unilateral import SleeperSupports
from ..vti.wheels import contact_vectors


@dataclass(frozen=True)
class WheelCases:
    """Static wheel-load cases: wheel w above settling sleeper i for every (w, i).

    a: (wheels * sleepers, m) support-dof displacements of the void-free track under the
    wheel loads [m], case index w * sleepers + i; own: (cases,) the support whose load the
    case measures; shape: (wheels, sleepers)."""
    a: np.ndarray
    own: np.ndarray
    shape: tuple


class ZoneStatics:
    """Static states of ``track`` over the unilateral ``supports`` (module docstring).

    level_dofs: track dofs whose displacement at rest is reported; or level_x: positions [m]
    of the rail whose deflection at rest is reported (the rail profile, by the elements'
    Hermite shape functions)."""

    def __init__(self, track, supports: SleeperSupports, level_dofs=(), level_x=None):
        ab, self._kd = to_upper_banded(track.K.tocsr())
        chol, info = lapack.dpbtrf(ab, lower=0, overwrite_ab=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"track stiffness is not positive definite ({info})")
        self._chol = chol
        self._track = track
        self.supports = supports
        self.m = len(supports.dof)
        cols = np.zeros((track.K.shape[0], self.m), order="F")
        cols[supports.dof, np.arange(self.m)] = 1.0
        x = self._solve(cols)
        self.G = x[supports.dof].copy()
        if level_x is None:
            self._level = x[np.asarray(level_dofs, dtype=int)].copy()
        else:
            _, idx, vals = contact_vectors(track, np.asarray(level_x, dtype=float))
            self._level = np.einsum("pk,pkm->pm", vals, x[idx])

    def _solve(self, rhs: np.ndarray) -> np.ndarray:
        sol, info = lapack.dpbtrs(self._chol, rhs, lower=0)
        if info != 0:
            raise np.linalg.LinAlgError(f"dpbtrs info={info}")
        return sol

    def wheel_cases(self, sleeper_x, offsets, loads, direction: float = 1.0) -> WheelCases:
        """Cases of a vehicle with wheels ``offsets`` [m] behind the leading one (running
        towards ``direction`` = +1 or -1) and static wheel loads ``loads`` [N]: wheel w above
        each of the sleepers at ``sleeper_x`` (the first len(sleeper_x) supports)."""
        offsets = np.asarray(offsets, dtype=float)
        loads = np.broadcast_to(np.asarray(loads, dtype=float), offsets.shape)
        xs = np.asarray(sleeper_x, dtype=float)
        k, n = len(offsets), len(xs)
        sgn = -1.0 if direction < 0 else 1.0
        lead = xs[None, :] + sgn * offsets[:, None]                      # (wheels, sleepers)
        pos = lead[..., None] - sgn * offsets[None, None, :]            # (.., .., wheel)
        on = (pos >= self._track.node_x[0]) & (pos <= self._track.node_x[-1])
        _, idx, vals = contact_vectors(self._track, np.clip(pos, self._track.node_x[0],
                                                            self._track.node_x[-1]).ravel())
        vals = vals.reshape(k * n, k, 4) * (loads[None, :, None] * on.reshape(k * n, k)[..., None])
        rhs = np.zeros((self._track.K.shape[0], k * n), order="F")
        np.add.at(rhs, (idx.reshape(k * n, k * 4), np.arange(k * n)[:, None]),
                  vals.reshape(k * n, k * 4))
        a = self._solve(rhs)[self.supports.dof].T.copy()
        own = np.tile(np.arange(n), k)
        return WheelCases(a, own, (k, n))

    def equilibrium(self, gap: np.ndarray, a: np.ndarray, contact: np.ndarray | None = None,
                    max_iterations: int = 50) -> tuple[np.ndarray, np.ndarray]:
        """Support-dof displacements u (cases, m) and contact sets (cases, m) of the static
        states with support displacements ``a`` (cases, m) of the loads, over ``gap`` (m,).
        contact: a starting guess (active set), e.g. the last call's."""
        rest = self.supports.rest
        c = np.ones(a.shape, dtype=bool) if contact is None else np.array(contact, dtype=bool)
        for _ in range(max_iterations):
            u = self._states(gap, a, c)
            now = u + rest - gap >= 0.0
            if np.array_equal(now, c):
                return u, c
            c = now
        raise RuntimeError(f"static contact of the sleepers did not settle in "
                           f"{max_iterations} passes")

    def _states(self, gap, a, contact):
        kb, rest, G = self.supports.stiffness, self.supports.rest, self.G
        u = a + (kb * np.where(contact, gap, rest)) @ G
        off = _OffBallast(~contact, G, kb)
        if off.rows.size:
            uo = off.solve(np.where(off.mask, u[off.rows[:, None], off.idx], 0.0))
            u[off.rows] += np.einsum("rk,rkm->rm", uo * off.kb, G[off.idx])
        return u

    def peak_forces(self, gap, cases: WheelCases, contact=None):
        """(forces (wheels, sleepers) [N], contact (cases, m)): each case's own support force."""
        u, c = self.equilibrium(gap, cases.a, contact)
        i = cases.own
        rows = np.arange(len(i))
        sup = self.supports
        p = u[rows, i] + sup.rest[i] - gap[i]
        f = np.where(c[rows, i], sup.stiffness[i] * p, 0.0)
        return f.reshape(cases.shape), c

    def peak_jacobian(self, cases: WheelCases, contact: np.ndarray) -> np.ndarray:
        """d(own support force)/d(gap) (wheels, sleepers, m) at the contact sets ``contact``:
        a sleeper that settles sheds load (diagonal < 0) to those around it (> 0)."""
        kb, G = self.supports.stiffness, self.G
        i = cases.own
        jac = G[i] * (kb * contact)              # e_iᵀ(I - G K_out)⁻¹ G K_c where no voids
        off = _OffBallast(~contact, G, kb)
        if off.rows.size:
            own = i[off.rows]
            z = off.solve(off.kb * G[off.idx, own[:, None]], transposed=True)
            jac[off.rows] = ((G[own] + np.einsum("rk,rkm->rm", z, G[off.idx]))
                             * (kb * contact[off.rows]))
        rows = np.arange(len(i))
        jac[rows, i] -= 1.0
        jac *= (kb[i] * contact[rows, i])[:, None]
        return jac.reshape(*cases.shape, self.m)

    def rest(self, gap: np.ndarray, contact=None):
        """The track at rest (own weight) over ``gap``: (void (m,) [m] under each support,
        level (len(level_dofs) or len(level_x),) [m] displacement of the level dofs or the
        rail at level_x, contact (m,))."""
        sup = self.supports
        u, c = self.equilibrium(gap, np.zeros((1, self.m)),
                                None if contact is None else contact[None])
        u, c = u[0], c[0]
        loads = sup.stiffness * np.where(c, gap, sup.rest + u)
        return np.maximum(gap - sup.rest - u, 0.0), self._level @ loads, c


class _OffBallast:
    """The cases with supports off the ballast, each with its own small system
    I - G_oo K_o (o: its supports off the ballast), solved all at once: the systems are padded
    to the largest o with identity rows and columns, which leave the others' solutions as
    they are."""

    def __init__(self, out: np.ndarray, G: np.ndarray, kb: np.ndarray):
        self.rows = np.flatnonzero(out.any(axis=1))
        counts = out[self.rows].sum(axis=1)
        k = int(counts.max(initial=0))
        self.mask = np.arange(k)[None, :] < counts[:, None]            # (cases, k)
        # each row's supports off the ballast first, in order; the padding points at 0
        order = np.argsort(~out[self.rows], axis=1, kind="stable")[:, :k]
        self.idx = np.where(self.mask, order, 0)
        self.kb = np.where(self.mask, kb[self.idx], 0.0)
        B = -G[self.idx[:, :, None], self.idx[:, None, :]] * self.kb[:, None, :]
        B[~(self.mask[:, :, None] & self.mask[:, None, :])] = 0.0
        B[:, np.arange(k), np.arange(k)] += 1.0
        self.B = B

    def solve(self, rhs: np.ndarray, transposed: bool = False) -> np.ndarray:
        """Per case, B x = rhs (or Bᵀ x = rhs); rhs (cases, k), zero in the padding."""
        B = np.swapaxes(self.B, 1, 2) if transposed else self.B
        return np.linalg.solve(B, rhs[..., None])[..., 0]
