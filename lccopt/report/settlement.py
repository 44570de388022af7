"""Settlement figures and sentences: a design's settlement prediction (the ``settlement_*``
histories of :mod:`lccopt.degradation.assessment`) drawn for ``lccopt report`` (best and
reference design), ``lccopt simulate`` (one design) and benchmarks/settlement/settlement_study.py
(the study's designs side by side).

    settlement-history.png   settlement of every settling sleeper against axle passes, one
                             panel per design; below, the limit's measure and the largest
                             void against axle passes (years on the top axis)
    settlement-profile.png   the ballast's settlement and the rail's level at rest along the
                             zone at chosen times (top), the voids under the sleepers (bottom)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..vti.response import OBJECTIVE_DOC, SETTLEMENT_OBJECTIVES
from .data import BEST_COLOR, DPI, OKABE_ITO, fnum

# What each settlement objective measures, for the report's summary (docs/settlement.md); a
# state measure is taken at the horizon, or for a tamped track at its worst over the horizon
# (SettlementResult.objectives): {when} and {force_when} say which.
MEANING = {
    "level_d1_max": "the largest deviation of the rail's longitudinal level in EN 13848's D1 "
                    "band (wavelengths 3-25 m) over the approach and the ERS {when}: "
                    "what a track recording car reports as an isolated defect",
    "level_d1_std": "the standard deviation of the rail's D1 level over the approach and the "
                    "ERS {when} (EN 13848-6 takes it over 200 m sections: there it "
                    "would be smaller by the root of the window's share of 200 m)",
    "rail_step": "how far the rail sits below its level at the slab's edge within 3 m of the "
                 "approach {when} (the slab's own settlement included)",
    "rail_angle": "the largest slope of the rail within 3 m either side of the interface "
                  "{when}, in mm/m: the ramp a wheel runs down off the slab",
    "differential_settlement": "the largest minus the smallest settlement of the settling "
                               "sleepers' ballast {when}: how uneven the approach has "
                               "become (the slab is not in it; reported, not what the rail "
                               "does)",
    "max_settlement": "the largest settlement of a settling sleeper {when}",
    "max_void": "the largest gap between a sleeper and its ballast at rest {when}: a "
                "hanging sleeper, held up by the rail",
    "level_std": "the standard deviation of the rail's level at rest (its own weight) over the "
                 "settling zone and 3 m either side, {when} (not the EN 13848 band "
                 "over 200 m)",
    "force_growth": "the largest wheel-rail force {force_when} over the new track's: how "
                    "much the settled geometry amplifies the dynamic load",
    "maintenance_rate": "1 / years_to_limit: how often the limit is reached, in 1/year "
                        "(the minimised form of a life: smaller is better)",
    "interventions": "the tampings over the horizon (each when the limit was reached; the "
                     "sleepers next to the slab out of the machine's reach are not lifted)",
    "years_to_limit": "years until the limit's measure first reaches its value: the first "
                      "tamping, if the track is tamped (the horizon if it never does)",
}
TIMES = (1 / 12, 1.0, 3.0, 10.0, 30.0, 100.0)    # [year] candidate times of the profiles
STYLES = ("-", "--", ":", "-.")                 # designs side by side, in this order


@dataclass
class Design:
    """One design's prediction as a figure shows it."""
    label: str
    histories: dict
    info: dict
    color: str = BEST_COLOR
    style: str = "-"

    @property
    def interface(self) -> float:
        return float(self.info.get("interface_entry", 0.0))


def has_settlement(histories: dict | None) -> bool:
    """Whether ``histories`` hold a settlement prediction.

    Parameters
    ----------
    histories
        an evaluation's histories, or None.

    Returns
    -------
    bool
    """
    return histories is not None and "settlement_sleepers" in histories


