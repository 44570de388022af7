"""The case schema: every key of a case file, once, with its doc, unit, bounds and default.

``SCHEMA`` is written with the kinds of value of ``lccopt.config.kinds`` and drives
:func:`lccopt.config.validate.check`, which turns the raw mapping into typed values (floats in
SI units, ints, lists) or raises a :class:`~lccopt.errors.CaseError` of one line naming the
file, the line and the key. docs/case-reference.md is generated from it
(``python -m lccopt.config.reference``).

Bounds that no real crossing or vehicle comes near (a speed above 250 km/h, a railpad softer
than 10 MN/m, a steel rail of 210 Pa) say why (``why``): they catch a value written in the
wrong unit, and the message proposes the unit that fits.
"""

from __future__ import annotations

from ..optim.scalarise import IMPROVEMENT, RHO
from ..uncertainty.statistics import ObjectiveNames
from ..vti.irregularity import SPECTRA
from ..vti.pads import NAMED_PADS
from ..vti.response import PAPER_OBJECTIVES, REPORTED_ONLY, SETTLEMENT_OBJECTIVES
from ..vti.specs import ZONE_POINTS
from ..vti.vehicle import DEFAULT_TYPE, VEHICLE_TYPES
from .kinds import (
    Items,
    Named,
    Num,
    NumList,
    Rows,
    Section,
    Str,
    StrList,
    TextOrSection,
)
from .plausible import MASS_WHY, PAD_WHY, RATIO_WHY, SEAT_WHY, SPEED
from .schema_degradation import DEGRADATION
from .schema_uncertainty import UNCERTAINTY
from .validate import MAX_MAGNITUDE, SAFE_NAME, check  # noqa: F401  (the schema's validator)

# years_to_limit is listed so that asking to minimise it gets its own message (checks)
# any of them also in a robust statistic (a case with uncertainty:): mean(F_max), q90(F_max)
OBJECTIVES = ObjectiveNames(PAPER_OBJECTIVES + SETTLEMENT_OBJECTIVES + REPORTED_ONLY)
CONDITION_MODES = ("worst", "mean", "each")
HISTORIES = ("all", "best", "none")


def _kv(doc_k: str, doc_c: str, unit_k: str, unit_c: str, **bounds) -> Section:
    bounds = bounds or {"gt": 0}
    return Section({"stiffness": Num(doc_k, unit_k, **bounds),
                    "damping": Num(doc_c, unit_c, ge=0)})


def _design_group(doc: str, integer: bool, counted: bool, unit: str = "-",
                  bounds_doc: str = "", **bounds) -> Section:
    fields = {
        "kind": Str("continuous or integer (a length: whole 0.1 m steps)",
                    ("integer",) if integer else ("continuous",)),
        "bounds": NumList("[lower, upper]" + bounds_doc, unit, length=2,
                          required=not bounds_doc, **bounds),
        "reference": (NumList("reference value of each variable", unit, **bounds) if counted
                      else Num("reference value", unit, integer=integer, **bounds)),
    }
    if counted:
        fields["count"] = Num("number of variables in the group", integer=True, ge=1, le=50)
    if not integer:
        fields["scale"] = Str("how the optimiser steps through the bounds: linear, or log (equal "
                              "ratios are equal steps; positive bounds)", ("linear", "log"),
                              required=False)
    return Section(fields, doc)


def _pad_group() -> Section:
    """The designed pads: their stiffness under the wheel, or as bought with their ratio."""
    group = _design_group("stiffness of the pads next to the interface, x_r1 farthest .. x_rN "
                          "nearest: under the wheel, or as bought (static) with "
                          "dynamic_to_static", integer=False, counted=True, unit="N/m",
                          ge=1e7, le=1e10, shown="MN/m", why=PAD_WHY)
    fields = dict(group.fields)
    fields["dynamic_to_static"] = Num(
        "when given, x_r (bounds, reference) are the pads' static (catalogue) stiffness and "
        "the simulation uses x_r times this, the dynamic-to-static ratio of the pad type "
        "searched (its EN 13146-9 test report); absent, x_r is the stiffness under the wheel",
        ge=1.0, le=10.0, why=RATIO_WHY, required=False, keep_absent=True)
    return Section(fields, group.doc)


_VEHICLE_TYPE = "; ".join(f"{t.name}: {t.doc}" for t in VEHICLE_TYPES.values()) \
    + " (lccopt/vti/vehicle.py)"
