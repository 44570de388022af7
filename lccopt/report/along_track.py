"""Figures along the track: the contact force under the wheel and the energy dissipated under
each sleeper, the best design against the reference design (the paper's Fig. 11)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .data import BEST_COLOR, REF_COLOR, RunData, fnum
from .plotting import (
    from_slab_edge,
    pyplot,
    range_bracket,
    save_figure,
    sleeper_ticks,
    speed_text,
    wheel_position_label,
    zone_marks,
)


def fig_contact_force(run: RunData, best: tuple, ref: tuple, bi: int, out: Path,
                      condition: str | None = None) -> Path | None:
    """Contact force along the track for the best and the reference design (under traffic
    ``condition``, the one that sets the worst F_max), with the force zone, the sleepers of each
    design, and F_max drawn as the max - min range it is."""
    (hb, ib), (hr, ir) = best, ref
    have = [(h, i) for h, i in (best, ref)
            if h is not None and "wheel_position" in h and "contact_force" in h]
    if not have:
        return None
    plt = pyplot()
    origin, info = from_slab_edge(ib if hb is not None and "wheel_position" in hb else ir)
    fig, ax = plt.subplots(figsize=(9, 5.0))
    xmax = max(float(np.max(h["wheel_position"])) for h, _ in have) - origin
    zone_marks(ax, info, xmax)
    x0 = min(float(np.min(h["wheel_position"])) for h, _ in have) - origin
    if "zone_start" in info:  # the run-in from static equilibrium is not of interest
        x0 = max(x0, float(info["zone_start"]) - 2.0)
    zone = (info.get("zone_start", x0), info.get("zone_end", xmax))
    first = condition
    f_max_of = run.cond_obj[first]["F_max"] if first else run.obj["F_max"]
    ri = run.ref_index()
    curves = []
    if hr is not None and "contact_force" in hr and "wheel_position" in hr:
        f_ref = (f_max_of[ri] if first and ri is not None
                 else run.ref_objectives.get("F_max", math.nan))
        curves.append((hr, REF_COLOR, "reference design", f_ref, 0))
    if hb is not None and "contact_force" in hb and "wheel_position" in hb:
        curves.append((hb, BEST_COLOR, f"best #{run.ids[bi]}", f_max_of[bi], 1))
    for h, color, lab, fmax, row in curves:
        xw, f = h["wheel_position"] - origin, h["contact_force"] / 1e3
        ax.plot(xw, f, color=color, lw=1.1,
                label=f"{lab}: F_max = {fnum(fmax / 1e3, 4)} kN (max - min in the zone)")
        in_zone = (xw >= zone[0]) & (xw <= zone[1])
        fw = h.get("contact_force_wheels")
        if fw is not None and fw.ndim == 2 and fw.shape[1] > 1 and "in_force_zone_wheels" in h:
            inw = np.asarray(h["in_force_zone_wheels"]).astype(bool)   # F_max is over all wheels
            lo, hi = float(fw[inw].min()) / 1e3, float(fw[inw].max()) / 1e3
            ax.hlines([lo, hi], zone[0], zone[1], color=color, lw=0.7, ls="--", zorder=2)
            range_bracket(ax, row, lo, hi, color, "F_max")
        elif in_zone.any():
            lo, hi = float(f[in_zone].min()), float(f[in_zone].max())
            ax.hlines([lo, hi], zone[0], zone[1], color=color, lw=0.7, ls="--", zorder=2)
            range_bracket(ax, row, lo, hi, color, "F_max")
        positions = h.get("sleeper_position", h.get("entry_sleeper_position"))
        if positions is not None:
            positions = np.asarray(positions, float) - origin
            sleeper_ticks(ax, positions[(positions >= x0) & (positions <= xmax)], color, row,
                          f"sleepers of the {lab.split(':')[0]}")
    if "static_wheel_load" in info:
        ax.axhline(info["static_wheel_load"] / 1e3, color="k", ls=":", lw=0.8,
                   label="static wheel load")
    if "interface_entry" in info:
        ax.text(info["interface_entry"], 0.98, " interface",
                transform=ax.get_xaxis_transform(), va="top",
                ha="left", fontsize=8)
    speed = speed_text(info, run.case)
    ax.set(xlabel=wheel_position_label(info),
           ylabel="wheel-rail contact force [kN]",
           title="Contact "
                 "force: best against reference design" + (f", vehicle at {speed}" if speed else "")
                 + (f"\ncondition {first}, the best design's worst F_max (leading wheel; every "
                    f"condition: conditions.png)" if first else ""))
    ax.set_xlim(x0, xmax)
    shown = [h["contact_force"][h["wheel_position"] - origin >= x0] / 1e3 for h, _ in have]
    lo, hi = min(float(v.min()) for v in shown), max(float(v.max()) for v in shown)
    ax.set_ylim(lo - 0.15 * (hi - lo or 1), hi + 0.15 * (hi - lo or 1))
    fig.legend(*ax.get_legend_handles_labels(), loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0, 0.2, 0.95, 1))
    return save_figure(fig, out / "contact-force.png")


def fig_sleeper_energy(run: RunData, best: tuple, ref: tuple, bi: int, out: Path,
                       condition: str | None = None) -> Path | None:
    """Energy per zone sleeper (profile, as the paper's Fig. 11); E_max = max - min shown as a
    band."""
    (hb, _), (hr, _) = best, ref
    eb = None if hb is None else hb.get("sleeper_energy")
    er = None if hr is None else hr.get("sleeper_energy")
    if eb is None and er is None:
        return None
    plt = pyplot()
    from matplotlib.lines import Line2D

    n = max(len(e) for e in (eb, er) if e is not None)
    fig, ax = plt.subplots(figsize=(9, 4.6))
    handles = []
    for e, h, color, marker, lab, row in ((er, hr, REF_COLOR, "D", "reference design", 0),
                                          (eb, hb, BEST_COLOR, "o", f"best #{run.ids[bi]}", 1)):
        if e is None:
            continue
        e = np.asarray(e, float)
        idx = np.arange(1, len(e) + 1)
        st = np.asarray(h.get("sleeper_strengthened", np.zeros(len(e))), dtype=bool)[:len(e)]
        # E_max as the max - min range it is: dashed bounds and a bracket in the design's colour
        # (two translucent bands on top of each other could not be told apart)
        ax.hlines([e.min(), e.max()], 0.5, n + 0.5, color=color, lw=0.8, ls="--", zorder=2)
        range_bracket(ax, row, float(e.min()), float(e.max()), color, "E_max")
        ax.plot(idx, e, color=color, lw=1.4, zorder=3)
        ax.scatter(idx[~st], e[~st], marker=marker, s=30, facecolor="white", edgecolor=color,
                   lw=1.3, zorder=4)
        ax.scatter(idx[st], e[st], marker=marker, s=30, facecolor=color, edgecolor=color,
                   lw=1.3, zorder=4)
        handles.append(Line2D([], [], color=color, marker=marker, markerfacecolor=color,
                              label=f"{lab}: E_max = {fnum(float(e.max() - e.min()), 4)} J (max - "
                                    "min, dashed), "
                                    f"E_rms = {fnum(float(np.sqrt(np.mean(e ** 2))), 4)} J"))
    handles += [Line2D([], [], ls="", marker="o", color="0.3",
                       label="strengthened sleeper (filled)"),
                Line2D([], [], ls="", marker="o", markerfacecolor="white", color="0.3",
                       label="standard sleeper (open)")]
    ax.set(xlabel="sleeper number (1 = next to the interface)",
           ylabel="energy dissipated in the support [J]",
           title="Energy dissipated under each sleeper of the evaluation zone (cf. paper Fig. 11)"
                 + (f"\ncondition {condition}, the best design's worst E_max (every condition: "
                    f"conditions.png)" if condition else ""),
           xlim=(0.5, n + 0.5))
    ax.set_xticks(np.arange(1, n + 1))
    fig.legend(handles=handles, loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0, 0.12, 0.95, 1))
    return save_figure(fig, out / "sleeper-energy.png")
