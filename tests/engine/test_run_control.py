"""Run control as a user has it: --set on optimise (recorded, so resume rebuilds the same
case), resume --budget on a finished run (what it proposed stays), and budgets it refuses."""

from __future__ import annotations

import json

import pytest

from lccopt.engine.journal import read_journal

from .conftest import FAKE, cli_run, read_table, write_case

# seconds a test: runs carried on through the command line
pytestmark = pytest.mark.slow

ENV = {"LCCOPT_EVALUATOR": FAKE}


def _asked(run):
    return [(e["id"], e["x"]) for e in read_journal(run / "journal.jsonl")[0]
            if e["event"] == "asked"]


def test_set_is_recorded_and_resume_budget_extends_a_finished_run(tmp_path):
    case = write_case(tmp_path, "ctl", budget=30, initial=4, seed=3)
    runs = tmp_path / "runs"
    r = cli_run("optimise", case, "--workers", "1", "--runs", runs,
                "--set", "optimisation.budget=8", "--set", "optimisation.seed=5", env=ENV)
    assert r.returncode == 0, r.stderr
    run = runs / "ctl"
    assert len(read_table(run)["id"]) == 8
    assert json.loads((run / "run.json").read_text())["overrides"] == ["optimisation.budget=8",
                                                                       "optimisation.seed=5"]
    first = _asked(run)
    r = cli_run("resume", run, env=ENV)             # the same case: the file with the same --set
    assert r.returncode == 0 and "nothing to do" in r.stderr, r.stderr
    r = cli_run("resume", run, "--budget", "12", "--workers", "1", env=ENV)
    assert r.returncode == 0, r.stderr
    assert "carrying on to a budget of 12 (--budget)" in r.stderr
    assert len(read_table(run)["id"]) == 12 and _asked(run)[:8] == first
    events = read_journal(run / "journal.jsonl")[0]
    assert [e["budget"] for e in events if e["event"] == "case_changed"] == [12]
    r = cli_run("resume", run, "--budget", "10", env=ENV)
    assert r.returncode == 2 and "--budget 10 is below the 12 evaluations" in r.stderr, r.stderr
    r = cli_run("status", run)
    assert r.stdout.startswith(f"{run}: finished, 12/12 evaluations"), r.stdout
