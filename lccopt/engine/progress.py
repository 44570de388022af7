"""Progress on stderr: a redrawn line on a terminal, one plain line per evaluation otherwise."""

from __future__ import annotations

import math
import sys
import time

from ..errors import printable, printable_lines
from ..terminal import wrap_items, wrap_message
from ..uncertainty.statistics import is_probability
from ..vti.response import objective_display


def hms(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    s = int(round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def fmt(v) -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.6g}"


def objective_value(k: str, v) -> str:
    """Objective k's value in engineering units, e.g. '7.56 kN', '0.413 J'."""
    if v is None or not math.isfinite(v):
        return "-"
    scale, unit = objective_display(k)
    return f"{v * scale:.3g} {unit}" if unit else f"{v * scale:.3g}"


def objective_text(k: str, v) -> str:
    """'F_max 7.56 kN'."""
    return f"{k} {objective_value(k, v)}"


def reference_objectives(table) -> dict | None:
    """The reference design's objectives: from the reference line (multi-objective), else
    evaluation 0 (the reference design is always proposal 0)."""
    ref = (table.reference or {}).get("objectives")
    if ref is None and 0 in table.rows and table.rows[0]["status"] == "ok":
        ref = table.rows[0]["objectives"]
    return ref


def best_items(table, short: bool = False) -> list[str]:
    """The best design's objectives so far with their change against the reference design,
    one item each (``F_max 5.4 kN -28%``; SHORT: without parentheses), [] if none yet."""
    best = table.best()
    if best is None:
        return []
    ref = reference_objectives(table)
    parts = []
    for k in table.objectives:
        v, r = best["objectives"].get(k), (ref or {}).get(k)
        rel = ""
        if r and v is not None and math.isfinite(v) and not is_probability(k):
            rel = f" {(v - r) / r:+.0%}" if short else f" ({(v - r) / r:+.0%})"
        parts.append(printable(objective_text(k, v)) + rel)
    return parts


def best_text(table, short: bool = False) -> str:
    """The best design so far: its objectives and their change against the reference design
    (SHORT: without the evaluation number, for a terminal line)."""
    best = table.best()
    if best is None:
        return "best -"
    return ("best " if short else f"best #{best['id']}: ") + ", ".join(best_items(table, short))


BAR = 5  # characters of the progress bar on a terminal


def fit(text: str, width: int) -> str:
    """TEXT cut to WIDTH characters with an ellipsis (rich would otherwise squeeze the times)."""
    return text if len(text) <= width else text[:max(0, width - 1)] + "…"


class Progress:
    """Evaluations, elapsed time, ETA and the best design so far.

    On a terminal a rich live display that fits the terminal's width: the bar and the times
    on one line, the best design's objectives below it, wrapped between objectives (a long
    name such as differential_settlement never cut), each line cut with an ellipsis rather
    than wrapped by the terminal, so a redraw never leaves stale lines; in a log file or pipe
    one plain line per finished evaluation."""

    def __init__(self, budget: int, stream=None, enabled: bool = True):
        self.stream = stream or sys.stderr
        self.budget = budget
        self.per_design = 1     # simulations per design (traffic conditions): the bar counts them
        self._best_shown = None  # the best design last written to a log
        self.enabled = enabled
        # no stream at all (pythonw, a closed stderr in a program using the library): silence
        self.mute = self.stream is None
        self.tty = enabled and not self.mute and _isatty(self.stream)
        self.t0 = time.monotonic()
        self.done0: int | None = None   # evaluations already done when this session started
        self._live = None
        self._task = None

    def start(self, table, per_design: int = 1) -> None:
        """Show the line from the session's start (the reference design's time counts too)."""
        self.per_design = max(1, int(per_design))
        self.t0 = time.monotonic()
        self.done0 = table.n_done
        if self.tty and not self.mute:
            try:
                self._start(table.n_done)
                self._draw(table, 0)
            except (OSError, ValueError):
                self._silence()

    def _start(self, done: int) -> None:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )
        from rich.progress import Progress as RichProgress
        from rich.table import Column
        from rich.text import Text

        class _Lines(RichProgress):
            """The progress line with lines of text below it (the best design)."""
            below: list[str] = []

            def get_renderables(self):
                yield self.make_tasks_table(self.tasks)
                for line in self.below:
                    yield Text(line, no_wrap=True, overflow="ellipsis")

        # the terminal itself: the live line is made of control sequences (what it shows is
        # made printable here)
        console = Console(file=getattr(self.stream, "raw", self.stream), highlight=False)
        fixed = Column(no_wrap=True)
        self._live = _Lines(
            BarColumn(bar_width=BAR), MofNCompleteColumn(table_column=fixed),
            TimeElapsedColumn(table_column=fixed), TextColumn("ETA", table_column=fixed),
            TimeRemainingColumn(table_column=fixed),
            TextColumn("{task.description}",
                       table_column=Column(no_wrap=True, overflow="ellipsis")),
            console=console, transient=False, auto_refresh=False)
        self._text_width = console.width - 1
        total = self.budget * self.per_design
        self._task = self._live.add_task("", total=total, completed=done * self.per_design)
        self._live.start()

    def _draw(self, table, parts: int) -> None:
        failed = table.n_failed
        items = best_items(table, short=True) or ["-"]
        self._live.below = [fit(line, self._text_width)
                            for line in wrap_items(items, "  best ", self._text_width)]
        self._live.update(self._task, completed=table.n_done * self.per_design + parts,
                          description=f"failed {failed}" if failed else "")
        self._live.refresh()

    def parts(self, table, parts: int) -> None:
        """Simulations finished of the designs still in flight (traffic conditions)."""
        if self._live is not None:
            try:
                self._draw(table, parts)
            except (OSError, ValueError):
                self._silence()

    def log(self, message: str) -> None:
        """A message on its own line (above the live progress line on a terminal, and wrapped
        to its width there; one line in a log)."""
        text = printable(f"lccopt: {message}")   # a run's stored strings (names, reasons)
        if self.mute:
            return
        if self._live is not None:
            try:
                self._live.console.print(wrap_message(text, self._live.console.width),
                                         markup=False, soft_wrap=True)
            except (OSError, ValueError):
                self._silence()
            return
        if _isatty(self.stream):
            text = wrap_message(text)
        self._write(text + "\n")

    def _write(self, text: str) -> None:
        """Progress is best effort: a stream that cannot be written (closed, full, an I/O
        error) silences it for the rest of the session, and the run goes on."""
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):
            self._silence()

    def _silence(self) -> None:
        self.mute = True
        if self._live is not None:
            live, self._live = self._live, None
            try:
                live.stop()
            except (OSError, ValueError):
                pass

    def update(self, table, last: dict | None = None) -> None:
        if not self.enabled or self.mute:
            return
        done, failed = table.n_done, table.n_failed
        if self.done0 is None:
            self.done0 = done
        tail = f"  failed {failed}" if failed else ""
        if self.tty:
            try:
                if self._live is None:
                    self._start(done)
                self._draw(table, 0)
            except (OSError, ValueError):
                self._silence()
            return
        # a log: one line per result, and the best design on a line of its own when it changes
        # (each fits 80 columns)
        elapsed = time.monotonic() - self.t0
        new = done - self.done0
        left = f", ~{hms((self.budget - done) * elapsed / new)} left" if new > 0 else ""
        width = len(str(self.budget))
        what = ""
        if last is not None:
            what = (f" #{last['id']} {last['phase']} ok" if last["status"] == "ok"
                    else f" #{last['id']} {last['phase']} FAILED: {printable(last['reason'])}")
        text = f"lccopt: [{done:>{width}}/{self.budget}]{what}, {hms(elapsed)}{left}{tail}\n"
        best = table.best()
        if best is not None and best["id"] != self._best_shown:
            self._best_shown = best["id"]
            text += f"lccopt:   {best_text(table)}\n"
        self._write(printable_lines(text))

    def close(self) -> None:
        if self._live is not None:
            try:
                self._live.refresh()
                self._live.stop()
            except (OSError, ValueError):
                pass
            self._live = None


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, OSError, ValueError):
        return False


