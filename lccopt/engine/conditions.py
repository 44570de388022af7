"""Traffic conditions and realisations of the track: one evaluation of a design is one task per
(condition, track).

:class:`ConditionPool` sits between the engine and an executor (local pool or Dask). The
engine submits one Task per design as always; the pool runs it as one task per part: each
traffic condition (or the case as it is, without conditions) on the track as drawn and, for a
case with ``uncertainty:``, on each of its realisations (the same for every design: common
random numbers). The parts are spread over the workers, and the engine gets one Outcome per
design when all its parts are in: on each track the conditions' objectives combined by the
case's rule (``Problem.combine``), the drawing's as the design's objectives and each
realisation's as ``F_max#r`` (``Problem.realisation_objectives``), and one evaluation file
holding every part.

Files, per design i, condition c and realisation r: the part's result is written
(atomically) to ``evals/00000i.c<c>.h5`` (the drawn track; ``.r<r>`` added for a
realisation; without conditions ``.r<r>``, or ``.drawn`` for the drawn track) as it arrives;
once all are in they are merged into ``evals/00000i.h5`` and the parts are removed. A part
that exists is complete (written to a temporary name and renamed; not fsynced, as every
evaluation file: loop.py), so a run stopped half-way through a design's parts (kill -9,
Ctrl-C, a full disk) keeps the parts already computed: on resume the design runs again for
the missing ones only (and for a part a power cut damaged). A realisation keeps only its
per-sleeper histories (its time histories would multiply the disk a design takes by the
realisations).

A design whose part fails fails as a whole (the reason names the part); its other parts still
finish, so their files are there if the design is ever run again.

Parallel share: ``slots`` (the engine's lag, how many designs are in flight) is the workers
divided by the parts, rounded up, so that the tasks of the designs in flight keep every worker
busy; it depends only on the worker count and the case, so a run stays reproducible.
"""

from __future__ import annotations

import math
from pathlib import Path

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


def part_name(i: int, c: int, r: int = -1) -> str:
    """Evaluation file of design i under condition c (-1: none) on realisation r (-1: the
    track as drawn), relative to the run directory; never the design's merged file."""
    part = (f".c{c:02d}" if c >= 0 else "") + (f".r{r:03d}" if r >= 0 else "")
    return f"evals/{i:06d}{part or '.drawn'}.h5"


