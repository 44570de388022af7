"""Independent calls of one function spread over processes of their own, answered in order:
the report's law check, whose settlement predictions take seconds to minutes each and need
nothing of each other.

Each process is a fresh interpreter (``python -c``, as the engine's workers: nothing of the
caller is inherited, and the caller's ``__main__`` is never imported again, as
``multiprocessing``'s spawn would) that reads its share of the calls pickled on stdin and
writes their results pickled on stdout. It ignores the stopping signals, which reach the
whole process group (the caller stops and kills it), dies with the caller (kill -9), and runs
single-threaded BLAS (the processes are the parallelism).
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
_SINGLE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
_PR_SET_PDEATHSIG = 1


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
    prctl = _prctl()
    parent = os.getpid()
    env = {**os.environ, **_SINGLE_THREAD}
    here = str(Path(__file__).resolve().parents[1])   # lccopt importable even if not installed
    env["PYTHONPATH"] = os.pathsep.join([here] + [p for p in [env.get("PYTHONPATH")] if p])
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
                                 preexec_fn=lambda: _child_setup(prctl, parent))
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


def _prctl():
    """libc's prctl, loaded here rather than between fork and exec; None where there is none."""
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def _child_setup(prctl, parent: int) -> None:
    """Between fork and exec: ignored signals stay ignored across exec, so a Ctrl-C during
    the interpreter's start cannot kill the process; the death signal survives exec too."""
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)
    if prctl is not None:
        prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        if os.getppid() != parent:   # the caller died before prctl
            os._exit(1)


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
