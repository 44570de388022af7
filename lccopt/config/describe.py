"""A validated case in lines a person reads: what ``lccopt check`` prints, and the vehicle
line ``lccopt simulate`` prints for each simulation.

Engineering units throughout (km/h, kN, MN/m, m): the resolved speed and the vehicle's static
wheel load are shown so that a value in the wrong unit, or a per-wheel reading that does not
add up to the real vehicle, shows before anything is simulated.
"""

from __future__ import annotations

import math

from ..terminal import WIDTH, wrap_items, wrap_message
from ..vti import pads
from ..vti.vehicle import build_vehicle, vehicle_type
from .build import vehicle_spec
from .checks import simulation_size
from .degradation import SINGLE_CONDITION, axles, bearing_areas, resolved_traffic
from .uncertainty import uncertainty_lines
from .zones import force_zone_end, interfaces, zone_end_x


def vehicle_facts(vehicle: dict) -> tuple[str, float, float]:
    """(type, speed [km/h], static wheel load [kN]) of a vehicle section."""
    v = vehicle_spec(vehicle)
    kind = v.type + (f" ({v.model})" if vehicle_type(v.type).models else "")
    return kind, v.speed * 3.6, build_vehicle(v).static_wheel_load / 1e3


def vehicle_line(vehicle: dict) -> str:
    """``half-car, 140 km/h, static wheel load 87.22 kN per wheel``."""
    kind, speed, load = vehicle_facts(vehicle)
    return f"{kind}, {speed:.4g} km/h, static wheel load {load:.2f} kN per wheel"


def variable_items(case) -> list[str]:
    """``x_r1 [50, 1200] MN/m log``, ``x_s1∈Z [3, 7] x 0.1 m``, ... for each design variable."""
    out = []
    for v in case.variables:
        unit, scale = v.display
        steps = v.integer and scale != 1.0          # a length counted in 0.1 m elements
        out.append(f"{v.name}{'∈Z' if v.integer and not steps else ''} [{v.lower * scale:g}, "
                   f"{v.upper * scale:g}]{f' {unit}' if unit else ''}"
                   f"{f' in {scale:g} m steps' if steps else ''}{' log' if v.log else ''}")
    return out


def _mn(k: float) -> str:
    return f"{k / 1e6:.4g}"


def pad_facts(case) -> list[str]:
    """The pads as entered and as simulated (under the wheel): the pads of the sleepers not
    designed, then the designed ones, one sentence each. ``lccopt check`` prints them
    (:func:`pad_lines`) and the report repeats them.

    Parameters
    ----------
    case
        a loaded case.

    Returns
    -------
    list of str
        e.g. ``["pads: 560 MN/m as bought x 2 = 1120 MN/m under the wheel, 120 kN s/m",
        "designed pads x_r1-x_r3: 20-480 MN/m as bought x 2.5 = 50-1200 MN/m under the
        wheel, damping 120 kN s/m per 1120 MN/m"]``.
    """
    section = case.track["railpad"]
    pad = pads.resolve(section)
    if pad.name:
        bought = f"{pad.name} (named; static not published), "
    elif pad.static_stiffness is None:
        bought = "static not given, "
    elif section.get("stiffness") is None:
        bought = f"{_mn(pad.static_stiffness)} MN/m as bought x {pad.ratio:.3g} = "
    else:
        bought = f"{_mn(pad.static_stiffness)} MN/m as bought (x {pad.ratio:.3g}), "
    facts = [f"pads: {bought}{_mn(pad.stiffness)} MN/m under the wheel, "
             f"{pad.damping / 1e3:.4g} kN s/m"]
    designed = [v for v in case.variables if v.group == "railpad_stiffness"]
    if designed:
        ratio = case.data["design"]["railpad_stiffness"].get("dynamic_to_static")
        names = designed[0].name + (f"-{designed[-1].name}" if len(designed) > 1 else "")
        lo, hi = designed[0].lower, designed[0].upper
        sim = (f"{_mn(pads.under_wheel(lo, ratio))}-{_mn(pads.under_wheel(hi, ratio))} MN/m "
               f"under the wheel")
        bought = f"{_mn(lo)}-{_mn(hi)} MN/m as bought x {ratio:.3g} = " if ratio else ""
        facts.append(f"designed pads {names}: {bought}{sim}, damping "
                     f"{pad.damping / 1e3:.4g} kN s/m per {_mn(pad.stiffness)} MN/m")
    return facts


