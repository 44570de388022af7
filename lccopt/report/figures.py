"""The report's figures (matplotlib, Agg), after the paper's Figs. 6-11."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .data import (BEST_COLOR, DPI, FAIL_COLOR, FRONT_COLOR, OBJECTIVE_NAMES, OKABE_ITO, PHASE_STYLE,
                   REF_COLOR, TYPE_II_COLOR, ZONE_COLOR, RunData, fnum, improvement_sign,
                   obj_display, value_label, var_value)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 9, "axes.titlesize": 10, "legend.fontsize": 8,
                         "axes.grid": True, "grid.alpha": 0.3, "figure.dpi": DPI})
    return plt


def _save(fig, path: Path) -> Path:
    fig.savefig(path, dpi=DPI)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path


def _history_panel(ax, run: RunData, vals: np.ndarray, ylo: float, yhi: float, arrows: bool = True,
                   unit: str | None = None, asf_track: bool = False) -> list:
    """One panel of the search history; returns the legend handles. ``asf_track``: VALS are one
    objective of a multi-objective run, and the best-so-far line follows the design that is
    best by the ASF so far (with a thin line for that objective's own lowest so far)."""
    import matplotlib.transforms as mtransforms
    from matplotlib.lines import Line2D

    ok = run.ok & np.isfinite(vals)
    ref_i = run.ref_index()
    clipped = ok & (vals > yhi)
    if unit is None:
        unit = "" if run.multi else " " + obj_display(run.objectives[0])[1]
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    handles = []
    for ph, (label, marker, color) in PHASE_STYLE.items():
        m = ok & (run.phase == ph) & ~clipped
        if ref_i is not None:
            m[ref_i] = False
        if m.any():
            ax.scatter(run.ids[m], vals[m], marker=marker, s=18, color=color, alpha=0.8, lw=0, zorder=3)
        n_ph = int((ok & (run.phase == ph)).sum())
        if n_ph:
            handles.append(Line2D([], [], ls="", marker=marker, color=color, label=f"{label} ({n_ph})"))
    other = ok & ~np.isin(run.phase, list(PHASE_STYLE)) & ~clipped
    if other.any():
        ax.scatter(run.ids[other], vals[other], marker="o", s=18, color="0.6", zorder=3)
        handles.append(Line2D([], [], ls="", marker="o", color="0.6", label=f"other ({other.sum()})"))
    if ref_i is not None and ok[ref_i] and not clipped[ref_i]:
        ax.scatter([run.ids[ref_i]], [vals[ref_i]], marker="D", s=60, color=REF_COLOR, edgecolor="k", zorder=5)
    if ref_i is not None and ok[ref_i]:
        handles.append(Line2D([], [], ls="", marker="D", color=REF_COLOR, markeredgecolor="k",
                              label=f"reference design (#{run.ids[ref_i]})"))
    tr = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    if clipped.any() and arrows:
        ax.scatter(run.ids[clipped], np.full(clipped.sum(), 0.985), marker="$\u2191$", s=40, color="0.45",
                   transform=tr, clip_on=False, zorder=4)
        handles.append(Line2D([], [], ls="", marker="$\u2191$", markersize=8, color="0.45",
                              label=f"above the plotted range ({clipped.sum()})"))
    failed = run.status == "failed"
    if failed.any():
        ax.scatter(run.ids[failed], np.full(failed.sum(), 0.03), marker="x", s=40, color=FAIL_COLOR,
                   transform=tr, zorder=6, clip_on=False)
        handles.append(Line2D([], [], ls="", marker="x", color=FAIL_COLOR,
                              label=f"failed evaluation ({failed.sum()}), no value"))
    order = np.argsort(run.ids)
    v = np.where(ok, vals, np.inf)[order]
    best = np.minimum.accumulate(v)
    if asf_track:   # the objective of the design the ASF ranks best so far
        lowest = best
        a = np.where(run.ok & np.isfinite(run.value), run.value, np.inf)[order]
        at = np.array([int(np.argmin(a[:k + 1])) for k in range(len(a))]) if len(a) else np.zeros(0, int)
        best = np.where(np.isfinite(a[at]), vals[order][at], np.inf)
    has = np.isfinite(best)
    if has.any():
        xs = np.append(run.ids[order][has], run.ids.max() + 0.5)
        ax.step(xs, np.append(best[has], best[has][-1]), where="post", color=FRONT_COLOR, lw=2.2, zorder=4)
        handles.append(Line2D([], [], color=FRONT_COLOR, lw=2.2,
                              label="best so far (by the ASF)" if asf_track else "best so far"))
        if asf_track and np.isfinite(lowest).any():
            hl = np.isfinite(lowest)
            xl = np.append(run.ids[order][hl], run.ids.max() + 0.5)
            ax.step(xl, np.append(lowest[hl], lowest[hl][-1]), where="post", color=FRONT_COLOR, lw=0.9,
                    ls=":", zorder=4)
            handles.append(Line2D([], [], color=FRONT_COLOR, lw=0.9, ls=":",
                                  label="lowest so far of this objective alone"))
    bi = run.best_index()
    if bi is not None:
        ax.scatter([run.ids[bi]], [vals[bi]], marker="*", s=180, color=BEST_COLOR, edgecolor="k", zorder=7)
        handles.append(Line2D([], [], ls="", marker="*", markersize=12, color=BEST_COLOR, markeredgecolor="k",
                              label=f"best by the ASF: #{run.ids[bi]}" if asf_track
                              else f"best: #{run.ids[bi]}, {fnum(vals[bi], 4)}{unit}"))
    starts = [int(run.ids[run.restart == r].min()) for r in np.unique(run.restart) if r > 0]
    for k, i0 in enumerate(starts):
        ax.axvline(i0 - 0.5, color="k", ls="--", lw=1.0, zorder=2)
        ax.text(i0 - 0.5, 0.88, f" restart {k + 1}", transform=ax.get_xaxis_transform(), va="top",
                ha="left", fontsize=8, bbox=dict(facecolor="white", edgecolor="none", alpha=0.7, pad=1))
    if starts:
        handles.append(Line2D([], [], color="k", ls="--", lw=1.0, label="restart (fresh design)"))
    if run.multi and not asf_track and run.ref_point is not None and ylo < 0 < yhi:
        ax.axhline(0.0, color="0.3", lw=0.8, ls=":")
        handles.append(Line2D([], [], color="0.3", ls=":", lw=0.8, label="0: the reference point f^r"))
    ax.set_ylim(ylo, yhi)
    ax.set_xlim(-1, max(int(run.ids.max()) + 1, run.budget))
    return handles


def _value_range(run: RunData, scale: float, below: float, above: float):
    """Scaled values, their ok mask and y-limits: the minimum to the 95th percentile (the
    worst values would squash the interesting end), padded by 6 % times below/above."""
    vals = run.value * scale
    ok = run.ok & np.isfinite(vals)
    if not ok.any():
        return vals, ok, 0.0, 1.0
    v_ok = vals[ok]
    lo, hi = float(v_ok.min()), float(np.percentile(v_ok, 95) if ok.sum() > 10 else v_ok.max())
    pad = 0.06 * (hi - lo if hi > lo else (abs(hi) or 1.0))
    return vals, ok, lo - below * pad, hi + above * pad


def fig_search_history(run: RunData, out: Path) -> Path:
    """All evaluations (top) and, when it adds detail, a zoom on the best-so-far line (bottom);
    a multi-objective run: one panel per objective, in its own units."""
    plt = _plt()
    if run.multi:
        return _objective_histories(run, out)
    s, ylabel = value_label(run)
    vals, ok, ylo, yhi = _value_range(run, s, below=2.0, above=2.5)  # room below for failure marks
    zoom = None
    if ok.sum() > 3:
        order = np.argsort(run.ids)
        bsf = np.minimum.accumulate(np.where(ok, vals, np.inf)[order])
        later = np.flatnonzero(run.phase[order] != "initial")  # first candidate after the initial design
        n0 = max(0, int(later[0]) - 1) if len(later) else len(bsf) - 1
        top, bottom = float(bsf[n0]), float(bsf[-1])
        if np.isfinite(top) and top > bottom and (top - bottom) < 0.35 * (yhi - ylo):
            pz = 0.12 * (top - bottom)
            zoom = (bottom - 2 * pz, top + 2.5 * pz)
    if zoom is None:
        fig, ax = plt.subplots(figsize=(10, 4.6))
        axes = [ax]
    else:
        fig, axes = plt.subplots(2, 1, figsize=(10, 7.2), sharex=True, gridspec_kw={"height_ratios": [1.25, 1]})
    handles = _history_panel(axes[0], run, vals, ylo, yhi)
    axes[0].set_title(f"Search history of '{run.name}': {run.n} of {run.budget} evaluations ({run.state})")
    axes[0].set_ylabel(ylabel)
    if zoom is not None:
        _history_panel(axes[1], run, vals, *zoom, arrows=False)
        axes[1].set_ylabel(ylabel)
        axes[1].set_title("zoom on the best so far (after the initial design)", fontsize=9)
    axes[-1].set_xlabel("evaluation number")
    axes[0].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0, frameon=False)
    fig.tight_layout()
    return _save(fig, out / "search-history.png")


