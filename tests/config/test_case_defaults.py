"""Defaults a user can trust: optimisation.initial_points (20, 2 (d + 1) for more than 9
variables, never above the budget), optimisation.asf.worst (1.5 x the reference design's
objectives, fixed once evaluation #0 is in and journalled), optimisation.histories (best);
check and simulate need no optimisation key."""

import json

import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.errors import CaseError
from lccopt.problem import DEFAULT_WORST_FACTOR, Problem
from tests.conftest import CHEAP_SIMULATION, CONFIGS

REFERENCE = CONFIGS / "reference.yaml"
FAKE = "tests.engine.fakesim:evaluate"


def case(tmp_path, body: str, name="d"):
    p = tmp_path / f"{name}.yaml"
    p.write_text(f"extends: {REFERENCE}\nname: {name}\n" + body)
    return p


@pytest.mark.parametrize("body, initial", [
    ("optimisation:\n  objectives: [F_max]\n  budget: 200\n", 20),
    ("optimisation:\n  objectives: [F_max]\n  budget: 12\n", 12),     # never above the budget
    ("optimisation:\n  objectives: [F_max]\n  budget: 200\n  initial_points: 30\n", 30),
    # 10 pads: 15 variables, 2 (d + 1) = 32 points
    ("optimisation:\n  objectives: [F_max]\n  budget: 200\ndesign:\n  railpad_stiffness:\n"
     "    count: 10\n    reference: [1120 MN/m, 1120 MN/m, 1120 MN/m, 1120 MN/m, 1120 MN/m, "
     "1120 MN/m, 1120 MN/m, 1120 MN/m, 1120 MN/m, 1120 MN/m]\n", 32),
])
def test_initial_points_default(tmp_path, body, initial):
    c = load_case(case(tmp_path, body))
    assert c.optimisation["initial_points"] == initial
    assert Problem.from_case(c).initial_points == initial


@pytest.mark.slow
def test_check_and_simulate_need_no_optimisation_key(tmp_path, run_cli):
    # a multi-objective section without worst (the issue: simulate refused it), and one
    # without objectives or budget
    for body in ("optimisation:\n  objectives: [F_max, E_max]\n  budget: 40\n",
                 "optimisation:\n  seed: 3\n"):
        p = case(tmp_path, body + CHEAP_SIMULATION)
        r = run_cli("check", p)
        assert r.returncode == 0, r.stderr
        r = run_cli("simulate", p, "--out", tmp_path / "o", "--no-plots", "--force")
        assert r.returncode == 0, r.stderr
    assert "  optimisation: none yet (lccopt optimise needs objectives and budget)" \
        in run_cli("check", p).stdout.splitlines()
    with pytest.raises(CaseError, match="optimisation: missing key 'objectives'"):
        Problem.from_case(load_case(p))


def test_the_default_worst_values_follow_the_reference_design(tmp_path):
    c = load_case(case(tmp_path, "optimisation:\n  objectives: [F_max, E_max]\n  budget: 40\n"))
    pb = Problem.from_case(c)
    assert pb.worst is None
    ref = {"F_rms": 56000.0, "F_max": 7557.0, "E_rms": 1.4, "E_max": 0.4125}
    set_ = pb.with_reference(ref)
    assert set_.worst == pytest.approx((DEFAULT_WORST_FACTOR * 7557.0,
                                        DEFAULT_WORST_FACTOR * 0.4125))
    point = set_.reference_point(ref)
    assert point == pytest.approx([0.8 * 7557.0, 0.8 * 0.4125])
    # each objective counts by its change relative to the reference design
    f = {"F_max": 7557.0 * 0.5, "E_max": 0.4125 * 0.5}
    kappa_terms = (set_.objective_vector(f) - np.array(point)) / (np.array(set_.worst) - point)
    assert kappa_terms == pytest.approx([(0.5 - 0.8) / 0.7] * 2)
    # given values win
    given = load_case(case(tmp_path, "optimisation:\n  objectives: [F_max, E_max]\n  budget: 40\n"
                                     "  asf:\n    worst: [9000, 1.0]\n", "g"))
    assert Problem.from_case(given).with_reference(ref).worst == (9000.0, 1.0)


@pytest.mark.slow
def test_a_run_without_worst_journals_the_default_with_the_reference(tmp_path, run_cli):
    p = case(tmp_path, "optimisation:\n  objectives: [F_max, E_max]\n  budget: 8\n"
                       "  initial_points: 4\n" + CHEAP_SIMULATION, "w")
    r = run_cli("optimise", p, "--workers", "1", "--runs", tmp_path / "runs",
                env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0, r.stderr
    lines = [json.loads(l) for l in (tmp_path / "runs" / "w" / "journal.jsonl").read_text()
             .splitlines()]
    ref = next(l for l in lines if l["event"] == "reference")
    o = ref["objectives"]
    assert ref["worst"] == pytest.approx([1.5 * o["F_max"], 1.5 * o["E_max"]])
    assert ref["point"] == pytest.approx([0.8 * o["F_max"], 0.8 * o["E_max"]])
    values = [l["value"] for l in lines if l["event"] == "evaluated"]
    assert len(values) == 8 and all(np.isfinite(values))
    # resumed, the finished run keeps its values (the same worst values)
    r = run_cli("resume", tmp_path / "runs" / "w", env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0, r.stderr


def test_histories_default_and_choices(tmp_path):
    c = load_case(case(tmp_path, "optimisation:\n  objectives: [F_max]\n  budget: 10\n"))
    assert c.histories == "best"
    assert "histories" not in c.resolved      # absent stays absent: older runs resolve as before
    c = load_case(case(tmp_path, "optimisation:\n  objectives: [F_max]\n  budget: 10\n"
                                 "  histories: all\n"))
    assert c.histories == "all" and "histories: all" in c.resolved
    with pytest.raises(CaseError, match=r"optimisation.histories: must be one of all, best, "
                                        r"none, got 'bets' \(did you mean 'best'\?\)"):
        load_case(case(tmp_path, "optimisation:\n  histories: bets\n"))
    assert load_case(REFERENCE).histories == "best"
