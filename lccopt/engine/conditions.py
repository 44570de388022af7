"""Traffic conditions: one evaluation of a design is one task per condition.

:class:`ConditionPool` sits between the engine and an executor (local pool or Dask). The
engine submits one Task per design as always; the pool runs it as one task per condition
(design, condition), spread over the workers, and hands the engine one Outcome per design
when all its conditions are in: the conditions' objectives combined by the case's rule
(``Problem.combine``) and one evaluation file holding every condition.

Files, per design i and condition c: the condition's result is written (atomically) to
``evals/00000i.c<c>.h5`` as it arrives; once all are in they are merged into
``evals/00000i.h5`` and the parts are removed. A part that exists is complete (written to a
temporary name and renamed; not fsynced, as every evaluation file: loop.py), so a run
stopped half-way through a design's conditions (kill -9, Ctrl-C, a full disk) keeps the
conditions already computed: on resume the design runs again for the missing ones only (and
for a part a power cut damaged).

A design whose condition fails fails as a whole (the reason names the condition); its other
conditions still finish, so their parts are there if the design is ever run again.

Parallel share: ``slots`` (the engine's lag, how many designs are in flight) is the
workers divided by the conditions, rounded up, so that the tasks of the designs in flight
keep every worker busy; it depends only on the worker count and the case, so a run stays
reproducible.
"""

from __future__ import annotations

import math

import numpy as np

from .. import machine
from ..errors import describe_os_error, environment_errno
from ..store import (
    merge_condition_files,
    read_evaluation,
    write_condition_evaluations,
    write_evaluation,
)
from .worker import Outcome, Task


def part_name(i: int, c: int) -> str:
    """Evaluation file of design i under condition c, relative to the run directory."""
    return f"evals/{i:06d}.c{c:02d}.h5"


