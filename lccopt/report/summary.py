"""The report's summary: Markdown and self-contained HTML, and summary.json's numbers."""

from __future__ import annotations

import datetime as _dt
import math

import numpy as np

from ..config.describe import pad_facts
from ..vti.response import objective_display, objective_doc, objective_unit
from .comparison import (
    bound_sides,
    bounds_text,
    drawn_only,
    kind_text,
    why_text,
    worse_objectives,
    worse_text,
)
from .data import (
    PHASE_STYLE,
    ZONE_COLOR,
    RunData,
    colour_name,
    fnum,
    improvement_sign,
    obj_display,
    objective_change,
    pct,
    var_value,
)
from .document import Doc
from .evaluations import OBJECTIVE_NAMES


def _table_unit(k: str) -> tuple[float, str]:
    """(scale, unit) of objective k in the report's tables: SI, but lengths in mm."""
    return (1e3, "mm") if objective_unit(k) == "m" else (1.0, objective_unit(k))


def build_summary(run: RunData, figs: dict, notes: dict, facts: list[str] | None = None,
                  indices: dict | None = None, settlement=None,
                  robust=None) -> tuple[Doc, dict]:
    """The summary document and summary.json's numbers; ``settlement``: (designs, limit) of a
    run that predicted settlement (``lccopt.report.settlement``); ``robust``: the designs
    compared over the realisations of the track (``lccopt.report.robust``)."""
    doc = Doc()
    bi, ri = run.best_index(), run.ref_index()
    n_failed = int((run.status == "failed").sum())
    restarts = sorted(int(r) for r in np.unique(run.restart) if r > 0)
    _introduction(doc, run, n_failed, restarts)
    _searched_section(doc, run)
    _history_section(doc, run, bi, n_failed, restarts, figs)

    summary = {"run": str(run.path), "name": run.name, "state": run.state, "evaluations": run.n,
               "budget": run.budget, "failed": n_failed, "restarts": len(restarts),
               "objectives": run.objectives,
               "source": run.source, "figures": {k: p.name for k, p in figs.items()},
               "notes": dict(notes)}
    if bi is None:
        doc.h(2, "Best design")
        doc.p("No evaluation has succeeded yet: there is no best design.")
        return doc, summary

    sides = _best_section(doc, run, bi, ri, figs)

    if run.conditions and ri is not None:
        _conditions_section(doc, run, bi, ri, figs)
    if settlement is not None:
        _settlement_section(doc, run, *settlement, figs)
        if len(settlement) > 2 and settlement[2] is not None:
            check = settlement[2]
            summary["law_check"] = {k: check[k] for k in ("keys", "n", "beats", "per_key",
                                                          "within_uncertainty")}
    if robust:
        from .robust import robust_section

        summary["realisations"] = robust_section(doc, run, robust, figs)

    worse = _why_section(doc, run, bi, ri, figs, notes, facts)
    _space_and_sensitivity_sections(doc, run, figs, notes, indices, summary)
    _files_section(doc, run, bi, ri)

    summary["best"] = {"id": int(run.ids[bi]), "value": float(run.value[bi]),
                       "x": {n: float(v) for n, v in zip(run.names, run.x[bi])},
                       "objectives": {k: float(run.obj[k][bi]) for k in run.obj},
                       "phase": str(run.phase[bi]), "restart": int(run.restart[bi])}
    summary["reference"] = {"id": int(run.ids[ri]) if ri is not None else None,
                            "x": {n: float(v) for n, v in zip(run.names, run.ref_x)},
                            "objectives": {k: float(v) for k, v in run.ref_objectives.items()}}
    summary["on_bound"] = {v.name: side for v, side in zip(run.variables, sides) if side}
    summary["worse"] = [k for k, _, _ in worse]
    summary["change_percent"] = {k: (float(run.obj[k][bi]) - r) / abs(r) * 100
                                 for k, r in run.ref_objectives.items() if k in run.obj and r}
    return doc, summary


