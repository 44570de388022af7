"""The Dask executor (``--scheduler ADDRESS``): the interface of executors.py on a
``dask.distributed`` scheduler.

A task past the timeout is cancelled and recorded as failed (Dask cannot kill a running
Python thread: the worker thread stays busy until the simulation returns); a worker that
dies is handled by Dask (the task is retried elsewhere, then reported as failed). A scheduler
that goes away (dies, disconnects, freezes, loses all its workers) fails nothing: what was in
flight runs again when it is back (``DaskExecutor``). What runs on a worker, and how it writes
the evaluation file when it sees the run directory, is in dask_task.py; reaching the scheduler
in dask_client.py.
"""

from __future__ import annotations

import contextlib
import os
import queue
import threading
import time
import uuid
from pathlib import Path

from . import awake
from .dask_client import (
    check_scheduler_address,
    quiet_client,
    quiet_client_loggers,
    restore_loggers,
)
from .dask_task import dask_task, write_probe
from .executors import ExecutorError, ExecutorLost
from .worker import Outcome, Task

CONNECT_TIMEOUT = 10         # [s] to reach the scheduler (distributed retries meanwhile)
WORKERS_TIMEOUT = 600        # [s] for a worker to join a scheduler that has none
RECONNECT_TIMEOUT = 300      # [s] for a lost scheduler to come back before the run stops
PROBE_TIMEOUT = 10           # [s] for the scheduler to answer a question (is it frozen?)
HEARTBEAT = 1.0              # [s] between the executor's questions to the scheduler
SILENT = 3.0                 # [s] without an answer: the scheduler is not answering (frozen)
_RESUME = "--scheduler ADDRESS"   # what a resume on a cluster that works needs
MAX_CANCELLED = 3            # times an evaluation may be cancelled by Dask before the run stops


