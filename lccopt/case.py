"""Case files: YAML -> validated, typed :class:`Case` in SI units.

Every problem found in a case file is reported as one line
``FILE:LINE: KEY.PATH: what is wrong`` through :class:`CaseError`; the CLI
prints it and exits with status 2.

The schema is declared once (``SCHEMA``) and drives validation; the README's "Case files"
section documents the keys.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ELEMENT_UNIT = 0.1  # [m] sleeper spans and strip length are counted in 0.1 m elements (paper, Table 4)


class CaseError(ValueError):
    """A case file problem, already formatted as ``file:line: key: message``."""


# --------------------------------------------------------------------------- YAML with line numbers

_FLOAT_RE = re.compile(
    r"""^[-+]?(?:[0-9][0-9_]*)?(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)?$""", re.X
)


MAX_CASE_BYTES = 1_000_000  # a case file is a few kB; anything near this is not one
MAX_DEPTH = 20              # sections nest 4 deep; deeper is an attack on the recursive reader
MAX_MAGNITUDE = 1e13        # no quantity of a case comes near it (Young's modulus of steel: 2.1e11)


class _Loader(yaml.SafeLoader):
    """SafeLoader that reads ``1120e6`` as a float (PyYAML's YAML 1.1 rules make it a string),
    refuses anchors/aliases (an alias bomb expands exponentially) and deep nesting."""

    _depth = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent) or getattr(self.peek_event(), "anchor", None):
            raise yaml.composer.ComposerError(
                None, None, "anchors and aliases (&name, *name) are not allowed in case files; "
                "use 'extends: other.yaml' to share values", self.peek_event().start_mark)
        self._depth += 1
        if self._depth > MAX_DEPTH:
            raise yaml.composer.ComposerError(None, None, f"nested more than {MAX_DEPTH} levels deep",
                                              self.peek_event().start_mark)
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


_PLAIN_TAGS = ("tag:yaml.org,2002:map", "tag:yaml.org,2002:seq")


def _build(node: yaml.Node, loader: _Loader, path: tuple, lines: dict, file: str) -> Any:
    """Turn a composed YAML node into plain Python objects, remembering each key's line."""
    lines[path] = f"{file}:{node.start_mark.line + 1}"
    if node.tag not in _PLAIN_TAGS and not isinstance(node, yaml.ScalarNode):  # scalars: constructor
        raise CaseError(f"{file}:{node.start_mark.line + 1}: {_dotted(path) or '<top>'}: "
                        f"YAML tags ({node.tag}) are not allowed in case files")
    if isinstance(node, yaml.MappingNode):
        out: dict = {}
        for key_node, value_node in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                raise CaseError(f"{file}:{key_node.start_mark.line + 1}: {_dotted(path) or '<top>'}: "
                                f"merge keys (<<) are not allowed in case files; use 'extends:'")
            key = loader.construct_object(key_node)
            if not isinstance(key, str):
                raise CaseError(f"{file}:{key_node.start_mark.line + 1}: {_dotted(path) or '<top>'}: "
                                f"keys must be strings, got {key!r}")
            if key in out:
                raise CaseError(f"{file}:{key_node.start_mark.line + 1}: {_dotted(path + (key,))}: "
                                f"duplicate key")
            out[key] = _build(value_node, loader, path + (key,), lines, file)
            lines[path + (key,)] = f"{file}:{key_node.start_mark.line + 1}"
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_build(v, loader, path + (i,), lines, file) for i, v in enumerate(node.value)]
    return loader.construct_object(node, deep=True)


def _dotted(path: tuple) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


def read_yaml(text: str, file: str) -> tuple[dict, dict]:
    """Parse YAML text; return (data, {key path: line})."""
    if len(text) > MAX_CASE_BYTES:
        raise CaseError(f"{file}:1: <file>: {len(text)} characters; a case file is at most "
                        f"{MAX_CASE_BYTES} (is this the right file?)")
    if "\x00" in text:
        line = text.count("\n", 0, text.index("\x00")) + 1
        raise CaseError(f"{file}:{line}: <file>: binary data (NUL byte); a case file is YAML text")
    lines: dict = {}  # key path -> "file:line"
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise CaseError(f"{file}:1: <top>: the file is empty")
        data = _build(node, _Loader(""), (), lines, file)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else 1
        raise CaseError(f"{file}:{line}: <yaml>: {exc.problem or exc}") from None
    except yaml.YAMLError as exc:  # e.g. the reader's "special characters are not allowed"
        at = text.count("\n", 0, exc.position) + 1 if isinstance(getattr(exc, "position", None), int) else 1
        raise CaseError(f"{file}:{at}: <yaml>: {str(exc).splitlines()[0]}") from None
    except RecursionError:
        raise CaseError(f"{file}:1: <yaml>: nested too deeply") from None
    finally:
        loader.dispose()
    if not isinstance(data, dict):
        raise CaseError(f"{file}:1: <top>: a case file is a mapping of sections")
    return data, lines


# --------------------------------------------------------------------------- schema

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
    gt: float | None = None
    ge: float | None = None
    default: Any = None
    required: bool = True


