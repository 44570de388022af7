"""Drawing helpers shared by the report's and a simulation's figures: matplotlib
(Agg) set up alike, saving, log ticks, the evaluation zone's marks, brackets and sleeper ticks."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .data import DPI, ZONE_COLOR


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # No offset on an axis ("+1.104e2" above ticks of 0.005-0.025): a spread of F_rms around
    # a 110 kN static load reads as 0.015 kN; whole values are read at a glance.
    plt.rcParams.update({"font.size": 9, "axes.titlesize": 10, "legend.fontsize": 8,
                         "axes.grid": True, "grid.alpha": 0.3, "figure.dpi": DPI,
                         "axes.formatter.useoffset": False})
    return plt


def save_figure(fig, path, dpi: float = DPI):
    """Save ``fig`` as PNG to ``path``: a ``outdir.Place`` (a staged output file: drawn in
    memory, written whole, never through a link) or a plain path (benchmark scripts); return
    it."""
    import matplotlib.pyplot as plt

    try:
        if hasattr(path, "write_bytes") and not isinstance(path, Path):
            import io

            buf = io.BytesIO()
            fig.savefig(buf, format="png", dpi=dpi)
            path.write_bytes(buf.getvalue())
        else:
            fig.savefig(path, dpi=dpi)
    finally:
        plt.close(fig)
    return path


def log_ticks(lo: float, hi: float, at_least: int = 5) -> list[float]:
    """Labelled ticks for a logarithmic axis over [LO, HI]: 1-2-5, else 1-2-3-5, else every
    mantissa per decade, the first of these that puts AT_LEAST ticks in the range (matplotlib's
    own locator leaves a range inside one decade, e.g. 0.3-1.8 kN, nearly unlabelled)."""
    decades = range(int(np.floor(np.log10(lo))) - 1, int(np.ceil(np.log10(hi))) + 1)
    pad_lo, pad_hi = lo / 1.15, hi * 1.15   # matplotlib's margins show a little beyond the data
    ticks: list[float] = []
    for mantissas in ((1, 2, 5), (1, 2, 3, 5), (1, 2, 3, 4, 5, 6, 7, 8, 9)):
        ticks = [float(f"{m}e{d}") for d in decades for m in mantissas
                 if pad_lo <= m * 10.0 ** d <= pad_hi]
        if len(ticks) >= at_least:
            break
    return ticks


# Along the track every figure measures from the entry slab edge (the interface the designed
# side ends at): negative on the approach, positive over the ERS, as the track drawing and the
# settlement figures do.
ALONG_TRACK = "from the entry slab edge [m]"
_POSITIONS = ("interface_entry", "interface_exit", "zone_start", "zone_end", "type_ii_end")


def wheel_position_label(info: dict) -> str:
    """The x label of a figure of one passage along the track: the designed side is always
    on the left, so a vehicle leaving the ERS (``direction: leave``) comes from the right."""
    side = "right" if info.get("direction") == "leave" else "left"
    return f"wheel position {ALONG_TRACK} (the vehicle comes from the {side})"


def from_slab_edge(info: dict) -> tuple[float, dict]:
    """(origin, info with its positions along the track measured from the entry slab edge)."""
    origin = float(info.get("interface_entry", 0.0))
    return origin, {k: (float(v) - origin if k in _POSITIONS else v) for k, v in info.items()}


def zone_marks(ax, info: dict, xmax: float, label: bool = True):
    x_a, x_b = info.get("interface_entry"), info.get("interface_exit")
    if x_a is not None and x_b is not None:
        ax.axvspan(x_a, min(x_b, xmax), color="0.88", zorder=0,
                   label="ERS (level crossing)" if label else None)
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
    ax.text(x + 0.004, 0.5 * (lo + hi), text, color=color, ha="left", va="center",
            fontsize=8, rotation=90,
            transform=ax.get_yaxis_transform(), clip_on=False)


def sleeper_ticks(ax, positions, color: str, row: int, label: str | None) -> None:
    """Short marks at the foot of the axes at each sleeper position (ROW 0, 1: stacked)."""
    positions = np.asarray(positions, float)
    if positions.size:
        ax.vlines(positions, 0.012 + 0.035 * row, 0.042 + 0.035 * row,
                  transform=ax.get_xaxis_transform(),
                  color=color, lw=1.2, zorder=5, label=label)
