"""``lccopt report RUN``: write a run's report (``lccopt.report``) and say what it holds."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from ..errors import printable
from ..report import Report, write_report
from ..report.comparison import drawn_only, fixed_limit
from ..report.data import pct
from ..terminal import wrap_items
from ..uncertainty.statistics import is_probability


def run_report(run: Path, format: str, out: Path | None, force: bool) -> None:
    typer.echo("\n".join(report_lines(write_report(run, format, out, force, echo=typer.echo))))


def change(k: str, new: float, old: float) -> str:
    """``-28.1 %``; a probability as its value against the reference design's (``0.25
    against 1``): its relative change would read as another probability."""
    return f"{new:.3g} against {old:.3g}" if is_probability(k) else pct(new, old)


def _on_bound(data, name: str, side: str) -> str:
    """``x_r1 (upper)``; a bound no case can widen says why: ``x_l (lower: no Type II strip)``,
    else the line would read as advice to widen it."""
    v = next((v for v in data.variables if v.name == name), None)
    limit = fixed_limit(data, v, side).split(":")[0] if v is not None else ""
    return f"{name} ({side}{f': {limit}' if limit else ''})"


def report_lines(report: Report) -> list[str]:
    """The lines that sum a written report up: the run, its best design against the
    reference, what sits on a bound or got worse, and what was written where."""
    data, summary = report.run, report.summary
    # printable: the name and objectives come from the run's files, which anyone may edit
    lines = [f"report of '{printable(data.name)}' ({data.n}/{data.budget} evaluations, "
             f"{data.state})"]
    if "best" in summary:  # a line of its own: one line would wrap on an 80-column terminal
        best = summary["best"]["objectives"]
        lines.append(f"  best #{summary['best']['id']}: " + ", ".join(
            f"{printable(k)} {change(k, best[k], data.ref_objectives.get(k, math.nan))}"
            for k in data.objectives))
        on = [_on_bound(data, k, side) for k, side in summary["on_bound"].items()]
        worse = [f"{k}{' as drawn' if drawn_only(data, k) else ''} "
                 f"{change(k, best[k], data.ref_objectives[k])}" for k in summary["worse"]]
        for head, items in (("  on a bound: ", on), ("  worse than the reference: ", worse)):
            if items:
                lines += wrap_items(items, head)
    lines.append(f"  {len(report.figures)} figures and {', '.join(p.name for p in report.files)} "
                 f"in {report.path} ({summary['seconds']:.1f} s)")
    return lines
