"""Pads as bought: a case gives its pads by their stiffness under the wheel (the simulated
spring, the paper's reading), by their static (catalogue) stiffness and dynamic-to-static
ratio, or by name; the designed pads may be searched in catalogue terms with their type's
ratio. The simulation uses the stiffness under the wheel whichever way it was entered; a case
that gives none of this as before reads back unchanged; `check` and the report show both."""

import numpy as np
import pytest
import yaml

from lccopt.config import load_case
from lccopt.errors import CaseError
from lccopt.problem import evaluate
from tests.conftest import CHEAP_SIMULATION, CONFIGS

REFERENCE = CONFIGS / "reference.yaml"
X_REF = [1120e6, 1120e6, 1120e6, 8, 6, 6, 4, 0]
X_SOFT = [214e6, 155e6, 50e6, 5, 6, 7, 3, 0]        # the paper's compromise (Table 7)


def case_with(tmp_path, body: str, name="c.yaml"):
    p = tmp_path / name
    p.write_text(f"extends: {REFERENCE}\nname: pads\n{CHEAP_SIMULATION}{body}")
    return p


def error(path) -> str:
    with pytest.raises(CaseError) as exc:
        load_case(path)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def test_the_bundled_case_reads_back_as_before(tmp_path):
    """No pad key appears in a resolved case that does not write it (runs keep their
    fingerprints), and the simulated pad is the one written."""
    case = load_case(REFERENCE)
    assert set(case.track["railpad"]) == {"stiffness", "damping"}
    assert "dynamic_to_static" not in case.data["design"]["railpad_stiffness"]
    assert load_case(REFERENCE).resolved == case.resolved
    pad = case.scenario().track.railpad
    assert (pad.stiffness, pad.damping) == (1120e6, 120e3)


def test_a_pad_as_bought_simulates_as_its_stiffness_under_the_wheel(tmp_path):
    """static x ratio and a named pad give the same simulation as the stiffness under the
    wheel written out; the static stiffness written beside it changes nothing."""
    under = case_with(tmp_path, "", "under.yaml")
    bought = case_with(tmp_path, "track:\n  railpad:\n    stiffness: null\n"
                                 "    static_stiffness: 448 MN/m\n    dynamic_to_static: 2.5\n",
                       "bought.yaml")
    named = case_with(tmp_path, "track:\n  railpad:\n    stiffness: null\n    damping: null\n"
                                "    type: FC9\n", "named.yaml")
    beside = case_with(tmp_path, "track:\n  railpad:\n    static_stiffness: 500 MN/m\n",
                       "beside.yaml")
    ref = evaluate(load_case(under), X_SOFT).objectives
    for p in (bought, named, beside):
        c = load_case(p)
        assert c.scenario().track.railpad == load_case(under).scenario().track.railpad
        assert evaluate(c, X_SOFT).objectives == ref
    # and a pad truly softer under the wheel changes the simulation
    other = case_with(tmp_path, "track:\n  railpad:\n    stiffness: 560 MN/m\n", "other.yaml")
    assert evaluate(load_case(other), X_SOFT).objectives["F_max"] != ref["F_max"]


def test_designed_pads_searched_as_bought_are_simulated_under_the_wheel(tmp_path):
    """x_r in catalogue terms with their type's ratio: the design the simulator gets, and
    so the objectives, are those of x_r x ratio entered as stiffness under the wheel."""
    bought = load_case(case_with(tmp_path, "design:\n  railpad_stiffness:\n"
                                           "    dynamic_to_static: 2\n"
                                           "    bounds: [25 MN/m, 600 MN/m]\n"
                                           "    reference: [560 MN/m, 560 MN/m, 560 MN/m]\n"))
    under = load_case(case_with(tmp_path, "", "under.yaml"))
    x_bought = [107e6, 77.5e6, 25e6, 5, 6, 7, 3, 0]
    np.testing.assert_array_equal(bought.track_design(x_bought).railpad_stiffness,
                                  np.array(X_SOFT[:3]))
    assert evaluate(bought, x_bought).objectives == evaluate(under, X_SOFT).objectives
    assert evaluate(bought, [560e6] * 3 + X_REF[3:]).objectives \
        == evaluate(under, X_REF).objectives


