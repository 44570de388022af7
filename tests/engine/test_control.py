"""Run control under attack, with real processes: stopping signals at any moment of any
command, closed and full standard streams. Each gets the documented exit code and one line,
and a run that was stopped resumes to the table of an uninterrupted one."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from lccopt.engine.runner import optimise
from tests.conftest import lccopt_command, subprocess_env

from .conftest import FAKE, REPO, assert_same_evaluations, read_table, write_case

ENV = {"LCCOPT_EVALUATOR": FAKE}
REPO_CONFIGS = REPO / "configs"


def _lccopt(*args, env=None, shell_redirect: str = "", cwd=None, **kw) -> subprocess.Popen:
    """``lccopt ARGS`` as the installed console script, in a session of its own (a signal
    goes to its whole process group, as a terminal, Slurm or systemd send it), optionally
    through ``sh -c 'exec lccopt ... REDIRECT'`` (closed or full streams)."""
    cmd = lccopt_command() + [str(a) for a in args]
    if shell_redirect:
        cmd = ["sh", "-c", f'exec "$@" {shell_redirect}', "sh", *cmd]
    return subprocess.Popen(cmd, env=subprocess_env(**(env or {})), cwd=cwd,
                            stdout=kw.pop("stdout", subprocess.PIPE),
                            stderr=kw.pop("stderr", subprocess.PIPE), text=True,
                            start_new_session=True, **kw)


def _catches(pid: int, sig: int, timeout: float = 30.0) -> None:
    """Wait until process PID has a handler for SIG (Linux: its SigCgt mask). Before it, the
    interpreter is still starting and a signal ends it as any program (nothing of lccopt's
    has run, nothing is lost); on a crowded machine that start alone can outlast the delays
    below, so they count from the moment lccopt catches the signal."""
    status = Path(f"/proc/{pid}/status")
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            fields = dict(line.split(":", 1) for line in status.read_text().splitlines())
        except OSError:
            return   # no /proc (or the process is gone): the delays alone, as elsewhere
        if int(fields["SigCgt"], 16) >> (sig - 1) & 1:
            return
        time.sleep(0.005)


def _stopped(args, sig, after: float, env=None) -> subprocess.CompletedProcess:
    """Start ``lccopt ARGS``, send SIG to its process group AFTER seconds from the moment it
    catches SIG, wait."""
    p = _lccopt(*args, env=env)
    _catches(p.pid, sig)
    time.sleep(after)
    try:
        os.killpg(p.pid, sig)
    except ProcessLookupError:
        pass
    out, err = p.communicate(timeout=120)
    return subprocess.CompletedProcess(p.args, p.returncode, out, err)


def _one_line(r, code: int, text: str) -> None:
    assert r.returncode == code, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    lines = r.stderr.strip().splitlines()
    assert lines and lines[-1] == text, r.stderr


@pytest.fixture
def finished(tmp_path):
    case = write_case(tmp_path, "ctl", budget=10, initial=4, seed=3)
    run = optimise(case, workers=1, runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    return case, run, read_table(run)


# ------------------------------------------------------------------------ signals

@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_every_command_stopped_by_a_signal_exits_130_with_one_line(tmp_path, finished, sig):
    """SIGTERM and SIGHUP to simulate, report, check and status while they load or work: exit
    130 and one line naming the signal. A command that finished before the signal came exits
    0 (check and status often do; report on a loaded machine may); simulate and report must
    have been stopped at least once."""
    case, run, _ = finished
    name = signal.Signals(sig).name
    for args, must_stop in ((["simulate", case, "--out", tmp_path / "sim"], True),
                            (["report", run, "--out", tmp_path / "rep"], True),
                            (["check", case], False), (["status", run], False)):
        stopped = 0
        for after in (0.3, 0.8):
            r = _stopped(args, sig, after)
            if r.returncode == 0:
                continue
            _one_line(r, 130, f"lccopt: interrupted by {name}")
            stopped += 1
        assert stopped or not must_stop, (args[0], "finished before every signal")


def test_optimise_and_resume_stopped_while_they_start_resume_to_the_same_table(tmp_path):
    """SIGTERM in the first second of optimise (workers starting, the run directory being
    made) and SIGHUP in the first second of resume: exit 130, no traceback, and the run
    carried on to its end equals an uninterrupted one."""
    case = write_case(tmp_path, "early", budget=10, initial=4, seed=5)
    reference = read_table(optimise(case, workers=2, runs=tmp_path / "whole", evaluator=FAKE,
                                    progress=False))
    runs = tmp_path / "runs"
    run = runs / "early"
    for i, after in enumerate((0.4, 0.9, 1.6)):
        if not run.exists():
            r = _stopped(["optimise", case, "--workers", "2", "--runs", runs], signal.SIGTERM,
                         after, env={**ENV, "LCCOPT_FAKE_DELAY": "0.3"})
        else:
            r = _stopped(["resume", run, "--workers", "2"], signal.SIGHUP, after,
                         env={**ENV, "LCCOPT_FAKE_DELAY": "0.3"})
        assert r.returncode in (0, 130) and "Traceback" not in r.stderr, r.stderr
    if not run.exists():
        r = subprocess.run(lccopt_command() + ["optimise", str(case), "--workers", "2",
                                               "--runs", str(runs)],
                           env=subprocess_env(**ENV), capture_output=True, text=True, timeout=300)
    else:
        r = subprocess.run(lccopt_command() + ["resume", str(run), "--workers", "2"],
                           env=subprocess_env(**ENV), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert not [p.name for p in runs.iterdir() if p.name != "early"], "nothing half made"
    assert_same_evaluations(reference, read_table(run))


# ------------------------------------------------------------------------ streams

def _done(p: subprocess.Popen) -> subprocess.CompletedProcess:
    out, err = p.communicate(timeout=300)
    return subprocess.CompletedProcess(p.args, p.returncode, out, err)


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_a_run_does_not_depend_on_its_streams(tmp_path, finished):
    """optimise with stderr closed (2>&-) or full (2>/dev/full) runs to the end as it would
    have; stdout that cannot take the summary (closed, full) still leaves the run finished,
    then exit 2 naming standard output."""
    case, _, reference = finished
    for i, redirect in enumerate(("2>&-", "2>/dev/full", ">/dev/full")):
        runs = tmp_path / f"runs{i}"
        r = _done(_lccopt("optimise", case, "--workers", "1", "--runs", runs, env=ENV,
                          shell_redirect=redirect))
        if redirect.startswith("2"):
            assert r.returncode == 0 and "done: 10 evaluations" in r.stdout, (redirect, r)
            assert "Traceback" not in r.stderr, r.stderr
        else:
            _one_line(r, 2, "lccopt: error: cannot write to standard output: No space left on "
                            "device")
        assert_same_evaluations(reference, read_table(runs / "ctl"))


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_status_and_report_on_closed_or_full_stdout_exit_2_with_one_line(tmp_path, finished):
    _, run, _ = finished
    r = _done(_lccopt("status", run, shell_redirect=">&-"))
    _one_line(r, 2, "lccopt: error: cannot write to standard output: it was closed")
    r = _done(_lccopt("status", run, shell_redirect=">/dev/full"))
    _one_line(r, 2, "lccopt: error: cannot write to standard output: No space left on device")
    r = _done(_lccopt("report", run, "--out", tmp_path / "rep", shell_redirect=">/dev/full"))
    _one_line(r, 2, "lccopt: error: cannot write to standard output: No space left on device")
    assert (tmp_path / "rep" / "report.md").is_file()   # the work is done all the same
    r = _done(_lccopt("status", run, shell_redirect="2>&- <&-"))
    assert r.returncode == 0 and r.stdout.startswith(f"{run}: finished"), r


# ------------------------------------------------------------------------ status's clock

def _rewrite_journal(run: Path, change) -> None:
    import json

    from lccopt.engine.journal import read_journal

    events = change(read_journal(run / "journal.jsonl")[0])
    for seq, ev in enumerate(events):
        ev["seq"] = seq
    (run / "journal.jsonl").write_text("".join(json.dumps(ev) + "\n" for ev in events))
    (run / "state.json").unlink(missing_ok=True)


def _holding_the_lock(run: Path):
    """The run's lock held as its driving process holds it: status says 'running'."""
    import fcntl

    fh = open(run / "lock", "rb")
    fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    return fh


