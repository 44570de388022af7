"""Figures of the best design: its change against the reference design (objectives and
variables), per traffic condition, and a drawing of the designed track."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .comparison import drawn_only
from .data import (
    BEST_COLOR,
    OKABE_ITO,
    REF_COLOR,
    TYPE_II_COLOR,
    RunData,
    improvement_sign,
    obj_display,
    var_value,
    with_unit,
)
from .evaluations import OBJECTIVE_NAMES
from .plotting import pyplot, save_figure


def fig_best_vs_reference(run: RunData, bi: int, ri: int | None, out: Path) -> Path:
    """Relative change of every objective (left) and the design vector (right), best against
    reference."""
    plt = pyplot()
    names = [k for k in run.obj if k in OBJECTIVE_NAMES or np.isfinite(run.obj[k][bi])]
    rows = max(len(names), len(run.names))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9.5, max(3.8, 1.4 + 0.3 * rows)),
                                 gridspec_kw={"width_ratios": [1, 1.5]})
    ch = []
    for k in names:
        r = run.ref_objectives.get(k, run.obj[k][ri] if ri is not None else math.nan)
        b = run.obj[k][bi]
        ch.append((b - r) / abs(r) * 100 if np.isfinite(b) and np.isfinite(r) and r else math.nan)
    ch = np.array(ch)
    better = [c * improvement_sign(k) < 0 for k, c in zip(names, np.nan_to_num(ch))]
    colors = [OKABE_ITO["blue"] if b else OKABE_ITO["vermillion"] for b in better]
    y = np.arange(len(names))
    a1.barh(y, np.nan_to_num(ch), color=colors)
    a1.set_yticks(y, [f"{k} (as drawn)" if drawn_only(run, k) else k for k in names])
    for t, k in zip(a1.get_yticklabels(), names):
        if k in run.objectives:
            t.set_fontweight("bold")
    a1.invert_yaxis()
    a1.axvline(0, color="k", lw=0.8)
    lim = max(5.0, float(np.nanmax(np.abs(ch))) * 1.35) if np.isfinite(ch).any() else 5.0
    a1.set_xlim(-lim, lim)
    for yi, c in zip(y, ch):
        if np.isfinite(c):
            a1.text(0, yi, f" {c:+.1f} % ", va="center",
                    ha="right" if c >= 0 else "left", fontsize=8)
    a1.set(xlabel="change vs reference design [%]",
           title="objectives\n(bold: the run's; blue: better)")
    a1.grid(axis="y", visible=False)
    # design vector, as a fraction of each variable's range
    xb, xr = run.x[bi], run.ref_x
    lo = np.array([v.lower for v in run.variables])
    hi = np.array([v.upper for v in run.variables])
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        lo, hi = np.nanmin(run.x, axis=0), np.nanmax(run.x, axis=0)
    from .sensitivity import to_unit

    # where each value sits in its range as the optimiser sees it: in ratios for log-searched pads
    log = np.array([bool(getattr(v, "log", False)) for v in run.variables], bool)
    ub, ur = to_unit(np.vstack([xb, xr]), lo, hi, log)
    yy = np.arange(len(run.names))
    a2.hlines(yy, 0, 1, color="0.85", lw=6)
    a2.scatter(ur, yy, marker="D", s=40, color=REF_COLOR, edgecolor="k", zorder=3,
               label="reference design")
    a2.scatter(ub, yy, marker="*", s=120, color=BEST_COLOR, edgecolor="k", zorder=4,
               label=f"best (#{run.ids[bi]})")
    for yi, v in enumerate(run.variables):
        a2.text(1.03, yi, f"{var_value(v, xr[yi])} → {var_value(v, xb[yi])}"
                + (f" {v.unit}" if v.unit else ""),
                va="center", fontsize=7.5, transform=a2.get_yaxis_transform())
    a2.set_yticks(yy, run.names)
    a2.invert_yaxis()
    a2.set_xlim(-0.05, 1.05)
    a2.set_xticks([0, 0.5, 1], ["lower bound", "middle", "upper bound"])
    logged = [v.name for v in run.variables if getattr(v, "log", False)]
    if len(logged) > 3:
        logged = [f"{logged[0]} to {logged[-1]}"]
    a2.set(title="design variables within their bounds" + (
        f"\n({', '.join(logged)} on a log scale, as the optimiser searches "
        f"{'it' if len(logged) == 1 and ' to ' not in logged[0] else 'them'})" if logged else ""))
    a2.grid(axis="y", visible=False)
    a2.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)
    fig.tight_layout()
    fig.subplots_adjust(right=0.8)
    return save_figure(fig, out / "best-vs-reference.png")


def fig_conditions(run: RunData, bi: int, ri: int | None, out: Path) -> Path | None:
    """Each traffic condition's objectives, best design against the reference design (one
    panel per objective; the run's combined value as a line: worst case or weighted mean)."""
    if not run.conditions or ri is None:
        return None
    plt = pyplot()
    keys = [k for k in OBJECTIVE_NAMES if all(k in run.cond_obj[c] for c in run.conditions)]
    m = len(run.conditions)
    fig, axes = plt.subplots(2, 2, figsize=(9.5, 2.2 + 0.28 * m * 2), sharey=True)
    y = np.arange(m)
    mode = (run.case.condition_mode if run.case is not None else "worst")
    for ax, k in zip(axes.ravel(), keys):
        scale, unit = obj_display(k)
        r = np.array([run.cond_obj[c][k][ri] for c in run.conditions]) * scale
        b = np.array([run.cond_obj[c][k][bi] for c in run.conditions]) * scale
        ax.barh(y - 0.2, r, height=0.38, color=REF_COLOR, label="reference design")
        ax.barh(y + 0.2, b, height=0.38, color=BEST_COLOR, label=f"best (#{run.ids[bi]})")
        for yi, (ri_, bi_) in enumerate(zip(r, b)):
            if np.isfinite(ri_) and np.isfinite(bi_) and ri_:
                ch = (bi_ - ri_) / abs(ri_) * 100
                ax.text(bi_, yi + 0.2, f" {ch:+.0f} %" if abs(ch) >= 0.5 else " ±0 %",
                        va="center", fontsize=7)
        if k in run.obj:
            for v, color in ((run.obj[k][ri] * scale, REF_COLOR),
                             (run.obj[k][bi] * scale, BEST_COLOR)):
                ax.axvline(v, color=color, lw=1.2, ls="--")
        bold = k in run.objectives or any(o.startswith(k + "@") for o in run.objectives)
        ax.set_title(with_unit(k, unit), fontweight="bold" if bold else "normal", fontsize=10)
        ax.set_xlim(0, max(np.nanmax(r), np.nanmax(b)) * 1.25)
        ax.grid(axis="y", visible=False)
    for ax in axes[:, 0]:
        ax.set_yticks(y, run.conditions)
    axes[0, 0].invert_yaxis()
    for ax in axes.ravel()[len(keys):]:
        ax.set_visible(False)
    how = {"worst": "worst case over the conditions", "mean": "weighted mean over the conditions",
           "each": "worst case (each condition's objectives are optimised)"}[mode]
    handles, labels = axes[0, 0].get_legend_handles_labels()
    handles.append(plt.Line2D([], [], color="0.3", ls="--"))
    labels.append(f"dashed: {how}")
    fig.legend(handles, labels, loc="lower center", ncol=3, frameon=False, fontsize=8)
    fig.suptitle("objectives per traffic condition (bold: the run's)", fontsize=11)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    return save_figure(fig, out / "conditions.png")