def pad_lines(case, width: int = WIDTH - 2) -> list[str]:
    """:func:`pad_facts` in lines of at most ``width`` columns (broken at ': ', ' = ' and
    ', ')."""
    lines = []
    for fact in pad_facts(case):
        head, rest = fact.split(": ", 1)
        items = rest.replace(" = ", ", = ").split(", ")
        wrapped = [line.replace(", =", " =") for line in
                   wrap_items(items, f"{head}: ", width=width)]
        for i in range(len(wrapped) - 1):       # no comma before a line that goes on with =
            if wrapped[i + 1].lstrip().startswith("="):
                wrapped[i] = wrapped[i].rstrip(",")
        lines += wrapped
    return lines


# A strengthened sleeper's support against the standard one's outside this range is flagged by
# check: its larger base makes it stiffer (the bundled cases take 1.25 x), but rarely more than
# twice as stiff, and never softer; a ratio outside is usually a support changed in one key and
# not the other (the two are separate keys).
STRENGTHENED_SUPPORT_RATIO = (1.0, 2.0)


def _mnm(v: float, per: str = "") -> str:
    return f"{v / 1e6:.4g} MN/m{per}"


def _kns(v: float, per: str = "") -> str:
    return f"{v / 1e3:.4g} kN s/m{per}"


def track_lines(case) -> list[str]:
    """The track lccopt resolved, in 80 columns: support, pads, sleepers, strengthened sleepers
    (and their ratio to the standard ones), the ERS; per rail, pads and supports per rail
    seat, as the simulation takes them."""
    t = case.data["track"]
    lay, sup, ss, ers = t["layout"], t["support"], t["strengthened_sleeper"], t["ers"]
    slab = ers["slab"]
    lines = ["  track, one rail (pads and supports per rail seat):",
             f"    support: {_mnm(sup['stiffness'])}, {_kns(sup['damping'])} under each sleeper"]
    lines += [f"    {line}" for line in pad_lines(case, WIDTH - 4)]
    lines += wrap_items([f"{t['sleeper']['mass']:.4g} kg", f"{lay['sleeper_spacing']:g} m apart",
                         f"{lay['entry_length']:g} m of ballast before the ERS",
                         f"{lay['exit_length']:g} m after it"], "    sleepers: ")
    ratio = (ss["mass"] / t["sleeper"]["mass"], ss["support_stiffness"] / sup["stiffness"],
             ss["support_damping"] / sup["damping"] if sup["damping"] else math.nan)
    lines += wrap_items([f"{ss['mass']:.4g} kg ({ratio[0]:.3g} x)",
                         f"support {_mnm(ss['support_stiffness'])} ({ratio[1]:.3g} x)",
                         f"{_kns(ss['support_damping'])} ({ratio[2]:.3g} x the standard)"],
                        "    strengthened sleepers: ", width=WIDTH)
    lengths = " + ".join(f"{x:g}" for x in ers["slab_lengths"])
    lines += wrap_items([f"{lengths} m of slab{'s' if len(ers['slab_lengths']) > 1 else ''}",
                         f"{slab['width_bottom']:g}/{slab['width_top']:g} m wide",
                         f"{slab['height']:g} m high", f"{slab['youngs_modulus'] / 1e9:g} GPa",
                         f"on {_mnm(ers['foundation']['stiffness'], '/m')} "
                         f"({ers['share_per_rail']:g} of it per rail)",
                         f"compound {_mnm(ers['compound']['stiffness'], '/m')}",
                         f"Type II strip {_mnm(ers['type_ii_compound']['stiffness'], '/m')}"],
                        "    ERS: ")
    return lines + track_warnings(case)


