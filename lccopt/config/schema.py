"""The case schema: a small language of value specs, the schema itself and its validator.

``SCHEMA`` declares every key of a case file once (its doc, unit, bounds and default) and
drives :func:`check`, which turns the raw mapping into typed values (floats in SI units,
ints, lists) or raises a :class:`~lccopt.errors.CaseError` of one line naming the file, the
line and the key. docs/ and the README's case reference document the same keys.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import CaseError
from ..vti.irregularity import SPECTRA
from ..vti.specs import VEHICLE_TYPES
from .profiles import ProfileError, ProfileText, pairs_rows, parse_rows, rows_text
from .reading import dotted, locate

MAX_MAGNITUDE = 1e13        # no quantity of a case comes near it (Young's modulus of steel: 2.1e11)
# A name is one path component of the run directory: never ".", "..", empty or hidden.
SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
_FLOAT_RE = re.compile(
    r"""^[-+]?(?:[0-9][0-9_]*)?(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)?$""", re.X
)

@dataclass(frozen=True)
class Num:
    """A number with optional bounds (``gt``: strictly greater)."""
    doc: str
    unit: str = "-"
    integer: bool = False
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    default: Any = None
    required: bool = True


@dataclass(frozen=True)
class Str:
    """Text, one of ``choices`` when given."""
    doc: str
    choices: tuple | None = None
    default: Any = None
    required: bool = True


@dataclass(frozen=True)
class NumList:
    """A list of numbers (``length`` fixed when given)."""
    doc: str
    unit: str = "-"
    length: int | None = None
    min_length: int = 1
    max_length: int = 50
    le: float | None = None
    gt: float | None = None
    ge: float | None = None
    default: Any = None
    required: bool = True


@dataclass(frozen=True)
class Section:
    """A mapping of fixed keys, each with its own spec (``fields``)."""
    fields: dict
    doc: str = ""
    required: bool = True


@dataclass(frozen=True)
class _Collection:
    """Several values of one spec (``item``), at most ``max_items``."""
    item: Any
    doc: str = ""
    max_items: int = 50
    required: bool = False
    default: Any = None


class Named(_Collection):
    """A mapping of user-chosen names (``SAFE_NAME``) to values of one spec (``vehicles:``)."""


class Items(_Collection):
    """A list of values of one spec (``conditions:``)."""


@dataclass(frozen=True)
class TextOrSection:
    """Text (e.g. a file name) or a mapping, checked against the one of ``sections``
    (``{key: Section}``) whose key it holds."""
    doc: str
    sections: dict
    default: Any = None
    required: bool = True


@dataclass(frozen=True)
class Rows:
    """The rows of a rail profile: text, one ``position, dip`` per line, or a list of
    [position, dip] pairs (lccopt.config.profiles); checked and kept as canonical text."""
    doc: str
    default: Any = None
    required: bool = True


@dataclass(frozen=True)
class StrList:
    """A list of distinct names from ``choices`` (one name alone is a list of one)."""
    doc: str
    choices: tuple
    default: Any = None
    required: bool = True


OBJECTIVES = ("F_rms", "F_max", "E_rms", "E_max")
CONDITION_MODES = ("worst", "mean", "each")


def _kv(doc_k: str, doc_c: str, unit_k: str, unit_c: str) -> Section:
    return Section({"stiffness": Num(doc_k, unit_k, gt=0), "damping": Num(doc_c, unit_c, ge=0)})


def _design_group(doc: str, integer: bool, counted: bool) -> Section:
    fields = {
        "kind": Str("continuous or integer", ("integer",) if integer else ("continuous",)),
        "bounds": NumList("[lower, upper]", length=2),
        "reference": (NumList("reference value of each variable") if counted
                      else Num("reference value", integer=integer)),
    }
    if counted:
        fields["count"] = Num("number of variables in the group", integer=True, ge=1, le=50)
    if not integer:
        fields["scale"] = Str("how the optimiser steps through the bounds: linear, or log (equal "
                              "ratios are equal steps; positive bounds)", ("linear", "log"),
                              required=False)
    return Section(fields, doc)


_VEHICLE_TYPE = ("three-dof: the paper's carbody-bogie-wheelset model (one wheel); bogie: one "
                 "bogie side with both wheelsets on the modelled rail (bounce and pitch) under "
                 "its carbody share; half-car: the carbody (bounce and pitch) on two such bogies "
                 "(lccopt/vti/vehicle.py)")
_VEHICLE = Section({
    "type": Str(_VEHICLE_TYPE, VEHICLE_TYPES, default="three-dof", required=False),
    "model": Str("three-dof only. paper: Eq. (A.3) as printed (bogie on two primary "
                 "suspensions, the second wheelset a fixed point); quarter-car: one primary "
                 "suspension per wheel", ("paper", "quarter-car"), default="paper",
                 required=False),
    "speed": Num("running speed", "m/s", gt=0, le=150.0),
    "carbody_mass": Num("carbody mass carried by one wheel", "kg", gt=0),
    "bogie_mass": Num("bogie mass carried by one wheel", "kg", gt=0),
    "wheelset_mass": Num("wheelset mass carried by one wheel", "kg", gt=0),
    "primary_stiffness": Num("primary suspension stiffness per wheel", "N/m", gt=0),
    "primary_damping": Num("primary suspension damping per wheel", "N s/m", ge=0),
    "secondary_stiffness": Num("secondary suspension stiffness per wheel", "N/m", gt=0),
    "secondary_damping": Num("secondary suspension damping per wheel", "N s/m", ge=0),
    "hertz_constant": Num("Hertz contact constant G", "m/N^(2/3)", gt=0),
    "hertz_load": Num("wheel load P used to linearise the Hertz spring", "N", gt=0),
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
        "youngs_modulus": Num("rail Young's modulus", "Pa", gt=0),
        "second_moment": Num("rail second moment of area", "m^4", gt=0),
        "area": Num("rail cross-section area", "m^2", gt=0),
        "density": Num("rail density", "kg/m^3", gt=0),
    }),
    "layout": Section({
        "entry_length": Num("ballast track before the level crossing", "m", gt=0, le=2000.0),
        "exit_length": Num("ballast track after the level crossing", "m", gt=0, le=2000.0),
        "sleeper_spacing": Num("standard sleeper spacing", "m", gt=0),
        "exit_first_span": Num("slab edge to first sleeper on the exit side", "m", gt=0),
    }),
    "railpad": _kv("railpad stiffness per rail seat", "railpad damping per rail seat",
                   "N/m", "N s/m"),
    "sleeper": Section({"mass": Num("sleeper mass per rail", "kg", gt=0)}),
    "support": _kv("ballast/subgrade stiffness per rail seat",
                   "ballast/subgrade damping per rail seat", "N/m", "N s/m"),
    "strengthened_sleeper": Section({
        "mass": Num("strengthened sleeper mass per rail", "kg", gt=0),
        "support_stiffness": Num("ballast/subgrade stiffness under it per rail seat", "N/m",
                                 gt=0),
        "support_damping": Num("ballast/subgrade damping under it per rail seat", "N s/m",
                               ge=0),
    }),
    "ers": Section({
        "slab_lengths": NumList("lengths of the slabs, in running order (not joined)", "m",
                                gt=0, le=1000.0),
        "compound": Section({
            "stiffness": Num("elastic compound + standard strip stiffness per metre of rail",
                             "N/m^2", gt=0),
            "damping_ratio": Num("compound damping ratio", ge=0, le=1),
        }),
        "type_ii_compound": Section({
            "stiffness": Num("compound stiffness with the Type II strip per metre of rail",
                             "N/m^2", gt=0),
            "damping_ratio": Num("compound damping ratio with the Type II strip", ge=0, le=1),
        }),
        "share_per_rail": Num("share of the whole-track slab and foundation given to one rail",
                              gt=0, le=1),
        "slab": Section({
            "youngs_modulus": Num("slab Young's modulus", "Pa", gt=0),
            "density": Num("slab density", "kg/m^3", gt=0),
            "width_bottom": Num("slab width at the bottom (whole slab)", "m", gt=0),
            "width_top": Num("slab width at the top (whole slab)", "m", gt=0),
            "height": Num("slab height", "m", gt=0),
        }),
        "foundation": _kv("foundation stiffness per metre of slab (whole slab)",
                          "foundation damping per metre of slab (whole slab)", "N/m^2",
                          "N s/m^2"),
    }),
})

_DESIGN = Section({
    "railpad_stiffness": _design_group("stiffness of the pads next to the interface, x_r1 "
                                       "farthest .. x_rN nearest", integer=False, counted=True),
    "strengthened_sleepers": _design_group("number of strengthened sleepers next to the "
                                           "interface", integer=True, counted=False),
    "sleeper_spans": _design_group("spans next to the interface in 0.1 m elements, x_s1 "
                                   "farthest .. x_sM from the slab edge to the first sleeper",
                                   integer=True, counted=True),
    "type_ii_strip": _design_group("length of Type II strip from the entry slab edge, in 0.1 m "
                                   "elements", integer=True, counted=False),
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

_OPTIMISATION = Section({
    "objectives": StrList("objectives to minimise; two or more are scalarised by the ASF",
                          OBJECTIVES),
    "budget": Num("evaluations in all, failures included", integer=True, ge=2, le=100_000),
    "initial_points": Num("initial design size, reference design included", integer=True, ge=2,
                          le=10_000),
    "seed": Num("random seed", integer=True, ge=0, default=0, required=False),
    "timeout": Num("per-evaluation timeout", "s", gt=0, default=600.0, required=False),
    "conditions": Str("how the objectives of several traffic conditions combine: worst (max "
                      "over conditions), mean (weighted mean) or each (every condition's "
                      "objective is an objective of its own, named like F_max@name)",
                      CONDITION_MODES, default="worst", required=False),
    "asf": Section({
        "rho": Num("augmentation coefficient of the Chebyshev ASF", ge=0, default=0.05,
                   required=False),
        "improvement": Num("reference point = reference design improved by this fraction",
                           ge=0, le=1, default=0.2, required=False),
        "worst": NumList("worst obtainable value of each objective (kappa_i = 1/(worst_i - "
                         "ref_i))", gt=0, max_length=len(OBJECTIVES) * 50, required=False),
    }, required=False),
}, required=False)

# Traffic conditions: named vehicles take every key of `vehicle:` (the speed is the
# condition's), and each condition runs one simulation of every design.
_VEHICLES = Named(
    Section({**_VEHICLE.fields,
             "speed": Num("default speed of the vehicle's conditions", "m/s", gt=0, le=150.0,
                          required=False)}, "a vehicle, with the keys of the vehicle section"),
    "named vehicles for the conditions (each with the keys of the vehicle section)")
_CONDITIONS = Items(Section({
    "name": Str("condition name (letters, digits, '.', '-', '_'); objectives of it are named "
                "like F_max@name"),
    "vehicle": Str("a name from vehicles:, or case for the case's vehicle section",
                   default="case", required=False),
    "speed": Num("running speed (default: the vehicle's)", "m/s", gt=0, le=150.0,
                 required=False),
    "direction": Str("enter: from the designed ballast side into the ERS; leave: from the ERS "
                     "onto the designed side", ("enter", "leave"), default="enter",
                     required=False),
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
    "evaluation": Section({
        "sleepers": Num("sleepers of the evaluation zone (next to the interface)", integer=True,
                        ge=1),
        "force_zone_after_interface": Num("the force zone ends this far into the ERS", "m",
                                          ge=0),
    }),
    "simulation": _SIMULATION,
    "optimisation": _OPTIMISATION,
    "vehicles": _VEHICLES,
    "conditions": _CONDITIONS,
})


def check(value: Any, spec: Any, path: tuple, lines: dict, file: str) -> Any:
    """Validate one value against its spec; return the typed value."""
    def fail(msg: str, at: tuple = path) -> CaseError:
        return CaseError(f"{locate(lines, at, file)}: {dotted(at) or '<top>'}: {msg}")

    def sub(v: Any, s: Any, key) -> Any:
        return check(v, s, path + (key,), lines, file)

    if isinstance(spec, Section):
        return _section(value, spec, sub, fail, lambda k: lines.get(path + (k,), file + ":1"),
                        path)
    if isinstance(spec, (Named, Items)):
        return _collection(value, spec, sub, fail, path)
    if isinstance(spec, TextOrSection):
        if isinstance(value, dict):
            keys = [k for k in spec.sections if k in value]
            if len(keys) != 1:
                raise fail(f"expected a mapping with one of the keys "
                           f"{' or '.join(repr(k) for k in spec.sections)}")
            return check(value, spec.sections[keys[0]], path, lines, file)
        if not isinstance(value, str):
            raise fail(f"expected a file name or a mapping, got {value!r:.60}")
        return value
    if isinstance(spec, Rows):
        return _rows(value, fail)
    if isinstance(spec, Num):
        return _number(value, spec, fail)
    if isinstance(spec, Str):
        if value is None and not spec.required:
            return None
        if not isinstance(value, str):
            raise fail(f"expected text, got {value!r}")
        if spec.choices and value not in spec.choices:
            raise fail(f"must be one of {', '.join(spec.choices)}, got '{value}'")
        return value
    if isinstance(spec, NumList):
        return _numbers(value, spec, fail, path)
    if isinstance(spec, StrList):
        return _names(value, spec, fail)
    raise TypeError(spec)


def _section(value: Any, spec: Section, sub, fail, line_of, path: tuple) -> dict:
    """A section: no unknown key, every required key, defaults for the others."""
    if not isinstance(value, dict):
        raise fail(f"expected a section (mapping), got {type(value).__name__}")
    unknown = [k for k in value if k not in spec.fields]
    if unknown:
        k = unknown[0]
        raise CaseError(f"{line_of(k)}: {dotted(path + (k,))}: unknown key (expected one of: "
                        f"{', '.join(spec.fields)})")
    out = {}
    for key, field_spec in spec.fields.items():
        if value.get(key) is None:  # absent, or written as null
            if getattr(field_spec, "required", True):
                raise fail(f"missing key '{key}'")
            optional_only = isinstance(field_spec, Section) and not any(
                getattr(f, "required", True) for f in field_spec.fields.values())
            out[key] = (sub({}, field_spec, key) if optional_only
                        else getattr(field_spec, "default", None))
            continue
        out[key] = sub(value[key], field_spec, key)
    return out


def _collection(value: Any, spec: _Collection, sub, fail, path: tuple):
    """Named (a mapping of names) or Items (a list), each value of ``spec.item``."""
    if isinstance(spec, Named):
        if not isinstance(value, dict) or not value:
            raise fail("expected a mapping of names to sections")
    elif not isinstance(value, list) or not value:
        raise fail("expected a list")
    if len(value) > spec.max_items:
        raise fail(f"{len(value)} entries; at most {spec.max_items}")
    if isinstance(spec, Items):
        return [sub(v, spec.item, i) for i, v in enumerate(value)]
    for k in value:
        if not isinstance(k, str) or not SAFE_NAME.fullmatch(k):
            raise fail(f"{str(k)[:40]!r} is not a name (1-64 letters, digits, '.', '-' "
                       f"and '_')", path + (k,))
    return {k: sub(v, spec.item, k) for k, v in value.items()}


def _numbers(value: Any, spec: NumList, fail, path: tuple) -> list:
    if not isinstance(value, list):
        raise fail(f"expected a list of numbers, got {value!r:.60}")
    if spec.length is not None and len(value) != spec.length:
        raise fail(f"expected {spec.length} values, got {len(value)}")
    if len(value) < spec.min_length:
        raise fail(f"expected at least {spec.min_length} value(s)")
    if len(value) > spec.max_length:
        raise fail(f"{len(value)} values; at most {spec.max_length}")
    item = Num(spec.doc, spec.unit, gt=spec.gt, ge=spec.ge, le=spec.le)
    return [_number(v, item, lambda m, i=i: fail(m, path + (i,))) for i, v in enumerate(value)]


def _names(value: Any, spec: StrList, fail) -> list:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not value:
        raise fail("expected a list of names")
    for v in value:
        if v not in spec.choices:
            raise fail(f"unknown name {v!r} (expected some of {', '.join(spec.choices)})")
    if len(set(value)) != len(value):
        raise fail("a name is listed twice")
    return list(value)


def _rows(value: Any, fail) -> ProfileText:
    """A profile's rows (text or pairs), checked, as canonical text."""
    try:
        if isinstance(value, str):
            rows = parse_rows(value)
        elif isinstance(value, list):
            rows = pairs_rows(value)
        else:
            raise fail(f"expected rows 'position, dip' (text) or [position, dip] pairs, got "
                       f"{value!r:.60}")
    except ProfileError as exc:
        where = "line" if isinstance(value, str) else "pair"
        raise fail(f"{where} {exc.line}: {exc}") from None
    return rows_text(rows)