_VEHICLE = Section({
    "type": Str(_VEHICLE_TYPE, tuple(VEHICLE_TYPES), default=DEFAULT_TYPE, required=False),
    "model": Str("three-dof only. paper: Eq. (A.3) as printed (bogie on two primary "
                 "suspensions, the second wheelset a fixed point); quarter-car: one primary "
                 "suspension per wheel", tuple(m for t in VEHICLE_TYPES.values() for m in t.models),
                 default="paper", required=False),
    "speed": Num("running speed; a bare number is in m/s (write 140 km/h for km/h)", **SPEED),
    "carbody_mass": Num("carbody mass carried by one wheel (a 4-axle car: 1/8 of the carbody)",
                        "kg", ge=10, why=MASS_WHY),
    "bogie_mass": Num("bogie mass carried by one wheel (1/4 of a two-axle bogie)", "kg", ge=10,
                      why=MASS_WHY),
    "wheelset_mass": Num("unsprung mass on one wheel: half a wheelset for bogie and half-car "
                         "(each wheel is one end of its axle); the paper's three-dof reading "
                         "puts the whole wheelset on its one wheel", "kg", ge=10, why=MASS_WHY),
    "primary_stiffness": Num("primary suspension stiffness per wheel (per axle box)", "N/m",
                             ge=1e4, shown="kN/m", why="suspensions are 0.1-10 MN/m per wheel"),
    "primary_damping": Num("primary suspension damping per wheel", "N s/m", ge=0),
    "secondary_stiffness": Num("secondary suspension stiffness per wheel (half the spring of "
                               "one bogie side)", "N/m", ge=1e4, shown="kN/m",
                               why="suspensions are 0.1-10 MN/m per wheel"),
    "secondary_damping": Num("secondary suspension damping per wheel", "N s/m", ge=0),
    "hertz_constant": Num("Hertz contact constant G", "m/N^(2/3)", gt=0),
    "hertz_load": Num("wheel load P used to linearise the Hertz spring", "N", ge=1e3, le=1e6,
                      shown="kN", why="wheel loads are some 20-200 kN"),
    "gravity": Num("gravitational acceleration", "m/s^2", gt=0, default=9.81, required=False),
    # bogie and half-car (per-wheel values above as for three-dof; lccopt/vti/vehicle.py)
    "wheelbase": Num("bogie and half-car: distance between the two wheelsets of a bogie", "m",
                     gt=0, le=20.0, required=False),
    "bogie_pitch_inertia": Num("bogie and half-car: pitch inertia of the bogie frame on the "
                               "modelled rail (half the whole bogie's)", "kg m^2", gt=0,
                               required=False),
    "carbody_pitch_inertia": Num("half-car: pitch inertia of the carbody on the modelled rail "
                                 "(half the whole carbody's)", "kg m^2", gt=0, required=False),
    "bogie_distance": Num("half-car: distance between the two bogie centres", "m", gt=0,
                          le=50.0, required=False),
}, "the vehicle on one rail: the 3-dof model, a bogie or a half car (masses and suspension "
   "values per wheel, see lccopt/vti/vehicle.py)")