def _objective_histories(run: RunData, out: Path) -> Path:
    """The search history of a multi-objective run in engineering units: each objective's value
    of every evaluation, and of the design the ASF ranks best so far."""
    plt = _plt()
    k = len(run.objectives)
    fig, axes = plt.subplots(k, 1, figsize=(10, 2.2 + 2.6 * k), sharex=True)
    handles = []
    for ax, name in zip(np.atleast_1d(axes), run.objectives):
        scale, unit = obj_display(name)
        vals = run.obj[name] * scale
        ok = run.ok & np.isfinite(vals)
        if ok.any():
            lo, hi = float(vals[ok].min()), float(np.percentile(vals[ok], 95) if ok.sum() > 10 else vals[ok].max())
        else:
            lo, hi = 0.0, 1.0
        pad = 0.06 * (hi - lo if hi > lo else (abs(hi) or 1.0))
        handles = _history_panel(ax, run, vals, lo - 2.0 * pad, hi + 2.5 * pad, unit=f" {unit}",
                                 asf_track=True)
        r = run.ref_objectives.get(name, math.nan) * scale
        if np.isfinite(r):
            ax.axhline(r, color=REF_COLOR, lw=0.8, ls="--", zorder=2)
        ax.set_ylabel(f"{name} [{unit}]")
    np.atleast_1d(axes)[0].set_title(f"Search history of '{run.name}': {run.n} of {run.budget} evaluations "
                                     f"({run.state}); the run minimises the ASF of {', '.join(run.objectives)}")
    np.atleast_1d(axes)[-1].set_xlabel("evaluation number")
    from matplotlib.lines import Line2D

    handles.append(Line2D([], [], color=REF_COLOR, lw=0.8, ls="--", label="the reference design's value"))
    np.atleast_1d(axes)[0].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                                  borderaxespad=0, frameon=False)
    fig.tight_layout()
    return _save(fig, out / "search-history.png")