def _introduction(doc: Doc, run: RunData, n_failed: int, restarts: list) -> None:
    """The title and the run's state."""
    state = {"finished": "finished",
             "running": f"still running ({run.n_pending} evaluation(s) in flight when this was "
                        "read)",
             "interrupted": f"interrupted (carry on with `lccopt resume {run.path}`)"}[run.state]
    doc.h(1, f"Run '{run.name}'")
    doc.p(f"**{run.n} of {run.budget} evaluations**, {n_failed} failed, {len(restarts)} "
          f"restart(s); the run is {state}. Read from `{run.source}` on "
          f"{_dt.datetime.now().astimezone().isoformat(timespec='seconds')}.")
    for note in run.notes:
        doc.p(f"Note: {note}")


def _searched_section(doc: Doc, run: RunData) -> None:
    """What was searched: the objectives, the variables and their bounds, the pads."""
    doc.h(2, "What was searched")
    if run.multi:
        def shown(k, v):
            scale, unit = _table_unit(k)
            return f"{k} = {fnum(v * scale)}" + (f" {unit}" if unit != "-" else "")

        pt = ", ".join(shown(k, v) for k, v in zip(run.objectives, run.ref_point)) \
            if run.ref_point is not None else "not set yet"
        wst = ", ".join(shown(k, v) for k, v in zip(run.objectives, run.worst)) \
            if run.worst is not None else "–"
        doc.p("Minimise "
              f"{', '.join(f'**{k}** ({objective_doc(k)})' for k in run.objectives)} "
              "together, scalarised by the augmented Chebyshev achievement function (paper Eq. 7, "
              f"ρ = {run.rho:g}). Reference point f^r ({run.improvement:.0%} better than the "
              f"reference design): {pt}; worst values (a scale, each objective weighed by "
              f"1/(worst - f^r), not a bound a design can reach): {wst}. The value is 0 on the "
              "reference point and negative beyond it.")
    else:
        k = run.objectives[0]
        doc.p(f"Minimise **{k}**: {objective_doc(k)} [{_table_unit(k)[1]}].")
    rows = []
    for v in run.variables:
        rng = f"{var_value(v, v.lower)} … {var_value(v, v.upper)}" if np.isfinite(v.lower) else "–"
        rows.append([f"`{v.name}`", v.label, v.unit or "–", rng, kind_text(v),
                     var_value(v, v.reference)])
    doc.table(["variable", "meaning", "unit", "bounds", "kind", "reference design"], rows, "llllll")
    if run.case is not None:
        doc.p("Pads, as entered and as simulated (under the wheel; docs/model.md, 'Pads as "
              "bought'):")
        doc.ul([fact[0].upper() + fact[1:] for fact in pad_facts(run.case)])
    if run.case is None and run.case_note:
        doc.p(f"Note: the run's case could not be loaded ({run.case_note}); bounds are not shown.")


def _history_section(doc: Doc, run: RunData, bi, n_failed: int, restarts: list,
                     figs: dict) -> None:
    """How the search went: phases, the best value, restarts, failures, wall time."""
    doc.h(2, "How the search went")
    if "search-history" in figs:
        doc.fig(figs["search-history"],
                "Value of every evaluation by number, by phase; failed evaluations as red crosses "
                "at the bottom; the green line is the best value so far; dashed lines mark "
                "restarts (paper Figs. 6, 7, 10).")
    phase_counts = {ph: int((run.phase == ph).sum()) for ph in PHASE_STYLE
                    if (run.phase == ph).any()}
    items = ["evaluations "
             "by phase: " + ", ".join(f"{PHASE_STYLE[p][0]} {c}" for p, c in phase_counts.items())]
    if bi is not None:
        items.append(f"best value {fnum(run.value[bi])} at evaluation #{run.ids[bi]} "
                     f"({run.phase[bi]}, restart {run.restart[bi]}); the best value was within 1 % "
                     f"of it from evaluation #{_first_near_best(run)} on")
    if restarts:
        starts = [int(run.ids[run.restart == r].min()) for r in restarts]
        items.append("restarts (fresh initial design after the step size collapsed or evaluations "
                     "kept failing) at "
                     + ", ".join(f"#{s}" for s in starts))
    if n_failed:
        reasons: dict = {}
        for r in run.reason[run.status == "failed"]:
            reasons[r or "no reason given"] = reasons.get(r or "no reason given", 0) + 1
        fids = [f"#{i}" for i in run.ids[run.status == "failed"]]
        items.append(f"{n_failed} failed evaluation(s) "
                     f"({', '.join(fids[:12])}{' …' if len(fids) > 12 else ''}): "
                     + "; ".join(
            f"{c}× {r}" for r, c in sorted(reasons.items(), key=lambda t: -t[1])[:5]))
    wt = run.wall_time[np.isfinite(run.wall_time)]
    if len(wt):
        items.append(f"simulation wall time per evaluation: median {np.median(wt):.2f} s, max "
                     f"{wt.max():.2f} s"
                     + ("; run sessions "
                        f"took {run.sessions_wall / 60:.1f} min" if np.isfinite(run.sessions_wall)
                        else ""))
    doc.ul(items)