def chosen_years(horizon: float) -> list[float]:
    """The times of the profile figure.

    Parameters
    ----------
    horizon
        the prediction's horizon [year].

    Returns
    -------
    list of float
        up to three of a month, 1, 3, 10, 30, 100 years within the horizon (the last three),
        and the horizon itself.
    """
    picked = [t for t in TIMES if t < horizon * (1 - 1e-9)][-3:]
    return picked + [float(horizon)]


def at_years(h: dict, key: str, years) -> np.ndarray:
    """A settlement history at given times, linear between the blocks.

    Parameters
    ----------
    h
        an evaluation's histories with ``settlement_years``.
    key
        the history (blocks x ...).
    years
        the times [year].

    Returns
    -------
    numpy.ndarray
        (len(years), ...) values.
    """
    t = np.asarray(h["settlement_years"], float)
    v = np.asarray(h[key], float)
    flat = v.reshape(len(t), -1)
    out = np.array([[np.interp(y, t, flat[:, j]) for j in range(flat.shape[1])] for y in years])
    return out.reshape((len(years),) + v.shape[1:])


def _plt():
    from .plotting import pyplot as plt

    return plt()


def _from_slab(d: Design) -> np.ndarray:
    return np.asarray(d.histories["settlement_sleeper_x"], float) - d.interface


def fig_settlement_history(designs: list[Design], out: Path, title: str,
                           limit: tuple[str, float] | None = None) -> Path:
    """Settlement per sleeper against axle passes, one panel per
    design (colour: distance from the slab); below, the limit's measure and the largest void
    of every design, with the limit.

    Parameters
    ----------
    designs
        the designs side by side.
    out
        the directory to write ``settlement-history.png`` into.
    title
        the figure's title.
    limit
        (measure, value [m]) of the limit, or None (the differential settlement is drawn).

    Returns
    -------
    pathlib.Path
        the PNG written.
    """
    plt = _plt()
    from matplotlib import cm
    from matplotlib.colors import Normalize

    n = len(designs)
    fig = plt.figure(figsize=(4.4 * n + 2.2, 7.6), layout="constrained")
    grid = fig.add_gridspec(2, n, height_ratios=[1.35, 1])
    top = [fig.add_subplot(grid[0, j]) for j in range(n)]
    for ax in top[1:]:
        ax.sharey(top[0])
    dist = np.concatenate([_from_slab(d) for d in designs])
    norm = Normalize(vmin=float(dist.min()), vmax=float(dist.max()))
    cmap = cm.viridis
    for ax, d in zip(top, designs):
        h = d.histories
        p = np.asarray(h["settlement_axle_passes"], float)
        s = np.asarray(h["settlement_sleepers"], float) * 1e3
        keep = p > 0
        for j, x in enumerate(_from_slab(d)):
            ax.plot(p[keep], s[keep, j], color=cmap(norm(x)), lw=1.0)
        sim = np.asarray(h["settlement_simulated"], bool) & keep
        ax.plot(p[sim], np.zeros(sim.sum()), "|", color="k", ms=8,
                label="simulated passages")
        ax.set_xscale("log")
        _time_marks(ax, h, labels=False)
        sims = d.info.get("settlement_simulations") or int(np.sum(sim))
        ax.set(title=f"{d.label}: {sims} simulations", xlabel="axle passes")
        ax.legend(loc="lower left", frameon=False)
    top[0].set_ylabel("settlement of each settling sleeper [mm]")
    top[0].invert_yaxis()
    bar = fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), ax=top, pad=0.01)
    bar.set_label("sleeper position from the slab edge [m]")
    _measures_panel(fig.add_subplot(grid[1, :]), designs, limit)
    fig.suptitle(title)
    return _save(fig, out / "settlement-history.png")