_TRACK = Section({
    "rail": Section({
        "youngs_modulus": Num("rail Young's modulus", "Pa", ge=1e9, shown="GPa",
                              why="steel is 210 GPa"),
        "second_moment": Num("rail second moment of area", "m^4", gt=0, le=1e-3,
                             why="rails are some 1000-5000 cm^4"),
        "area": Num("rail cross-section area", "m^2", gt=0, le=0.1,
                    why="rails are some 50-100 cm^2"),
        "density": Num("rail density", "kg/m^3", ge=100, why="steel is 7850 kg/m^3"),
    }),
    "layout": Section({
        "entry_length": Num("ballast track before the level crossing", "m", gt=0, le=2000.0),
        "exit_length": Num("ballast track after the level crossing", "m", gt=0, le=2000.0),
        "sleeper_spacing": Num("standard sleeper spacing", "m", gt=0, le=2.0,
                               why="sleepers are some 0.6 m apart"),
        "exit_first_span": Num("slab edge to first sleeper on the exit side", "m", gt=0,
                               le=2.0, why="a sleeper span is some 0.3-0.7 m"),
    }),
    "railpad": Section({
        "type": Str("a named pad whose published values lccopt holds (lccopt/vti/pads.py): "
                    "its stiffness under the wheel and damping; then no other key",
                    tuple(NAMED_PADS), required=False, keep_absent=True),
        "stiffness": Num("the pad's stiffness under the wheel (dynamic, per rail seat): what "
                         "the simulation uses", "N/m", ge=1e7, le=1e10, shown="MN/m",
                         why=PAD_WHY, required=False, keep_absent=True),
        "static_stiffness": Num("the pad as bought: its static (catalogue, EN 13146-9) "
                                "stiffness; with dynamic_to_static instead of stiffness, or "
                                "beside it (then shown, not used)", "N/m", ge=1e7, le=1e10,
                                shown="MN/m", why=PAD_WHY, required=False, keep_absent=True),
        "dynamic_to_static": Num("the pad's dynamic (EN 13146-9 low-frequency, preloaded) over "
                                 "its static stiffness, from its test report: stiffness = "
                                 "static_stiffness x this", ge=1.0, le=10.0, why=RATIO_WHY,
                                 required=False, keep_absent=True),
        "damping": Num("railpad damping per rail seat (the designed pads' scales with their "
                       "stiffness under the wheel)", "N s/m", ge=0, required=False,
                       keep_absent=True),
    }, "the pads of the sleepers not designed, per rail seat: a named pad (type), or its "
       "stiffness under the wheel, or its static stiffness and dynamic_to_static; and its "
       "damping (docs/model.md, 'Pads as bought')"),
    "sleeper": Section({"mass": Num("sleeper mass per rail (half the sleeper)", "kg", ge=10,
                                    why="a sleeper is some 100-400 kg"),
                        "bearing_area": Num(
                            "settlement (degradation:) only: the sleeper's base area that "
                            "carries one rail seat's force (the law is fed force / area). "
                            "Default 0.375 m^2: half the base of a 2.5 m x 0.30 m monoblock, "
                            "as AREMA's average ballast pressure spreads each rail seat's "
                            "force over half the base (docs/settlement.md)", "m^2", gt=0,
                            le=2.0, why="half a sleeper's base is some 0.2-0.6 m^2",
                            required=False, keep_absent=True)}),
    "support": _kv("ballast/subgrade stiffness per rail seat",
                   "ballast/subgrade damping per rail seat", "N/m", "N s/m", ge=1e6,
                   shown="MN/m", why=SEAT_WHY),
    "strengthened_sleeper": Section({
        "mass": Num("strengthened sleeper mass per rail", "kg", ge=10,
                    why="a sleeper is some 100-400 kg"),
        "support_stiffness": Num("ballast/subgrade stiffness under it per rail seat", "N/m",
                                 ge=1e6, shown="MN/m", why=SEAT_WHY),
        "support_damping": Num("ballast/subgrade damping under it per rail seat", "N s/m",
                               ge=0),
        "bearing_area": Num("settlement (degradation:) only: its base area per rail seat. "
                            "Default: the standard sleeper's bearing_area x support_stiffness "
                            "/ the standard support stiffness (a larger base on the same "
                            "ballast: area and stiffness in proportion)", "m^2", gt=0, le=2.0,
                            why="half a sleeper's base is some 0.2-0.6 m^2", required=False,
                            keep_absent=True),
    }),
    "ers": Section({
        "slab_lengths": NumList("lengths of the slabs, in running order (not joined); the "
                                "ERS is their sum", "m", gt=0, le=1000.0),
        "compound": Section({
            "stiffness": Num("elastic compound + standard strip stiffness per metre of rail",
                             "N/m^2", ge=1e5, shown="MN/m^2",
                             why="fastenings are some 5-200 MN/m per metre"),
            "damping_ratio": Num("compound damping ratio", ge=0, le=1),
        }),
        "type_ii_compound": Section({
            "stiffness": Num("compound stiffness with the Type II strip per metre of rail",
                             "N/m^2", ge=1e5, shown="MN/m^2",
                             why="fastenings are some 5-200 MN/m per metre"),
            "damping_ratio": Num("compound damping ratio with the Type II strip", ge=0, le=1),
        }),
        "share_per_rail": Num("share of the whole-track slab and foundation given to one rail",
                              gt=0, le=1),
        "slab": Section({
            "youngs_modulus": Num("slab Young's modulus", "Pa", ge=1e9, shown="GPa",
                                  why="concrete is some 20-50 GPa"),
            "density": Num("slab density", "kg/m^3", ge=100, why="concrete is 2400 kg/m^3"),
            "width_bottom": Num("slab width at the bottom (whole slab)", "m", gt=0, le=20.0),
            "width_top": Num("slab width at the top (whole slab)", "m", gt=0, le=20.0),
            "height": Num("slab height", "m", gt=0, le=5.0),
        }),
        "foundation": _kv("foundation stiffness per metre of slab (whole slab)",
                          "foundation damping per metre of slab (whole slab)", "N/m^2",
                          "N s/m^2", ge=1e5, shown="MN/m^2",
                          why="foundations are some 10-5000 MN/m per metre"),
    }),
})