@dataclass(frozen=True)
class Section:
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
    """Text (e.g. a file name) or a mapping checked against ``section``."""
    doc: str
    section: Section
    default: Any = None
    required: bool = True


@dataclass(frozen=True)
class StrList:
    doc: str
    choices: tuple
    default: Any = None
    required: bool = True


OBJECTIVES = ("F_rms", "F_max", "E_rms", "E_max")
CONDITION_MODES = ("worst", "mean", "each")
OBJECTIVE_UNITS = {"F_rms": "N", "F_max": "N", "E_rms": "J", "E_max": "J"}


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


SCHEMA = Section({
    "name": Str("case name, also the run directory name (letters, digits, - and _)"),
    "description": Str("free text", required=False, default=""),
    "vehicle": Section({
        "type": Str("three-dof: the paper's carbody-bogie-wheelset model (one wheel); bogie: one "
                    "bogie side with both wheelsets on the modelled rail (bounce and pitch) under "
                    "its carbody share; half-car: the carbody (bounce and pitch) on two such bogies "
                    "(lccopt/vti/vehicle.py)", ("three-dof", "bogie", "half-car"),
                    default="three-dof", required=False),
        "model": Str("three-dof only. paper: Eq. (A.3) as printed (bogie on two primary suspensions, "
                     "the second wheelset a fixed point); quarter-car: one primary suspension per wheel",
                     ("paper", "quarter-car"), default="paper", required=False),
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
                                   "modelled rail (half the whole bogie's)", "kg m^2", gt=0, required=False),
        "carbody_pitch_inertia": Num("half-car: pitch inertia of the carbody on the modelled rail "
                                     "(half the whole carbody's)", "kg m^2", gt=0, required=False),
        "bogie_distance": Num("half-car: distance between the two bogie centres", "m", gt=0, le=50.0,
                              required=False),
    }, "the vehicle on one rail: the 3-dof model, a bogie or a half car (masses and suspension "
       "values per wheel, see lccopt/vti/vehicle.py)"),
    "track": Section({
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
        "railpad": _kv("railpad stiffness per rail seat", "railpad damping per rail seat", "N/m", "N s/m"),
        "sleeper": Section({"mass": Num("sleeper mass per rail", "kg", gt=0)}),
        "support": _kv("ballast/subgrade stiffness per rail seat", "ballast/subgrade damping per rail seat",
                       "N/m", "N s/m"),
        "strengthened_sleeper": Section({
            "mass": Num("strengthened sleeper mass per rail", "kg", gt=0),
            "support_stiffness": Num("ballast/subgrade stiffness under it per rail seat", "N/m", gt=0),
            "support_damping": Num("ballast/subgrade damping under it per rail seat", "N s/m", ge=0),
        }),
        "ers": Section({
            "slab_lengths": NumList("lengths of the slabs, in running order (not joined)", "m", gt=0),
            "compound": Section({
                "stiffness": Num("elastic compound + standard strip stiffness per metre of rail", "N/m^2", gt=0),
                "damping_ratio": Num("compound damping ratio", ge=0, le=1),
            }),
            "type_ii_compound": Section({
                "stiffness": Num("compound stiffness with the Type II strip per metre of rail", "N/m^2", gt=0),
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
                              "foundation damping per metre of slab (whole slab)", "N/m^2", "N s/m^2"),
        }),
    }),
    "design": Section({
        "railpad_stiffness": _design_group("stiffness of the pads next to the interface, "
                                           "x_r1 farthest .. x_rN nearest", integer=False, counted=True),
        "strengthened_sleepers": _design_group("number of strengthened sleepers next to the interface",
                                               integer=True, counted=False),
        "sleeper_spans": _design_group("spans next to the interface in 0.1 m elements, x_s1 farthest .. "
                                       "x_sM from the slab edge to the first sleeper", integer=True, counted=True),
        "type_ii_strip": _design_group("length of Type II strip from the entry slab edge, in 0.1 m elements",
                                       integer=True, counted=False),
    }),
    "evaluation": Section({
        "sleepers": Num("sleepers of the evaluation zone (next to the interface)", integer=True, ge=1),
        "force_zone_after_interface": Num("the force zone ends this far into the ERS", "m", ge=0),
    }),
    "simulation": Section({
        "time_step": Num("Newmark time step", "s", gt=0),
        "element_length": Num("rail element length where the wheel runs (must divide 0.1 m)", "m",
                              ge=0.01, le=0.1),
        "far_element_length": Num("longest rail element away from the wheel (supports stay on nodes)",
                                  "m", ge=0.01, le=0.6, default=0.3, required=False),
        "run_in": Num("distance run before the evaluation zone", "m", ge=0, le=1000.0),
        "run_out": Num("distance run after the force zone (sleepers settle)", "m", ge=0, le=1000.0),
        "direction": Str("enter: the vehicle runs towards +x, from the designed entry ballast into "
                         "the ERS; leave: towards -x, from the ERS onto the designed side (same zone)",
                         ("enter", "leave"), default="enter", required=False),
        "irregularity": TextOrSection(
            "CSV file (position m, dip m) of the vertical rail profile, relative to the case file, or "
            "a random profile from a standard spectrum (lccopt/vti/irregularity.py); none for a "
            "smooth rail",
            Section({
                "spectrum": Str("erri-low, erri-high (ORE/ERRI B176), fra-4, fra-5, fra-6 (FRA classes)",
                                ("erri-low", "erri-high", "fra-4", "fra-5", "fra-6")),
                "seed": Num("random seed: the same profile for every design", integer=True, ge=0),
                "wavelengths": NumList("[min, max] band of wavelengths generated", "m", length=2, gt=0),
                "amplitude_scale": Num("factor on the profile", ge=0, default=1.0, required=False),
            }), required=False, default=None),
    }),
    "optimisation": Section({
        "objectives": StrList("objectives to minimise; two or more are scalarised by the ASF", OBJECTIVES),
        "budget": Num("evaluations in all, failures included", integer=True, ge=2, le=100_000),
        "initial_points": Num("initial design size, reference design included", integer=True, ge=2,
                              le=10_000),
        "seed": Num("random seed", integer=True, ge=0, default=0, required=False),
        "timeout": Num("per-evaluation timeout", "s", gt=0, default=600.0, required=False),
        "conditions": Str("how the objectives of several traffic conditions combine: worst (max over "
                          "conditions), mean (weighted mean) or each (every condition's objective is "
                          "an objective of its own, named like F_max@name)",
                          CONDITION_MODES, default="worst", required=False),
        "asf": Section({
            "rho": Num("augmentation coefficient of the Chebyshev ASF", ge=0, default=0.05, required=False),
            "improvement": Num("reference point = reference design improved by this fraction",
                               ge=0, le=1, default=0.2, required=False),
            "worst": NumList("worst obtainable value of each objective (kappa_i = 1/(worst_i - ref_i))",
                             gt=0, required=False),
        }, required=False),
    }, required=False),
})

