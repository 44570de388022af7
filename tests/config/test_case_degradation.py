"""The degradation: section of a case (lccopt/config/degradation.py): what a valid one becomes
(defaults of the chosen law, the horizon, the settlement prediction's typed inputs) and what is
refused with one line `file:line: key: message`: the paper's three-dof vehicle, a traffic or
horizon without load cycles, a prediction that costs too much, settling sleepers the runs do
not pass whole, objectives that need a prediction."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

from lccopt.config import load_case
from lccopt.degradation.rail import MEASURES
from lccopt.errors import CaseError
from tests.conftest import CONFIGS

BOGIE = (CONFIGS / "vehicles" / "virm-bogie.yaml").as_posix()
TRAFFIC = (CONFIGS / "traffic.yaml").as_posix()


def case_file(tmp_path, body: str, base: str = BOGIE, name: str = "deg"):
    p = tmp_path / f"{name}.yaml"
    p.write_text(f"extends: {base}\nname: {name}\n{body}", encoding="utf-8")
    return p


def refused(tmp_path, body: str, key: str, words: str, base: str = BOGIE):
    """load_case raises one line naming the file, a line, ``key`` and ``words``."""
    p = case_file(tmp_path, body, base)
    with pytest.raises(CaseError) as e:
        load_case(p)
    msg = str(e.value)
    assert "\n" not in msg
    assert re.match(rf"{re.escape(str(p))}:\d+: {re.escape(key)}: ", msg), msg
    assert words in msg, msg
    return msg


def test_configs_settlement_is_the_paper_crossing_under_ten_years_of_virm_bogies():
    case = load_case(CONFIGS / "settlement.yaml")
    spec = case.degradation_spec()
    assert spec.horizon_years == 10.0 and spec.settling_sleepers == 20
    (t,) = spec.traffic
    assert t.passages_per_year == 170 * 4 * 2 * 365 and t.scenario.vehicle.type == "bogie"
    assert spec.law.name == "varandas"
    assert dict(spec.law.parameters) == {"alpha": 0.6, "beta": 0.82, "gamma": 0.01, "f0": 50e3,
                                         "n0": 1e6}
    assert (spec.limit.measure, spec.limit.value) == ("level_d1_max", 2e-3)
    # it optimises the rail's measure with tamping: how often the rail's D1 level reaches its
    # limit and has to be tamped, the two sleepers by the slab out of the machine's reach
    assert spec.limit.measure in MEASURES
    assert (spec.tamping.unreachable_sleepers, spec.tamping.min_interval) == (2, 0.1)
    assert list(case.optimisation["objectives"]) == ["interventions", "maintenance_rate"]
    assert case.conditions == () and case.traffic == ()      # one task per design
    # the resolved case (what a run keeps) says what the prediction ran with: the law's
    # defaults and the horizon, none of the other law's keys
    deg = yaml.safe_load(case.resolved)["degradation"]
    assert deg["law"] == {"name": "varandas", "alpha": 0.6, "beta": 0.82, "gamma": 0.01,
                          "reference_force": 50e3, "reference_cycles": 1e6}
    assert deg["horizon_years"] == 10.0 and "horizon_axle_passes" not in deg


def test_a_case_without_degradation_resolves_as_before():
    assert "degradation" not in yaml.safe_load(load_case(CONFIGS / "moo.yaml").resolved)


def test_quantities_take_their_units(tmp_path):
    case = load_case(case_file(tmp_path, """degradation:
  passages_per_year: 1370 /day
  horizon_years: 20 years
  tolerance: 1.5 kN
  law: {gamma: 8 mm, reference_force: 60 kN}
  limit: {measure: max_void, value: 2 mm}
