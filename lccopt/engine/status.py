"""``lccopt status RUN``: where a run stands, read from its journal without disturbing it.

Read-only and lock-free: the journal is appended to by the process driving the run, and a
reader sees its committed lines (a torn last line is ignored); whether the run is going is
asked of the run's lock (flock), which a crashed process cannot leave held.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ..errors import printable
from ..terminal import wrap_items
from ..version import recorded_code
from .events import RUN, SESSION
from .journal import JournalError, read_journal
from .progress import best_text, hms
from .run import Run
from .rundir import JOURNAL, RunDir, RunError

RATE_WINDOW = 20  # results over which the current pace is measured


def status_lines(run: Path) -> list[str]:
    """The lines ``lccopt status`` prints (RunError if RUN is not a run directory)."""
    rd = RunDir.open(Path(run))
    try:
        events, _, _ = read_journal(rd.at(JOURNAL))
    except JournalError as exc:
        raise RunError(f"{exc.args[0].split(';')[0]}; the journal was changed by something other "
                       f"than lccopt: 'lccopt resume {rd.path} --repair-journal' carries on from "
                       f"the {exc.line - 1} lines before it") from None
    if not events or events[0].get("event") != RUN:
        raise RunError(f"{rd.journal_path} is empty or not an lccopt journal")
    table = Run.of(events)
    shown = _variables(rd) or [(n, "", 1.0) for n in table.names]
    budget = int(table.budget or 0)
    running = rd.locked_by_other()
    state = "finished" if table.finished else ("running" if running else "stopped")
    done, failed, pending = table.n_done, table.n_failed, len(table.pending_ids())
    # at most one design per worker runs (the schedule's lag); the loop asks one ahead, which
    # waits for a free worker
    flying = min(pending, table.lag) if getattr(table, "lag", None) else pending
    lines = [f"{rd.path}: {state}, {done}/{budget} evaluations"
             + (f" ({failed} failed)" if failed else "")
             + (f", {flying} in flight" if flying and running else "")
             + (f" and {pending - flying} proposed" if pending > flying and running else "")]
    lines.append("  " + best_text(table))
    best = table.best()
    if best is not None:
        lines += wrap_items([f"{n}={v * scale:.4g}" + (f" {unit}" if unit else "")
                             for (n, unit, scale), v in zip(shown, best["x"])], "  x: ")
    tracks = table.head.get("realisations")
    if isinstance(tracks, dict):   # the track varies: what every design was judged on
        lines += [f"  tracks: {tracks.get('count')} realisations (seed {tracks.get('seed')}) "
                  f"and the drawn track per design,",
                  f"          their fingerprint {tracks.get('fingerprint')}"]
    lines += _codes(events)
    lines += _timing(table, budget, running)
    if not table.finished and not running:
        lines.append(f"  carry on with: lccopt resume {rd.path}")
    return lines


def _codes(events: list[dict]) -> list[str]:
    """A line when the run's sessions ran more than one version of lccopt's code (its start
    and each session's end record it): designs evaluated by each may not compare."""
    codes = []
    for ev in events:
        code = recorded_code(ev.get("versions")) if ev.get("event") in (RUN, SESSION) else None
        if code and code not in codes:
            codes.append(code)
    if len(codes) < 2:
        return []
    return ["  lccopt's code changed between sessions (values may not compare):",
            *wrap_items([codes[0], *(f"then {c}" for c in codes[1:])], "    ")]


def _timing(table: Run, budget: int, running: bool) -> list[str]:
    walls = [r["wall_time"] for r in table.rows.values() if r["status"] != "pending"
             and _number(r["wall_time"]) and r["wall_time"] >= 0]
    out = []
    if walls:
        out.append(f"  {sum(walls) / len(walls):.3g} s of simulation per evaluation")
    left = budget - table.n_done
    pace = _pace(table.stamps) if running and left > 0 else None
    if pace is not None:
        out.append(f"  one result every {pace:.3g} s lately; about {hms(left * pace)} left")
    return out


def _pace(results: list[tuple]) -> float | None:
    """Seconds per result over the last RATE_WINDOW results of the session that is going
    (``Run.stamps``: (mono, at) of the results after the last ``session`` line, which ends a
    session), from the driving process's monotonic clock (``mono``): a step of the wall clock
    (NTP, a suspended laptop, a changed time zone or date) changes nothing. Lines of an lccopt
    that wrote only the wall clock (``at``) are rated from it, after its last step back. None
    when it cannot be told."""
    stamps = [mono for mono, _ in results]
    if not all(_number(t) for t in stamps):
        stamps = [at for _, at in results]
        if not all(_number(t) for t in stamps):
            return None
    stamps = stamps[-RATE_WINDOW:]
    for i in range(len(stamps) - 1, 0, -1):
        if stamps[i] < stamps[i - 1]:   # the clock stepped back: only what came after
            stamps = stamps[i:]
            break
    if len(stamps) < 2 or stamps[-1] <= stamps[0]:
        return None
    return (stamps[-1] - stamps[0]) / (len(stamps) - 1)


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _variables(rd: RunDir) -> list[tuple[str, str, float]] | None:
    """(name, unit, factor) of each design variable, as run.json records them."""
    try:
        meta = json.loads(rd.read_text("run.json", 1_000_000))
        # printable: run.json is a file anyone could have edited (a name with a newline or a
        # terminal escape sequence must not make lines or colours of its own)
        return [(printable(str(n)), printable(str(u)), float(f)) for n, u, f in meta["variables"]]
    except (OSError, ValueError, KeyError, TypeError):
        return None

