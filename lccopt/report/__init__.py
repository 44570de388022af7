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
or killed run), or results.h5 is not this run's (its identity does not match the journal's
lines), the evaluation table is rebuilt from the journal instead. Only the evaluation files of
the best and the reference design are read; missing ones (failed evaluations, files of a fake
evaluator without histories) leave a note instead of a figure.

Written whole or not at all (``lccopt.outdir``): every file is drawn into a staging folder, and
only a complete report is moved into place; RUN/report/ is replaced whole (an old report's
files never stay beside a new one's), a user's --out folder gets the report's files, one
report at a time per folder.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..errors import printable
from ..outdir import Output
from ..terminal import echo
from .along_track import fig_contact_force, fig_sleeper_energy
from .comparison import history_facts
from .data import FIGURES, FORMATS, RunData, _usage, load_run, read_history
from .design import fig_best_vs_reference, fig_conditions, fig_track_layout
from .law_variants import CHECK_FILE, law_check
from .robust import fig_spread, run_spreads, spread_keys
from .search import fig_objective_space, fig_search_history
from .sensitivity import fig_sensitivity, sensitivity_of
from .settlement import (
    Design,
    fig_settlement_history,
    fig_settlement_profile,
    has_settlement,
    limit_of,
)
from .summary import build_summary

__all__ = ["Report", "write_report"]

Echo = Callable[..., None]   # echo(text, err=False): how the report says something


REPORT_FILES = ("report.md", "report.html", "summary.json", CHECK_FILE)


@dataclass(frozen=True)
class Report:
    """What :func:`write_report` wrote: the report's folder (as the user named it), the run it
    reports on (its name, evaluations, state, objectives), the summary's key numbers, the
    figures and the summary files."""

    path: Path
    run: RunData
    summary: dict
    figures: dict
    files: list


def write_report(run: Path, format: str = "both", out: Path | None = None,
                 force: bool = False, *, echo: Echo = echo) -> Report:
    """Write figures and the summary of run directory RUN into OUT (default RUN/report/);
    return what was written. A folder of the user's (``out``) that already holds a report's
    files is refused unless ``force``: a report replaces its own files only. ``echo(text,
    err=False)`` says the run's warnings and the progress of a long step (on standard error,
    ``err=True``)."""
    import time

    t0 = time.perf_counter()
    fmt_ = str(format).lower()
    if fmt_ not in FORMATS:
        raise _usage(f"--format must be one of {', '.join(FORMATS)}, got {format!r}")
    data = load_run(Path(run))
    try:
        with _output(data, out, force, echo) as output:
            summary, figs, wrote = _draw(data, fmt_, output.root, t0, echo)
    finally:
        data.rd.close()
    return Report(output.shown, data, summary, figs, wrote)


def _output(data, out: Path | None, force: bool, echo: Echo) -> Output:
    """Where the report goes: RUN/report (lccopt's own, replaced whole), or a folder of the
    user's (``out``), whose report files are refused unless ``force``."""
    for warning in data.warnings:
        echo(f"lccopt: warning: {printable(warning)}", err=True)
    own = data.path / "report"
    if out is None or Path(out).absolute() == own.absolute():
        return Output.own(data.rd.folder, "report", own, "report")
    names = (*REPORT_FILES, *(f"{f}.png" for f in FIGURES))
    return Output.into(Path(out), names, (), force, "report")


def _draw(data, fmt_: str, out, t0: float, echo: Echo):
    """Every figure and the summary of ``data`` into ``out`` (a staged folder); return
    (summary, figures, summary files)."""
    import time

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
                                         bi, out, figs, echo)
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
        wrote.append((out / "report.md").write_bytes(doc.markdown().encode("utf-8")))
    if fmt_ in ("html", "both"):
        wrote.append((out / "report.html").write_bytes(
            doc.html(f"lccopt report: {data.name}").encode("utf-8")))
    summary["seconds"] = round(time.perf_counter() - t0, 2)
    (out / "summary.json").write_bytes(
        (json.dumps(summary, indent=2, allow_nan=True) + "\n").encode("utf-8"))
    return summary, figs, wrote


def _settlement_figures(data, histories, bi: int, out: Path, figs: dict, echo: Echo):
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
    return designs, limit, law_check(data, bi, data.ref_index(), out, echo)

