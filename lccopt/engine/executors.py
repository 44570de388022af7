"""Executors: where evaluations run. One small interface, two implementations.

    ex.start()                 start workers / connect
    ex.free() -> int           how many tasks can be submitted now
    ex.running -> int          tasks in flight
    ex.submit(task)            start one Task (only when free() > 0)
    ex.wait(timeout) -> [Outcome]   finished tasks (ok or failed), at most `timeout` s of waiting
    ex.kill_running()          stop every task in flight (they are not reported)
    ex.close()

:class:`LocalPool` is a pool of our own worker processes (a fresh interpreter each,
started with ``python -c``: nothing of this process is inherited), one socket pair and one
task per worker, so that a worker that dies (segfault, ``os._exit``, OOM kill) or hangs
past the timeout is killed and replaced and only its task is recorded as failed
(``concurrent.futures.ProcessPoolExecutor`` breaks as a whole on one dead worker). Workers
run single-threaded BLAS, ignore SIGINT and die with the parent process.

:class:`DaskExecutor` submits to a ``dask.distributed`` scheduler (``--scheduler ADDRESS``).
A task past the timeout is cancelled and recorded as failed (Dask cannot kill a running
Python thread: the worker thread stays busy until the simulation returns); a worker that
dies is handled by Dask (the task is retried elsewhere, then reported as failed).
"""

from __future__ import annotations

import contextlib
import multiprocessing.connection as mpc
import os
import signal
import socket
import subprocess
import sys
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from .worker import SINGLE_THREAD_ENV, STOP_SIGNALS, Outcome, Task, _death_reason, load_evaluator, run_task


class ExecutorError(Exception):
    """The executor cannot run at all (bad evaluator, no Dask, scheduler unreachable)."""


def default_workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def _ignore_stop_signals() -> None:
    """Run in the worker between fork and exec: the ignored disposition survives exec, so
    Ctrl-C or SIGTERM to the process group during the worker's start-up cannot kill it."""
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)


_WORKER_MAIN = ("import sys; from lccopt.engine.worker import local_worker_main; "
                "local_worker_main(*map(int, sys.argv[1:]))")


@dataclass
class _Slot:
    index: int
    proc: subprocess.Popen | None = None
    conn: mpc.Connection | None = None
    pidfd: int | None = None
    ready: bool = False
    task: Task | None = None
    started: float = 0.0
    deaths_before_ready: int = 0

    def waitables(self) -> list:
        return [self.conn] + ([self.pidfd] if self.pidfd is not None else [])