def track_warnings(case) -> list[str]:
    """``warning:`` lines for a track that is valid but probably not what was meant: a
    strengthened sleeper's support much stiffer or softer than the standard support."""
    t = case.data["track"]
    sup, ss = t["support"], t["strengthened_sleeper"]
    lo, hi = STRENGTHENED_SUPPORT_RATIO
    out = []
    for what, own, standard, shown in (("stiffness", "support_stiffness", "stiffness", _mnm),
                                       ("damping", "support_damping", "damping", _kns)):
        if not standard_value_ok(ss[own], sup[standard], lo, hi):
            out.append(wrap_message(
                f"warning: strengthened_sleeper.{own} {shown(ss[own])} is "
                f"{ss[own] / sup[standard]:.3g} x support.{standard} {shown(sup[standard])} "
                f"(the bundled cases assume 1.25 x, for a larger base; check warns outside "
                f"{lo:g}-{hi:g} x): if you changed the support, change this key too", WIDTH - 2))
    return ["  " + line.replace("\n", "\n  ") for line in out]


def standard_value_ok(value: float, standard: float, lo: float, hi: float) -> bool:
    """Whether VALUE lies within [LO, HI] x STANDARD (a zero standard: only zero is)."""
    if standard == 0:
        return value == 0
    return lo * (1 - 1e-9) <= value / standard <= hi * (1 + 1e-9)


def zone_line(case) -> str:
    """Where the objectives are measured."""
    point = force_zone_end(case.evaluation)
    side = "after" if point.offset >= 0 else "before"
    where = point.at.replace("_", " ")
    at = (f"{abs(point.offset):g} m {side} the {where}" if point.offset else f"the {where}")
    # along the track from the entry slab edge, as every figure measures
    past = zone_end_x(case.data) - interfaces(case.data)[0]
    lines = wrap_items(
        [f"{case.evaluation['sleepers']} sleepers; force to {at}",
         f"{abs(past):.4g} m {'past' if past >= 0 else 'before'} the entry slab edge"],
        "zone: ", width=WIDTH - 2)
    reach = rail_on_compound_length(case.data)
    x_a, x_b = interfaces(case.data)
    if past < reach:
        short = (f"; on a {x_b - x_a:g} m ERS the exit interface's reach (about 2/beta) "
                 f"overlaps it too" if x_b - x_a < 3 * reach else "")
        lines += wrap_message(
            f"warning: the force zone reaches {max(past, 0.0):.3g} m into the ERS, less than "
            f"the {reach:.2f} m of 1/beta (the rail on the slab's compound): the force's "
            f"peak past the entry interface (0.63 m for the paper's crossing) may lie "
            f"outside it, and F_max with it{short} (docs/model.md, 'The objectives')",
            WIDTH - 2).split("\n")
    return "\n".join(lines)


def rail_on_compound_length(data: dict) -> float:
    """1/beta [m] of the rail on the ERS's compound, (4 EI / k)^(1/4): the length over which a
    change of support under the rail shows in its deflection and the wheel's force."""
    rail, compound = data["track"]["rail"], data["track"]["ers"]["compound"]
    return (4.0 * rail["youngs_modulus"] * rail["second_moment"] / compound["stiffness"]) ** 0.25


def optimisation_line(case) -> str:
    """The optimisation in one line, or what ``lccopt optimise`` still needs."""
    opt = case.optimisation
    missing = [k for k in ("objectives", "budget") if not (opt or {}).get(k)]
    if missing:
        return f"optimisation: none yet (lccopt optimise needs {' and '.join(missing)})"
    worst = opt["asf"]["worst"]
    asf = ""
    if len(opt["objectives"]) > 1 or opt["conditions"] == "each":
        asf = ("\n  asf.worst: as given" if worst else
               "\n  asf.worst: 1.5 x the reference design's objectives (the default)")
    items = [*opt["objectives"][:-1], f"{opt['objectives'][-1]}; budget {opt['budget']}",
             f"{opt['initial_points']} initial points; histories: {case.histories}"]
    return "\n".join(wrap_items(items, "optimisation: ", width=WIDTH - 2)) + asf


def condition_lines(case) -> list[str]:
    """The traffic conditions: vehicle (type, static wheel load), speed, direction."""
    lines = [f"  {len(case.traffic)} traffic conditions, combined by "
             f"'{case.condition_mode}' (vehicle: type, static wheel load):"]
    for c in case.traffic:
        kind, speed, load = vehicle_facts(c.data["vehicle"])
        weight = f", weight {c.weight:g}" if case.condition_mode == "mean" else ""
        lines.append(f"    {c.name}: {c.vehicle} ({kind}, {load:.1f} kN), {speed:.4g} km/h, "
                     f"{c.direction}{weight}")
    return lines