class ConditionPool:
    """An executor of designs over the case's conditions and realisations (see the module
    docstring)."""

    def __init__(self, inner, case, problem, run_path: Path):
        self.inner, self.case, self.problem = inner, case, problem
        self.run_path = Path(run_path)
        self.conditions = list(range(len(case.conditions))) or [-1]
        self.tracks = [-1, *range(case.realisations)]
        self.keys = [(c, r) for r in self.tracks for c in self.conditions]   # the parts
        self.m = len(self.keys)
        self.kind = inner.kind
        self._queue: list[Task] = []                       # part tasks waiting for a worker
        self._parts: dict[int, dict[tuple, Outcome]] = {}  # design id -> (c, r) -> outcome
        self._tasks: dict[int, Task] = {}                  # designs in flight

    # -- executor interface ----------------------------------------------------------------------
    @property
    def description(self) -> str:
        what = []
        if self.case.conditions:
            what.append(f"{len(self.case.conditions)} conditions")
        if self.case.realisations:
            what.append(f"{self.case.realisations} realisations and the drawn track")
        return f"{self.inner.description}, {' x '.join(what)} per design"

    def start(self, log=None) -> None:
        self.inner.start(log)

    @property
    def slots(self) -> int:
        return max(1, math.ceil(self.inner.slots / self.m))

    @property
    def running(self) -> int:
        return len(self._tasks)

    def parts_done(self, ids) -> int:
        """Parts finished of the designs ``ids`` still in flight."""
        return sum(len(self._parts[i]) for i in self._tasks if i in ids)

    def free(self) -> int:
        return max(0, self.slots - len(self._tasks)) if not self._queue else 0

    def submit(self, task: Task) -> None:
        self._tasks[task.id] = task
        done = self._parts.setdefault(task.id, {})
        for c, r in self.keys:
            kept = self._kept_part(task, c, r)
            if kept is not None:
                done[(c, r)] = kept
                continue
            out = (None if task.out_path is None
                   else str(self.run_path / part_name(task.id, c, r)))
            self._queue.append(Task(task.id, task.x, task.phase, task.restart, out, condition=c,
                                    histories=task.histories and r < 0, realisation=r))
        self._pump()

    def wait(self, timeout: float) -> list[Outcome]:
        self._pump()
        out = []
        ready = [i for i in self._tasks if len(self._parts[i]) == self.m]
        if not ready:
            for o in self.inner.wait(timeout):
                if o.id in self._tasks:
                    self._parts[o.id][(o.condition, o.realisation)] = o
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

    def _kept_part(self, task: Task, c: int, r: int) -> Outcome | None:
        """The outcome of part (c, r) from its file of an earlier session, if it is there,
        readable and of this design."""
        path = self.run_path / part_name(task.id, c, r)
        if task.out_path is None or not path.is_file():
            return None
        try:
            x, ev = read_evaluation(path)
        except Exception:  # noqa: BLE001 - damaged: simulate again
            return None
        if x.shape != (len(task.x),) or not np.array_equal(x, np.asarray(task.x, dtype=float)):
            return None
        info = dict(ev.info)
        return Outcome(task.id, condition=c, realisation=r, objectives=dict(ev.objectives),
                       info=info,
                       file_written=True, wall_time=float(info.get("wall_time", math.nan)),
                       worker=str(info.get("worker", "")),
                       machine={k: str(info[k]) for k in machine.ENTRIES if k in info})

    def _label(self, c: int, r: int) -> str:
        """The part in a failure's reason: ``condition v160``, ``realisation 3``, both."""
        names = [cond.name for cond in self.case.conditions]
        where = [f"condition {names[c]}"] if c >= 0 else []
        if r >= 0:
            where.append(f"realisation {r}")
        elif self.case.realisations:
            where.append("the drawn track")
        return ", ".join(where)

    def _combine(self, task: Task, parts: dict[tuple, Outcome]) -> Outcome:
        names = [c.name for c in self.case.conditions]
        faults = [f"{self._label(*k)}: {parts[k].fault}" for k in self.keys if parts[k].fault]
        wall = sum(o.wall_time for o in parts.values() if math.isfinite(o.wall_time))
        workers = ",".join(sorted({o.worker for o in parts.values() if o.worker}))
        if faults:
            return Outcome(task.id, fault=faults[0], wall_time=wall, worker=workers)
        errors = [f"{self._label(*k)}: {parts[k].error}" for k in self.keys if parts[k].error]
        if errors:
            return Outcome(task.id, error=errors[0][:500], wall_time=wall, worker=workers)
        bad = [f"{self._label(*k)}: {n}={v!r}" for k in self.keys
               for n, v in parts[k].objectives.items()
               if not (isinstance(v, (int, float)) and math.isfinite(v))]
        if bad:
            return Outcome(task.id, error=f"non-finite objectives: {', '.join(bad)}"[:500],
                           wall_time=wall, worker=workers)
        on_track = {r: self._on_track(parts, r) for r in self.tracks}
        tracks = [on_track[r] for r in self.tracks if r >= 0]
        objectives = {**on_track[-1], **self.problem.realisation_objectives(tracks)}
        first = self.conditions[0]
        drawn = parts[(first, -1)]
        info = {}
        if self.case.conditions:
            info = {"conditions": len(names),
                    **{f"{k}@{names[c]}": v for c in self.conditions
                       for k, v in parts[(c, -1)].info.items()
                       if k in ("wall_time", "contact_loss_steps")}}
        if tracks:
            info["realisations"] = len(tracks)
        # the parts' machines, one entry each where they agree (a Dask cluster may differ)
        entries = {k: ",".join(sorted({str(o.machine[k]) for o in parts.values()
                                       if k in o.machine}))
                   for k in machine.ENTRIES}
        entries = {k: v for k, v in entries.items() if v}
        out = Outcome(task.id, objectives=objectives, info=info, wall_time=wall, worker=workers,
                      machine=entries, parts=drawn.parts if not self.case.conditions else None)
        target = self.run_path / f"evals/{task.id:06d}.h5"
        attrs = {"id": task.id, "phase": task.phase, "restart": task.restart, "worker": workers,
                 "wall_time": wall, **entries}
        try:
            if task.out_path is not None:   # the workers wrote the parts (or sent them here)
                paths = {k: self.run_path / part_name(task.id, *k) for k in self.keys}
                for k, o in parts.items():
                    if not o.file_written:  # a Dask worker that does not see the run directory
                        write_evaluation(paths[k], o.evaluation, task.x, self.case.names,
                                         attrs={"id": task.id, "condition": k[0],
                                                "realisation": k[1], "worker": o.worker,
                                                "wall_time": o.wall_time, **o.machine},
                                         durable=False)
                merge_condition_files(target, [paths[(c, -1)] for c in self.conditions], names,
                                      self.problem.weights, objectives, attrs, durable=False,
                                      realisations=[(on_track[r], paths[(first, r)])
                                                    for r in self.tracks if r >= 0])
                for p in paths.values():
                    p.unlink(missing_ok=True)
            else:                            # the evaluations came back whole
                write_condition_evaluations(
                    target, [parts[(c, -1)].evaluation for c in self.conditions], task.x,
                    self.case.names, names, self.problem.weights, objectives, attrs,
                    durable=False, realisations=[(on_track[r], parts[(first, r)].evaluation)
                                                 for r in self.tracks if r >= 0])
            out.file_written = True
        except Exception as exc:  # noqa: BLE001
            if environment_errno(exc) is not None:
                return Outcome(task.id, fault=f"cannot write {target}: {describe_os_error(exc)}",
                               wall_time=wall, worker=workers)
            return Outcome(task.id, error=f"could not write {target}: {exc}", wall_time=wall,
                           worker=workers)
        return out

    def _on_track(self, parts: dict[tuple, Outcome], r: int) -> dict:
        """The objectives of one track (-1: as drawn): its conditions' combined by the case's
        rule, or the one part's."""
        if not self.case.conditions:
            return dict(parts[(-1, r)].objectives)
        return self.problem.combine([parts[(c, r)].objectives for c in self.conditions])
