"""When a phase of the search ends and what the next one is (paper Step F, the restart).

A phase is the search from one start: the first initial design, a fresh Latin hypercube, or
a point it goes on from (its "anchor": the run's best point, or a bound probe), with the step
size reset. ``RestartPolicy`` is the default; ``Strategy(restarts=...)`` takes any object with
the same three methods and ``state_dict``/``load_state_dict`` (experiments: benchmarks/
variants.py). A policy reads the strategy (``records``, ``phase``, ``budget``, ``n_asked``,
``settings``, ``space``, ``sigma``, ``failed_row``) and draws from ``strategy.rng`` only.

The default, in order of precedence at a restart:

1. After the bound probes of the run's probe-and-subspace step (all told): unless one
   improved on the run's best, a subspace phase from the best probe with its integer held
   on that bound, for half the budget left, on trial: it must improve on the run's best
   within ``fail_tol(d)`` proposals or it ends there. An "off" switch (no strip: x_l = 0) with
   the other variables tuned for "on" is a poor point of a subspace whose own optimum a step
   of sigma from the run's best never reaches. If a probe improved: on from the run's best.
2. After a failed trial: on from the run's best point (its basin is the best found).
3. The run's one probe-and-subspace step, where the run's basin looks spent: at the first
   restart that would go on from the run's best point (``subspace_start`` "endgame"), or the
   first after a phase that found nothing better than the phases before it ("stalled"; a
   composite surrogate's restarts are fresh, so "endgame" would never come): the run's best
   point with each integer on each bound no point has had, as the phase's design.
4. ``restart_from`` "endgame": with less budget left than the run's phases took on average,
   on from the run's best point (a late fresh design rarely gets anywhere); else, and with
   "fresh", a fresh Latin hypercube of n_initial points away from every used point.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .candidates import bound_probes
from .context import AskContext
from .sampling import latin_hypercube
from .settings import SIGMA_MIN, fail_tol


@dataclass
class Phase:
    """A phase of the search as it runs.

    Attributes
    ----------
    index : int
        0 for the first, then one more per restart (the records' ``restart``).
    start : int
        The id of its first proposal.
    n_design : int
        The points of its design (asked before any surrogate proposal).
    anchor : int or None
        The record it goes on from (no design), or None.
    frozen : int or None
        A variable it holds at the anchor's value (a subspace phase), or None.
    end : int or None
        The number of proposals at which it ends, or None (the step rule ends it).
    trial : (int, float) or None
        (n_asked at its end, value to beat): a subspace phase's trial.
    """

    index: int = 0
    start: int = 0
    n_design: int = 0
    anchor: int | None = None
    frozen: int | None = None
    end: int | None = None
    trial: tuple[int, float] | None = None

    def to_dict(self) -> dict:
        """Plain JSON types."""
        d = asdict(self)
        d["trial"] = None if self.trial is None else list(self.trial)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "Phase":
        """The phase a ``to_dict`` wrote."""
        t = d.get("trial")
        return cls(int(d["index"]), int(d["start"]), int(d["n_design"]),
                   None if d["anchor"] is None else int(d["anchor"]),
                   None if d["frozen"] is None else int(d["frozen"]),
                   None if d["end"] is None else int(d["end"]),
                   None if t is None else (int(t[0]), float(t[1])))


@dataclass
class NextPhase:
    """What a restart policy asks for: the design to ask first (points), the record to go on
    from, the variable to hold, the proposal count to end at, the trial (see ``Phase``)."""

    design: list
    anchor: int | None = None
    frozen: int | None = None
    end: int | None = None
    trial: tuple[int, float] | None = None


class RestartPolicy:
    """The default restart policy (see the module docstring)."""

    def __init__(self):
        self.subspace_tried = False  # the run's one probe-and-subspace step has been taken
        self.subspace_probes: range | None = None  # its probes, until the phase they lead to

    # -- when -------------------------------------------------------------------------------
    def phase_over(self, s) -> bool:
        """Whether the phase of strategy ``s`` ends before its next proposal (its design
        asked): sigma collapsed, evaluations failing in a row, its end reached, the step's
        probes all told, or a failed trial."""
        ph = s.phase
        return (s.sigma < SIGMA_MIN or s.failed_row >= fail_tol(s.space.dim)
                or ph.end is not None and s.n_asked >= ph.end
                or self.subspace_probes is not None and not any(
                    s.records[i]["status"] == "pending" for i in self.subspace_probes)
                or trial_failed(s))

    # -- what -------------------------------------------------------------------------------
    def next_phase(self, s) -> NextPhase:
        """The phase that follows the one of ``s`` that ends (see the module docstring)."""
        failed = trial_failed(s)
        ok = [r for r in s.records if r["status"] == "ok"]
        best = min(ok, key=lambda r: (r["value"], r["id"])) if ok else None
        from_best = s.settings.restart_from == "endgame" and _late(s)
        if self.subspace_probes is not None:
            plan = self._subspace_phase(s, ok)
            if plan is not None:
                return plan
            from_best = True  # a probe improved on the run's best: go on from it
        elif failed:
            from_best = True
        elif best and not self.subspace_tried and (
                from_best if s.settings.subspace_start == "endgame" else last_phase_stalled(s, ok)):
            self.subspace_tried = True
            probes = new_bound_probes(s, best["x"])
            if probes:
                n = len(s.records)
                self.subspace_probes = range(n, n + len(probes))
                return NextPhase(probes, anchor=best["id"])
        if from_best and best:
            return NextPhase([], anchor=best["id"])
        taken = np.array([r["x"] for r in s.records]).reshape(-1, s.space.dim)
        return NextPhase(list(latin_hypercube(s.space, s.n_initial, s.rng, exclude=taken)))

    def _subspace_phase(self, s, ok: list[dict]) -> NextPhase | None:
        """After the step's probes: the subspace phase of the best probe, or None if a probe
        improved on the run's best (by the step rule's tolerance)."""
        ids, self.subspace_probes = self.subspace_probes, None
        anchor = s.records[s.phase.anchor]
        probes = [r for r in ok if r["id"] in ids]
        if not probes or min(r["value"] for r in ok) < s.success_bar(anchor["value"]):
            return None
        p = min(probes, key=lambda r: (r["value"], r["id"]))
        j = int(np.flatnonzero(p["x"] != anchor["x"])[0])
        end = s.n_asked + (s.budget - s.n_asked) // 2
        trial = (s.n_asked + fail_tol(s.space.dim),
                 s.success_bar(min(r["value"] for r in ok)))
        return NextPhase([], anchor=p["id"], frozen=j, end=end, trial=trial)

    # -- state ------------------------------------------------------------------------------
    def state_dict(self) -> dict:
        """The policy's state (part of the strategy's) as plain JSON types."""
        pr = self.subspace_probes
        return {"subspace_tried": self.subspace_tried,
                "subspace_probes": None if pr is None else [pr.start, pr.stop]}

    def load_state_dict(self, d: dict) -> None:
        """Back to the state a ``state_dict`` wrote."""
        self.subspace_tried = bool(d["subspace_tried"])
        pr = d["subspace_probes"]
        self.subspace_probes = None if pr is None else range(int(pr[0]), int(pr[1]))


def trial_failed(s) -> bool:
    """A subspace phase at the end of its trial, the trial's points told and none below the
    bar (while some are pending the phase goes on: the verdict waits for them)."""
    trial = s.phase.trial
    if trial is None or s.n_asked < trial[0]:
        return False
    end, bar = trial
    return not any(r["status"] == "pending" or r["status"] == "ok" and r["value"] < bar
                   for r in s.records[s.phase.start:end])


def last_phase_stalled(s, ok: list[dict]) -> bool:
    """Whether the phase that just ended failed to improve on the best of the phases before
    it by the step rule's tolerance: a fresh design found no better basin."""
    before = [r["value"] for r in ok if r["restart"] < s.phase.index]
    last = [r["value"] for r in ok if r["restart"] == s.phase.index]
    if not before:
        return False
    return not (last and min(last) < s.success_bar(min(before)))


def new_bound_probes(s, best: np.ndarray) -> list:
    """The bound probes of ``best`` (``candidates.bound_probes``) that no point of the run
    has taken yet."""
    free = s.space.ub - s.space.lb > 0
    P = bound_probes(s.space, best, best[None, :], free)
    taken = np.array([r["x"] for r in s.records]).reshape(-1, s.space.dim)
    return list(P[~AskContext(s.space, taken, taken[:0]).is_taken(P)])


def _late(s) -> bool:
    """The budget left is shorter than the run's phases so far (the first design's and every
    restart's, by their proposals) were on average."""
    n = s.phase.index + 1
    lengths = np.bincount([r["restart"] for r in s.records], minlength=n)
    return s.budget - s.n_asked < lengths[:n].mean()