def _measures_panel(ax, designs: list[Design], limit) -> None:
    """The limit's measure (solid) and the largest void (dashed) of each design against
    axle passes, the limit as a line; years on the top axis."""
    name = limit[0] if limit else "differential_settlement"
    for d in designs:
        h = d.histories
        p = np.asarray(h["settlement_axle_passes"], float)
        keep = p > 0
        m = _measure(h, name) * 1e3
        v = np.asarray(h["settlement_void"], float).max(axis=1) * 1e3
        ax.plot(p[keep], m[keep], color=d.color, lw=1.8, label=f"{d.label}: {name}")
        if name != "max_void":    # else the solid line is it already
            ax.plot(p[keep], v[keep], color=d.color, lw=1.2, ls="--",
                    label=f"{d.label}: max_void")
        tamped = np.asarray(h.get("settlement_tamped", np.zeros(len(p))), bool)
        for j, at in enumerate(p[tamped]):
            ax.axvline(at, color=d.color, lw=1.0, ls=d.style if d.style != "-" else "-.",
                       alpha=0.8, label=f"{d.label}: tamped" if j == 0 else None)
    if limit:
        ax.axhline(limit[1] * 1e3, color=OKABE_ITO["vermillion"], lw=1.0, ls=":",
                   label=f"limit: {name} {limit[1] * 1e3:g} mm")
    ax.set_xscale("log")
    _time_marks(ax, designs[0].histories, labels=True)
    ax.set(xlabel="axle passes", ylabel="[mm]")
    # below the axis, clear of the curves, the limit line and the time labels above
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), frameon=False, fontsize=7.5,
              ncol=3)


def _time_marks(ax, h: dict, labels: bool) -> None:
    """Dotted lines at a day, a week, a month, a year, ... of the traffic (passes are
    proportional to time)."""
    t = np.asarray(h["settlement_years"], float)
    per = float(np.asarray(h["settlement_axle_passes"], float)[-1]) / t[-1]
    at, texts = [], []
    for years, text in ((1 / 365, "1 day"), (7 / 365, "1 week"), (1 / 12, "1 month"),
                        (1.0, "1 year"), (10.0, "10 years"), (100.0, "100 years")):
        if years * per < 2.0 or years > t[-1] * 1.0001:
            continue
        ax.axvline(years * per, color="0.6", lw=0.7, ls=":", zorder=1)
        at.append(years * per)
        texts.append(text)
    if labels and at:
        # on an axis of their own above the panel: inside it they ran into the legend, the
        # curves and the limit line
        from matplotlib.ticker import NullLocator

        at, texts = _apart(ax, at, texts, fontsize=7)
        top = ax.secondary_xaxis("top")
        top.set_xticks(at, texts, fontsize=7, color="0.35")
        top.xaxis.set_minor_locator(NullLocator())
        top.tick_params(length=3, color="0.6")


def _apart(ax, at: list, texts: list, fontsize: float) -> tuple[list, list]:
    """The time labels that fit side by side on AX's log axis, the longer times first (on a
    long horizon "1 week" and "1 month" would touch): each label's width estimated from its
    characters, against the axes' width in the figure."""
    lo, hi = (np.log10(v) for v in ax.get_xlim())
    inches = ax.get_position().width * ax.figure.get_figwidth()
    per_inch = (hi - lo) / max(inches, 1e-9)                 # decades per inch
    half = [0.5 * (0.6 * fontsize * len(t) / 72.0 + 0.08) * per_inch for t in texts]
    kept: list[int] = []
    for i in reversed(range(len(at))):
        if not kept or np.log10(at[kept[-1]]) - half[kept[-1]] >= np.log10(at[i]) + half[i]:
            kept.append(i)
    kept.reverse()
    return [at[i] for i in kept], [texts[i] for i in kept]


def _measure(h: dict, name: str) -> np.ndarray:
    """A SettlementResult measure from the stored histories."""
    if f"settlement_{name}" in h:
        return np.asarray(h[f"settlement_{name}"], float)
    s = np.asarray(h["settlement_sleepers"], float)
    if name == "differential_settlement":
        return np.ptp(s, axis=1)
    if name == "max_settlement":
        return s.max(axis=1)
    if name == "max_void":
        return np.asarray(h["settlement_void"], float).max(axis=1)
    return np.asarray(h["settlement_level"], float).std(axis=1)