def law_items(law: dict) -> list[str]:
    """A settlement law's parameters as ``lccopt check`` shows them.

    Parameters
    ----------
    law
        the checked ``degradation.law`` section.

    Returns
    -------
    list of str
        e.g. ``["alpha 0.6", "beta 0.82", "gamma 10 mm", "reference_force 50 kN", ...]``.
    """
    shown = {"gamma": (1e3, " mm"), "first_cycle": (1e3, " mm"), "reference_force": (1e-3, " kN")}
    return [f"{k} {v * shown.get(k, (1.0, ''))[0]:g}{shown.get(k, (1.0, ''))[1]}"
            for k, v in law.items() if k != "name"]


def count_text(v: float) -> str:
    """A count as people write it: three significant figures, with thousands separated
    (496,000), in millions from a million (9.93 million)."""
    if not math.isfinite(v):
        return f"{v}"
    if abs(v) >= 1e6:
        return f"{v / 1e6:.3g} million"
    if abs(v) >= 1e3:
        return f"{float(f'{v:.3g}'):,.0f}"
    return f"{v:.3g}"


def traffic_items(case) -> tuple[list[tuple[str, list[str]]], list[str], float]:
    """The traffic in the words people count it in: each condition's trains (when given so),
    passages of its modelled vehicle, axles and axle load, then the trains, axle passes and
    gross tonnes a year of all together.

    Parameters
    ----------
    case
        a loaded case with a ``degradation:`` section.

    Returns
    -------
    (list of (str, list of str), list of str, float)
        (condition name, its items) in case order, the items of the total, and the axle passes
        a year.
    """
    vehicles = ({c.name: c.data["vehicle"] for c in case.traffic}
                or {SINGLE_CONDITION: case.vehicle})
    per, axle_passes, tonnes, trains = [], 0.0, 0.0, 0.0
    for name, t in resolved_traffic(case.data, case.traffic).items():
        v = vehicles[name]
        n, load = axles(v), vehicle_facts(v)[2]                 # kN per wheel
        what = vehicle_type(v.get("type")).passage
        if t.trains_per_day is not None:
            trains += t.trains_per_day
            items = [f"{t.trains_per_day:g} trains a day, {t.per_train:g} {what} passages each",
                     f"{count_text(t.passages)} {what} passages a year ({n} axles each)"]
        else:
            items = [f"{count_text(t.passages)} {what} passages a year ({n} axles each)"]
        items.append(f"axle load {2 * load:.3g} kN")
        per.append((name, items))
        axle_passes += t.axle_passes
        tonnes += t.axle_passes * 2 * load * 1e3 / 9.81 / 1e3            # t
    total = [f"{count_text(axle_passes)} axle passes",
             f"about {tonnes / 1e6:.3g} million gross tonnes a year"]
    if trains:
        total.insert(0, f"{trains:g} trains a day")
    return per, total, axle_passes


def traffic_lines(case) -> tuple[list[str], float]:
    """The traffic of a case with ``degradation:`` as ``lccopt check`` prints it
    (:func:`traffic_items`): lines of at most 80 columns, and the axle passes a year."""
    per, total, axle_passes = traffic_items(case)
    lines = []
    for name, items in per:
        lines += wrap_items(items, "    traffic: " if not case.traffic else f"    traffic {name}: ")
    return lines + wrap_items(total, "    "), axle_passes


def traffic_sentence(case) -> str:
    """The traffic of a case with ``degradation:`` in one phrase, as ``lccopt check`` counts
    it (the report's words): the one vehicle's traffic without its condition's name, or each
    condition's by its name."""
    per, total, _ = traffic_items(case)
    if not case.traffic:
        return f"{', '.join(per[0][1])}; {', '.join(total[-2:])}"
    return "; ".join(f"{name}: {', '.join(items)}" for name, items in per) + \
        f"; together {', '.join(total)}"