def test_status_rates_a_running_run_by_the_monotonic_clock_whatever_the_wall_clock_did(
        tmp_path, finished):
    """A wall-clock step (NTP, a changed date) between results: the pace and the time left
    come from the driving process's monotonic clock (one result per second here, 10 left),
    never negative or absurd; a journal of an lccopt that wrote only the wall clock is rated
    from the results after its last step back."""
    _, run, _ = finished

    def running_with_a_step(events, mono=True):
        events = [ev for ev in events if ev["event"] not in ("finished", "session")]
        events[0]["budget"] = 20
        results = [ev for ev in events if ev["event"] in ("evaluated", "failed")]
        for k, ev in enumerate(results):
            ev["at"] = 1.8e9 + k - (17300.0 if k >= 5 else 0.0)   # the wall clock stepped back
            if mono:
                ev["mono"] = 5000.0 + k
            else:
                ev.pop("mono", None)
        return events

    _rewrite_journal(run, running_with_a_step)
    lock = _holding_the_lock(run)
    try:
        r = subprocess.run(lccopt_command() + ["status", str(run)], capture_output=True,
                           text=True, timeout=60, env=subprocess_env())
        assert r.returncode == 0, r.stderr
        assert "running, 10/20 evaluations" in r.stdout, r.stdout
        assert "one result every 1 s lately; about 0:00:10 left" in r.stdout, r.stdout
        _rewrite_journal(run, lambda events: running_with_a_step(events, mono=False))
        r = subprocess.run(lccopt_command() + ["status", str(run)], capture_output=True,
                           text=True, timeout=60, env=subprocess_env())
        assert "one result every 1 s lately; about 0:00:10 left" in r.stdout, r.stdout
    finally:
        lock.close()


