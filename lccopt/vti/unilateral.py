"""Sleepers that can lift off the ballast: unilateral supports with voids, in Newmark steps.

A ballast sleeper's support (spring k_b and damper c_b) acts only while the sleeper touches the
ballast. Displacements u are those of the linear model: downward positive, measured from the
static equilibrium of the void-free track under its own weight, in which sleeper i rests
``rest_i`` below its weightless position. The ballast surface under sleeper i lies ``gap_i``
below the as-built level (the sleeper's weightless position), so with U_i = u_i + rest_i the
sleeper's absolute displacement

    penetration  p_i = u_i + rest_i - gap_i,   in contact iff p_i >= 0,
    support force F_i = k_b p_i + c_b u̇_i in contact, 0 over the void.

Relative to the linear model (spring k_b u_i, damper c_b u̇_i) that is, per sleeper, a
constant load k_b gap_i in contact, and out of contact the spring and damper removed and the
sleeper's static support force k_b rest_i (its weight share) set free. A sleeper whose gap
exceeds what the track's own weight closes hangs from the rail through its pad.

The effective matrix A = K + a0 M + a1 C (every support in) is factorised once, A = UᵀU, as in
:mod:`lccopt.vti.newmark`. A sleeper over a void is a rank-one term -(k_b + a1 c_b) e eᵀ; with
the k moving wheel contacts that makes one Woodbury (capacitance) system of size k + m for m
sleepers off the ballast, in the factored form with rows U⁻ᵀe_j (cached per sleeper). Each step
starts from the previous step's contact set and iterates (active set) until every sleeper's
state agrees with its penetration, flipping every disagreeing sleeper at once. The damper makes
a consistent set not always exist (it can pull up a sleeper whose penetration says "in"); after
``max_iterations`` passes the sleepers still changing keep their state of the step before, and
the step is counted in ``History.info['unsettled']``. Where no sleeper is off the ballast a
step costs what
:func:`~lccopt.vti.newmark.integrate_wheels` costs plus a gather of the sleepers'
displacements: no refactorisation, ever.

Discrete energy balance (THEORY.md's, extended): with the support forces' trapezoidal work
½(F_n + F_{n+1})·Δu the balance is exact; the spring's energy ½ k_b ⟨p⟩² differs from that
work
only in a step where the sleeper switches, by ½ k_b p_n p_{n+1} (p_n, p_{n+1} on either side of
zero), which shrinks as Δt² (tests/vti/test_voids_energy.py).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import scipy.sparse as sp
from scipy.linalg import blas, lapack
from scipy.sparse.linalg import spsolve

from .assembly import to_upper_banded
from .newmark import History, _check_on_rail, contact_vectors, forward_columns

GRAVITY = 9.81


@dataclass(frozen=True)
class SleeperSupports:
    """Ballast sleepers whose support acts only in contact (arrays of one value per sleeper)."""
    dof: np.ndarray          # the sleeper's dof in the track model
    x: np.ndarray            # position along the track [m]
    stiffness: np.ndarray    # k_b [N/m]
    damping: np.ndarray      # c_b [N s/m]
    rest: np.ndarray         # deflection under the track's own weight, void-free track [m]
    gap: np.ndarray          # lowering of the ballast surface below the as-built level [m]

    def with_gaps(self, gap) -> "SleeperSupports":
        """The same sleepers over a ballast surface lowered by ``gap`` [m] (>= 0)."""
        gap = np.asarray(gap, dtype=float)
        if gap.shape != self.dof.shape or np.any(gap < 0) or not np.all(np.isfinite(gap)):
            raise ValueError("gaps: one finite value >= 0 per sleeper")
        return replace(self, gap=gap.copy())

    def penetration(self, u: np.ndarray) -> np.ndarray:
        """p = u + rest - gap at each sleeper for track displacements u [m]."""
        return u[self.dof] + self.rest - self.gap

    def free_loads(self, contact: np.ndarray) -> np.ndarray:
        """Constant load per sleeper in u-coordinates: k gap in contact, k rest over a void."""
        return self.stiffness * np.where(contact, self.gap, self.rest)


def self_weight_deflection(track, gravity: float = GRAVITY) -> np.ndarray:
    """Static displacement [m] of every dof under the track's own weight (void-free track).

    The weight is g M t with t = 1 on translational dofs, 0 on rotations: for the Hermite
    beams that is the consistent load of the mass per metre (the translational shape functions
    of an element sum to one)."""
    t = np.ones(track.K.shape[0])
    t[np.asarray(track.info["rotation_dofs"], dtype=int)] = 0.0
    return spsolve(track.K.tocsc(), gravity * (track.M @ t))


def sleeper_supports(track, sleepers=None, gravity: float = GRAVITY) -> SleeperSupports:
    """Unilateral supports for ballast sleepers of a built track, no voids yet.

    sleepers: indices into the track's sleepers (entry sleepers nearest the interface first,
    then exit sleepers; ``track.sleeper_x``); None for all of them."""
    idx = np.arange(len(track.sleeper_dof)) if sleepers is None else np.asarray(sleepers, int)
    dof = np.asarray(track.sleeper_dof)[idx]
    rest = self_weight_deflection(track, gravity)[dof]
    return SleeperSupports(dof=dof, x=np.asarray(track.sleeper_x, float)[idx],
                           stiffness=np.asarray(track.support_stiffness, float)[idx],
                           damping=np.asarray(track.support_damping, float)[idx],
                           rest=rest, gap=np.zeros(len(idx)))


def static_equilibrium(Kg, rhs: np.ndarray, supports: SleeperSupports,
                       max_iterations: int = 50) -> tuple[np.ndarray, np.ndarray]:
    """Solve Kg u = rhs with the unilateral sleepers (active set); return (u, contact).

    Kg: a stiffness (track, or track and vehicle bordered) whose leading dofs are the track's,
    with every support in. Each pass solves with the current contact set and flips every
    sleeper whose penetration disagrees with it."""
    Kg = sp.csc_matrix(Kg)
    dof, k = supports.dof, supports.stiffness
    contact = supports.gap <= supports.rest            # where the track's weight closes it
    for _ in range(max_iterations):
        out = ~contact
        a = Kg - sp.csc_matrix((k[out], (dof[out], dof[out])), shape=Kg.shape)
        b = np.array(rhs, dtype=float)
        np.add.at(b, dof, supports.free_loads(contact))
        u = spsolve(a.tocsc(), b)
        now = supports.penetration(u) >= 0.0
        if np.array_equal(now, contact):
            return u, contact
        contact = now
    raise RuntimeError(f"static contact of the sleepers did not settle in {max_iterations} passes")


def rest_state(track, supports: SleeperSupports) -> np.ndarray:
    """Track displacements u [m] at rest (own weight only) over the voids of ``supports``:
    the unloaded track geometry relative to the as-built one."""
    return static_equilibrium(track.K, np.zeros(track.K.shape[0]), supports)[0]


class _Wheels:
    """The moving contacts: a vehicle's wheels through their Hertz springs (eliminated), or one
    constant moving force. Holds what a step needs: Κ, c0 and the vehicle's state update."""

    def __init__(self, track, vehicle, load, dt, speed, x_start, n_steps, irregularity):
        a0, a1, a2 = 4.0 / dt ** 2, 2.0 / dt, 4.0 / dt
        steps = n_steps + 1
        lead = x_start + speed * dt * np.arange(steps)
        _check_on_rail(track, lead)
        self.vehicle, self.lead = vehicle, lead
        if vehicle is None:
            offsets, self.k = np.zeros(1), 1
        else:
            offsets = np.asarray(vehicle.wheel_offsets, dtype=float)
            self.k = len(vehicle.wheel_dofs)
        sgn = -1.0 if speed < 0 else 1.0
        pos = lead[:, None] - sgn * offsets[None, :]
        k = self.k
        elem, idx, vals = contact_vectors(track, pos.ravel())
        self.elem, self.idx, self.vals = (elem.reshape(steps, k), idx.reshape(steps, k, 4),
                                          vals.reshape(steps, k, 4))
        off = (pos < track.node_x[0] - 1e-9) | (pos > track.node_x[-1] + 1e-9)
        self.vals[off], self.idx[off], self.elem[off] = 0.0, 0, -1
        self.pos = pos
        self.r = (np.array([irregularity(p) for p in pos.ravel()], float).reshape(steps, k)
                  if irregularity is not None else np.zeros((steps, k)))
        if vehicle is None:
            self.load = float(load)
            self.kap = np.zeros((1, 1))
            return
        Mv, Cv, Kv, fv = (np.asarray(a, float) for a in (vehicle.M, vehicle.C, vehicle.K,
                                                           vehicle.weight_load))
        nv, W, kw = Mv.shape[0], np.asarray(vehicle.wheel_dofs, int), vehicle.contact_stiffness
        self.Mv, self.Kv, self.fv, self.W, self.kw, self.nv = Mv, Kv, fv, W, kw, nv
        B = Kv + a0 * Mv + a1 * Cv
        B[W, W] += kw
        Binv = np.linalg.inv(B)
        self.kap = kw * (np.eye(k) - kw * Binv[np.ix_(W, W)])
        # t = [z, zd, zdd, 1, r (k), δ (k)]: c0 = Crow t, s' = G t (integrate_wheels' scheme)
        kb = kw * Binv[:, W]
        Q = np.hstack([Binv @ (a0 * Mv + a1 * Cv), Binv @ (a2 * Mv + Cv), Binv @ Mv,
                       (Binv @ fv)[:, None], kb, np.zeros((nv, k))])
        Qd = Q.copy()
        Qd[:, 3 * nv + 1 + k:] = kb
        I, O = np.eye(nv), np.zeros((nv, nv))
        Rv = np.block([[O, O, O, I], [-a1 * I, -I, O, a1 * I], [-a0 * I, -a2 * I, -I, a0 * I]])
        self.G = Rv[:, 3 * nv:] @ Qd
        self.G[:, :3 * nv] += Rv[:, :3 * nv]
        sel_r = np.zeros((k, Q.shape[1]))
        sel_r[:, 3 * nv + 1:3 * nv + 1 + k] = np.eye(k)
        self.crow = kw * (Q[W] - sel_r)

    def static_system(self, K, n):
        """(Kg, rhs): the coupled static system with every wheel at its start position."""
        k, idx, vals, r0 = self.k, self.idx[0], self.vals[0], self.r[0]
        Nm = sp.csr_matrix((vals.ravel(), (idx.ravel(), np.repeat(np.arange(k), 4))), shape=(n, k))
        if self.vehicle is None:
            return K, Nm @ np.full(k, self.load)
        nv, W, kw = self.nv, self.W, self.kw
        Wm = sp.csr_matrix((np.ones(k), (W, np.arange(k))), shape=(nv, k))
        Kg = sp.bmat([[K + kw * (Nm @ Nm.T), -kw * (Nm @ Wm.T)],
                      [-kw * (Wm @ Nm.T), sp.csr_matrix(self.Kv) + kw * (Wm @ Wm.T)]], format="csc")
        rhs = np.zeros(n + nv)
        np.add.at(rhs, idx.ravel(), -kw * (r0[:, None] * vals).ravel())
        rhs[n:] = self.fv
        rhs[n + W] += kw * r0
        return Kg, rhs

    def start(self, z):
        """Vehicle state vector t from the static displacements z (None: a moving force)."""
        if self.vehicle is None:
            return None
        nv, k = self.nv, self.k
        return np.concatenate([z, np.zeros(2 * nv), [1.0], np.zeros(2 * k)])

    def c0(self, t, s):
        if self.vehicle is None:
            return np.full(1, self.load)
        nv, k = self.nv, self.k
        t[3 * nv + 1:3 * nv + 1 + k] = self.r[s]
        return self.crow @ t

    def advance(self, t, s, delta):
        """Vehicle state after the step with rail displacements δ; the contact forces."""
        if self.vehicle is None:
            return np.full(1, self.load)
        nv, k = self.nv, self.k
        t[3 * nv + 1 + k:] = delta
        t[:3 * nv] = self.G @ t
        return self.kw * (t[self.W] - delta - self.r[s])


