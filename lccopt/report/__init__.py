"""``lccopt report RUN``: figures and a summary of a run, after the paper's Figs. 6-11, Tables 5-7.

Writes into ``RUN/report/`` (or ``--out DIR``):

    search-history.png     value of every evaluation by number, phase, failures, best so far,
                           restarts (Figs. 6, 7, 10)
    objective-space.png    all evaluations in (F_max, E_max) (the run's two first objectives for
                           a multi-objective run), Pareto front, reference design, reference
                           point, chosen compromise (Fig. 9); drawn for single-objective runs too
    best-vs-reference.png  change of every objective and design variable, best vs reference
                           (Tables 5-7 as a picture; the numbers are in the summary)
    conditions.png         each traffic condition's objectives, best vs reference (cases with
                           a conditions: list)
    contact-force.png      contact force against wheel position, best and reference (ERS and
                           evaluation zone marked)
    sleeper-energy.png     energy dissipated under each zone sleeper, best and reference (Fig. 11)
    track-layout.png       drawing of the entry side next to the interface, best and reference
    sensitivity.png        variance-based (Sobol') indices of each objective over the design
                           space, from a cubic RBF of the run's evaluations
    settlement-history.png settlement per sleeper against axle passes, best and reference (a
                           case with degradation:; lccopt/report/settlement.py)
    settlement-profile.png the settlement along the zone at chosen times, and the voids
    law-variants.json      the best and the reference design re-predicted under eight variants
                           of the settlement law (kept for the next report)
    robust-spread.png      each objective over the realisations of the track, reference, nominal
                           and robust optimum side by side (a case with uncertainty:;
                           lccopt/report/robust.py)
    report.md / report.html  the summary (HTML self-contained: figures embedded as base64)
    summary.json           the key numbers, machine-readable

Read-only on the run: results.h5 is opened read-only and read at once (the engine replaces it
atomically); when the journal has committed more evaluations than results.h5 shows (a running
or killed run), the evaluation table is rebuilt from the journal instead. Only the evaluation
files of the best and the reference design are read; missing ones (failed evaluations, files of
a fake evaluator without histories) leave a note instead of a figure.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from ..atomic import atomic_write_text
from ..errors import printable
from ..safeio import UnsafeFile, check_owned_dir
from .along_track import fig_contact_force, fig_sleeper_energy
from .data import FIGURES, FORMATS, _usage, load_run, pct, read_history
from .design import fig_best_vs_reference, fig_conditions, fig_track_layout
from .robust import fig_spread, run_spreads, spread_keys
from .search import fig_objective_space, fig_search_history
from .sensitivity import fig_sensitivity, sensitivity_of
from .settlement import (
    CHECK_FILE,
    Design,
    fig_settlement_history,
    fig_settlement_profile,
    has_settlement,
    law_check,
    limit_of,
)
from .summary import build_summary, history_facts

__all__ = ["write_report"]


REPORT_FILES = ("report.md", "report.html", "summary.json", CHECK_FILE)


def write_report(run: Path, format: str = "both", out: Path | None = None,
                 force: bool = False) -> Path:
    """Write figures and the summary of run directory RUN into OUT (default RUN/report/);
    return that directory. A folder of the user's (``out``) that already holds a report's
    files is refused unless ``force``: a report replaces its own files only."""
    import time

    t0 = time.perf_counter()
    fmt_ = str(format).lower()
    if fmt_ not in FORMATS:
        raise _usage(f"--format must be one of {', '.join(FORMATS)}, got {format!r}")
    data = load_run(Path(run))
    import typer

    for warning in data.warnings:
        typer.echo(f"lccopt: warning: {printable(warning)}", err=True)
    own = data.path / "report"
    theirs = out is not None and Path(out).absolute() != own.absolute()
    out = Path(out) if theirs else own
    if not theirs and os.path.lexists(own):
        try:
            check_owned_dir(own)   # a link planted as RUN/report is never written through
        except UnsafeFile as exc:
            raise _usage(str(exc)) from None
    if out.exists() and not out.is_dir():
        raise _usage(f"--out {out} is a file, not a folder")
    if theirs and not force:
        names = (*REPORT_FILES, *(f"{f}.png" for f in FIGURES))
        taken = [n for n in names if os.path.lexists(out / n)]
        if taken:
            raise _usage(f"{out} already holds {taken[0]}{' and more' if len(taken) > 1 else ''}: "
                         f"choose another --out, or add --force to replace them")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _usage(f"cannot create {out}: {exc.strerror or exc}") from None
    if not theirs:
        # figures of an earlier report that this one may not redraw; only ever inside the run
        # directory: a user's --out folder is written to, never cleaned
        for name in FIGURES:
            p = out / f"{name}.png"
            if os.path.lexists(p):
                p.unlink()

    figs: dict[str, Path] = {}
    notes: dict[str, str] = {}
    figs["search-history"] = fig_search_history(data, out)
    p, note = fig_objective_space(data, out)
    figs["objective-space"] = p
    if note:
        notes["objective-space"] = note
    bi, ri = data.best_index(), data.ref_index()
    if bi is not None:
        figs["best-vs-reference"] = fig_best_vs_reference(data, bi, ri, out)
        p = fig_conditions(data, bi, ri, out)
        if p is not None:
            figs["conditions"] = p
        # with traffic conditions, each figure shows the condition that sets its objective's
        # worst case for the best design (the histories of one simulation)
        shown = {"contact-force": data.setting_condition("F_max", bi),
                 "sleeper-energy": data.setting_condition("E_max", bi), "track-layout": None}
        histories = {}
        for key, fn in (("contact-force", fig_contact_force),
                        ("sleeper-energy", fig_sleeper_energy),
                        ("track-layout", fig_track_layout)):
            c = shown[key]
            if c not in histories:
                hb, ib, nb = read_history(data, bi, c)
                hr, ir, nr = read_history(data, ri, c) if ri is not None else (
                    None, {}, "the reference design was not evaluated successfully")
                why = "; ".join(n for n in (nb and f"best: {nb}", nr and f"reference: {nr}") if n)
                histories[c] = ((hb, ib), (hr, ir), why)
            best, ref, why = histories[c]
            p = fn(data, best, ref, bi, out, condition=c)
            if p is not None:
                figs[key] = p
                if why and key != "track-layout":
                    notes[key] = why
            else:
                notes[key] = why or ("the evaluation files hold no such histories "
                                     "(e.g. a test evaluator)")
        best, ref, _ = histories[shown["sleeper-energy"]]
        facts = history_facts(best, ref, shown["sleeper-energy"])
        settlement = _settlement_figures(data, histories[None] if None in histories else None,
                                         bi, out, figs)
    else:
        facts, settlement = [], None
    robust = run_spreads(data, bi, ri) if bi is not None else None
    if robust:
        figs["robust-spread"] = fig_spread(robust, spread_keys(data), out,
                                           f"'{data.name}' on {data.realisations} realisations "
                                           f"of the track")
    indices = sensitivity_of(data)
    p = fig_sensitivity(data, out, indices)
    if p is not None:
        figs["sensitivity"] = p
    else:
        notes["sensitivity"] = ("too few successful evaluations to fit a surrogate for the "
                                "sensitivity indices")

    doc, summary = build_summary(data, figs, notes, facts, indices, settlement, robust)
    wrote = []
    if fmt_ in ("md", "both"):
        atomic_write_text(out / "report.md", doc.markdown())
        wrote.append(out / "report.md")
    if fmt_ in ("html", "both"):
        atomic_write_text(out / "report.html", doc.html(f"lccopt report: {data.name}"))
        wrote.append(out / "report.html")
    summary["seconds"] = round(time.perf_counter() - t0, 2)
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2, allow_nan=True) + "\n")

    # printable: the name and objectives come from the run's files, which anyone may edit
    typer.echo(f"report of '{printable(data.name)}' ({data.n}/{data.budget} evaluations, "
               f"{data.state})")
    if "best" in summary:  # a line of its own: one line would wrap on an 80-column terminal
        typer.echo(f"  best #{summary['best']['id']}: " + ", ".join(
            f"{printable(k)} "
            f"{pct(summary['best']['objectives'][k], data.ref_objectives.get(k, math.nan))}"
            for k in data.objectives))
        from ..terminal import wrap_items

        on = [f"{k} ({side})" for k, side in summary["on_bound"].items()]
        worse = [f"{k} {pct(summary['best']['objectives'][k], data.ref_objectives[k])}"
                 for k in summary["worse"]]
        for head, items in (("  on a bound: ", on), ("  worse than the reference: ", worse)):
            if items:
                typer.echo("\n".join(wrap_items(items, head)))
    typer.echo(f"  {len(figs)} figures and {', '.join(p.name for p in wrote)} in {out} "
               f"({summary['seconds']:.1f} s)")
    return out


def _settlement_figures(data, histories, bi: int, out: Path, figs: dict):
    """The settlement figures of a run whose evaluations predicted settlement (best and
    reference design); (designs, limit) for the summary, or None."""
    if histories is None:
        return None
    (hb, ib), (hr, ir), _ = histories
    designs = []
    from .data import BEST_COLOR, REF_COLOR

    if has_settlement(hr):
        designs.append(Design("reference", hr, ir, REF_COLOR, "--"))
    if has_settlement(hb):
        designs.append(Design(f"best #{data.ids[bi]}", hb, ib, BEST_COLOR, "-"))
    if not designs:
        return None
    limit = limit_of(designs[-1].info)
    title = (f"Settlement of '{data.name}' under its traffic (the law's values, not a "
             f"forecast)")
    figs["settlement-history"] = fig_settlement_history(designs, out, title, limit)
    figs["settlement-profile"] = fig_settlement_profile(designs, out, title)
    return designs, limit, law_check(data, bi, data.ref_index(), out)