"""))
    spec = case.degradation_spec()
    assert spec.traffic[0].passages_per_year == pytest.approx(1370 * 365)
    assert spec.horizon_years == 20.0 and spec.tolerance == 1500.0
    assert dict(spec.law.parameters)["gamma"] == pytest.approx(8e-3)
    assert dict(spec.law.parameters)["f0"] == 60e3
    assert (spec.limit.measure, spec.limit.value) == ("max_void", pytest.approx(2e-3))


def test_a_horizon_in_axle_passes_becomes_years_of_the_traffic(tmp_path):
    case = load_case(case_file(tmp_path, "degradation:\n  passages_per_year: 5.0e5\n"
                                         "  horizon_axle_passes: 3.0e7\n"))
    assert case.degradation_spec().horizon_years == pytest.approx(30.0)   # 2 axles a bogie
    # the resolved copy (what a run keeps, and report loads again) gives it once, in years
    again = tmp_path / "resolved.yaml"
    again.write_text(case.resolved, encoding="utf-8")
    assert load_case(again, resolved=True).degradation_spec().horizon_years == pytest.approx(30.0)


def test_the_logarithmic_law_takes_its_own_parameters(tmp_path):
    case = load_case(case_file(tmp_path, """degradation:
  passages_per_year: 5.0e5
  law: {name: logarithmic, first_cycle: 0.5 mm, log_rate: 1.0}
"""))
    law = case.degradation_spec().law
    assert law.name == "logarithmic"
    assert dict(law.parameters) == {"first_cycle": pytest.approx(5e-4), "log_rate": 1.0,
                                    "exponent": 1.6, "f0": 50e3}


def test_traffic_conditions_each_have_their_passages(tmp_path):
    body = """track: {layout: {exit_length: 40.0}}
degradation:
  traffic: {virm-140-enter-smooth: 2.0e5, virm-160-leave-smooth: 1.0e5}
optimisation: {objectives: [differential_settlement], budget: 30, conditions: mean}
conditions:
  - {name: virm-140-enter-smooth, vehicle: virm, speed: 140 km/h, direction: enter,
     irregularity: none}
  - {name: virm-160-leave-smooth, vehicle: virm, speed: 160 km/h, direction: leave,
     irregularity: none, weight: 2}
  - {name: freight-100-enter-smooth, vehicle: freight, speed: 100 km/h, direction: enter,
     irregularity: none}
