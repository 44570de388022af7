"""Figures of designs judged over realisations of the track (a case with ``uncertainty:``,
docs/robust.md): the spread of each objective over the realisations, design beside design,
with the track as drawn marked.

``fig_spread`` draws, for each objective, one column per design: a dot per realisation, the
band between the 10 % and 90 % quantiles, the mean, and the drawing's value (a diamond). The
realisations are the same tracks for every design (common random numbers), so a thin line
joins each track's values from one design to the next: solid where it falls, dotted where it
does not; under each design's name, on how many tracks it beats the first design (the
reference, or the design it is compared with) and the design left of it. A track engineer
reads at a glance how wide the spread is against the design's gain, and on how many of the
tracks the design wins.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..uncertainty import statistics as stats
from .data import BEST_COLOR, OKABE_ITO, REF_COLOR, RunData, fnum, obj_display, with_unit
from .plotting import pyplot, save_figure

NOMINAL_COLOR = OKABE_ITO["purple"]

LOW, HIGH = 0.1, 0.9      # the band drawn for each design


@dataclass
class Spread:
    """One design's values over the realisations: ``drawn`` (objective -> value on the track
    as drawn) and ``tracks`` (objective -> array, one value per realisation)."""
    label: str
    drawn: dict
    tracks: dict
    color: str


def spread_of(label: str, objectives: dict, n: int, color: str) -> Spread:
    """A design's Spread from its objectives (with each realisation's as ``F_max#r``)."""
    keys = {stats.objective_of(k) for k in objectives if stats.is_realisation_key(k)}
    return Spread(label, {k: float(objectives[k]) for k in keys if k in objectives},
                  {k: stats.values(objectives, k, n) for k in keys}, color)


def wins(design: Spread, reference: Spread, key: str) -> tuple[int, int]:
    """(tracks on which ``design`` is below the reference, tracks) for objective ``key``."""
    a, b = design.tracks[key], reference.tracks[key]
    ok = np.isfinite(a) & np.isfinite(b)
    return int(np.count_nonzero(a[ok] < b[ok])), int(np.count_nonzero(ok))


def fig_spread(designs: list[Spread], keys: list[str], out: Path, title: str,
               name: str = "robust-spread.png", first: str = "the reference") -> Path:
    """The spread figure (module docstring) of ``designs`` (the first, called ``first`` under
    the others, is the one they are compared with) for objectives ``keys``."""
    plt = pyplot()
    keys = [k for k in keys if all(k in d.tracks for d in designs)]
    n_cols = len(designs)
    width = max(1, len(keys)) * (1.3 + 1.25 * n_cols) + 0.6
    fig, axes = plt.subplots(1, max(1, len(keys)), figsize=(max(7.0, width), 5.2),
                             squeeze=False)
    n = len(designs[0].tracks[keys[0]]) if keys else 0
    for ax, key in zip(axes[0], keys):
        scale, unit = obj_display(key)
        ref = designs[0]
        for j, d in enumerate(designs):
            v = d.tracks[key] * scale
            if j > 0:   # each track from the design left of this one to this one
                left = designs[j - 1].tracks[key] * scale
                thin = v.size > 30
                for a, b in zip(left, v):
                    better = b < a
                    ax.plot([j - 1, j], [a, b], color=OKABE_ITO["green"] if better else "0.55",
                            lw=0.5 if thin else 0.8, ls="-" if better else ":",
                            alpha=0.35 if thin else 0.7, zorder=1)
            lo, hi = np.nanquantile(v, LOW), np.nanquantile(v, HIGH)
            ax.add_patch(plt.Rectangle((j - 0.17, lo), 0.34, hi - lo, color=d.color, alpha=0.25,
                                       lw=0, zorder=2))
            ax.plot([j - 0.17, j + 0.17], [np.nanmean(v)] * 2, color=d.color, lw=2, zorder=3)
            ax.scatter(np.full(v.size, j), v, s=14, color=d.color, edgecolor="white", lw=0.4,
                       zorder=4)
            if key in d.drawn:
                ax.scatter([j + 0.27], [d.drawn[key] * scale], marker="D", s=30, color="white",
                           edgecolor=d.color, lw=1.4, zorder=5)
        # under each design's name, on how many tracks it beats the reference (and the
        # design left of it): read with the design, without a band of text above the panels
        labels = [designs[0].label]
        for j, d in enumerate(designs[1:], 1):
            w, m = wins(d, ref, key)
            text = f"{d.label}\nbeats {first}\non {w} of {m} tracks"
            if j > 1:
                w2, m2 = wins(d, designs[j - 1], key)
                text += f";\nthe design left of it\non {w2} of {m2}"
            labels.append(text)
        ax.set_xticks(range(n_cols), labels, fontsize=8)
        ax.set_xlim(-0.5, n_cols - 0.4)
        ax.set_ylabel(with_unit(key, unit))
        ax.grid(axis="x", visible=False)
    # a legend of the marks, once, under the panels
    handles = [
        plt.Line2D([], [], ls="", marker="o", color="0.3", markersize=4,
                   label=f"one realisation of the track ({n})"),
        plt.Rectangle((0, 0), 1, 1, color="0.3", alpha=0.25,
                      label=f"{LOW:.0%}-{HIGH:.0%} of the realisations"),
        plt.Line2D([], [], color="0.3", lw=2, label="mean"),
        plt.Line2D([], [], ls="", marker="D", markerfacecolor="white", color="0.3",
                   label="the track as drawn"),
    ]
    if n_cols > 1:
        handles += [plt.Line2D([], [], color=OKABE_ITO["green"], lw=0.8,
                               label="same track: lower than the design to its left"),
                    plt.Line2D([], [], color="0.55", lw=0.8, ls=":",
                               label="same track: not lower")]
    fig.legend(handles=handles, loc="lower center", ncol=2, fontsize=7.5, frameon=False)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.13 if n_cols > 1 else 0.08, 1, 0.96))
    return save_figure(fig, (Path(out) if isinstance(out, str) else out) / name)