# ------------------------------------------------------------------------ damaged files

def _error_line(r) -> str:
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    lines = r.stderr.strip().splitlines()
    assert lines and lines[-1].startswith("lccopt: error: "), r.stderr
    return lines[-1]


def test_a_damaged_journal_or_results_file_is_one_line_naming_it(tmp_path, finished):
    """Lines that are whole JSON but hold what lccopt cannot use (a text for a number, a
    result of a design never asked): status and resume exit 2 naming the journal and the
    line; a results.h5 that claims 10^11 rows is refused by report, naming it, never
    allocated; a state.json crafted to match the journal's line is a cache: resume replays."""
    import json
    import shutil

    import h5py

    _, run, _ = finished

    def text_for_a_number(events):
        next(ev for ev in events if ev["event"] == "asked" and ev["id"] == 3)["x"][0] = "abc"
        return events

    def a_result_never_asked(events):
        next(ev for ev in events if ev["event"] == "evaluated" and ev["id"] == 3)["id"] = 99
        return events

    for what, damage in (("text", text_for_a_number), ("id", a_result_never_asked)):
        copy = tmp_path / what / "ctl"
        shutil.copytree(run, copy)
        _rewrite_journal(copy, damage)
        for args in (["status", copy], ["resume", copy, "--budget", "12", "--workers", "1"]):
            r = subprocess.run(lccopt_command() + [str(a) for a in args], capture_output=True,
                               text=True, timeout=120, env=subprocess_env(**ENV))
            line = _error_line(r)
            assert f"{copy / 'journal.jsonl'}: line " in line and "is damaged" in line, line
    big = tmp_path / "big" / "ctl"
    shutil.copytree(run, big)
    (big / "journal.jsonl").unlink()
    with h5py.File(big / "results.h5", "a") as f:
        del f["evaluations/id"]
        f["evaluations"].create_dataset("id", shape=(10 ** 11,), dtype="i8", chunks=(1000,))
    r = subprocess.run(lccopt_command() + ["report", str(big), "--out", str(tmp_path / "rep")],
                       capture_output=True, text=True, timeout=120, env=subprocess_env())
    line = _error_line(r)
    assert f"{big / 'results.h5'}" in line and "100000000000" in line, line
    # a snapshot that names the journal's last line but holds nonsense: dropped, replayed
    state = json.loads((run / "state.json").read_text())
    state["strategy"] = {"history": "nonsense", "rng": [1, 2]}
    (run / "state.json").write_text(json.dumps(state))
    # an evaluation file whose design claims 10^11 values: damaged, simulated again
    with h5py.File(run / "evals" / "000002.h5", "a") as f:
        del f["design"]
        f.create_dataset("design", shape=(10 ** 11,), dtype="f8", chunks=(1000,))
    r = subprocess.run(lccopt_command() + ["resume", str(run), "--budget", "12", "--workers",
                                           "1"], capture_output=True, text=True, timeout=120,
                       env=subprocess_env(**ENV))
    assert r.returncode == 0, r.stderr
    assert "lost or damaged, simulating them again: #2" in r.stderr, r.stderr
    assert len(read_table(run)["id"]) == 12


