"""The run as its journal describes it: one object built by applying the journal's lines in
order, and the one writer of those lines.

:class:`Run` knows what every reader of a run needs, so that none of them works it out from
the lines again: the evaluations (the table results.h5 holds), the budget in force (the first
line's, then each ``case_changed`` line's: a resume with ``--budget``), the reference design's
line and the ASF's point, worst values and rho in force, the schedule of the last session,
whether the run finished, the sessions' wall times and the pace of the session going. The
engine (``loop.Engine``), a resume's replay of the optimiser (``replay``), ``lccopt status``
and the report read it alike.

:class:`Recorder` writes each kind of line with its fields and applies it to the run at once,
so the run in memory is always the journal's lines applied in order. Lines of a kind this
lccopt does not know (a newer lccopt's) are kept in the journal and change nothing here.
"""

from __future__ import annotations

import math

from .events import (
    ASKED,
    CASE_CHANGED,
    EVALUATED,
    EXHAUSTED,
    FAILED,
    FINISHED,
    REFERENCE,
    RESTORED,
    RESULTS,
    RUN,
    SCHEDULE,
    SESSION,
)


def eval_name(i: int) -> str:
    """The run's file of evaluation ``i`` (relative to the run directory)."""
    return f"evals/{i:06d}.h5"


class Run:
    """A run's state after the journal lines applied so far (:meth:`apply`, in order).

    ``names`` and ``objectives`` label the design variables and objectives (results.h5's
    columns); the journal's own first line is ``head``."""

    def __init__(self, names=(), objectives=()):
        self.names = list(names)
        self.objectives = list(objectives)
        self.head: dict = {}                 # the run's first line (``run``)
        self.rows: dict[int, dict] = {}      # every proposal, by id
        self.budget: int | None = None       # evaluations the run goes to (None: not recorded)
        self.reference: dict | None = None   # the reference line: objectives, point, worst, ...
        self.asf: dict | None = None         # point, worst, rho of the ASF in force
        self.finished = False
        self.seq = -1
        self.last_event: dict | None = None
        self.head_mark = ""                  # line_mark of the run's first line: which run it is
        self.lag: int | None = None          # the schedule's lag (workers) of the last session
        self.batch = 1                       # and its block size (schedule.batch_size)
        self.dimension = 0                   # values of a design (the first proposal's)
        self.session_walls: list[float] = []  # wall time of each session that ended
        # (mono, at) of each result since the last session line: the pace of the one going
        self.stamps: list[tuple] = []

    @classmethod
    def of(cls, events: list[dict], names=None, objectives=None) -> "Run":
        """The run after ``events`` (names: ``x1, x2, ...`` unless given; objectives: the
        first line's unless given)."""
        run = cls(names or (), objectives or ())
        for ev in events:
            run.apply(ev)
        if names is None:
            run.names = [f"x{i + 1}" for i in range(run.dimension)]
        if objectives is None:
            run.objectives = list(run.head.get("objectives") or [])
        return run

    def apply(self, ev: dict) -> None:
        """The next journal line (KeyError, TypeError, ValueError on one lccopt cannot use)."""
        self.seq = ev["seq"]
        self.last_event = ev
        kind = ev["event"]
        if self.seq == 0:
            from .journal import line_mark

            self.head_mark = line_mark(ev)
            if kind == RUN:
                self.head = ev
                self.budget = ev.get("budget")
        if kind == ASKED:
            self.rows[ev["id"]] = {
                "id": ev["id"], "x": list(ev["x"]), "phase": ev["phase"], "restart": ev["restart"],
                "status": "pending", "reason": "", "objectives": {}, "value": math.nan,
                "wall_time": math.nan, "worker": "", "file": "",
            }
            self.dimension = self.dimension or len(ev["x"])
        elif kind in RESULTS:
            self._result(ev, kind)
        elif kind == REFERENCE:
            self.reference = {k: v for k, v in ev.items() if k not in ("seq", "event")}
            self.asf = {"point": ev.get("point"), "worst": ev.get("worst"), "rho": ev.get("rho")}
        elif kind == FINISHED:
            self.finished = True
        elif kind == SCHEDULE:
            self.lag = int(ev["lag"])
            self.batch = int(ev.get("batch", 1))
        elif kind == CASE_CHANGED:  # e.g. a larger budget: a finished run carries on
            self.finished = False
            self.budget = int(ev["budget"])
            if self.asf is not None:
                self.asf.update({k: ev[k] for k in ("worst", "rho") if k in ev})
        elif kind == SESSION:
            self.session_walls.append(ev.get("wall_time", 0.0))
            self.stamps = []

    def _result(self, ev: dict, kind: str) -> None:
        r = self.rows[ev["id"]]
        r["status"] = "ok" if kind == EVALUATED else "failed"
        r["objectives"] = dict(ev.get("objectives") or {})
        r["value"] = ev.get("value", math.nan) if kind == EVALUATED else math.nan
        r["reason"] = ev.get("reason", "")
        r["wall_time"] = ev.get("wall_time", math.nan)
        r["worker"] = ev.get("worker", "")
        r["file"] = ev.get("file", "")
        if r["file"] not in ("", eval_name(ev["id"])):  # never a path out of the run
            raise ValueError(f"evaluation #{ev['id']} names the file {r['file'][:80]!r}")
        if "parts" in ev:  # the sleepers' energies (composite surrogate of E_max)
            r["parts"] = ev["parts"]
        self.stamps.append((ev.get("mono"), ev.get("at")))

    # -- views ----------------------------------------------------------------------------------
    def done_rows(self) -> list[dict]:
        return [self.rows[i] for i in sorted(self.rows) if self.rows[i]["status"] != "pending"]

    def pending_ids(self) -> list[int]:
        return sorted(i for i, r in self.rows.items() if r["status"] == "pending")

    @property
    def n_done(self) -> int:
        return sum(r["status"] != "pending" for r in self.rows.values())

    @property
    def n_failed(self) -> int:
        return sum(r["status"] == "failed" for r in self.rows.values())

    def best(self) -> dict | None:
        ok = [r for r in self.rows.values() if r["status"] == "ok"]
        return min(ok, key=lambda r: (r["value"], r["id"])) if ok else None

    def files(self) -> set[str]:
        return {r["file"] for r in self.rows.values() if r["file"]}

    def told(self, i: int, outputs=None):
        """What the optimiser is told of proposal ``i`` (``schedule.release``): None while it
        has no result, ``("failed", reason)``, or ``("ok", value, outputs)`` with ``outputs``
        (the problem's ``outputs``) of its objectives and parts."""
        r = self.rows.get(i)
        if r is None or r["status"] == "pending":
            return None
        if r["status"] != "ok":
            return ("failed", r["reason"])
        return ("ok", r["value"],
                None if outputs is None else outputs(r["objectives"], r.get("parts")))