class _Rows:
    """Rows U⁻ᵀe_j (A = UᵀU), cached by dof."""

    def __init__(self, chol):
        self.chol, self.n, self.cache = chol, chol.shape[1], {}

    def get(self, dofs) -> np.ndarray:
        out = np.empty((len(dofs), self.n))
        for row, j in zip(out, dofs):
            got = self.cache.get(int(j))
            if got is None:
                forward_columns(self.chol, [j], row[None, :])
                self.cache[int(j)] = row.copy()
            else:
                row[:] = got
        return out


def integrate_unilateral(track, dt: float, speed: float, x_start: float, n_steps: int, *,
                         supports: SleeperSupports, vehicle=None, load: float = 0.0,
                         irregularity: Callable[[float], float] | None = None,
                         record_dofs: np.ndarray | None = None, on_step: Callable | None = None,
                         max_iterations: int = 8) -> History:
    """:func:`~lccopt.vti.newmark.integrate` with unilateral sleeper supports (module docstring).

    vehicle: any vehicle (its k wheels are k moving contacts), or None for one constant moving
    force ``load`` [N]. Starts from the static equilibrium with the wheels in place and the
    voids of ``supports``. on_step(n, u, v, a, z, zd, zdd, idx, vals, force, contact): optional
    hook after each step (tests); z, zd, zdd are None for a moving force.

    Returns a History with ``support_force`` and ``support_contact`` (one column per sleeper of
    ``supports``) and ``info`` {"iterations": most active-set passes of a step, "unsettled":
    steps whose contact set did not settle, "switches": contact changes}."""
    M, C, K = track.M.tocsr(), track.C.tocsr(), track.K.tocsr()
    n = K.shape[0]
    rec_dofs = np.asarray(record_dofs if record_dofs is not None else [], dtype=int)
    a0, a1, a2 = 4.0 / dt ** 2, 2.0 / dt, 4.0 / dt
    wh = _Wheels(track, vehicle, load, dt, speed, x_start, n_steps, irregularity)
    k, steps = wh.k, n_steps + 1
    sup = supports
    dof, kb, cb = sup.dof, sup.stiffness, sup.damping

    Kg, rhs0 = wh.static_system(K, n)
    sol, contact = static_equilibrium(Kg, rhs0, sup)
    u0 = sol[:n]
    t = wh.start(sol[n:].copy())

    ab, kd = to_upper_banded(K + a0 * M + a1 * C)
    chol, info = lapack.dpbtrf(ab, lower=0, overwrite_ab=1)
    if info != 0:
        raise np.linalg.LinAlgError(
            f"effective track matrix is not positive definite (dpbtrf info={info})")
    chol = np.asfortranarray(chol)
    MC = sp.hstack([M, C]).tocsr()
    S = np.zeros((3, n))                  # rows p, q, u as in newmark.integrate
    S_next = np.zeros((3, n))
    S[0], S[1], S[2] = a0 * u0, a1 * u0, u0
    R = np.array([[-1.0, -a2, 4.0 * a0], [0.0, -1.0, 2.0 * a1]])

    force = np.zeros((steps, k))
    rail = np.zeros((steps, k))
    veh = np.zeros((steps, wh.nv if vehicle is not None else 0))
    rec = np.zeros((steps, 2, len(rec_dofs)))
    sup_u = np.zeros((steps, len(dof)))           # u and q = a1 u + v at the sleepers
    sup_q = np.zeros((steps, len(dof)))
    scontact = np.zeros((steps, len(dof)), dtype=bool)
    low = sup.gap - sup.rest                         # in contact iff u >= gap - rest
    delta = np.einsum("ij,ij->i", wh.vals[0], u0[wh.idx[0]])
    rail[0] = delta
    force[0] = (np.full(k, wh.load) if vehicle is None
                else wh.kw * (t[wh.W] - delta - wh.r[0]))
    if vehicle is not None:
        veh[0] = t[:wh.nv]
    rec[0, 0], rec[0, 1] = a1 * u0[rec_dofs], u0[rec_dofs]
    sup_u[0], sup_q[0] = u0[dof], a1 * u0[dof]
    scontact[0] = contact

    rows = _Rows(chol)
    wheel_rows = {}                       # wheel rows by dof, dropped behind the last wheel
    scols = np.zeros((k, 4, n))
    Sm = np.zeros((k, n))
    prev = np.full(k, -10)
    free = np.zeros(n)                    # constant support loads of the current contact set
    np.add.at(free, dof, sup.free_loads(contact))
    stats = {"iterations": 0, "unsettled": 0, "switches": 0}
    out_set = _OutSet(rows, sup, contact, a1)
    tbsv, dot = blas.dtbsv, np.dot

    def fill(dst, dofs):
        for r, j in zip(dst, dofs):
            got = wheel_rows.get(int(j))
            if got is None:
                forward_columns(chol, [j], r[None, :])
                wheel_rows[int(j)] = r.copy()
            else:
                r[:] = got

    for s in range(1, steps):
        idx, vals = wh.idx[s], wh.vals[s]
        for i in range(k):                               # wheel rows, as integrate_wheels
            e = wh.elem[s, i]
            if e < 0:
                Sm[i] = 0.0
                continue
            if e != prev[i]:
                if e == prev[i] + 1:
                    scols[i, :2] = scols[i, 2:]
                    fill(scols[i, 2:], idx[i, 2:])
                elif e == prev[i] - 1:
                    scols[i, 2:] = scols[i, :2]
                    fill(scols[i, :2], idx[i, :2])
                else:
                    fill(scols[i], idx[i])
                prev[i] = e
            dot(vals[i], scols[i], out=Sm[i])
        if s % 64 == 0 and k > 1:
            _drop_rows_behind(wheel_rows, wh.elem[s], idx, vals, speed)
        rhs = MC @ S[:2].reshape(-1) + free
        q_out = out_set.damper_loads(S[1])
        if q_out is not None:
            rhs[out_set.dofs] -= q_out
        y = tbsv(kd, chol, rhs, trans=1, overwrite_x=1)
        c0 = wh.c0(t, s)
        start = out_set.contact.copy()
        for it in range(1, max_iterations + 2):
            delta, u_new = out_set.solve(y, Sm, c0, wh.kap, chol, kd)
            pu = u_new[dof]
            now = pu >= low
            changed = now ^ out_set.contact
            if not changed.any():
                break
            if it == max_iterations + 1:           # the step's last solve: accepted as it is
                stats["unsettled"] += 1
                break
            if it == max_iterations:
                # no consistent set (a damper can pull a sleeper that its penetration would
                # release): the sleepers still changing keep their state of the step before
                now = np.where(changed, start, out_set.contact)
                changed = now ^ out_set.contact
                if not changed.any():
                    stats["unsettled"] += 1
                    break
            # move the changed sleepers' constant loads (and dampers) into y
            dq = out_set.switch(now, changed, S[1])
            y = y + dot(dq, rows.get(dof[changed]))
            free[dof[changed]] = sup.free_loads(now)[changed]
            stats["switches"] += int(changed.sum())
        stats["iterations"] = max(stats["iterations"], it)
        force[s] = wh.advance(t, s, delta)
        if vehicle is not None:
            veh[s] = t[:wh.nv]
        S[2] = u_new
        dot(R, S, out=S_next[:2])
        S_next[2] = S[2]
        S, S_next = S_next, S
        rail[s] = delta
        rec[s] = S[1:, rec_dofs]
        sup_q[s] = S[1, dof]
        sup_u[s] = pu
        scontact[s] = out_set.contact
        if on_step is not None:
            u = S[2]
            v = S[1] - a1 * u
            acc = S[0] - a0 * u - a2 * v
            zs = ((None,) * 3 if vehicle is None else
                  (t[:wh.nv].copy(), t[wh.nv:2 * wh.nv].copy(), t[2 * wh.nv:3 * wh.nv].copy()))
            on_step(s, u, v, acc, *zs, idx, vals, force[s], out_set.contact.copy())

    # support forces from the recorded sleeper displacements and velocities
    sforce = np.where(scontact, kb * (sup_u + sup.rest - sup.gap) + cb * (sup_q - a1 * sup_u), 0.0)
    rec_u = rec[:, 1]
    rec_v = rec[:, 0] - a1 * rec_u
    return History(dt * np.arange(steps), wh.lead,
                   force[:, 0].copy(), rail[:, 0].copy(), veh, rec_u, rec_v, wh.pos, force, rail,
                   support_force=sforce, support_contact=scontact.astype(np.int8), info=stats)