"""
    body = body.replace("virm-140-enter-smooth: 2.0e5,",
                        "virm-140-enter-smooth: 2.0e5, freight-100-enter-smooth: 0,")
    case = load_case(case_file(tmp_path, body, TRAFFIC))
    spec = case.degradation_spec()
    assert [t.name for t in spec.traffic] == ["virm-140-enter-smooth", "virm-160-leave-smooth",
                                              "freight-100-enter-smooth"]
    assert [t.name for t in spec.settling_traffic] == ["virm-140-enter-smooth",
                                                       "virm-160-leave-smooth"]
    assert [t.weight for t in spec.traffic] == [1.0, 2.0, 1.0]
    assert spec.condition_mode == "mean"
    assert case.conditions == () and len(case.traffic) == 3   # the engine does not split it
    from lccopt.problem import Problem

    problem = Problem.from_case(case)
    assert problem.conditions == () and problem.traffic == tuple(t.name for t in spec.traffic)


@pytest.mark.parametrize("body, key, words", [
    ("degradation: {passages_per_year: 5.0e5}\nvehicle: {type: three-dof}\n", "vehicle.type",
     "use type: bogie or half-car"),
    ("degradation: {passages_per_year: 5.0e5}\nvehicle: {type: three-dof, model: paper}\n",
     "vehicle.type", "fixed in space"),
    ("degradation: {horizon_years: 10}\n", "degradation", "missing key 'passages_per_year'"),
    ("degradation: {passages_per_year: 5.0e5, horizon_axle_passes: 0.5}\n",
     "degradation.horizon_axle_passes", "less than one load cycle"),
    ("degradation: {passages_per_year: 5.0e5, horizon_years: 1.0e-7}\n",
     "degradation.horizon_years", "less than one load cycle"),
    ("degradation: {passages_per_year: 5.0e5, horizon_years: 1, horizon_axle_passes: 1e6}\n",
     "degradation.horizon_axle_passes", "give the horizon once"),
    ("degradation: {passages_per_year: 0}\n", "degradation.passages_per_year", "must be > 0"),
    ("degradation: {passages_per_year: 5.0e5, traffic: {a: 1}}\n", "degradation.traffic",
     "no conditions: list"),
    ("degradation: {passages_per_year: 5.0e5, law: {name: logarithmic, log_rate: 1}}\n",
     "degradation.law", "missing key 'first_cycle': the logarithmic law has no published"),
    ("degradation:\n  passages_per_year: 5.0e5\n  law: {name: logarithmic, first_cycle: 1 mm,"
     " log_rate: 1, alpha: 0.6}\n", "degradation.law.alpha", "a parameter of the varandas law"),
    ("degradation: {passages_per_year: 5.0e5, law: {beta: 1.0}}\n", "degradation.law.beta",
     "must be <= 0.99"),
    ("degradation: {passages_per_year: 5.0e5, settling_sleepers: 21}\n",
     "degradation.settling_sleepers", "at most 20"),
    ("degradation: {passages_per_year: 5.0e5, follower_flat: 60, follower_taper: 30}\n",
     "degradation.follower_taper", "reach the rail's pinned end"),
    ("degradation: {passages_per_year: 5.0e5, limit: {measure: force_growth}}\n",
     "degradation.limit.measure", "must be one of"),
    ("degradation: {passages_per_year: 5.0e5, horizon_years: 10 km}\n",
     "degradation.horizon_years", "unknown unit 'km'"),
    ("optimisation: {objectives: [max_void], budget: 10}\n", "optimisation.objectives",
     "needs a degradation: section"),
    ("degradation: {passages_per_year: 5.0e5}\noptimisation: {objectives: [years_to_limit], "
     "budget: 10}\n", "optimisation.objectives", "minimise maintenance_rate"),
    # tamping settings out of range
    ("degradation: {passages_per_year: 5.0e5, tamping: {unreachable_sleepers: 20}}\n",
     "degradation.tamping.unreachable_sleepers", "no sleeper would be tamped (at most 19)"),
    ("degradation: {passages_per_year: 5.0e5, tamping: {unreachable_sleepers: -1}}\n",
     "degradation.tamping.unreachable_sleepers", "must be >= 0"),
    ("degradation: {passages_per_year: 5.0e5, tamping: {min_interval: 0}}\n",
     "degradation.tamping.min_interval", "must be > 0"),
    ("degradation: {passages_per_year: 5.0e5, horizon_years: 2, tamping: {min_interval: 3}}\n",
     "degradation.tamping.min_interval", "not less than the horizon"),
    ("degradation: {passages_per_year: 5.0e5, tamping: {reach: 2}}\n",
     "degradation.tamping.reach", "unknown key"),
    ("degradation: {passages_per_year: 5.0e5}\noptimisation: {objectives: [interventions], "
     "budget: 10}\n", "optimisation.objectives", "it needs degradation.tamping"),
    # a bearing area of 0
    ("track: {sleeper: {bearing_area: 0}}\ndegradation: {passages_per_year: 5.0e5}\n",
     "track.sleeper.bearing_area", "must be > 0"),
    ("track: {strengthened_sleeper: {bearing_area: 0 m^2}}\n"
     "degradation: {passages_per_year: 5.0e5}\n",
     "track.strengthened_sleeper.bearing_area", "must be > 0"),
    ("degradation: {passages_per_year: 5.0e5, subgrade: {soil: peat}}\n",
     "degradation.subgrade.soil", "must be one of"),
    ("degradation: {passages_per_year: 5.0e5, subgrade: {strength: -1 kPa}}\n",
     "degradation.subgrade.strength", "must be > 0"),
])
def test_what_a_settlement_prediction_cannot_do_is_refused(tmp_path, body, key, words):
    refused(tmp_path, body, key, words)


def test_a_quarter_car_three_dof_has_no_fixed_point_and_is_accepted(tmp_path):
    case = load_case(case_file(tmp_path, "degradation: {passages_per_year: 5.0e5}\n",
                               (CONFIGS / "reference.yaml").as_posix()).parent
                     / "deg.yaml", ("vehicle.model=quarter-car",))
    assert case.degradation_spec().traffic[0].scenario.vehicle.model == "quarter-car"


def test_the_three_dof_vehicle_of_a_condition_is_refused_by_its_name(tmp_path):
    paper = yaml.safe_dump({"paper": load_case(CONFIGS / "reference.yaml").vehicle},
                           default_flow_style=True).strip()
    body = f"""degradation: {{traffic: {{a: 1.0e5}}}}
