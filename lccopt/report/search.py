"""Figures of the search: the search history with best-so-far and restarts (the paper's Figs.
6, 7, 10) and the objective space with the Pareto front (Fig. 9)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .data import (
    BEST_COLOR,
    FAIL_COLOR,
    FRONT_COLOR,
    OKABE_ITO,
    PHASE_STYLE,
    REF_COLOR,
    RunData,
    fnum,
    obj_display,
    value_label,
    with_unit,
)
from .plotting import log_ticks, pyplot, save_figure


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
            ax.scatter(run.ids[m], vals[m], marker=marker, s=18, color=color,
                       alpha=0.8, lw=0, zorder=3)
        n_ph = int((ok & (run.phase == ph)).sum())
        if n_ph:
            handles.append(Line2D([], [], ls="", marker=marker, color=color,
                                  label=f"{label} ({n_ph})"))
    other = ok & ~np.isin(run.phase, list(PHASE_STYLE)) & ~clipped
    if other.any():
        ax.scatter(run.ids[other], vals[other], marker="o", s=18, color="0.6", zorder=3)
        handles.append(Line2D([], [], ls="", marker="o", color="0.6",
                              label=f"other ({other.sum()})"))
    if ref_i is not None and ok[ref_i] and not clipped[ref_i]:
        ax.scatter([run.ids[ref_i]], [vals[ref_i]], marker="D", s=60, color=REF_COLOR,
                   edgecolor="k", zorder=5)
    if ref_i is not None and ok[ref_i]:
        handles.append(Line2D([], [], ls="", marker="D", color=REF_COLOR, markeredgecolor="k",
                              label=f"reference design (#{run.ids[ref_i]})"))
    tr = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    if clipped.any() and arrows:
        ax.scatter(run.ids[clipped], np.full(clipped.sum(), 0.985), marker="$\u2191$",
                   s=40, color="0.45",
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
        at = (np.array([int(np.argmin(a[:k + 1])) for k in range(len(a))]) if len(a)
              else np.zeros(0, int))
        best = np.where(np.isfinite(a[at]), vals[order][at], np.inf)
    has = np.isfinite(best)
    if has.any():
        xs = np.append(run.ids[order][has], run.ids.max() + 0.5)
        ax.step(xs, np.append(best[has], best[has][-1]), where="post", color=FRONT_COLOR,
                lw=2.2, zorder=4)
        handles.append(Line2D([], [], color=FRONT_COLOR, lw=2.2,
                              label="best so far (by the ASF)" if asf_track else "best so far"))
        if asf_track and np.isfinite(lowest).any():
            hl = np.isfinite(lowest)
            xl = np.append(run.ids[order][hl], run.ids.max() + 0.5)
            ax.step(xl, np.append(lowest[hl], lowest[hl][-1]), where="post",
                    color=FRONT_COLOR, lw=0.9,
                    ls=":", zorder=4)
            handles.append(Line2D([], [], color=FRONT_COLOR, lw=0.9, ls=":",
                                  label="lowest so far of this objective alone"))
    bi = run.best_index()
    if bi is not None:
        ax.scatter([run.ids[bi]], [vals[bi]], marker="*", s=180, color=BEST_COLOR,
                   edgecolor="k", zorder=7)
        handles.append(Line2D([], [], ls="", marker="*", markersize=12, color=BEST_COLOR,
                              markeredgecolor="k",
                              label=f"best by the ASF: #{run.ids[bi]}" if asf_track
                              else f"best: #{run.ids[bi]}, {fnum(vals[bi], 4)}{unit}"))
    starts = [int(run.ids[run.restart == r].min()) for r in np.unique(run.restart) if r > 0]
    for k, i0 in enumerate(starts):
        ax.axvline(i0 - 0.5, color="k", ls="--", lw=1.0, zorder=2)
        ax.text(i0 - 0.5, 0.88, f" restart {k + 1}", transform=ax.get_xaxis_transform(), va="top",
                ha="left", fontsize=8,
                bbox=dict(facecolor="white", edgecolor="none", alpha=0.7, pad=1))
    if starts:
        handles.append(Line2D([], [], color="k", ls="--", lw=1.0, label="restart (fresh design)"))
    if run.multi and not asf_track and run.ref_point is not None and ylo < 0 < yhi:
        ax.axhline(0.0, color="0.3", lw=0.8, ls=":")
        handles.append(Line2D([], [], color="0.3", ls=":", lw=0.8,
                              label="0: the reference point f^r"))
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
    plt = pyplot()
    if run.multi:
        return _objective_histories(run, out)
    s, ylabel = value_label(run)
    vals, ok, ylo, yhi = _value_range(run, s, below=2.0, above=2.5)  # room below for failure marks
    zoom = None
    if ok.sum() > 3:
        order = np.argsort(run.ids)
        bsf = np.minimum.accumulate(np.where(ok, vals, np.inf)[order])
        # the first candidate after the initial design
        later = np.flatnonzero(run.phase[order] != "initial")
        n0 = max(0, int(later[0]) - 1) if len(later) else len(bsf) - 1
        top, bottom = float(bsf[n0]), float(bsf[-1])
        if np.isfinite(top) and top > bottom and (top - bottom) < 0.35 * (yhi - ylo):
            pz = 0.12 * (top - bottom)
            zoom = (bottom - 2 * pz, top + 2.5 * pz)
    if zoom is None:
        fig, ax = plt.subplots(figsize=(10, 4.6))
        axes = [ax]
    else:
        fig, axes = plt.subplots(2, 1, figsize=(10, 7.2), sharex=True,
                                 gridspec_kw={"height_ratios": [1.25, 1]})
    handles = _history_panel(axes[0], run, vals, ylo, yhi)
    axes[0].set_title(f"Search history of '{run.name}': {run.n} of {run.budget} evaluations "
                      f"({run.state})")
    axes[0].set_ylabel(ylabel)
    if zoom is not None:
        _history_panel(axes[1], run, vals, *zoom, arrows=False)
        axes[1].set_ylabel(ylabel)
        axes[1].set_title("zoom on the best so far (after the initial design)", fontsize=9)
    axes[-1].set_xlabel("evaluation number")
    axes[0].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                   borderaxespad=0, frameon=False)
    fig.tight_layout()
    return save_figure(fig, out / "search-history.png")


def _objective_histories(run: RunData, out: Path) -> Path:
    """The search history of a multi-objective run in engineering units: each objective's value
    of every evaluation, and of the design the ASF ranks best so far."""
    plt = pyplot()
    k = len(run.objectives)
    fig, axes = plt.subplots(k, 1, figsize=(10, 2.2 + 2.6 * k), sharex=True)
    handles = []
    for ax, name in zip(np.atleast_1d(axes), run.objectives):
        scale, unit = obj_display(name)
        vals = run.obj[name] * scale
        ok = run.ok & np.isfinite(vals)
        if ok.any():
            top = np.percentile(vals[ok], 95) if ok.sum() > 10 else vals[ok].max()
            lo, hi = float(vals[ok].min()), float(top)
        else:
            lo, hi = 0.0, 1.0
        pad = 0.06 * (hi - lo if hi > lo else (abs(hi) or 1.0))
        handles = _history_panel(ax, run, vals, lo - 2.0 * pad, hi + 2.5 * pad, unit=f" {unit}",
                                 asf_track=True)
        r = run.ref_objectives.get(name, math.nan) * scale
        if np.isfinite(r):
            ax.axhline(r, color=REF_COLOR, lw=0.8, ls="--", zorder=2)
        ax.set_ylabel(with_unit(name, unit))
    # two lines: long objective names (a settlement's) made one line wider than the figure
    np.atleast_1d(axes)[0].set_title(f"Search history of '{run.name}': {run.n} of {run.budget} "
                                     f"evaluations ({run.state})\nthe run minimises the ASF of "
                                     f"{', '.join(run.objectives)}")
    np.atleast_1d(axes)[-1].set_xlabel("evaluation number")
    from matplotlib.lines import Line2D

    handles.append(Line2D([], [], color=REF_COLOR, lw=0.8, ls="--",
                          label="the reference design's value"))
    np.atleast_1d(axes)[0].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                                  borderaxespad=0, frameon=False)
    fig.tight_layout()
    return save_figure(fig, out / "search-history.png")


def fig_objective_space(run: RunData, out: Path) -> tuple[Path, str]:
    """(path, note). Multi-objective: the run's first two objectives; else F_max vs E_max.

    Left: all evaluations (logarithmic axes when they span a wide range); right: a zoom on the
    Pareto front, the reference design and the reference point."""
    plt = pyplot()
    from matplotlib.ticker import FixedLocator, FuncFormatter, LogLocator

    if run.multi:
        kx, ky = run.objectives[0], run.objectives[1]
        front = run.pareto.copy()
        note = ""
        if len(run.objectives) > 2:
            note = (f"The run has {len(run.objectives)} objectives; the figure shows the first "
                    "two, the Pareto front is over all of them.")
    else:
        from ..optim.scalarise import pareto_mask

        kx, ky = "F_max", "E_max"
        F = np.column_stack([run.obj[kx], run.obj[ky]])
        F[~run.ok] = math.nan
        front = pareto_mask(F)
        note = (f"This run minimised {run.objectives[0]} alone; the objective-space figure shows "
                "all evaluations in (F_max, E_max) anyway, with the evaluations that no other "
                "beats in both (not the run's goal).")
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
            ax.scatter([target[0]], [target[1]], marker="P", s=90, color=OKABE_ITO["vermillion"],
                       edgecolor="k", zorder=5,
                       label=L(f"reference point f^r ({imp})"))
            ax.axvline(target[0], color=OKABE_ITO["vermillion"], lw=0.7, ls=":", zorder=1)
            ax.axhline(target[1], color=OKABE_ITO["vermillion"], lw=0.7, ls=":", zorder=1)
        if bi is not None:
            lab = "chosen compromise (best ASF value)" if run.multi else f"best {run.objectives[0]}"
            ax.scatter([X[bi]], [Y[bi]], marker="*", s=260, color=BEST_COLOR,
                       edgecolor="k", zorder=6,
                       label=L(f"{lab}: #{run.ids[bi]} ({fnum(X[bi], 4)} {ux}, {fnum(Y[bi], 4)} "
                               f"{uy})"))
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
        a1.set_title("zoom: "
                     "Pareto front, reference design" + (", reference point" if target else ""))
        a1.set_xlim(box[0], box[1])
        a1.set_ylim(box[2], box[3])
    fig.suptitle(f"Objective space of '{run.name}'" + ("" if run.multi else
                                                        f" (the run minimised {run.objectives[0]} "
                                                        "alone)"))
    fig.legend(*a0.get_legend_handles_labels(), loc="lower center",
               ncol=2 if box else 1, frameon=False)
    fig.tight_layout(rect=(0, 0.15 if box else 0.22, 1, 1))
    return save_figure(fig, out / "objective-space.png"), note
