"""Newmark average-acceleration integration of the track with a moving wheel-rail contact.

The coupled system of Eq. (3) is

    [A_t + k_w N Nᵀ    -k_w N e3ᵀ      ] [u]   [b_t - k_w N r]
    [-k_w e3 Nᵀ        A_v + k_w e3 e3ᵀ] [z] = [b_v + k_w e3 r]

with A = K + 4/dt² M + 2/dt C for track (t) and vehicle (v), N the Hermite vector of the
wheel position and r the rail irregularity (dip positive). Eliminating the 3 vehicle dofs
leaves the constant banded track matrix A_t plus one moving rank-one term, so A_t = UᵀU is
factorised once (banded Cholesky) and each step is one sparse product for the right-hand
side and one forward and one backward banded triangular solve, with Sherman-Morrison applied
between them (rows U⁻ᵀe_j of the wheel's element are solved once per element). The solution
is the same as solving the coupled system outright, to round-off.

A vehicle with k wheels on the rail (bogie, half car) gives k moving rank-one terms, applied
together in the same factored form by a k x k Woodbury (capacitance) solve per step
(:func:`integrate_wheels`); the vehicle may run either way (negative speed). The leading
wheel must stay on the modelled rail for the whole run (checked; the case's window is chosen
so); a trailing wheel beyond a rail end rests on a rigid continuation of the rail.

Time histories are recorded per step. No flush of tiny values: in the reference track the
smallest nonzero state value is ~1e-68, far above the denormal range; denormals appear only
where a track end lies several hundred metres from the wheel (the exponential decay of the
deflection), a band of a few hundred dofs that every banded solve regenerates, so a periodic
flush could not remove them anyway (benchmarks/RESULTS-simulator.md, "Denormals").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np
import scipy.sparse as sp
from scipy.linalg import blas, lapack
from scipy.sparse.linalg import spsolve

from .assembly import hermite, to_upper_banded


class TrackLike(Protocol):
    M: sp.spmatrix
    C: sp.spmatrix
    K: sp.spmatrix
    node_x: np.ndarray      # rail node positions, increasing [m]
    rail_w: np.ndarray      # dof of rail deflection per node (-1: fixed)
    rail_th: np.ndarray     # dof of rail rotation per node


def contact_vectors(track: TrackLike, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element index, dof indices (n, 4) and Hermite values (n, 4) of N at positions x.

    Fixed dofs get index 0 and value 0, so they take no part in the products."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    nx = track.node_x
    e = np.clip(np.searchsorted(nx, x, side="right") - 1, 0, len(nx) - 2)
    vals = hermite(x - nx[e], nx[e + 1] - nx[e])
    idx = np.stack([track.rail_w[e], track.rail_th[e], track.rail_w[e + 1], track.rail_th[e + 1]],
                   axis=1)
    vals[idx < 0] = 0.0
    idx[idx < 0] = 0
    return e, idx, vals


def contact_vector(track: TrackLike, x: float) -> tuple[np.ndarray, np.ndarray]:
    """Dof indices and Hermite values of N at one position x."""
    _, idx, vals = contact_vectors(track, x)
    return idx[0], vals[0]


def inverse_columns(chol: np.ndarray, dofs: np.ndarray) -> np.ndarray:
    """Rows A⁻¹e_j (shape (len(dofs), n)) of a matrix factorised by ``dpbtrf``."""
    n = chol.shape[1]
    unit = np.zeros((n, len(dofs)), order="F")
    unit[dofs, np.arange(len(dofs))] = 1.0
    sol, info = lapack.dpbtrs(chol, unit, lower=0, overwrite_b=1)
    return sol.T


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


@dataclass
class History:
    time: np.ndarray
    position: np.ndarray                # of the leading wheel
    contact_force: np.ndarray           # of the leading wheel
    rail_displacement: np.ndarray       # Nᵀu under the leading wheel
    vehicle_displacement: np.ndarray    # (steps+1, vehicle dofs), e.g. carbody, bogie, wheel
    dof_displacement: np.ndarray        # (steps+1, len(record_dofs))
    dof_velocity: np.ndarray            # (steps+1, len(record_dofs))
    wheel_position: np.ndarray | None = None          # (steps+1, wheels), front first
    wheel_force: np.ndarray | None = None             # (steps+1, wheels)
    wheel_rail_displacement: np.ndarray | None = None  # (steps+1, wheels)
    # unilateral sleeper supports (lccopt/vti/unilateral.py), else None
    support_force: np.ndarray | None = None    # (steps+1, supports) ballast force [N]
    support_contact: np.ndarray | None = None  # (steps+1, supports) 1 in contact, 0 over a void
    info: dict | None = None                   # active-set statistics of the unilateral supports

    def __post_init__(self):
        if self.wheel_position is None:   # one wheel
            self.wheel_position = self.position[:, None]
            self.wheel_force = self.contact_force[:, None]
            self.wheel_rail_displacement = self.rail_displacement[:, None]


def integrate(track: TrackLike, dt: float, speed: float, x_start: float, n_steps: int, *,
              vehicle=None, load: float = 0.0, irregularity: Callable[[float], float] | None = None,
              record_dofs: np.ndarray | None = None, initial: tuple | None = None,
              vehicle_offset: np.ndarray | None = None,
              on_step: Callable | None = None, general: bool = False) -> History:
    """Run ``n_steps`` Newmark steps from static equilibrium with the wheel at ``x_start``.

    vehicle: a :class:`~lccopt.vti.vehicle.Vehicle` (coupled through its Hertz spring), or
    None for a constant moving force ``load`` [N].
    initial: (u, v) of the track instead of static equilibrium (moving load only), e.g. a
    known steady state; the accelerations follow from equilibrium.
    vehicle_offset: displacements added to the vehicle's static position at t = 0 (free
    vibration from a chosen shape).
    on_step(n, u, v, a, z, zd, zdd, idx, vals, force): optional hook after each step (tests).

    speed may be negative (the vehicle runs towards -x). A vehicle with several wheels
    (``vehicle.wheel_offsets`` behind the leading wheel, which starts at x_start) runs through
    :func:`integrate_wheels`, as does a one-wheel vehicle with ``general=True`` (tests).
    Every support is linear here; sleepers whose ballast support acts only in contact (voids)
    run through :func:`~lccopt.vti.unilateral.integrate_unilateral`, which builds on this
    module.
    """
    if vehicle is not None and (general or len(vehicle.wheel_dofs) > 1):
        return integrate_wheels(track, dt, speed, x_start, n_steps, vehicle=vehicle,
                                irregularity=irregularity, record_dofs=record_dofs,
                                vehicle_offset=vehicle_offset, on_step=on_step)
    _check_on_rail(track, x_start + speed * dt * np.array([0, n_steps]))
    M, C, K = track.M.tocsr(), track.C.tocsr(), track.K.tocsr()
    n = K.shape[0]
    r_of = irregularity or (lambda x: 0.0)
    record_dofs = np.asarray(record_dofs if record_dofs is not None else [], dtype=int)
    a0, a1, a2 = 4.0 / dt ** 2, 2.0 / dt, 4.0 / dt

    coupled = vehicle is not None
    if coupled:
        Mv, Cv, Kv, fv = vehicle.M, vehicle.C, vehicle.K, vehicle.weight_load
        kw = vehicle.contact_stiffness
        B = Kv + a0 * Mv + a1 * Cv
        B[2, 2] += kw
        Binv = np.linalg.inv(B)
        s = Binv[2, 2]
        kappa = kw * (1.0 - kw * s)   # rank-one coefficient left after eliminating the vehicle
        binv_col = Binv[:, 2].copy()
    else:
        kw = kappa = 0.0

    # --- static equilibrium with the wheel in place
    idx, vals = contact_vector(track, x_start)
    r0 = r_of(x_start)
    if coupled:
        Nfull = sp.csr_matrix((vals, (idx, np.zeros(4, int))), shape=(n, 1))
        e3 = sp.csr_matrix(([1.0], ([2], [0])), shape=(3, 1))
        Kg = sp.bmat([[K + kw * (Nfull @ Nfull.T), -kw * (Nfull @ e3.T)],
                      [-kw * (e3 @ Nfull.T), sp.csr_matrix(Kv) + kw * (e3 @ e3.T)]], format="csc")
        rhs = np.zeros(n + 3)
        np.add.at(rhs, idx, -kw * r0 * vals)
        rhs[n:] = fv
        rhs[n + 2] += kw * r0
        sol = spsolve(Kg, rhs)
        u0, z = sol[:n], sol[n:].copy()
    else:
        f = np.zeros(n)
        np.add.at(f, idx, load * vals)
        u0 = spsolve(K.tocsc(), f)
        z = np.zeros(3)
    v0 = np.zeros(n)
    acc0 = np.zeros(n)
    zd = np.zeros(3)
    zdd = np.zeros(3)
    if initial is not None:
        if coupled:
            raise ValueError("an initial track state is supported for a moving load only")
        u0, v0 = (np.asarray(a, dtype=float).copy() for a in initial)
        acc0 = spsolve(M.tocsc(), f - K @ u0 - C @ v0)
    if vehicle_offset is not None:
        if not coupled:
            raise ValueError("vehicle_offset needs a vehicle")
        z = z + np.asarray(vehicle_offset, dtype=float)
        # the offset unbalances the vehicle: start from the consistent accelerations
        delta0 = float(vals @ u0[idx])
        fc = kw * (z[2] - delta0 - r0)
        zdd = np.linalg.solve(Mv, fv - Kv @ z - np.array([0.0, 0.0, fc]))

    # --- constant effective matrix, factorised once (banded Cholesky)
    ab, kd = to_upper_banded(K + a0 * M + a1 * C)
    chol, info = lapack.dpbtrf(ab, lower=0, overwrite_ab=1)
    if info != 0:
        raise np.linalg.LinAlgError(
            f"effective track matrix is not positive definite (dpbtrf info={info})")
    # The track state is kept as p = a0 u + a2 v + a, q = a1 u + v and u, so that the right-hand
    # side M(a0 u + a2 v + a) + C(a1 u + v) is one sparse product [M C] [p; q], and Newmark's
    # updates of v and a become (with a1 a2 = 2 a0) q' = 2 a1 u' - q, p' = 4 a0 u' - a2 q - p.
    # v = q - a1 u and a = p - a0 u - a2 v are formed only where they are recorded.
    MC = sp.hstack([M, C]).tocsr()
    S = np.zeros((3, n))                # rows p, q, u
    S_next = np.zeros((3, n))
    S[0] = a0 * u0 + a2 * v0 + acc0
    S[1] = a1 * u0 + v0
    S[2] = u0
    R = np.array([[-1.0, -a2, 4.0 * a0], [0.0, -1.0, 2.0 * a1]])   # [p; q; u'] -> [p'; q']
    s_vec = np.zeros(n)
    # With A_t = UᵀU: z = U⁻ᵀ b, s = U⁻ᵀ N, then Nᵀu = sᵀ(z + c s) and u = U⁻¹(z + c s) for a
    # contact force c (Sherman-Morrison in factored form). s = vals · (U⁻ᵀe_j for the
    # element's 4 dofs): rows solved when the wheel enters an element, from row j on only;
    # the next element shares a node, so that costs two rows. Per step: one forward and one
    # backward banded triangular solve, i.e. one banded solve pair.
    scols = np.zeros((4, n), order="C")
    chol = np.asfortranarray(chol)
    steps = n_steps + 1
    time = dt * np.arange(steps)
    position = x_start + speed * time
    elem, idx_all, vals_all = contact_vectors(track, position)
    new_elem = np.r_[True, True, elem[2:] != elem[1:-1]]   # step 1 always fills the columns
    shift = np.r_[False, False, elem[2:] == elem[1:-1] + 1]
    back = np.r_[False, False, elem[2:] == elem[1:-1] - 1]      # running towards -x
    r_all = np.array([r_of(p) for p in position]) if irregularity is not None else np.zeros(steps)
    force = np.zeros(steps)
    rail_disp = np.zeros(steps)
    veh = np.zeros((steps, 3))
    rec = np.zeros((steps, 2, len(record_dofs)))      # q and u at the recorded dofs

    delta = float(vals @ u0[idx])
    rail_disp[0] = delta
    veh[0] = z
    force[0] = kw * (z[2] - delta - r0) if coupled else load
    rec[0, 0] = a1 * u0[record_dofs] + v0[record_dofs]
    rec[0, 1] = u0[record_dofs]

    if coupled:
        # Vehicle, state s = [z, zd, zdd]: with t = [s, 1, r, δ],
        #   z0 = Binv (Mv (a0 z + a2 zd + zdd) + Cv (a1 z + zd) + fv + kw r e3) = Q t,
        #   z' = z0 + kw δ Binv e3, and Newmark's zd', zdd' from z, zd, zdd, z',
        # so c0 = kw (z0[2] - r) and s' = G t are two small products per step.
        kb = kw * binv_col
        Q = np.hstack([Binv @ (a0 * Mv + a1 * Cv), Binv @ (a2 * Mv + Cv), Binv @ Mv,
                       (Binv @ fv)[:, None], kb[:, None], np.zeros((3, 1))])
        Qd = Q.copy()
        Qd[:, 11] = kb                                   # z' = Qd t
        I3, O3 = np.eye(3), np.zeros((3, 3))
        Rv = np.block([[O3, O3, O3, I3],
                       [-a1 * I3, -I3, O3, a1 * I3],
                       [-a0 * I3, -a2 * I3, -I3, a0 * I3]])   # [s; z'] -> s'
        G = Rv[:, 9:] @ Qd
        G[:, :9] += Rv[:, :9]
        c_row = kw * (Q[2] - np.r_[np.zeros(10), 1.0, 0.0])   # c0 = c_row t
        t = np.concatenate([z, zd, zdd, [1.0, 0.0, 0.0]])
        kappa_ = kappa
        kw_ = kw

    tbsv = blas.dtbsv
    axpy = blas.daxpy
    dot = np.dot
    for k in range(1, steps):
        # right-hand side of the track from the state at step k-1 (public sparse product)
        rhs = MC @ S[:2].reshape(-1)
        idx, vals = idx_all[k], vals_all[k]
        if new_elem[k]:
            if shift[k]:
                scols[:2] = scols[2:]
                forward_columns(chol, idx[2:], scols[2:])
            elif back[k]:
                scols[2:] = scols[:2]
                forward_columns(chol, idx[:2], scols[:2])
            else:
                forward_columns(chol, idx, scols)
        y = tbsv(kd, chol, rhs, trans=1, overwrite_x=1)          # z = U⁻ᵀ rhs
        dot(vals, scols, out=s_vec)
        g1 = dot(s_vec, y)
        g2 = dot(s_vec, s_vec)
        if coupled:
            r = r_all[k]
            t[10] = r
            c0 = dot(c_row, t)
            delta = (g1 + c0 * g2) / (1.0 + kappa_ * g2)   # Nᵀ u_next
            coef = c0 - kappa_ * delta
            t[11] = delta
            t[:9] = dot(G, t)
            force[k] = kw_ * (t[2] - delta - r)
            veh[k] = t[:3]
        else:
            coef = load
            delta = g1 + load * g2
            force[k] = load
        # u' = U⁻¹(z + coef s); then p', q' from p, q, u'
        S[2] = tbsv(kd, chol, axpy(s_vec, y, a=coef), overwrite_x=1)
        dot(R, S, out=S_next[:2])
        S_next[2] = S[2]
        S, S_next = S_next, S
        rail_disp[k] = delta
        rec[k] = S[1:, record_dofs]
        if on_step is not None:
            u = S[2]
            v = S[1] - a1 * u
            acc = S[0] - a0 * u - a2 * v
            if coupled:
                z, zd, zdd = t[:3].copy(), t[3:6].copy(), t[6:9].copy()
            on_step(k, u, v, acc, z, zd, zdd, idx, vals, force[k])

    rec_u = rec[:, 1]
    rec_v = rec[:, 0] - a1 * rec_u
    return History(time, position, force, rail_disp, veh, rec_u, rec_v)


def _check_on_rail(track: TrackLike, positions) -> None:
    """Every wheel stays on the modelled rail for the whole run (the window is chosen so; a
    wheel beyond a rail end would be extrapolated from the end element)."""
    p = np.asarray(positions, dtype=float)
    lo, hi = float(track.node_x[0]), float(track.node_x[-1])
    if p.min() < lo - 1e-9 or p.max() > hi + 1e-9:
        raise ValueError(f"a wheel runs from {p.min():.3f} m to {p.max():.3f} m, beyond the "
                         f"modelled rail [{lo:g}, {hi:g}] m: lengthen the track or shorten the run")


def integrate_wheels(track: TrackLike, dt: float, speed: float, x_start: float, n_steps: int, *,
                     vehicle, irregularity: Callable[[float], float] | None = None,
                     record_dofs: np.ndarray | None = None,
                     vehicle_offset: np.ndarray | None = None,
                     on_step: Callable | None = None) -> History:
    """:func:`integrate` for a vehicle with k wheels on the rail (k moving rank-one contacts).

    Wheel i runs at x_start + speed t - sign(speed) d_i (d_i = ``vehicle.wheel_offsets``, behind
    the leading wheel). With W the wheel dofs of the vehicle, N = [N_1 .. N_k] the Hermite
    vectors and B = A_v + k_w W Wᵀ, eliminating the vehicle leaves

        (A_t + N Κ Nᵀ) u = b_t + N c0,    Κ = k_w (I - k_w Wᵀ B⁻¹ W)    (k x k),

    c0 = k_w (Wᵀ B⁻¹ (b_v + k_w W r) - r), and the contact forces are c = c0 - Κ δ with δ = Nᵀu.
    With A_t = UᵀU factorised once, y = U⁻ᵀ b_t and S = U⁻ᵀ N (rows U⁻ᵀe_j cached per wheel
    and element): δ = Sᵀy + SᵀS c, i.e. (I + SᵀS Κ) δ = Sᵀy + SᵀS c0 (the k x k capacitance
    system of Woodbury's identity), then u = U⁻¹(y + S c). Per step: one forward and one
    backward banded triangular solve, k dot products with the cached rows, a k x k solve.
    The leading wheel must stay on the modelled rail (checked); a trailing wheel beyond a rail
    end rests on a rigid continuation of the rail (N_i = 0: its row of S vanishes, δ_i = 0).
    """
    M, C, K = track.M.tocsr(), track.C.tocsr(), track.K.tocsr()
    n = K.shape[0]
    record_dofs = np.asarray(record_dofs if record_dofs is not None else [], dtype=int)
    a0, a1, a2 = 4.0 / dt ** 2, 2.0 / dt, 4.0 / dt
    Mv, Cv, Kv, fv = (np.asarray(a, dtype=float)
                      for a in (vehicle.M, vehicle.C, vehicle.K, vehicle.weight_load))
    nv = Mv.shape[0]
    W = np.asarray(vehicle.wheel_dofs, dtype=int)
    k = len(W)
    kw = vehicle.contact_stiffness
    sgn = -1.0 if speed < 0 else 1.0

    steps = n_steps + 1
    time = dt * np.arange(steps)
    lead = x_start + speed * time
    pos = lead[:, None] - sgn * np.asarray(vehicle.wheel_offsets, dtype=float)[None, :]
    _check_on_rail(track, lead)
    elem, idx_all, vals_all = contact_vectors(track, pos.ravel())
    elem = elem.reshape(steps, k)
    idx_all = idx_all.reshape(steps, k, 4)
    vals_all = vals_all.reshape(steps, k, 4)
    # a trailing wheel beyond a rail end rests on a rigid continuation of the rail: no track
    # coupling (N = 0), its contact spring on the ground
    off = (pos < track.node_x[0] - 1e-9) | (pos > track.node_x[-1] + 1e-9)
    vals_all[off] = 0.0
    idx_all[off] = 0
    elem[off] = -1
    if irregularity is not None:
        r_all = np.array([irregularity(p) for p in pos.ravel()], dtype=float).reshape(steps, k)
    else:
        r_all = np.zeros((steps, k))

    B = Kv + a0 * Mv + a1 * Cv
    B[W, W] += kw
    Binv = np.linalg.inv(B)
    Kap = kw * (np.eye(k) - kw * Binv[np.ix_(W, W)])

    # --- static equilibrium with every wheel in place (coupled system solved outright)
    idx, vals, r0 = idx_all[0], vals_all[0], r_all[0]
    Nm = sp.csr_matrix((vals.ravel(), (idx.ravel(), np.repeat(np.arange(k), 4))), shape=(n, k))
    Wm = sp.csr_matrix((np.ones(k), (W, np.arange(k))), shape=(nv, k))
    Kg = sp.bmat([[K + kw * (Nm @ Nm.T), -kw * (Nm @ Wm.T)],
                  [-kw * (Wm @ Nm.T), sp.csr_matrix(Kv) + kw * (Wm @ Wm.T)]], format="csc")
    rhs = np.zeros(n + nv)
    np.add.at(rhs, idx.ravel(), -kw * (r0[:, None] * vals).ravel())
    rhs[n:] = fv
    rhs[n + W] += kw * r0
    sol = spsolve(Kg, rhs)
    u0, z = sol[:n], sol[n:].copy()
    zd = np.zeros(nv)
    zdd = np.zeros(nv)
    delta = np.einsum("ij,ij->i", vals, u0[idx])
    if vehicle_offset is not None:
        z = z + np.asarray(vehicle_offset, dtype=float)
        fc = kw * (z[W] - delta - r0)
        load = fv - Kv @ z
        load[W] -= fc
        zdd = np.linalg.solve(Mv, load)

    ab, kd = to_upper_banded(K + a0 * M + a1 * C)
    chol, info = lapack.dpbtrf(ab, lower=0, overwrite_ab=1)
    if info != 0:
        raise np.linalg.LinAlgError(
            f"effective track matrix is not positive definite (dpbtrf info={info})")
    chol = np.asfortranarray(chol)
    MC = sp.hstack([M, C]).tocsr()
    S = np.zeros((3, n))
    S_next = np.zeros((3, n))
    S[0] = a0 * u0
    S[1] = a1 * u0
    S[2] = u0
    R = np.array([[-1.0, -a2, 4.0 * a0], [0.0, -1.0, 2.0 * a1]])

    force = np.zeros((steps, k))
    rail = np.zeros((steps, k))
    veh = np.zeros((steps, nv))
    rec = np.zeros((steps, 2, len(record_dofs)))
    rail[0] = delta
    veh[0] = z
    force[0] = kw * (z[W] - delta - r0)
    rec[0, 0] = a1 * u0[record_dofs]
    rec[0, 1] = u0[record_dofs]

    # vehicle: t = [z, zd, zdd, 1, r (k), δ (k)]; z0 = Q t, z' = Qd t, s' = G t, c0 = Crow t
    kb = kw * Binv[:, W]                                          # (nv, k)
    Q = np.hstack([Binv @ (a0 * Mv + a1 * Cv), Binv @ (a2 * Mv + Cv), Binv @ Mv,
                   (Binv @ fv)[:, None], kb, np.zeros((nv, k))])
    Qd = Q.copy()
    Qd[:, 3 * nv + 1 + k:] = kb
    I, O = np.eye(nv), np.zeros((nv, nv))
    Rv = np.block([[O, O, O, I],
                   [-a1 * I, -I, O, a1 * I],
                   [-a0 * I, -a2 * I, -I, a0 * I]])
    G = Rv[:, 3 * nv:] @ Qd
    G[:, :3 * nv] += Rv[:, :3 * nv]
    sel_r = np.zeros((k, Q.shape[1]))
    sel_r[:, 3 * nv + 1:3 * nv + 1 + k] = np.eye(k)
    Crow = kw * (Q[W] - sel_r)
    t = np.concatenate([z, zd, zdd, [1.0], np.zeros(2 * k)])
    r_sl = slice(3 * nv + 1, 3 * nv + 1 + k)
    d_sl = slice(3 * nv + 1 + k, 3 * nv + 1 + 2 * k)
    n3 = 3 * nv
    eye = np.eye(k)

    scols = np.zeros((k, 4, n))
    Sm = np.zeros((k, n))
    prev = np.full(k, -10)
    # rows U⁻ᵀe_j by dof: a trailing wheel meets the elements the leading one met (exact
    # copies, not recomputed); rows behind the last wheel on the rail are dropped
    rows: dict[int, np.ndarray] = {}

    def fill(dst, dofs):
        for r, j in zip(dst, dofs):
            got = rows.get(int(j))
            if got is None:
                forward_columns(chol, [j], r[None, :])
                rows[int(j)] = r.copy()
            else:
                r[:] = got

    def refresh(i, e):
        p = prev[i]
        if e == p + 1:
            scols[i, :2] = scols[i, 2:]
            fill(scols[i, 2:], idx_all[s, i, 2:])
        elif e == p - 1:
            scols[i, 2:] = scols[i, :2]
            fill(scols[i, :2], idx_all[s, i, :2])
        else:
            fill(scols[i], idx_all[s, i])
        prev[i] = e
    tbsv = blas.dtbsv
    dot = np.dot
    solve = np.linalg.solve
    for s in range(1, steps):
        rhs = MC @ S[:2].reshape(-1)
        idx, vals = idx_all[s], vals_all[s]
        for i in range(k):
            e = elem[s, i]
            if e < 0:                      # off the modelled rail
                Sm[i] = 0.0
                continue
            if e != prev[i]:
                refresh(i, e)
            dot(vals[i], scols[i], out=Sm[i])
        if s % 64 == 0 and k > 1:
            on = elem[s] >= 0
            if on.any():
                held = idx[on][vals[on] != 0.0]
                if held.size:
                    keep_from, keep_to = int(held.min()), int(held.max())
                    behind = [j for j in rows if (j < keep_from if speed >= 0 else j > keep_to)]
                    for j in behind:
                        del rows[j]
        y = tbsv(kd, chol, rhs, trans=1, overwrite_x=1)
        g1 = dot(Sm, y)
        G2 = dot(Sm, Sm.T)
        r = r_all[s]
        t[r_sl] = r
        c0 = dot(Crow, t)
        delta = solve(eye + dot(G2, Kap), g1 + dot(G2, c0))
        coef = c0 - dot(Kap, delta)
        t[d_sl] = delta
        t[:n3] = dot(G, t)
        force[s] = kw * (t[W] - delta - r)
        veh[s] = t[:nv]
        S[2] = tbsv(kd, chol, y + dot(coef, Sm), overwrite_x=1)
        dot(R, S, out=S_next[:2])
        S_next[2] = S[2]
        S, S_next = S_next, S
        rail[s] = delta
        rec[s] = S[1:, record_dofs]
        if on_step is not None:
            u = S[2]
            v = S[1] - a1 * u
            acc = S[0] - a0 * u - a2 * v
            on_step(s, u, v, acc, t[:nv].copy(), t[nv:2 * nv].copy(), t[2 * nv:n3].copy(),
                    idx, vals, force[s])

    rec_u = rec[:, 1]
    rec_v = rec[:, 0] - a1 * rec_u
    return History(time, lead, force[:, 0].copy(), rail[:, 0].copy(), veh, rec_u, rec_v,
                   pos, force, rail)