vehicles: {paper}
conditions: [{{name: a, vehicle: paper}}]
"""
    refused(tmp_path, body, "vehicles.paper",
            "the paper's three-dof vehicle of condition a cannot carry",
            base=(CONFIGS / "reference.yaml").as_posix())


@pytest.mark.parametrize("traffic, key, words", [
    ("{virm-140-enter-smooth: 1.0e5}", "degradation.traffic",
     "condition 'freight-100-enter-smooth' has no passages a year"),
    ("{virm-140-enter-smooth: 1.0e5, freight-100-enter-smooth: 0, virm-140-enter: 1}",
     "degradation.traffic.virm-140-enter",
     "no condition 'virm-140-enter' (did you mean 'virm-140-enter-smooth'?)"),
    ("{virm-140-enter-smooth: 0, freight-100-enter-smooth: 0}", "degradation.traffic",
     "no condition has passages"),
])
def test_a_traffic_that_names_the_conditions_wrong_is_refused(tmp_path, traffic, key, words):
    body = f"""degradation:
  traffic: {traffic}
conditions:
  - {{name: virm-140-enter-smooth, vehicle: virm, irregularity: none}}
  - {{name: freight-100-enter-smooth, vehicle: freight, irregularity: none}}
"""
    refused(tmp_path, body, key, words, TRAFFIC)


def test_each_condition_an_objective_is_refused_with_degradation(tmp_path):
    body = """degradation:
  traffic: {virm-140-enter-smooth: 1.0e5}
optimisation: {objectives: [F_max], budget: 30, conditions: each}
conditions:
  - {name: virm-140-enter-smooth, vehicle: virm, irregularity: none}