class LocalPool:
    kind = "local"

    def __init__(self, case, spec, workers: int, timeout: float):
        if workers < 1:
            raise ExecutorError(f"--workers must be at least 1, got {workers}")
        self.case, self.spec, self.timeout = case, spec, float(timeout)
        self.slots = int(workers)
        self._slots = [_Slot(i) for i in range(self.slots)]
        self.description = f"{self.slots} local worker process{'es' if self.slots > 1 else ''}"

    # -- lifecycle --------------------------------------------------------------------------
    def start(self, wait: float = 120.0) -> None:
        """Start the workers; return once they are ready (ExecutorError if they cannot start)."""
        for s in self._slots:
            self._spawn(s)
        deadline = time.monotonic() + wait
        while self.free() < self.slots and time.monotonic() < deadline:
            for o in self.wait(0.1):  # no task yet: only "ready", "fatal" or deaths
                pass

    def _spawn(self, s: _Slot) -> None:
        parent_sock, child_sock = socket.socketpair()
        env = {**os.environ, **SINGLE_THREAD_ENV}
        here = str(Path(__file__).resolve().parents[2])  # lccopt importable even if not installed
        env["PYTHONPATH"] = os.pathsep.join([here] + [p for p in [env.get("PYTHONPATH")] if p])
        cmd = [sys.executable, "-c", _WORKER_MAIN, str(child_sock.fileno()), str(os.getpid()), str(s.index)]
        proc = subprocess.Popen(cmd, pass_fds=[child_sock.fileno()], env=env, stdin=subprocess.DEVNULL,
                                preexec_fn=_ignore_stop_signals)
        child_sock.close()
        s.proc, s.ready, s.task = proc, False, None
        s.conn = mpc.Connection(parent_sock.detach())
        try:
            s.pidfd = os.pidfd_open(proc.pid)
        except (AttributeError, OSError):  # not Linux >= 5.3: death is seen as EOF on the socket
            s.pidfd = None
        try:
            s.conn.send(("init", self.case, self.spec, list(sys.path)))
        except OSError:
            pass  # died already: wait() notices

    def close(self) -> None:
        for s in self._slots:
            if s.proc is None:
                continue
            if s.task is None and s.ready:
                with contextlib.suppress(OSError):
                    s.conn.send(None)
        deadline = time.monotonic() + 3.0
        for s in self._slots:
            if s.proc is None:
                continue
            try:
                s.proc.wait(max(0.01, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                s.proc.kill()
                s.proc.wait(5)
            self._release(s)
            s.proc = None

    # -- tasks --------------------------------------------------------------------------------
    @property
    def running(self) -> int:
        return sum(s.task is not None for s in self._slots)

    def free(self) -> int:
        return sum(s.ready and s.task is None for s in self._slots)

    def submit(self, task: Task) -> None:
        for s in self._slots:
            if s.ready and s.task is None:
                s.task, s.started = task, time.monotonic()
                try:
                    s.conn.send(task)
                except OSError:
                    pass  # the worker died: noticed by wait() through its sentinel
                return
        raise RuntimeError("submit() without a free worker")

    def kill_running(self) -> None:
        for s in self._slots:
            if s.task is not None:
                self._kill(s)
                s.task = None
                self._spawn(s)

    def _kill(self, s: _Slot) -> None:
        with contextlib.suppress(Exception):
            s.proc.kill()
        with contextlib.suppress(Exception):
            s.proc.wait(5)
        self._release(s)

    @staticmethod
    def _release(s: _Slot) -> None:
        with contextlib.suppress(OSError):
            s.conn.close()
        if s.pidfd is not None:
            with contextlib.suppress(OSError):
                os.close(s.pidfd)
            s.pidfd = None

    def wait(self, timeout: float) -> list[Outcome]:
        now = time.monotonic()
        limit = timeout
        for s in self._slots:
            if s.task is not None:
                limit = min(limit, max(0.0, s.started + self.timeout - now))
        objs = [w for s in self._slots for w in s.waitables()]
        ready = set(mpc.wait(objs, timeout=max(0.0, limit)))
        out: list[Outcome] = []
        for s in self._slots:
            if s.conn in ready or (s.pidfd is not None and s.pidfd in ready) or s.proc.poll() is not None:
                self._drain(s, out)
        now = time.monotonic()
        for s in self._slots:
            if s.task is not None and now - s.started > self.timeout:
                task = s.task
                self._kill(s)
                out.append(Outcome.of(task, error=f"timed out after {self.timeout:g} s (worker killed)",
                                   wall_time=now - s.started, worker=f"local-{s.index}"))
                s.task = None
                self._spawn(s)
        return out

    def _drain(self, s: _Slot, out: list) -> None:
        dead = False
        try:
            while s.conn.poll():
                msg = s.conn.recv()
                if msg[0] == "ready":
                    s.ready, s.deaths_before_ready = True, 0
                elif msg[0] == "done":
                    outcome = msg[1]
                    if s.task is not None and outcome.id == s.task.id:
                        out.append(outcome)
                        s.task = None
                elif msg[0] == "crashed":  # the evaluation killed its (forked) process
                    if s.task is not None:
                        out.append(Outcome.of(s.task, error=msg[1], wall_time=time.monotonic() - s.started,
                                           worker=f"local-{s.index}"))
                        s.task = None
                elif msg[0] == "fatal":
                    self.close()
                    raise ExecutorError(msg[1])
        except (EOFError, OSError):
            dead = True
        if dead or s.proc.poll() is not None:
            with contextlib.suppress(subprocess.TimeoutExpired):
                s.proc.wait(5)
            reason = _death_reason(s.proc.returncode)
            if s.task is not None:
                out.append(Outcome.of(s.task, error=reason, wall_time=time.monotonic() - s.started,
                                   worker=f"local-{s.index}"))
                s.task = None
            if not s.ready:
                s.deaths_before_ready += 1
                if s.deaths_before_ready >= 3:
                    self.close()
                    raise ExecutorError(f"local worker processes die while starting: {reason}")
            self._release(s)
            self._spawn(s)


# ------------------------------------------------------------------------------ Dask

_DASK_EVALUATORS: dict = {}


def dask_task(case, task: Task, spec) -> Outcome:
    """Runs on a Dask worker (returns the whole Evaluation: the parent writes the file)."""
    try:
        from distributed import get_worker

        name = get_worker().address
    except Exception:  # noqa: BLE001
        name = "dask"
    key = spec if isinstance(spec, str) else id(spec)
    fn = _DASK_EVALUATORS.get(key)
    if fn is None:
        try:
            fn = _DASK_EVALUATORS[key] = load_evaluator(spec)
        except Exception as exc:  # noqa: BLE001
            return Outcome.of(task, error=f"cannot load the evaluator {spec!r} on {name}: {exc}",
                           worker=name)
    return run_task(case, task, fn, name)


class DaskExecutor:
    kind = "dask"

    def __init__(self, case, spec, address, timeout: float):
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise ExecutorError("--scheduler needs Dask: pip install 'dask[distributed]' "
                                "(or pip install 'lccopt[dask]')") from None
        self.case, self.spec, self.timeout = case, spec, float(timeout)
        self.address = address
        self.client = None
        self._futures: dict = {}  # future -> (task, submitted at)
        self._slots_cache = (0.0, 0)
        self.description = f"Dask scheduler {address if isinstance(address, str) else 'in-process'}"

    def start(self) -> None:
        from distributed import Client

        try:
            if isinstance(self.address, str):
                self.client = Client(self.address, timeout="20s", set_as_default=False)
            else:  # a Cluster object (tests, notebooks)
                self.client = Client(self.address, set_as_default=False)
        except Exception as exc:  # noqa: BLE001
            raise ExecutorError(f"cannot connect to the Dask scheduler at {self.address}: "
                                f"{type(exc).__name__}: {exc}") from None
        n = self._n_threads(force=True)
        self.description = f"Dask scheduler {self.client.scheduler.address} ({n} worker threads)"

    def _n_threads(self, force: bool = False) -> int:
        t, n = self._slots_cache
        if force or time.monotonic() - t > 5.0:
            try:
                n = int(sum(self.client.nthreads().values()))
            except Exception:  # noqa: BLE001
                pass
            self._slots_cache = (time.monotonic(), n)
        return n

    @property
    def slots(self) -> int:
        return max(1, self._n_threads())

    @property
    def running(self) -> int:
        return len(self._futures)

    def free(self) -> int:
        return max(0, self._n_threads() - len(self._futures))

    def submit(self, task: Task) -> None:
        task.out_path = None  # Dask workers may not share our file system
        fut = self.client.submit(dask_task, self.case, task, self.spec, pure=False,
                                 key=f"lccopt-eval-{task.id}-{uuid.uuid4().hex[:8]}")
        self._futures[fut] = (task, time.monotonic())

    def wait(self, timeout: float) -> list[Outcome]:
        from distributed import wait as dwait

        if not self._futures:
            time.sleep(timeout)
            return []
        now = time.monotonic()
        limit = min([timeout] + [max(0.0, t0 + self.timeout - now) for _, t0 in self._futures.values()])
        try:
            dwait(list(self._futures), timeout=max(0.01, limit), return_when="FIRST_COMPLETED")
        except Exception:  # noqa: BLE001 - a timeout of the wait itself
            pass
        out: list[Outcome] = []
        now = time.monotonic()
        for fut in list(self._futures):
            task, t0 = self._futures[fut]
            if fut.done():
                del self._futures[fut]
                if fut.status == "finished":
                    out.append(fut.result())
                else:
                    try:
                        exc = fut.exception()
                        reason = f"{type(exc).__name__}: {exc}"
                    except Exception as e:  # noqa: BLE001 - cancelled
                        reason = f"{type(e).__name__}: {e}"
                    out.append(Outcome.of(task, error=f"Dask task failed: {reason}"[:500],
                                       wall_time=now - t0, worker="dask"))
            elif now - t0 > self.timeout:
                del self._futures[fut]
                fut.cancel()
                out.append(Outcome.of(task, error=f"timed out after {self.timeout:g} s (Dask task cancelled)",
                                   wall_time=now - t0, worker="dask"))
        return out

    def kill_running(self) -> None:
        for fut in list(self._futures):
            fut.cancel()
        self._futures.clear()

    def close(self) -> None:
        if self.client is not None:
            with contextlib.suppress(Exception):
                self.kill_running()
                self.client.close()
            self.client = None


def make_executor(case, spec, workers: int | None, scheduler, timeout: float):
    if scheduler is not None:
        return DaskExecutor(case, spec, scheduler, timeout)
    return LocalPool(case, spec, workers or default_workers(), timeout)
