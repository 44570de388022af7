"""The ``degradation:`` section of a case: its checks, its defaults filled in, and the
settlement prediction's typed inputs (:class:`lccopt.degradation.assessment.DegradationSpec`).

A case with this section is judged by the settlement of its design under its traffic over a
horizon (docs/settlement.md): the traffic is the case's one vehicle (``passages_per_year``) or
its ``conditions:`` (``traffic: {name: passages a year}``). The checks refuse what the
prediction cannot do right: the paper's three-dof vehicle (half its bogie rests on an
unmodelled wheelset fixed in space, so a settling track changes its wheel load), a traffic or
horizon without load cycles, settling sleepers the runs do not pass whole, followers that
reach the rail's pinned end, and a prediction beyond what one design may cost.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..degradation.inputs import (
    DegradationSpec,
    LawSpec,
    Limit,
    SubgradeSpec,
    TampingSpec,
    Traffic,
)
from ..vti.response import REPORTED_ONLY, SETTLEMENT_OBJECTIVES
from ..vti.specs import ELEMENT_UNIT
from ..vti.vehicle import vehicle_type
from . import build
from .checks import MAX_DESIGN_STEP_DOFS, simulation_size
from .validate import _did_you_mean

# law name -> {case key: (argument of its class in lccopt.degradation.laws, default)}; None: no
# published default (the key is required). Sources: docs/settlement.md, "Parameters".
LAW_PARAMETERS = {
    "varandas": {"alpha": ("alpha", 0.6), "beta": ("beta", 0.82), "gamma": ("gamma", 10.0e-3),
                 "reference_force": ("f0", 50.0e3), "reference_cycles": ("n0", 1.0e6)},
    "logarithmic": {"first_cycle": ("first_cycle", None), "log_rate": ("log_rate", None),
                    "exponent": ("exponent", 1.6), "reference_force": ("f0", 50.0e3)},
}
DEFAULT_HORIZON_YEARS = 10.0
SINGLE_CONDITION = "vehicle"     # the traffic condition of a case without a conditions: list
_THREE_DOF = ("cannot carry a settlement prediction (degradation:): it rests half its bogie on "
              "a second wheelset fixed in space, so a settling track changes its wheel load "
              "(56 -> 39 kN for a uniform 14 mm, docs/settlement.md); use type: bogie or "
              "half-car (configs/vehicles/), or model: quarter-car")


def axles(vehicle: dict) -> int:
    """Wheels of a vehicle section on the modelled rail: load cycles per passage.

    Parameters
    ----------
    vehicle
        a validated vehicle section (``type`` three-dof, bogie or half-car).

    Returns
    -------
    int
        1 (three-dof), 2 (bogie) or 4 (half-car).
    """
    return vehicle_type(vehicle.get("type")).wheels


def check_degradation(data: dict, conditions: tuple, err) -> None:
    """Check the ``degradation:`` section of a case and the objectives that need it.

    Fills in the defaults of the chosen law and the horizon (in years), so that the resolved
    case says what the prediction ran with.

    Parameters
    ----------
    data
        the validated case (changed in place: ``degradation.law`` and
        ``degradation.horizon_years`` completed).
    conditions
        the case's traffic conditions (empty for a case without ``conditions:``).
    err
        ``err(key_path, message)`` -> the case error to raise, naming the file and line.

    Raises
    ------
    CaseError
        (from ``err``) the first problem found.
    """
    deg = data.get("degradation")
    opt = data.get("optimisation") or {}
    objectives = opt.get("objectives") or []
    for k in objectives:
        if k in REPORTED_ONLY:
            raise err(("optimisation", "objectives"),
                      f"{k} is reported, not minimised (a longer life is better): minimise "
                      f"maintenance_rate = 1 / {k}")
        if k in SETTLEMENT_OBJECTIVES and deg is None:
            raise err(("optimisation", "objectives"),
                      f"{k} is an objective of a settlement prediction: it needs a "
                      f"degradation: section (docs/settlement.md)")
    if deg is None:
        return
    if opt.get("conditions") == "each":
        raise err(("optimisation", "conditions"),
                  "each is not available with degradation: (one settlement prediction couples "
                  "every condition); use worst or mean")
    _check_vehicles(data, conditions, err)
    rates = _check_traffic(data, deg, conditions, err)
    _check_horizon(deg, rates, err)
    _check_law(deg["law"], err)
    _check_zone(data, deg, err)
    _check_tamping(deg, objectives, err)
    _check_cost(data, deg, conditions, rates, err)


def _check_vehicles(data: dict, conditions: tuple, err) -> None:
    for c in conditions or [None]:
        v = data["vehicle"] if c is None else c.data["vehicle"]
        if (v.get("type") or "three-dof") == "three-dof" and (v.get("model") or "paper") == "paper":
            if c is None or c.vehicle == "case":
                at = ("vehicle", "type")
            else:
                at = ("vehicles", c.vehicle)
            under = "" if c is None else f" of condition {c.name}"
            raise err(at, f"the paper's three-dof vehicle{under} {_THREE_DOF}")


TRAIN_KEYS = ("trains_per_day", "vehicles_per_train", "bogies_per_train", "axle_passes_per_year")
FORMS = ("passages_per_year", "trains_per_day", "axle_passes_per_year")


@dataclass(frozen=True)
class TrafficOf:
    """One condition's traffic resolved: passages of its modelled vehicle a year, its axle
    passes a year, and (when given in trains) trains a day and passages per train."""
    passages: float
    axle_passes: float
    trains_per_day: float | None = None
    per_train: float | None = None


def _passages_per_train(vehicle: dict, entry: dict, at: tuple, err) -> float:
    """Passages of the modelled vehicle per train: a bogie passes twice per vehicle (two
    bogies), a half car once, a one-wheel model once per axle (4 per vehicle, 2 per bogie)."""
    kind = vehicle.get("type") or "three-dof"
    vehicles, bogies = entry.get("vehicles_per_train"), entry.get("bogies_per_train")
    if kind == "bogie":
        return float(bogies if bogies is not None else 2 * vehicles)
    if kind == "half-car":
        if bogies is not None and bogies % 2:
            raise err(at + ("bogies_per_train",),
                      f"{bogies:g} bogies: the modelled half car is a vehicle on two bogies, "
                      f"so give an even number (or vehicles_per_train)")
        return float(vehicles if vehicles is not None else bogies / 2)
    return float(2 * bogies if bogies is not None else 4 * vehicles)


def traffic_of(entry, vehicle: dict, at: tuple, err) -> TrafficOf:
    """A traffic written in any of its forms, checked and resolved.

    Parameters
    ----------
    entry
        passages a year (a number), or a mapping with one of ``passages_per_year``,
        ``trains_per_day`` (with ``vehicles_per_train`` or ``bogies_per_train``) or
        ``axle_passes_per_year``.
    vehicle
        the condition's validated vehicle section (what one passage is).
    at
        the key path of the entry, for the messages.
    err
        ``err(key_path, message)`` -> the case error to raise.

    Returns
    -------
    TrafficOf
    """
    if not isinstance(entry, dict):
        entry = {"passages_per_year": entry}
    given = [k for k in FORMS if entry.get(k) is not None]
    n = axles(vehicle)
    if not given:
        raise err(at, "missing key 'passages_per_year' (passages of the vehicle a year), or "
                      "trains_per_day with vehicles_per_train, or axle_passes_per_year")
    if len(given) > 1:
        raise err(at + (given[1],), f"give the traffic once: {given[0]} or {given[1]}")
    per = [k for k in ("vehicles_per_train", "bogies_per_train") if entry.get(k) is not None]
    if given[0] == "trains_per_day":
        if not per:
            raise err(at + ("trains_per_day",),
                      "trains without their length: give vehicles_per_train (cars, each on "
                      "two bogies) or bogies_per_train")
        if len(per) > 1:
            raise err(at + ("bogies_per_train",),
                      "give vehicles_per_train or bogies_per_train, not both")
        per_train = _passages_per_train(vehicle, entry, at, err)
        passages = entry["trains_per_day"] * 365.0 * per_train
        return TrafficOf(passages, passages * n, float(entry["trains_per_day"]), per_train)
    if per:
        raise err(at + (per[0],), f"{per[0]} describes trains: it needs trains_per_day")
    if given[0] == "axle_passes_per_year":
        return TrafficOf(entry["axle_passes_per_year"] / n, float(entry["axle_passes_per_year"]))
    return TrafficOf(float(entry["passages_per_year"]), entry["passages_per_year"] * n)


def resolved_traffic(data: dict, conditions: tuple, err=None) -> dict:
    """{condition name: TrafficOf} of a case (one condition, ``vehicle``, without
    ``conditions:``), checked when ``err`` is given (else the case is a checked one)."""
    deg = data["degradation"]
    err = err or (lambda at, msg: ValueError(f"{'.'.join(map(str, at))}: {msg}"))
    if not conditions:
        entry = {k: deg.get(k) for k in ("passages_per_year", *TRAIN_KEYS)}
        return {SINGLE_CONDITION: traffic_of(entry, data["vehicle"], ("degradation",), err)}
    return {c.name: traffic_of(deg["traffic"][c.name], c.data["vehicle"],
                               ("degradation", "traffic", c.name), err) for c in conditions}


def _check_traffic(data: dict, deg: dict, conditions: tuple, err) -> dict:
    """{condition: axle passes a year} of the traffic, checked."""
    at = ("degradation",)
    if not conditions:
        if deg.get("traffic") is not None:
            raise err(at + ("traffic",), "the case has no conditions: list; give its vehicle's "
                                          "passages_per_year (or trains_per_day) instead")
        return {k: t.axle_passes for k, t in resolved_traffic(data, (), err).items()}
    for k in ("passages_per_year", *TRAIN_KEYS):
        if deg.get(k) is not None:
            raise err(at + (k,), "the case has conditions: give each one's traffic under "
                                 "traffic:")
    traffic = deg.get("traffic")
    names = [c.name for c in conditions]
    if traffic is None:
        raise err(at, f"missing key 'traffic' (passages a year of each condition: "
                      f"{', '.join(names)})")
    for k in traffic:
        if k not in names:
            raise err(at + ("traffic", k), f"no condition '{k}'{_did_you_mean(k, names)}")
    for n in names:
        if n not in traffic:
            raise err(at + ("traffic",), f"condition '{n}' has no passages a year (0 if it "
                                          f"counts for the paper's objectives only)")
    rates = {k: t.axle_passes for k, t in resolved_traffic(data, conditions, err).items()}
    if sum(rates.values()) <= 0:
        raise err(at + ("traffic",), "no condition has passages: nothing loads the ballast")
    return rates


def _check_horizon(deg: dict, rates: dict, err) -> None:
    per_year = sum(rates.values())
    years, passes = deg.get("horizon_years"), deg.get("horizon_axle_passes")
    if years is not None and passes is not None:
        raise err(("degradation", "horizon_axle_passes"),
                  "give the horizon once: horizon_years or horizon_axle_passes")
    if passes is not None:
        years = passes / per_year
    if years is None:
        years = DEFAULT_HORIZON_YEARS
    if years * per_year < 1.0:
        key = "horizon_axle_passes" if passes is not None else "horizon_years"
        raise err(("degradation", key),
                  f"{years:g} years of {per_year:g} axle passes a year is less than one load "
                  f"cycle: the ballast would not settle")
    deg["horizon_years"] = float(years)
    # the resolved case gives the horizon once, in years (it is loaded again by report)
    deg.pop("horizon_axle_passes", None)


def _check_law(law: dict, err) -> None:
    name = law["name"]
    known = LAW_PARAMETERS[name]
    at = ("degradation", "law")
    for key, value in law.items():
        if key != "name" and value is not None and key not in known:
            other = next(n for n, keys in LAW_PARAMETERS.items() if key in keys)
            raise err(at + (key,), f"a parameter of the {other} law, not of {name} (law.name)")
    for key, (_, default) in known.items():
        if law.get(key) is None:
            if default is None:
                raise err(at, f"missing key '{key}': the {name} law has no published default "
                              f"for it (docs/settlement.md)")
            law[key] = default
    for key in [k for k, v in law.items() if v is None]:
        del law[key]           # absent stays absent: the other law's keys


def _check_zone(data: dict, deg: dict, err) -> None:
    """The runs pass the whole vehicle over every settling sleeper (they start run_in before
    the evaluation zone), and the followers end before the rail's pinned end at x = 0."""
    n = deg["settling_sleepers"]
    zone = data["evaluation"]["sleepers"]
    if n > zone:
        raise err(("degradation", "settling_sleepers"),
                  f"{n} settling sleepers, but the runs start {data['simulation']['run_in']:g} m "
                  f"before the evaluation zone's {zone} sleepers: at most {zone} (or raise "
                  f"evaluation.sleepers)")
    layout = data["track"]["layout"]
    spans = data["design"]["sleeper_spans"]
    n_near = spans["count"]
    far = layout["entry_length"] - min(n, n_near) * spans["bounds"][1] * ELEMENT_UNIT \
        - max(0, n - n_near) * layout["sleeper_spacing"]
    reach = deg["follower_flat"] + deg["follower_taper"]
    if far - reach < layout["sleeper_spacing"]:
        raise err(("degradation", "follower_taper"),
                  f"the followers (follower_flat + follower_taper = {reach:g} m beyond the "
                  f"farthest settling sleeper at {far:g} m) reach the rail's pinned end at "
                  f"x = 0: shorten them or lengthen track.layout.entry_length")


