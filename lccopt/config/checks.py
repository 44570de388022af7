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
from ..vti.vehicle import vehicle_length, vehicle_type
from .build import spectrum_profile, track_length, vehicle_spec
from .profiles import MAX_DIP, cover_problem, profile_array
from .schema import DEFAULT_INITIAL_POINTS
from .zones import zone_end_x

STEPS_PER_CONTACT_PERIOD = 5  # Newmark (average acceleration) shortens nothing, but lengthens the
# period by (w dt)^2/12: 13 % at 5 steps per period of the stiffest mode that carries the
# contact force (the wheel on its Hertz spring); coarser steps alias it (time_step 0.05 gave
# E_max 2.90 J instead of 0.368 J).
RAIL_END_MARGIN = 1.0  # [m] the leading wheel stays this far from the pinned rail ends
# [m] every wheel starts this far inside the modelled rail: a wheel that starts beyond a rail
# end, or at it, rolls onto (or away from) the pinned end and shakes the vehicle through the
# run (the VIRM half car: F_max and E_max off by up to 8 % and 12 %; from 2 m inside,
# unchanged to four digits: docs/model.md, "Traffic conditions")
START_MARGIN = 2.0

# What one simulation can do. Measured on this machine's reference case and VIRM half car
# (one core; memory as the peak resident size above the interpreter's): ~1.1 kB per time step
# (the histories), ~5.5 kB per track dof (matrices, factors, the static solve), and for a
# vehicle of several wheels 16 bytes per dof for every element its wheels span on the fine
# mesh (the cached rows U^-T e_j: 0.6 GB for the half car at 1 cm elements); ~40 ns per step
# and dof.
MAX_STEPS = 500_000         # time steps of one simulation: ~0.55 GB of histories
MAX_MEMORY = 2e9            # [bytes] of one simulation (a worker process)
MAX_STEP_DOFS = 1e10        # steps x track dofs of one simulation: ~7 minutes
BYTES_PER_STEP, BYTES_PER_DOF = 1100, 5500
# and what one design's simulations (all its traffic conditions) can do together: `lccopt
# simulate` keeps every condition's histories until it writes them
MAX_DESIGN_STEPS = 2_000_000
MAX_DESIGN_STEP_DOFS = 5e10  # ~35 minutes per design


def is_multiple(length: float, unit: float) -> bool:
    """``length`` is a whole multiple of ``unit`` (to round-off)."""
    q = length / unit
    return abs(q - round(q)) < 1e-9 * max(1.0, q)


def check_railpad(data: dict, err) -> None:
    """``track.railpad`` gives its pad one way: a named pad alone; or its stiffness under the
    wheel (with its static stiffness if known); or its static stiffness and ratio; with its
    damping but for a named pad. A static stiffness above the one under the wheel is refused:
    elastomers stiffen with the rate of loading, so a pad is no softer under the wheel than
    bought (lccopt/vti/pads.py)."""
    pad = data["track"]["railpad"]
    at = ("track", "railpad")
    given = [k for k in ("type", "stiffness", "static_stiffness", "dynamic_to_static",
                         "damping") if pad.get(k) is not None]
    if "type" in given:
        if len(given) > 1:
            raise err(at + (given[1],), f"the named pad '{pad['type']}' sets the pad's values: "
                                        f"give type alone (over a base case's values: "
                                        f"{given[1]}: null)")
        return
    if "stiffness" in given and "dynamic_to_static" in given:
        raise err(at + ("dynamic_to_static",), "give the stiffness under the wheel or "
                                               "static_stiffness x dynamic_to_static, not both "
                                               "(over a base case's stiffness: stiffness: null)")
    if "stiffness" not in given:
        as_bought = [k for k in ("static_stiffness", "dynamic_to_static") if k in given]
        if not as_bought:
            raise err(at, "missing key 'stiffness' (the pad's stiffness under the wheel), or "
                          "'type' (a named pad), or 'static_stiffness' and 'dynamic_to_static'")
        if len(as_bought) == 1:
            other = ({"static_stiffness", "dynamic_to_static"} - set(as_bought)).pop()
            raise err(at, f"missing key '{other}': the stiffness under the wheel is "
                          f"static_stiffness x dynamic_to_static (or give it as 'stiffness')")
    elif "static_stiffness" in given and pad["static_stiffness"] > pad["stiffness"]:
        raise err(at + ("static_stiffness",),
                  f"{pad['static_stiffness'] / 1e6:g} MN/m is above the stiffness under the "
                  f"wheel ({pad['stiffness'] / 1e6:g} MN/m): a pad is no softer under the "
                  f"wheel than bought")
    if "damping" not in given:
        raise err(at, "missing key 'damping'")


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
                  f"{dt:g} s moves the wheel {step:.3g} m per step at {v['speed'] * 3.6:.4g} "
                  f"km/h (vehicle.speed), more than one element ({sim['element_length']:g} m): "
                  f"time_step <= {sim['element_length'] / v['speed']:.3g} s")
    check_vehicle_fits(data, err)
    check_size(data, err)
    irr = sim.get("irregularity")
    if isinstance(irr, dict) and "spectrum" in irr:
        # the mesh and the time step must follow the shortest wave
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
    kind = vehicle_type(v.get("type"))
    for key in kind.keys:
        if v.get(key) is None:
            raise err(("vehicle", key), f"missing key '{key}' (vehicle type {kind.name} needs it)")
    problem = kind.check(vehicle_spec(v))
    if problem is not None:
        raise err(("vehicle", problem[0]), problem[1])
    lowest, highest, zone_start = run_extent(data)
    length = vehicle_length(vehicle_spec(v))
    layout = data["track"]["layout"]
    total = layout["entry_length"] + sum(data["track"]["ers"]["slab_lengths"]) \
        + layout["exit_length"]
    leave = (sim.get("direction") or "enter") == "leave"
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
    # where the wheels stand when the run starts: behind the leading wheel, towards the
    # entry end (enter) or the exit end (leave)
    if length > 0 and zone_start > 0:
        last = highest + length if leave else lowest - length
        short = last - (total - START_MARGIN) if leave else START_MARGIN - last
        if short > 1e-9:
            key = "exit_length" if leave else "entry_length"
            raise err(("track", "layout", key),
                      f"the vehicle's last wheel would start at {last:.3g} m, "
                      f"{'beyond the' if last < 0 or last > total else 'next to the'} end of "
                      f"the modelled rail [0, {total:g}] m: a wheel rolling onto or away from "
                      f"the rail's end shakes the vehicle through the run (every wheel starts "
                      f"at least {START_MARGIN:g} m inside): {key} "
                      f"{layout[key]:g} m is {short:.3g} m short")