def fig_settlement_profile(designs: list[Design], out: Path, title: str,
                           years: list[float] | None = None) -> Path:
    """The ballast's settlement at the sleepers (markers) and the
    rail's level at rest (thin) along the zone at chosen times (colour), designs by line
    style; the voids below.

    Parameters
    ----------
    designs, out, title
        as :func:`fig_settlement_history`; the file written is ``settlement-profile.png``.
    years
        the times [year]; default :func:`chosen_years` of the first design's horizon.

    Returns
    -------
    pathlib.Path
        the PNG written.
    """
    plt = _plt()
    horizon = float(np.asarray(designs[0].histories["settlement_years"], float)[-1])
    years = years or chosen_years(horizon)
    colors = plt.get_cmap("plasma")(np.linspace(0.0, 0.8, len(years)))
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 7.4), sharex=True,
                                 gridspec_kw={"height_ratios": [1.6, 1]})
    for d in designs:
        h, style = d.histories, d.style
        x = _from_slab(d)
        lx = np.asarray(h["settlement_level_x"], float) - d.interface
        s = at_years(h, "settlement_sleepers", years) * 1e3
        v = at_years(h, "settlement_void", years) * 1e3
        lev = at_years(h, "settlement_level", years) * 1e3
        for t, c, sy, vy, ly in zip(years, colors, s, v, lev):
            lab = f"{d.label}, {_years_text(t)}"
            a1.plot(x, -sy, style, color=c, marker="o", ms=3, lw=1.4, label=lab)
            a1.plot(lx, -ly, style, color=c, lw=0.7, alpha=0.7)
            a2.plot(x, vy, style, color=c, marker="o", ms=3, lw=1.2, label=lab)
    right = max(float(np.max(d.histories["settlement_level_x"])) - d.interface for d in designs)
    for ax in (a1, a2):
        ax.axvspan(0.0, right + 0.5, color="0.88", zorder=0)
        ax.axvline(0.0, color="0.3", lw=0.9)
        ax.set_xlim(right=right + 0.5)
    slab = designs[0].histories.get("settlement_slab")
    said = ("slab (ERS): the rail's level\nwith the slab's own settlement" if slab is not None
            else "slab (ERS):\nno settlement")
    a1.text(0.1, 0.02, said, transform=a1.get_xaxis_transform(), fontsize=8, color="0.3")
    a1.set(ylabel="lowering (settlement) [mm]",
           title="ballast under each sleeper (markers) and the rail's level at rest (thin)")
    a2.set(xlabel="position from the slab edge [m] (the designed side left, the slab right)",
           ylabel="void under the sleeper [mm]", title="voids: sleepers hanging from the rail")
    a1.legend(loc="lower left", frameon=False, fontsize=7.5, ncol=max(1, len(designs)))
    fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, out / "settlement-profile.png")


def _years_text(t: float) -> str:
    if t < 1.0:
        m = t * 12
        return f"{m:.3g} month" + ("" if abs(m - 1) < 1e-9 else "s")
    return f"{t:.3g} year" + ("" if t == 1.0 else "s")


def _save(fig, path: Path) -> Path:
    from .plotting import save_figure as save

    fig.dpi = DPI
    return save(fig, path)


