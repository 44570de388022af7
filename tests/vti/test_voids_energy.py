"""Newmark's discrete energy balance with sleepers switching between contact and void
(THEORY.md's balance, extended; lccopt/vti/unilateral.py).

With K_0, C_0 the track without the unilateral supports, φ_i the support's load in the step
equations (spring and damper in contact, minus its weight share k rest_i, in u-coordinates):

    ½v'ᵀMv' - ½vᵀMv + ½u'ᵀK_0u' - ½uᵀK_0u + Δt v̄ᵀC_0v̄ + Σ_i ½(φ_i + φ_i')Δu_i = Δuᵀ f̄

holds to round-off every step. Splitting the support work into the spring's energy
½ k s p² (s the contact flag, p the penetration), the damper's dissipation and the constant
load's work leaves, in a step where sleeper i switches, exactly R_i = ±½ k p_i p_i' (p, p' of
opposite signs): the residual of the energy balance with contact switching, O(k (v Δt)²) per
switch: it shrinks with Δt (halving Δt divides it by 2.8 here).
"""

import numpy as np
import pytest

from lccopt.vti.newmark import integrate
from lccopt.vti.unilateral import sleeper_supports
from tests.vti.test_voids import discrete_track

# seconds a test: simulations at several time steps
pytestmark = pytest.mark.slow


def run_balance(dt, speed=20.0, load=100e3):
    tr = discrete_track()
    sup = sleeper_supports(tr, np.arange(15, 45))
    gaps = np.zeros(30)
    gaps[[12, 13, 15]] = [0.3e-3, 0.1e-3, 0.2e-3]
    sup = sup.with_gaps(gaps)
    dof, k, c = sup.dof, sup.stiffness, sup.damping
    n = tr.K.shape[0]
    K0 = tr.K.tolil()
    C0 = tr.C.tolil()
    for d, kk, cc in zip(dof, k, c):
        K0[d, d] -= kk
        C0[d, d] -= cc
    K0, C0, M = K0.tocsr(), C0.tocsr(), tr.M.tocsr()
    x_start = float(sup.x[14]) - 3.0      # from x = 14.9 m over the voids to x = 22.1 m
    steps = int(round(6.0 / (speed * dt)))
    rows, prev = [], {}

    def on_step(st):
        u, v, contact = st.u, st.v, st.contact
        f = np.zeros(n)
        np.add.at(f, st.idx[0], load * st.vals[0])
        p = u[dof] + sup.rest - sup.gap
        phi = np.where(contact, k * p + c * v[dof], 0.0) - k * sup.rest
        cur = dict(u=u.copy(), v=v.copy(), f=f, p=p, phi=phi, s=contact.copy(), vs=v[dof].copy())
        if prev:
            q = prev
            du = cur["u"] - q["u"]
            vbar = 0.5 * (cur["v"] + q["v"])
            kin = 0.5 * (cur["v"] @ (M @ cur["v"]) - q["v"] @ (M @ q["v"]))
            strain = 0.5 * (cur["u"] @ (K0 @ cur["u"]) - q["u"] @ (K0 @ q["u"]))
            diss = dt * vbar @ (C0 @ vbar)
            work = du @ (0.5 * (cur["f"] + q["f"]))
            dsup = du[dof]
            support = np.sum(0.5 * (cur["phi"] + q["phi"]) * dsup)
            spring = 0.5 * k * (cur["s"] * cur["p"] ** 2 - q["s"] * q["p"] ** 2)
            damper = 0.5 * c * (q["s"] * q["vs"] + cur["s"] * cur["vs"]) * dsup
            weight = -k * sup.rest * dsup
            switch = cur["s"] != q["s"]
            sign = np.where(cur["s"], -1, 1)
            r_switch = np.where(switch, 0.5 * k * q["p"] * cur["p"] * sign, 0.0)
            rows.append((kin + strain + diss + support - work, kin, strain, diss, work,
                         np.sum(spring + damper + weight) - support, r_switch.sum(),
                         switch.sum(), np.abs(0.5 * k * q["p"] * cur["p"])[switch].sum()))
        prev.clear()
        prev.update(cur)

    integrate(tr, dt, speed, x_start, steps, load=load, supports=sup, on_step=on_step)
    return np.array(rows), k


def test_energy_balance_with_contact_switching_is_exact_and_the_switch_residual_shrinks_as_dt2():
    r1, k = run_balance(2e-4)
    balance, scale = r1[:, 0], np.abs(r1[:, 1:5]).sum()
    assert r1[:, 7].sum() >= 4                                  # sleepers did switch
    step_scale = np.max(np.abs(r1[:, 1:5]).sum(axis=1))
    assert np.max(np.abs(balance)) < 1e-9 * step_scale            # round-off, step by step
    assert abs(balance.sum()) < 1e-10 * scale
    # energy of the spring + damper dissipation + weight work vs the trapezoidal support work:
    # they differ by exactly -R per switch, R = ±½ k p p'
    split_gap = r1[:, 5]
    assert np.allclose(split_gap, -r1[:, 6], atol=1e-12 * scale)
    assert np.all(np.abs(r1[:, 6]) <= r1[:, 8] + 1e-15)
    r2, _ = run_balance(1e-4)
    res1, res2 = np.abs(r1[:, 6]).sum(), np.abs(r2[:, 6]).sum()
    assert res1 > 0
    # per switch O(k (v dt)^2); measured: halving dt divides it by 2.8 (27 switches either way)
    assert res1 / res2 > 2.0
    # and it is small against the energy the ballast dissipates
    assert res2 < 0.05 * r2[:, 3].sum()
