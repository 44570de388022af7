"""Processes of lccopt's own: how one is started (its environment, its stopping signals, its
death with its parent), for the engine's local workers and the calls spread here; and
independent calls of one function spread over such processes, answered in order (a
settlement report's law check, ``simulate``'s realisations: simulations that take seconds to
minutes each and need nothing of each other).

A process of ``call_in_processes`` is a fresh interpreter (``python -c``, as the engine's
workers: nothing of the caller is inherited, and the caller's ``__main__`` is never imported
again, as ``multiprocessing``'s spawn would) that reads its share of the calls pickled on
stdin and writes their results pickled on stdout. It ignores the stopping signals, which
reach the whole process group (the caller stops and kills it), dies with the caller (kill
-9), and runs single-threaded BLAS (the processes are the parallelism).
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
    """``[fn(*args) for args in calls]``, the calls dealt round-robin to ``processes``
    processes (in this process when one is enough). ``fn`` and the arguments must pickle;
    ``fn`` must be importable by its module's name. A call that raises has its exception
    raised here; a process that dies raises RuntimeError. Interrupted (Ctrl-C, any exception
    here), the processes are killed before it propagates."""
    n = min(int(processes), len(calls))
    if n <= 1:
        return [fn(*args) for args in calls]
    shares = [list(range(i, len(calls), n)) for i in range(n)]
    with contextlib.suppress(Exception):   # loaded here, not between fork and exec
        _load_libc()
    parent, env = os.getpid(), child_env()
    try:   # their stderr is this process's; none if it has none (closed: 2>&-)
        os.fstat(2)
        stderr = None
    except OSError:
        stderr = subprocess.DEVNULL
    procs: list[subprocess.Popen] = []
    try:
        for share in shares:
            p = subprocess.Popen([sys.executable, "-c", _SERVE], stdin=subprocess.PIPE,
                                 stdout=subprocess.PIPE, stderr=stderr, env=env,
                                 preexec_fn=lambda: _child_setup(parent))
            procs.append(p)
            try:   # this process's sys.path first: fn's module is found as it was here
                p.stdin.write(pickle.dumps(list(sys.path)))
                p.stdin.write(pickle.dumps((fn, [calls[i] for i in share])))
                p.stdin.close()
            except BrokenPipeError:   # it died at once: its exit code below says how
                pass
        results: list[Any] = [None] * len(calls)
        for share, p in zip(shares, procs):
            answer = p.stdout.read()
            code = p.wait()
            if code != 0:
                raise RuntimeError(f"a process of {fn.__name__} died ({_how(code)})")
            for i, (kind, value) in zip(share, pickle.loads(answer)):
                if kind == "error":
                    raise value
                results[i] = value
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
    """A process's side: its calls from stdin, their results (or the first error) on stdout.
    What the calls print goes to stderr (file descriptor 1 is pointed there), never into the
    answer."""
    answer = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    sys.path[:0] = [p for p in pickle.load(sys.stdin.buffer) if p not in sys.path]
    fn, calls = pickle.load(sys.stdin.buffer)
    out = []
    for args in calls:
        try:
            out.append(("ok", fn(*args)))
        except Exception as exc:  # noqa: BLE001 - raised again in the caller
            out.append(("error", exc))
            break
    try:
        data = pickle.dumps(out)
    except Exception:  # noqa: BLE001 - an exception that does not pickle: its words instead
        kind, exc = out[-1]
        out[-1] = (kind, RuntimeError(f"{type(exc).__name__}: {exc}"))
        data = pickle.dumps(out)
    answer.write(data)
    answer.flush()