def _layout_of(run: RunData, h: dict | None, info: dict, x: np.ndarray) -> dict | None:
    """Entry-side layout of a design: from its histories, else rebuilt from the case."""
    keys = ("entry_sleeper_position", "entry_pad_stiffness", "entry_strengthened")
    if h is not None and all(k in h for k in keys) and "interface_entry" in info:
        lay = {"x": np.asarray(h["entry_sleeper_position"], float),
               "k": np.asarray(h["entry_pad_stiffness"], float),
               "strong": np.asarray(h["entry_strengthened"], bool),
               "x_a": float(info["interface_entry"]),
               "x_b": float(info.get("interface_exit", math.nan)),
               "type_ii_end": float(info.get("type_ii_end",
                                                                                               info["interface_entry"]))}
    elif run.case is not None:
        try:
            from ..vti.track import build_track

            case = run.case
            t = build_track(case.scenario(), case.track_design(np.asarray(x, float)))
        except Exception:  # noqa: BLE001
            return None
        lay = {"x": t.entry_sleeper_x, "k": t.entry_pad_stiffness,
               "strong": np.asarray(t.entry_strengthened, bool),
               "x_a": t.interface[0], "x_b": t.interface[1], "type_ii_end": t.type_ii_end}
    else:
        return None
    slabs = None
    if run.case is not None:
        slabs = list(run.case.track["ers"]["slab_lengths"])
    lay["slabs"] = slabs
    return lay