# ------------------------------------------------------------------------ stored strings

def test_a_runs_stored_strings_are_printed_escaped(tmp_path, finished):
    """Terminal escape sequences, carriage returns and newlines in run.json's case file and
    variable names (a run directory from elsewhere) are shown as escapes by status and
    resume: no colour, no retitled terminal, no forged line."""
    import json

    _, run, _ = finished
    meta = json.loads((run / "run.json").read_text())
    meta["case_file"] = "/nowhere/\x1b]0;pwned\x07\x1b[2J\nlccopt: done.yaml"
    meta["variables"][0][0] = "x_r1\x1b[31m\r\nforged"
    meta["variables"][0][1] = "MN/m\x1b[5m"
    (run / "run.json").write_text(json.dumps(meta))
    status = subprocess.run(lccopt_command() + ["status", str(run)], capture_output=True,
                            text=True, timeout=60, env=subprocess_env())
    resume = subprocess.run(lccopt_command() + ["resume", str(run), "--budget", "11",
                                                "--workers", "1"],
                            capture_output=True, text=True, timeout=120, env=subprocess_env(**ENV))
    assert status.returncode == 0 and resume.returncode == 0, (status.stderr, resume.stderr)
    for text in (status.stdout, resume.stdout, resume.stderr):
        assert not any(c in text for c in "\x1b\x07\r"), text
        assert "\nforged" not in text and "\nlccopt: done.yaml" not in text, text
    assert "x_r1\\x1b[31m\\r\\nforged=" in status.stdout, status.stdout
    assert "/nowhere/\\x1b]0;pwned\\x07\\x1b[2J\\nlccopt: done.yaml is gone" in resume.stderr


# ------------------------------------------------------------------------ messages

def test_each_message_names_what_the_user_typed(tmp_path, finished):
    """--set values the YAML reader refuses, keys --set made, a --set budget below the file's
    initial design, resume --budget out of bounds or below the run's evaluations, a control
    character in a case file: exit 2, one line, blaming --set, --budget or the file's line."""
    case, run, _ = finished

    def line(*args) -> str:
        return _error_line(subprocess.run(lccopt_command() + [str(a) for a in args],
                                          capture_output=True, text=True, timeout=120,
                                          env=subprocess_env(**ENV)))

    got = line("check", case, "--set", "description=&a x")
    assert got.startswith("lccopt: error: --set: description: cannot read the value '&a x': "
                          "anchors and aliases") and "other.yaml" not in got, got
    assert """--set 'description="&a x"'""" in got, got
    assert line("check", case, "--set", "nosuch.key=3").startswith(
        "lccopt: error: --set: nosuch: unknown key"), "blamed on the case file's line 1"
    got = line("check", case, "--set", "optimisation.budget=3")
    assert got.startswith("lccopt: error: --set: optimisation.budget: 3 is below the 4 initial "
                          f"points ({case}:"), got
    assert line("resume", run, "--budget", "-5") == (
        "lccopt: error: --budget -5: a budget is 2 to 100000 evaluations")
    assert line("resume", run, "--budget", "3") == (
        "lccopt: error: --budget 3 is below the 10 evaluations the run has already asked for; "
        "give at least 10")
    bad = tmp_path / "escape.yaml"
    bad.write_text(f"extends: {case}\ndescription: a\x1bb\n")
    got = line("check", bad)
    assert got.startswith(f"lccopt: error: {bad}:2: ") and "\x1b" not in got, got


# ------------------------------------------------------------------------ degenerate objectives

