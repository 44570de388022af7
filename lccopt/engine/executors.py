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

:class:`~lccopt.engine.dask_executor.DaskExecutor` (dask_executor.py, where its timeouts
and dead workers are described; dask_task.py, its file writing) submits to a
``dask.distributed`` scheduler (``--scheduler ADDRESS``).
"""

from __future__ import annotations

import contextlib
import multiprocessing.connection as mpc
import os
import socket
import subprocess
import sys
import time
from dataclasses import dataclass

from ..fanout import child_env, ignore_stop_signals
from . import awake
from .worker import Outcome, Task, _death_reason


class ExecutorError(Exception):
    """The executor cannot run at all (bad evaluator, no Dask, scheduler unreachable)."""


class ExecutorLost(ExecutorError):
    """The workers went away during a run (a Dask scheduler gone, frozen, or without workers
    for too long; local workers that cannot start an evaluation process): an environment
    fault, never a failed design; what was in flight stays pending. ``resume``: the options a
    resume then needs (``--scheduler ADDRESS``)."""

    def __init__(self, message: str, resume: str = ""):
        super().__init__(message)
        self.resume = resume


# What one local worker costs: its interpreter with numpy, scipy and h5py loaded (~55 MB
# resident) and the child forked for each evaluation (~40-60 MB more with a paper-case
# simulation), with room to spare; and four descriptors of this process (socket, pidfd, and
# the pipes of a process being replaced).
WORKER_MEMORY = 150 * 2 ** 20
WORKER_FILES = 4


def max_local_workers() -> tuple[int, str]:
    """(how many local workers this machine can hold, why: the binding limit in words).

    Raises the soft open-file limit to the hard one on the way (what many workers need)."""
    import resource

    try:
        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        if soft != hard and hard != resource.RLIM_INFINITY:
            resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
            soft = hard
    except (ValueError, OSError):
        pass
    by_files = max(1, (soft - 64) // WORKER_FILES) if soft != resource.RLIM_INFINITY else 1 << 20
    available = _memory_available()
    by_memory = max(1, available // WORKER_MEMORY) if available else 1 << 20
    if by_memory <= by_files:
        return int(by_memory), (f"{available / 2 ** 30:.1f} GB free, "
                                f"~{WORKER_MEMORY // 2 ** 20} MB each")
    return int(by_files), f"ulimit -n {soft}, {WORKER_FILES} files each"


def _memory_available() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        pass
    return None


def default_workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def local_processes(tasks: int) -> int:
    """How many processes of its own a command runs ``tasks`` independent simulations in
    (lccopt.fanout): one per core it may use, as many as the machine holds, no more than the
    tasks."""
    return max(1, min(tasks, default_workers(), max_local_workers()[0]))


# A task whose process is killed by a signal this many times fails (a design that makes the
# simulation crash every time must not hold the run); fewer times, it simply runs again.
MAX_KILLS = 3


def _stopped(pid: int) -> str:
    """"SIGSTOP" if the worker ``pid`` or one of its children (the evaluation it forked) is
    stopped by a signal, "traced" if under a debugger, else "". Read from Linux's /proc
    (where there is none the answer is "": a frozen worker's design is timed out)."""
    pids, seen = [pid], set()
    while pids:
        p = pids.pop()
        if p in seen:
            continue
        seen.add(p)
        try:
            with open(f"/proc/{p}/stat", "rb") as f:
                stat = f.read()
        except OSError:
            continue
        # the state follows the command name, which is in parentheses and may hold any byte
        state = stat[stat.rfind(b")") + 2:stat.rfind(b")") + 3]
        if state in (b"T", b"t"):
            return "SIGSTOP" if state == b"T" else "traced"
        with contextlib.suppress(OSError):
            for tid in os.listdir(f"/proc/{p}/task"):
                with open(f"/proc/{p}/task/{tid}/children", "rb") as f:
                    pids.extend(int(c) for c in f.read().split())
    return ""


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
        if self.proc is None:   # stopped for good (the run is stopping)
            return []
        return [self.conn] + ([self.pidfd] if self.pidfd is not None else [])


class LocalPool:
    kind = "local"

    def __init__(self, case, evaluator, workers: int, timeout: float):
        if workers < 1:
            raise ExecutorError(f"--workers must be at least 1, got {workers}")
        self.case, self.evaluator, self.timeout = case, evaluator, float(timeout)
        self.slots = int(workers)
        self._slots = [_Slot(i) for i in range(self.slots)]
        self._retry: list[Task] = []        # tasks whose worker was killed, to run again
        # (id, condition, realisation) -> times its worker was killed
        self._deaths: dict[tuple, int] = {}
        self.description = f"{self.slots} local worker process{'es' if self.slots > 1 else ''}"

    # -- lifecycle --------------------------------------------------------------------------
    def start(self, log=None, wait: float = 120.0) -> None:
        """Start the workers; return once they are ready (ExecutorError if they cannot start)."""
        for s in self._slots:
            self._spawn(s)
        deadline = time.monotonic() + wait
        while self.free() < self.slots and time.monotonic() < deadline:
            for o in self.wait(0.1):  # no task yet: only "ready", "fatal" or deaths
                pass

    def _spawn(self, s: _Slot) -> None:
        parent_sock, child_sock = socket.socketpair()
        cmd = [sys.executable, "-c", _WORKER_MAIN, str(child_sock.fileno()), str(os.getpid()),
               str(s.index)]
        proc = subprocess.Popen(cmd, pass_fds=[child_sock.fileno()], env=child_env(),
                                stdin=subprocess.DEVNULL, preexec_fn=ignore_stop_signals)
        child_sock.close()
        s.proc, s.ready, s.task = proc, False, None
        s.conn = mpc.Connection(parent_sock.detach())
        try:
            s.pidfd = os.pidfd_open(proc.pid)
        except (AttributeError, OSError):  # not Linux >= 5.3: death is seen as EOF on the socket
            s.pidfd = None
        try:
            s.conn.send(("init", self.case, self.evaluator, list(sys.path)))
        except OSError:
            pass  # died already: wait() notices

    def close(self) -> None:
        """Stop the workers: an idle one is asked to exit (it is between tasks, so nothing is
        lost), one still starting or busy is killed (its task, if any, stays pending)."""
        for s in self._slots:
            if s.proc is None:
                continue
            if s.task is None and s.ready:
                with contextlib.suppress(OSError):
                    s.conn.send(None)
            else:
                with contextlib.suppress(OSError):
                    s.proc.kill()
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
        return sum(s.task is not None for s in self._slots) + len(self._retry)

    def free(self) -> int:
        return max(0, sum(s.ready and s.task is None for s in self._slots) - len(self._retry))

    def submit(self, task: Task) -> None:
        for s in self._slots:
            if s.ready and s.task is None:
                self._give(s, task)
                return
        raise RuntimeError("submit() without a free worker")

    def _give(self, s: _Slot, task: Task) -> None:
        s.task, s.started = task, awake.now()
        try:
            s.conn.send(task)
        except OSError:
            pass  # the worker died: noticed by wait() through its sentinel

    def _lost(self, s: _Slot, reason: str, killed: bool, out: list) -> None:
        """The slot's task lost its process. Killed by a signal (the OOM killer, kill -9 of a
        worker) says nothing about the design: it runs again, up to MAX_KILLS times; any other
        death (an exit status) is the evaluation's own failure."""
        task, s.task = s.task, None
        key = (task.id, task.condition, task.realisation)
        self._deaths[key] = self._deaths.get(key, 0) + 1
        if killed and self._deaths[key] < MAX_KILLS:
            self._retry.append(task)
            return
        if killed:
            reason = f"{reason}, {self._deaths[key]} times"
        out.append(Outcome.of(task, error=reason, wall_time=awake.now() - s.started,
                              worker=f"local-{s.index}"))

    def kill_running(self) -> None:
        """Stop every task in flight at once (the run is stopping: no worker is started again)."""
        self._retry.clear()
        for s in self._slots:
            if s.task is not None:
                self._kill(s)
                s.task, s.proc, s.ready = None, None, False

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
        # timeouts on the driver's own clock: a pause of this process (SIGSTOP, Ctrl-Z) is
        # never charged to the designs in flight (awake.py)
        now = awake.now()
        limit = timeout
        for s in self._slots:
            if s.task is not None:
                limit = min(limit, max(0.0, s.started + self.timeout - now))
        objs = [w for s in self._slots for w in s.waitables()]
        ready = set(mpc.wait(objs, timeout=max(0.0, limit)))
        out: list[Outcome] = []
        for s in self._slots:
            if s.proc is None:
                continue
            if (s.conn in ready or (s.pidfd is not None and s.pidfd in ready)
                    or s.proc.poll() is not None):
                self._drain(s, out)
        now = awake.now()
        for s in self._slots:
            if s.task is not None and now - s.started > self.timeout:
                # a worker stopped from outside (SIGSTOP to its process, a debugger) has not
                # run the design for the timeout: it runs again, like one killed by a signal
                frozen = _stopped(s.proc.pid)
                self._kill(s)
                if frozen:
                    self._lost(s, f"worker process stopped ({frozen}) past the timeout", True,
                               out)
                else:
                    out.append(Outcome.of(s.task, wall_time=now - s.started,
                                          worker=f"local-{s.index}",
                                          error=f"timed out after {self.timeout:g} s "
                                                f"(worker killed)"))
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
                    if self._retry and s.task is None:
                        self._give(s, self._retry.pop(0))
                elif msg[0] == "done":
                    outcome = msg[1]
                    if s.task is not None and outcome.id == s.task.id:
                        out.append(outcome)
                        s.task = None
                elif msg[0] == "fault":  # the worker cannot start evaluations (no memory or
                    # processes left): the run stops, what was in flight stays pending
                    raise ExecutorLost(msg[1])
                elif msg[0] == "crashed":  # the evaluation's (forked) process died
                    if s.task is not None:
                        self._lost(s, msg[1], msg[2] if len(msg) > 2 else False, out)
                        if self._retry and s.ready:
                            self._give(s, self._retry.pop(0))
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
                self._lost(s, reason, s.proc.returncode is not None and s.proc.returncode < 0, out)
            if not s.ready:
                s.deaths_before_ready += 1
                if s.deaths_before_ready >= 3:
                    self.close()
                    raise ExecutorError(f"local worker processes die while starting: {reason}")
            self._release(s)
            self._spawn(s)