def run_extent(data: dict) -> tuple[float, float, float]:
    """(lowest, highest) position of the leading wheel over the run and the start of the
    evaluation zone [m], for the design whose zone reaches farthest (upper bounds of the
    spans), so that every design's run lies within."""
    v, sim = data["vehicle"], data["simulation"]
    length = vehicle_length(vehicle_spec(v))
    layout = data["track"]["layout"]
    zone_end = zone_end_x(data)
    spans = data["design"]["sleeper_spans"]
    n_zone, n_near = data["evaluation"]["sleepers"], spans["count"]
    far_span = spans["bounds"][1] * ELEMENT_UNIT   # the zone reaches farthest at the upper bounds
    zone_start = layout["entry_length"] - min(n_zone, n_near) * far_span \
        - max(0, n_zone - n_near) * layout["sleeper_spacing"]
    x_b = layout["entry_length"] + sum(data["track"]["ers"]["slab_lengths"])
    if (sim.get("direction") or "enter") == "leave":
        return zone_start - sim["run_out"] - length, max(zone_end, x_b) + sim["run_in"], zone_start
    return zone_start - sim["run_in"], zone_end + sim["run_out"] + length, zone_start


def simulation_size(data: dict) -> tuple[int, int]:
    """(time steps, track dofs) of one simulation, at most (the farthest-reaching design) and
    about (the dofs counted as ``lccopt.vti.track`` meshes: fine elements where the wheels
    run, 2 m either side, coarse ones elsewhere, a node at every support)."""
    sim, layout = data["simulation"], data["track"]["layout"]
    lowest, highest, _ = run_extent(data)
    run = max(highest - lowest, 0.0)
    steps = int(np.ceil(run / (data["vehicle"]["speed"] * sim["time_step"])))
    ers = float(sum(data["track"]["ers"]["slab_lengths"]))
    total = layout["entry_length"] + ers + layout["exit_length"]
    fine = min(total, run + vehicle_length(vehicle_spec(data["vehicle"])) + 4.0)
    sleepers = (layout["entry_length"] + layout["exit_length"]) / layout["sleeper_spacing"]
    supports = sleepers + len(data["track"]["ers"]["slab_lengths"]) + 1
    rail_nodes = fine / sim["element_length"] + (total - fine) / sim["far_element_length"] \
        + supports
    slab_nodes = min(ers, fine) / sim["element_length"] + ers / sim["far_element_length"]
    return steps, int(2 * rail_nodes + sleepers + 2 * slab_nodes)


