"""The simulation method as it was before issue 11, frozen: the comparison of the speed and
accuracy benchmarks (benchmarks/model/simulator_speed.py, benchmarks/model/simulate_accuracy.py,
tests/vti/test_speedup.py). Not part of lccopt: the package holds the current method only.

:func:`integrate_reference` is the same Newmark scheme as :func:`lccopt.vti.newmark.integrate`
(same equations, same results to round-off) with the old loop: a full banded solve per step,
two columns of A⁻¹ per element, a periodic flush of tiny values. The only edit: the right-hand
side product uses the public ``csr @ vector`` instead of scipy's private ``csr_matvec`` kernel
(about 4 µs per step more). :func:`evaluate_legacy` is the old evaluation around it (F_max from
the steps inside the force zone only); run it at ``REFERENCE_SETTINGS``, the simulation
settings of configs/reference.yaml before issue 11. What changed with issue 11 is mostly those
settings (time step, run-in, far-field elements); the figures are in
benchmarks/RESULTS-simulator.md.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp
from scipy.linalg import lapack
from scipy.sparse.linalg import spsolve

from lccopt.vti.assembly import to_upper_banded
from lccopt.vti.newmark import History
from lccopt.vti.response import Evaluation, objectives_from
from lccopt.vti.track import build_track
from lccopt.vti.vehicle import build_vehicle
from lccopt.vti.wheels import TrackLike, contact_vector, contact_vectors

FLUSH_EVERY = 200         # steps between flushes of tiny values
FLUSH_BELOW = 1e-150      # |value| below this is set to 0 (displacements are ~1e-3 m)

# the simulation settings of configs/reference.yaml before issue 11
REFERENCE_SETTINGS = dict(time_step=2.0e-4, element_length=0.05, far_element_length=0.3,
                          run_in=10.0, run_out=3.0)


def inverse_columns(chol: np.ndarray, dofs: np.ndarray) -> np.ndarray:
    """Rows A⁻¹e_j (shape (len(dofs), n)) of a matrix factorised by ``dpbtrf``."""
    n = chol.shape[1]
    unit = np.zeros((n, len(dofs)), order="F")
    unit[dofs, np.arange(len(dofs))] = 1.0
    sol, info = lapack.dpbtrs(chol, unit, lower=0, overwrite_b=1)
    return sol.T


def evaluate_legacy(case, x) -> Evaluation:
    """Design x of ``case`` by the method before issue 11: its integrator, the three-dof vehicle
    only, and F_max from the steps inside the force zone only (the current method also takes
    the force at the zone's exact ends). Objectives, the leading wheel's force and position,
    and the step and dof counts."""
    scenario, design = case.scenario(), case.track_design(x)
    track = build_track(scenario, design)
    vehicle = build_vehicle(scenario.vehicle)
    if vehicle.n_wheels > 1:
        raise ValueError("the legacy integrator runs the three-dof vehicle only")
    dt = scenario.settings.time_step
    x_start, zone_start, zone_end, x_end = track.window
    speed = -vehicle.speed if x_end < x_start else vehicle.speed
    n_steps = int(np.ceil(abs(x_end - x_start) / (vehicle.speed * dt)))
    n_zone = scenario.zones.sleepers
    irregularity = None
    profile = scenario.irregularity
    if profile is not None:
        px, pr = profile[:, 0], profile[:, 1]
        irregularity = lambda pos: float(np.interp(pos, px, pr, left=0.0, right=0.0))  # noqa: E731
    h = integrate_reference(track, dt, speed, x_start, n_steps, vehicle=vehicle,
                            irregularity=irregularity,
                            record_dofs=track.entry_sleeper_dof[:n_zone])
    v_mid = 0.5 * (h.dof_velocity[1:] + h.dof_velocity[:-1])
    energy = dt * track.entry_support_damping[:n_zone] * np.sum(v_mid ** 2, axis=0)
    lo, hi = min(zone_start, zone_end) - 1e-9, max(zone_start, zone_end) + 1e-9
    in_zone = (h.position >= lo) & (h.position <= hi)
    objectives = objectives_from(h.contact_force[in_zone], energy)
    return Evaluation(objectives, {"contact_force": h.contact_force, "wheel_position": h.position,
                                   "sleeper_energy": energy},
                      {"n_steps": n_steps, "n_dofs": track.n_dofs, "time_step": dt})


def integrate_reference(track: TrackLike, dt: float, speed: float, x_start: float, n_steps: int,
                        *, vehicle=None, load: float = 0.0,
                        irregularity: Callable[[float], float] | None = None,
                        record_dofs: np.ndarray | None = None, initial: tuple | None = None,
                        vehicle_offset: np.ndarray | None = None,
                        on_step: Callable | None = None) -> History:
    """Run ``n_steps`` Newmark steps from static equilibrium with the wheel at ``x_start``.

    vehicle: a :class:`~lccopt.vti.vehicle.Vehicle` (coupled through its Hertz spring), or
    None for a constant moving force ``load`` [N].
    initial: (u, v) of the track instead of static equilibrium (moving load only), e.g. a
    known steady state; the accelerations follow from equilibrium.
    vehicle_offset: displacements added to the vehicle's static position at t = 0 (free
    vibration from a chosen shape).
    on_step(n, u, v, a, z, zd, zdd, idx, vals, force): optional hook after each step (tests).
    """
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
    u0[np.abs(u0) < FLUSH_BELOW] = 0.0
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
    # rhs of the track from [u; v; a]: M(a0 u + a2 v + a) + C(a1 u + v), one sparse product
    W = sp.hstack([a0 * M + a1 * C, a2 * M + C, M]).tocsr()

    # state rows: u, v, a, u_next (so that one small matrix product updates them)
    X = np.zeros((4, n))
    Y = np.zeros((4, n))
    X[0], X[1], X[2] = u0, v0, acc0
    R = np.array([[-a1, -1.0, 0.0, a1], [-a0, -a2, -1.0, a0]])  # -> [v_next; a_next]
    rhs = np.zeros(n)
    w = np.zeros(n)
    # A_t⁻¹N = vals · (A_t⁻¹ e_j for the element's 4 dofs): columns solved when the wheel
    # enters an element; the next element shares a node, so that costs two columns, not a
    # second banded solve every step.
    cols = np.empty((4, n))

    steps = n_steps + 1
    time = dt * np.arange(steps)
    position = x_start + speed * time
    elem, idx_all, vals_all = contact_vectors(track, position)
    new_elem = np.r_[True, True, elem[2:] != elem[1:-1]]   # step 1 always fills the columns
    force = np.zeros(steps)
    rail_disp = np.zeros(steps)
    veh = np.zeros((steps, 3))
    rec_u = np.zeros((steps, len(record_dofs)))
    rec_v = np.zeros((steps, len(record_dofs)))

    delta = float(vals @ u0[idx])
    rail_disp[0] = delta
    veh[0] = z
    force[0] = kw * (z[2] - delta - r0) if coupled else load
    rec_u[0] = u0[record_dofs]
    rec_v[0] = v0[record_dofs]

    for k in range(1, steps):
        # right-hand side of the track from the state at step k-1
        rhs = W @ X[:3].reshape(-1)
        idx, vals = idx_all[k], vals_all[k]
        if new_elem[k]:
            if k > 1 and elem[k] == elem[k - 1] + 1:
                cols[:2] = cols[2:]
                cols[2:] = inverse_columns(chol, idx[2:])
            else:
                cols[:] = inverse_columns(chol, idx)
        r = r_of(position[k])
        y, info = lapack.dpbtrs(chol, rhs, lower=0)
        np.dot(vals, cols, out=w)
        g1 = float(vals @ y[idx])
        g2 = float(vals @ w[idx])
        if coupled:
            rv = Mv @ (a0 * z + a2 * zd + zdd) + Cv @ (a1 * z + zd) + fv
            z0 = Binv @ rv + (kw * r) * binv_col
            c0 = kw * (z0[2] - r)
            nt = g1 + c0 * g2                      # Nᵀ A_t⁻¹ b
            delta = nt / (1.0 + kappa * g2)        # Nᵀ u_next
            coef = c0 - kappa * delta
        else:
            coef = load
            delta = g1 + load * g2
        np.multiply(w, coef, out=X[3])
        X[3] += y
        np.dot(R, X, out=Y[1:3])
        Y[0] = X[3]
        X, Y = Y, X
        if coupled:
            z_new = z0 + (kw * delta) * binv_col
            zd_new = -zd + a1 * (z_new - z)
            zdd = -zdd - a2 * zd + a0 * (z_new - z)
            z, zd = z_new, zd_new
            force[k] = kw * (z[2] - delta - r)
        else:
            force[k] = load
        rail_disp[k] = delta
        veh[k] = z
        rec_u[k] = X[0, record_dofs]
        rec_v[k] = X[1, record_dofs]
        if k % FLUSH_EVERY == 0:
            X[:3][np.abs(X[:3]) < FLUSH_BELOW] = 0.0
        if on_step is not None:
            on_step(k, X[0], X[1], X[2], z, zd, zdd, idx, vals, force[k])

    return History(time, position, force, rail_disp, veh, rec_u, rec_v, position[:, None],
                   force[:, None], rail_disp[:, None])