def log_ticks(lo: float, hi: float, at_least: int = 5) -> list[float]:
    """Labelled ticks for a logarithmic axis over [LO, HI]: 1-2-5, else 1-2-3-5, else every
    mantissa per decade, the first of these that puts AT_LEAST ticks in the range (matplotlib's
    own locator leaves a range inside one decade, e.g. 0.3-1.8 kN, nearly unlabelled)."""
    decades = range(int(np.floor(np.log10(lo))) - 1, int(np.ceil(np.log10(hi))) + 1)
    pad_lo, pad_hi = lo / 1.15, hi * 1.15   # matplotlib's margins show a little beyond the data
    ticks: list[float] = []
    for mantissas in ((1, 2, 5), (1, 2, 3, 5), (1, 2, 3, 4, 5, 6, 7, 8, 9)):
        ticks = [float(f"{m}e{d}") for d in decades for m in mantissas if pad_lo <= m * 10.0 ** d <= pad_hi]
        if len(ticks) >= at_least:
            break
    return ticks


def fig_objective_space(run: RunData, out: Path) -> tuple[Path, str]:
    """(path, note). Multi-objective: the run's first two objectives; else F_max vs E_max.

    Left: all evaluations (logarithmic axes when they span a wide range); right: a zoom on the
    Pareto front, the reference design and the reference point."""
    plt = _plt()
    from matplotlib.ticker import FixedLocator, FuncFormatter, LogLocator

    if run.multi:
        kx, ky = run.objectives[0], run.objectives[1]
        front = run.pareto.copy()
        note = ""
        if len(run.objectives) > 2:
            note = (f"The run has {len(run.objectives)} objectives; the figure shows the first two, the "
                    f"Pareto front is over all of them.")
    else:
        from ..optim.scalarise import pareto_mask

        kx, ky = "F_max", "E_max"
        F = np.column_stack([run.obj[kx], run.obj[ky]])
        F[~run.ok] = math.nan
        front = pareto_mask(F)
        note = (f"This run minimised {run.objectives[0]} alone; the objective-space figure shows all evaluations "
                f"in (F_max, E_max) anyway, with the evaluations that no other beats in both (not the run's goal).")
    sx, ux = obj_display(kx)
    sy, uy = obj_display(ky)
    X, Y = run.obj[kx] * sx, run.obj[ky] * sy
    ok = run.ok & np.isfinite(X) & np.isfinite(Y)
    fm = ok & front
    rx, ry = run.ref_objectives.get(kx, math.nan) * sx, run.ref_objectives.get(ky, math.nan) * sy
    target = None
    if run.multi and run.ref_point is not None:
        target = (run.ref_point[0] * sx, run.ref_point[1] * sy)
    bi = run.best_index()
    px = list(X[fm]) + [v for v in (rx, target[0] if target else math.nan) if np.isfinite(v)]
    py = list(Y[fm]) + [v for v in (ry, target[1] if target else math.nan) if np.isfinite(v)]
    if bi is not None:
        px.append(X[bi])
        py.append(Y[bi])
    box = None
    if len(set(zip(np.round(px, 12), np.round(py, 12)))) >= 2 and ok.sum() >= 2:
        x0, x1, y0, y1 = min(px), max(px), min(py), max(py)
        dx, dy = (x1 - x0) or abs(x1) * 0.1 or 1.0, (y1 - y0) or abs(y1) * 0.1 or 1.0
        box = (x0 - 0.1 * dx, x1 + 0.1 * dx, y0 - 0.1 * dy, y1 + 0.1 * dy)
        fx, fy = np.ptp(X[ok]) or 1.0, np.ptp(Y[ok]) or 1.0
        if (box[1] - box[0]) > 0.5 * fx and (box[3] - box[2]) > 0.5 * fy:
            box = None  # the zoom would show about what the full view shows
    fig, axes = plt.subplots(1, 2 if box else 1, figsize=(11 if box else 7.5, 5.4), squeeze=False)
    axes = axes[0]

    def draw(ax, labels: bool):
        L = (lambda t: t) if labels else (lambda t: None)  # noqa: E731
        ax.scatter(X[ok & ~front], Y[ok & ~front], s=16, color="0.6", alpha=0.7, lw=0,
                   label=L(f"evaluations ({(ok & ~front).sum()})"))
        if fm.any():
            o = np.argsort(X[fm])
            ax.plot(X[fm][o], Y[fm][o], color=FRONT_COLOR, lw=1.0, drawstyle="steps-post", zorder=3)
            ax.scatter(X[fm], Y[fm], s=34, color=FRONT_COLOR, edgecolor="k", lw=0.5, zorder=4,
                       label=L(f"Pareto front of all evaluations ({fm.sum()})" if run.multi
                               else f"non-dominated in ({kx}, {ky}) ({fm.sum()})"))
        if np.isfinite(rx) and np.isfinite(ry):
            ax.scatter([rx], [ry], marker="D", s=70, color=REF_COLOR, edgecolor="k", zorder=5,
                       label=L(f"reference design ({fnum(rx, 4)} {ux}, {fnum(ry, 4)} {uy})"))
        if target is not None:
            imp = f"{run.improvement:.0%} better than the reference design" \
                if run.improvement is not None and np.isfinite(run.improvement) else "target"
            ax.scatter([target[0]], [target[1]], marker="P", s=90, color=OKABE_ITO["vermillion"], edgecolor="k", zorder=5,
                       label=L(f"reference point f^r ({imp})"))
            ax.axvline(target[0], color=OKABE_ITO["vermillion"], lw=0.7, ls=":", zorder=1)
            ax.axhline(target[1], color=OKABE_ITO["vermillion"], lw=0.7, ls=":", zorder=1)
        if bi is not None:
            lab = "chosen compromise (best ASF value)" if run.multi else f"best {run.objectives[0]}"
            ax.scatter([X[bi]], [Y[bi]], marker="*", s=260, color=BEST_COLOR, edgecolor="k", zorder=6,
                       label=L(f"{lab}: #{run.ids[bi]} ({fnum(X[bi], 4)} {ux}, {fnum(Y[bi], 4)} {uy})"))
        ax.set(xlabel=f"{kx} [{ux}]", ylabel=f"{ky} [{uy}]")

    a0 = axes[0]
    draw(a0, True)
    a0.set_title("all evaluations")
    for vals, axis in ((X[ok], a0.xaxis), (Y[ok], a0.yaxis)):
        if len(vals) and np.all(vals > 0) and vals.max() > 4 * vals.min():
            (a0.set_xscale if axis is a0.xaxis else a0.set_yscale)("log")
            axis.set_major_locator(FixedLocator(log_ticks(float(vals.min()), float(vals.max()))))
            axis.set_minor_locator(LogLocator(subs=np.arange(1, 10)))
            axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            axis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    if box:
        a1 = axes[1]
        draw(a1, False)
        a1.set_title("zoom: Pareto front, reference design" + (", reference point" if target else ""))
        a1.set_xlim(box[0], box[1])
        a1.set_ylim(box[2], box[3])
    fig.suptitle(f"Objective space of '{run.name}'" + ("" if run.multi else
                                                        f" (the run minimised {run.objectives[0]} alone)"))
    fig.legend(*a0.get_legend_handles_labels(), loc="lower center", ncol=2 if box else 1, frameon=False)
    fig.tight_layout(rect=(0, 0.15 if box else 0.22, 1, 1))
    return _save(fig, out / "objective-space.png"), note


