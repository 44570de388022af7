"""The run as its journal describes it (lccopt/engine/run.py): one object that resume, status
and the report read alike. After `resume --budget` all three agree on the budget, which
run.json keeps as a number (a run.json of an earlier lccopt, with it as a --set item among
the overrides, carries on alike); a line of a kind a newer lccopt writes is kept and changes
nothing; a case whose budget the journal does not hold gets a case_changed line, so that the
replay finds the budget the run goes to."""

from __future__ import annotations

import json
import math

import pytest

from lccopt.config import load_case
from lccopt.engine.events import ASKED, CASE_CHANGED, EVALUATED, RUN, SCHEDULE, SESSION
from lccopt.engine.journal import read_journal
from lccopt.engine.replay import restore
from lccopt.engine.run import Run
from lccopt.problem import Problem

from .conftest import FAKE, cli_run, read_table, write_case

# seconds a test: runs carried on through the command line
pytestmark = pytest.mark.slow

ENV = {"LCCOPT_EVALUATOR": FAKE}


def _lines(run) -> list[dict]:
    return read_journal(run / "journal.jsonl")[0]


def _report_budget(run) -> int:
    """The budget the report reads (and shows in its first line and summary)."""
    from lccopt.report.data import load_run

    data = load_run(run)
    try:
        return data.budget
    finally:
        data.rd.close()


def test_resume_budget_is_the_budget_of_status_report_and_the_replay(tmp_path):
    case = write_case(tmp_path, "agree", budget=8, initial=4, seed=2)
    runs = tmp_path / "runs"
    assert cli_run("optimise", case, "--workers", "1", "--runs", runs, env=ENV).returncode == 0
    run = runs / "agree"
    r = cli_run("resume", run, "--budget", "11", "--workers", "1", env=ENV)
    assert r.returncode == 0, r.stderr
    events = _lines(run)
    assert [e["budget"] for e in events if e["event"] == CASE_CHANGED] == [11]
    assert Run.of(events).budget == 11
    # the replay of a resume ends at the journal's budget, not the case file's (8)
    strategy, table = restore(Problem.from_case(load_case(case)), events, None)
    assert strategy.budget == 11 and strategy.done and table.n_done == 11
    assert cli_run("status", run).stdout.startswith(f"{run}: finished, 11/11 evaluations")
    assert _report_budget(run) == 11
    (run / "results.h5").unlink()   # the report's table from the journal alone
    assert _report_budget(run) == 11
    meta = json.loads((run / "run.json").read_text())
    assert meta["budget"] == 11 and meta["overrides"] == []   # a number, not a --set item
    r = cli_run("resume", run, env=ENV)   # --budget is remembered: nothing left to do
    assert r.returncode == 0 and "nothing to do" in r.stderr, r.stderr
    # as an earlier lccopt recorded it: a --set item among the overrides
    del meta["budget"]
    meta["overrides"] = ["optimisation.budget=11"]
    (run / "run.json").write_text(json.dumps(meta, indent=2) + "\n")
    r = cli_run("resume", run, env=ENV)
    assert r.returncode == 0 and "nothing to do" in r.stderr, r.stderr
    r = cli_run("resume", run, "--budget", "12", "--workers", "1", env=ENV)
    assert r.returncode == 0 and Run.of(_lines(run)).budget == 12, r.stderr
    assert cli_run("status", run).stdout.startswith(f"{run}: finished, 12/12 evaluations")