# Traffic conditions (issue 10): named vehicles take every key of `vehicle:` (the speed is the
# condition's), and each condition runs one simulation of every design.
SCHEMA.fields["vehicles"] = Named(
    Section({**SCHEMA.fields["vehicle"].fields,
             "speed": Num("default speed of the vehicle's conditions", "m/s", gt=0, le=150.0,
                          required=False)}, "a vehicle, with the keys of the vehicle section"),
    "named vehicles for the conditions (each with the keys of the vehicle section)")
SCHEMA.fields["conditions"] = Items(Section({
    "name": Str("condition name (letters, digits, '.', '-', '_'); objectives of it are named "
                "like F_max@name"),
    "vehicle": Str("a name from vehicles:, or case for the case's vehicle section",
                   default="case", required=False),
    "speed": Num("running speed (default: the vehicle's)", "m/s", gt=0, le=150.0, required=False),
    "direction": Str("enter: from the designed ballast side into the ERS; leave: from the ERS "
                     "onto the designed side", ("enter", "leave"), default="enter", required=False),
    # the same forms as simulation.irregularity (default: that one); none: a smooth rail
    "irregularity": SCHEMA.fields["simulation"].fields["irregularity"],
    "weight": Num("weight of the condition in the weighted mean (conditions: mean)", gt=0,
                  default=1.0, required=False),
}), "traffic conditions; without this list the case is one condition: its vehicle section")


def _check(value: Any, spec: Any, path: tuple, lines: dict, file: str) -> Any:
    """Validate one value against its spec; return the typed value."""
    def fail(msg: str, at: tuple = path) -> CaseError:
        where, line = at, lines.get(at)
        while line is None and where:
            where = where[:-1]
            line = lines.get(where)
        return CaseError(f"{line or file + ':1'}: {_dotted(at) or '<top>'}: {msg}")

    if isinstance(spec, Section):
        if not isinstance(value, dict):
            raise fail(f"expected a section (mapping), got {type(value).__name__}")
        unknown = [k for k in value if k not in spec.fields]
        if unknown:
            k = unknown[0]
            raise CaseError(f"{lines.get(path + (k,), file + ':1')}: {_dotted(path + (k,))}: unknown key "
                            f"(expected one of: {', '.join(spec.fields)})")
        out = {}
        for key, sub in spec.fields.items():
            if value.get(key) is None:  # absent, or written as null
                if getattr(sub, "required", True):
                    raise fail(f"missing key '{key}'")
                optional_only = isinstance(sub, Section) and not any(
                    getattr(f, "required", True) for f in sub.fields.values())
                out[key] = (_check({}, sub, path + (key,), lines, file) if optional_only
                            else getattr(sub, "default", None))
                continue
            out[key] = _check(value[key], sub, path + (key,), lines, file)
        return out
    if isinstance(spec, Named):
        if not isinstance(value, dict) or not value:
            raise fail("expected a mapping of names to sections")
        if len(value) > spec.max_items:
            raise fail(f"{len(value)} entries; at most {spec.max_items}")
        for k in value:
            if not isinstance(k, str) or not SAFE_NAME.fullmatch(k):
                raise fail(f"{str(k)[:40]!r} is not a name (1-64 letters, digits, '.', '-' and '_')",
                           path + (k,))
        return {k: _check(v, spec.item, path + (k,), lines, file) for k, v in value.items()}
    if isinstance(spec, Items):
        if not isinstance(value, list) or not value:
            raise fail("expected a list")
        if len(value) > spec.max_items:
            raise fail(f"{len(value)} entries; at most {spec.max_items}")
        return [_check(v, spec.item, path + (i,), lines, file) for i, v in enumerate(value)]
    if isinstance(spec, TextOrSection):
        if isinstance(value, dict):
            return _check(value, spec.section, path, lines, file)
        if not isinstance(value, str):
            raise fail(f"expected a file name or a mapping, got {value!r}")
        return value
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
        if not isinstance(value, list):
            raise fail(f"expected a list of numbers, got {value!r}")
        if spec.length is not None and len(value) != spec.length:
            raise fail(f"expected {spec.length} values, got {len(value)}")
        if len(value) < spec.min_length:
            raise fail(f"expected at least {spec.min_length} value(s)")
        item = Num(spec.doc, spec.unit, gt=spec.gt, ge=spec.ge)
        return [_number(v, item, lambda m, i=i: fail(m, path + (i,))) for i, v in enumerate(value)]
    if isinstance(spec, StrList):
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
    raise TypeError(spec)