def _number(value: Any, spec: Num, fail) -> float | int:
    """A number checked against ``spec``: an int for an integer spec, else a float."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > MAX_MAGNITUDE:
        raise fail(f"{str(value)[:12]}... ({len(str(abs(value)))} digits) is not a plausible value")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        if isinstance(value, str) and _FLOAT_RE.match(value.strip()) and value.strip():
            value = float(value)  # e.g. "1_120e6"
        else:
            raise fail(f"expected a number, got {value!r}")
    if not np.isfinite(value):
        raise fail(f"must be finite, got {value!r}")
    if abs(value) > MAX_MAGNITUDE:
        raise fail(f"{value:g} is not a plausible value (|value| <= {MAX_MAGNITUDE:g} in SI units)")
    if spec.integer:
        if float(value) != int(value):
            raise fail(f"must be a whole number, got {value!r}")
        value = int(value)
    else:
        value = float(value)
    unit = f" {spec.unit}" if spec.unit != "-" else ""
    if spec.gt is not None and not value > spec.gt:
        raise fail(f"must be > {spec.gt:g}{unit}, got {value:g}")
    if spec.ge is not None and not value >= spec.ge:
        raise fail(f"must be >= {spec.ge:g}{unit}, got {value:g}")
    if spec.le is not None and not value <= spec.le:
        raise fail(f"must be <= {spec.le:g}{unit}, got {value:g}")
    return value