"""
    refused(tmp_path, body, "optimisation.conditions", "each is not available", TRAFFIC)


def test_a_prediction_beyond_what_one_design_may_cost_is_refused(tmp_path):
    """Fourteen half-car conditions with passages, up to 1000 simulations each: ~2e11 steps x
    dofs per design."""
    names = [c.name for c in load_case(TRAFFIC).traffic]
    traffic = ", ".join(f"{n}: 1.0e4" for n in names)
    msg = refused(tmp_path, f"degradation:\n  traffic: {{{traffic}}}\n  max_simulations: 1000\n",
                  "degradation.max_simulations", "about 35 minutes per design", TRAFFIC)
    assert "1000 simulations of 14 condition(s)" in msg


def test_check_prints_the_prediction_in_80_columns(run_cli):
    r = run_cli("check", CONFIGS / "settlement.yaml")
    assert r.returncode == 0, r.stderr
    out = r.stdout.splitlines()[1:]        # the first names the file
    assert all(len(line) <= 80 for line in out), [line for line in out if len(line) > 80]
    text = r.stdout
    assert "settlement: varandas law: alpha 0.6, beta 0.82, gamma 10 mm," in text
    assert "traffic: 170 trains a day, 8 bogie passages each," in text
    assert "496,000 bogie passages a year (2 axles each), axle load 174 kN" in text
    assert "170 trains a day, 993,000 axle passes," in text
    assert "about 17.7 million gross tonnes a year" in text
    assert "horizon 10 years = 9.93 million axle passes; 20 settling sleepers" in text
    assert "limit: level_d1_max 2 mm" in text
    assert "at most 30 simulations x 1 condition(s), tolerance 2 kN" in text
    # where a user first reads the law: its millimetres are not checked against a crossing
    assert ("the millimetres will be the law's values, not a forecast: the law is not\n"
            "    calibrated to a measured crossing (docs/settlement.md, Validation)") in text
    assert "subgrade (Li & Selig): soil CL, strength 150 kPa," in text


def _docs_traffic_example() -> str:
    """The traffic example of docs/settlement.md (after its marker), as a user copies it."""
    text = (Path(__file__).parents[2] / "docs" / "settlement.md").read_text(encoding="utf-8")
    block = text.split("<!-- traffic-example -->", 1)[1].split("```yaml\n", 1)[1]
    return block.split("```", 1)[0]


def test_trains_a_day_written_from_the_docs_are_the_equivalent_bogie_count(tmp_path):
    """docs/settlement.md's example, copied as it stands, gives the same traffic as the
    passages and the axle passes its comments say: the same prediction's input."""
    example = _docs_traffic_example()
    trains = load_case(case_file(tmp_path, example, name="trains"))
    bogies = load_case(case_file(tmp_path, "degradation: {passages_per_year: 131400}\n",
                                 name="bogies"))
    axle_passes = load_case(case_file(tmp_path, "degradation: {axle_passes_per_year: 262800}\n",
                                      name="axles"))
    got = [c.degradation_spec().traffic[0].passages_per_year
           for c in (trains, bogies, axle_passes)]
    assert got == [30 * 6 * 2 * 365] * 3
    assert [c.degradation_spec().horizon_years for c in (trains, bogies)] == [10.0, 10.0]


def test_trains_of_conditions_become_passages_of_each_vehicle(tmp_path):
    """A bogie condition passes twice per car, a half-car condition once; a bare number stays
    passages a year."""
    body = """vehicle: {type: bogie, wheelbase: 2.5, bogie_pitch_inertia: 1400}
conditions:
  - {name: a, vehicle: case, irregularity: none}
  - {name: b, vehicle: virm, irregularity: none}
  - {name: c, vehicle: case, irregularity: none}
degradation:
  traffic:
    a: {trains_per_day: 10, vehicles_per_train: 4}
    b: {trains_per_day: 10, bogies_per_train: 8}
    c: 1000
"""
    case = load_case(case_file(tmp_path, body, TRAFFIC))
    p = [t.passages_per_year for t in case.degradation_spec().traffic]
    assert p == [10 * 8 * 365, 10 * 4 * 365, 1000.0]


@pytest.mark.parametrize("body, key, words", [
    ("degradation: {trains_per_day: 30}\n", "degradation.trains_per_day",
     "trains without their length: give vehicles_per_train"),
    ("degradation: {vehicles_per_train: 4}\n", "degradation",
     "missing key 'passages_per_year'"),
    ("degradation: {passages_per_year: 5.0e5, vehicles_per_train: 4}\n",
     "degradation.vehicles_per_train", "needs trains_per_day"),
    ("degradation: {trains_per_day: 30, vehicles_per_train: 4, bogies_per_train: 8}\n",
     "degradation.bogies_per_train", "not both"),
    ("degradation: {trains_per_day: 30, vehicles_per_train: 4, passages_per_year: 1e5}\n",
     "degradation.trains_per_day", "give the traffic once"),
    ("degradation: {trains_per_day: 30, vehicles_per_train: 0}\n",
     "degradation.vehicles_per_train", "must be >= 1"),
    ("degradation: {trains_per_day: 30, vehicles_per_train: 2.5}\n",
     "degradation.vehicles_per_train", "whole number"),
])
def test_trains_without_their_length_are_refused(tmp_path, body, key, words):
    refused(tmp_path, body, key, words)