def _best_section(doc: Doc, run: RunData, bi: int, ri, figs: dict) -> list[str]:
    """The best design against the reference design; returns which bound each variable
    sits on."""
    doc.h(2, "Best design against the reference design")
    lab = "chosen compromise (lowest ASF value)" if run.multi else f"lowest {run.objectives[0]}"
    longer = [k for k in run.obj if improvement_sign(k) < 0]
    doc.p(f"The best design is evaluation **#{run.ids[bi]}**, the {lab}. Changes are relative to "
          "the reference design (evaluation #0); negative is better for every objective (paper "
          "Tables 5-7)"
          + (f" but {', '.join(longer)}, a life (longer is better)." if longer else "."))
    rows = []
    sides = bound_sides(run, bi)
    for j, v in enumerate(run.variables):
        xr, xb = run.ref_x[j], run.x[bi, j]
        on = f" ({sides[j]} bound)" if sides[j] else ""
        rows.append([f"`{v.name}`", v.label, v.unit or "–", var_value(v, xr),
                     var_value(v, xb) + on,
                     pct(xb, xr) if not v.integer else
                     (f"{(xb - xr) * v.scale:+.3g}" if xb != xr else "0")])
    doc.table(["variable", "meaning", "unit", "reference", f"best #{run.ids[bi]}", "change"],
              rows, "lllrrr")
    rows = []
    for k in run.obj:
        r = run.ref_objectives.get(k, run.obj[k][ri] if ri is not None else math.nan)
        b = float(run.obj[k][bi])
        if k not in OBJECTIVE_NAMES and not (np.isfinite(b) or np.isfinite(r)):
            continue
        s_, unit = _table_unit(k)
        tgt = ""
        if run.multi and run.ref_point is not None and k in run.objectives:
            t = run.ref_point[run.objectives.index(k)]
            tgt = f"{fnum(t * s_)} ({'reached' if b <= t else 'not reached'})"
        name = (f"**{k}**" if k in run.objectives
                else k + (" (as drawn)" if drawn_only(run, k) else ""))
        rows.append([name, unit, fnum(r * s_),
                     fnum(b * s_), objective_change(k, b, r)] + ([tgt] if run.multi else []))
    doc.table(["objective", "unit", "reference", f"best #{run.ids[bi]}", "change"]
              + (["target f^r"] if run.multi else []), rows)
    doc.p(f"Value minimised: reference {fnum(run.value[ri]) if ri is not None else '–'}, best "
          f"{fnum(run.value[bi])}.")
    bounds = bounds_text(run, bi, sides)
    if bounds:
        doc.p(bounds)
    if "best-vs-reference" in figs:
        doc.fig(figs["best-vs-reference"],
                "Change of every objective (left) and where the design variables sit "
                "within their bounds (right), best against reference.")
    return sides


