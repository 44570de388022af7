"""Figures of one simulation (``lccopt simulate``): contact force along the track, energy per
zone sleeper, wheel and rail displacement (matplotlib, Agg).

Drawn in the report's colours and with its marks (``plotting.range_bracket``,
``plotting.sleeper_ticks``), so that a simulation and a run's report read alike.
"""

from __future__ import annotations

import numpy as np

from ..vti.response import Evaluation
from .data import OKABE_ITO, TYPE_II_COLOR
from .plotting import (
    from_slab_edge,
    range_bracket,
    sleeper_ticks,
    speed_text,
    wheel_position_label,
    zone_marks,
)

FILES = ("contact_force.png", "sleeper_energy.png", "displacement.png")


def simulation_figures(ev: Evaluation, name: str, out) -> list:
    """Write contact_force.png, sleeper_energy.png and displacement.png of one simulation
    (``name``: the case's, for the titles) into ``out`` (a folder's path, or an
    ``outdir.Staged`` folder); return their paths."""
    from .plotting import pyplot, save_figure

    plt = pyplot()   # the report's style: whole values on the axes, the same fonts and grid
    paths = []
    for draw, file in zip((_contact_force, _sleeper_energy, _displacement), FILES):
        paths.append(save_figure(draw(plt, ev, name), out / file, dpi=120))
    return paths


def _along_track(plt, ev: Evaluation, height: float):
    """A figure along the track: positions from the entry slab edge (the wheel's, ``x``), the
    ERS, the force evaluation zone and the Type II strip marked as the report's figures mark
    them. Returns the figure, its axes, ``x``, the origin and the facts so measured."""
    origin, info = from_slab_edge(ev.info)
    x = ev.histories["wheel_position"] - origin
    fig, ax = plt.subplots(figsize=(9, height))
    zone_marks(ax, info, float(x.max()))
    if info["type_ii_end"] > info["interface_entry"]:
        ax.axvspan(info["interface_entry"], info["type_ii_end"], ymin=0.025, ymax=0.05,
                   color=TYPE_II_COLOR, label="Type II strip")
    ax.set_xlabel(wheel_position_label(info))
    return fig, ax, x, origin, info


def _contact_force(plt, ev: Evaluation, name: str):
    h = ev.histories
    fig, ax, x, origin, info = _along_track(plt, ev, 4.6)
    speed = speed_text(info)
    f = h["contact_force"] / 1e3
    fw = h.get("contact_force_wheels")
    several = fw is not None and fw.ndim == 2 and fw.shape[1] > 1
    if several:  # trailing wheels, each at its position
        xw, inw = h["wheel_positions"] - origin, h["in_force_zone_wheels"].astype(bool)
        for j in range(1, fw.shape[1]):
            ax.plot(xw[:, j], fw[:, j] / 1e3, lw=0.6, color=OKABE_ITO["sky"], alpha=0.7,
                    label="trailing wheels" if j == 1 else None)
        lo, hi = float(fw[inw].min()) / 1e3, float(fw[inw].max()) / 1e3   # F_max: all wheels
    else:
        zone = (x >= info["zone_start"]) & (x <= info["zone_end"])
        lo, hi = float(f[zone].min()), float(f[zone].max())
    ax.plot(x, f, lw=0.9, color=OKABE_ITO["blue"],
            label="contact force (leading wheel)" if several else "contact force")
    ax.hlines([lo, hi], info["zone_start"], info["zone_end"], color=OKABE_ITO["blue"], lw=0.7,
              ls="--")
    range_bracket(ax, 0, lo, hi, OKABE_ITO["blue"], "F_max")
    ax.axhline(info["static_wheel_load"] / 1e3, color="k", ls=":", lw=0.8,
               label="static wheel load")
    sleeper_ticks(ax, h["entry_sleeper_position"] - origin, "0.3", 0, "sleepers")
    ax.set(ylabel="wheel-rail contact force [kN]",
           title=f"case {name}" + (f" at {speed}" if speed else "")
                 + f": F_max = {ev.objectives['F_max'] / 1e3:.2f} kN (max - min in the zone), "
                 f"F_rms = {ev.objectives['F_rms'] / 1e3:.2f} kN", xlim=(x.min(), x.max()))
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 0.96, 1))
    return fig


def _sleeper_energy(plt, ev: Evaluation, name: str):
    from matplotlib.patches import Patch

    h = ev.histories
    fig, ax = plt.subplots(figsize=(9, 4.4))
    e = h["sleeper_energy"]
    n = np.arange(1, len(e) + 1)
    strengthened = h["sleeper_strengthened"] > 0
    # strengthened sleepers differ in colour and hatching, so the two read apart without colour
    ax.bar(n[~strengthened], e[~strengthened], color=OKABE_ITO["sky"], edgecolor="k", lw=0.5)
    ax.bar(n[strengthened], e[strengthened], color=OKABE_ITO["vermillion"], edgecolor="k",
           lw=0.5, hatch="///")
    ax.hlines([e.min(), e.max()], 0.3, len(e) + 0.7, color="k", lw=0.7, ls="--")
    range_bracket(ax, 0, float(e.min()), float(e.max()), "k", "E_max")
    ax.set(xlabel="sleeper number (1 = next to the interface)",
           ylabel="energy dissipated in support [J]",
           title=f"E_max = {ev.objectives['E_max']:.4f} J (max - min), "
                 f"E_rms = {ev.objectives['E_rms']:.4f} J",
           xticks=n, xlim=(0.3, len(e) + 0.7))
    ax.legend(handles=[Patch(facecolor=OKABE_ITO["vermillion"], edgecolor="k", hatch="///",
                             label="strengthened sleeper"),
                       Patch(facecolor=OKABE_ITO["sky"], edgecolor="k", label="standard sleeper")],
              loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 0.96, 1))
    return fig


def _displacement(plt, ev: Evaluation, name: str):
    h = ev.histories
    fig, ax, x, _, info = _along_track(plt, ev, 4.4)
    speed = speed_text(info)
    ax.plot(x, h["wheel_displacement"] * 1e3, lw=0.9, color=OKABE_ITO["blue"], label="wheel")
    ax.plot(x, h["rail_displacement"] * 1e3, lw=0.9, color=OKABE_ITO["vermillion"],
            label="rail under the wheel")
    ax.invert_yaxis()
    ax.set(ylabel="displacement, downward [mm]",
           title="wheel and rail displacement" + (f" at {speed}" if speed else ""))
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=5, fontsize=8, frameon=False)
    fig.tight_layout()
    return fig
