"""The settlement iteration (lccopt/degradation/iteration.py) on converged runs: a uniform track
settles uniformly, the ERS interface makes a dip on the ballast side with hanging sleepers next
to the slab, a stiffer law parameter settles less, and the 10-year result converges as the
tolerance shrinks. Short versions (coarse time step and mesh) of
benchmarks/settlement/settlement.py."""

import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.degradation.blocks import SleeperLoads, implicit_block
from lccopt.degradation.iteration import predict_settlement
from lccopt.degradation.laws import VarandasLaw
from lccopt.degradation.loading import (
    Axles,
    Loading,
    PassageKind,
    SettlementZone,
    entry_zone,
    vti_passage_kind,
)
from lccopt.degradation.statics import ZoneStatics
from lccopt.vti.newmark import integrate
from lccopt.vti.track import build_track
from lccopt.vti.unilateral import sleeper_supports
from lccopt.vti.vehicle import build_vehicle
from tests.vti.test_voids import discrete_track

# seconds a test: settlement predictions over many blocks of simulations
pytestmark = pytest.mark.slow

YEARS = 10.0
PER_YEAR = 1.0e6          # passes of the one-wheel quarter car: 10^7 axle passes in 10 years


def uniform_zone(tr, settling, taper=6.0):
    """Sleepers ``settling`` (indices) settle; all others follow the last of them, tapering to
    zero over ``taper`` metres before the rail's pinned ends."""
    n = len(tr.sleeper_x)
    others = np.setdiff1d(np.arange(n), settling)
    x = tr.sleeper_x[others]
    to_end = np.minimum(x, tr.node_x[-1] - x)
    w = np.clip((to_end - 1.0) / taper, 0.0, 1.0)
    w = 0.5 - 0.5 * np.cos(np.pi * w)
    keep = w > 0
    idx = np.concatenate([settling, others[keep]])
    return SettlementZone(sleeper_supports(tr, idx), len(settling), w[keep])


def moving_load_condition(tr, x_from, x_to, speed=20.0, load=100e3, dt=1e-3):
    steps = int(round((x_to - x_from) / (speed * dt)))

    def simulate(sup):
        h = integrate(tr, dt, speed, x_from, steps, load=load, supports=sup)
        return Loading(h.support_force.max(axis=0)[None, :], float(h.contact_force.max()))
    return PassageKind("load", PER_YEAR, simulate, Axles(np.zeros(1), np.array([load])))


def test_uniform_track_settles_uniformly():
    tr = discrete_track(n_sleepers=60)
    settling = np.arange(15, 45)                       # x from 27.0 m down to 9.6 m
    zone = uniform_zone(tr, settling)
    cond = moving_load_condition(tr, 6.0, 30.0)
    r = predict_settlement(tr, zone, [cond], horizon_years=YEARS)
    s = r.settlement[-1]
    expected = VarandasLaw().constant(r.peak_force[0, 0].mean(), YEARS * PER_YEAR)
    assert s.mean() == pytest.approx(expected, rel=0.02)   # the law's constant-load curve
    assert np.ptp(s) < 0.01 * s.mean()
    assert r.void[-1].max() < 1e-6
    # nothing differential to resolve: the loads between simulations are right to < 100 N
    # (the moving load's dynamics), so the profile allowance triples at every simulation
    assert max(r.info["load_errors"]) < 100.0
    assert r.n_simulations <= 6 and not r.info["budget_bound"]


def reference_setup(x=None, per_year=PER_YEAR):
    case = load_case("configs/reference.yaml").with_simulation(
        time_step=1e-3, element_length=0.1, run_in=2.0, run_out=1.0)
    case.data["vehicle"]["model"] = "quarter-car"     # no fixed point (docs/settlement.md)
    design = case.reference if x is None else np.asarray(x, float)
    tr = build_track(case.scenario(), case.track_design(design))
    veh = build_vehicle(case.scenario().vehicle)
    x0, _, _, x1 = tr.window
    dt = case.simulation["time_step"]
    n = int(np.ceil((x1 - x0) / (veh.speed * dt)))
    cond = vti_passage_kind("quarter-car", per_year, tr, veh, dt=dt, speed=veh.speed,
                         x_start=x0, n_steps=n)
    return tr, entry_zone(tr, 20), cond


@pytest.fixture(scope="module")
def reference():
    tr, zone, cond = reference_setup()
    return tr, zone, cond, predict_settlement(tr, zone, [cond], horizon_years=YEARS)


def test_the_ers_interface_makes_a_dip_on_the_ballast_side(reference):
    """The slab does not settle, the ballast does: next to the interface the rail hangs from
    the slab (voids), and a few sleepers further the settlement exceeds the open track's."""
    r = reference[3]
    s, far = r.settlement[-1], r.settlement[-1, -1]
    dip = int(np.argmax(s))
    assert 2 <= dip <= 8 and s[dip] > far + 2e-3           # the dip, 1.5-5 m from the slab
    assert s[0] < far - 2e-3                                # held up by the slab
    assert r.void[-1, :3].min() > 2e-3                      # hanging sleepers at the interface
    assert r.void[-1, -8:].max() < 1e-6                     # none in the open track
    assert np.all(np.abs(np.diff(s[10:])) < 0.5e-3)         # smooth: no checkerboard
    assert r.n_simulations <= 30
    assert r.axle_passes[-1] == pytest.approx(YEARS * PER_YEAR)
    assert np.all(np.diff(r.measure("level_std")) >= -1e-6)   # the geometry only gets worse
    assert r.objectives()["force_growth"] > 1.05               # the dip amplifies the force