def simulation_memory(data: dict, steps: int, dofs: int) -> tuple[float, int]:
    """(bytes, cached rows): about what one simulation of ``steps`` and ``dofs`` holds."""
    vehicle = vehicle_spec(data["vehicle"])
    rows = 0
    if vehicle_type(vehicle.type).wheels > 1:   # two rows per element the wheels span, the ends
        rows = int(2 * (vehicle_length(vehicle) / data["simulation"]["element_length"] + 4))
    return steps * BYTES_PER_STEP + dofs * (BYTES_PER_DOF + 8 * rows), rows


def check_size(data: dict, err) -> None:
    """One simulation stays within what a machine can hold and a worker can finish."""
    sim = data["simulation"]
    steps, dofs = simulation_size(data)
    if steps > MAX_STEPS:
        lowest, highest, _ = run_extent(data)
        speed = data["vehicle"]["speed"]
        raise err(("simulation", "time_step"),
                  f"{sim['time_step']:g} s makes {steps:,} steps (the leading wheel runs "
                  f"{highest - lowest:.3g} m at {speed:.3g} m/s); a simulation takes at most "
                  f"{MAX_STEPS:,} steps (their histories fill the memory): time_step >= "
                  f"{(highest - lowest) / speed / MAX_STEPS:.3g} s")
    memory, rows = simulation_memory(data, steps, dofs)
    if memory > MAX_MEMORY:
        held = (f", and the {data['vehicle']['type']} keeps {rows:,} rows of them while its wheels "
                f"cross the {sim['element_length']:g} m elements" if rows else "")
        raise err(("simulation", "element_length"),
                  f"one simulation would hold about {memory / 1e9:.2g} GB ({steps:,} steps, about "
                  f"{dofs:,} track dofs{held}); at most {MAX_MEMORY / 1e9:g} GB: longer "
                  f"elements (element_length, far_element_length), a shorter track or run")
    if steps * dofs > MAX_STEP_DOFS:
        raise err(("simulation",),
                  f"{steps:,} steps of about {dofs:,} track dofs ({steps * dofs:.2g} in all) "
                  f"is more than a simulation can do in reasonable time (at most "
                  f"{MAX_STEP_DOFS:.0e}, about 7 minutes at 40 ns per step and dof): a longer "
                  f"time_step or element_length, a shorter run or track")


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


def default_initial_points(budget: int, n_variables: int) -> int:
    """The initial design's size when a case does not give it: 20, the paper's for its 8
    variables (well above the d + 1 points a cubic RBF with a linear tail needs), 2 (d + 1) for
    more than 9 variables; never above the budget."""
    return min(int(budget), max(DEFAULT_INITIAL_POINTS, 2 * (n_variables + 1)))


def check_optimisation(data: dict, err, n_variables: int) -> None:
    """Initial design within the budget (its default filled in), one worst value per
    objective of the ASF where they are given (the engine derives them otherwise)."""
    opt = data["optimisation"]
    if opt is None:
        return
    budget = opt["budget"]
    if opt["initial_points"] is None and budget is not None:
        opt["initial_points"] = default_initial_points(budget, n_variables)
    check_degenerate_objectives(data, err)
    budget_at, points_at = ("optimisation", "budget"), ("optimisation", "initial_points")
    if budget is not None and opt["initial_points"] is not None \
            and opt["initial_points"] > budget:
        raise _disagree(err, budget_at, points_at,
                        f"{budget} is below the {opt['initial_points']} initial points "
                        f"({_where(err, points_at)}): give at least {opt['initial_points']}, "
                        f"or set initial_points too",
                        f"{opt['initial_points']} initial points exceed the budget of {budget}")
    worst = opt["asf"]["worst"]
    if worst is None or not opt["objectives"]:
        return
    n_obj = len(opt["objectives"])
    n_each = len(data["conditions"] or []) if opt["conditions"] == "each" else 1
    if len(worst) not in (n_obj, n_obj * n_each):
        also = (f" or {n_obj * n_each} (one per objective and condition)"
                if n_each > 1 else "")
        objectives_at, worst_at = ("optimisation", "objectives"), ("optimisation", "asf", "worst")
        raise _disagree(err, objectives_at, worst_at,
                        f"{n_obj} objective(s), but asf.worst ({_where(err, worst_at)}) gives "
                        f"{len(worst)} values: set asf.worst too",
                        f"expected {n_obj} values (one per objective){also}, got {len(worst)}")


# Objectives that are a spread (max - min) over a set of sleepers: with one sleeper they are 0
# for every design. (objective -> the key that counts the sleepers, what they are)
_SPREADS = {"E_max": (("evaluation", "sleepers"), "zone sleeper"),
            "differential_settlement": (("degradation", "settling_sleepers"), "settling sleeper")}