def fig_best_vs_reference(run: RunData, bi: int, ri: int | None, out: Path) -> Path:
    """Relative change of every objective (left) and the design vector (right), best vs reference."""
    plt = _plt()
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
    a1.set_yticks(y, names)
    for t in a1.get_yticklabels():
        if t.get_text() in run.objectives:
            t.set_fontweight("bold")
    a1.invert_yaxis()
    a1.axvline(0, color="k", lw=0.8)
    lim = max(5.0, float(np.nanmax(np.abs(ch))) * 1.35) if np.isfinite(ch).any() else 5.0
    a1.set_xlim(-lim, lim)
    for yi, c in zip(y, ch):
        if np.isfinite(c):
            a1.text(0, yi, f" {c:+.1f} % ", va="center", ha="right" if c >= 0 else "left", fontsize=8)
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
    a2.scatter(ur, yy, marker="D", s=40, color=REF_COLOR, edgecolor="k", zorder=3, label="reference design")
    a2.scatter(ub, yy, marker="*", s=120, color=BEST_COLOR, edgecolor="k", zorder=4, label=f"best (#{run.ids[bi]})")
    for yi, v in enumerate(run.variables):
        a2.text(1.03, yi, f"{var_value(v, xr[yi])} → {var_value(v, xb[yi])}"
                + (f" {v.unit}" if v.unit else ""),
                va="center", fontsize=7.5, transform=a2.get_yaxis_transform())
    a2.set_yticks(yy, run.names)
    a2.invert_yaxis()
    a2.set_xlim(-0.05, 1.05)
    a2.set_xticks([0, 0.5, 1], ["lower bound", "middle", "upper bound"])
    a2.set(title="design variables within their bounds" + (" (pads: in ratios)" if log.any() else ""))
    a2.grid(axis="y", visible=False)
    a2.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)
    fig.tight_layout()
    fig.subplots_adjust(right=0.8)
    return _save(fig, out / "best-vs-reference.png")