# ---------------------------------------------------------------------------- a run's designs

def is_robust(run: RunData) -> bool:
    """The run minimised statistics over the realisations (not the drawing's values)."""
    return any(stats.is_statistic(k) for k in run.objectives)


def nominal_index(run: RunData) -> int | None:
    """The evaluation a deterministic judgement would pick among the run's: the lowest value
    of the drawing's objectives (the ASF of the paper's rule for two or more: reference point
    and worst values from the reference design's values on the drawing)."""
    from ..optim.scalarise import IMPROVEMENT, RHO, asf
    from ..problem import DEFAULT_WORST_FACTOR

    bases = list(dict.fromkeys(stats.objective_of(k) for k in run.objectives))
    ri = run.ref_index()
    if any(b not in run.obj for b in bases) or ri is None:
        return None
    F = np.column_stack([run.obj[b] for b in bases])
    ok = run.ok & np.all(np.isfinite(F), axis=1)
    if not ok.any():
        return None
    if len(bases) == 1:
        score = F[:, 0]
    else:
        ref = F[ri]
        improvement = (run.improvement if np.isfinite(run.improvement or np.nan)
                       else IMPROVEMENT)
        rho = run.rho if np.isfinite(run.rho or np.nan) else RHO
        score = np.array([asf(f, (1 - improvement) * ref, DEFAULT_WORST_FACTOR * ref, rho=rho)
                          for f in F])
    score = np.where(ok, score, np.inf)
    return int(np.lexsort((run.ids, score))[0])


def run_spreads(run: RunData, bi: int, ri: int | None) -> list[Spread] | None:
    """The designs the report compares over the realisations: the reference design, the
    nominal optimum of the run (when it differs from the best: ``nominal_index``) and the
    best design; None without realisations."""
    if not run.realisations or ri is None or not run.real_obj:
        return None

    def spread(i: int, label: str, color: str) -> Spread:
        return Spread(label, {k: float(run.obj[k][i]) for k in run.real_obj if k in run.obj},
                      {k: np.asarray(v[i], dtype=float) for k, v in run.real_obj.items()},
                      color)

    designs = [spread(ri, "reference", REF_COLOR)]
    robust = is_robust(run)
    ni = nominal_index(run) if robust else None
    if ni is not None and ni not in (bi, ri):
        designs.append(spread(ni, f"nominal\noptimum #{run.ids[ni]}", NOMINAL_COLOR))
    if bi != ri:
        designs.append(spread(bi, f"{'robust' if robust else 'best'}\noptimum #{run.ids[bi]}",
                              BEST_COLOR))
    return designs


