"""The settlement iteration (lccopt/degradation/iteration.py): plausibility on a uniform track
and at the ERS interface, the law's parameter, and convergence as the blocks shrink. Short
versions (cheap runs) of benchmarks/settlement.py."""

import numpy as np
import pytest

from lccopt.case import load_case
from lccopt.degradation.iteration import Condition, predict_settlement
from lccopt.degradation.laws import VarandasLaw
from lccopt.degradation.loading import Loading, SettlementZone, entry_zone, vti_condition
from lccopt.vti.newmark import integrate
from lccopt.vti.track import build_track
from lccopt.vti.unilateral import sleeper_supports
from lccopt.vti.vehicle import Vehicle
from tests.vti.test_voids import discrete_track


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


def moving_load_condition(tr, x_from, x_to, speed=20.0, load=100e3, dt=1e-3, per_year=1e6):
    steps = int(round((x_to - x_from) / (speed * dt)))

    def simulate(sup):
        h = integrate(tr, dt, speed, x_from, steps, load=load, supports=sup)
        return Loading(h.support_force.max(axis=0)[None, :], float(h.contact_force.max()))
    return Condition("load", per_year, simulate)


def test_uniform_track_settles_uniformly():
    tr = discrete_track(n_sleepers=60)
    settling = np.arange(15, 45)                       # x from 27.0 m down to 9.6 m
    zone = uniform_zone(tr, settling)
    cond = moving_load_condition(tr, 6.0, 30.0)
    r = predict_settlement(tr, zone, [cond], horizon_years=5.0, tolerance=0.1e-3)
    s = r.settlement[-1]
    assert s.mean() > 3e-3                             # millimetres after 5e6 passes
    assert np.ptp(s) < 0.01 * s.mean()
    assert r.void[-1].max() < 1e-6 and r.info["truncated"] is False
    # one block or a few: nothing differential to resolve
    assert r.info["blocks"] <= 3


def reference_setup(x=None):
    case = load_case("configs/reference.yaml").with_simulation(
        time_step=1e-3, element_length=0.1, run_in=2.0, run_out=1.0)
    case.data["vehicle"]["model"] = "quarter-car"     # no fixed point (docs/settlement.md)
    tr = build_track(case, case.reference if x is None else np.asarray(x, float))
    veh = Vehicle.from_case(case)
    x0, _, _, x1 = tr.window
    dt = case.simulation["time_step"]
    n = int(np.ceil((x1 - x0) / (veh.speed * dt)))
    cond = Condition("quarter-car", 1e6,
                     vti_condition(tr, veh, dt=dt, speed=veh.speed, x_start=x0, n_steps=n))
    return tr, entry_zone(tr, 20), cond


@pytest.fixture(scope="module")
def reference_run():
    tr, zone, cond = reference_setup()
    return predict_settlement(tr, zone, [cond], horizon_years=0.02, tolerance=0.4e-3)


def test_the_ers_interface_makes_a_dip_on_the_ballast_side(reference_run):
    """The slab does not settle, the ballast does: next to the interface the rail hangs from
    the slab (voids), and a few sleepers further the settlement exceeds the open track's."""
    r = reference_run
    s, far = r.settlement[-1], r.settlement[-1, -1]
    dip = int(np.argmax(s))
    assert 1 <= dip <= 8 and s[dip] > far + 1e-3          # the dip, a metre or more from the slab
    assert r.void[-1, :3].max() > 0.5e-3                   # hanging sleepers at the interface
    assert r.void[-1, -5:].max() < 1e-6                    # none in the open track
    assert not r.info["truncated"]
    assert r.measure("differential_settlement")[-1] > 1e-3
    assert np.all(np.diff(r.measure("level_std")) >= -1e-5)  # the geometry only gets worse
    assert r.wheel_force_max[-1, 0] > r.wheel_force_max[0, 0]   # the dip amplifies the force


def test_a_stiffer_law_parameter_settles_less():
    tr, zone, cond = reference_setup()
    soft = predict_settlement(tr, zone, [cond], horizon_years=0.005, tolerance=0.5e-3)
    stiff = predict_settlement(tr, zone, [cond], horizon_years=0.005, tolerance=0.5e-3,
                               law=VarandasLaw(gamma=5e-3))
    assert np.all(stiff.settlement[-1] < soft.settlement[-1])
    assert stiff.measure("max_settlement")[-1] < 0.7 * soft.measure("max_settlement")[-1]


@pytest.mark.xfail(strict=True, reason=(
    "known gap: the explicit block update (loads frozen over a block) is unstable for the "
    "checkerboard mode (a sleeper that settles more loses its load to its neighbours) unless "
    "every block's settlement increment is small; at 0.4 mm it oscillates and needs more blocks "
    "than at 0.2 mm. A semi-implicit update with the load-redistribution stiffness is the fix "
    "(docs/settlement.md, 'Limits')."))
def test_settlement_converges_as_the_blocks_shrink():
    tr, zone, cond = reference_setup()
    runs = [predict_settlement(tr, zone, [cond], horizon_years=0.002, tolerance=tol)
            for tol in (0.4e-3, 0.2e-3, 0.1e-3)]
    blocks = [r.info["blocks"] for r in runs]
    assert blocks[0] < blocks[1] < blocks[2]
    prof = np.array([r.settlement[-1] for r in runs])
    d1 = np.max(np.abs(prof[1] - prof[0]))
    d2 = np.max(np.abs(prof[2] - prof[1]))
    assert d2 < 0.7 * d1                                     # first order: about halves
    assert d2 < 0.05 * prof[2].max()