def fig_conditions(run: RunData, bi: int, ri: int | None, out: Path) -> Path | None:
    """Each traffic condition's objectives, best design against the reference design (one
    panel per objective; the run's combined value as a line: worst case or weighted mean)."""
    if not run.conditions or ri is None:
        return None
    plt = _plt()
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
                ax.text(bi_, yi + 0.2, f" {ch:+.0f} %" if abs(ch) >= 0.5 else " ±0 %", va="center", fontsize=7)
        if k in run.obj:
            for v, color in ((run.obj[k][ri] * scale, REF_COLOR), (run.obj[k][bi] * scale, BEST_COLOR)):
                ax.axvline(v, color=color, lw=1.2, ls="--")
        bold = k in run.objectives or any(o.startswith(k + "@") for o in run.objectives)
        ax.set_title(f"{k} [{unit}]", fontweight="bold" if bold else "normal", fontsize=10)
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
    return _save(fig, out / "conditions.png")


def _zone_marks(ax, info: dict, xmax: float, label: bool = True):
    x_a, x_b = info.get("interface_entry"), info.get("interface_exit")
    if x_a is not None and x_b is not None:
        ax.axvspan(x_a, min(x_b, xmax), color="0.88", zorder=0, label="ERS (level crossing)" if label else None)
        ax.axvline(x_a, color="0.3", lw=0.9, zorder=1)
    if "zone_start" in info and "zone_end" in info:
        # a solid strip along the bottom and dashed ends, not a translucent band: over the ERS's
        # grey a band would mix into a colour that no legend entry shows
        lo, hi = sorted((info["zone_start"], info["zone_end"]))
        ax.axvspan(lo, hi, ymin=0.0, ymax=0.025, color=ZONE_COLOR, zorder=1,
                   label="force evaluation zone" if label else None)
        for x in (lo, hi):
            ax.axvline(x, color=ZONE_COLOR, lw=0.8, ls="--", zorder=1)


def speed_text(info: dict, case=None) -> str:
    """'140 km/h' from an evaluation's info (or the case, for files written before it was kept)."""
    v = info.get("speed")
    if v is None and case is not None:
        v = case.data["vehicle"]["speed"]
    return "" if v is None else f"{float(v) * 3.6:.0f} km/h"


def range_bracket(ax, column: int, lo: float, hi: float, color: str, text: str) -> None:
    """A vertical double arrow from LO to HI in the right margin of AX (COLUMN 0, 1, ...) with
    TEXT beside it: what a max - min objective measures, clear of the curves."""
    x = 1.012 + 0.045 * column
    ax.annotate("", xy=(x, hi), xytext=(x, lo), xycoords=("axes fraction", "data"),
                textcoords=("axes fraction", "data"), annotation_clip=False,
                arrowprops=dict(arrowstyle="<->", color=color, lw=1.4, shrinkA=0, shrinkB=0))
    ax.text(x + 0.004, 0.5 * (lo + hi), text, color=color, ha="left", va="center", fontsize=8, rotation=90,
            transform=ax.get_yaxis_transform(), clip_on=False)


def sleeper_ticks(ax, positions, color: str, row: int, label: str | None) -> None:
    """Short marks at the foot of the axes at each sleeper position (ROW 0, 1: stacked)."""
    positions = np.asarray(positions, float)
    if positions.size:
        ax.vlines(positions, 0.012 + 0.035 * row, 0.042 + 0.035 * row, transform=ax.get_xaxis_transform(),
                  color=color, lw=1.2, zorder=5, label=label)


