"""The best design against the reference design, in words: which bounds it sits on and why,
which objectives it makes worse, what changed and what the histories show."""

from __future__ import annotations

import math

import numpy as np

from ..uncertainty.statistics import is_statistic
from .data import (
    RunData,
    fnum,
    improvement_sign,
    obj_display,
    objective_change,
    pct,
    var_value,
)


def history_facts(best: tuple, ref: tuple, condition: str | None = None) -> list[str]:
    """Sentences on the histories of the best and the reference design (for 'Why it is better'),
    under ``condition`` (the traffic condition that sets the worst E_max), if given."""
    (hb, ib), (hr, ir) = best, ref
    out = []
    eb = None if hb is None else hb.get("sleeper_energy")
    er = None if hr is None else hr.get("sleeper_energy")
    if eb is not None and er is not None and len(eb) and len(er):
        eb, er = np.asarray(eb, float), np.asarray(er, float)
        under = (f"In condition {condition} (which sets the best design's worst E_max), u"
                 if condition else "U")
        nb, nr = int(np.argmax(eb)) + 1, int(np.argmax(er)) + 1
        if nb != nr:
            most = (f"the most loaded zone sleeper is number {nb} ({fnum(eb.max(), 4)} J) instead "
                    f"of number {nr} ({fnum(er.max(), 4)} J)")
        elif nb == 1:
            most = "sleeper 1 stays the most loaded of the zone"
        else:
            most = (f"sleeper {nb} stays the most loaded of the zone ({fnum(eb.max(), 4)} J "
                    f"instead of {fnum(er.max(), 4)} J)")
        out.append(f"{under}nder sleeper 1, next to the interface, the ballast dissipates "
                   f"{fnum(eb[0], 4)} J instead of {fnum(er[0], 4)} J ({pct(eb[0], er[0])}); "
                   f"{most}, and the spread max - min (E_max) is "
                   f"{fnum(eb.max() - eb.min(), 4)} J instead of {fnum(er.max() - er.min(), 4)} J.")
    peaks = []
    for h, i in ((hb, ib), (hr, ir)):
        if (h is None or "contact_force" not in h or "wheel_position" not in h
                or "interface_entry" not in i):
            return out
        x, f = np.asarray(h["wheel_position"]), np.asarray(h["contact_force"])
        m = (x >= i["interface_entry"] - 1.0) & (x <= i["interface_entry"] + 3.0)
        if not m.any():
            return out
        k = int(np.argmax(f[m]))
        # a maximum on the window's first or last sample is no peak: the force is still rising
        peaks.append((float(f[m][k]), float(x[m][k] - i["interface_entry"]),
                      k in (0, int(m.sum()) - 1)))
    (pb, xb, eb), (pr, xr, er) = peaks

    def where(xp: float, edge: bool) -> str:
        side = "after" if xp >= 0 else "before"
        return (f"at the window's {'end' if xp >= 0 else 'start'}, {abs(xp):.2f} m {side} the slab "
                f"edge (still rising there)" if edge else f"{abs(xp):.2f} m {side} the slab edge")

    out.append("Around the interface (1 m before to 3 m after it) the contact force is highest, "
               f"{fnum(pb / 1e3, 4)} kN, {where(xb, eb)}, against {fnum(pr / 1e3, 4)} kN "
               f"{where(xr, er)} for the reference design.")
    return out


def kind_text(v) -> str:
    """How a variable is searched, in words: a count, a length in 0.1 m steps, a continuous
    value (on a log scale)."""
    if v.integer and v.unit == "m":
        return f"in {v.scale:g} m steps"
    if v.integer:
        return "whole number"
    return "continuous" + (", log scale" if v.log else "")


# A continuous variable within this share of its range (in the optimiser's scale: log for log
# variables) of a bound counts as on it: the local search stops a hair short of a bound.
ON_BOUND = 1e-3


def bound_sides(run: RunData, bi: int) -> list[str]:
    """For each design variable of the best design: 'lower', 'upper' or '' (inside)."""
    out = []
    for j, v in enumerate(run.variables):
        x, lo, hi = float(run.x[bi, j]), v.lower, v.upper
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
            out.append("")
            continue
        if v.log and lo > 0 and x > 0:
            x, lo, hi = np.log(x), np.log(lo), np.log(hi)
        tol = 1e-9 if v.integer else ON_BOUND * (hi - lo)
        out.append("lower" if x <= lo + tol else "upper" if x >= hi - tol else "")
    return out


def fixed_limit(run: RunData, v, side: str) -> str:
    """Why a bound cannot be widened ('' if it can): a count of none, a strip over the whole
    ERS."""
    if side == "lower" and v.group in ("strengthened_sleepers", "type_ii_strip") and v.lower <= 0:
        return ("no strengthened sleeper: there cannot be fewer"
                if v.group == "strengthened_sleepers" else "no Type II strip: it cannot be shorter")
    if side == "upper" and v.group == "type_ii_strip" and run.case is not None:
        from ..config.zones import interfaces

        x_a, x_b = interfaces(run.case.data)
        if v.upper * v.scale >= x_b - x_a - 1e-9:
            return "the strip covers the whole ERS"
    return ""