def test_an_objective_no_design_can_change_is_refused_by_check(tmp_path):
    """A spread (max - min) over one sleeper is 0 for every design: check refuses it with the
    file, line and key of the count, before anything is simulated (optimise spent the
    reference simulation, then blamed an asf.worst the user never set, on every resume)."""
    settle = tmp_path / "one.yaml"
    settle.write_text(f"extends: {REPO_CONFIGS / 'settlement.yaml'}\nname: one\n"
                      "degradation:\n  settling_sleepers: 1\n  tamping: {unreachable_sleepers: 0}\n"
                      "optimisation:\n  objectives: [differential_settlement, F_max]\n")
    zone = tmp_path / "zone.yaml"
    zone.write_text(f"extends: {REPO_CONFIGS / 'quickstart.yaml'}\nname: zone\n"
                    "evaluation:\n  sleepers: 1\n")
    for case, key, line in ((settle, "degradation.settling_sleepers", 4),
                            (zone, "evaluation.sleepers", 4)):
        for args in (["check", case], ["optimise", case, "--runs", tmp_path / "runs"]):
            r = subprocess.run(lccopt_command() + [str(a) for a in args], capture_output=True,
                               text=True, timeout=120, env=subprocess_env())
            got = _error_line(r)
            assert got.startswith(f"lccopt: error: {case}:{line}: {key}: 1 "), got
            assert "0 for every design" in got, got
    assert not (tmp_path / "runs").exists()


def test_a_reference_design_at_zero_names_the_default_worst_and_resumes_once_set(tmp_path):
    """An objective the reference design brings to 0 (data, not the case's making) leaves the
    default ASF worst value no room: one line naming the case and what to set, no budget spent,
    and the run carries on once asf.worst is set."""
    case = write_case(tmp_path, "zero", budget=8, initial=4, worst=(60000.0, 5.0))
    text = case.read_text()
    case.write_text(text.replace("  asf:\n    worst: [60000.0, 5.0]\n", ""))
    env = {**ENV, "LCCOPT_FAKE_ZERO": "E_max"}
    r = subprocess.run(lccopt_command() + ["optimise", str(case), "--workers", "1", "--runs",
                                           str(tmp_path / "runs")],
                       capture_output=True, text=True, timeout=120, env=subprocess_env(**env))
    got = _error_line(r)
    assert got.startswith(f"lccopt: error: {case}: E_max: the reference design's E_max is 0"), got
    assert "set optimisation.asf.worst" in got, got
    from .conftest import journal_events

    run = tmp_path / "runs" / "zero"
    assert not [e for e in journal_events(run) if e["event"] in ("evaluated", "failed")]
    case.write_text(text)
    r = subprocess.run(lccopt_command() + ["resume", str(run), "--allow-changed-case",
                                           "--workers", "1"],
                       capture_output=True, text=True, timeout=120, env=subprocess_env(**env))
    assert r.returncode == 0, r.stderr
    assert len(read_table(run)["id"]) == 8


# ------------------------------------------------------------------------ a stopped driver

def test_a_driver_stopped_longer_than_the_timeout_charges_nothing_to_the_designs(tmp_path):
    """Ctrl-Z (SIGSTOP to the process group: driver and workers) for twice the timeout, then
    SIGCONT: the evaluations in flight finish as if nothing happened (they were recorded as
    timed out), and the table is the uninterrupted run's."""
    from .conftest import n_done

    case = write_case(tmp_path, "paused", budget=8, initial=4, seed=4, timeout=2.0)
    reference = read_table(optimise(case, workers=2, runs=tmp_path / "whole", evaluator=FAKE,
                                    progress=False))
    p = _lccopt("optimise", case, "--workers", "2", "--runs", tmp_path / "runs",
                env={**ENV, "LCCOPT_FAKE_DELAY": "1.0"})
    run = tmp_path / "runs" / "paused"
    deadline = time.monotonic() + 120
    while n_done(run) < 2:
        assert time.monotonic() < deadline and p.poll() is None
        time.sleep(0.05)
    time.sleep(0.3)              # evaluations in flight
    os.killpg(p.pid, signal.SIGSTOP)
    time.sleep(4.5)
    os.killpg(p.pid, signal.SIGCONT)
    r = _done(p)
    assert r.returncode == 0, r.stderr
    assert "FAILED" not in r.stderr, r.stderr
    assert_same_evaluations(reference, read_table(run))