def fig_contact_force(run: RunData, best: tuple, ref: tuple, bi: int, out: Path,
                      condition: str | None = None) -> Path | None:
    """Contact force along the track for the best and the reference design (under traffic
    ``condition``, the one that sets the worst F_max), with the force zone, the sleepers of each
    design, and F_max drawn as the max - min range it is."""
    (hb, ib), (hr, ir) = best, ref
    have = [(h, i) for h, i in (best, ref) if h is not None and "wheel_position" in h and "contact_force" in h]
    if not have:
        return None
    plt = _plt()
    info = ib if hb is not None and "wheel_position" in hb else ir
    fig, ax = plt.subplots(figsize=(9, 5.0))
    xmax = max(float(np.max(h["wheel_position"])) for h, _ in have)
    _zone_marks(ax, info, xmax)
    x0 = min(float(np.min(h["wheel_position"])) for h, _ in have)
    if "zone_start" in info:  # the run-in from static equilibrium is not of interest
        x0 = max(x0, float(info["zone_start"]) - 2.0)
    zone = (info.get("zone_start", x0), info.get("zone_end", xmax))
    first = condition
    fmax_of = (lambda i: run.cond_obj[first]["F_max"][i]) if first else (lambda i: run.obj["F_max"][i])
    ri = run.ref_index()
    curves = []
    if hr is not None and "contact_force" in hr and "wheel_position" in hr:
        f_ref = fmax_of(ri) if first and ri is not None else run.ref_objectives.get("F_max", math.nan)
        curves.append((hr, REF_COLOR, "reference design", f_ref, 0))
    if hb is not None and "contact_force" in hb and "wheel_position" in hb:
        curves.append((hb, BEST_COLOR, f"best #{run.ids[bi]}", fmax_of(bi), 1))
    for h, color, lab, fmax, row in curves:
        xw, f = h["wheel_position"], h["contact_force"] / 1e3
        ax.plot(xw, f, color=color, lw=1.1, label=f"{lab}: F_max = {fnum(fmax / 1e3, 4)} kN (max - min in the zone)")
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
            positions = np.asarray(positions, float)
            sleeper_ticks(ax, positions[(positions >= x0) & (positions <= xmax)], color, row,
                          f"sleepers of the {lab.split(':')[0]}")
    if "static_wheel_load" in info:
        ax.axhline(info["static_wheel_load"] / 1e3, color="k", ls=":", lw=0.8, label="static wheel load")
    if "interface_entry" in info:
        ax.text(info["interface_entry"], 0.98, " interface", transform=ax.get_xaxis_transform(), va="top",
                ha="left", fontsize=8)
    speed = speed_text(info, run.case)
    ax.set(xlabel="wheel position along the track [m]", ylabel="wheel-rail contact force [kN]",
           title="Contact force: best against reference design" + (f", vehicle at {speed}" if speed else "")
                 + (f"\ncondition {first}, the best design's worst F_max (leading wheel; every "
                    f"condition: conditions.png)" if first else ""))
    ax.set_xlim(x0, xmax)
    shown = [h["contact_force"][h["wheel_position"] >= x0] / 1e3 for h, _ in have]
    lo, hi = min(float(v.min()) for v in shown), max(float(v.max()) for v in shown)
    ax.set_ylim(lo - 0.15 * (hi - lo or 1), hi + 0.15 * (hi - lo or 1))
    fig.legend(*ax.get_legend_handles_labels(), loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0, 0.2, 0.95, 1))
    return _save(fig, out / "contact-force.png")


def fig_sleeper_energy(run: RunData, best: tuple, ref: tuple, bi: int, out: Path,
                       condition: str | None = None) -> Path | None:
    """Energy per zone sleeper (profile, as the paper's Fig. 11); E_max = max - min shown as a band."""
    (hb, _), (hr, _) = best, ref
    eb = None if hb is None else hb.get("sleeper_energy")
    er = None if hr is None else hr.get("sleeper_energy")
    if eb is None and er is None:
        return None
    plt = _plt()
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
        ax.scatter(idx[~st], e[~st], marker=marker, s=30, facecolor="white", edgecolor=color, lw=1.3, zorder=4)
        ax.scatter(idx[st], e[st], marker=marker, s=30, facecolor=color, edgecolor=color, lw=1.3, zorder=4)
        handles.append(Line2D([], [], color=color, marker=marker, markerfacecolor=color,
                              label=f"{lab}: E_max = {fnum(float(e.max() - e.min()), 4)} J (max - min, dashed), "
                                    f"E_rms = {fnum(float(np.sqrt(np.mean(e ** 2))), 4)} J"))
    handles += [Line2D([], [], ls="", marker="o", color="0.3", label="strengthened sleeper (filled)"),
                Line2D([], [], ls="", marker="o", markerfacecolor="white", color="0.3",
                       label="standard sleeper (open)")]
    ax.set(xlabel="sleeper number (1 = next to the interface)", ylabel="energy dissipated in the support [J]",
           title="Energy dissipated under each sleeper of the evaluation zone (cf. paper Fig. 11)"
                 + (f"\ncondition {condition}, the best design's worst E_max (every condition: "
                    f"conditions.png)" if condition else ""),
           xlim=(0.5, n + 0.5))
    ax.set_xticks(np.arange(1, n + 1))
    fig.legend(handles=handles, loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0, 0.12, 0.95, 1))
    return _save(fig, out / "sleeper-energy.png")