def _bounds_why(group: str) -> str:
    """What the case's schema says of the values a design group may take (e.g. 'railpads are
    20-2000 MN/m'), or ''."""
    from ..config.schema import SCHEMA

    try:
        return SCHEMA.fields["design"].fields[group].fields["bounds"].why or ""
    except (AttributeError, KeyError):
        return ""


def bounds_text(run: RunData, bi: int, sides: list[str]) -> str:
    """Every variable of the best design on a bound of the search, and what to do about it:
    where the bound is the case's choice, widen it (a new run); where it is a fixed limit, say
    so."""
    on = [(v, side, float(run.x[bi, j])) for j, (v, side) in enumerate(zip(run.variables, sides))
          if side]
    if not on:
        return ("No design variable of the best design is on a bound of the search: its optimum "
                "lies inside the design space.")
    items, widen, fixed = [], {}, []
    for v, side, x in on:
        items.append(f"`{v.name}` = {var_value(v, x)}{f' {v.unit}' if v.unit else ''} "
                     f"({side} bound)")
        limit = fixed_limit(run, v, side)
        if limit:
            fixed.append(f"`{v.name}` ({limit})")
        else:
            widen.setdefault(v.group, []).append(v)
    text = (f"**On a bound:** {len(on)} of the best design's {len(run.variables)} variables sit on "
            f"a bound of the search: {', '.join(items)}.")
    if widen:
        parts = []
        for group, vs in widen.items():
            why = "; ".join(w for w in (_bounds_why(group), "with their unit, in steps of 0.1 m"
                                        if vs[0].kind.length else "") if w)
            names = ", ".join(v.name for v in vs)
            parts.append(f"`design.{group}.bounds` ({names}{f'; {why}' if why else ''})")
        text += (f" The optimum may lie beyond the bounds the case chose: if the track allows it, "
                 f"widen {' and '.join(parts)} and start a new run (another name, or "
                 f"`lccopt optimise CASE --force`).")
    if fixed:
        text += f" Fixed limits, which no case can widen: {'; '.join(fixed)}."
    return text


def worse_objectives(run: RunData, bi: int) -> list[tuple[str, float, float]]:
    """(name, reference, best) of every reported objective the best design makes worse than
    the reference design (the optimised ones and the others alike)."""
    out = []
    for k in run.obj:
        r = run.ref_objectives.get(k, math.nan)
        b = float(run.obj[k][bi])
        if not (np.isfinite(r) and np.isfinite(b)) or abs(b - r) <= UNCHANGED * abs(r):
            continue
        if (b - r) * improvement_sign(k) > 0:
            out.append((k, float(r), b))
    return out


def amount(value: float, unit: str) -> str:
    """``5.37 kN``; a dimensionless value without a trailing space."""
    return f"{fnum(value, 4)} {unit}".rstrip()


def drawn_only(run: RunData, k: str) -> bool:
    """Whether ``k`` is a plain objective of a run over realisations of the track: there it
    is the drawing's value, and its statistics (``q90(E_max)``) are what the run judged."""
    return bool(run.realisations) and not is_statistic(k)


def worse_text(run: RunData, worse: list) -> str:
    """'What got worse' as a sentence: every reported objective the best design makes worse."""
    if not worse:
        return ("Nothing got worse: every reported objective of the best design is at least as "
                "good as the reference design's.")
    parts = []
    for k, r, b in worse:
        s, u = obj_display(k)
        word = "rises" if b > r else "falls"
        drawn = " on the track as drawn" if drawn_only(run, k) else ""
        parts.append(f"{k}{drawn} {word} from {fnum(r * s, 4)} to {amount(b * s, u)} "
                     f"({objective_change(k, b, r)}"
                     + ("" if k in run.objectives else ", not an objective of this run") + ")")
    return "**What got worse:** " + "; ".join(parts) + "."


# Relative change below which an objective counts as unchanged (the last digits of a simulation
# move with the machine: docs/runs.md, reproducibility).
UNCHANGED = 5e-4



def why_text(run: RunData, bi: int, ri: int | None, notes: dict) -> str:
    parts = []
    for k in run.objectives:
        r, b = run.ref_objectives.get(k, math.nan), float(run.obj[k][bi])
        if np.isfinite(r) and r:
            s, u = obj_display(k)
            setter = run.setting_condition(k, bi)
            name = f"{k} (worst case, set by {setter})" if setter and _worst_case(run) else k
            if abs(b - r) <= UNCHANGED * abs(r):
                parts.append(f"{name} is unchanged at {amount(r * s, u)}")
            else:
                word = "falls" if b < r else "rises"
                parts.append(f"{name} {word} from {fnum(r * s, 4)} to {amount(b * s, u)} "
                             f"({objective_change(k, b, r)})")
    text = "Against the reference design, " + "; ".join(parts) + "." if parts else ""
    diffs = []
    for j, v in enumerate(run.variables):
        xr, xb = run.ref_x[j], run.x[bi, j]
        if not np.isclose(xr, xb):
            diffs.append(f"{v.label} {var_value(v, xr)} → {var_value(v, xb)}"
                         + (f" {v.unit}" if v.unit else ""))
    if diffs:
        text += " The design differs in: " + "; ".join(diffs) + "."
    else:
        text += " The best design is the reference design."
    return text.strip()


def _worst_case(run: RunData) -> bool:
    return (run.case.condition_mode if run.case is not None else "worst") == "worst"
