"""A case with degradation: evaluated as the optimiser's workers evaluate it
(lccopt.problem.evaluate -> lccopt.degradation.assessment): the paper's objectives are those of
the plain simulation, the settlement objectives those of predict_settlement called by hand,
two identical conditions of half the traffic settle as one of all of it, and conditions that
run the other way (another mesh) settle the same sleepers together. Coarse, short versions
(1 ms steps, 0.1 m elements, one year, 10 settling sleepers)."""

from __future__ import annotations

import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.degradation.assessment import (
    predict,
    settlement_objectives,
    slab_settlement,
    sleeper_law,
)
from lccopt.degradation.iteration import predict_settlement
from lccopt.degradation.laws import LI_SELIG, VarandasLaw
from lccopt.degradation.loading import entry_zone, vti_passage_kind
from lccopt.problem import Problem, evaluate
from lccopt.vti.passage import simulate_passage as simulate
from lccopt.vti.response import SETTLEMENT_OBJECTIVES
from lccopt.vti.track import build_track
from lccopt.vti.vehicle import build_vehicle
from tests.conftest import CONFIGS

# seconds a test: settlement predictions of whole cases
pytestmark = pytest.mark.slow

BOGIE = (CONFIGS / "vehicles" / "virm-bogie.yaml").as_posix()
CHEAP = """simulation: {time_step: 1.0e-3, element_length: 0.1, far_element_length: 0.6,
             run_in: 2.0, run_out: 1.0}
"""


def cheap_case(tmp_path, degradation: str, extra: str = "", name: str = "c"):
    p = tmp_path / f"{name}.yaml"
    p.write_text(f"extends: {BOGIE}\nname: {name}\n{CHEAP}degradation:\n{degradation}{extra}",
                 encoding="utf-8")
    return load_case(p)


ONE_YEAR = """  horizon_years: 1
  settling_sleepers: 10
  tolerance: 4 kN
"""


@pytest.fixture(scope="module")
def single(tmp_path_factory):
    case = cheap_case(tmp_path_factory.mktemp("single"),
                      "  passages_per_year: 5.0e5\n" + ONE_YEAR)
    return case, evaluate(case, case.reference)


def test_a_case_evaluation_is_the_simulation_and_the_prediction_it_says(single):
    case, ev = single
    plain = simulate(case.scenario(), case.track_design(case.reference))
    for k in ("F_rms", "F_max", "E_rms", "E_max"):
        assert ev.objectives[k] == plain.objectives[k]
    np.testing.assert_array_equal(ev.histories["contact_force"], plain.histories["contact_force"])
    # the prediction by hand, as benchmarks/settlement/settlement.py builds it
    tr = build_track(case.scenario(), case.track_design(case.reference))
    veh = build_vehicle(case.scenario().vehicle)
    x0, _, _, x1 = tr.window
    dt = case.simulation["time_step"]
    cond = vti_passage_kind("vehicle", 5.0e5, tr, veh, dt=dt, speed=veh.speed, x_start=x0,
                         n_steps=int(np.ceil((x1 - x0) / (veh.speed * dt))))
    spec = case.degradation_spec()
    law = sleeper_law(spec, tr, case.data["track"]["support"]["stiffness"])
    r = predict_settlement(tr, entry_zone(tr, 10), [cond], horizon_years=1.0, law=law,
                           tolerance=4e3, slab=slab_settlement(spec, [cond]))
    np.testing.assert_array_equal(ev.histories["settlement_sleepers"], r.settlement)
    np.testing.assert_array_equal(ev.histories["settlement_void"], r.void)
    np.testing.assert_array_equal(ev.histories["settlement_axle_passes"], r.axle_passes)
    o = r.objectives("differential_settlement", 3e-3)
    for k in SETTLEMENT_OBJECTIVES[:9]:
        assert ev.objectives[k] == o[k]
    assert ev.objectives["years_to_limit"] == pytest.approx(o["passes_to_limit"] / 1.0e6)
    assert ev.info["settlement_simulations"] == r.n_simulations
    assert ev.info["settlement_conditions"] == "vehicle"


def test_years_to_limit_is_when_the_measure_reaches_the_limit(single):
    """Linear between blocks; maintenance_rate is its inverse; the horizon when the limit is
    never reached."""
    case, ev = single
    h = ev.histories
    d = np.ptp(h["settlement_sleepers"], axis=1)
    years = h["settlement_years"]
    o = ev.objectives
    assert o["maintenance_rate"] * o["years_to_limit"] == pytest.approx(1.0)
    below = d[-1] < 3e-3
    assert ev.info["settlement_limit_reached"] == (not below)
    if below:
        assert o["years_to_limit"] == pytest.approx(1.0)
    # a limit it does reach: the first block past it brackets the time
    from lccopt.degradation.inputs import Limit
    from lccopt.degradation.iteration import SettlementResult

    r = SettlementResult(years=years, axle_passes=h["settlement_axle_passes"],
                         settlement=h["settlement_sleepers"], void=h["settlement_void"],
                         level=h["settlement_level"], level_x=h["settlement_level_x"],
                         peak_force=h["settlement_peak_force"],
                         wheel_force_max=h["settlement_wheel_force_max"],
                         simulated=h["settlement_simulated"].astype(bool),
                         sleeper_x=h["settlement_sleeper_x"], conditions=("vehicle",),
                         n_simulations=1)
    half = 0.5 * d[-1]
    got = settlement_objectives(r, Limit("differential_settlement", half))["years_to_limit"]
    i = int(np.flatnonzero(d >= half)[0])
    assert years[i - 1] < got <= years[i]