def _layout_of(run: RunData, h: dict | None, info: dict, x: np.ndarray) -> dict | None:
    """Entry-side layout of a design: from its histories, else rebuilt from the case."""
    keys = ("entry_sleeper_position", "entry_pad_stiffness", "entry_strengthened")
    if h is not None and all(k in h for k in keys) and "interface_entry" in info:
        lay = {"x": np.asarray(h["entry_sleeper_position"], float), "k": np.asarray(h["entry_pad_stiffness"], float),
               "strong": np.asarray(h["entry_strengthened"], bool), "x_a": float(info["interface_entry"]),
               "x_b": float(info.get("interface_exit", math.nan)), "type_ii_end": float(info.get("type_ii_end",
                                                                                               info["interface_entry"]))}
    elif run.case is not None:
        try:
            from ..vti.track import build_track

            case = run.case
            t = build_track(case.scenario(), case.track_design(np.asarray(x, float)))
        except Exception:  # noqa: BLE001
            return None
        lay = {"x": t.entry_sleeper_x, "k": t.entry_pad_stiffness, "strong": np.asarray(t.entry_strengthened, bool),
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
    plt = _plt()
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
    norm = mcolors.LogNorm(vmin=kmin / 1e6, vmax=kmax / 1e6) if kmax > kmin else mcolors.Normalize(kmin / 1e6 - 1,
                                                                                                    kmax / 1e6 + 1)
    cmap = plt.get_cmap("viridis")
    # x: distance from the entry slab edge (negative: ballast track)
    n_show = n_zone or 20
    left = -max(float(l["x_a"] - l["x"][min(n_show, len(l["x"])) - 1]) for _, l in lays) - 0.8
    ers_len = min(float(l["x_b"] - l["x_a"]) for _, l in lays if np.isfinite(l["x_b"])) if \
        any(np.isfinite(l["x_b"]) for _, l in lays) else 12.0
    right = min(ers_len, max(3.0, max(l["type_ii_end"] - l["x_a"] for _, l in lays) + 1.0))
    fig, axes = plt.subplots(len(lays), 1, figsize=(10, 1.9 * len(lays) + 1.3), sharex=True, squeeze=False)
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
            ax.add_patch(Rectangle((x0, -0.9), L - 0.02, 0.55, facecolor="0.75", edgecolor="0.3", lw=0.8))
            x0 += L
        ax.axvline(0.0, color="k", lw=1.0, ls="-", ymin=0.05, ymax=0.95)
        # Type II strip
        t2 = l["type_ii_end"] - l["x_a"]
        if t2 > 0:
            ax.add_patch(Rectangle((0, -0.35), t2, 0.33, facecolor=TYPE_II_COLOR, alpha=0.6, edgecolor="none"))
        ax.add_patch(Rectangle((max(t2, 0), -0.35), max(right, ers_len) - max(t2, 0), 0.33, facecolor="0.55",
                               edgecolor="none"))
        # rail
        ax.plot([left, right], [0.0, 0.0], color="k", lw=3, solid_capstyle="butt")
        # sleepers with pads
        for i, (xi, k, st) in enumerate(zip(xs, l["k"], l["strong"])):
            if xi < left:
                break
            wdt = 0.30 if st else 0.22
            ax.add_patch(Rectangle((xi - wdt / 2, -0.75 if st else -0.65), wdt, 0.55 if st else 0.45,
                                   facecolor="tab:brown" if st else "burlywood", edgecolor="k", lw=0.5,
                                   hatch="///" if st else None))
            ax.add_patch(Rectangle((xi - 0.09, -0.2), 0.18, 0.17, facecolor=cmap(norm(k / 1e6)), edgecolor="k",
                                   lw=0.4))
            if n_zone is not None and i + 1 in (1, 5, 10, 15, 20) and i < n_zone:
                ax.text(xi, -1.05, str(i + 1), ha="center", va="center", fontsize=7, color="0.3")
        # spans next to the interface (the designed ones)
        n_sp = sum(v.group == "sleeper_spans" for v in run.variables) or 3
        pts = np.concatenate([[0.0], xs[:n_sp]])
        for a, b in zip(pts[:-1], pts[1:]):
            ax.annotate("", xy=(a, 0.28), xytext=(b, 0.28), arrowprops=dict(arrowstyle="<->", lw=0.7))
            ax.text(0.5 * (a + b), 0.36, f"{abs(a - b):.1f}", ha="center", va="bottom", fontsize=7)
        n_pad = sum(v.group == "railpad_stiffness" for v in run.variables)
        for xi, k in zip(xs[:n_pad], l["k"][:n_pad]):  # the designed pads, in MN/m
            ax.text(xi, 0.05, f"{k / 1e6:.0f}", ha="center", va="bottom", fontsize=6.5, color="0.15")
        ax.text(left, 0.62, title, fontsize=9, fontweight="bold", va="center")
        ax.text(0.05, 0.62, f"ERS →  {'Type II strip ' + format(t2, '.1f') + ' m' if t2 > 0 else 'no Type II strip'}",
                fontsize=8, va="center")
    axes[-1, 0].set_xlabel("distance from the entry slab edge [m] (vehicle runs left to right; "
                           "sleeper numbers below; above: designed pads in MN/m, spans in m)")
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.tight_layout(rect=(0, 0.09, 0.88, 1))
    cax = fig.add_axes((0.895, 0.2, 0.015, 0.7))
    cb = fig.colorbar(sm, cax=cax)
    cb.set_label("railpad stiffness [MN/m]")
    if isinstance(norm, mcolors.LogNorm):
        from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

        ticks = [t for t in (20, 50, 100, 200, 500, 1000, 2000) if norm.vmin <= t <= norm.vmax]
        cb.ax.yaxis.set_major_locator(FixedLocator(ticks))
        cb.ax.yaxis.set_minor_locator(NullLocator())
        cb.ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    handles = [Patch(facecolor="burlywood", edgecolor="k", label="standard sleeper"),
               Patch(facecolor="tab:brown", edgecolor="k", hatch="///", label="strengthened sleeper"),
               Patch(facecolor="0.55", label="standard rail strip (Type I)"),
               Patch(facecolor=TYPE_II_COLOR, alpha=0.6, label="Type II rail strip"),
               Patch(facecolor="0.75", edgecolor="0.3", label="concrete slab")]
    fig.legend(handles=handles, loc="lower center", ncol=5, frameon=False, bbox_to_anchor=(0.45, 0.0))
    return _save(fig, out / "track-layout.png")


def sensitivity_of(run: RunData) -> dict:
    """{objective: Indices} for each objective the run minimised (lccopt.report.sensitivity)."""
    from .sensitivity import sobol_indices

    lower = np.array([v.lower for v in run.variables], float)
    upper = np.array([v.upper for v in run.variables], float)
    if not (np.isfinite(lower).all() and np.isfinite(upper).all()):
        return {}
    integer = np.array([v.integer for v in run.variables], bool)
    log = np.array([bool(getattr(v, "log", False)) for v in run.variables], bool)
    out = {}
    for k in run.objectives:
        f = np.where(run.ok, run.obj[k], np.nan)
        ind = sobol_indices(run.x, f, lower, upper, integer, log)
        if ind is not None:
            out[k] = ind
    return out


def fig_sensitivity(run: RunData, out: Path, indices: dict) -> Path | None:
    """Variance-based sensitivity indices of each objective (total effect, first order inside)."""
    if not indices:
        return None
    plt = _plt()
    from matplotlib.patches import Patch

    d = len(run.variables)
    fig, axes = plt.subplots(1, len(indices), figsize=(4.6 * len(indices) + 1.4, 0.42 * d + 1.8),
                             sharey=True, squeeze=False)
    y = np.arange(d)[::-1]
    for ax, (k, ind) in zip(axes[0], indices.items()):
        ax.barh(y, ind.total, height=0.7, color=FRONT_COLOR, alpha=0.35, label="total effect ST_i")
        ax.barh(y, ind.first, height=0.4, color=FRONT_COLOR, label="first order S_i")
        ax.set_xlim(0, max(1.0, float(np.max(ind.total)) * 1.05))
        quality = (f"{ind.n_points} evaluations; surrogate's leave-one-out\nerror {ind.loo_error:.0%} of "
                   f"the values' spread" if np.isfinite(ind.loo_error) else "")
        ax.set_title(f"{k}\n{quality}", fontsize=8.5)
        ax.set_xlabel("share of the objective's variance")
        ax.grid(axis="x", alpha=0.3)
    short = (("railpad stiffness, sleeper", "pad, sleeper"), (" from the interface", ""),
             (" next to the interface", ""), (" from the entry slab edge", ""))
    labels = []
    for v in run.variables:
        label = v.label
        for a, b in short:
            label = label.replace(a, b)
        labels.append(f"{v.name}: {label}")
    axes[0, 0].set_yticks(y)
    axes[0, 0].set_yticklabels(labels, fontsize=8)
    fig.suptitle("Which design variables move the objectives over the whole design space "
                 "(variance-based indices of a surrogate)", fontsize=9.5)
    fig.legend(handles=[Patch(color=FRONT_COLOR, alpha=0.35, label="total effect ST_i (with interactions)"),
                        Patch(color=FRONT_COLOR, label="first order S_i (alone)")],
               loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 0.94))
    return _save(fig, out / "sensitivity.png")


# ================================================================================ summary