def _why_section(doc: Doc, run: RunData, bi: int, ri, figs: dict, notes: dict,
                 facts) -> list:
    """Why it is better, with the histories' figures; returns the objectives it worsens."""
    doc.h(2, "Why it is better")
    doc.p(why_text(run, bi, ri, notes))
    worse = worse_objectives(run, bi)
    doc.p(worse_text(run, worse))
    for fact in facts or []:
        doc.p(fact)
    for key, cap in (("contact-force",
                      "Wheel-rail contact force against wheel position, best and reference design; "
                      f"grey: ERS, {colour_name(ZONE_COLOR)} strip: evaluation zone of the force "
                      "objectives; along the track from the entry slab edge."),
                     ("sleeper-energy",
                      "Energy dissipated in the ballast/subgrade under each sleeper of the "
                      "evaluation zone, sleeper 1 next to the interface (paper Fig. 11)."),
                     ("track-layout",
                      "The designed track next to the interface: sleepers (standard or "
                      "strengthened), railpad stiffness by colour, spans next to the slab, the "
                      "Type II strip and the slab edge; reference above, best below.")):
        if key in figs:
            doc.fig(figs[key], cap)
            if key in notes:  # drawn from what was there (e.g. the reference only)
                doc.p(f"Note: {notes[key]}.")
        elif key in notes:
            doc.p(f"No {key.replace('-', ' ')} figure: {notes[key]}.")
    return worse


def _space_and_sensitivity_sections(doc: Doc, run: RunData, figs: dict, notes: dict,
                                    indices, summary: dict) -> None:
    """The objective space and the sensitivity indices (into summary.json too)."""
    doc.h(2, "Objective space")
    if "objective-space" in figs:
        doc.fig(figs["objective-space"],
                "All evaluations in objective space with the Pareto front, the reference "
                "design, the reference point and the chosen compromise (paper Fig. 9).")
    if notes.get("objective-space"):
        doc.p(notes["objective-space"])
    doc.h(2, "Sensitivity")
    for k, ind in (indices or {}).items():
        order = np.argsort(-ind.total)[:3]
        top = ", ".join(f"{run.variables[j].name} ({ind.total[j]:.2f})" for j in order)
        doc.p(f"{k} is moved most by {top} (total-effect indices of a surrogate of {ind.n_points} "
              f"evaluations; its leave-one-out error is {ind.loo_error:.0%} of the values' spread"
              + (": a rough guide only)." if not ind.loo_error < 0.3 else ")."))
        summary.setdefault("sensitivity", {})[k] = {
            "total": dict(zip(run.names, map(float, ind.total))),
            "first": dict(zip(run.names, map(float, ind.first))), "loo_error": ind.loo_error}
    if "sensitivity" in figs:
        doc.fig(figs["sensitivity"],
                "Variance-based (Sobol') indices of each objective over the whole design space: "
                "the share of its variance a variable explains alone (first order) and with its "
                "interactions (total effect), from a cubic RBF fitted to the run's evaluations.")
    elif notes.get("sensitivity"):
        doc.p(f"No sensitivity figure: {notes['sensitivity']}.")


def _files_section(doc: Doc, run: RunData, bi: int, ri) -> None:
    doc.h(2, "Files")
    doc.ul([f"results table: `{run.path / 'results.h5'}`; commit log: "
            f"`{run.path / 'journal.jsonl'}`",
            f"histories of the best design: `{run.path / run.file[bi]}`" if run.file[bi] else
            "the best design has no histories file",
            "histories of "
            f"the reference design: `{run.path / run.file[ri]}`" if ri is not None and run.file[ri]
            else "the reference design has no histories file"])


def _first_near_best(run: RunData) -> int:
    ok = run.ok & np.isfinite(run.value)
    order = np.argsort(run.ids)
    v = np.where(ok, run.value, np.inf)[order]
    bsf = np.minimum.accumulate(v)
    b = bsf[-1]
    tol = 0.01 * abs(b) if b != 0 else 1e-12
    return int(run.ids[order][np.flatnonzero(bsf <= b + tol)[0]])


def _conditions_section(doc: Doc, run: RunData, bi: int, ri: int, figs: dict) -> None:
    """Every traffic condition's objectives, reference design against the best design."""
    how = {"worst": "the worst case over the conditions", "mean": "their weighted mean",
           "each": "each condition's objectives as objectives of their own"}
    mode = run.case.condition_mode if run.case is not None else "worst"
    doc.h(2, "Traffic conditions")
    doc.p(f"Each design was simulated under {len(run.conditions)} conditions; the run minimised "
          f"{how[mode]}.")
    about = {c.name: c for c in (run.case.conditions if run.case is not None else ())}
    rows = []
    for c in run.conditions:
        a = about.get(c)
        row = [c, a.vehicle if a else "–", f"{a.speed * 3.6:.0f}" if a else "–",
               a.direction if a else "–",
               f"{a.weight:g}" if a else "–"]
        for k in ("F_max", "E_max"):
            r, b = float(run.cond_obj[c][k][ri]), float(run.cond_obj[c][k][bi])
            s_, _ = obj_display(k)
            row.append(f"{fnum(r * s_, 3)} → {fnum(b * s_, 3)} ({pct(b, r)})")
        rows.append(row)
    doc.table(["condition", "vehicle", "km/h", "direction", "weight", "F_max "
                                                                      "[kN]", "E_max [J]"], rows,
              "lrrlrrr")
    if "conditions" in figs:
        doc.fig(figs["conditions"],
                "Each condition's objectives, reference design against the best design; "
                "dashed: the combined value.")


