"""Calls spread over processes of their own (lccopt.fanout): the same answers as in one
process, in order; errors and dead processes said; Ctrl-C to the process group and kill -9
of the caller leave no process behind."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from lccopt.fanout import call_in_processes
from tests.conftest import leaves_no_process


def test_the_answers_are_those_of_one_process_in_order():
    rng = np.random.default_rng(7)
    calls = [(rng.standard_normal((40, 40)),) for _ in range(7)]
    here = [np.linalg.inv(*c) for c in calls]
    there = call_in_processes(np.linalg.inv, calls, 3)
    assert len(there) == 7
    for a, b in zip(here, there):
        np.testing.assert_array_equal(a, b)      # bit for bit
    pids = call_in_processes(os.getpid, [()] * 5, 2)
    assert len(set(pids)) == 2 and os.getpid() not in pids
    assert call_in_processes(os.getpid, [()] * 3, 1) == [os.getpid()] * 3   # one: here
    assert call_in_processes(print, [("said",)] * 2, 2) == [None, None]   # printing is no answer


def pid_after(seconds: float) -> int:
    time.sleep(seconds)
    return os.getpid()


def test_a_long_call_does_not_hold_the_calls_after_it():
    """Each process is handed the next call when it has answered its last: while one works
    on a long call, the other answers all the short ones (dealt out in advance, half of them
    would wait behind the long one)."""
    pids = call_in_processes(pid_after, [(3.0,)] + [(0.0,)] * 5, 2)
    assert len(set(pids[1:])) == 1 and pids[1] != pids[0], pids


def test_an_answer_that_does_not_pickle_is_said():
    with pytest.raises(RuntimeError, match="cannot pickle"):
        call_in_processes(_a_lock, [(), ()], 2)


def _a_lock():
    import threading

    return threading.Lock()


def test_an_error_is_raised_as_itself_and_a_dead_process_is_said():
    with pytest.raises(ValueError, match="math domain error"):
        call_in_processes(math.sqrt, [(4.0,), (-1.0,), (9.0,)], 2)
    with pytest.raises(RuntimeError, match=r"a process of _exit died \(exit code 3\)"):
        call_in_processes(os._exit, [(3,), (3,)], 2)


_CALLER = """
import sys, time
from lccopt.errors import stop_on_signals
from lccopt.fanout import call_in_processes
stop_on_signals()
print("ready", flush=True)
try:
    call_in_processes(time.sleep, [(60,)] * 2, 2)
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(130)
"""


def _children(pid: int) -> list[int]:
    with open(f"/proc/{pid}/task/{pid}/children", encoding="ascii") as f:
        return [int(c) for c in f.read().split()]


@pytest.mark.parametrize("how", ["ctrl-c to the group", "kill -9 of the caller"])
def test_no_process_outlives_its_caller(how):
    p = subprocess.Popen([sys.executable, "-c", _CALLER], stdout=subprocess.PIPE, text=True,
                         start_new_session=True)
    with leaves_no_process(p.pid):
        assert p.stdout.readline().strip() == "ready"
        t0 = time.monotonic()
        while len(_children(p.pid)) < 2:
            assert time.monotonic() - t0 < 60, "the processes did not start"
            time.sleep(0.05)
        time.sleep(0.5)                            # their interpreters started
        if how == "ctrl-c to the group":
            os.killpg(p.pid, signal.SIGINT)
            out, _ = p.communicate(timeout=30)
            assert p.returncode == 130 and out.strip() == "interrupted"
        else:
            p.kill()
            p.wait(timeout=30)


def test_a_function_of_the_callers_own_modules_is_found(tmp_path):
    """A function from a module only the caller's sys.path reaches (a notebook's folder, an
    uninstalled checkout) runs in the processes as here."""
    (tmp_path / "mine_fanout.py").write_text("def twice(v):\n    return 2 * v\n")
    sys.path.insert(0, str(tmp_path))
    try:
        import mine_fanout

        assert call_in_processes(mine_fanout.twice, [(1,), (2,), (3,)], 2) == [2, 4, 6]
    finally:
        sys.path.remove(str(tmp_path))
        sys.modules.pop("mine_fanout", None)


def test_a_caller_without_stderr_still_gets_its_answers():
    """A caller whose stderr is closed (2>&-): the processes print nowhere, and what a call
    prints never reaches the answer (a pipe made then may take descriptor 2)."""
    code = ("import os, sys; os.close(2); from lccopt.fanout import call_in_processes; "
            "print(call_in_processes(print, [('said',)] * 2, 2), flush=True)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert (r.returncode, r.stdout) == (0, "[None, None]\n"), r.stdout