def degradation_lines(case) -> list[str]:
    """The settlement prediction of a case with ``degradation:`` as ``lccopt check`` prints
    it, in lines of at most 80 columns indented by two: law, traffic (axle passes and gross
    tonnage a year), horizon, limit and cost cap."""
    deg = case.degradation
    lines = wrap_items(law_items(deg["law"]), f"  settlement: {deg['law']['name']} law: ")
    lines += _pressure_lines(case)
    traffic, per_year = traffic_lines(case)
    lines += traffic
    simulated = sum(t.passages > 0 for t in resolved_traffic(case.data, case.traffic).values())
    horizon = deg["horizon_years"]
    limit = deg["limit"]
    lines.append(f"    horizon {horizon:.4g} year{'' if horizon == 1 else 's'} = "
                 f"{count_text(horizon * per_year)} axle passes; "
                 f"{deg['settling_sleepers']} settling sleepers")
    lines.append(f"    limit: {limit['measure']} {limit['value'] * 1e3:g} mm (years_to_limit, "
                 f"maintenance_rate)")
    tamping = deg.get("tamping")
    if tamping is not None:
        lines.append(f"    tamped at the limit, not the {tamping['unreachable_sleepers']} "
                     f"sleeper(s) by the slab; at most every {tamping['min_interval']:g} yr")
    lines.append(f"    per design: at most {deg['max_simulations']} simulations x {simulated} "
                 f"condition(s), tolerance {deg['tolerance'] / 1e3:g} kN")
    # the law's parameters come from other tracks: nothing here is a forecast
    lines += ["    the millimetres will be the law's values, not a forecast: the law is not",
              "    calibrated to a measured crossing (docs/settlement.md, Validation)"]
    return lines


def _pressure_lines(case) -> list[str]:
    """How the law is fed: the bearing areas and reference pressure; the subgrade layer."""
    deg = case.degradation
    standard, strengthened = bearing_areas(case.data)
    f0 = deg["law"]["reference_force"]
    lines = wrap_items([f"bearing area {standard:g} m^2 a rail seat",
                        f"strengthened {strengthened:.3g} m^2",
                        f"reference pressure {f0 / standard / 1e3:.3g} kPa",
                        f"{deg['reading']} reading"], "    fed the sleeper-ballast pressure: ")
    sub = deg["subgrade"]
    if sub["soil"] == "none":
        return lines + ["    subgrade: none (the ballast law alone: a softer support settles "
                        "less)"]
    k = case.data["track"]["support"]["stiffness"]
    k0 = sub["reference_stiffness"]
    here = sub["strength"] * k / k0
    strength = [f"strength {here / 1e3:.3g} kPa"]
    if k != k0:        # the strength follows the support: say from what
        strength += [f"scaled from {sub['strength'] / 1e3:g} kPa on {k0 / 1e6:g} MN/m "
                     f"to this {k / 1e6:g} MN/m support"]
    return lines + wrap_items(
        [f"soil {sub['soil']}", *strength,
         f"{sub['depth']:g}-{sub['depth'] + sub['thickness']:g} m below the sleepers"],
        "    subgrade (Li & Selig): ")


def case_lines(case, file) -> list[str]:
    """What ``lccopt check`` prints for a valid case."""
    lines = [f"{file}: ok: case '{case.name}', {len(case.variables)} design variables:"]
    lines += wrap_items(variable_items(case), "  ")
    if case.traffic:
        lines += condition_lines(case)
    else:
        lines.append(f"  vehicle: {vehicle_line(case.vehicle)}")
    lines += track_lines(case)
    lines += [f"  {line}" for line in zone_line(case).split("\n")]
    steps, dofs = max(simulation_size(one.data) for one in (case.traffic or [case]))
    lines.append(f"  {'the longest simulation' if case.traffic else 'one simulation'}: at "
                 f"most {steps:,} steps of about {dofs:,} track dofs")
    if case.degradation is not None:
        lines += degradation_lines(case)
    if case.realisations:
        lines += uncertainty_lines(case)
    lines += [f"  {line}" for line in optimisation_line(case).split("\n")]
    if case.overrides:
        lines += wrap_items([f"--set {o}" for o in case.overrides], "  with ")
    return lines