def _drop_rows_behind(rows: dict, elem, idx, vals, speed) -> None:
    """Forget cached wheel rows behind the last wheel on the rail (they are not met again)."""
    on = elem >= 0
    if not on.any():
        return
    held = idx[on][vals[on] != 0.0]
    if held.size:
        lo, hi = int(held.min()), int(held.max())
        for j in [j for j in rows if (j < lo if speed >= 0 else j > hi)]:
            del rows[j]


class _OutSet:
    """The sleepers off the ballast in a step: their rows U⁻ᵀe_j, the Woodbury terms, the solve.

    With D = diag(k_b + a1 c_b) over the m sleepers off the ballast, E their rows and S the
    wheels' rows, the step's displacements are u' = U⁻¹(y + Sᵀc + Eᵀ D σ) with the wheel
    forces
    c = c0 - Κ δ, where δ = S(...) and σ = E(...) solve

        [I + S Sᵀ Κ    -S Eᵀ D] [δ]   [S y + S Sᵀ c0]
        [E Sᵀ Κ     I - E Eᵀ D] [σ] = [E y + E Sᵀ c0].
    """

    def __init__(self, rows: _Rows, sup: SleeperSupports, contact, a1):
        self.rows, self.sup, self.a1 = rows, sup, a1
        self.contact = np.array(contact, dtype=bool)
        self._refresh()

    def _refresh(self):
        out = ~self.contact
        self.dofs = self.sup.dof[out]
        self.c_out = self.sup.damping[out]
        self.d = self.sup.stiffness[out] + self.a1 * self.c_out
        self.E = self.rows.get(self.dofs) if out.any() else np.zeros((0, self.rows.n))
        self.GEE = self.E @ self.E.T

    def damper_loads(self, q):
        """c_b q at the sleepers off the ballast (their dampers leave the right-hand side)."""
        return self.c_out * q[self.dofs] if len(self.dofs) else None

    def switch(self, now, changed, q) -> np.ndarray:
        """Update the contact set; return the change of the right-hand side at the changed
        sleepers (constant loads k gap <-> k rest, and the damper term c_b q)."""
        sup = self.sup
        i = np.flatnonzero(changed)
        goes_out = ~now[i]
        dload = sup.free_loads(now)[i] - sup.free_loads(self.contact)[i]
        dq = dload + np.where(goes_out, -1.0, 1.0) * sup.damping[i] * q[sup.dof[i]]
        self.contact = now.copy()
        self._refresh()
        return dq

    def solve(self, y, Sm, c0, kap, chol, kd):
        """(δ, u') of the step for the current contact set."""
        k, m = Sm.shape[0], len(self.dofs)
        gN = Sm @ y
        GNN = Sm @ Sm.T
        if m == 0:
            if k == 1:                     # Sherman-Morrison, as newmark.integrate
                g2 = GNN[0, 0]
                delta = (gN + g2 * c0) / (1.0 + kap[0, 0] * g2)
            else:
                delta = np.linalg.solve(np.eye(k) + GNN @ kap, gN + GNN @ c0)
            z = y + (c0 - kap @ delta) @ Sm
            return delta, blas.dtbsv(kd, chol, z, overwrite_x=1)
        E, D = self.E, self.d
        gE = E @ y
        GNE = Sm @ E.T
        A = np.block([[np.eye(k) + GNN @ kap, -GNE * D],
                      [GNE.T @ kap, np.eye(m) - self.GEE * D]])
        b = np.concatenate([gN + GNN @ c0, gE + GNE.T @ c0])
        w = np.linalg.solve(A, b)
        delta, sigma = w[:k], w[k:]
        z = y + (c0 - kap @ delta) @ Sm + (D * sigma) @ E
        return delta, blas.dtbsv(kd, chol, z, overwrite_x=1)
