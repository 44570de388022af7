"""The optimiser rebuilt from a run's journal: a snapshot (``state.json``) plus a replay of the
journal lines after it, and the settings a run recorded.

The optimiser calls are a fixed function of the journal lines (``Replay``: each ``asked`` or
``exhausted`` line is an ask, a result is told as the schedule rule allows after each line,
with the lag of the session's ``schedule`` line), so the optimiser state after any committed
line is the snapshot plus a replay of the lines after it (``ask`` must give back the logged
point, which is checked). With the same worker count the sequence of calls, and so the run,
is the same as without the interruption, and the same from one run to the next.
"""

from __future__ import annotations

import re

import numpy as np

from ..problem import Problem
from ..version import recorded_code
from .events import ASKED, CASE_CHANGED, EXHAUSTED, REFERENCE, RESULTS, SCHEDULE
from .journal import JournalError, line_mark
from .run import Run
from .schedule import release
from .upgrade import ADDED_SETTINGS, recorded_settings_dict, settings_unrecorded


def restore(problem: Problem, events: list[dict], snapshot: dict | None):
    """Optimiser and run (``run.Run``) after the journal's events (snapshot + replay of the
    rest).

    The optimiser is built with the settings the run recorded (``recorded_settings``). The
    snapshot is a cache: one made with other settings, or that does not replay (stale,
    foreign, from another version), is dropped and the whole journal replayed."""
    seq = snapshot.get("seq") if isinstance(snapshot, dict) else None
    if (isinstance(seq, int) and 0 <= seq < len(events)
            and snapshot.get("mark") == line_mark(events[seq])):
        try:
            strategy, table = _restore(problem, events, snapshot)
            if _agrees(strategy, table):
                return strategy, table
        except Exception:  # noqa: BLE001 - a cache anyone could have edited: replay instead
            pass
    return _restore(problem, events, None)


def _agrees(strategy, table: Run) -> bool:
    """The optimiser restored from a snapshot holds exactly the journal's proposals, and the
    results it was told are the journal's (a snapshot that claims a line it does not reflect
    would otherwise carry on from another state)."""
    history = strategy.history
    if len(history) != len(table.rows):
        return False
    for rec in history:
        row = table.rows.get(rec["id"])
        if row is None or not np.array_equal(np.asarray(row["x"], dtype=float), rec["x"]):
            return False
        if rec["status"] != "pending" and (rec["status"] != row["status"] or (
                row["status"] == "ok" and rec["value"] != row["value"])):
            return False
    return True


def _restore(problem: Problem, events: list[dict], snapshot: dict | None):
    from ..optim.strategy import Strategy

    run = Run(problem.names, problem.objectives)
    replayer = Replay(None, problem.reference_first, problem, run)
    if events:  # the run's first line: its budget and settings build the optimiser
        replayer._apply(events[0])
    settings = recorded_settings(problem, events[0]) if events else problem.optimiser_settings()
    strategy, start = None, 1
    if snapshot is not None and 0 <= snapshot["seq"] < len(events):
        try:
            strategy = Strategy.from_state(snapshot["strategy"])
            start = int(snapshot["seq"]) + 1
        except Exception:  # noqa: BLE001 - a stale or foreign snapshot: replay everything
            strategy = None
        if strategy is not None and strategy.settings != settings:
            strategy = None
    if strategy is None:
        budget = problem.budget if run.budget is None else run.budget
        strategy = problem.strategy(budget=budget, settings=settings)
        start = 1
    elif not problem.multi:  # not part of the state (for E_max alone: sleeper_energy_spread)
        strategy.set_aggregate(problem.aggregate(None))
    replayer.strategy = strategy
    if events:
        replayer._follow(events[0])
    for ev in events[1:start]:  # what the snapshot already reflects: results held back, the lag
        replayer.note(ev)
    for ev in events[start:]:
        replayer(ev)
    return strategy, run


def recorded_settings(problem: Problem, first: dict):
    """The optimiser settings of the run whose journal's first line is ``first``.

    The line records them (``"optimiser"``: the settings' dict, where a setting added since
    takes its earlier value); a line that says ``"optimiser": 12`` instead means today's
    default settings for the recorded surrogate with those added since at their earlier value.
    Any other run (another number, no settings, or settings this lccopt does not have)
    raises JournalError naming the lccopt version that made it."""
    from ..optim.settings import Settings

    rec = first.get("optimiser")
    if isinstance(rec, dict):
        try:
            return Settings.from_dict(recorded_settings_dict(rec))
        except ValueError as exc:
            raise JournalError(f"{_made_by(first)} with optimiser settings this lccopt does not "
                               f"have ({exc}): resume it with that version") from None
    if settings_unrecorded(rec):
        return Settings.default(composite=first.get("surrogate", "scalar") != "scalar").replace(
            **ADDED_SETTINGS)
    what = ("no optimiser settings" if rec is None
            else f"\"optimiser\": {rec!r} instead of its settings")
    raise JournalError(f"{_made_by(first)} (its journal names {what}), whose proposals this "
                       f"lccopt does not make: resume it with that version")