def _children(pid: int) -> list[int]:
    out = []
    for tid in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{tid}/children") as f:
            out += [int(c) for c in f.read().split()]
    return out


def test_one_worker_stopped_longer_than_the_timeout_charges_nothing_to_its_design(tmp_path):
    """SIGSTOP to one local worker and the evaluation it runs (not to the driver) for 2.5 times
    the timeout: its design is not recorded as timed out but runs again on a fresh worker, and
    the table is the uninterrupted run's. A design that hangs while its worker runs is still
    timed out (test_engine's faulty-simulations test)."""
    from .conftest import n_done

    case = write_case(tmp_path, "frozen", budget=8, initial=4, seed=5, timeout=2.0)
    reference = read_table(optimise(case, workers=2, runs=tmp_path / "whole", evaluator=FAKE,
                                    progress=False))
    p = _lccopt("optimise", case, "--workers", "2", "--runs", tmp_path / "runs",
                env={**ENV, "LCCOPT_FAKE_DELAY": "1.0"})
    run = tmp_path / "runs" / "frozen"
    deadline = time.monotonic() + 120
    while n_done(run) < 2:
        assert time.monotonic() < deadline and p.poll() is None
        time.sleep(0.05)
    time.sleep(0.3)              # evaluations in flight
    worker = _children(p.pid)[0]
    frozen = [worker] + _children(worker)
    for pid in frozen:
        os.kill(pid, signal.SIGSTOP)
    time.sleep(5.0)
    for pid in frozen:           # the driver has killed them by now; a live one goes on
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGCONT)
    r = _done(p)
    assert r.returncode == 0, r.stderr
    assert "FAILED" not in r.stderr and "timed out" not in r.stderr, r.stderr
    assert_same_evaluations(reference, read_table(run))


def test_workers_that_cannot_start_an_evaluation_stop_the_run_with_nothing_failed(tmp_path):
    """A local worker whose fork fails (no memory or process slots left) is the machine's
    fault: exit 2 with one line, the evaluation in flight stays pending (it was recorded as
    failed, 'worker process died'), and a resume ends the run as an uninterrupted one."""
    from .conftest import journal_events

    case = write_case(tmp_path, "nofork", budget=8, initial=4, seed=2)
    reference = read_table(optimise(case, workers=1, runs=tmp_path / "whole", evaluator=FAKE,
                                    progress=False))
    runs = tmp_path / "runs"
    r = subprocess.run(lccopt_command() + ["optimise", str(case), "--workers", "1", "--runs",
                                           str(runs)], capture_output=True, text=True,
                       timeout=120,
                       env=subprocess_env(LCCOPT_EVALUATOR="tests.engine.forkless:evaluate"))
    got = _error_line(r)
    assert "cannot start an evaluation process: Resource temporarily unavailable" in got, got
    assert f"'lccopt resume {runs / 'nofork'}'" in got, got
    events = journal_events(runs / "nofork")
    assert sum(e["event"] == "evaluated" for e in events) == 3
    assert not [e for e in events if e["event"] == "failed"]
    r = subprocess.run(lccopt_command() + ["resume", str(runs / "nofork"), "--workers", "1"],
                       capture_output=True, text=True, timeout=120, env=subprocess_env(**ENV))
    assert r.returncode == 0, r.stderr
    assert_same_evaluations(reference, read_table(runs / "nofork"))


def test_an_interruption_wrapped_by_python_is_still_an_interruption():
    """A signal raised inside a class body's __set_name__ (a lazily imported dataclass) comes
    out wrapped in a RuntimeError: the command line finds the interruption behind it."""
    from lccopt.cli import _interruption_behind
    from lccopt.errors import Interrupted

    class Stopped:
        def __set_name__(self, owner, name):
            raise Interrupted(signal.SIGTERM)

    with pytest.raises(RuntimeError) as caught:
        type("Case", (), {"data": Stopped()})
    found = _interruption_behind(caught.value)
    assert isinstance(found, Interrupted) and found.signum == signal.SIGTERM
    assert _interruption_behind(RuntimeError("a real fault")) is None