def _number(value: Any, spec: Num, fail) -> float | int:
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


# --------------------------------------------------------------------------- typed case

@dataclass(frozen=True)
class Variable:
    """One scalar design variable."""
    name: str        # e.g. x_r1
    group: str       # design section key
    integer: bool
    lower: float
    upper: float
    reference: float
    unit: str
    log: bool = False  # searched on a log scale (design.<group>.scale: log)

    @property
    def display(self) -> tuple[str, float]:
        """(unit, scale) shown to people: pad stiffness in MN/m, counts as they are."""
        return ("MN/m", 1e-6) if self.unit == "N/m" else ("", 1.0)

    def show(self, value: float) -> str:
        unit, scale = self.display
        return f"{self.name}={value * scale:.6g}" + (f" {unit}" if unit else "")


@dataclass(frozen=True)
class Case:
    """A validated case. ``data`` holds the typed sections (SI units) as nested dicts.

    ``text`` is the case file as written; ``resolved`` is the whole case after ``extends``
    and defaults, as YAML: what a run directory keeps so that it stands on its own.
    """
    path: Path
    text: str
    data: dict = field(repr=False)
    variables: tuple[Variable, ...] = ()
    irregularity: np.ndarray | None = field(default=None, repr=False)
    conditions: tuple["Condition", ...] = ()

    @property
    def resolved(self) -> str:
        return yaml.safe_dump(self.data, sort_keys=False)

    @property
    def name(self) -> str:
        return self.data["name"]

    @property
    def vehicle(self) -> dict:
        return self.data["vehicle"]

    @property
    def track(self) -> dict:
        return self.data["track"]

    @property
    def evaluation(self) -> dict:
        return self.data["evaluation"]

    @property
    def simulation(self) -> dict:
        return self.data["simulation"]

    @property
    def optimisation(self) -> dict | None:
        return self.data["optimisation"]

    @property
    def names(self) -> list[str]:
        return [v.name for v in self.variables]

    @property
    def reference(self) -> np.ndarray:
        return np.array([v.reference for v in self.variables], dtype=float)

    @property
    def lower(self) -> np.ndarray:
        return np.array([v.lower for v in self.variables], dtype=float)

    @property
    def upper(self) -> np.ndarray:
        return np.array([v.upper for v in self.variables], dtype=float)

    @property
    def integer(self) -> np.ndarray:
        return np.array([v.integer for v in self.variables], dtype=bool)

    @property
    def log(self) -> np.ndarray:
        """Variables the optimiser searches on a log scale."""
        return np.array([v.log for v in self.variables], dtype=bool)

    def with_simulation(self, **settings) -> "Case":
        """A copy with some simulation settings replaced (convergence studies, tests)."""
        data = {**self.data, "simulation": {**self.data["simulation"], **settings}}
        conditions = tuple(c.with_simulation(settings) for c in self.conditions)
        return Case(self.path, self.text, data, self.variables, self.irregularity, conditions)

    @property
    def condition_mode(self) -> str:
        """worst, mean or each: how the objectives of the conditions combine."""
        return (self.optimisation or {}).get("conditions") or "worst"

    def condition_case(self, i: int) -> "Case":
        """The case of condition i: one simulation, as the vti module runs it."""
        c = self.conditions[i]
        return Case(self.path, self.text, c.data, self.variables, c.irregularity)

    def check_design(self, x) -> np.ndarray:
        """Return x as floats if it is a valid design vector, else raise ValueError."""
        x = np.asarray(x, dtype=float).ravel()
        if x.size != len(self.variables):
            raise ValueError(f"a design vector has {len(self.variables)} values "
                             f"({', '.join(self.names)}), got {x.size}")
        for v, xi in zip(self.variables, x):
            if not np.isfinite(xi) or xi < v.lower or xi > v.upper:
                raise ValueError(f"{v.name} = {xi:g} is outside [{v.lower:g}, {v.upper:g}]")
            if v.integer and xi != round(xi):
                raise ValueError(f"{v.name} = {xi:g} must be a whole number")
        _check_layout_fits(self.data, x, self.variables)
        return x