class ConditionPool:
    """An executor of designs over the case's conditions (see the module docstring)."""

    def __init__(self, inner, case, problem, rd):
        self.inner, self.case, self.problem = inner, case, problem
        self.rd = rd   # the run directory (RunDir): files through its evals/, held open
        self.m = len(case.conditions)
        self.kind = inner.kind
        self._queue: list[Task] = []                      # condition tasks waiting for a worker
        self._parts: dict[int, dict[int, Outcome]] = {}   # design id -> condition -> outcome
        self._tasks: dict[int, Task] = {}                 # designs in flight

    # -- executor interface ----------------------------------------------------------------------
    @property
    def description(self) -> str:
        return f"{self.inner.description}, {self.m} conditions per design"

    def start(self, log=None) -> None:
        self.inner.start(log)

    @property
    def slots(self) -> int:
        return max(1, math.ceil(self.inner.slots / self.m))

    @property
    def running(self) -> int:
        return len(self._tasks)

    def parts_done(self, ids) -> int:
        """Conditions finished of the designs ``ids`` still in flight."""
        return sum(len(self._parts[i]) for i in self._tasks if i in ids)

    def free(self) -> int:
        return max(0, self.slots - len(self._tasks)) if not self._queue else 0

    def submit(self, task: Task) -> None:
        self._tasks[task.id] = task
        done = self._parts.setdefault(task.id, {})
        for c in range(self.m):
            kept = self._kept_part(task, c)
            if kept is not None:
                done[c] = kept
                continue
            out = None if task.out_path is None else str(
                self.rd.evals().path / part_name(task.id, c)[len("evals/"):])
            self._queue.append(Task(task.id, task.x, task.phase, task.restart, out, condition=c,
                                    histories=task.histories, out_dir_id=task.out_dir_id,
                                    run=task.run))
        self._pump()

    def wait(self, timeout: float) -> list[Outcome]:
        self._pump()
        out = []
        ready = [i for i in self._tasks if len(self._parts[i]) == self.m]
        if not ready:
            for o in self.inner.wait(timeout):
                if o.id in self._tasks:
                    self._parts[o.id][o.condition] = o
            self._pump()
            ready = [i for i in self._tasks if len(self._parts[i]) == self.m]
        for i in sorted(ready):
            out.append(self._combine(self._tasks.pop(i), self._parts.pop(i)))
        return out

    def kill_running(self) -> None:
        self._queue.clear()
        self.inner.kill_running()
        self._tasks.clear()
        self._parts.clear()

    def close(self) -> None:
        self.inner.close()

    # -- internals -------------------------------------------------------------------------------
    def _pump(self) -> None:
        while self._queue and self.inner.free() > 0:
            self.inner.submit(self._queue.pop(0))

    def _kept_part(self, task: Task, c: int) -> Outcome | None:
        """The outcome of condition c from its part file of an earlier session, if it is
        there, readable and of this design."""
        place = self.rd.at(part_name(task.id, c))
        if task.out_path is None or not place[0].is_file(place[1]):
            return None
        try:
            x, ev = read_evaluation(place)
        except Exception:  # noqa: BLE001 - damaged: simulate again
            return None
        if x.shape != (len(task.x),) or not np.array_equal(x, np.asarray(task.x, dtype=float)):
            return None
        info = dict(ev.info)
        return Outcome(task.id, condition=c, objectives=dict(ev.objectives), info=info,
                       file_written=True, wall_time=float(info.get("wall_time", math.nan)),
                       worker=str(info.get("worker", "")),
                       machine={k: str(info[k]) for k in machine.ENTRIES if k in info})

    def _combine(self, task: Task, parts: dict[int, Outcome]) -> Outcome:
        names = [c.name for c in self.case.conditions]
        faults = [f"{names[c]}: {o.fault}" for c, o in sorted(parts.items()) if o.fault]
        wall = sum(o.wall_time for o in parts.values() if math.isfinite(o.wall_time))
        workers = ",".join(sorted({o.worker for o in parts.values() if o.worker}))
        if faults:
            return Outcome(task.id, fault=faults[0], wall_time=wall, worker=workers)
        errors = [f"condition {names[c]}: {o.error}" for c, o in sorted(parts.items()) if o.error]
        if errors:
            return Outcome(task.id, error=errors[0][:500], wall_time=wall, worker=workers)
        per = [parts[c].objectives for c in range(self.m)]
        bad = [f"condition {names[c]}: {k}={v!r}" for c, o in enumerate(per) for k, v in o.items()
               if not (isinstance(v, (int, float)) and math.isfinite(v))]
        if bad:
            return Outcome(task.id, error=f"non-finite objectives: {', '.join(bad)}"[:500],
                           wall_time=wall, worker=workers)
        objectives = self.problem.combine(per)
        info = {"conditions": len(per), **{f"{k}@{names[c]}": v for c in range(self.m)
                                            for k, v in parts[c].info.items()
                                            if k in ("wall_time", "contact_loss_steps")}}
        # the conditions' machines, one entry each where they agree (a Dask cluster may differ)
        entries = {k: ",".join(sorted({str(o.machine[k]) for o in parts.values()
                                       if k in o.machine}))
                   for k in machine.ENTRIES}
        entries = {k: v for k, v in entries.items() if v}
        out = Outcome(task.id, objectives=objectives, info=info, wall_time=wall, worker=workers,
                      machine=entries)
        target = self.rd.at(f"evals/{task.id:06d}.h5")
        shown = target[0].display(target[1])
        attrs = {"id": task.id, "phase": task.phase, "restart": task.restart, "worker": workers,
                 "wall_time": wall, **({"run": task.run} if task.run else {}), **entries}
        try:
            if task.out_path is not None:   # the workers wrote the parts (or sent them here)
                places = [self.rd.at(part_name(task.id, c)) for c in range(self.m)]
                for c, o in parts.items():
                    if not o.file_written:  # the worker did not write it (see worker.run_task)
                        write_evaluation(places[c], o.evaluation, task.x, self.case.names,
                                         attrs={"id": task.id, "condition": c, "worker": o.worker,
                                                "wall_time": o.wall_time,
                                                **({"run": task.run} if task.run else {}),
                                                **o.machine},
                                         durable=False)
                merge_condition_files(target, places, names, self.problem.weights, objectives,
                                      attrs, durable=False)
                for folder, name in places:
                    folder.unlink(name)
            else:                            # the evaluations came back whole
                write_condition_evaluations(target, [parts[c].evaluation for c in range(self.m)],
                                            task.x, self.case.names, names, self.problem.weights,
                                            objectives, attrs, durable=False)
            out.file_written = True
        except Exception as exc:  # noqa: BLE001
            if environment_errno(exc) is not None:
                return Outcome(task.id, fault=describe_os_error(exc), wall_time=wall,
                               worker=workers)
            return Outcome(task.id, error=f"could not write {shown}: {exc}", wall_time=wall,
                           worker=workers)
        return out