def _check_tamping(deg: dict, objectives, err) -> None:
    tamping = deg.get("tamping")
    if tamping is None:
        if "interventions" in objectives:
            raise err(("optimisation", "objectives"),
                      "interventions counts tampings: it needs degradation.tamping")
        return
    n = deg["settling_sleepers"]
    if tamping["unreachable_sleepers"] >= n:
        raise err(("degradation", "tamping", "unreachable_sleepers"),
                  f"{tamping['unreachable_sleepers']} of the {n} settling sleepers out of the "
                  f"machine's reach: no sleeper would be tamped (at most {n - 1})")
    if tamping["min_interval"] >= deg["horizon_years"]:
        raise err(("degradation", "tamping", "min_interval"),
                  f"{tamping['min_interval']:g} years between tampings is not less than the "
                  f"horizon ({deg['horizon_years']:g} years): no tamping could be done")


def _check_cost(data: dict, deg: dict, conditions: tuple, rates: dict, err) -> None:
    """At most MAX_DESIGN_STEP_DOFS of work per design: max_simulations runs of every
    condition with passages and one paper simulation of every condition."""
    sims = [(c.name, c.data) for c in conditions] or [(SINGLE_CONDITION, data)]
    work = 0.0
    for name, one in sims:
        steps, dofs = simulation_size(one)
        work += steps * dofs * (1 + (deg["max_simulations"] if rates[name] > 0 else 0))
    if work > MAX_DESIGN_STEP_DOFS:
        n = sum(r > 0 for r in rates.values())
        raise err(("degradation", "max_simulations"),
                  f"{deg['max_simulations']} simulations of {n} condition(s) per design take up "
                  f"to {work:.2g} steps x track dofs; at most {MAX_DESIGN_STEP_DOFS:.0e} (about "
                  f"35 minutes per design): fewer conditions with passages, a smaller "
                  f"max_simulations or a coarser time_step")


