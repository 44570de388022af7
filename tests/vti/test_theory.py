"""The vehicle-track model against closed-form solutions and the exact Newmark energy balance
(../shared/THEORY.md)."""

import numpy as np
import pytest
import scipy.sparse.linalg as sla

from lccopt.config import load_case
from lccopt.vti.newmark import integrate
from lccopt.vti.track import WinklerBeam, build_track
from lccopt.vti.vehicle import Vehicle, build_vehicle
from lccopt.vti.wheels import contact_vector

EI = 210e9 * 2.337e-5    # 54E1
M_RAIL = 7800 * 6.977e-3
K_FOUND = 100e6          # N/m²
P = 100e3


def hetenyi(x, beta, k=K_FOUND, p=P):
    ax = np.abs(x)
    return p * beta / (2 * k) * np.exp(-beta * ax) * (np.cos(beta * x) + np.sin(beta * ax))


def fryba(s, beta, alpha, k=K_FOUND, p=P):
    a, b = np.sqrt(1 - alpha ** 2), np.sqrt(1 + alpha ** 2)
    return p * beta / (2 * k * a) * np.exp(-beta * a * np.abs(s)) * (
        np.cos(beta * b * s) + a / b * np.sin(beta * b * np.abs(s)))


def test_static_point_load_matches_hetenyi():
    beam = WinklerBeam.build(60.0, 0.1, EI, M_RAIL, K_FOUND)
    idx, vals = contact_vector(beam, 30.0)
    f = np.zeros(beam.K.shape[0])
    np.add.at(f, idx, P * vals)
    u = sla.spsolve(beam.K.tocsc(), f)
    beta = (K_FOUND / (4 * EI)) ** 0.25
    assert beta == pytest.approx(1.502, abs=1e-3)
    w = u[beam.rail_w[1:-1]]
    x = beam.node_x[1:-1] - 30.0
    exact = hetenyi(x, beta)
    peak = exact.max()
    assert peak == pytest.approx(0.751e-3, rel=1e-3)                 # THEORY.md example
    assert w.max() == pytest.approx(peak, rel=0.01)
    near = np.abs(x) < 3 / beta                      # the shape, incl. the uplift lobes
    assert np.max(np.abs(w[near] - exact[near])) < 0.01 * peak
    # rotation dofs are the slope dw/dx of the same curve
    th = u[beam.rail_th[1:-1]]
    h = 1e-6
    slope = (hetenyi(x + h, beta) - hetenyi(x - h, beta)) / (2 * h)
    away = (np.abs(x) > 0.05) & near
    assert np.max(np.abs(th[away] - slope[away])) < 0.01 * np.abs(slope).max()


def test_moving_load_at_half_critical_speed_matches_fryba():
    speed = 100.0
    v_cr = 2 * speed                                  # alpha = 0.5
    mass = np.sqrt(4 * K_FOUND * EI) / v_cr ** 2      # scale the mass: v_cr = (4kEI/m²)^(1/4)
    beam = WinklerBeam.build(80.0, 0.1, EI, mass, K_FOUND)
    beta = (K_FOUND / (4 * EI)) ** 0.25
    alpha = speed / v_cr
    x0, dt, steps = 25.0, 5e-5, 4000                  # the load runs 20 m
    # start from the steady state in the moving frame s = x - x0 (THEORY.md's advice)
    x = beam.node_x
    h = 1e-5
    def w(s):
        return fryba(s, beta, alpha)

    def dw(s):
        return (w(s + h) - w(s - h)) / (2 * h)

    n = beam.K.shape[0]
    u0, v0 = np.zeros(n), np.zeros(n)
    free_w, free_th = beam.rail_w >= 0, beam.rail_th >= 0
    u0[beam.rail_w[free_w]] = w(x[free_w] - x0)
    u0[beam.rail_th[free_th]] = dw(x[free_th] - x0)
    v0[beam.rail_w[free_w]] = -speed * dw(x[free_w] - x0)
    x_th = x[free_th] - x0
    v0[beam.rail_th[free_th]] = -speed * (dw(x_th + h) - dw(x_th - h)) / (2 * h)
    hist = integrate(beam, dt, speed, x0, steps, load=P, initial=(u0, v0))
    peak = w(0.0)
    assert peak == pytest.approx(P * beta / (2 * K_FOUND * np.sqrt(1 - alpha ** 2)))
    assert peak > 1.15 * hetenyi(0.0, beta)          # inertia matters at this speed
    # deflection under the load over the last half of the run: steady, equal to Frýba's
    late = hist.rail_displacement[steps // 2:]
    assert np.max(np.abs(late - peak)) < 0.02 * peak


def rigid_track_case():
    """The reference case with the quarter-car reading, whose closed forms these tests check
    (the paper's bogie has its second primary suspension on a fixed point: see
    tests/vti/test_paper_model.py)."""
    case = load_case("configs/reference.yaml")
    case.data["vehicle"]["model"] = "quarter-car"
    return case


def stiff_beam():
    """A rail on a foundation so stiff that it is rigid for the vehicle."""
    return WinklerBeam.build(20.0, 0.1, EI, M_RAIL, 1e13)


def test_quarter_car_static_contact_force_is_the_weight():
    veh = build_vehicle(rigid_track_case().scenario().vehicle)
    hist = integrate(stiff_beam(), 1e-4, 0.0, 10.0, 200, vehicle=veh)
    weight = veh.masses.sum() * veh.gravity
    assert hist.contact_force[0] == pytest.approx(weight, rel=1e-9)
    # standing still from static equilibrium: nothing moves
    assert np.max(np.abs(hist.contact_force - weight)) < 1e-6 * weight


def zero_crossing_frequency(t, y):
    y = y - y.mean()
    s = np.signbit(y)
    i = np.nonzero(s[1:] != s[:-1])[0]
    tc = t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])   # linear interpolation
    return (len(tc) - 1) / (2 * (tc[-1] - tc[0]))