def test_two_identical_conditions_of_half_the_traffic_settle_as_one(tmp_path, single):
    """Both conditions load every sleeper as the one did, half as often: the law sees the same
    load histogram, so the settlement is the same; each simulation point simulates both."""
    _, one = single
    case = cheap_case(tmp_path, "  traffic: {a: 2.5e5, b: 2.5e5}\n" + ONE_YEAR,
                      "conditions: [{name: a, vehicle: case}, {name: b, vehicle: case}]\n")
    assert case.conditions == () and len(case.traffic) == 2
    two = evaluate(case, case.reference)
    np.testing.assert_allclose(two.histories["settlement_sleepers"][-1],
                               one.histories["settlement_sleepers"][-1], atol=1e-6)
    assert two.info["settlement_simulations"] == 2 * one.info["settlement_simulations"]
    assert two.histories["settlement_peak_force"].shape[1] == 2
    assert two.objectives["F_max"] == one.objectives["F_max"]
    assert two.objectives["F_max@a"] == two.objectives["F_max@b"] == one.objectives["F_max"]


def test_conditions_on_other_meshes_settle_the_same_sleepers_together(tmp_path):
    """A bogie leaving the crossing runs from beyond the slab: its track model has another
    mesh, and its simulations take the zone's gaps on its own supports. Both directions load
    the approach, so both together settle it more than the entering traffic alone."""
    deg = "  traffic: {enter: 2.5e5, leave: 2.5e5}\n" + ONE_YEAR
    case = cheap_case(tmp_path, deg, "conditions: [{name: enter, vehicle: case},\n             "
                                     "{name: leave, vehicle: case, direction: leave}]\n")
    tracks = [build_track(case.condition_case(i).scenario(), case.track_design(case.reference))
              for i in range(2)]
    assert tracks[0].n_dofs != tracks[1].n_dofs                  # another mesh
    ev = evaluate(case, case.reference)
    h = ev.histories
    sim = h["settlement_simulated"].astype(bool)
    assert np.all(np.isfinite(h["settlement_wheel_force_max"][sim]))   # both, every time
    assert np.all(h["settlement_peak_force"][-1] > 10e3)
    alone = cheap_case(tmp_path, "  passages_per_year: 2.5e5\n" + ONE_YEAR, name="alone")
    base = evaluate(alone, alone.reference)
    assert np.all(h["settlement_sleepers"][-1] > base.histories["settlement_sleepers"][-1])


def test_e_max_alone_fits_the_sleepers_energies_only_of_one_simulation(tmp_path):
    one = cheap_case(tmp_path, "  passages_per_year: 5.0e5\n",
                     "optimisation: {objectives: [E_max], budget: 10}\n", name="e1")
    two = cheap_case(tmp_path, "  traffic: {a: 1.0e5, b: 1.0e5}\n",
                     "optimisation: {objectives: [E_max], budget: 10}\nconditions: [{name: a, "
                     "vehicle: case}, {name: b, vehicle: case, speed: 100 km/h}]\n", name="e2")
    assert Problem.from_case(one).surrogate == "sleeper-energies"
    assert Problem.from_case(two).surrogate == "scalar"      # E_max is the worst of two


def test_the_law_of_each_sleeper_is_fed_its_pressure_and_its_subgrade(tmp_path):
    """The reference design's 8 strengthened sleepers (1.25x the base, by default as their
    support stiffness) are fed 1/1.25 of their force; the standard ones their force; the
    subgrade's strength follows the case's support stiffness."""
    case = cheap_case(tmp_path, "  passages_per_year: 5.0e5\n" + ONE_YEAR)
    spec = case.degradation_spec()
    assert spec.strengthened_bearing_area == pytest.approx(1.25 * spec.bearing_area)
    tr = build_track(case.scenario(), case.track_design(case.reference))
    law = sleeper_law(spec, tr, 45e6)
    np.testing.assert_allclose(law.pressure_scale, [1 / 1.25] * 8 + [1.0] * 2)
    soft = sleeper_law(spec, tr, 22.5e6)
    assert soft.subgrade.constant(40e3, 1e6)[-1] == pytest.approx(
        2 ** soft.subgrade.exponent * law.subgrade.constant(40e3, 1e6)[-1])
    assert isinstance(law.ballast, VarandasLaw)