def _made_by(first: dict) -> str:
    versions = first.get("versions")
    version = versions.get("lccopt") if isinstance(versions, dict) else None
    if not (isinstance(version, str) and re.fullmatch(r"[\w.+-]{1,30}", version)):
        version = None   # a crafted journal shows nothing of its own on the terminal
    code = recorded_code(versions)
    if code:
        version = f"{version or '(version unknown)'} (code {code})"
    when = str(first.get("time", ""))[:10]
    if not re.fullmatch(r"\d{4}-\d{2}-\d{2}", when):
        when = ""
    return (f"this run was made by lccopt {version or '(version unknown)'}"
            + (f" on {when}" if when else ""))


class Replay:
    """Makes the optimiser calls that the engine made for each journal line (see schedule.py:
    results are told in id order, each once the proposal ``lag`` ids later has been made;
    the lag is the one of the session's ``schedule`` line).

    Each line is applied to ``run`` (a fresh ``run.Run`` unless given), and the calls follow
    from it: the results told are the run's, the budget is the run's after a ``case_changed``
    line. With the problem given, results are told with their objective vectors, and the
    optimiser's aggregate (the ASF, for a composite surrogate) is set as the engine set it:
    from the run's ASF in force after a ``reference`` line, or a ``case_changed`` line that
    records other worst values or rho."""

    def __init__(self, strategy, multi: bool, problem=None, run: Run | None = None):
        self.strategy, self.multi, self.problem = strategy, multi, problem
        self.run = Run() if run is None else run

    def outputs(self, ev: dict):
        if self.problem is None:
            return None
        return self.problem.outputs(ev.get("objectives") or {}, ev.get("parts"))

    def _told(self, i: int):
        return self.run.told(i, None if self.problem is None else self.problem.outputs)

    def _apply(self, ev: dict) -> None:
        try:
            self.run.apply(ev)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            seq = ev.get("seq")
            line = seq + 1 if isinstance(seq, int) else "?"
            raise JournalError(f"journal line {line} is not a valid event "
                               f"({type(exc).__name__}: {exc}); the journal was changed by "
                               f"something other than lccopt") from None

    def note(self, ev: dict) -> None:
        """Apply a line the optimiser's state already reflects (a snapshot's): the run, the
        block size and the aggregate follow it, no call is made."""
        self._apply(ev)
        self._follow(ev)

    def _follow(self, ev: dict) -> None:
        kind = ev["event"]
        if kind == SCHEDULE:
            self.strategy.set_batch(self.run.batch)
        elif self.problem is None or self.run.asf is None:
            return
        elif kind == REFERENCE or (kind == CASE_CHANGED and ("worst" in ev or "rho" in ev)):
            a = self.run.asf
            self.strategy.set_aggregate(self.problem.aggregate(a["point"], a["worst"], a["rho"]))

    def __call__(self, ev: dict) -> None:
        kind = ev["event"]
        if self.run.lag is None and kind in (ASKED, EXHAUSTED, *RESULTS):
            raise JournalError(f"journal line {ev['seq'] + 1}: {kind} before the journal's "
                               f"first schedule line; the journal was changed by something "
                               f"other than lccopt")
        self._apply(ev)
        if kind in (ASKED, EXHAUSTED):
            replay(self.strategy, ev)
        elif kind == CASE_CHANGED:
            self.strategy.budget = self.run.budget
        self._follow(ev)
        if self.run.lag is not None:
            release(self.strategy, self.run.lag, self.multi, self._told)


def replay(strategy, ev: dict) -> None:
    """The optimiser call of an ``asked`` or ``exhausted`` line; an asked point the optimiser
    does not propose raises JournalError."""
    props = strategy.ask(1)
    if ev["event"] == ASKED:
        if (not props or props[0].id != ev["id"]
                or not np.array_equal(props[0].x, np.asarray(ev["x"], float))):
            got = f"#{props[0].id} {props[0].x.tolist()}" if props else "nothing"
            raise JournalError(f"journal line {ev['seq'] + 1}: the optimiser proposes {got}, the "
                               f"journal says #{ev['id']} {ev['x']}; was lccopt changed since the "
                               f"run started?")
    elif props or not strategy.exhausted:
        got = props[0].id if props else "?"
        raise JournalError(f"journal line {ev['seq'] + 1}: the optimiser proposes #{got}, the "
                           f"journal says the design space was exhausted; was lccopt changed "
                           f"since the run started?")
