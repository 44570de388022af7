"""Case files -> a validated, typed :class:`Case` in SI units.

``load_case`` reads the file (``reading``), validates it against the schema (``schema``),
checks what needs physics or the layout (``checks``) and returns a :class:`Case`: its design
variables, its traffic conditions, and the simulator's typed inputs (``Case.scenario``,
``Case.track_design``, built by ``build``). Every problem is one line
``FILE:LINE: KEY.PATH: what is wrong`` through :class:`~lccopt.errors.CaseError`; the CLI
prints it and exits with status 2.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from ..errors import CaseError
from ..vti.specs import Scenario, TrackDesign
from . import build
from .checks import (check_accuracy, check_design_space, check_layout_fits, check_mesh_units,
                     check_optimisation, spectrum_problem)
from .reading import dotted, locate, read_case_text, read_with_base
from .schema import SAFE_NAME, SCHEMA, check


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
        """``x_r1=214 MN/m``: the value in the units people use."""
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
        """The case of condition i: one simulation, as the simulator runs it."""
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
        check_layout_fits(self.data, x, self.variables)
        return x

    def scenario(self) -> Scenario:
        """The simulator's inputs of this case's one simulation (for a case with traffic
        conditions: of its own vehicle section; ``condition_case(i).scenario()`` for one)."""
        return build.scenario(self.data, self.irregularity)

    def track_design(self, x) -> TrackDesign:
        """Design vector x, checked (ValueError), as the simulator takes it."""
        return build.track_design(self.variables, self.check_design(x))


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

        def at(k, path=path):
            return f"{lines.get(path + (k,), lines.get(path))}: {dotted(path + (k,))}"

        if lo > hi:
            raise CaseError(f"{at('bounds')}: lower bound {lo:g} is above upper bound {hi:g}")
        if integer and (lo != round(lo) or hi != round(hi)):
            raise CaseError(f"{at('bounds')}: an integer variable needs whole-number bounds, "
                            f"got [{lo:g}, {hi:g}]")
        if "scale" in g and g["scale"] is None:
            del g["scale"]  # absent stays absent: the resolved case does not grow a key
        log = g.get("scale") == "log"
        if log and not lo > 0:
            raise CaseError(f"{at('scale')}: a log scale needs positive bounds, "
                            f"got [{lo:g}, {hi:g}]")
        refs = g["reference"] if "count" in g else [g["reference"]]
        if "count" in g and len(refs) != g["count"]:
            raise CaseError(f"{at('reference')}: expected {g['count']} values (count), "
                            f"got {len(refs)}")
        for i, r in enumerate(refs):
            name = f"{stem}{i + 1}" if "count" in g else stem
            if integer and r != round(r):
                raise CaseError(f"{at('reference')}: {name} = {r:g} must be a whole number")
            if not lo <= r <= hi:
                raise CaseError(f"{at('reference')}: reference {name} = {r:g} is outside the "
                                f"bounds [{lo:g}, {hi:g}]")
            out.append(Variable(name, key, integer, float(lo), float(hi), float(r), unit, log))
    return tuple(out)


def load_case(path: str | Path) -> Case:
    """Read and validate a case file.

    Parameters
    ----------
    path
        the case file (YAML); ``extends:`` and irregularity files are relative to it.

    Returns
    -------
    Case
        the validated case, in SI units.

    Raises
    ------
    CaseError
        on any problem, as one line ``file:line: key.path: what is wrong``.
    """
    path = Path(path)
    file = str(path)
    text = read_case_text(path)
    raw, lines = read_with_base(path, text)
    data = check(raw, SCHEMA, (), lines, file)

    def err(at: tuple, msg: str) -> CaseError:
        return CaseError(f"{locate(lines, at, file)}: {dotted(at)}: {msg}")

    if not SAFE_NAME.fullmatch(data["name"]):
        raise err(("name",), "1-64 letters, digits, '.', '-' and '_', starting with a letter or "
                             "digit (it names the run directory)")
    check_mesh_units(data, err)
    variables = _variables(data["design"], lines, file)
    check_design_space(data, variables, err)
    check_optimisation(data, err)
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
        length = build.track_length(data)
        problem = spectrum_problem(value, length)
        if problem:
            raise err(at + (problem[0],), problem[1])
        return build.spectrum_profile(value, length)
    irr_path = path.parent / value
    try:
        irregularity = np.loadtxt(irr_path, delimiter=",", ndmin=2, dtype=float)
    except (OSError, ValueError) as exc:
        raise err(at, f"cannot read {irr_path}: {exc}") from None
    if (irregularity.shape[1] != 2 or irregularity.shape[0] < 2
            or np.any(np.diff(irregularity[:, 0]) <= 0)):
        raise err(at, "expected two columns (position m, dip m) with increasing positions")
    return irregularity


def _conditions(data: dict, path: Path, err, case_irregularity) -> tuple[Condition, ...]:
    """The traffic conditions of a case (none without a ``conditions:`` list)."""
    vehicles = data.get("vehicles") or {}
    listed = data.get("conditions") or []
    if not listed:
        if vehicles:
            raise err(("vehicles",),
                      "named vehicles are used by a conditions: list, and there is none")
        if (data.get("optimisation") or {}).get("conditions") not in (None, "worst"):
            raise err(("optimisation", "conditions"), "needs a conditions: list")
        return ()
    out, seen = [], set()
    for i, c in enumerate(listed):
        at = ("conditions", i)
        if not SAFE_NAME.fullmatch(c["name"]):
            raise err(at + ("name",), "1-64 letters, digits, '.', '-' and '_', starting with a "
                                      "letter or digit (it names the condition's objectives and "
                                      "files)")
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
            raise err(at + ("speed",),
                      f"missing key 'speed' (vehicle '{c['vehicle']}' has none)")
        vehicle["speed"] = speed
        sim = dict(data["simulation"])
        sim["direction"] = c["direction"]
        irregularity = case_irregularity
        if c["irregularity"] is not None:
            sim["irregularity"] = c["irregularity"]
            irregularity = _load_irregularity(c["irregularity"], path, err,
                                              at + ("irregularity",), data)
        one = {k: v for k, v in data.items() if k not in ("vehicles", "conditions")}
        one.update(vehicle=vehicle, simulation=sim)

        def cond_err(where, msg, at=at, name=c["vehicle"]):
            if where[:1] == ("vehicle",) and name != "case":   # a named vehicle's own key
                return err(("vehicles", name) + where[1:], f"{msg} (in condition {c['name']})")
            return err(at, f"{dotted(where)}: {msg}")

        check_accuracy(one, cond_err)
        out.append(Condition(c["name"], float(c["weight"]), c["vehicle"], float(speed),
                             c["direction"], one, irregularity))
    return tuple(out)


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
                raise ValueError(f"{v.name} = {xi:g}{u} is outside "
                                 f"[{v.lower * scale:g}, {v.upper * scale:g}]{u}")
        x = [xi / v.display[1] for xi, v in zip(x, case.variables)]
    return case.check_design(x)


def design_items(case: Case, x) -> list[str]:
    """``["x_r1=214 MN/m", ..., "x_n=5", ...]``: each variable in the units people use."""
    return [v.show(xi) for v, xi in zip(case.variables, x)]