def fig_track_layout(run: RunData, best: tuple, ref: tuple, bi: int, out: Path,
                     condition: str | None = None) -> Path | None:
    lays = [("reference design", _layout_of(run, ref[0], ref[1], run.ref_x)),
            (f"best design #{run.ids[bi]}", _layout_of(run, best[0], best[1], run.x[bi]))]
    lays = [(t, l) for t, l in lays if l is not None]
    if not lays:
        return None
    plt = pyplot()
    import matplotlib.colors as mcolors
    from matplotlib.patches import Patch, Rectangle

    n_zone = None
    if run.case is not None:
        n_zone = int(run.case.evaluation["sleepers"])
    kmin = min(float(np.min(l["k"])) for _, l in lays)
    kmax = max(float(np.max(l["k"])) for _, l in lays)
    v_lo = [v for v in run.variables if v.group == "railpad_stiffness"]
    if v_lo and np.isfinite(v_lo[0].lower):
        kmin, kmax = min(kmin, v_lo[0].lower), max(kmax, v_lo[0].upper)
    if kmax > kmin:
        norm = mcolors.LogNorm(vmin=kmin / 1e6, vmax=kmax / 1e6)
    else:
        norm = mcolors.Normalize(kmin / 1e6 - 1, kmax / 1e6 + 1)
    cmap = plt.get_cmap("viridis")
    # x: distance from the entry slab edge (negative: ballast track)
    n_show = n_zone or 20
    left = -max(float(l["x_a"] - l["x"][min(n_show, len(l["x"])) - 1]) for _, l in lays) - 0.8
    ers_len = min(float(l["x_b"] - l["x_a"]) for _, l in lays if np.isfinite(l["x_b"])) if \
        any(np.isfinite(l["x_b"]) for _, l in lays) else 12.0
    right = min(ers_len, max(3.0, max(l["type_ii_end"] - l["x_a"] for _, l in lays) + 1.0))
    fig, axes = plt.subplots(len(lays), 1, figsize=(10, 1.9 * len(lays) + 1.3),
                             sharex=True, squeeze=False)
    for ax, (title, l) in zip(axes[:, 0], lays):
        xs = l["x"] - l["x_a"]
        ax.set_ylim(-1.25, 0.75)
        ax.set_xlim(left, right)
        ax.grid(False)
        ax.set_yticks([])
        for sp in ("left", "right", "top"):
            ax.spines[sp].set_visible(False)
        # slab(s)
        x0 = 0.0
        for k, L in enumerate(l["slabs"] or [ers_len]):
            ax.add_patch(Rectangle((x0, -0.9), L - 0.02, 0.55, facecolor="0.75",
                                   edgecolor="0.3", lw=0.8))
            x0 += L
        ax.axvline(0.0, color="k", lw=1.0, ls="-", ymin=0.05, ymax=0.95)
        # Type II strip
        t2 = l["type_ii_end"] - l["x_a"]
        if t2 > 0:
            ax.add_patch(Rectangle((0, -0.35), t2, 0.33, facecolor=TYPE_II_COLOR, alpha=0.6,
                                   edgecolor="none"))
        ax.add_patch(Rectangle((max(t2, 0), -0.35), max(right, ers_len) - max(t2, 0), 0.33,
                               facecolor="0.55",
                               edgecolor="none"))
        # rail
        ax.plot([left, right], [0.0, 0.0], color="k", lw=3, solid_capstyle="butt")
        # sleepers with pads
        for i, (xi, k, st) in enumerate(zip(xs, l["k"], l["strong"])):
            if xi < left:
                break
            wdt = 0.30 if st else 0.22
            ax.add_patch(Rectangle((xi - wdt / 2, -0.75 if st else -0.65), wdt,
                                   0.55 if st else 0.45,
                                   facecolor="tab:brown" if st else "burlywood",
                                   edgecolor="k", lw=0.5,
                                   hatch="///" if st else None))
            ax.add_patch(Rectangle((xi - 0.09, -0.2), 0.18, 0.17,
                                   facecolor=cmap(norm(k / 1e6)), edgecolor="k",
                                   lw=0.4))
            if n_zone is not None and i + 1 in (1, 5, 10, 15, 20) and i < n_zone:
                ax.text(xi, -1.05, str(i + 1), ha="center", va="center", fontsize=7, color="0.3")
        # spans next to the interface (the designed ones)
        n_sp = sum(v.group == "sleeper_spans" for v in run.variables) or 3
        pts = np.concatenate([[0.0], xs[:n_sp]])
        for a, b in zip(pts[:-1], pts[1:]):
            ax.annotate("", xy=(a, 0.28), xytext=(b, 0.28),
                        arrowprops=dict(arrowstyle="<->", lw=0.7))
            ax.text(0.5 * (a + b), 0.36, f"{abs(a - b):.1f}", ha="center", va="bottom", fontsize=7)
        n_pad = sum(v.group == "railpad_stiffness" for v in run.variables)
        for xi, k in zip(xs[:n_pad], l["k"][:n_pad]):  # the designed pads, in MN/m
            ax.text(xi, 0.05, f"{k / 1e6:.0f}", ha="center", va="bottom",
                    fontsize=6.5, color="0.15")
        ax.text(left, 0.62, title, fontsize=9, fontweight="bold", va="center")
        ax.text(0.05, 0.62,
                "ERS →  "
                f"{'Type II strip ' + format(t2, '.1f') + ' m' if t2 > 0 else 'no Type II strip'}",
                fontsize=8, va="center")
    axes[-1, 0].set_xlabel("distance from the entry slab edge [m] (vehicle runs left to right)\n"
                           "sleeper numbers below; above: designed pads under the wheel in MN/m, "
                           "spans in m")
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.tight_layout(rect=(0, 0.09, 0.88, 1))
    cax = fig.add_axes((0.895, 0.2, 0.015, 0.7))
    cb = fig.colorbar(sm, cax=cax)
    cb.set_label("railpad stiffness under the wheel [MN/m]")
    if isinstance(norm, mcolors.LogNorm):
        from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

        ticks = [t for t in (20, 50, 100, 200, 500, 1000, 2000) if norm.vmin <= t <= norm.vmax]
        cb.ax.yaxis.set_major_locator(FixedLocator(ticks))
        cb.ax.yaxis.set_minor_locator(NullLocator())
        cb.ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    handles = [Patch(facecolor="burlywood", edgecolor="k", label="standard sleeper"),
               Patch(facecolor="tab:brown", edgecolor="k", hatch="///",
                     label="strengthened sleeper"),
               Patch(facecolor="0.55", label="standard rail strip (Type I)"),
               Patch(facecolor=TYPE_II_COLOR, alpha=0.6, label="Type II rail strip"),
               Patch(facecolor="0.75", edgecolor="0.3", label="concrete slab")]
    fig.legend(handles=handles, loc="lower center", ncol=5, frameon=False,
               bbox_to_anchor=(0.45, 0.0))
    return save_figure(fig, out / "track-layout.png")