def summary_lines(rd, table, case, problem, wall: float, t_optimiser: float,
                  t_bookkeeping: float) -> list[str]:
    """The lines that end a run's session: evaluations, times, the best design against the
    reference design (on the same tracks, with realisations), where the results are."""
    from ..config import design_items

    t, pb = table, problem
    lines = [f"done: {t.n_done} evaluations ({t.n_failed} failed) in {rd.path}",
             f"  this session {hms(wall)} wall, optimiser {t_optimiser:.1f} s, "
             f"bookkeeping {t_bookkeeping:.1f} s"]
    best = t.best()
    ref = reference_objectives(t) or {}
    if best is not None:
        lines.append(f"best #{best['id']} ({best['phase']}, restart {best['restart']}): value "
                     f"{fmt(best['value'])}")
        lines += wrap_items(design_items(case, best["x"]), "  x: ")
        for k in pb.objectives:
            v, r = best["objectives"].get(k), ref.get(k)
            rel = ("" if not r else " (unchanged: the reference design's)" if v == r else
                   f" (reference design {objective_value(k, r)})" if is_probability(k) else
                   f" ({(v - r) / r:+.1%} vs reference design {objective_value(k, r)})")
            lines.append(f"  {objective_text(k, v)}{rel}")
    # the reference design against itself beats it nowhere: nothing to say
    if best is not None and pb.realisations and ref and best["id"] != 0:
        lines += wrap_items(realisation_wins(pb, best["objectives"], ref),
                            "  beats the reference design on the same tracks: ")
    lines.append(f"results: {rd.results_path}")
    return lines


def realisation_wins(problem, objectives: dict, reference: dict) -> list[str]:
    """``F_max on 7 of 8``: on how many realisations a design's value of each objective the
    case measures is below the reference design's."""
    from ..uncertainty import statistics as robust

    out = []
    for base in dict.fromkeys(robust.objective_of(k) for k in problem.objectives):
        a = robust.values(objectives, base, problem.realisations)
        b = robust.values(reference, base, problem.realisations)
        out.append(f"{base} on {int((a < b).sum())} of {problem.realisations} realisations")
    return out