def degradation_spec(data: dict, conditions: tuple, variation=None) -> DegradationSpec:
    """The settlement prediction's typed inputs from a case checked by
    :func:`check_degradation`.

    Parameters
    ----------
    data
        the checked case.
    conditions
        its traffic conditions (empty: the case's own vehicle is the one condition).
    variation
        one realisation of the built track (``lccopt.vti.specs.TrackVariation``), or None
        for the track as drawn.

    Returns
    -------
    lccopt.degradation.inputs.DegradationSpec
    """
    deg = data["degradation"]
    resolved = resolved_traffic(data, conditions)
    if conditions:
        traffic = tuple(Traffic(c.name, build.scenario(c.data, variation),
                                resolved[c.name].passages, c.weight) for c in conditions)
    else:
        traffic = (Traffic(SINGLE_CONDITION, build.scenario(data, variation),
                           resolved[SINGLE_CONDITION].passages),)
    law = deg["law"]
    params = tuple((arg, float(law[key])) for key, (arg, _) in LAW_PARAMETERS[law["name"]].items())
    mode = (data.get("optimisation") or {}).get("conditions") or "worst"
    standard, strengthened = bearing_areas(data)
    sub = deg["subgrade"]
    subgrade = None if sub["soil"] == "none" else SubgradeSpec(
        sub["soil"], sub["strength"], sub["reference_stiffness"], sub["depth"],
        sub["thickness"])
    return DegradationSpec(
        traffic=traffic, horizon_years=deg["horizon_years"],
        law=LawSpec(law["name"], params),
        settling_sleepers=deg["settling_sleepers"], follower_flat=deg["follower_flat"],
        follower_taper=deg["follower_taper"], rail_seats=deg["rail_seats"],
        tolerance=deg["tolerance"], steps_per_decade=deg["steps_per_decade"],
        max_simulations=deg["max_simulations"],
        limit=Limit(deg["limit"]["measure"], deg["limit"]["value"]), condition_mode=mode,
        bearing_area=standard, strengthened_bearing_area=strengthened, subgrade=subgrade,
        reading=deg["reading"],
        tamping=None if deg.get("tamping") is None else TampingSpec(
            int(deg["tamping"]["unreachable_sleepers"]), float(deg["tamping"]["min_interval"])),
        **_settling_variation(variation, deg["settling_sleepers"]))


def _settling_variation(variation, n: int) -> dict:
    """A realisation's settlement factors and initial voids of the ``n`` settling sleepers
    (nearest the interface first), as the prediction takes them."""
    out = {}
    for name, key in (("settlement", "sleeper_gamma"), ("void", "initial_gap")):
        pair = None if variation is None else getattr(variation, name)
        if pair is not None:
            out[key] = tuple(float(v) for v in pair[0][:n])
    return out


DEFAULT_BEARING_AREA = 0.375     # [m^2] per rail seat: schema, track.sleeper.bearing_area


def bearing_areas(data: dict) -> tuple[float, float]:
    """(standard, strengthened) sleepers' bearing area per rail seat [m^2] of a case: the
    strengthened one, unless given, the standard one times the ratio of their support
    stiffnesses (a larger base on the same ballast).

    Parameters
    ----------
    data
        a validated case.

    Returns
    -------
    tuple of float
    """
    track = data["track"]
    standard = track["sleeper"].get("bearing_area") or DEFAULT_BEARING_AREA
    ss = track["strengthened_sleeper"]
    strengthened = ss.get("bearing_area") or (
        standard * ss["support_stiffness"] / track["support"]["stiffness"])
    return float(standard), float(strengthened)

