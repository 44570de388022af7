"""`lccopt report` on a single-objective run with failed evaluations and a restart.

The run: the real simulator (cheap mesh) behind ``report_evaluators:fail_window``, which makes
calls 5..12 raise. With one worker these are the 8 candidates right after the 5-point initial
design; 8 failures in a row (the optimiser's ``max_failed_row`` for 8 variables) force a
restart with a fresh initial design. Failed evaluations leave no histories file.
"""

from __future__ import annotations

import json

import h5py
import pytest

from .helpers import FIGURES, lccopt, png_size, write_case

# seconds a test: a run with failures and a restart, then its report
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    base = tmp_path_factory.mktemp("report-fail")
    faults = base / "faults"
    faults.mkdir()
    case = write_case(base, "rep-fail", objectives=("F_max",), budget=20, initial=5, seed=2)
    env = {"LCCOPT_EVALUATOR": "tests.report.report_evaluators:fail_window",
           "LCCOPT_REPORT_FAULT_DIR": str(faults), "LCCOPT_REPORT_FAIL_CALLS": "5-13"}
    proc = lccopt("optimise", case, "--runs", base / "runs", "--workers", 1, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    run = base / "runs" / "rep-fail"
    proc = lccopt("report", run)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return run, proc


def test_the_run_has_failures_and_a_restart(run_dir):
    run, _ = run_dir
    with h5py.File(run / "results.h5", "r") as f:
        status = [s.decode() if isinstance(s, bytes) else s for s in f["evaluations/status"][()]]
        restart = f["evaluations/restart"][()]
        ids = f["evaluations/id"][()]
    assert status.count("failed") == 8
    assert restart.max() == 1
    failed = [i for i, s in zip(ids, status) if s == "failed"]
    assert not any((run / "evals" / f"{i:06d}.h5").exists() for i in failed)


def test_report_shows_failures_and_the_restart(run_dir):
    run, proc = run_dir
    with h5py.File(run / "results.h5", "r") as f:
        restart = f["evaluations/restart"][()]
        ids = f["evaluations/id"][()]
        best = dict(f["best"].attrs)
    first = int(ids[restart == 1].min())
    s = json.loads((run / "report" / "summary.json").read_text())
    assert s["failed"] == 8 and s["restarts"] == 1 and s["evaluations"] == 20
    assert s["best"]["id"] == best["id"] and s["best"]["value"] == best["value"]
    md = (run / "report" / "report.md").read_text()
    assert "8 failed" in md and "8× RuntimeError: injected failure" in md
    assert ("restarts (fresh initial design after the step size collapsed or evaluations kept "
            f"failing) at #{first}") in md
    for name in FIGURES:
        png_size(run / "report" / f"{name}.png")


def test_single_objective_summary_and_objective_space_note(run_dir):
    run, _ = run_dir
    md = (run / "report" / "report.md").read_text()
    assert "Minimise **F_max**" in md
    assert "minimised F_max alone" in md  # objective space drawn anyway, with a note
    assert "target f^r" not in md


def test_the_library_says_a_reports_warnings_only_through_the_callers_echo(run_dir, tmp_path,
                                                                          monkeypatch, capsys):
    """From Python, write_report prints nothing itself: the run's warning (a damaged journal
    line) goes to the echo it is given, on the error side, and what it wrote comes back."""
    import shutil

    import lccopt.report as report

    run = shutil.copytree(run_dir[0], tmp_path / "run")
    journal = run / "journal.jsonl"
    lines = journal.read_text().splitlines(keepends=True)
    journal.write_text("".join(lines[:-2] + ["{damaged\n"] + lines[-2:]))
    drawn = ({"seconds": 0.0}, {}, [])      # the figures are the other tests'
    monkeypatch.setattr(report, "_draw", lambda *args: drawn)
    heard = []
    written = report.write_report(run, "md", tmp_path / "rep",
                                  echo=lambda text, err=False: heard.append((text, err)))
    said = capsys.readouterr()
    assert said.out == said.err == ""
    assert len(heard) == 1 and heard[0][1] is True, heard
    assert heard[0][0].startswith(f"lccopt: warning: {journal}: line {len(lines) - 1} is damaged")
    assert heard[0][0].endswith("the table is results.h5's, which may lag the run")
    assert written.path == tmp_path / "rep" and written.run.name == "rep-fail"
    assert (written.summary, written.figures, written.files) == drawn
