"""A run directory and the command line under attack, as an attacker would try them: links and
special files planted in a run, closed pipes, absurd options, files swapped or stale. Each
gets the documented exit code and one line, touches nothing outside the run, and a resumed
run ends as an uninterrupted one."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from lccopt.engine.journal import line_mark
from lccopt.engine.runner import optimise

from .conftest import (
    FAKE,
    REPO,
    assert_same_evaluations,
    cli,
    cli_run,
    journal_events,
    n_done,
    read_table,
    wait_for,
    write_case,
)

# seconds a test: runs attacked through their files, in subprocesses
pytestmark = pytest.mark.slow

ENV = {"LCCOPT_EVALUATOR": FAKE}





def _error_line(r) -> str:
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, r.stderr
    assert lines and lines[-1].startswith("lccopt: error: "), r.stderr
    assert "Traceback" not in r.stderr, r.stderr
    return lines[-1]


@pytest.fixture
def finished(tmp_path):
    """A finished two-objective run of the fake evaluator, and its table."""
    case = write_case(tmp_path, "h", budget=10, initial=4, seed=3)
    run = optimise(case, workers=1, runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    return case, run, read_table(run)


# ------------------------------------------------------------------------ links in a run

def test_links_planted_in_a_run_are_never_written_through(tmp_path, finished):
    case, run, _ = finished
    outside = tmp_path / "precious.txt"
    outside.write_text("precious")
    (run / "lock").unlink()
    (run / "lock").symlink_to(outside)
    for args in (("resume", run), ("optimise", case, "--runs", run.parent, "--force"),
                 ("report", run)):
        line = _error_line(cli_run(*args, env=ENV))
        assert "symbolic link" in line and "lock" in line, line
    assert outside.read_text() == "precious"

    (run / "lock").unlink()
    (run / "lock").touch()
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    (folder / "keep.tmp").write_text("mine")
    shutil.move(run / "evals", tmp_path / "evals-moved")
    (run / "evals").symlink_to(folder)
    line = _error_line(cli_run("resume", run, env=ENV))
    assert "evals" in line and "symbolic link" in line, line
    # nothing deleted, nothing written
    assert sorted(p.name for p in folder.iterdir()) == ["keep.tmp"]

    (run / "evals").unlink()
    shutil.move(tmp_path / "evals-moved", run / "evals")
    journal = run / "journal.jsonl"
    shutil.move(journal, tmp_path / "journal.jsonl")
    journal.symlink_to(tmp_path / "journal.jsonl")
    before = (tmp_path / "journal.jsonl").read_bytes()
    line = _error_line(cli_run("resume", run, env=ENV))
    assert "journal.jsonl" in line and "symbolic link" in line, line
    assert (tmp_path / "journal.jsonl").read_bytes() == before


def test_special_files_in_a_run_never_hang_a_command(tmp_path, finished):
    case, run, _ = finished
    (run / "lock").unlink()
    os.mkfifo(run / "lock")
    for args in (("resume", run), ("report", run)):
        line = _error_line(cli_run(*args, env=ENV, timeout=60))
        assert "FIFO" in line, line
    (run / "lock").unlink()
    (run / "lock").touch()
    os.mkfifo(run / "evals" / "000099.h5")
    line = _error_line(cli_run("resume", run, env=ENV, timeout=60))
    assert "000099.h5" in line and "FIFO" in line, line
    (run / "evals" / "000099.h5").unlink()
    # a FIFO as results.h5: every command that opens the run refuses it alike (one rule for
    # every reader); without it, the report reads the journal instead
    (run / "results.h5").unlink()
    os.mkfifo(run / "results.h5")
    for args in (("status", run), ("report", run, "--out", tmp_path / "rep")):
        line = _error_line(cli_run(*args, env=ENV, timeout=60))
        assert "results.h5" in line and "FIFO" in line, line
    (run / "results.h5").unlink()
    r = cli_run("report", run, "--out", tmp_path / "rep", env=ENV, timeout=60)
    assert r.returncode == 0, r.stderr


def test_a_foreign_or_stale_snapshot_is_a_cache_dropped_for_a_replay(tmp_path):
    """state.json is a cache: a snapshot of another run or of an earlier moment of this one is
    dropped and the journal replayed; the run ends as an uninterrupted one. A FIFO put in its
    place is refused by name (as any special file in a run), and once removed the run goes on."""
    case = write_case(tmp_path, "st", budget=14, initial=4, seed=5)
    (tmp_path / "o").mkdir()
    other = write_case(tmp_path / "o", "st", budget=14, initial=4, seed=6)
    reference = read_table(optimise(case, workers=1, runs=tmp_path / "uninterrupted",
                                    evaluator=FAKE, progress=False))
    foreign = optimise(other, workers=1, runs=tmp_path / "foreign", evaluator=FAKE, progress=False)
    for planted in ("fifo", "foreign", "stale"):
        runs = tmp_path / f"planted-{planted}"
        p = cli("optimise", case, "--workers", "1", "--runs", runs,
                env={**ENV, "LCCOPT_FAKE_DELAY": "0.2"}, start_new_session=True)
        run = runs / "st"
        wait_for(lambda: n_done(run) >= 8)
        wait_for(lambda: n_done(run) >= 10)
        os.killpg(p.pid, signal.SIGKILL)
        p.communicate()
        (run / "state.json").unlink(missing_ok=True)
        if planted == "fifo":
            os.mkfifo(run / "state.json")
        elif planted == "foreign":
            snap = json.loads((foreign / "state.json").read_text())
            snap["seq"] = min(snap["seq"], len(journal_events(run)) - 1)
            (run / "state.json").write_text(json.dumps(snap))
        else:   # a later state that claims one of this run's lines: its replay cannot agree
            snap = json.loads((tmp_path / "uninterrupted" / "st" / "state.json").read_text())
            seq = len(journal_events(run)) - 2
            snap.update(seq=seq, mark=line_mark(journal_events(run)[seq]))
            (run / "state.json").write_text(json.dumps(snap))
        if planted == "fifo":
            line = _error_line(cli_run("resume", run, "--workers", "1", env=ENV, timeout=60))
            assert "state.json" in line and "FIFO" in line, line
            (run / "state.json").unlink()
        r = cli_run("resume", run, "--workers", "1", env=ENV, timeout=120)
        assert r.returncode == 0, (planted, r.stderr)
        assert_same_evaluations(reference, read_table(run))


# ------------------------------------------------------------------------ files swapped

def test_an_evaluation_file_swapped_for_another_is_never_shown_and_is_simulated_again(
        tmp_path, finished):
    case, run, table = finished
    best = int(table["id"][table["value"].argmin()])
    assert best != 0
    shutil.copy(run / "evals" / "000000.h5", run / "evals" / f"{best:06d}.h5")
    r = cli_run("report", run, env=ENV)
    assert r.returncode == 0, r.stderr
    summary = json.loads((run / "report" / "summary.json").read_text())
    notes = summary["notes"]
    assert any(f"{best:06d}.h5 holds evaluation #0" in n for n in notes.values()), notes
    case.write_text(case.read_text().replace("budget: 10", "budget: 11"))
    r = cli_run("resume", run, "--allow-changed-case", "--workers", "1", env=ENV)
    assert r.returncode == 0, r.stderr
    assert "1 evaluation file(s) lost or damaged" in r.stderr and f"#{best}" in r.stderr, r.stderr
    from lccopt.store import evaluation_problem

    x_best = table["x"][table["id"] == best][0]
    assert evaluation_problem(run / "evals" / f"{best:06d}.h5", best, x_best) is None


def test_a_damaged_journal_is_said_by_report_on_one_line(tmp_path, finished):
    _, run, _ = finished
    lines = (run / "journal.jsonl").read_text().splitlines()
    lines[5] = lines[5][: len(lines[5]) // 2]     # cut mid-JSON, not the last line
    (run / "journal.jsonl").write_text("\n".join(lines) + "\n")
    r = cli_run("report", run, env=ENV)
    assert r.returncode == 0, r.stderr
    warnings = [w for w in r.stderr.splitlines() if w.startswith("lccopt: warning: ")]
    assert len(warnings) == 1, r.stderr
    assert "journal.jsonl" in warnings[0] and "results.h5" in warnings[0], r.stderr


# ------------------------------------------------------------------------ changed cases

def test_changes_a_run_cannot_honour_are_refused_by_name(tmp_path, finished):
    case, run, _ = finished
    text = case.read_text()
    for old, new, key in (("seed: 3", "seed: 4", "optimisation.seed"),
                          ("initial_points: 4", "initial_points: 5", "optimisation.initial_points"),
                          ("time_step: 1.0e-3", "time_step: 5.0e-4", "simulation.time_step")):
        case.write_text(text.replace(old, new).replace("budget: 10", "budget: 12"))
        line = _error_line(cli_run("resume", run, "--allow-changed-case", env=ENV))
        assert key in line and "new name" in line and "--force" in line, line
    case.write_text(text.replace("budget: 10", "budget: 6"))
    line = _error_line(cli_run("resume", run, "--allow-changed-case", env=ENV))
    assert "budget of 6 is below the 10 evaluations" in line, line
    assert not any(e["event"] == "case_changed" for e in journal_events(run))
    case.write_text(text.replace("budget: 10", "budget: 12")
                    .replace("timeout: 60.0", "timeout: 30.0"))
    assert cli_run("resume", run, "--allow-changed-case", env=ENV).returncode == 0
    assert len(read_table(run)["id"]) == 12


# ------------------------------------------------------------------------ options

def test_absurd_worker_counts_and_scheduler_addresses_get_one_line_at_once(tmp_path):
    case = write_case(tmp_path, "w", budget=6, initial=4)
    for n in ("99999999999999999999999", "100000"):
        line = _error_line(cli_run("optimise", case, "--workers", n, "--runs", tmp_path,
                                   env=ENV, timeout=60))
        assert "local workers fit here" in line, line
    for address in ("nonsense", "tcp://[::1", "http://host:1"):
        t0 = time.monotonic()
        r = cli_run("optimise", case, "--scheduler", address, "--runs", tmp_path, env=ENV,
                    timeout=60)
        assert time.monotonic() - t0 < 20          # the Client's finaliser would hang for 40 s
        assert "--scheduler" in _error_line(r) and "Exception ignored" not in r.stderr, r.stderr
    assert not (tmp_path / "w").exists()


def test_runs_that_is_not_a_folder_and_a_name_taken_by_a_file_are_said_plainly(tmp_path):
    case = write_case(tmp_path, "nf", budget=6, initial=4)
    (tmp_path / "afile").write_text("")
    (tmp_path / "loop1").symlink_to(tmp_path / "loop2")
    (tmp_path / "loop2").symlink_to(tmp_path / "loop1")
    for runs, words in (("afile", "a regular file"), ("loop1", "leads nowhere"),
                        ("/dev/null", "character device")):
        where = tmp_path / runs if runs[0] != "/" else runs
        line = _error_line(cli_run("optimise", case, "--runs", where, env=ENV))
        assert words in line and "not a folder" in line, line
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "nf").write_text("")
    line = _error_line(cli_run("optimise", case, "--runs", tmp_path / "runs", env=ENV))
    assert "is a regular file, not a run directory" in line and "resume" not in line, line


def test_report_out_never_replaces_a_users_files_without_force(tmp_path, finished):
    _, run, _ = finished
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "report.md").write_text("my notes")
    line = _error_line(cli_run("report", run, "--out", mine, env=ENV))
    assert "report.md" in line and "--force" in line, line
    assert (mine / "report.md").read_text() == "my notes"
    assert cli_run("report", run, "--out", mine, "--force", env=ENV).returncode == 0
    assert (mine / "report.md").read_text() != "my notes"
    # RUN/report is the run's own: replaced freely, but never through a planted link
    assert cli_run("report", run, env=ENV).returncode == 0
    assert cli_run("report", run, env=ENV).returncode == 0
    shutil.rmtree(run / "report")
    (run / "report").symlink_to(mine)
    line = _error_line(cli_run("report", run, env=ENV))
    assert "symbolic link" in line, line


def test_simulate_never_writes_through_a_link_planted_at_its_default_folder(tmp_path):
    """runs/<case>-simulate is lccopt's folder when no --out is named: a link there is
    refused (exit 2, nothing reaches its target); a link the user names as --out is theirs."""
    target = tmp_path / "elsewhere"
    target.mkdir()
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "reference-simulate").symlink_to(target)
    case = REPO / "configs" / "reference.yaml"
    line = _error_line(cli_run("simulate", case, "--no-plots", cwd=tmp_path, env=ENV))
    assert "runs/reference-simulate" in line and "symbolic link" in line, line
    assert "--out" in line and list(target.iterdir()) == []
    r = cli_run("simulate", case, "--no-plots", "--out", tmp_path / "runs" /
                "reference-simulate", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert [p.name for p in target.iterdir()] == ["simulation.h5"]


# ------------------------------------------------------------------------ closed pipes

def _into_closed_pipe(args, env=None, cwd=None) -> int:
    """Run ``lccopt ARGS`` with stdout and stderr on a pipe whose reader has gone (as after
    ``| head``, but before the first write, so the outcome does not depend on timing)."""
    read, write = os.pipe()
    os.close(read)
    main = "import sys; from lccopt.cli import main; sys.exit(main())"
    e = {**os.environ, "PYTHONPATH": str(REPO), "MPLBACKEND": "Agg", **(env or {})}
    try:
        return subprocess.run([sys.executable, "-c", main, *map(str, args)], env=e, cwd=cwd,
                              stdout=write, stderr=write, timeout=300).returncode
    finally:
        os.close(write)


def test_every_command_into_a_closed_pipe_exits_141_with_its_work_done(tmp_path, finished):
    case, run, _ = finished
    assert _into_closed_pipe(["--help"]) == 141
    assert _into_closed_pipe(["check", REPO / "configs" / "traffic.yaml"]) == 141
    sim = tmp_path / "sim"
    assert _into_closed_pipe(["simulate", case, "--out", sim]) == 141
    assert (sim / "simulation.h5").is_file() and (sim / "contact_force.png").is_file()
    assert _into_closed_pipe(["report", run, "--out", tmp_path / "rep"]) == 141
    assert (tmp_path / "rep" / "report.html").is_file()
    big = write_case(tmp_path, "pipe", budget=40, initial=4)
    assert _into_closed_pipe(["optimise", big, "--workers", "2", "--runs", tmp_path / "r"],
                             env={**ENV, "LCCOPT_FAKE_DELAY": "0.05"}) == 141
    r = cli_run("resume", tmp_path / "r" / "pipe", "--workers", "2", env=ENV)   # saved, resumable
    assert r.returncode == 0, r.stderr
    assert len(read_table(tmp_path / "r" / "pipe")["id"]) == 40


# ------------------------------------------------------------------------ workers and signals

def test_a_worker_killed_by_a_signal_runs_its_design_again(tmp_path):
    """kill -9 of one local worker (as the OOM killer does) is not a failure of the design."""
    case = write_case(tmp_path, "k", budget=10, initial=4, seed=7)
    reference = read_table(optimise(case, workers=2, runs=tmp_path / "uninterrupted",
                                    evaluator=FAKE, progress=False))
    p = cli("optimise", case, "--workers", "2", "--runs", tmp_path / "runs",
            env={**ENV, "LCCOPT_FAKE_DELAY": "0.5"})
    run = tmp_path / "runs" / "k"
    wait_for(lambda: n_done(run) >= 2)
    workers = [int(d.name) for d in Path("/proc").iterdir() if d.name.isdigit()
               and "local_worker_main" in _cmdline(d)]
    assert workers
    os.kill(workers[0], signal.SIGKILL)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 0, err
    table = read_table(run)
    assert (table["status"] == "ok").all(), set(table["reason"])
    assert_same_evaluations(reference, table)


def _cmdline(d: Path) -> str:
    try:
        return (d / "cmdline").read_bytes().decode(errors="replace")
    except OSError:
        return ""


def test_sigterm_to_the_group_stops_well_within_a_schedulers_grace(tmp_path):
    """Slurm and systemd send SIGTERM, then SIGKILL after a grace period: lccopt must be out
    long before (no worker started again during shutdown), with its run saved."""
    case = write_case(tmp_path, "g", budget=10, initial=4)
    p = cli("optimise", case, "--workers", "2", "--runs", tmp_path / "runs",
            env={**ENV, "LCCOPT_FAKE_DELAY": "30"}, start_new_session=True)
    run = tmp_path / "runs" / "g"
    wait_for(lambda: (run / "journal.jsonl").exists() and sum(
        e["event"] == "asked" for e in journal_events(run)) >= 1)
    time.sleep(0.5)
    t0 = time.monotonic()
    os.killpg(p.pid, signal.SIGTERM)
    p.communicate(timeout=60)
    assert time.monotonic() - t0 < 2.0       # 3.4 s when a worker was started again
    assert p.returncode == 130


def test_a_run_directory_never_chooses_the_code_that_evaluates(tmp_path, finished):
    """run.json names the evaluator a run was started with; a run directory from elsewhere must
    not make `resume` import and call a function of its choosing."""
    case, run, _ = finished
    (tmp_path / "evil.py").write_text(f"open({str(tmp_path / 'imported')!r}, 'w').close()\n"
                                      "def go(case, x):\n    raise SystemExit\n")
    meta = json.loads((run / "run.json").read_text())
    meta["evaluator"] = "evil:go"
    (run / "run.json").write_text(json.dumps(meta))
    case.write_text(case.read_text().replace("budget: 10", "budget: 11"))
    env = {k: v for k, v in os.environ.items() if k != "LCCOPT_EVALUATOR"}
    env["PYTHONPATH"] = f"{tmp_path}{os.pathsep}{REPO}"
    main = "import sys; from lccopt.cli import main; sys.exit(main())"
    r = subprocess.run([sys.executable, "-c", main, "resume", str(run), "--allow-changed-case",
                        "--workers", "1"], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert not (tmp_path / "imported").exists()
    assert "started with evaluator 'evil:go'" in r.stderr


def test_a_journal_that_names_a_file_out_of_the_run_is_refused(tmp_path, finished):
    _, run, _ = finished
    lines = [json.loads(line) for line in (run / "journal.jsonl").read_text().splitlines()]
    for ev in lines:
        if ev["event"] == "evaluated" and ev["id"] == 3:
            ev["file"] = "../../../../etc/hostname"
    (run / "journal.jsonl").write_text("".join(json.dumps(ev, separators=(",", ":")) + "\n"
                                               for ev in lines))
    line = _error_line(cli_run("resume", run, env=ENV))
    assert "names the file" in line and "/etc/hostname" in line, line