class Recorder:
    """The one writer of a run's journal lines after its first: each kind with its fields,
    appended (``journal.Journal``) and applied to ``run`` at once (without a run: a line a
    resume writes before it replays the journal, such as ``case_changed``). ``sync=False``
    lines wait for the engine's next flush or sync (see journal.py)."""

    def __init__(self, journal, run: Run | None = None):
        self.journal, self.run = journal, run

    def _write(self, kind: str, sync: bool = True, **fields) -> dict:
        ev = self.journal.append(kind, sync=sync, **fields)
        if self.run is not None:
            self.run.apply(ev)
        return ev

    def schedule(self, lag: int, batch: int) -> dict:
        from .rundir import now_iso

        return self._write(SCHEDULE, lag=lag, batch=batch, time=now_iso())

    def asked(self, i: int, x, phase: str, restart: int) -> dict:
        return self._write(ASKED, sync=False, id=int(i), x=[float(v) for v in x], phase=phase,
                           restart=int(restart))

    def exhausted(self, n_asked: int) -> dict:
        return self._write(EXHAUSTED, n_asked=n_asked)

    def reference(self, x, objectives: dict, point, worst, rho, improvement) -> dict:
        return self._write(REFERENCE, sync=False, id=0, x=x, objectives=objectives, point=point,
                           worst=worst, rho=rho, improvement=improvement)

    def evaluated(self, value: float, result: dict) -> dict:
        """``result``: id, objectives, wall_time, worker, file, at, mono (and parts)."""
        return self._write(EVALUATED, sync=False, value=value, **result)

    def failed(self, reason: str, result: dict) -> dict:
        return self._write(FAILED, sync=False, reason=reason, **result)

    def restored(self, i: int, same: bool, why: str) -> dict:
        return self._write(RESTORED, id=i, file=eval_name(i), same=same, why=why)

    def case_changed(self, case_sha256: str, budget: int, case_file: str, **asf) -> dict:
        """A resume's changed case: its fingerprint, budget and file, and (``asf``) the
        worst values and rho of a multi-objective run."""
        from .rundir import now_iso

        return self._write(CASE_CHANGED, time=now_iso(), case_sha256=case_sha256,
                           budget=budget, case_file=case_file, **asf)

    def session(self, **timings) -> dict:
        """The end of a session: wall_time, evaluations, the times spent, workers, executor."""
        from .rundir import now_iso, versions

        return self._write(SESSION, time=now_iso(), **timings, versions=versions())

    def finished(self) -> dict:
        from .rundir import now_iso

        return self._write(FINISHED, time=now_iso(), evaluations=self.run.n_done)