class DaskExecutor:
    """The executor interface (executors.py) on a Dask scheduler.

    A lost scheduler or connection is an environment fault, never a design's failure: the
    evaluations in flight (cancelled by distributed, or whose results can no longer be
    fetched) are kept, the executor waits for the scheduler to come back (distributed
    reconnects, else a new Client every few seconds), saying so, for RECONNECT_TIMEOUT, then
    runs them again; if it does not come back, :class:`ExecutorLost` stops the run with the
    evaluations still pending. A heartbeat thread asks the scheduler every HEARTBEAT s: the
    spans in which it does not answer (frozen by SIGSTOP, a debugger, a full machine) are not
    counted against the evaluations' timeout, no evaluation is timed out before it has answered
    again, and one silent for PROBE_TIMEOUT is taken for lost likewise. So is a scheduler whose
    workers have all gone (waited for up to WORKERS_TIMEOUT). The time the executor waits for
    the cluster is not counted against the evaluations' timeout."""

    kind = "dask"

    def __init__(self, case, evaluator, address, timeout: float):
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise ExecutorError("--scheduler needs Dask: pip install 'dask[distributed]' "
                                "(or pip install 'lccopt[dask]')") from None
        self.case, self.evaluator, self.timeout = case, evaluator, float(timeout)
        self.address = address
        self.client = None
        self._futures: dict = {}  # future -> (task, submitted at on the driver's clock)
        self._done: queue.SimpleQueue = queue.SimpleQueue()  # futures as they finish
        self._orphans: list[Task] = []   # in flight when the cluster went away: to run again
        self._cancelled: dict[tuple, int] = {}   # (id, condition) -> times Dask cancelled it
        self._lost: tuple[float, str] | None = None   # (since, why) while the scheduler is gone
        self._idle_since: float | None = None   # while the scheduler has no worker
        self._stalled_at: float | None = None   # the cluster is away: deadlines stand still
        self._retry_at = 0.0
        self._log = None
        self._probe: tuple[str, str] | None = None  # (path, content) of the run directory's probe
        self._probe_folder = None                   # the folder it is in, held open
        self._slots_cache = (0.0, 0)
        # the heartbeat (a thread asks the scheduler every HEARTBEAT s) counts its answers;
        # the run's loop reads the count and times them on the driver's clock (the thread never
        # reads or marks that clock: awake.py counts a pause from the main thread's last turn).
        # The spans of SILENT s or more without an answer (a frozen, stopped or cut-off
        # scheduler) are not counted against the evaluations' timeout.
        self._beats = 0            # answers so far (written by the thread only)
        self._beats_seen = 0       # ... as the loop last read them
        self._late: dict = {}      # future past its timeout -> the count when first seen so
        self._answered_at = awake.now()
        self._silences: list[tuple[float, float]] = []
        self._beating: threading.Event | None = None
        self._beat_thread: threading.Thread | None = None
        self.description = f"Dask scheduler {address if isinstance(address, str) else 'in-process'}"

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self, log=None) -> None:
        """Connect; wait (saying so through ``log``) for the first worker to join."""
        self._log = log
        self._log_level = quiet_client_loggers()
        if isinstance(self.address, str):
            check_scheduler_address(self.address)
        try:
            self.client = self._connect(CONNECT_TIMEOUT)
        except Exception as exc:  # noqa: BLE001
            reason = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            raise ExecutorError(f"cannot connect to the Dask scheduler at {self.address}: "
                                f"{reason} (is it running?)") from None
        n = self._n_threads(force=True)
        if n == 0:
            self._say(f"the Dask scheduler has no workers yet; waiting up to "
                      f"{WORKERS_TIMEOUT // 60} min for one (dask worker "
                      f"{self.client.scheduler.address} --nthreads 1)")
            try:
                self.client.wait_for_workers(1, timeout=WORKERS_TIMEOUT)
            except Exception:  # noqa: BLE001 - distributed raises its own TimeoutError
                self.close()
                raise ExecutorError(f"no Dask worker joined the scheduler at {self.address} in "
                                    f"{WORKERS_TIMEOUT // 60} min; start workers, then run "
                                    f"again") from None
            n = self._n_threads(force=True)
        self.description = f"Dask scheduler {self.client.scheduler.address} ({n} worker threads)"
        self._answered(awake.now())
        self._beating = threading.Event()
        self._beat_thread = threading.Thread(target=self._heartbeat, args=(self._beating,),
                                             daemon=True, name="lccopt-dask-heartbeat")
        self._beat_thread.start()

    # -- the heartbeat -----------------------------------------------------------------------
    def _heartbeat(self, stop: threading.Event) -> None:
        """Thread: ask the scheduler for its workers every HEARTBEAT s and count its answers
        (a sync call of the Client, which serves any thread through its own event loop; never
        the run's loop, which must not wait on a scheduler that may be frozen)."""
        while not stop.wait(HEARTBEAT):
            client = self.client
            if client is None or client.status != "running":
                continue
            try:
                n = int(sum(client.nthreads(callback_timeout=SILENT).values()))
            except Exception:  # noqa: BLE001 - no answer: the silence goes on
                continue
            if stop.is_set():
                return
            self._slots_cache = (time.monotonic(), n)
            self._beats += 1

    def _observe(self) -> float:
        """The loop's turn: an answer counted since the last turn is timed now (on the
        driver's clock); return now."""
        now = awake.now()
        beats = self._beats
        if beats != self._beats_seen:
            self._beats_seen = beats
            self._answered(now)
        return now

    def _answered(self, t: float) -> None:
        if t - self._answered_at >= SILENT:
            self._silences.append((self._answered_at, t))
        self._answered_at = max(self._answered_at, t)
        # spans that no evaluation in flight overlaps any more are dropped
        oldest = min((t0 for _, t0 in self._futures.values()), default=t)
        self._silences = [(a, b) for a, b in self._silences if b > oldest]

    def _silent_for(self, now: float) -> float:
        """How long the scheduler has not answered (0 if it answered within SILENT s)."""
        quiet = now - self._answered_at
        return quiet if quiet >= SILENT else 0.0

    def _charged(self, t0: float, now: float) -> float:
        """Time of an evaluation submitted at ``t0``, at ``now``, less the spans in which the
        scheduler did not answer (a frozen scheduler reports nothing its workers did)."""
        spans = list(self._silences)
        if now - self._answered_at >= SILENT:
            spans.append((self._answered_at, now))
        return (now - t0) - sum(max(0.0, min(b, now) - max(a, t0)) for a, b in spans)

    def _connect(self, timeout: float):
        if isinstance(self.address, str):
            return quiet_client(self.address, timeout=f"{timeout}s", set_as_default=False)
        # a Cluster object (tests, notebooks)
        return quiet_client(self.address, set_as_default=False)

    def _say(self, message: str) -> None:
        if self._log is not None:
            self._log(message)

    def close(self) -> None:
        if self._beating is not None:
            self._beating.set()
            self._beating = None
            # its call returns within SILENT s: never a thread in a Client being closed, nor
            # one left running while the interpreter exits
            self._beat_thread.join(SILENT + 1.0)
            self._beat_thread = None
        if self.client is not None:
            self.kill_running()
            client, self.client = self.client, None
            with contextlib.suppress(BaseException):
                client.close(timeout=5)
        if getattr(self, "_log_level", None):
            restore_loggers(self._log_level)
            self._log_level = None
        if self._probe_folder is not None:
            if self._probe is not None:
                with contextlib.suppress(OSError):
                    self._probe_folder.unlink(os.path.basename(self._probe[0]))
            self._probe_folder.close()
            self._probe_folder, self._probe = None, None

    # -- the interface -------------------------------------------------------------------------
    def _connected(self) -> bool:
        return self.client is not None and self.client.status == "running"

    def _n_threads(self, force: bool = False) -> int:
        t, n = self._slots_cache
        if self._beating is not None and not force:
            return n     # the heartbeat's latest answer: the loop never waits on the scheduler
        if self._connected() and (force or time.monotonic() - t > 5.0):
            try:   # never without a time limit: a frozen scheduler would hang the run
                n = int(sum(self.client.nthreads(callback_timeout=PROBE_TIMEOUT).values()))
            except Exception:  # noqa: BLE001
                pass
            self._slots_cache = (time.monotonic(), n)
        return n

    @property
    def slots(self) -> int:
        return max(1, self._n_threads())

    @property
    def running(self) -> int:
        return len(self._futures) + len(self._orphans)

    def free(self) -> int:
        if self._lost is not None or self._orphans:
            return 0
        return max(0, self._n_threads() - len(self._futures))

    def submit(self, task: Task) -> None:
        if task.out_path is not None and self._probe_folder is None:
            self._probe_folder, self._probe = write_probe(Path(task.out_path).parent,
                                                           task.out_dir_id)
        try:
            if not self._connected():
                raise ConnectionError("not connected")
            fut = self.client.submit(dask_task, self.case, task, self.evaluator, self._probe,
                                     pure=False,
                                     key=f"lccopt-eval-{task.id}-{uuid.uuid4().hex[:8]}")
        except Exception as exc:  # noqa: BLE001 - the connection went: the task waits for it
            self._orphans.append(task)
            self._lose(f"{type(exc).__name__}: {exc}")
            return
        self._futures[fut] = (task, awake.now())
        fut.add_done_callback(self._done.put)  # no scan of every future in flight per wait

    def wait(self, timeout: float) -> list[Outcome]:
        self._observe()
        if self._lost is not None:
            self._reconnect(timeout)
            return []
        if self._orphans:
            self._run_orphans()
        if not self._futures:
            time.sleep(timeout)
            return []
        now = awake.now()   # the driver's own clock: its pauses are not the designs' (awake.py)
        # until the next deadline (one past waits for the heartbeat: the loop's usual turn)
        limit = timeout if self._stalled_at is not None else min(
            [timeout] + [r for r in (self.timeout - self._charged(t0, now)
                                     for _, t0 in self._futures.values()) if r > 0])
        finished = []
        try:
            finished.append(self._done.get(timeout=max(0.01, limit)))
            while True:
                finished.append(self._done.get_nowait())
        except queue.Empty:
            pass
        out: list[Outcome] = []
        now = self._observe()
        for fut in finished:
            if fut not in self._futures:
                continue
            task, t0 = self._futures.pop(fut)
            outcome = self._outcome(fut, task, self._charged(t0, now))
            if outcome is not None:
                out.append(outcome)
        if self._lost is None and self._silent_for(now) > PROBE_TIMEOUT:
            self._lose(f"it has not answered for {PROBE_TIMEOUT} s")
        if self._lost is None:
            self._check_workers(now)
        if self._lost is None and self._stalled_at is None:
            out += self._timeouts(now)
        return out

    def _outcome(self, fut, task: Task, elapsed: float) -> Outcome | None:
        """The outcome of a finished future; None (the task kept to run again) when the cluster,
        not the design, ended it: cancelled or lost by distributed, or a result that cannot be
        fetched any more."""
        if fut.status == "finished":
            try:
                return fut.result(timeout=PROBE_TIMEOUT)
            except Exception as exc:  # noqa: BLE001 - the result is on a worker out of reach
                return self._keep(task, f"the result of evaluation #{task.id} could not be "
                                        f"fetched ({type(exc).__name__}: {exc})")
        if not self._connected():
            return self._keep(task, "the connection to it was lost")
        if fut.status in ("cancelled", "lost"):
            return self._keep(task, f"it reported evaluation #{task.id} {fut.status}")
        try:
            exc = fut.exception(timeout=0)
            reason = f"{type(exc).__name__}: {exc}"
        except Exception as e:  # noqa: BLE001
            reason = f"{type(e).__name__}: {e}"
        return Outcome.of(task, error=f"Dask task failed: {reason}"[:500], wall_time=elapsed,
                          worker="dask")

    def _keep(self, task: Task, why: str) -> None:
        key = (task.id, task.condition)
        self._cancelled[key] = self._cancelled.get(key, 0) + 1
        if self._cancelled[key] > MAX_CANCELLED:
            raise ExecutorLost(f"the Dask scheduler at {self.address} cancelled evaluation "
                               f"#{task.id} {MAX_CANCELLED + 1} times ({why[:200]})", _RESUME)
        self._orphans.append(task)
        if not self._connected():
            self._lose(why)
        return None

    def _lose(self, why: str) -> None:
        """The scheduler went away: keep what was in flight, wait for it to come back."""
        if self._lost is not None:
            return
        self._lost = (awake.now(), why)
        self._update_stall()
        for fut, (task, _) in list(self._futures.items()):
            self._orphans.append(task)
            with contextlib.suppress(Exception):
                fut.release()
        self._futures.clear()
        self._say(f"lost the connection to the Dask scheduler at {self.address} "
                  f"({_short(why)}); waiting up to {_span(RECONNECT_TIMEOUT)} for it to come "
                  f"back; the evaluations in flight will run again")

    def _reconnect(self, timeout: float) -> None:
        since, why = self._lost
        if not self._connected() and awake.now() >= self._retry_at and (
                self.client is None or self.client.status in ("closed", "closing", "failed")):
            # distributed gave up reconnecting: a new Client, a short attempt each time (the
            # run's loop must go on answering Ctrl-C and SIGTERM)
            self._retry_at = awake.now() + 2.0
            old, self.client = self.client, None
            if old is not None:
                with contextlib.suppress(BaseException):
                    old.close(timeout=1)
            try:
                self.client = self._connect(1.0)
            except Exception:  # noqa: BLE001 - not back yet
                self.client = None
        self._observe()
        if self._connected() and (self._answered_at > since or self._beating is None):
            self._lost = None
            self._update_stall()
            self._slots_cache = (0.0, 0)
            n = self._n_threads(force=True)
            self._say(f"the Dask scheduler at {self.address} is back ({n} worker threads); "
                      f"running again the {len(self._orphans)} evaluation(s) that were in "
                      f"flight")
            self._run_orphans()
            return
        if awake.now() - since > RECONNECT_TIMEOUT:
            raise ExecutorLost(f"lost the connection to the Dask scheduler at {self.address} "
                               f"({_short(why)}) and it did not come back within "
                               f"{_span(RECONNECT_TIMEOUT)}", _RESUME)
        time.sleep(timeout)

    def _run_orphans(self) -> None:
        orphans, self._orphans = self._orphans, []
        for task in orphans:
            self.submit(task)

    def _check_workers(self, now: float) -> None:
        """A scheduler whose workers have all gone: the evaluations in flight wait for one (not
        counted against their timeout) for up to WORKERS_TIMEOUT, then the run stops."""
        if self._n_threads() > 0:
            if self._idle_since is not None:
                self._idle_since = None
                self._update_stall()
                self._say(f"a Dask worker joined the scheduler at {self.address}; carrying on")
            return
        if self._idle_since is None:
            self._idle_since = now
            self._update_stall()
            self._say(f"the Dask scheduler at {self.address} has no workers left; waiting up "
                      f"to {_span(WORKERS_TIMEOUT)} for one (the evaluations in flight stay "
                      f"pending)")
        elif now - self._idle_since > WORKERS_TIMEOUT:
            raise ExecutorLost(f"the Dask scheduler at {self.address} has had no workers for "
                               f"{_span(WORKERS_TIMEOUT)}", _RESUME)

    def _update_stall(self) -> None:
        """While the cluster is away (scheduler lost, no workers) the evaluations' deadlines
        stand still: they move on by the time it was away."""
        now = awake.now()
        away = self._lost is not None or self._idle_since is not None
        if away and self._stalled_at is None:
            self._stalled_at = now
        elif not away and self._stalled_at is not None:
            shift = now - self._stalled_at
            self._stalled_at = None
            for fut, (task, t0) in list(self._futures.items()):
                self._futures[fut] = (task, t0 + shift)

    def _timeouts(self, now: float) -> list[Outcome]:
        """The evaluations past their timeout (less the scheduler's silences), recorded as
        failed once the scheduler has answered a whole heartbeat asked after they were seen
        late: a scheduler frozen meanwhile has not reported what its workers did, and its
        silence, once it answers, is taken off their time."""
        late = [f for f, (_, t0) in self._futures.items() if self._charged(t0, now) > self.timeout]
        # the heartbeat count when each was first seen late (a design no longer late, after a
        # silence was taken off, starts again)
        self._late = {f: self._late.get(f, self._beats) for f in late}
        out = []
        for fut in late:
            if fut.done() or self._beats < self._late[fut] + 2:
                continue    # finished as its time ran out (read at the next turn), or not known
            task, t0 = self._futures.pop(fut)
            del self._late[fut]
            with contextlib.suppress(Exception):
                fut.cancel()
            out.append(Outcome.of(task, wall_time=self._charged(t0, now), worker="dask",
                                  error=f"timed out after {self.timeout:g} s "
                                        f"(Dask task cancelled)"))
        return out

    def kill_running(self) -> None:
        for fut in list(self._futures):
            with contextlib.suppress(Exception):
                fut.cancel()
        self._futures.clear()
        self._late.clear()
        self._orphans.clear()


def _span(seconds: float) -> str:
    return f"{seconds / 60:g} min" if seconds >= 60 else f"{seconds:g} s"


def _short(why: str) -> str:
    first = why.strip().splitlines()[0] if why.strip() else "no reason given"
    return first[:160]
