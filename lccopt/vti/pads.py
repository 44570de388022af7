"""Railpads as they are bought and as the wheel loads them.

A pad is sold by its *static* stiffness: EN 13146-9's quasi-static secant stiffness between two
loads. A passing wheel loads it within a fraction of a second, on top of the clips' toe load,
and at tens to hundreds of Hz; there it is stiffer. EN 13146-9 measures that too, as the pad's
low-frequency *dynamic* stiffness under preload, and published measurements find the
stiffness of rubber pads to rise with frequency and, more, with preload and load amplitude,
and to depend on the pad's type, temperature and age (Thompson & Verheij 1997, "The dynamic
behaviour of rail fasteners at high frequencies", Applied Acoustics 52(1); "Measurement and
modelling of resilient rubber rail-pads"; Oregui, Nunez, Dollevoet & Li, "Sensitivity analysis
of railpad parameters on vertical railway track dynamics", ASCE J. Eng. Mech.,
doi:10.1061/(ASCE)EM.1943-7889.0001207). The simulation's pad is a spring and a damper with
the stiffness under the wheel: the paper's reading ("dynamic stiffness values of railpads ...
are adopted in the simulation", Sec. 3.1).

This module turns a pad as a user enters it into that spring: the stiffness under the wheel as
given; or the static (catalogue) stiffness times the pad's dynamic-to-static ratio, both from
its EN 13146-9 test report; or a named pad whose published values it holds. It guesses no
ratio: none is published for pads in general (the ratio is the pad's own, docs/model.md).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Pad:
    """One railpad: what the simulation uses and what it was entered as."""
    stiffness: float                    # under the wheel (dynamic) [N/m]: the simulated spring
    damping: float                      # [N s/m]
    static_stiffness: float | None = None   # as bought (EN 13146-9 static) [N/m], if known
    name: str | None = None             # a named pad (NAMED_PADS)
    source: str = ""                    # where a named pad's values come from

    @property
    def ratio(self) -> float | None:
        """Dynamic-to-static stiffness ratio, if the static stiffness is known."""
        return None if self.static_stiffness is None else self.stiffness / self.static_stiffness


# Pads whose values are published, by the name a case may give (track.railpad.type).
NAMED_PADS = {
    "FC9": Pad(stiffness=1120e6, damping=120e3, name="FC9",
               source="Shang et al. 2023, Table 3: the Dutch standard 4.5 mm cork-rubber pad, "
                      "its dynamic stiffness and damping; its static stiffness is not given"),
}


def resolve(section: dict) -> Pad:
    """The pad of a checked ``track.railpad`` section (lccopt.config.checks.check_railpad):
    ``type`` (a named pad), ``stiffness`` (under the wheel; with ``static_stiffness`` if
    known) or ``static_stiffness`` with ``dynamic_to_static``; ``damping`` but for a named
    pad."""
    name = section.get("type")
    if name is not None:
        return NAMED_PADS[name]
    static = section.get("static_stiffness")
    stiffness = section.get("stiffness")
    if stiffness is None:
        stiffness = static * section["dynamic_to_static"]
    return Pad(stiffness=float(stiffness), damping=float(section["damping"]),
               static_stiffness=None if static is None else float(static))


def under_wheel(entered, dynamic_to_static: float | None):
    """The stiffness under the wheel of designed pads entered as static (catalogue) values
    with the ratio of their type, or as they are (ratio None: already under the wheel)."""
    return entered if dynamic_to_static is None else entered * dynamic_to_static