def test_a_stiffer_law_parameter_settles_less(reference):
    tr, zone, cond, soft = reference
    stiff = predict_settlement(tr, zone, [cond], horizon_years=YEARS,
                               law=VarandasLaw(gamma=5e-3))
    assert np.all(stiff.settlement[-1] < soft.settlement[-1])
    assert stiff.measure("max_settlement")[-1] < 0.6 * soft.measure("max_settlement")[-1]
    assert (stiff.measure("differential_settlement")[-1]
            < soft.measure("differential_settlement")[-1])


def test_softer_pads_next_to_the_slab_shrink_the_voids(reference):
    """The paper's design idea (soft pads at the interface, Sec. 4.2) on the converged 10-year
    result: with 50 MN/m pads on the three sleepers nearest the slab (the rest as the
    reference) the voids there shrink by a third or more and the wheel force grows less. (The
    spread of settlement within the zone does not shrink: docs/settlement.md.)"""
    _, _, _, ref = reference
    tr, zone, cond = reference_setup([50e6, 50e6, 50e6, 8, 6, 6, 4, 0])
    soft = predict_settlement(tr, zone, [cond], horizon_years=YEARS)
    assert soft.measure("max_void")[-1] < 0.7 * ref.measure("max_void")[-1]
    assert soft.measure("max_settlement")[-1] < ref.measure("max_settlement")[-1]
    assert soft.objectives()["force_growth"] < ref.objectives()["force_growth"] - 0.05


def test_settlement_converges_as_the_tolerance_shrinks(reference):
    """Halving the load tolerance (2 -> 1 kN) moves the 10-year profile by < 0.15 mm and the
    differential settlement by < 0.1 mm (about 1 %), less than the step before (4 -> 2 kN);
    it costs more simulations."""
    tr, zone, cond, mid = reference
    coarse = predict_settlement(tr, zone, [cond], horizon_years=YEARS, tolerance=4e3)
    fine = predict_settlement(tr, zone, [cond], horizon_years=YEARS, tolerance=1e3,
                              max_simulations=60)
    assert coarse.n_simulations < mid.n_simulations < fine.n_simulations
    assert not fine.info["budget_bound"]
    d1 = np.max(np.abs(mid.settlement[-1] - coarse.settlement[-1]))
    d2 = np.max(np.abs(fine.settlement[-1] - mid.settlement[-1]))
    assert d2 < 0.15e-3 and d2 < d1
    diff = [r.measure("differential_settlement")[-1] for r in (coarse, mid, fine)]
    assert abs(diff[2] - diff[1]) < 0.1e-3


def test_implicit_blocks_are_stable_where_explicit_ones_make_a_checkerboard(reference):
    """10^6 passes on the statics alone (no dynamic part) in 80 blocks spaced in log N: with the
    loads of each block's end (implicit) the profile is smooth and one single block lands
    within 1 mm of it; with the loads of each block's start (explicit) a sleeper that settled
    more sheds its load, settles less in the next block, and the profile zigzags."""
    tr, zone, cond, _ = reference
    law = VarandasLaw()
    loads = SleeperLoads(ZoneStatics(tr, zone.supports), zone, [cond], 1.0)
    n = zone.n_settling
    ends = np.unique(np.round(np.logspace(0, 6, 80)))
    implicit, explicit = np.zeros(n), np.zeros(n)
    s_imp, s_exp, done = law.start(n), law.start(n), 0.0
    for end in ends:
        cycles = np.array([end - done])
        implicit, rows = implicit_block(law, s_imp, implicit, loads, cycles)
        np.testing.assert_allclose(implicit, law.settlement(law.add(s_imp, rows, cycles)),
                                   atol=1e-8)
        s_imp = law.add(s_imp, rows, cycles)
        s_exp = law.add(s_exp, loads(explicit, jacobian=False)[0], cycles)
        explicit = law.settlement(s_exp)
        done = end
    one, _ = implicit_block(law, law.start(n), np.zeros(n), loads, np.array([done]))
    assert np.max(np.abs(np.diff(implicit, 2))) < 1e-3          # the dip's own curvature
    assert np.max(np.abs(one - implicit)) < 1e-3
    assert np.max(np.abs(np.diff(explicit, 2))) > 3e-3


def test_bad_traffic_and_settings_are_refused(reference):
    tr, zone, cond, _ = reference
    idle = PassageKind("idle", 0.0, cond.simulate, cond.axles)
    for conditions, kw in (([], {}), ([idle], {}), ([cond], {"tolerance": 0.0}),
                           ([cond], {"max_simulations": 1}), ([cond], {"horizon_years": -1.0})):
        with pytest.raises(ValueError):
            predict_settlement(tr, zone, conditions, **({"horizon_years": YEARS} | kw))
