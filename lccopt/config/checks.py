"""Checks of a validated case that need physics or the layout, beyond the schema's bounds.

Each check takes the typed sections (``data``) and ``err(key_path, message)``, which makes the
one-line :class:`~lccopt.errors.CaseError` naming the key's file and line, and raises it on
the first problem. Newmark's average-acceleration rule is unconditionally stable, so a time
step or a mesh that cannot follow the dynamics fails silently: these checks say so first.
"""

from __future__ import annotations

import numpy as np

from ..vti.irregularity import ELEMENTS_PER_SHORTEST_WAVE, STEPS_PER_SHORTEST_WAVE, band_bins
from ..vti.specs import ELEMENT_UNIT
from .build import vehicle_spec

STEPS_PER_CONTACT_PERIOD = 5  # Newmark (average acceleration) shortens nothing, but lengthens the
# period by (w dt)^2/12: 13 % at 5 steps per period of the stiffest mode that carries the
# contact force (the wheel on its Hertz spring); coarser steps alias it (time_step 0.05 gave
# E_max 2.90 J instead of 0.368 J).
VEHICLE_KEYS = {  # keys a vehicle type needs beyond the three-dof ones
    "bogie": ("wheelbase", "bogie_pitch_inertia"),
    "half-car": ("wheelbase", "bogie_pitch_inertia", "carbody_pitch_inertia", "bogie_distance"),
}
RAIL_END_MARGIN = 1.0  # [m] the leading wheel stays this far from the pinned rail ends


def is_multiple(length: float, unit: float) -> bool:
    """``length`` is a whole multiple of ``unit`` (to round-off)."""
    q = length / unit
    return abs(q - round(q)) < 1e-9 * max(1.0, q)


def check_mesh_units(data: dict, err) -> None:
    """Lengths sit on the 0.1 m grid that sleeper spans are counted in."""
    le = data["simulation"]["element_length"]
    if not is_multiple(ELEMENT_UNIT, le):
        raise err(("simulation", "element_length"), f"must divide 0.1 m exactly, got {le:g}")
    check_accuracy(data, err)
    layout = data["track"]["layout"]
    for key in ("entry_length", "exit_length", "sleeper_spacing", "exit_first_span"):
        if not is_multiple(layout[key], ELEMENT_UNIT):
            raise err(("track", "layout", key),
                      f"must be a multiple of 0.1 m, got {layout[key]:g}")
    for i, s in enumerate(data["track"]["ers"]["slab_lengths"]):
        if not is_multiple(s, ELEMENT_UNIT):
            raise err(("track", "ers", "slab_lengths", i),
                      f"must be a multiple of 0.1 m, got {s:g}")


def check_accuracy(data: dict, err) -> None:
    """Reject time steps that make the simulation inaccurate (it stays stable: Newmark's
    average-acceleration rule is unconditionally stable, so a bad step fails silently)."""
    v, sim = data["vehicle"], data["simulation"]
    dt = sim["time_step"]
    k_contact = 1.5 / v["hertz_constant"] * v["hertz_load"] ** (1.0 / 3.0)
    f_contact = np.sqrt(k_contact / v["wheelset_mass"]) / (2 * np.pi)
    limit = 1.0 / (STEPS_PER_CONTACT_PERIOD * f_contact)
    if dt > limit:
        raise err(("simulation", "time_step"),
                  f"{dt:g} s is too coarse: the wheel on its contact spring rings at "
                  f"{f_contact:.0f} Hz, which needs at least {STEPS_PER_CONTACT_PERIOD} steps per "
                  f"period (time_step <= {limit:.3g} s)")
    step = v["speed"] * dt
    if step > sim["element_length"] * (1 + 1e-9):
        raise err(("simulation", "time_step"),
                  f"{dt:g} s moves the wheel {step:.3g} m per step, more than one element "
                  f"({sim['element_length']:g} m): time_step <= "
                  f"{sim['element_length'] / v['speed']:.3g} s")
    check_vehicle_fits(data, err)
    irr = sim.get("irregularity")
    if isinstance(irr, dict):   # the shortest wave must be followed by the mesh and the time step
        shortest = irr["wavelengths"][0]
        need = max(ELEMENTS_PER_SHORTEST_WAVE * sim["element_length"],
                   STEPS_PER_SHORTEST_WAVE * step)
        if shortest < need * (1 - 1e-9):
            raise err(("simulation", "irregularity", "wavelengths"),
                      f"the shortest wavelength {shortest:g} m is below what the mesh and time "
                      f"step resolve ({need:.3g} m: {ELEMENTS_PER_SHORTEST_WAVE} elements of "
                      f"{sim['element_length']:g} m and {STEPS_PER_SHORTEST_WAVE} steps of "
                      f"{step:.3g} m)")