@pytest.mark.parametrize("body, key, words", [
    ("track:\n  railpad:\n    stiffness: null\n    static_stiffness: 448 MN/m\n",
     "track.railpad", "missing key 'dynamic_to_static'"),
    ("track:\n  railpad:\n    stiffness: null\n    dynamic_to_static: 2\n",
     "track.railpad", "missing key 'static_stiffness'"),
    ("track:\n  railpad:\n    dynamic_to_static: 2\n    static_stiffness: 448 MN/m\n",
     "track.railpad.dynamic_to_static", "not both"),
    ("track:\n  railpad:\n    type: FC9\n", "track.railpad.stiffness", "give type alone"),
    ("track:\n  railpad:\n    static_stiffness: 2000 MN/m\n", "track.railpad.static_stiffness",
     "no softer under the wheel than bought"),
    ("track:\n  railpad:\n    stiffness: null\n    damping: null\n    type: fc9\n",
     "track.railpad.type", "must be one of FC9"),
    ("track:\n  railpad:\n    stiffness: null\n    static_stiffness: 448 MN/m\n"
     "    dynamic_to_static: 0.5\n", "track.railpad.dynamic_to_static", "no softer"),
    ("track:\n  railpad:\n    damping: null\n", "track.railpad", "missing key 'damping'"),
    ("design:\n  railpad_stiffness:\n    dynamic_to_static: 20\n",
     "design.railpad_stiffness.dynamic_to_static", "above 10"),
])
def test_a_pad_given_wrongly_is_one_line_naming_the_key(tmp_path, body, key, words):
    msg = error(case_with(tmp_path, body))
    assert f": {key}: " in msg and words in msg, msg
    assert ".yaml:" in msg


def test_check_and_the_report_show_the_pads_as_bought_and_under_the_wheel(tmp_path, run_cli):
    p = case_with(tmp_path, "track:\n  railpad:\n    stiffness: null\n"
                            "    static_stiffness: 448 MN/m\n    dynamic_to_static: 2.5\n"
                            "design:\n  railpad_stiffness:\n    dynamic_to_static: 2\n"
                            "    bounds: [25 MN/m, 600 MN/m]\n"
                            "    reference: [560 MN/m, 560 MN/m, 560 MN/m]\n"
                            "optimisation:\n  objectives: [F_max]\n  budget: 3\n"
                            "  initial_points: 2\n")
    out = run_cli("check", p)
    assert out.returncode == 0, out.stderr
    assert "pads: 448 MN/m as bought x 2.5 = 1120 MN/m under the wheel, 120 kN s/m" in out.stdout
    assert "designed pads x_r1-x_r3: 25-600 MN/m as bought x 2" in out.stdout
    assert "= 50-1200 MN/m under the wheel" in out.stdout
    assert max(len(line) for line in out.stdout.splitlines()[1:]) <= 80   # [0]: the path
    ref = run_cli("check", REFERENCE)
    assert "pads: static not given, 1120 MN/m under the wheel, 120 kN s/m" in ref.stdout
    assert "designed pads x_r1-x_r3: 50-1200 MN/m under the wheel" in ref.stdout
    run = run_cli("optimise", p, "--runs", tmp_path / "runs", "--workers", "1")
    assert run.returncode == 0, run.stderr
    report = run_cli("report", tmp_path / "runs" / "pads")
    assert report.returncode == 0, report.stderr
    text = (tmp_path / "runs" / "pads" / "report" / "report.md").read_text()
    assert "Pads: 448 MN/m as bought x 2.5 = 1120 MN/m under the wheel" in text
    assert "Designed pads x_r1-x_r3: 25-600 MN/m as bought x 2 = 50-1200 MN/m under the " \
           "wheel" in text
    # the run keeps the pads as entered: its resolved case reads back to them
    kept = yaml.safe_load((tmp_path / "runs" / "pads" / "case.yaml").read_text())
    assert kept["track"]["railpad"] == {"static_stiffness": 448e6, "dynamic_to_static": 2.5,
                                        "damping": 120e3}