def _settlement_section(doc: Doc, run: RunData, designs: list, limit, check, figs: dict) -> None:
    """What the settlement prediction assumed, what its objectives mean, what it shows, and
    whether the ranking holds under the law's uncertainty (``check``, or None)."""
    from .law_variants import check_sentences
    from .settlement import facts, meaning_items

    doc.h(2, "Settlement over the horizon")
    info = designs[-1].info
    horizon = info.get("settlement_horizon_years")
    deg = run.case.degradation if run.case is not None else None
    what = (f"over {horizon:g} year{'' if horizon == 1 else 's'}" if horizon
            else "over its horizon")
    if deg is not None:
        from ..config.describe import law_items, traffic_sentence

        traffic = traffic_sentence(run.case)
        what += (f" of the traffic ({traffic}), by the {deg['law']['name']} law "
                 f"({', '.join(law_items(deg['law']))}), {deg['settling_sleepers']} settling "
                 f"sleepers next to the slab")
    tamping = ""
    tamped = bool(info.get("settlement_tamping"))
    if tamped:
        tamping = (f" The track is tamped whenever the limit is reached (the "
                   f"{info.get('settlement_unreachable_sleepers', '?')} sleepers next to the "
                   f"slab out of the machine's reach are not lifted; the tamped ballast "
                   f"settles anew). Its state cycles between tampings, so each measure of "
                   f"it is its worst over the horizon, not its state at the horizon (one "
                   f"moment of the cycle: just tamped, or about to be).")
    doc.p(f"Every design's settlement was predicted {what} (docs/settlement.md): blocks of load "
          f"cycles, each sleeper's ballast settling by the law from the pressure under it at "
          f"every axle, its subgrade by its own law, the track re-simulated as it settles."
          f"{tamping} The millimetres are the law's values, not a forecast: the law is not "
          f"calibrated to a measured crossing. The objectives:")
    doc.ul(meaning_items(limit, tamped))
    for d in designs:
        doc.p(facts(d))
    captions = {
        "settlement-history": "Top: settlement of every settling sleeper against axle passes "
                              "(colour: distance from the slab; ticks: the simulated passages). "
                              "Bottom: the limit's measure (the rail's level) and the largest "
                              "void against axle passes and years, with the tampings.",
        "settlement-profile": "Top: the ballast's lowering under each sleeper (markers) and the "
                              "rail's level at rest (thin) along the approach at chosen times; "
                              "bottom: the voids under the sleepers. Solid: the best design, "
                              "dashed: the reference design.",
    }
    for key, cap in captions.items():
        if key in figs:
            doc.fig(figs[key], cap)
    if check is not None:
        doc.h(3, "Rankings and the law's uncertainty")
        for sentence in check_sentences(check):
            doc.p(sentence)
        keys = check["keys"]
        rows = []
        for r in check["variants"]:
            cells = [r["label"]]
            for k in keys:
                scale, unit = objective_display(k)
                cells.append(f"{fnum(r['best'][k] * scale, 3)} / "
                             f"{fnum(r['reference'][k] * scale, 3)} {unit}".rstrip())
            cells.append("yes" if all(r["best"][k] <= r["reference"][k] for k in keys)
                         and any(r["best"][k] < r["reference"][k] for k in keys) else "no")
            rows.append(cells)
        doc.table(["law variant", *(f"{k}: best / reference" for k in keys),
                   "best beats reference"], rows, "l" + "r" * len(keys) + "l")
