"""The simulator's typed inputs (``lccopt.vti.specs``) from the validated sections of a case.

The simulator imports nothing from the config layer: whatever it needs of a case is built
here, once per simulation, from the typed mapping that :func:`lccopt.config.load_case`
validated (SI units).
"""

from __future__ import annotations

import numpy as np

from ..vti import irregularity as spectra
from ..vti import pads
from ..vti.specs import (
    ERS,
    Compound,
    EvaluationZones,
    Layout,
    Rail,
    Scenario,
    SimulationSettings,
    Slab,
    SpringDamper,
    StrengthenedSleeper,
    TrackDesign,
    TrackSpec,
    TrackVariation,
    VehicleSpec,
)
from ..vti.vehicle import DEFAULT_TYPE
from .profiles import profile_array
from .variables import split
from .zones import force_zone_end

_VEHICLE_KEYS = ("speed", "carbody_mass", "bogie_mass", "wheelset_mass", "primary_stiffness",
                 "primary_damping", "secondary_stiffness", "secondary_damping", "hertz_constant",
                 "hertz_load", "gravity", "wheelbase", "bogie_pitch_inertia",
                 "carbody_pitch_inertia", "bogie_distance")


def vehicle_spec(vehicle: dict) -> VehicleSpec:
    """The ``vehicle:`` section (or a named vehicle with its condition's speed)."""
    values = {k: vehicle.get(k) for k in _VEHICLE_KEYS}
    if values["gravity"] is None:
        del values["gravity"]
    return VehicleSpec(type=vehicle.get("type") or DEFAULT_TYPE,
                       model=vehicle.get("model") or "paper", **values)


def railpad(section: dict) -> SpringDamper:
    """The pads of the sleepers not designed: their stiffness under the wheel and damping
    (``lccopt.vti.pads``: a named pad, or as bought with its ratio)."""
    pad = pads.resolve(section)
    return SpringDamper(stiffness=pad.stiffness, damping=pad.damping)


def track_spec(track: dict) -> TrackSpec:
    """The ``track:`` section."""
    ers = track["ers"]
    ss = track["strengthened_sleeper"]
    return TrackSpec(
        rail=Rail(**track["rail"]),
        layout=Layout(**track["layout"]),
        railpad=railpad(track["railpad"]),
        sleeper_mass=track["sleeper"]["mass"],
        support=SpringDamper(**track["support"]),
        strengthened_sleeper=StrengthenedSleeper(mass=ss["mass"],
                                                 support_stiffness=ss["support_stiffness"],
                                                 support_damping=ss["support_damping"]),
        ers=ERS(slab_lengths=tuple(ers["slab_lengths"]), compound=Compound(**ers["compound"]),
                type_ii_compound=Compound(**ers["type_ii_compound"]),
                share_per_rail=ers["share_per_rail"], slab=Slab(**ers["slab"]),
                foundation=SpringDamper(**ers["foundation"])))


def track_length(data: dict) -> float:
    """Length of the modelled track [m] (the same for every design)."""
    track = data["track"]
    return float(track["layout"]["entry_length"] + sum(track["ers"]["slab_lengths"])
                 + track["layout"]["exit_length"])


def settings(simulation: dict) -> SimulationSettings:
    """The ``simulation:`` section but the rail profile."""
    return SimulationSettings(time_step=simulation["time_step"],
                              element_length=simulation["element_length"],
                              far_element_length=simulation["far_element_length"],
                              run_in=simulation["run_in"], run_out=simulation["run_out"],
                              direction=simulation.get("direction") or "enter")


def zones(evaluation: dict) -> EvaluationZones:
    """The ``evaluation:`` section (the force zone's end in either form, as a point relative
    to the layout)."""
    return EvaluationZones(sleepers=evaluation["sleepers"],
                           force_zone_end=force_zone_end(evaluation))


def spectrum_profile(irregularity: dict, length: float) -> np.ndarray:
    """The random profile of a spectrum mapping over a track of ``length`` (from its seed)."""
    scale = irregularity.get("amplitude_scale")
    return spectra.generate(irregularity["spectrum"], irregularity["seed"],
                            irregularity["wavelengths"], length, 1.0 if scale is None else scale)


def profile(data: dict) -> np.ndarray | None:
    """The rail profile (N, 2) of one simulation of a case: its rows (``points``), or
    generated from its spectrum (the same for every design), or None (a smooth rail)."""
    irregularity = data["simulation"].get("irregularity")
    if irregularity is None or irregularity == "none":
        return None
    if isinstance(irregularity, dict) and "points" in irregularity:
        return profile_array(irregularity["points"])
    if isinstance(irregularity, dict):
        return spectrum_profile(irregularity, track_length(data))
    raise ValueError(f"irregularity {irregularity!r}: a file is read by "
                     f"lccopt.config.load_case, which keeps its rows")


def scenario(data: dict, variation: TrackVariation | None = None) -> Scenario:
    """One simulation's inputs from the typed sections of a case (or of one condition), on
    the track as drawn or as one realisation (``variation``) has it."""
    return Scenario(vehicle=vehicle_spec(data["vehicle"]), track=track_spec(data["track"]),
                    settings=settings(data["simulation"]), zones=zones(data["evaluation"]),
                    irregularity=profile(data), variation=variation)


def track_design(variables, x, dynamic_to_static: float | None = None) -> TrackDesign:
    """A design vector (checked, internal units) split into its groups; designed pads entered
    as bought (``dynamic_to_static`` given) become their stiffness under the wheel."""
    g = split(variables, x)
    return TrackDesign(railpad_stiffness=pads.under_wheel(g["railpad_stiffness"],
                                                          dynamic_to_static),
                       strengthened_sleepers=float(g["strengthened_sleepers"][0]),
                       sleeper_spans=g["sleeper_spans"],
                       type_ii_strip=float(g["type_ii_strip"][0]))
