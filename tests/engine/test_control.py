"""Run control under attack, with real processes: stopping signals at any moment of any
command, closed and full standard streams. Each gets the documented exit code and one line,
and a run that was stopped resumes to the table of an uninterrupted one."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from lccopt.engine.runner import optimise
from tests.conftest import lccopt_command, subprocess_env

from .conftest import FAKE, assert_same_evaluations, read_table, write_case

ENV = {"LCCOPT_EVALUATOR": FAKE}


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


def _stopped(args, sig, after: float, env=None) -> subprocess.CompletedProcess:
    """Start ``lccopt ARGS``, send SIG to its process group AFTER seconds, wait."""
    p = _lccopt(*args, env=env)
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
    130 and one line naming the signal (the commands that finish first exit 0)."""
    case, run, _ = finished
    name = signal.Signals(sig).name
    for args, may_finish in ((["simulate", case, "--out", tmp_path / "sim"], False),
                             (["report", run, "--out", tmp_path / "rep"], False),
                             (["check", case], True), (["status", run], True)):
        for after in (0.3, 0.8):
            r = _stopped(args, sig, after)
            if may_finish and r.returncode == 0:
                continue
            _one_line(r, 130, f"lccopt: interrupted by {name}")


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
