"""``lccopt status RUN``: where a run stands, read from its journal without disturbing it.

Read-only and lock-free: the journal is appended to by the process driving the run, and a
reader sees its committed lines (a torn last line is ignored); whether the run is going is
asked of the run's lock (flock), which a crashed process cannot leave held.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

from ..safeio import read_owned
from ..terminal import wrap_items
from .journal import read_journal
from .progress import best_text, hms
from .rundir import RunDir, RunError, Table

RATE_WINDOW = 20  # results over which the current pace is measured


def status_lines(run: Path) -> list[str]:
    """The lines ``lccopt status`` prints (RunError if RUN is not a run directory)."""
    rd = RunDir.open(Path(run))
    events, _, _ = read_journal(rd.journal_path)
    if not events or events[0].get("event") != "run":
        raise RunError(f"{rd.journal_path} is empty or not an lccopt journal")
    head = events[0]
    shown = _variables(rd) or [(f"x{i + 1}", "", 1.0) for i in range(_dimension(events))]
    names = [n for n, _, _ in shown]
    table = Table(names, list(head.get("objectives") or []))
    budget = int(head.get("budget") or 0)
    for ev in events:
        table.apply(ev)
        if ev.get("event") == "case_changed" and ev.get("budget"):
            budget = int(ev["budget"])
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
    lines += _timing(events, table, budget, running)
    if not table.finished and not running:
        lines.append(f"  carry on with: lccopt resume {rd.path}")
    return lines


def _timing(events: list[dict], table: Table, budget: int, running: bool) -> list[str]:
    walls = [r["wall_time"] for r in table.rows.values()
             if r["status"] != "pending" and math.isfinite(r["wall_time"])]
    out = []
    if walls:
        out.append(f"  {sum(walls) / len(walls):.3g} s of simulation per evaluation")
    stamps = [ev["at"] for ev in events if ev.get("event") in ("evaluated", "failed")
              and isinstance(ev.get("at"), (int, float))]
    left = budget - table.n_done
    if running and len(stamps) >= 2 and left > 0:
        recent = stamps[-RATE_WINDOW:]
        pace = (recent[-1] - recent[0]) / (len(recent) - 1)
        since = max(0.0, time.time() - recent[-1])
        out.append(f"  one result every {pace:.3g} s lately; about "
                   f"{hms(max(0.0, left * pace - since))} left")
    return out


def _variables(rd: RunDir) -> list[tuple[str, str, float]] | None:
    """(name, unit, factor) of each design variable, as run.json records them."""
    try:
        meta = json.loads(read_owned(rd.meta_path, 1_000_000).decode("utf-8"))
        return [(str(n), str(u), float(f)) for n, u, f in meta["variables"]]
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _dimension(events: list[dict]) -> int:
    asked = next((ev for ev in events if ev.get("event") == "asked"), None)
    return len(asked["x"]) if asked else 0