SOFT = """  track: {support: {stiffness: 22.5 MN/m},
          strengthened_sleeper: {support_stiffness: 28.125 MN/m}}
"""


@pytest.mark.parametrize("soil", ["none", "CL"])
def test_a_soft_subgrade_settles_as_the_docs_say(tmp_path, soil):
    """docs/settlement.md, "A softer subgrade is a weaker one": halving the support stiffness
    (a soft subgrade, the strengthened sleepers' too) spreads each wheel over more sleepers,
    so the ballast law alone (soil: none) predicts *less* settlement and a better rail; with
    the subgrade layer, whose strength falls with its stiffness, the approach settles *more*,
    the slab on the same soil 2^m times as much, and the rail measures do not get worse."""
    deg = f"  passages_per_year: 5.0e5\n{ONE_YEAR}  subgrade: {{soil: {soil}}}\n"
    out, slab = {}, {}
    for name, extra in (("stiff", ""), ("soft", SOFT)):
        case = cheap_case(tmp_path, deg, extra.replace("  track:", "track:"), name=name)
        r = predict(case.degradation_spec(), case.track_design(case.reference))
        out[name] = r.objectives("differential_settlement", 3e-3)
        slab[name] = r.rail["slab"][-1]
    soft, stiff = out["soft"], out["stiff"]
    if soil == "none":
        for k in ("max_settlement", "differential_settlement", "level_d1_max", "rail_step"):
            assert soft[k] < stiff[k], k
        assert slab["soft"] == slab["stiff"] == 0.0
    else:
        assert soft["max_settlement"] > 1.1 * stiff["max_settlement"]
        assert soft["differential_settlement"] > stiff["differential_settlement"]
        assert slab["soft"] / slab["stiff"] == pytest.approx(2.0 ** LI_SELIG["CL"][2])
        for k in ("level_d1_max", "rail_step"):
            assert stiff[k] * 0.9 < soft[k] <= stiff[k] * 1.02, k


def test_tamping_lifts_the_reachable_sleepers_and_leaves_the_others(tmp_path):
    """Each time the limit is reached, the sleepers the machine reaches are lifted to the
    slab's level (gap 0 in the track model) and the 2 next to the slab are not; the tamped
    track is below the limit again; interventions counts the tampings and years_to_limit is
    the first."""
    deg = ("  passages_per_year: 5.0e5\n  horizon_years: 0.45\n  settling_sleepers: 10\n"
           "  tolerance: 4 kN\n  max_simulations: 60\n"
           "  limit: {measure: level_d1_max, value: 1.2 mm}\n"
           "  tamping: {unreachable_sleepers: 2, min_interval: 0.05}\n")
    case = cheap_case(tmp_path, deg)
    ev = evaluate(case, case.reference)
    h = ev.histories
    tamped = h["settlement_tamped"].astype(bool)
    rows = np.flatnonzero(tamped)
    assert len(rows) >= 2 and ev.objectives["interventions"] == len(rows)
    s, slab = h["settlement_sleepers"], h["settlement_slab"]
    d1 = h["settlement_level_d1_max"]
    years = h["settlement_years"]
    for i in rows:
        np.testing.assert_allclose(s[i, 2:], slab[i], atol=1e-12)      # lifted to the slab
        np.testing.assert_allclose(s[i, :2], s[i - 1, :2], atol=1e-15)    # out of reach
        assert s[i - 1, 2:].max() > slab[i] + 0.5e-3                     # they had settled
        assert years[i] == years[i - 1]
        assert d1[i - 1] >= 0.5e-3 > d1[i]
        assert h["settlement_simulated"][i]                              # the new track, simulated
    assert np.diff(years[rows]).min() >= 0.05 - 1e-9
    assert not ev.info["settlement_budget_bound"]
    assert ev.objectives["years_to_limit"] == pytest.approx(years[rows[0]])
    # the sleepers out of reach hang: the tamped neighbours hold the rail up
    assert h["settlement_void"][-1, :2].max() > 0.5e-3
    # the tamped track's state is judged at its worst over the horizon, whatever the moment
    # of the tamping cycle the horizon falls on: the limit's measure is the limit, reached
    # before each tamping (a block passes it by at most 2 %), not its last row's value
    o = ev.objectives
    assert 1.2e-3 <= o["level_d1_max"] == d1.max() <= 1.2e-3 * 1.02
    for k in ("level_d1_std", "rail_step", "rail_angle", "level_std"):
        assert o[k] == h[f"settlement_{k}"].max() > h[f"settlement_{k}"][rows].min(), k
    assert o["max_void"] == h["settlement_void"].max()
    sims = h["settlement_simulated"].astype(bool)
    wheel = h["settlement_wheel_force_max"][sims]
    assert o["force_growth"] == pytest.approx(wheel.max() / wheel[0].max())