def facts(d: Design) -> str:
    """One sentence on a design's prediction: the dip, the hanging sleepers, the
    limit.

    Parameters
    ----------
    d
        the design.

    Returns
    -------
    str
    """
    h, info = d.histories, d.info
    s = np.asarray(h["settlement_sleepers"], float)[-1]
    v = np.asarray(h["settlement_void"], float)[-1]
    x = _from_slab(d)
    j = int(np.argmax(s))
    hanging = int(np.sum(v > 0.5e-3))
    years = float(np.asarray(h["settlement_years"], float)[-1])
    out = (f"{d.label}: after {_years_text(years)} the ballast has settled most "
           f"{abs(x[j]):.2f} m from the slab ({fnum(s[j] * 1e3, 3)} mm), least "
           f"{abs(x[int(np.argmin(s))]):.2f} m from it ({fnum(s.min() * 1e3, 3)} mm); "
           f"{hanging} sleeper(s) hang over a void of more than 0.5 mm (largest "
           f"{fnum(v.max() * 1e3, 3)} mm, {abs(x[int(np.argmax(v))]):.2f} m from the slab)")
    measure, value = info.get("settlement_limit_measure"), info.get("settlement_limit_value")
    tamped = np.asarray(h.get("settlement_tamped", np.zeros(len(s))), bool)
    t = np.asarray(h["settlement_years"], float)[tamped]
    if info.get("settlement_tamping") and t.size:
        # a tamping is done at the end of the block that reaches the limit: its time is the
        # years_to_limit of a tamped track, so the limit is said through the tampings
        shown = ", ".join(_years_text(float(v)) for v in t[:6]) + (", ..." if t.size > 6
                                                                    else "")
        out += (f"; tamped {t.size} time{'s' if t.size > 1 else ''} over the horizon, each "
                f"when {measure} reached {value * 1e3:g} mm (after {shown})")
    elif measure and value:
        reached = info.get("settlement_limit_reached")
        out += (f"; {measure} reaches {value * 1e3:g} mm after "
                f"{_limit_years(h, measure, value)}" if reached else
                f"; {measure} stays below {value * 1e3:g} mm over the horizon")
        if info.get("settlement_tamping"):
            out += "; never tamped over the horizon"
    if info.get("settlement_tamping") and float(info.get("settlement_tamping_ineffective",
                                                         -1.0)) >= 0:
        when = _years_text(float(info["settlement_tamping_ineffective"]))
        out += (f"; a tamping after {when} left the limit reached (the sleepers out of "
                f"reach): tamping ended there")
    sims = info.get("settlement_simulations")
    return out + (f" ({sims} simulations)." if sims else ".")


def _limit_years(h: dict, measure: str, value: float) -> str:
    m = _measure(h, measure)
    t = np.asarray(h["settlement_years"], float)
    hit = np.flatnonzero(m >= value)
    if not hit.size:
        return "never"
    i = int(hit[0])
    y = 0.0 if i == 0 else t[i - 1] + (value - m[i - 1]) / (m[i] - m[i - 1]) * (t[i] - t[i - 1])
    return _years_text(float(y))


def meaning_items(limit: tuple[str, float] | None, tamped: bool = False) -> list[str]:
    """The settlement objectives and what each measures.

    Parameters
    ----------
    limit
        (measure, value [m]) that years_to_limit counts to, said where it counts; or None.
    tamped
        whether the track is tamped (its state measures are then its worst over the horizon).

    Returns
    -------
    list of str
        one Markdown item per objective.
    """
    out = []
    for k in (*SETTLEMENT_OBJECTIVES, "years_to_limit"):
        text = MEANING.get(k, OBJECTIVE_DOC.get(k, k)).format(
            when="at its worst over the horizon" if tamped else "at the horizon",
            force_when="over the horizon" if tamped else "of the last simulation")
        if limit and k in ("maintenance_rate", "years_to_limit"):
            text += f"; the limit: {limit[0]} reaching {limit[1] * 1e3:g} mm"
        out.append(f"**{k}**: {text}")
    return out


def limit_of(info: dict) -> tuple[str, float] | None:
    """The limit a prediction counted to, from its info.

    Parameters
    ----------
    info
        an evaluation's info (``settlement_limit_measure``, ``settlement_limit_value``).

    Returns
    -------
    tuple of (str, float) or None
    """
    m, v = info.get("settlement_limit_measure"), info.get("settlement_limit_value")
    return (str(m), float(v)) if m and v and math.isfinite(float(v)) else None
