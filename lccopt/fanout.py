"""Processes of lccopt's own: how one is started (its environment, its stopping signals, its
death with its parent), for the engine's local workers and the calls spread here; and
independent calls of one function spread over such processes, answered in order (a
settlement report's law check, ``simulate``'s realisations: simulations that take seconds to
minutes each and need nothing of each other).

A process of ``call_in_processes`` is a fresh interpreter (``python -c``, as the engine's
workers: nothing of the caller is inherited, and the caller's ``__main__`` is never imported
again, as ``multiprocessing``'s spawn would) that reads its calls pickled on stdin, one at a
time, and answers each pickled on stdout before it is handed the next. It ignores the
stopping signals, which reach the whole process group (the caller stops and kills it), dies
with the caller (kill -9), and runs single-threaded BLAS (the processes are the parallelism).
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable, Sequence

from .errors import STOP_SIGNALS

_SERVE = "from lccopt.fanout import _serve; _serve()"
_PR_SET_PDEATHSIG = 1

# Set in every process of lccopt's own before numpy is imported: N processes use N cores.
SINGLE_THREAD_ENV = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "VECLIB_MAXIMUM_THREADS": "1",
    "NUMEXPR_NUM_THREADS": "1",
}


def child_env() -> dict:
    """The environment of a process of lccopt's own: this one's, with single-threaded BLAS
    and lccopt's folder first on PYTHONPATH (importable even where it is not installed)."""
    env = {**os.environ, **SINGLE_THREAD_ENV}
    here = str(Path(__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([here] + [p for p in [env.get("PYTHONPATH")] if p])
    return env


def ignore_stop_signals() -> None:
    """Ignore the stopping signals: they reach the whole process group, and the parent stops
    its processes itself. Run between fork and exec, the ignored disposition survives exec,
    so a Ctrl-C during the interpreter's start cannot kill the process."""
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)


_libc = None  # loaded once, inherited by forked children (0.2 ms each)


def _load_libc():
    global _libc
    if _libc is None:
        import ctypes

        _libc = ctypes.CDLL("libc.so.6", use_errno=True)
    return _libc


def die_with_parent(parent_pid: int) -> None:
    """Linux: ask the kernel to SIGKILL this process when its parent dies (kill -9 of the
    run); exit at once if it died already. Elsewhere nothing (a process then ends on its
    broken pipe)."""
    try:
        _load_libc().prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        if os.getppid() != parent_pid:  # the parent died before prctl
            os._exit(1)
    except Exception:  # noqa: BLE001 - not Linux
        pass


def call_in_processes(fn: Callable, calls: Sequence[tuple], processes: int) -> list[Any]:
    """``[fn(*args) for args in calls]``, spread over ``processes`` processes (in this process
    when one is enough), answered in order. Each process is handed the next call as soon as it
    has answered its last, so calls of unequal cost (a settlement prediction that tamps twice
    as often, a realisation with hanging sleepers) keep every process busy to the end. ``fn``
    and the arguments must pickle; ``fn`` must be importable by its module's name. A call that
    raises has its exception raised here; a process that dies raises RuntimeError.
    Interrupted (Ctrl-C, any exception here), the processes are killed before it propagates."""
    from multiprocessing.connection import wait

    n = min(int(processes), len(calls))
    if n <= 1:
        return [fn(*args) for args in calls]
    with contextlib.suppress(Exception):   # loaded here, not between fork and exec
        _load_libc()
    parent, env = os.getpid(), child_env()
    try:   # their stderr is this process's; none if it has none (closed: 2>&-)
        os.fstat(2)
        stderr = None
    except OSError:
        stderr = subprocess.DEVNULL
    procs: list[subprocess.Popen] = []
    results: list[Any] = [None] * len(calls)
    todo = iter(range(len(calls)))

    def hand_next(p: subprocess.Popen) -> bool:
        """Send ``p`` the next call (True), or tell it there is none (False)."""
        i = next(todo, None)
        try:
            pickle.dump(None if i is None else (i, calls[i]), p.stdin)
            p.stdin.flush()
        except BrokenPipeError:   # it died: its end of file below says how
            pass
        if i is None:
            with contextlib.suppress(OSError):
                p.stdin.close()
        return i is not None

    try:
        for _ in range(n):
            p = subprocess.Popen([sys.executable, "-c", _SERVE], stdin=subprocess.PIPE,
                                 stdout=subprocess.PIPE, stderr=stderr, env=env,
                                 preexec_fn=lambda: _child_setup(parent))
            procs.append(p)
            try:   # this process's sys.path first: fn's module is found as it was here
                pickle.dump(list(sys.path), p.stdin)
                pickle.dump(fn, p.stdin)
            except BrokenPipeError:
                pass
        busy = {p.stdout: p for p in procs if hand_next(p)}
        while busy:
            for stdout in wait(list(busy)):
                p = busy.pop(stdout)
                try:   # one answer per call handed, written whole: this read cannot stall
                    i, kind, value = pickle.load(stdout)
                except EOFError:
                    raise RuntimeError(f"a process of {fn.__name__} died ({_how(p.wait())})") \
                        from None
                if kind == "error":
                    raise value
                results[i] = value
                if hand_next(p):
                    busy[stdout] = p
        for p in procs:
            code = p.wait()
            if code != 0:
                raise RuntimeError(f"a process of {fn.__name__} died ({_how(code)})")
        return results
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
            p.wait()
            for pipe in (p.stdin, p.stdout):
                with contextlib.suppress(OSError):
                    pipe.close()


def _how(code: int) -> str:
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


def _child_setup(parent: int) -> None:
    """Between fork and exec (libc loaded before the fork): the stopping signals ignored,
    death with the caller; both survive exec."""
    ignore_stop_signals()
    die_with_parent(parent)


def _serve() -> None:
    """A process's side: its calls from stdin, one at a time, each answered on stdout as
    ``(index, "ok", result)`` or ``(index, "error", exception)`` before the next is read; it
    ends at a None or end of file. What the calls print goes to stderr (file descriptor 1 is
    pointed there), never into the answers."""
    answer = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    calls = sys.stdin.buffer
    sys.path[:0] = [p for p in pickle.load(calls) if p not in sys.path]
    fn = pickle.load(calls)
    while True:
        try:
            call = pickle.load(calls)
        except EOFError:
            return
        if call is None:
            return
        i, args = call
        try:
            out = (i, "ok", fn(*args))
        except Exception as exc:  # noqa: BLE001 - raised again in the caller
            out = (i, "error", exc)
        try:
            data = pickle.dumps(out)
        except Exception as why:  # noqa: BLE001 - an answer that does not pickle: words
            what = out[2] if out[1] == "error" else why
            data = pickle.dumps((i, "error", RuntimeError(f"{type(what).__name__}: {what}")))
        answer.write(data)
        answer.flush()