_DESIGN = Section({
    "railpad_stiffness": _pad_group(),
    "strengthened_sleepers": _design_group("number of strengthened sleepers next to the "
                                           "interface", integer=True, counted=False),
    # lengths: written with their unit, held as whole 0.1 m elements (config/variables.py)
    "sleeper_spans": _design_group("spans next to the interface, x_s1 farthest .. x_sM from "
                                   "the slab edge to the first sleeper; lengths with their unit "
                                   "(0.6 m), in steps of 0.1 m (the rail's elements)",
                                   integer=True, counted=True, unit="m"),
    "type_ii_strip": _design_group("length of Type II strip from the entry slab edge (at most "
                                   "the ERS), with its unit (1.2 m), in steps of 0.1 m",
                                   integer=True, counted=False, unit="m",
                                   bounds_doc=". Default: [0 m, the ERS's length], so that "
                                              "the strip may cover the whole crossing"),
})

# amplitude_scale <= 10: ten times a standard spectrum is beyond any class of track it
# describes; the profile itself is held to |dip| <= 0.05 m (lccopt.config.profiles).
_IRREGULARITY = TextOrSection(
    "CSV file (position m, dip m) of the vertical rail profile, relative to the case file; "
    "or its rows in the case (points:); or a random profile from a standard spectrum "
    "(spectrum:, lccopt/vti/irregularity.py); none for a smooth rail",
    {"spectrum": Section({
        "spectrum": Str("erri-low, erri-high (ORE/ERRI B176), fra-4, fra-5, fra-6 (FRA classes)",
                        SPECTRA),
        "seed": Num("random seed: the same profile for every design", integer=True, ge=0),
        "wavelengths": NumList("[min, max] band of wavelengths generated", "m", length=2, gt=0),
        "amplitude_scale": Num("factor on the profile", ge=0, le=10.0, default=1.0,
                               required=False),
     }), "points": Section({
        "source": Str("where the rows came from (the CSV file a case named); not read",
                      required=False),
        "points": Rows("rows 'position, dip' in m, one per line (or [position, dip] pairs); "
                       "increasing positions, |dip| <= 0.05 m"),
     })}, required=False, default=None)

_SIMULATION = Section({
    "time_step": Num("Newmark time step", "s", gt=0),
    "element_length": Num("rail element length where the wheel runs (must divide 0.1 m)", "m",
                          ge=0.01, le=0.1),
    "far_element_length": Num("longest rail element away from the wheel (supports stay on "
                              "nodes)", "m", ge=0.01, le=0.6, default=0.3, required=False),
    "run_in": Num("distance run before the evaluation zone", "m", ge=0, le=1000.0),
    "run_out": Num("distance run after the force zone (sleepers settle)", "m", ge=0,
                   le=1000.0),
    "direction": Str("enter: the vehicle runs towards +x, from the designed entry ballast into "
                     "the ERS; leave: towards -x, from the ERS onto the designed side (same "
                     "zone)", ("enter", "leave"), default="enter", required=False),
    "irregularity": _IRREGULARITY,
})

# Where the force zone ends (lccopt.config.zones): 2 m before the ERS's far edge unless a
# case says otherwise. Why 2 m: configs/reference.yaml, evaluation.
DEFAULT_FORCE_ZONE_END = {"at": "exit_interface", "offset": -2.0}
_EVALUATION = Section({
    "sleepers": Num("sleepers of the evaluation zone: the entry sleepers next to the "
                    "interface whose ballast energies give E_rms and E_max; the zone starts "
                    "at the farthest", integer=True, ge=1),
    "force_zone_end": Section({
        "at": Str("a named point of the layout: entry_interface (where the designed ballast "
                  "meets the ERS) or exit_interface (the ERS's far edge)", ZONE_POINTS),
        "offset": Num("distance from that point towards the exit side (negative: towards the "
                      "entry side)", "m", ge=-1000.0, le=1000.0, default=0.0,
                      required=False),
    }, "where the force zone (F_rms, F_max) ends; it starts at the farthest zone sleeper. "
       "Default: {at: exit_interface, offset: -2.0}, 2 m before the ERS's far edge, so that "
       "the zone follows the layout", required=False, keep_absent=True),
    "force_zone_after_interface": Num(
        "older form of force_zone_end: a length from the entry interface, the same as "
        "{at: entry_interface, offset: this}; it does not follow slab_lengths", "m", ge=0,
        required=False, keep_absent=True),
})