@dataclass(frozen=True)
class Condition:
    """One traffic condition: the vehicle, speed, direction and rail profile of one simulation
    of every design. ``data`` is the whole case as that simulation sees it."""
    name: str
    weight: float
    vehicle: str
    speed: float
    direction: str
    data: dict = field(repr=False)
    irregularity: np.ndarray | None = field(default=None, repr=False)

    def with_simulation(self, settings: dict) -> "Condition":
        data = {**self.data, "simulation": {**self.data["simulation"], **settings}}
        return Condition(self.name, self.weight, self.vehicle, self.speed, self.direction, data,
                         self.irregularity)


_GROUPS = (  # design key, variable name stem, unit
    ("railpad_stiffness", "x_r", "N/m"),
    ("strengthened_sleepers", "x_n", "-"),
    ("sleeper_spans", "x_s", "elements"),
    ("type_ii_strip", "x_l", "elements"),
)


def _variables(design: dict, lines: dict, file: str) -> tuple[Variable, ...]:
    out = []
    for key, stem, unit in _GROUPS:
        g = design[key]
        path = ("design", key)
        lo, hi = g["bounds"]
        integer = g["kind"] == "integer"
        at = lambda k: f"{lines.get(path + (k,), lines.get(path))}: {_dotted(path + (k,))}"
        if lo > hi:
            raise CaseError(f"{at('bounds')}: lower bound {lo:g} is above upper bound {hi:g}")
        if integer and (lo != round(lo) or hi != round(hi)):
            raise CaseError(f"{at('bounds')}: an integer variable needs whole-number bounds, got [{lo:g}, {hi:g}]")
        if "scale" in g and g["scale"] is None:
            del g["scale"]  # absent stays absent: a case of before resolves as it did (resumes)
        log = g.get("scale") == "log"
        if log and not lo > 0:
            raise CaseError(f"{at('scale')}: a log scale needs positive bounds, got [{lo:g}, {hi:g}]")
        refs = g["reference"] if "count" in g else [g["reference"]]
        if "count" in g and len(refs) != g["count"]:
            raise CaseError(f"{at('reference')}: expected {g['count']} values (count), got {len(refs)}")
        for i, r in enumerate(refs):
            name = f"{stem}{i + 1}" if "count" in g else stem
            if integer and r != round(r):
                raise CaseError(f"{at('reference')}: {name} = {r:g} must be a whole number")
            if not lo <= r <= hi:
                raise CaseError(f"{at('reference')}: reference {name} = {r:g} is outside the bounds "
                                f"[{lo:g}, {hi:g}]")
            out.append(Variable(name, key, integer, float(lo), float(hi), float(r), unit, log))
    return tuple(out)


