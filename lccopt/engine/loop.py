"""The ask/tell loop of a run: proposals to the workers, outcomes to the journal and the
optimiser, snapshots and results.h5 along the way.

One process (this one) runs the loop and is the only writer of the journal, the state
snapshot and results.h5. Workers evaluate designs (and, in the local pool, write their own
immutable ``evals/NNNNNN.h5`` before reporting back).

Commit protocol, per evaluation ``i``:

1. ``asked`` line (id, x, phase, restart) after ``strategy.ask`` returned the proposal;
2. the worker writes ``evals/00000i.h5`` (tmp + rename: complete whatever kill -9 interrupts;
   not fsynced, one file per evaluation being more than a disk's fsync rate allows at
   scale: a file a power cut damaged is found by the resume, which simulates it again);
3. ``evaluated`` (objectives, scalar value, wall time, worker, file) or ``failed`` (reason)
   line when the outcome arrives; ``strategy.tell`` (value and objective vector, which the
   composite surrogate of a multi-objective run fits) / ``tell_failed`` when its turn comes:
   results are told in id order, result ``i`` once proposal ``i + k`` is made (k = workers;
   ``schedule.py``), so proposal ``n`` sees exactly results ``0 .. n-k-1`` whatever the timing;
4. every few seconds: ``state.json`` (strategy state + the journal seq it reflects) and
   ``results.h5`` (rebuilt from the journal), both atomic.

Journal lines are handed to the operating system before the evaluations they start (they
survive kill -9) and fsynced together at least every ``SYNC_EVERY`` seconds and before a
snapshot (a power cut loses at most the last second: those evaluations run again).

For two or more objectives the reference design (always proposal 0) runs alone first: its
objectives fix the ASF reference point (``reference`` line) before any value is computed.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ..config import Case
from ..errors import (
    CaseError,
    EnvironmentFault,
    RunInterrupted,
    describe_os_error,
    environment_errno,
    printable_lines,
)
from ..problem import Problem
from ..terminal import PipeGuard
from .executors import ExecutorLost
from .journal import Journal, line_mark
from .progress import Progress, summary_lines
from .results import write_results
from .run import Recorder, Run, eval_name
from .rundir import RunDir
from .schedule import batch_size, may_ask, release
from .stopping import StopSignals
from .worker import Outcome, Task

RESULTS_EVERY = 10.0  # [s] results.h5 is rebuilt at most this often while running (and at the end)
SNAPSHOT_EVERY = 5.0  # [s] state.json likewise; resume replays the journal lines after it
SYNC_EVERY = 1.0      # [s] the journal is fsynced at least this often (a power cut loses less)


def environment_fault(exc: BaseException, rd: RunDir) -> EnvironmentFault:
    return EnvironmentFault(f"{describe_os_error(exc)}; the run stopped with nothing lost "
                            f"(evaluations in flight stay pending): fix the cause, then "
                            f"'lccopt resume {rd.path}'")


class Engine:
    def __init__(self, rd: RunDir, case: Case, problem: Problem, journal: Journal, table: Run,
                 strategy, executor, progress: Progress):
        self.rd, self.case, self.problem = rd, case, problem
        self.journal, self.table, self.strategy = journal, table, strategy
        self.log = Recorder(journal, table)   # every line this process writes, applied to table
        self.progress = progress
        self.meta = rd.meta()
        self.parts = 1           # tasks per design: its conditions x tracks (conditions.py)
        if case.conditions or getattr(case, "realisations", 0):
            from .conditions import ConditionPool

            executor = ConditionPool(executor, case, problem, rd)
            self.parts = executor.m
        self.executor = executor
        self.ref_point = (table.reference or {}).get("point")
        if self.ref_point is not None:  # as the replay of the journal set it (restore)
            self.problem = problem = problem.with_reference(table.reference["objectives"])
            self.strategy.set_aggregate(problem.aggregate(self.ref_point))
        self._ahead: int | None = None   # id asked ahead, waiting for a free worker
        # proposal n sees exactly the results 0 .. n-lag-1 (schedule.py); lag = the workers
        self.lag = max(1, int(executor.slots))
        # proposals per surrogate fit (schedule.py)
        self.batch = batch_size(self.lag, getattr(case, "proposals_per_fit", 1))
        self.strategy.set_batch(self.batch)
        self.halt = StopSignals()  # stop: propose nothing more; abort: stop the running too
        self._stop_logged = False
        self._saved_seq = table.seq
        self._results_at = 0.0
        self._snapshot_at = time.monotonic()
        self._synced_at = time.monotonic()
        self.t_optimiser = 0.0     # time in ask/tell
        self.t_bookkeeping = 0.0   # journal, snapshots, results.h5, files written here
        self.t_held = 0.0          # worker-seconds idle because a proposal waited for a late result
        self._held = False         # the last ask waited for a result (schedule.py)
        self._restore: list[int] = []          # ids whose lost evals/ file is simulated again
        self._restoring: set[int] = set()
        self.histories = getattr(case, "histories", "best")
        self._histories_done: set[int] = set()  # designs whose histories were made at the end
        self._owner_lost = False   # the run's journal was replaced: this process stops writing

    def restore_files(self, ids: list[int], out: Progress) -> None:
        """Simulate again the evaluations whose file was deleted or damaged (no budget spent)."""
        if ids:
            out.log(f"{len(ids)} evaluation file(s) lost or damaged, simulating them again: "
                    f"{', '.join('#' + str(i) for i in ids[:6])}{' ...' if len(ids) > 6 else ''}")
        self._restore = list(ids)

    # -- main -----------------------------------------------------------------------------------
    def run(self) -> None:
        try:
            self._run()
        except ExecutorLost as exc:  # the workers went away: the evaluations stay pending
            how = f"'lccopt resume {self.rd.path}{' ' + exc.resume if exc.resume else ''}'"
            raise EnvironmentFault(f"{exc}; the run stopped with nothing lost (the evaluations "
                                   f"in flight stay pending): when the workers are back, "
                                   f"{how}") from None
        except (OSError, RuntimeError) as exc:  # h5py reports a full disk as either
            if environment_errno(exc) is None:
                raise
            raise environment_fault(exc, self.rd) from None

    def _run(self) -> None:
        p, pb = self.progress, self.problem
        if pb.reference_first and 0 in self.table.rows \
                and self.table.rows[0]["status"] == "failed" \
                and self.table.reference is None:
            raise self._reference_failed(self.table.rows[0]["reason"])
        self.halt.install()
        t_start = time.monotonic()
        n_start = self.table.n_done
        try:
            what = ", ".join(pb.objectives) + (" (ASF, Eq. 7)" if pb.multi else "")
            # two lines, so that an 80-column terminal does not wrap them
            p.log(f"run {self.rd.path} (case '{self.case.name}'): {pb.dim} variables, "
                  f"budget {pb.budget}, {self.table.n_done} done")
            p.log(f"minimising {what}; {self.executor.description}")
            p.start(self.table, self.parts)
            if self.table.lag != self.lag or self.table.batch != self.batch:
                self.log.schedule(self.lag, self.batch)
            self._release()
            requeue = self.table.pending_ids()
            if requeue:
                p.log(f"running again {len(requeue)} evaluation(s) that were in flight: "
                      f"{', '.join('#' + str(i) for i in requeue)}")
            while True:
                # | head went away: stop as SIGPIPE would
                if PipeGuard.closed_pipe and not self.halt.abort:
                    self.halt.stop = self.halt.abort = True
                if self.halt.stop:
                    self._held = False
                submitted = 0 if self.halt.stop else self._fill(requeue)
                if time.monotonic() - self._snapshot_at > SNAPSHOT_EVERY:
                    self._check_owner()
                    self._snapshot()
                if self.executor.running == 0:
                    if (not self.halt.stop and self.strategy.done and not self._restore
                            and self._best_lacks_histories()):
                        continue  # its histories are simulated again (no budget), then it ends
                    if self.halt.stop or (self.strategy.done and not self._restore):
                        break
                    if submitted == 0 and self.executor.free() > 0:
                        break  # nothing left to propose and nothing in flight
                idle = self.executor.free() if self._held and self.executor.running else 0
                t_wait = time.monotonic()
                for o in self.executor.wait(0.2):
                    self._record(o)
                self.journal.flush()  # the results' lines survive a kill -9 from here on
                if self.parts > 1:   # the designs' parts, not a re-simulation's
                    p.parts(self.table, self.executor.parts_done(set(self.table.pending_ids())))
                if idle:
                    self.t_held += idle * (time.monotonic() - t_wait)
                if self.halt.stop and not self._stop_logged:
                    self._stop_logged = True
                    n = self.executor.running
                    msg = "interrupted: no new evaluations"
                    if not self.halt.abort and n:
                        msg += (f"; waiting for the {n} running to finish (Ctrl-C again to stop "
                                f"them now)")
                    p.log(msg)
                if self.halt.abort:
                    n = self.executor.running
                    if n:
                        p.log(f"stopping {n} running evaluation(s); they run again on resume")
                    self.executor.kill_running()
                    break
                if time.monotonic() - self._results_at > RESULTS_EVERY:
                    self._write_results()
        finally:
            self.executor.close()
            self.halt.restore()
            p.close()
            wall = time.monotonic() - t_start
            try:
                if not self._owner_lost:   # else the files are another process's now
                    self._close_session(wall, n_start)
            finally:
                self.journal.close()
        if not self.rd.folder.still_at(self.rd.path):
            p.log(f"note: {self.rd.path} no longer leads to this run's directory (it was moved or "
                  f"replaced while the run went); the run's files went with the directory")
        if not self.table.finished:
            p.log(f"saved {self.table.n_done}/{pb.budget} evaluations in {self.rd.path}; carry on "
                  f"with:")
            p.log(f"    lccopt resume {self.rd.path}")
            raise RunInterrupted(self.rd.path, self.table.n_done, pb.budget, self.halt.signum)
        self._summary(wall)

    def _close_session(self, wall: float, n_start: int) -> None:
        self._snapshot()
        self.log.session(wall_time=wall, evaluations=self.table.n_done - n_start,
                         optimiser_time=self.t_optimiser, bookkeeping_time=self.t_bookkeeping,
                         held_time=self.t_held, workers=self.lag,
                         executor=self.executor.description)
        if self.strategy.done and not self.table.pending_ids() and not self.table.finished:
            self.log.finished()
        self._write_results()

    def _best_lacks_histories(self) -> bool:
        """With ``histories: best``, queue the best design again when its file has no time
        histories (once all results are in); True if it was queued."""
        best = self.table.best()
        if self.histories != "best" or best is None or best["id"] in self._histories_done \
                or self.table.pending_ids():
            return False
        self._histories_done.add(best["id"])
        from ..store import has_time_histories

        if has_time_histories(self.rd.at(eval_name(best["id"]))):
            return False
        self._restore.append(best["id"])
        return True

    def _fill(self, requeue: list[int]) -> int:
        """Give every free worker a point; then, with all workers busy, propose the next point
        already, so that the next worker to finish gets it at once (the ask, or a whole
        block of proposals, runs while the evaluations do). A proposal waits for the results
        it must see (``_ask``); a free worker then idles until the late one arrives. Points
        asked but not yet running are pending in the journal: a resume runs them first, in
        order, and only then asks again, as the run would have. The asked lines are written
        (handed to the OS: they survive kill -9) before their evaluations start."""
        self._held = False
        rows = []
        free = self.executor.free()
        while len(rows) < free:
            if self._restore:
                i = self._restore.pop(0)
                self._restoring.add(i)
                rows.append(self.table.rows[i])
            elif requeue:
                rows.append(self.table.rows[requeue.pop(0)])
            elif self._ahead is not None:
                rows.append(self.table.rows[self._ahead])
                self._ahead = None
            else:
                row = self._ask()
                if row is None:
                    break
                rows.append(row)
        t0 = time.perf_counter()
        self.journal.flush()
        if time.monotonic() - self._synced_at > SYNC_EVERY:
            self.journal.sync()
            self._synced_at = time.monotonic()
        self.t_bookkeeping += time.perf_counter() - t0
        for row in rows:
            self._submit(row)
        if self.executor.free() == 0 and not requeue and self._ahead is None:
            row = self._ask()
            if row is not None:
                self._ahead = row["id"]
        return len(rows)

    def _ask(self) -> dict | None:
        """One proposal from the optimiser, committed to the journal; None if there is none now."""
        if (self.problem.reference_first and self.table.reference is None
                and self.strategy.n_asked >= 1):
            return None  # the reference design runs alone: the others' values need its result
        if self.strategy.done:
            return None
        if not may_ask(self.strategy, self.lag, self.problem.reference_first):
            self._held = True
            return None  # waits for the results it must see (in id order, whatever the timing)
        t0 = time.perf_counter()
        exhausted = self.strategy.exhausted
        props = self.strategy.ask(1)
        t1 = time.perf_counter()
        self.t_optimiser += t1 - t0
        if not props:
            if self.strategy.exhausted and not exhausted:  # replayed as a call that gives nothing
                self.log.exhausted(self.strategy.n_asked)
            self.t_bookkeeping += time.perf_counter() - t1
            self._release()  # no more proposals: every result may be told
            return None
        pr = props[0]
        self.log.asked(pr.id, pr.x, pr.phase, pr.restart)
        self.t_bookkeeping += time.perf_counter() - t1
        self._release()
        return self.table.rows[pr.id]

    def _result(self, i: int):
        return self.table.told(i, self.problem.outputs)

    def _release(self) -> None:
        """Tell the optimiser the results it may see now (in id order; see schedule.py)."""
        t0 = time.perf_counter()
        release(self.strategy, self.lag, self.problem.reference_first, self._result)
        self.t_optimiser += time.perf_counter() - t0

    def _submit(self, row: dict) -> None:
        # the evaluation file's path: a local worker writes it if that path leads to the run's
        # evals/ (its identity: not if the run directory was moved or replaced by a link), a Dask
        # worker if it also sees the run directory (executors.py), else the outcome brings the
        # evaluation to write here, through the directory this process holds open
        evals = self.rd.evals()
        out = str(evals.path / Path(eval_name(row["id"])).name)
        # time histories: every design's, or the reference design's and, at the end, the best's
        # (simulated again then: a few MB per design saved; docs/runs.md, "Disk use")
        keep = self.histories == "all" or (
            self.histories == "best" and (row["id"] == 0 or row["id"] in self._restoring))
        self.executor.submit(Task(row["id"], list(row["x"]), row["phase"], row["restart"], out,
                                  histories=keep, out_dir_id=evals.identity,
                                  run=self.table.head_mark))

    def _record(self, o: Outcome) -> None:
        if o.fault is not None:  # the machine refused a write: stop, the evaluation stays pending
            raise EnvironmentFault(f"{o.fault}; the run stopped with nothing lost (evaluations in "
                                   f"flight stay pending): fix the cause, then "
                                   f"'lccopt resume {self.rd.path}'")
        if o.id in self._restoring:
            self._restored(o)
            return
        row = self.table.rows.get(o.id)
        if row is None or row["status"] != "pending":
            return
        if (self.halt.stop and o.error is not None
                and o.error.startswith("worker process died (killed by")):
            return  # stopped along with lccopt by a signal: pending, runs again on resume
        t0 = time.perf_counter()
        pb = self.problem
        error = o.error
        objectives = o.objectives
        if objectives is not None and pb.statistics:   # the robust statistics of its tracks
            reference = (objectives if o.id == 0
                         else (self.table.reference or {}).get("objectives"))
            objectives = pb.complete(objectives, reference)
        if error is None:
            error = pb.finite(objectives)
        file = ""
        if objectives is not None:
            if o.file_written:
                file = eval_name(o.id)
            elif o.evaluation is not None:
                from ..store import write_evaluation

                attrs = {"id": o.id, "phase": row["phase"], "restart": row["restart"],
                         "worker": o.worker, "wall_time": o.wall_time, "run": self.table.head_mark,
                         **o.machine}
                write_evaluation(self.rd.at(eval_name(o.id)), o.evaluation, row["x"],
                                 self.case.names, attrs=attrs, durable=False)
                file = eval_name(o.id)
        common = dict(id=o.id, objectives=objectives or {}, wall_time=o.wall_time, worker=o.worker,
                      file=file,
                      # when it was committed: the date, and this process's monotonic clock,
                      # from which `lccopt status` rates the run (a wall clock can step)
                      at=round(time.time(), 3), mono=round(time.monotonic(), 3))
        if error is None:
            if o.id == 0 and self.table.reference is None:
                # CaseError if a worst value does not exceed its reference point (asked of the
                # case's problem: its message tells the case's worst values from the default)
                try:
                    point = pb.reference_point(objectives)
                except CaseError as exc:
                    raise CaseError(f"{self.case.path}: {exc}") from None
                self.problem = pb = pb.with_reference(objectives)  # worst: the case's or default
                self.log.reference(row["x"], objectives, point,
                                   list(pb.worst) if pb.worst else None, pb.rho, pb.improvement)
                self.ref_point = point
                self.strategy.set_aggregate(pb.aggregate(point))
            value = pb.value(objectives, self.ref_point)
            if pb.surrogate == "sleeper-energies" and o.parts is not None:
                common["parts"] = o.parts  # what the composite surrogate fits (and a replay tells)
            self.log.evaluated(value, common)
        else:
            self.log.failed(error, common)
        self.t_bookkeeping += time.perf_counter() - t0
        self._release()  # told when its turn comes, not when it arrives (schedule.py)
        self.progress.update(self.table, last=row)
        if error is not None and pb.reference_first and o.id == 0 \
                and self.table.reference is None:
            raise self._reference_failed(error)

    def _restored(self, o: Outcome) -> None:
        self._restoring.discard(o.id)
        row = self.table.rows[o.id]
        if o.error is None and o.evaluation is not None:
            from ..store import write_evaluation

            write_evaluation(self.rd.at(eval_name(o.id)), o.evaluation, row["x"],
                             self.case.names,
                             attrs={"id": o.id, "phase": row["phase"], "restart": row["restart"],
                                    "worker": o.worker, "wall_time": o.wall_time,
                                    "run": self.table.head_mark, **o.machine})
        if o.error is not None:
            self.progress.log(f"could not simulate #{o.id} again ({o.error}); its file stays "
                              f"missing")
            return
        same = all(abs(o.objectives[k] - v) <= 1e-9 * max(1.0, abs(v))
                   for k, v in row["objectives"].items() if k in o.objectives)
        why = "histories" if o.id in self._histories_done else "lost"
        self.log.restored(o.id, same, why)
        if not same:
            self.progress.log(f"#{o.id} simulated again gives other objectives than the journal's "
                              f"(another machine or library version?); the journal's values are "
                              f"kept")

    def _reference_failed(self, reason: str) -> CaseError:
        need = ("the ASF reference point" if self.problem.multi
                else "what p_worse compares with")
        return CaseError(f"{self.case.path}: the reference design (evaluation #0) failed: "
                         f"{reason}; the case needs its objectives for {need}")

    def _check_owner(self) -> None:
        """Stop (exit 2) if this process is no longer the run's one driver (RunDir.check_lock)."""
        why = self.rd.check_lock()
        if why:
            self._owner_lost = True
            raise EnvironmentFault(f"{why}; this process stopped writing to the run: check it with "
                                   f"'lccopt status {self.rd.path}'")

    def _snapshot(self) -> None:
        if self.table.seq == self._saved_seq:
            return
        t0 = time.perf_counter()
        self.journal.sync()  # a snapshot never reflects a line that is not on disk
        self.rd.save_state(self.table.seq, self.strategy.state_dict(),
                           line_mark(self.table.last_event))
        self._saved_seq = self.table.seq
        self._snapshot_at = time.monotonic()
        self.t_bookkeeping += time.perf_counter() - t0

    def _write_results(self) -> None:
        t0 = time.perf_counter()
        write_results(self.rd.at("results.h5"), self.table, case=self.case,
                      problem=self.problem, meta=self.meta)
        self._results_at = time.monotonic()
        self.t_bookkeeping += time.perf_counter() - t0

    def _summary(self, wall: float) -> None:
        lines = summary_lines(self.rd, self.table, self.case, self.problem, wall,
                              self.t_optimiser, self.t_bookkeeping)
        sys.stdout.write(printable_lines("\n".join(lines)) + "\n")
        sys.stdout.flush()
