"""The Dask executor (``--scheduler ADDRESS``): the interface of executors.py on a
``dask.distributed`` scheduler.

A task past the timeout is cancelled and recorded as failed (Dask cannot kill a running
Python thread: the worker thread stays busy until the simulation returns); a worker that
dies is handled by Dask (the task is retried elsewhere, then reported as failed). A worker
that sees the run directory (the same machine, or a shared file system: it finds there the
probe file this process wrote, with its random content) writes the evaluation file itself,
as a local worker does; any other returns the whole evaluation and this process writes it.
"""

from __future__ import annotations

import contextlib
import os
import queue
import time
import uuid
from pathlib import Path

from . import awake
from .executors import ExecutorError
from .worker import Outcome, Task, load_evaluator, run_task

_DASK_EVALUATORS: dict = {}
_SEES_RUN: dict = {}  # probe (path, content) -> whether this worker sees the run directory


def sees_run(probe) -> bool:
    """Whether the probe file at ``probe[0]`` holds ``probe[1]`` here (the run directory is
    this worker's too); asked once per worker process and run."""
    key = tuple(probe)
    if key not in _SEES_RUN:
        try:
            with open(probe[0], encoding="ascii") as fh:
                _SEES_RUN[key] = fh.read(100) == probe[1]
        except (OSError, ValueError):
            _SEES_RUN[key] = False
    return _SEES_RUN[key]


def dask_task(case, task: Task, spec, probe=None) -> Outcome:
    """Runs on a Dask worker: writes the evaluation file if it sees the run directory
    (``probe``), else returns the whole Evaluation for the parent to write."""
    try:
        from distributed import get_worker

        name = get_worker().address
    except Exception:  # noqa: BLE001
        name = "dask"
    if task.out_path is not None and not (probe is not None and sees_run(probe)):
        task.out_path = None
    key = spec if isinstance(spec, str) else id(spec)
    fn = _DASK_EVALUATORS.get(key)
    if fn is None:
        try:
            fn = _DASK_EVALUATORS[key] = load_evaluator(spec)
        except Exception as exc:  # noqa: BLE001
            return Outcome.of(task, error=f"cannot load the evaluator {spec!r} on {name}: {exc}",
                           worker=name)
    return run_task(case, task, fn, name)


CONNECT_TIMEOUT = 10         # [s] to reach the scheduler (distributed retries meanwhile)
WORKERS_TIMEOUT = 600        # [s] for the first worker to join a scheduler that has none
_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")


def _check_scheduler_address(address: str) -> None:
    """Refuse an address distributed cannot parse before a Client is made: a Client that fails
    on one hangs for 40 s in its finaliser and prints a traceback."""
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address, strict=False)
        if scheme not in _SCHEMES:
            raise ValueError(f"unknown scheme '{scheme}://' "
                             f"(expected one of {', '.join(_SCHEMES)})")
        parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise ExecutorError(f"--scheduler {address[:60]!r}: {exc}; expected e.g. "
                            f"tcp://head-node:8786") from None


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
        self._done: queue.SimpleQueue = queue.SimpleQueue()  # futures as they finish
        self._probe: tuple[str, str] | None = None  # (path, content) of the run directory's probe
        self._slots_cache = (0.0, 0)
        self.description = f"Dask scheduler {address if isinstance(address, str) else 'in-process'}"

    def start(self, log=None) -> None:
        """Connect; wait (saying so through ``log``) for the first worker to join."""
        from distributed import Client

        if isinstance(self.address, str):
            _check_scheduler_address(self.address)
        try:
            if isinstance(self.address, str):
                self.client = Client(self.address, timeout=f"{CONNECT_TIMEOUT}s",
                                     set_as_default=False)
            else:  # a Cluster object (tests, notebooks)
                self.client = Client(self.address, set_as_default=False)
        except Exception as exc:  # noqa: BLE001
            reason = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            raise ExecutorError(f"cannot connect to the Dask scheduler at {self.address}: {reason} "
                                f"(is it running?)") from None
        n = self._n_threads(force=True)
        if n == 0:
            if log is not None:
                log(f"the Dask scheduler has no workers yet; waiting up to {WORKERS_TIMEOUT // 60} "
                    f"min for one (dask worker {self.client.scheduler.address} --nthreads 1)")
            try:
                self.client.wait_for_workers(1, timeout=WORKERS_TIMEOUT)
            except Exception:  # noqa: BLE001 - distributed raises its own TimeoutError
                self.close()
                raise ExecutorError(f"no Dask worker joined the scheduler at {self.address} in "
                                    f"{WORKERS_TIMEOUT // 60} min; start workers, then run "
                                    f"again") from None
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
        if task.out_path is not None and self._probe is None:
            self._probe = _write_probe(Path(task.out_path).parent)
        fut = self.client.submit(dask_task, self.case, task, self.spec, self._probe, pure=False,
                                 key=f"lccopt-eval-{task.id}-{uuid.uuid4().hex[:8]}")
        self._futures[fut] = (task, awake.now())
        fut.add_done_callback(self._done.put)  # no scan of every future in flight per wait

    def wait(self, timeout: float) -> list[Outcome]:
        if not self._futures:
            time.sleep(timeout)
            return []
        now = awake.now()   # the driver's own clock: its pauses are not the designs' (awake.py)
        limit = min([timeout] + [max(0.0, t0 + self.timeout - now)
                                 for _, t0 in self._futures.values()])
        finished = []
        try:
            finished.append(self._done.get(timeout=max(0.01, limit)))
            while True:
                finished.append(self._done.get_nowait())
        except queue.Empty:
            pass
        out: list[Outcome] = []
        now = awake.now()
        for fut in finished:
            if fut in self._futures:
                task, t0 = self._futures.pop(fut)
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
        for fut in [f for f, (_, t0) in self._futures.items() if now - t0 > self.timeout]:
            task, t0 = self._futures.pop(fut)
            fut.cancel()
            out.append(Outcome.of(task, wall_time=now - t0, worker="dask",
                                  error=f"timed out after {self.timeout:g} s "
                                        f"(Dask task cancelled)"))
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
        if self._probe is not None:
            with contextlib.suppress(OSError):
                os.unlink(self._probe[0])
            self._probe = None


def _write_probe(directory: Path) -> tuple[str, str]:
    """A file of random content in the run's evals/ (named ``*.tmp``: a resume removes one
    left behind), by which a Dask worker knows it sees the run directory."""
    content = uuid.uuid4().hex
    path = directory / f"dask-probe.{content[:8]}.tmp"
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o644)
    with os.fdopen(fd, "w", encoding="ascii") as fh:
        fh.write(content)
    return str(path.resolve()), content