def _check_layout_fits(data: dict, x: np.ndarray, variables) -> None:
    """Spans, strengthened sleepers and the strip must fit the track (raises ValueError)."""
    layout = data["track"]["layout"]
    sim = data["simulation"]
    groups = {}
    for v, xi in zip(variables, x):
        groups.setdefault(v.group, []).append(xi)
    spans = np.array(groups["sleeper_spans"]) * ELEMENT_UNIT
    ers_length = sum(data["track"]["ers"]["slab_lengths"])
    if groups["type_ii_strip"][0] * ELEMENT_UNIT > ers_length + 1e-9:
        raise ValueError(f"the Type II strip ({groups['type_ii_strip'][0] * ELEMENT_UNIT:g} m) is longer "
                         f"than the ERS ({ers_length:g} m)")
    n_sleepers = int((layout["entry_length"] - spans.sum()) // layout["sleeper_spacing"]) + len(spans)
    if n_sleepers < max(groups["strengthened_sleepers"][0], data["evaluation"]["sleepers"]):
        raise ValueError(f"the entry side holds {n_sleepers} sleepers, fewer than the strengthened "
                         f"sleepers or the evaluation zone ask for")
    if len(groups["railpad_stiffness"]) > n_sleepers:  # the extra pads would sit on no sleeper
        raise ValueError(f"{len(groups['railpad_stiffness'])} designed railpads, but the entry side "
                         f"holds {n_sleepers} sleepers")
    need = data["evaluation"]["sleepers"] * layout["sleeper_spacing"] + spans.sum() + sim["run_in"]
    if need > layout["entry_length"] - 5.0:
        raise ValueError(f"the evaluation zone and run-in ({need:g} m) do not fit the "
                         f"{layout['entry_length']:g} m entry track with 5 m to spare")


def _is_multiple(length: float, unit: float) -> bool:
    q = length / unit
    return abs(q - round(q)) < 1e-9 * max(1.0, q)


def _merge(base: dict, over: dict) -> dict:
    """Deep-merge two raw case mappings: sections merge key by key, anything else is replaced."""
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(base[k], v) if isinstance(v, dict) and isinstance(base.get(k), dict) else v
    return out


def _read_with_base(path: Path, text: str, seen: set) -> tuple[dict, dict]:
    """Read a case file; ``extends: other.yaml`` (relative to it) starts from another case."""
    raw, lines = read_yaml(text, str(path))
    base_name = raw.pop("extends", None)
    if base_name is None:
        return raw, lines
    where = lines[("extends",)]
    if not isinstance(base_name, str):
        raise CaseError(f"{where}: extends: expected a file name, got {base_name!r}")
    base_path = (path.parent / base_name).resolve()
    if base_path in seen:
        raise CaseError(f"{where}: extends: {base_name} extends itself (a cycle)")
    try:
        base_text = base_path.read_text(encoding="utf-8")
    except OSError as exc:
        raise CaseError(f"{where}: extends: cannot read {base_path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise CaseError(f"{where}: extends: {base_path} is not UTF-8 text (byte {exc.start})") from None
    base_raw, base_lines = _read_with_base(base_path, base_text, seen | {base_path})
    return _merge(base_raw, raw), {**base_lines, **lines}


# A case name is one path component of the run directory: never ".", "..", empty or hidden.
SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


def text_line(path: Path, offset: int) -> int:
    """1-based line number of a byte offset in a file (for messages about undecodable bytes)."""
    try:
        return path.read_bytes()[:offset].count(b"\n") + 1
    except OSError:
        return 1


def load_case(path: str | Path) -> Case:
    """Read and validate a case file; raise :class:`CaseError` on any problem."""
    path = Path(path)
    file = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise CaseError(f"{file}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        line = text_line(path, exc.start)
        raise CaseError(f"{file}:{line}: <file>: not UTF-8 text (byte {exc.start}); "
                        f"save the case file as UTF-8") from None
    raw, lines = _read_with_base(path, text, set())
    data = _check(raw, SCHEMA, (), lines, file)

    def err(at: tuple, msg: str) -> CaseError:
        where, line = at, lines.get(at)
        while line is None and where:
            where = where[:-1]
            line = lines.get(where)
        return CaseError(f"{line or file + ':1'}: {_dotted(at)}: {msg}")

    if not SAFE_NAME.fullmatch(data["name"]):
        raise err(("name",), "1-64 letters, digits, '.', '-' and '_', starting with a letter or digit "
                             "(it names the run directory)")
    le = data["simulation"]["element_length"]
    if not _is_multiple(ELEMENT_UNIT, le):
        raise err(("simulation", "element_length"), f"must divide 0.1 m exactly, got {le:g}")
    _check_accuracy(data, err)
    layout = data["track"]["layout"]
    for key in ("entry_length", "exit_length", "sleeper_spacing", "exit_first_span"):
        if not _is_multiple(layout[key], ELEMENT_UNIT):
            raise err(("track", "layout", key), f"must be a multiple of 0.1 m, got {layout[key]:g}")
    for i, s in enumerate(data["track"]["ers"]["slab_lengths"]):
        if not _is_multiple(s, ELEMENT_UNIT):
            raise err(("track", "ers", "slab_lengths", i), f"must be a multiple of 0.1 m, got {s:g}")
    variables = _variables(data["design"], lines, file)
    try:
        _check_layout_fits(data, np.array([v.upper if v.group in ("sleeper_spans", "type_ii_strip",
                                                                   "strengthened_sleepers")
                                           else v.reference for v in variables]), variables)
    except ValueError as exc:
        raise err(("design",), f"at the upper bounds: {exc}") from None

    opt = data["optimisation"]
    if opt is not None:
        if opt["initial_points"] > opt["budget"]:
            raise err(("optimisation", "initial_points"),
                      f"{opt['initial_points']} initial points exceed the budget of {opt['budget']}")
        worst = opt["asf"]["worst"]
        n_obj = len(opt["objectives"])
        n_each = len(data["conditions"] or []) if opt["conditions"] == "each" else 1
        if n_obj * n_each > 1:
            if worst is None:
                raise err(("optimisation", "asf"), "missing key 'worst' (needed for two or more objectives)")
            if len(worst) not in (n_obj, n_obj * n_each):
                also = (f" or {n_obj * n_each} (one per objective and condition)" if n_each > 1 else "")
                raise err(("optimisation", "asf", "worst"),
                          f"expected {n_obj} values (one per objective){also}, got {len(worst)}")

    irregularity = _load_irregularity(data["simulation"]["irregularity"], path, err,
                                      ("simulation", "irregularity"), data)
    conditions = _conditions(data, path, err, irregularity)
    return Case(path=path, text=text, data=data, variables=variables, irregularity=irregularity,
                conditions=conditions)


def _load_irregularity(value, path: Path, err, at: tuple, data: dict) -> np.ndarray | None:
    """The rail profile (position m, dip m) a case names (a CSV file, or a random profile from
    a spectrum: the same for every design), or None for a smooth rail."""
    if not value or value == "none":
        return None
    if isinstance(value, dict):
        from .vti import irregularity as irr    # numerical code, loaded only when needed

        length = irr.track_length(data)
        problem = irr.check_spec(value, length)
        if problem:
            raise err(at + (problem[0],), problem[1])
        return irr.profile_of(value, length)
    irr_path = path.parent / value
    try:
        irregularity = np.loadtxt(irr_path, delimiter=",", ndmin=2, dtype=float)
    except (OSError, ValueError) as exc:
        raise err(at, f"cannot read {irr_path}: {exc}") from None
    if irregularity.shape[1] != 2 or irregularity.shape[0] < 2 or np.any(np.diff(irregularity[:, 0]) <= 0):
        raise err(at, "expected two columns (position m, dip m) with increasing positions")
    return irregularity


def _conditions(data: dict, path: Path, err, case_irregularity) -> tuple[Condition, ...]:
    """The traffic conditions of a case (none without a ``conditions:`` list)."""
    vehicles = data.get("vehicles") or {}
    listed = data.get("conditions") or []
    if not listed:
        if vehicles:
            raise err(("vehicles",), "named vehicles are used by a conditions: list, and there is none")
        if (data.get("optimisation") or {}).get("conditions") not in (None, "worst"):
            raise err(("optimisation", "conditions"), "needs a conditions: list")
        return ()
    out, seen = [], set()
    for i, c in enumerate(listed):
        at = ("conditions", i)
        if not SAFE_NAME.fullmatch(c["name"]):
            raise err(at + ("name",), "1-64 letters, digits, '.', '-' and '_', starting with a letter "
                                      "or digit (it names the condition's objectives and files)")
        if c["name"] in seen:
            raise err(at + ("name",), f"'{c['name']}' names two conditions")
        seen.add(c["name"])
        if c["vehicle"] == "case":
            vehicle = dict(data["vehicle"])
        elif c["vehicle"] in vehicles:
            vehicle = dict(vehicles[c["vehicle"]])
        else:
            raise err(at + ("vehicle",), f"no vehicle '{c['vehicle']}' (vehicles: "
                                         f"{', '.join(['case', *vehicles])})")
        speed = c["speed"] if c["speed"] is not None else vehicle.get("speed")
        if speed is None:
            raise err(at + ("speed",), f"missing key 'speed' (vehicle '{c['vehicle']}' has none)")
        vehicle["speed"] = speed
        sim = dict(data["simulation"])
        sim["direction"] = c["direction"]
        irregularity = case_irregularity
        if c["irregularity"] is not None:
            sim["irregularity"] = c["irregularity"]
            irregularity = _load_irregularity(c["irregularity"], path, err, at + ("irregularity",), data)
        one = {k: v for k, v in data.items() if k not in ("vehicles", "conditions")}
        one.update(vehicle=vehicle, simulation=sim)
        def cond_err(where, msg, at=at, name=c["vehicle"]):
            if where[:1] == ("vehicle",) and name != "case":   # a named vehicle's own key
                return err(("vehicles", name) + where[1:], f"{msg} (in condition {c['name']})")
            return err(at, f"{_dotted(where)}: {msg}")

        _check_accuracy(one, cond_err)
        out.append(Condition(c["name"], float(c["weight"]), c["vehicle"], float(speed), c["direction"],
                             one, irregularity))
    return tuple(out)


STEPS_PER_CONTACT_PERIOD = 5  # Newmark (average acceleration) shortens nothing, but lengthens the
# period by (w dt)^2/12: 13 % at 5 steps per period of the stiffest mode that carries the
# contact force (the wheel on its Hertz spring); coarser steps alias it (time_step 0.05 gave
# E_max 2.90 J instead of 0.368 J).


def _check_accuracy(data: dict, err) -> None:
    """Reject time steps that make the simulation inaccurate (it stays stable: Newmark's
    average-acceleration rule is unconditionally stable, so a bad step fails silently)."""
    v, sim = data["vehicle"], data["simulation"]
    dt = sim["time_step"]
    k_contact = 1.5 / v["hertz_constant"] * v["hertz_load"] ** (1.0 / 3.0)
    f_contact = np.sqrt(k_contact / v["wheelset_mass"]) / (2 * np.pi)
    limit = 1.0 / (STEPS_PER_CONTACT_PERIOD * f_contact)
    if dt > limit:
        raise err(("simulation", "time_step"),
                  f"{dt:g} s is too coarse: the wheel on its contact spring rings at {f_contact:.0f} Hz, "
                  f"which needs at least {STEPS_PER_CONTACT_PERIOD} steps per period (time_step <= "
                  f"{limit:.3g} s)")
    step = v["speed"] * dt
    if step > sim["element_length"] * (1 + 1e-9):
        raise err(("simulation", "time_step"),
                  f"{dt:g} s moves the wheel {step:.3g} m per step, more than one element "
                  f"({sim['element_length']:g} m): time_step <= {sim['element_length'] / v['speed']:.3g} s")
    _check_vehicle_fits(data, err)
    irr = sim.get("irregularity")
    if isinstance(irr, dict):   # the shortest wave must be followed by the mesh and the time step
        shortest = irr["wavelengths"][0]
        need = max(4 * sim["element_length"], 5 * step)   # 4 elements, 5 steps per wave
        if shortest < need * (1 - 1e-9):
            raise err(("simulation", "irregularity", "wavelengths"),
                      f"the shortest wavelength {shortest:g} m is below what the mesh and time step "
                      f"resolve ({need:.3g} m: 4 elements of {sim['element_length']:g} m and 5 steps of "
                      f"{step:.3g} m)")


VEHICLE_KEYS = {  # keys a vehicle type needs beyond the three-dof ones
    "bogie": ("wheelbase", "bogie_pitch_inertia"),
    "half-car": ("wheelbase", "bogie_pitch_inertia", "carbody_pitch_inertia", "bogie_distance"),
}
RAIL_END_MARGIN = 1.0  # [m] the leading wheel stays this far from the pinned rail ends


def vehicle_length(vehicle: dict) -> float:
    """Distance from the leading to the last wheel of a vehicle section [m] (keys checked)."""
    kind = vehicle.get("type") or "three-dof"
    if kind == "bogie":
        return float(vehicle["wheelbase"])
    if kind == "half-car":
        return float(vehicle["bogie_distance"] + vehicle["wheelbase"])
    return 0.0


def _check_vehicle_fits(data: dict, err) -> None:
    """The vehicle type has its keys, and the leading wheel stays on the modelled rail for the
    whole run in either direction, whatever the design (lccopt.vti.track.wheel_window; a
    trailing wheel beyond a rail end rests on a rigid continuation of the rail)."""
    v, sim = data["vehicle"], data["simulation"]
    kind = v.get("type") or "three-dof"
    for key in VEHICLE_KEYS.get(kind, ()):
        if v.get(key) is None:
            raise err(("vehicle", key), f"missing key '{key}' (vehicle type {kind} needs it)")
    if kind == "half-car" and v["bogie_distance"] <= v["wheelbase"]:
        raise err(("vehicle", "bogie_distance"), f"{v['bogie_distance']:g} m must exceed the wheelbase "
                                                 f"({v['wheelbase']:g} m): the bogies would overlap")
    length = vehicle_length(v)
    layout = data["track"]["layout"]
    total = layout["entry_length"] + sum(data["track"]["ers"]["slab_lengths"]) + layout["exit_length"]
    zone_end = layout["entry_length"] + data["evaluation"]["force_zone_after_interface"]
    spans = data["design"]["sleeper_spans"]
    n_zone, n_near = data["evaluation"]["sleepers"], spans["count"]
    far_span = spans["bounds"][1] * ELEMENT_UNIT        # the zone reaches farthest at the upper bounds
    zone_start = layout["entry_length"] - min(n_zone, n_near) * far_span \
        - max(0, n_zone - n_near) * layout["sleeper_spacing"]
    x_b = layout["entry_length"] + sum(data["track"]["ers"]["slab_lengths"])
    if (sim.get("direction") or "enter") == "leave":
        lowest, highest = zone_start - sim["run_out"] - length, max(zone_end, x_b) + sim["run_in"]
    else:
        lowest, highest = zone_start - sim["run_in"], zone_end + sim["run_out"] + length
    if zone_start <= 0:
        lowest = RAIL_END_MARGIN    # the zone itself does not fit: the design check says so
    if lowest < RAIL_END_MARGIN or highest > total - RAIL_END_MARGIN:
        beyond_exit = highest > total - RAIL_END_MARGIN
        key = "run_out" if beyond_exit == ((sim.get("direction") or "enter") == "enter") else "run_in"
        raise err(("simulation", key),
                  f"the leading wheel would run from {lowest:.3g} m to {highest:.3g} m, beyond the "
                  f"modelled rail [0, {total:g}] m less {RAIL_END_MARGIN:g} m at each end (vehicle "
                  f"{length:g} m long): shorten run_in/run_out or lengthen track.layout."
                  f"{'exit_length' if beyond_exit else 'entry_length'}")


def parse_design(text: str, case: Case) -> np.ndarray:
    """Parse ``--design 214,155,50,5,6,7,3,0`` (pads in MN/m, the rest as counted) into a
    checked design vector in SI units (raises ValueError)."""
    try:
        x = [float(t) for t in text.replace(" ", "").split(",") if t]
    except ValueError:
        raise ValueError(f"expected comma-separated numbers, got {text!r}") from None
    if len(x) == len(case.variables):
        for xi, v in zip(x, case.variables):
            unit, scale = v.display
            u = f" {unit}" if unit else ""
            if not np.isfinite(xi) or not v.lower * scale <= xi <= v.upper * scale:
                raise ValueError(f"{v.name} = {xi:g}{u} is outside [{v.lower * scale:g}, {v.upper * scale:g}]{u}")
        x = [xi / v.display[1] for xi, v in zip(x, case.variables)]
    return case.check_design(x)


def design_items(case: Case, x) -> list[str]:
    """``["x_r1=214 MN/m", ..., "x_n=5", ...]``: each variable in the units people use."""
    return [v.show(xi) for v, xi in zip(case.variables, x)]