def check_vehicle_fits(data: dict, err) -> None:
    """The vehicle type has its keys, and the leading wheel stays on the modelled rail for the
    whole run in either direction, whatever the design (lccopt.vti.track.wheel_window; a
    trailing wheel beyond a rail end rests on a rigid continuation of the rail)."""
    v, sim = data["vehicle"], data["simulation"]
    kind = v.get("type") or "three-dof"
    for key in VEHICLE_KEYS.get(kind, ()):
        if v.get(key) is None:
            raise err(("vehicle", key), f"missing key '{key}' (vehicle type {kind} needs it)")
    if kind == "half-car" and v["bogie_distance"] <= v["wheelbase"]:
        raise err(("vehicle", "bogie_distance"),
                  f"{v['bogie_distance']:g} m must exceed the wheelbase ({v['wheelbase']:g} m): "
                  f"the bogies would overlap")
    length = vehicle_spec(v).length
    layout = data["track"]["layout"]
    slabs = data["track"]["ers"]["slab_lengths"]
    total = layout["entry_length"] + sum(slabs) + layout["exit_length"]
    zone_end = layout["entry_length"] + data["evaluation"]["force_zone_after_interface"]
    spans = data["design"]["sleeper_spans"]
    n_zone, n_near = data["evaluation"]["sleepers"], spans["count"]
    far_span = spans["bounds"][1] * ELEMENT_UNIT   # the zone reaches farthest at the upper bounds
    zone_start = layout["entry_length"] - min(n_zone, n_near) * far_span \
        - max(0, n_zone - n_near) * layout["sleeper_spacing"]
    x_b = layout["entry_length"] + sum(slabs)
    leave = (sim.get("direction") or "enter") == "leave"
    if leave:
        lowest, highest = zone_start - sim["run_out"] - length, max(zone_end, x_b) + sim["run_in"]
    else:
        lowest, highest = zone_start - sim["run_in"], zone_end + sim["run_out"] + length
    if zone_start <= 0:
        lowest = RAIL_END_MARGIN    # the zone itself does not fit: the design check says so
    if lowest < RAIL_END_MARGIN or highest > total - RAIL_END_MARGIN:
        beyond_exit = highest > total - RAIL_END_MARGIN
        key = "run_out" if beyond_exit == (not leave) else "run_in"
        raise err(("simulation", key),
                  f"the leading wheel would run from {lowest:.3g} m to {highest:.3g} m, beyond "
                  f"the modelled rail [0, {total:g}] m less {RAIL_END_MARGIN:g} m at each end "
                  f"(vehicle {length:g} m long): shorten run_in/run_out or lengthen track.layout."
                  f"{'exit_length' if beyond_exit else 'entry_length'}")


def check_layout_fits(data: dict, x: np.ndarray, variables) -> None:
    """Spans, strengthened sleepers and the strip must fit the track (raises ValueError)."""
    layout = data["track"]["layout"]
    sim = data["simulation"]
    groups: dict[str, list] = {}
    for v, xi in zip(variables, x):
        groups.setdefault(v.group, []).append(xi)
    spans = np.array(groups["sleeper_spans"]) * ELEMENT_UNIT
    ers_length = sum(data["track"]["ers"]["slab_lengths"])
    strip = groups["type_ii_strip"][0] * ELEMENT_UNIT
    if strip > ers_length + 1e-9:
        raise ValueError(f"the Type II strip ({strip:g} m) is longer than the ERS "
                         f"({ers_length:g} m)")
    n_sleepers = int((layout["entry_length"] - spans.sum()) // layout["sleeper_spacing"]) \
        + len(spans)
    if n_sleepers < max(groups["strengthened_sleepers"][0], data["evaluation"]["sleepers"]):
        raise ValueError(f"the entry side holds {n_sleepers} sleepers, fewer than the "
                         f"strengthened sleepers or the evaluation zone ask for")
    if len(groups["railpad_stiffness"]) > n_sleepers:  # the extra pads would sit on no sleeper
        raise ValueError(f"{len(groups['railpad_stiffness'])} designed railpads, but the entry "
                         f"side holds {n_sleepers} sleepers")
    need = data["evaluation"]["sleepers"] * layout["sleeper_spacing"] + spans.sum() + sim["run_in"]
    if need > layout["entry_length"] - 5.0:
        raise ValueError(f"the evaluation zone and run-in ({need:g} m) do not fit the "
                         f"{layout['entry_length']:g} m entry track with 5 m to spare")


def check_design_space(data: dict, variables, err) -> None:
    """The layout fits at the designs that reach farthest (upper bounds of the counts)."""
    farthest = np.array([v.upper if v.group in ("sleeper_spans", "type_ii_strip",
                                                "strengthened_sleepers")
                         else v.reference for v in variables])
    try:
        check_layout_fits(data, farthest, variables)
    except ValueError as exc:
        raise err(("design",), f"at the upper bounds: {exc}") from None


def check_optimisation(data: dict, err) -> None:
    """Initial design within the budget, one worst value per objective of the ASF."""
    opt = data["optimisation"]
    if opt is None:
        return
    if opt["initial_points"] > opt["budget"]:
        raise err(("optimisation", "initial_points"),
                  f"{opt['initial_points']} initial points exceed the budget of {opt['budget']}")
    worst = opt["asf"]["worst"]
    n_obj = len(opt["objectives"])
    n_each = len(data["conditions"] or []) if opt["conditions"] == "each" else 1
    if n_obj * n_each > 1:
        if worst is None:
            raise err(("optimisation", "asf"),
                      "missing key 'worst' (needed for two or more objectives)")
        if len(worst) not in (n_obj, n_obj * n_each):
            also = (f" or {n_obj * n_each} (one per objective and condition)"
                    if n_each > 1 else "")
            raise err(("optimisation", "asf", "worst"),
                      f"expected {n_obj} values (one per objective){also}, got {len(worst)}")


def spectrum_problem(spec: dict, length: float) -> tuple[str, str] | None:
    """(key, message) of the first problem of a spectrum irregularity on a track of ``length``,
    or None. Mesh and time-step limits are checked with :func:`check_accuracy`."""
    lo, hi = spec["wavelengths"]
    if not lo < hi:
        return "wavelengths", f"[min, max] must increase, got [{lo:g}, {hi:g}] m"
    if hi > length + 1e-9:
        return "wavelengths", (f"the longest wavelength {hi:g} m exceeds the track ({length:g} m), "
                               f"over which the profile is generated")
    if len(band_bins(length, (lo, hi))) == 0:
        return "wavelengths", (f"the band [{lo:g}, {hi:g}] m holds no wavelength {length:g} m / m "
                               f"(m whole) of the {length:g} m track: widen it")
    return None