def spread_keys(run: RunData) -> list[str]:
    """The objectives drawn: those the run's objectives measure, else F_max and E_max."""
    keys = list(dict.fromkeys(stats.objective_of(k) for k in run.objectives))
    keys = [k for k in keys if k in run.real_obj] or [k for k in ("F_max", "E_max")
                                                       if k in run.real_obj]
    return keys[:4]


def quantile_level(run: RunData) -> float:
    levels = [stats.parse(k)[2] for k in run.objectives
              if stats.parse(k) is not None and stats.parse(k)[0] == "quantile"]
    return levels[0] if levels else stats.DEFAULT_QUANTILE


def robust_section(doc, run: RunData, designs: list[Spread], figs: dict) -> dict:
    """The report's section on the realisations: what varied, each design's values on the
    drawing and over the realisations, on how many tracks each beats the reference design,
    the nominal optimum beside the robust one; the numbers for summary.json."""
    n = run.realisations
    q = quantile_level(run)
    keys = spread_keys(run)
    rec = run.real_record or {}
    doc.h(2, "Over the realisations of the track")
    what = ""
    if run.case is not None and run.case.realisations:
        from ..config.uncertainty import uncertainty_lines

        what = "; ".join(line.strip() for line in uncertainty_lines(run.case, cost=False)[1:])
    doc.p(f"Every design was simulated on the track as drawn and on the same {n} realisations "
          f"of it (common random numbers: seed {rec.get('seed', '?')}, fingerprint "
          f"`{rec.get('fingerprint', '?')}`; docs/robust.md)" + (f": {what}." if what else ".")
          + " On each track a design either beats the reference design or does not; the "
            "probability of beating it is the fraction of tracks on which it does.")
    rows, out = [], {}
    for d in designs:
        out[d.label.replace("\n", " ")] = entry = {}
        for k in keys:
            s_, unit = obj_display(k)
            v = d.tracks[k]
            w, m = wins(d, designs[0], k)
            entry[k] = {"drawn": d.drawn.get(k, float("nan")), "mean": stats.mean(v),
                        f"q{round(q * 100)}": stats.quantile(v, q), "beats_reference": w,
                        "tracks": m}
            rows.append([d.label.replace("\n", " "), with_unit(k, unit),
                         fnum(d.drawn.get(k, float("nan")) * s_, 4), fnum(stats.mean(v) * s_, 4),
                         fnum(stats.quantile(v, q) * s_, 4),
                         "–" if d is designs[0] else f"{w} of {m} ({w / m:.0%})"])
    doc.table(["design", "objective", "as drawn", "mean", f"{q:.0%} quantile",
               "beats the reference on"], rows, "llrrrr")
    labels = [d.label.replace("\n", " ") for d in designs]
    if len(designs) == 3 and is_robust(run):
        nom, rob = designs[1], designs[2]
        parts = []
        for k in keys:
            s_, unit = obj_display(k)
            a, b = stats.quantile(nom.tracks[k], q), stats.quantile(rob.tracks[k], q)
            parts.append(f"{k} {fnum(a * s_, 4)} against {fnum(b * s_, 4)} {unit}")
        doc.p(f"The {labels[1]} is the design this run would pick by the drawing alone; over "
              f"the realisations its {q:.0%} quantiles are " + "; ".join(parts)
              + f" for the {labels[2]}.")
    if is_robust(run):
        doc.p("Before building the optimum: the run's own tracks favour the designs it chose. "
              "Optimise the case for the drawing as well, simulate this optimum against that "
              "run's on 16 realisations neither run saw (`lccopt simulate CASE --design "
              "\"<this optimum>\" --against \"<the nominal optimum>\" --set "
              "uncertainty.seed=<another> --set uncertainty.realisations=16`, each design as "
              "`lccopt status` prints it) and keep this optimum only if its quantile comes out "
              "clearly lower; otherwise the nominal one (docs/robust.md, \"Using it\": on 12 "
              "seeds of the study this choice was never worse than the nominal optimum; a "
              "robust optimum alone was worse on 8).")
    if "robust-spread" in figs:
        doc.fig(figs["robust-spread"],
                f"Each objective over the {n} realisations (dots), {LOW:.0%}-{HIGH:.0%} band, "
                "mean (bar) and the track as drawn (diamond), for the reference design, the "
                "run's nominal optimum (where it differs) and the optimum; a line joins each "
                "track's values from one design to the next, solid where it falls.")
    return out