DEFAULT_INITIAL_POINTS = 20
_OPTIMISATION = Section({
    "objectives": StrList("objectives to minimise; two or more are scalarised by the ASF "
                          "(required by lccopt optimise). F_rms, F_max [N], E_rms, E_max [J]: "
                          "the paper's; the others need degradation: (docs/settlement.md): "
                          "differential_settlement, max_settlement, max_void, level_std [m], "
                          "force_growth [-], maintenance_rate [1/year] (1 / years_to_limit, "
                          "which is reported, not minimised), level_d1_max, level_d1_std, "
                          "rail_step [m], rail_angle [-], interventions [-] (tamping:). With "
                          "uncertainty: any of them over the realisations: mean(F_max), "
                          "q90(F_max) (a quantile, q1-q99), p_worse(F_max) (docs/robust.md)",
                          OBJECTIVES, required=False),
    "budget": Num("evaluations in all, failures included (required by lccopt optimise)",
                  integer=True, ge=2, le=100_000, required=False),
    "initial_points": Num("initial design size, reference design included. Default: 20 (the "
                          "paper's, for 8 variables), 2 (d + 1) for d > 9 variables, never "
                          "above the budget", integer=True, ge=2, le=10_000, required=False),
    "seed": Num("random seed", integer=True, ge=0, default=0, required=False),
    "timeout": Num("per-evaluation timeout", "s", gt=0, default=600.0, required=False),
    "conditions": Str("how the objectives of several traffic conditions combine: worst (max "
                      "over conditions), mean (weighted mean) or each (every condition's "
                      "objective is an objective of its own, named like F_max@name)",
                      CONDITION_MODES, default="worst", required=False),
    "proposals_per_fit": Num(
        "designs proposed from one surrogate fit, at most the worker count. 1: each proposal "
        "sees every result the schedule allows (the best designs per evaluation); more keeps "
        "many workers busy when evaluations take well under a second, at a cost in quality "
        "(docs/runs.md, Scale)", integer=True, ge=1, le=1024, default=1, required=False,
        keep_absent=True),
    "histories": Str("time histories an optimisation keeps in evals/: all (every design's), "
                     "best (the reference design's and the best design's; the other files "
                     "hold the design, objectives and facts) or none. Default: best",
                     HISTORIES, default="best", required=False, keep_absent=True),
    "asf": Section({
        "rho": Num("augmentation coefficient of the Chebyshev ASF", ge=0, default=RHO,
                   required=False),
        "improvement": Num("reference point = reference design improved by this fraction",
                           ge=0, le=1, default=IMPROVEMENT, required=False),
        "worst": NumList("worst obtainable value of each objective, in its SI unit (N for "
                         "F_*, J for E_*, m for settlements, 1/year for maintenance_rate): "
                         "kappa_i = 1/(worst_i - ref_i). Default: 1.5 x the reference "
                         "design's value, set once evaluation #0 is in", gt=0,
                         max_length=len(OBJECTIVES) * 50, required=False),
    }, required=False),
}, "what lccopt optimise needs; check and simulate never do", required=False,
   none_if_absent=True)

# Traffic conditions: named vehicles take every key of `vehicle:` (the speed is the
# condition's), and each condition runs one simulation of every design.
_VEHICLES = Named(
    Section({**_VEHICLE.fields,
             "speed": Num("default speed of the vehicle's conditions", required=False,
                          **SPEED)}, "a vehicle, with the keys of the vehicle section"),
    "named vehicles for the conditions (each with the keys of the vehicle section)")
_CONDITIONS = Items(Section({
    "name": Str("condition name (letters, digits, '.', '-', '_'); objectives of it are named "
                "like F_max@name"),
    "vehicle": Str("a name from vehicles:, or case for the case's vehicle section",
                   default="case", required=False),
    "speed": Num("running speed (default: the vehicle's)", required=False, **SPEED),
    "direction": Str("enter: from the designed ballast side into the ERS; leave: from the ERS "
                     "onto the designed side. Default: the case's simulation.direction",
                     ("enter", "leave"), default=None, required=False),
    # the same forms as simulation.irregularity (default: that one); none: a smooth rail
    "irregularity": _IRREGULARITY,
    "weight": Num("weight of the condition in the weighted mean (conditions: mean)", gt=0,
                  default=1.0, required=False),
}), "traffic conditions; without this list the case is one condition: its vehicle section")

SCHEMA = Section({
    "name": Str("case name, also the run directory name (letters, digits, - and _)"),
    "description": Str("free text", required=False, default=""),
    "vehicle": _VEHICLE,
    "track": _TRACK,
    "design": _DESIGN,
    "evaluation": _EVALUATION,
    "simulation": _SIMULATION,
    "optimisation": _OPTIMISATION,
    "vehicles": _VEHICLES,
    "conditions": _CONDITIONS,
    "degradation": DEGRADATION,
    "uncertainty": UNCERTAINTY,
})
