"""`--set KEY.PATH=VALUE` on check, simulate and optimise: applied as if a file extending the
case had written it, validated with the same messages (located at --set), and recorded in
the resolved case a run or a simulation keeps."""

import h5py
import pytest
import yaml

from lccopt.config import load_case
from lccopt.config.overrides import parse_path
from lccopt.errors import CaseError
from tests.conftest import CHEAP_SIMULATION, CONFIGS, write_case

REFERENCE = CONFIGS / "reference.yaml"
FAKE = "tests.engine.fakesim:evaluate"


def test_values_are_set_as_if_written_in_a_file(tmp_path):
    case = load_case(REFERENCE, ["vehicle.speed=160 km/h", "track.ers.slab_lengths=[9.0]",
                                 "design.type_ii_strip.bounds=[0 m, 8 m]",
                                 "evaluation.force_zone_end={offset: -1.5}"])
    assert case.vehicle["speed"] == pytest.approx(160 / 3.6)
    assert case.track["ers"]["slab_lengths"] == [9.0]
    # a mapping merges into the section it names, as extends does
    assert case.evaluation["force_zone_end"] == {"at": "exit_interface", "offset": -1.5}
    assert case.overrides == ("vehicle.speed=160 km/h", "track.ers.slab_lengths=[9.0]",
                              "design.type_ii_strip.bounds=[0 m, 8 m]",
                              "evaluation.force_zone_end={offset: -1.5}")
    written = tmp_path / "c.yaml"
    written.write_text(f"extends: {REFERENCE}\nname: reference\nvehicle:\n  speed: 160 km/h\n"
                       "track:\n  ers:\n    slab_lengths: [9.0]\ndesign:\n  type_ii_strip:\n"
                       "    bounds: [0 m, 8 m]\nevaluation:\n  force_zone_end: {offset: -1.5}\n")
    assert load_case(written).resolved == case.resolved


def test_list_items_and_new_sections(tmp_path):
    case = load_case(CONFIGS / "traffic.yaml", ["conditions[0].speed=90 km/h",
                                                 "conditions.1.direction=enter"])
    assert case.conditions[0].speed == pytest.approx(25.0)
    assert case.conditions[1].direction == "enter"
    case = load_case(REFERENCE, ["optimisation.objectives=[F_max]", "optimisation.budget=30"])
    assert case.optimisation["budget"] == 30 and case.optimisation["initial_points"] == 20
    assert parse_path("conditions[2].irregularity.seed") == ("conditions", 2, "irregularity",
                                                             "seed")


@pytest.mark.parametrize("item, words", [
    ("vehicle.speed=140", "--set: vehicle.speed: 140 m/s is 504 km/h"),
    ("vehicle.sped=40", "--set: vehicle.sped: unknown key (did you mean 'speed'?)"),
    ("vehicle.speed", "--set: expected KEY.PATH=VALUE"),
    ("=3", "--set: expected KEY.PATH=VALUE"),
    ("vehicle..speed=3", "--set: vehicle..speed: not a key path"),
    ("conditions[0].speed=90 km/h", "--set: conditions[0].speed: no item [0]"),
    ("vehicle.speed.x=3", "--set: vehicle.speed.x: vehicle.speed is a value, not a section"),
    ("vehicle.speed=[1, 2", "--set: vehicle.speed: cannot read the value"),
    ("extends=other.yaml", "--set: extends: name the base case in a file"),
    ("evaluation.force_zone_end={at: exit_interface, offset: 3}",
     "--set: evaluation.force_zone_end.offset: {at: exit_interface, offset: 3} ends 3 m past"),
])
def test_a_bad_value_is_located_at_set(item, words):
    with pytest.raises(CaseError) as exc:
        load_case(REFERENCE, [item])
    assert str(exc.value).startswith(words), str(exc.value)


def test_check_and_simulate_take_set(tmp_path, run_cli):
    case = tmp_path / "c.yaml"
    case.write_text(f"extends: {REFERENCE}\nname: s\n" + CHEAP_SIMULATION)
    r = run_cli("check", case, "--set", "vehicle.speed=160 km/h", "--set", "name=other")
    assert r.returncode == 0, r.stderr
    assert "case 'other'" in r.stdout and "160 km/h" in r.stdout
    assert "  with --set vehicle.speed=160 km/h, --set name=other" in r.stdout
    r = run_cli("check", case, "--set", "vehicle.speed=160")
    assert r.returncode == 2
    assert r.stderr.startswith("lccopt: error: --set: vehicle.speed: 160 m/s is 576 km/h")
    r = run_cli("simulate", case, "--set", "vehicle.speed=100 km/h", "--out", tmp_path / "o",
                "--no-plots")
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "o" / "simulation.h5") as f:
        resolved = yaml.safe_load(f["info"].attrs["case"])
        assert f["info"].attrs["speed"] == pytest.approx(100 / 3.6)
    assert resolved["vehicle"]["speed"] == pytest.approx(100 / 3.6)


@pytest.mark.slow
def test_optimise_takes_set_and_the_run_records_it(tmp_path, run_cli):
    case = write_case(tmp_path, "ov", objectives=("F_max",), budget=20, initial=5)
    r = run_cli("optimise", case, "--workers", "1", "--runs", tmp_path / "runs",
                "--set", "optimisation.budget=6", "--set", "vehicle.speed=120 km/h",
                env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0, r.stderr
    run = tmp_path / "runs" / "ov"
    copy = yaml.safe_load((run / "case.yaml").read_text())
    assert copy["optimisation"]["budget"] == 6
    assert copy["vehicle"]["speed"] == pytest.approx(120 / 3.6)
    with h5py.File(run / "results.h5") as f:
        assert len(f["evaluations/id"]) == 6


@pytest.mark.slow
def test_optimise_budget_is_the_budget_a_resume_keeps(tmp_path, run_cli):
    """`optimise --budget N` runs N evaluations whatever the file says; the run records it, so
    a resume of the finished run finds the case unchanged (not 'the case file changed'); a
    budget out of bounds is one line blaming --budget, exit 2."""
    case = write_case(tmp_path, "bud", objectives=("F_max",), budget=20, initial=5)
    env = {"LCCOPT_EVALUATOR": FAKE}
    bad = run_cli("optimise", case, "--budget", "1", "--runs", tmp_path / "runs", env=env)
    assert bad.returncode == 2
    assert bad.stderr.strip() == "lccopt: error: --budget: optimisation.budget: must be >= 2, got 1"
    assert not (tmp_path / "runs" / "bud").exists()
    r = run_cli("optimise", case, "--budget", "7", "--workers", "1", "--runs", tmp_path / "runs",
                env=env)
    assert r.returncode == 0, r.stderr
    run = tmp_path / "runs" / "bud"
    with h5py.File(run / "results.h5") as f:
        assert len(f["evaluations/id"]) == 7
    again = run_cli("resume", run, "--workers", "1", env=env)
    assert again.returncode == 0, again.stderr
    assert "finished: 7 evaluations" in again.stderr + again.stdout