def test_a_line_of_a_kind_this_lccopt_does_not_know_is_kept_and_changes_nothing(tmp_path):
    case = write_case(tmp_path, "newer", budget=6, initial=4, seed=1)
    runs = tmp_path / "runs"
    assert cli_run("optimise", case, "--workers", "1", "--runs", runs, env=ENV).returncode == 0
    run = runs / "newer"
    before = read_table(run)
    status = cli_run("status", run).stdout
    journal = run / "journal.jsonl"
    n = len(_lines(run))
    unknown = {"seq": n, "event": "annotated", "note": "from a newer lccopt", "budget": 3,
               "id": 2}
    with journal.open("a") as fh:
        fh.write(json.dumps(unknown, separators=(",", ":")) + "\n")
    events = _lines(run)
    assert Run.of(events).budget == 6 and Run.of(events).n_done == 6
    assert cli_run("status", run).stdout == status
    assert _report_budget(run) == 6
    r = cli_run("resume", run, "--budget", "8", "--workers", "1", env=ENV)
    assert r.returncode == 0, r.stderr
    after = _lines(run)
    assert after[n] == unknown                       # kept where it was
    assert [e["seq"] for e in after] == list(range(len(after)))
    table = read_table(run)
    assert len(table["id"]) == 8
    assert (table["x"][:6] == before["x"]).all()     # what the run proposed stays


def test_a_case_budget_the_journal_does_not_hold_is_journalled_before_the_run_goes_on(tmp_path):
    """run.json names a case of budget 10 while the journal's lines say 8 (the line recording
    the change was cut off the journal): the resume writes the budget into the journal, so the
    replay of the run, and so a later resume, agrees with what it ran."""
    case = write_case(tmp_path, "cut", budget=8, initial=4, seed=4)
    runs = tmp_path / "runs"
    assert cli_run("optimise", case, "--workers", "1", "--runs", runs, env=ENV).returncode == 0
    run = runs / "cut"
    assert cli_run("resume", run, "--budget", "10", "--workers", "1", env=ENV).returncode == 0
    events = _lines(run)
    cut = next(i for i, e in enumerate(events) if e["event"] == CASE_CHANGED)
    (run / "journal.jsonl").write_text("".join(json.dumps(e, separators=(",", ":")) + "\n"
                                               for e in events[:cut]))
    (run / "state.json").unlink()
    (run / "results.h5").unlink()
    r = cli_run("resume", run, "--workers", "1", env=ENV)
    assert r.returncode == 0, r.stderr
    events = _lines(run)
    assert [e["budget"] for e in events if e["event"] == CASE_CHANGED] == [10]
    assert Run.of(events).n_done == 10
    r = cli_run("resume", run, env=ENV)    # the journal replays to what the run did
    assert r.returncode == 0 and "nothing to do" in r.stderr, r.stderr


def test_the_run_follows_its_lines_in_order():
    """Budget, ASF, schedule, sessions and the pace of the session going, from the lines."""
    x = [1.0, 2.0]
    lines = [
        {"event": RUN, "budget": 5, "objectives": ["F_max", "E_max"]},
        {"event": SCHEDULE, "lag": 2, "batch": 1},
        {"event": ASKED, "id": 0, "x": x, "phase": "initial", "restart": 0},
        {"event": EVALUATED, "id": 0, "value": 0.0, "objectives": {"F_max": 1.0},
         "mono": 10.0, "at": 100.0},
        {"event": "reference", "id": 0, "x": x, "objectives": {"F_max": 1.0},
         "point": [1.0, 2.0], "worst": [3.0, 4.0], "rho": 0.05},
        {"event": SESSION, "wall_time": 7.5},
        {"event": CASE_CHANGED, "budget": 9, "rho": 0.1},
        {"event": SCHEDULE, "lag": 3, "batch": 2},
        {"event": ASKED, "id": 1, "x": x, "phase": "initial", "restart": 0},
        {"event": "failed", "id": 1, "reason": "diverged", "mono": 20.0},
        {"event": "finished"},
    ]
    run = Run.of([{"seq": i, **e} for i, e in enumerate(lines)])
    assert run.budget == 9 and run.finished and (run.lag, run.batch) == (3, 2)
    assert run.asf == {"point": [1.0, 2.0], "worst": [3.0, 4.0], "rho": 0.1}
    assert run.reference["rho"] == 0.05            # the reference line as written
    assert run.session_walls == [7.5] and run.stamps == [(20.0, None)]
    assert run.names == ["x1", "x2"] and run.objectives == ["F_max", "E_max"]
    assert run.told(0) == ("ok", 0.0, None) and run.told(1) == ("failed", "diverged")
    assert math.isnan(run.rows[1]["value"]) and run.n_done == 2 and run.n_failed == 1