def check_degenerate_objectives(data: dict, err) -> None:
    """An objective the case makes the same for every design is refused here, before any
    simulation: a spread over one sleeper (0 for every design: nothing to minimise, and an ASF
    whose reference point and worst value are both 0), or maintenance_rate counting to a limit
    on such a spread (the limit is never reached: 1 / horizon for every design). The key
    blamed is the count that makes it so."""
    opt = data["optimisation"]
    objectives = list(opt.get("objectives") or [])
    deg = data.get("degradation") or {}
    limit = (deg.get("limit") or {}).get("measure") if deg else None
    asked = [(k, k) for k in objectives]
    if "maintenance_rate" in objectives and limit in _SPREADS:
        asked.append((limit, f"maintenance_rate (its limit is on {limit})"))
    for measure, objective in asked:
        if measure not in _SPREADS:
            continue
        at, what = _SPREADS[measure]
        section = data.get(at[0]) or {}
        count = section.get(at[1])
        if count == 1:
            listed = _where(err, ("optimisation", "objectives"))
            raise err(at, f"1 {what} makes {measure} (max - min over them) 0 for every design, so "
                          f"{objective}, an objective of this case ({listed}), cannot be "
                          f"minimised: at least 2, or another objective")


def _where(err, at: tuple) -> str:
    """Where key ``at`` was set (file:line or --set), if ``err`` can tell; else its name."""
    where = getattr(err, "where", None)
    return where(at) if where is not None else ".".join(at)


def _disagree(err, first: tuple, second: tuple, on_first: str, on_second: str):
    """The error of two keys that disagree: on ``first`` (``on_first``) when it came from the
    command line (--set) and ``second`` did not, so that the message names what the user
    typed; else on ``second`` (``on_second``)."""
    if _where(err, first) == "--set" and _where(err, second) != "--set":
        return err(first, on_first)
    return err(second, on_second)


def check_design_size(sizes: list[tuple[int, int]], err) -> None:
    """The simulations of one design (its conditions: ``sizes`` of each) together."""
    steps = sum(s for s, _ in sizes)
    work = sum(s * d for s, d in sizes)
    if steps > MAX_DESIGN_STEPS:
        raise err(("conditions",),
                  f"the {len(sizes)} conditions take {steps:,} time steps per design in all; at "
                  f"most {MAX_DESIGN_STEPS:,} (lccopt simulate holds every condition's histories "
                  f"in memory): fewer conditions or longer time steps")
    if work > MAX_DESIGN_STEP_DOFS:
        raise err(("conditions",),
                  f"the {len(sizes)} conditions take {work:.2g} steps x track dofs per design "
                  f"in all; at most {MAX_DESIGN_STEP_DOFS:.0e} (about 35 minutes per design): "
                  f"fewer conditions, a coarser time_step or element_length")


def check_profile(data: dict, err, at: tuple) -> None:
    """The rail profile of one simulation (``data["simulation"]["irregularity"]``, resolved):
    a spectrum's band fits the track and its profile stays plausible; rows cover the track."""
    value = data["simulation"].get("irregularity")
    if not isinstance(value, dict):
        return
    length = track_length(data)
    if "points" in value:
        problem = cover_problem(profile_array(value["points"]), length)
        if problem:
            raise err(at, problem)
        return
    problem = spectrum_problem(value, length)
    if problem:
        raise err(at + (problem[0],), problem[1])
    deepest = float(np.abs(spectrum_profile(value, length)[:, 1]).max())
    if deepest > MAX_DIP:
        raise err(at + ("amplitude_scale",),
                  f"the {value['spectrum']} profile (seed {value['seed']}, wavelengths "
                  f"{value['wavelengths'][0]:g}-{value['wavelengths'][1]:g} m, amplitude_scale "
                  f"{value['amplitude_scale']:g}) reaches a dip of {deepest:.3g} m, beyond "
                  f"{MAX_DIP:g} m: a narrower band of wavelengths or a smaller amplitude_scale")


def spectrum_problem(irregularity: dict, length: float) -> tuple[str, str] | None:
    """(key, message) of the first problem of a spectrum irregularity on a track of ``length``,
    or None. Mesh and time-step limits are checked with :func:`check_accuracy`."""
    lo, hi = irregularity["wavelengths"]
    if not lo < hi:
        return "wavelengths", f"[min, max] must increase, got [{lo:g}, {hi:g}] m"
    if hi > length + 1e-9:
        return "wavelengths", (f"the longest wavelength {hi:g} m exceeds the track ({length:g} m), "
                               f"over which the profile is generated")
    if len(band_bins(length, (lo, hi))) == 0:
        return "wavelengths", (f"the band [{lo:g}, {hi:g}] m holds no wavelength {length:g} m / m "
                               f"(m whole) of the {length:g} m track: widen it")
    return None