@pytest.mark.parametrize("mode", [0, 1, 2])
def test_quarter_car_eigenfrequencies_on_rigid_track(mode):
    """Free vibration started in each mode of the 3x3 problem oscillates at its frequency."""
    from scipy.linalg import eigh

    base = build_vehicle(rigid_track_case().scenario().vehicle)
    veh = Vehicle(base.masses, base.k_s1, 0.0, base.k_s2, 0.0, base.speed, base.gravity,
                  base.hertz_constant, base.hertz_load)         # undamped
    K = veh.K.copy()
    K[2, 2] += veh.contact_stiffness
    lam, phi = eigh(K, veh.M)
    f = np.sqrt(lam) / (2 * np.pi)
    assert np.allclose(f, veh.rigid_track_frequencies())
    assert 1.0 < f[0] < 3.0 and 5.0 < f[1] < 15.0 and 100.0 < f[2] < 300.0   # carbody, bogie, wheel
    period = 1 / f[mode]
    dt = period / 400
    steps = int(8 * period / dt)
    shape = phi[:, mode] / np.abs(phi[:, mode]).max() * 1e-4
    hist = integrate(stiff_beam(), dt, 0.0, 10.0, steps, vehicle=veh, vehicle_offset=shape)
    dof = int(np.argmax(np.abs(phi[:, mode])))
    measured = zero_crossing_frequency(hist.time, hist.vehicle_displacement[:, dof])
    # Newmark's period error (ωΔt)²/12 is 2e-5 here
    assert measured == pytest.approx(f[mode], rel=2e-3)


def test_newmark_energy_balance_is_exact_over_a_whole_run():
    """E_{n+1} - E_n + Δt v̄ᵀCv̄ = Δuᵀf̄ + k_w/2 [δ_{n+1} g_{n+1}ᵀu_n - δ_n g_nᵀu_{n+1}] each step."""
    case = load_case("configs/reference.yaml").with_simulation(run_in=2.0, run_out=1.0)
    x = case.reference.copy()
    x[:3] = [300e6, 100e6, 60e6]          # soft pads near the interface: a lively run
    x[-1] = 40                            # and some Type II strip
    track = build_track(case.scenario(), case.track_design(x))
    veh = build_vehicle(case.scenario().vehicle)
    M, C, K = track.M, track.C, track.K
    Mv, Cv, Kv, fv, kw = veh.M, veh.C, veh.K, veh.weight_load, veh.contact_stiffness
    dt = case.simulation["time_step"]
    x_start = 96.0
    steps = int(6.0 / (veh.speed * dt))   # 96 m -> 102 m, across the interface
    rows = []
    prev = {}

    def g_dot(idx, vals, u, z):            # gᵀU with g = [-N; e3]
        return z[2] - float(vals @ u[idx])

    def on_step(st):
        cur = dict(u=st.u.copy(), v=st.v.copy(), z=st.z, zd=st.zd, idx=st.idx[0].copy(),
                   vals=st.vals[0].copy())
        if prev:
            p = prev
            delta_new = g_dot(cur["idx"], cur["vals"], cur["u"], cur["z"])
            delta_old = g_dot(p["idx"], p["vals"], p["u"], p["z"])

            def energy(s, delta):
                return (0.5 * s["v"] @ (M @ s["v"]) + 0.5 * s["zd"] @ Mv @ s["zd"]
                        + 0.5 * s["u"] @ (K @ s["u"]) + 0.5 * s["z"] @ Kv @ s["z"]
                        + 0.5 * kw * delta ** 2)

            vbar, zbar = 0.5 * (p["v"] + cur["v"]), 0.5 * (p["zd"] + cur["zd"])
            dissipated = dt * (vbar @ (C @ vbar) + zbar @ Cv @ zbar)
            work = (cur["z"] - p["z"]) @ fv
            moving = 0.5 * kw * (delta_new * g_dot(cur["idx"], cur["vals"], p["u"], p["z"])
                                 - delta_old * g_dot(p["idx"], p["vals"], cur["u"], cur["z"]))
            de = energy(cur, delta_new) - energy(p, delta_old)
            rows.append((de, dissipated, work, moving))
        prev.clear()
        prev.update(cur)

    integrate(track, dt, veh.speed, x_start, steps, vehicle=veh, on_step=on_step)
    r = np.array(rows)
    residual = r[:, 0] + r[:, 1] - r[:, 2] - r[:, 3]
    scale = np.sum(np.abs(r[:, 1])) + np.sum(np.abs(r[:, 2])) + np.sum(np.abs(r[:, 3]))
    assert np.sum(r[:, 1]) > 0 and np.sum(np.abs(r[:, 3])) > 0   # damping and moving work present
    assert abs(residual.sum()) / scale < 1e-9
    # step by step, round-off only
    assert np.max(np.abs(residual)) / np.max(np.abs(r[:, 1])) < 1e-6
