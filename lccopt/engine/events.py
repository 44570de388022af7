"""The journal's event kinds, and what each journal line must hold, checked as it is read.

Every kind of line lccopt writes is named here once (``RUN``, ``ASKED``, ...): the writer
(``run.Recorder``), the one place that applies lines in order (``run.Run.apply``), the
optimiser's replay and this check compare against these names, never against text of their own.

A journal is a file anyone can edit: a line that parses as JSON but holds a string where a
number belongs, an evaluation of a design never asked for, or a list where a name belongs
would otherwise surface as a traceback wherever it is first used (status, resume's replay,
the report). :class:`EventCheck` sees every line in order, once, and raises ValueError
naming the field; the reader turns that into one line naming the journal and the line.

Only what lccopt reads is checked; fields it does not know are left alone, and so are
events of a kind it does not know (a newer lccopt's).
"""

from __future__ import annotations

import math

MAX_DIMENSION = 10_000      # design variables: far beyond any case (the paper's has 8)

# The kinds of journal line. Their text is what the journal holds, so it never changes: runs
# made by every earlier lccopt are read with these.
RUN = "run"                    # line 0: what the run is (budget, objectives, seed, settings)
SCHEDULE = "schedule"          # a session's lag (workers) and block of proposals per fit
ASKED = "asked"                # a proposal (id, x, phase, restart)
EXHAUSTED = "exhausted"        # an ask that gave nothing: the design space is used up
EVALUATED = "evaluated"        # a proposal's objectives and value
FAILED = "failed"              # a proposal that gave no objectives, and why
REFERENCE = "reference"        # the reference design's objectives: the ASF's reference point
CASE_CHANGED = "case_changed"  # a resume with another budget, timeout or ASF worst values / rho
RESTORED = "restored"          # a lost evaluation file simulated again (no budget spent)
SESSION = "session"            # the end of one command's work on the run, with its timings
FINISHED = "finished"          # every evaluation of the budget has its result
RESULTS = (EVALUATED, FAILED)  # the lines that end a proposal


def _int(v, name: str, least: int = 0) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < least:
        raise ValueError(f"{name} must be a whole number of at least {least}, not {_show(v)}")
    return v


def _number(v, name: str, finite: bool = False) -> float:
    """A JSON number (NaN and infinities too unless ``finite``: timings may be NaN)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (finite and not math.isfinite(v)):
        raise ValueError(f"{name} must be a {'finite ' if finite else ''}number, not {_show(v)}")
    return float(v)


def _str(v, name: str) -> str:
    if not isinstance(v, str):
        raise ValueError(f"{name} must be text, not {_show(v)}")
    return v


def _numbers(v, name: str, finite: bool = False, most: int = MAX_DIMENSION) -> list:
    if not isinstance(v, list) or len(v) > most:
        raise ValueError(f"{name} must be a list of numbers, not {_show(v)}")
    for i, item in enumerate(v):
        _number(item, f"{name}[{i}]", finite)
    return v


def _objectives(v, name: str) -> dict:
    if not isinstance(v, dict):
        raise ValueError(f"{name} must be a mapping of objective names to numbers, not {_show(v)}")
    for k, item in v.items():
        _number(item, f"{name}.{k}")
    return v


def _show(v) -> str:
    text = repr(v)
    return text if len(text) <= 40 else text[:37] + "..."


def _optional(ev: dict, key: str, check, *args) -> None:
    if key in ev and ev[key] is not None:
        check(ev[key], key, *args)


class EventCheck:
    """Checks journal lines in order (call it on each); raises ValueError on the first
    field that lccopt could not use."""

    def __init__(self):
        self.pending: set[int] = set()   # asked, no result yet
        self.asked: set[int] = set()
        self.dimension: int | None = None

    def __call__(self, ev: dict) -> None:
        kind = ev.get("event")
        _str(kind, "event")
        if ev["seq"] == 0 and kind == RUN:
            _optional(ev, "budget", _int)
            if "objectives" in ev and not (isinstance(ev["objectives"], list) and all(
                    isinstance(k, str) for k in ev["objectives"])):
                raise ValueError(f"objectives must be a list of names, not "
                                 f"{_show(ev['objectives'])}")
            _optional(ev, "seed", _int)
        elif kind == ASKED:
            i = _int(ev.get("id"), "id")
            if i in self.asked:
                raise ValueError(f"evaluation #{i} is asked twice")
            x = _numbers(ev.get("x"), "x", finite=True)
            if self.dimension is None:
                self.dimension = len(x)
            if len(x) != self.dimension or not x:
                raise ValueError(f"x has {len(x)} values where the run's designs have "
                                 f"{self.dimension}")
            _str(ev.get("phase"), "phase")
            _int(ev.get("restart"), "restart")
            self.asked.add(i)
            self.pending.add(i)
        elif kind in RESULTS:
            i = _int(ev.get("id"), "id")
            if i not in self.pending:
                raise ValueError(f"a result of evaluation #{i}, which "
                                 f"{'has one already' if i in self.asked else 'was never asked'}")
            self.pending.discard(i)
            _optional(ev, "objectives", _objectives)
            for key in ("wall_time", "at", "mono"):
                _optional(ev, key, _number)
            for key in ("worker", "file"):
                _optional(ev, key, _str)
            if kind == EVALUATED:
                _number(ev.get("value"), "value")
                _objectives(ev.get("objectives"), "objectives")
                _optional(ev, "parts", _numbers)
            else:
                _str(ev.get("reason"), "reason")
        elif kind == REFERENCE:
            _objectives(ev.get("objectives"), "objectives")
            _optional(ev, "point", _numbers)
            _optional(ev, "worst", _numbers)
            for key in ("rho", "improvement"):
                _optional(ev, key, _number)
        elif kind == SCHEDULE:
            _int(ev.get("lag"), "lag", 1)
            _optional(ev, "batch", _int, 1)
        elif kind == CASE_CHANGED:
            _int(ev.get("budget"), "budget")
            _optional(ev, "worst", _numbers)
            _optional(ev, "rho", _number)
        elif kind == EXHAUSTED:
            _optional(ev, "n_asked", _int)
        elif kind == RESTORED:
            i = _int(ev.get("id"), "id")
            if i not in self.asked:
                raise ValueError(f"evaluation #{i} restored but never asked")
        elif kind == SESSION:
            for key in ("wall_time", "evaluations", "optimiser_time", "bookkeeping_time",
                        "held_time"):
                _optional(ev, key, _number)
