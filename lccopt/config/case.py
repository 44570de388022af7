"""Case files -> a validated, typed :class:`Case` in SI units.

``load_case`` reads the file (``reading``), validates it against the schema (``schema``),
checks what needs physics or the layout (``checks``) and returns a :class:`Case`: its design
variables, its traffic conditions, and the simulator's typed inputs (``Case.scenario``,
``Case.track_design``, built by ``build``). Every problem is one line
``FILE:LINE: KEY.PATH: what is wrong`` through :class:`~lccopt.errors.CaseError`; the CLI
prints it and exits with status 2.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np
import yaml

from ..errors import CaseError
from ..vti.specs import Scenario, TrackDesign
from . import build
from . import overrides as set_values
from .checks import (
    check_accuracy,
    check_design_size,
    check_layout_fits,
    check_mesh_units,
    check_optimisation,
    check_profile,
    check_railpad,
    simulation_size,
)
from .degradation import check_degradation, degradation_spec
from .profile_files import RowCount, profile_rows
from .profiles import (
    ProfileText,
)
from .reading import (
    dotted,
    locate,
    read_case_text,
    read_with_base,
)
from .schema import SAFE_NAME, SCHEMA, check
from .uncertainty import check_uncertainty, draw
from .units import split as split_quantity
from .variables import Variable, read_lengths
from .variables import variables as design_variables
from .zones import check_design_space, derive_strip_bounds, resolve_zone


class _Dumper(yaml.SafeDumper):
    """YAML of a resolved case: a profile's rows as a literal block, one row per line (fast to
    read back: one scalar, not two numbers per row); everything else as ``yaml.safe_dump``."""


_Dumper.add_representer(ProfileText, lambda dumper, text: dumper.represent_scalar(
    "tag:yaml.org,2002:str", str(text), style="|"))


@dataclass(frozen=True)
class Case:
    """A validated case. ``data`` holds the typed sections (SI units) as nested dicts.

    ``text`` is the case file as written; ``resolved`` is the whole case after ``extends``,
    ``--set`` values (``overrides``, as given) and defaults, as YAML: what a run directory
    keeps so that it stands on its own.

    ``traffic`` holds the case's traffic conditions (its ``conditions:`` list). ``conditions``
    are those a design is evaluated under one simulation each, which the run engine spreads
    over its workers: the same, except for a case with ``degradation:``, whose one settlement
    prediction per design simulates every condition on the track they settle together (so
    ``conditions`` is empty and the prediction reads ``traffic``).

    ``budget_option`` is a budget given on the command line (``--budget``; a run records it,
    as it records ``overrides``, so that a resume loads the case the same way).

    ``variations`` holds the realisations of a case with ``uncertainty:`` (drawn once, when
    the case is loaded: ``lccopt.config.uncertainty``); ``realisation`` is the one this case
    object simulates (``part_case``), -1 for the track as drawn.
    """
    path: Path
    text: str
    data: dict = field(repr=False)
    variables: tuple[Variable, ...] = ()
    conditions: tuple["Condition", ...] = ()
    overrides: tuple[str, ...] = ()
    traffic: tuple["Condition", ...] = ()
    variations: tuple = field(default=(), repr=False)
    realisation: int = -1
    budget_option: int | None = None    # optimisation.budget given as --budget

    @cached_property
    def resolved(self) -> str:
        """The whole case as YAML: every rail profile as its rows, so that it stands on its
        own (what a run directory keeps and fingerprints; written once per case object: a
        profile of many rows takes a second)."""
        return yaml.dump(self.data, Dumper=_Dumper, sort_keys=False)

    @property
    def irregularity(self) -> np.ndarray | None:
        """The rail profile (N, 2) of the case's own simulation, or None (a smooth rail)."""
        return build.profile(self.data)

    # the case's sections, as validated (SI units)
    name = property(lambda self: self.data["name"])
    vehicle = property(lambda self: self.data["vehicle"])
    track = property(lambda self: self.data["track"])
    evaluation = property(lambda self: self.data["evaluation"])
    simulation = property(lambda self: self.data["simulation"])
    optimisation = property(lambda self: self.data["optimisation"],
                            doc="the optimisation section, None for a case that only simulates")

    @property
    def histories(self) -> str:
        """all, best or none: the time histories an optimisation keeps (default best: the
        reference design's and the best design's)."""
        return (self.optimisation or {}).get("histories") or "best"

    @property
    def proposals_per_fit(self) -> int:
        """Designs proposed from one surrogate fit (default 1; the engine caps it by the
        worker count)."""
        return int((self.optimisation or {}).get("proposals_per_fit") or 1)

    @property
    def names(self) -> list[str]:
        return [v.name for v in self.variables]

    def _column(self, field: str, dtype=float) -> np.ndarray:
        return np.array([getattr(v, field) for v in self.variables], dtype=dtype)

    # the variables' reference design, bounds and kinds, in internal units
    reference = property(lambda self: self._column("reference"))
    lower = property(lambda self: self._column("lower"))
    upper = property(lambda self: self._column("upper"))
    integer = property(lambda self: self._column("integer", bool))
    log = property(lambda self: self._column("log", bool), doc="searched on a log scale")

    @property
    def degradation(self) -> dict | None:
        """The ``degradation:`` section (checked, defaults filled in), or None."""
        return self.data.get("degradation")

    def degradation_spec(self):
        """The settlement prediction's inputs
        (:class:`lccopt.degradation.inputs.DegradationSpec`) of a case with ``degradation:``,
        on this case object's track (``variation``)."""
        return degradation_spec(self.data, self.traffic, self.variation)

    @property
    def realisations(self) -> int:
        """Realisations of the track every design is simulated on (0: the drawing only)."""
        return len(self.variations)

    @property
    def variation(self):
        """This case object's realisation of the track (``lccopt.vti.specs.TrackVariation``),
        None for the track as drawn."""
        return None if self.realisation < 0 else self.variations[self.realisation]

    def part_case(self, condition: int, realisation: int) -> "Case":
        """The case of one task of a design: traffic condition ``condition`` (-1: the case as
        it is) on realisation ``realisation`` of the track (-1: as drawn)."""
        one = self if condition < 0 else self.condition_case(condition)
        return one if realisation == one.realisation else replace(one, realisation=realisation)

    def with_simulation(self, **settings) -> "Case":
        """A copy with some simulation settings replaced (convergence studies, tests)."""
        data = {**self.data, "simulation": {**self.data["simulation"], **settings}}
        traffic = tuple(c.with_simulation(settings) for c in self.traffic)
        conditions = () if self.degradation is not None else traffic
        return replace(self, data=data, conditions=conditions, traffic=traffic)

    @property
    def condition_mode(self) -> str:
        """worst, mean or each: how the objectives of the conditions combine."""
        return (self.optimisation or {}).get("conditions") or "worst"

    def condition_case(self, i: int) -> "Case":
        """The case of traffic condition i: one simulation, as the simulator runs it (on this
        case object's track)."""
        return Case(self.path, self.text, self.traffic[i].data, self.variables,
                    variations=self.variations, realisation=self.realisation)

    def to_user(self, x=None) -> np.ndarray:
        """Design x (internal units; default the reference design) in the units people
        write it in: what ``--design`` and ``lccopt.simulate(case, design)`` take."""
        x = self.reference if x is None else np.asarray(x, dtype=float)
        return np.array([v.to_user(xi) for v, xi in zip(self.variables, x)])

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
        conditions: of its own vehicle section; ``condition_case(i).scenario()`` for one), on
        this case object's track (``variation``)."""
        return build.scenario(self.data, self.variation)

    def track_design(self, x) -> TrackDesign:
        """Design vector x, checked (ValueError), as the simulator takes it."""
        return build.track_design(self.variables, self.check_design(x),
                                  self.data["design"]["railpad_stiffness"].get(
                                      "dynamic_to_static"))


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

    @property
    def irregularity(self) -> np.ndarray | None:
        """The rail profile (N, 2) of this condition, or None (a smooth rail)."""
        return build.profile(self.data)

    def with_simulation(self, settings: dict) -> "Condition":
        data = {**self.data, "simulation": {**self.data["simulation"], **settings}}
        return Condition(self.name, self.weight, self.vehicle, self.speed, self.direction, data)


def _is_run_copy(path: Path) -> bool:
    """A run directory's own copy of its case (``case.yaml`` beside the run's journal, as
    lccopt.engine.rundir lays a run out): its lengths are 0.1 m elements, so ``lccopt check
    runs/NAME/case.yaml`` reads it as the run does instead of asking for units."""
    return path.name == "case.yaml" and (path.parent / "journal.jsonl").is_file()


def load_case(path: str | Path, overrides=(), text: str | None = None,
              resolved: bool | None = None, budget: int | None = None) -> Case:
    """Read and validate a case file.

    Parameters
    ----------
    path
        the case file (YAML); ``extends:`` and irregularity files are relative to it.
    overrides
        ``KEY.PATH=VALUE`` items (``--set``), applied as if a file extending the case had
        written them (``lccopt.config.overrides``).
    text
        the case file's text, when the caller has read it already (a run's copy, read
        through the run directory it holds open); else it is read from ``path``.
    resolved
        the file is a case as lccopt resolved it (``Case.resolved``, a run's copy), whose
        design lengths are bare counts of 0.1 m elements; a case file a person writes gives
        them with their unit (0.6 m). Default: when ``text`` is given or ``path`` is a run
        directory's ``case.yaml``.
    budget
        ``optimisation.budget`` given on the command line (``--budget``), applied after
        the overrides; the initial design's default follows it as it follows a file's.

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
    if resolved is None:
        resolved = text is not None or _is_run_copy(path)
    text = read_case_text(path) if text is None else text
    raw, lines = read_with_base(path, text)
    overrides = tuple(overrides)
    raw = set_values.apply(raw, lines, overrides)
    if budget is not None:
        raw = set_values.put(raw, lines, ("optimisation", "budget"), int(budget), where="--budget")
    read_lengths(raw, lambda at: f"{locate(lines, at, file)}: {dotted(at)}", resolved)
    data = check(raw, SCHEMA, (), lines, file)

    def err(at: tuple, msg: str) -> CaseError:
        return CaseError(f"{locate(lines, at, file)}: {dotted(at)}: {msg}")

    err.where = lambda at: locate(lines, at, file)   # where a key was set (a check of two
    # keys blames the one the user typed on the command line)

    if not SAFE_NAME.fullmatch(data["name"]):
        raise err(("name",), "1-64 letters, digits, '.', '-' and '_', starting with a letter or "
                             "digit (it names the run directory)")
    resolve_zone(data, err)
    check_railpad(data, err)
    check_mesh_units(data, err)
    derive_strip_bounds(data)
    variables = design_variables(
        data["design"], lambda key, k: f"{locate(lines, ('design', key, k), file)}: "
                                       f"{dotted(('design', key, k))}")
    check_design_space(data, variables, err)
    check_optimisation(data, err, len(variables))
    rows = RowCount(err)
    at = ("simulation", "irregularity")
    data["simulation"]["irregularity"] = rows.add(
        profile_rows(data["simulation"]["irregularity"], path, lines, err, at), at)
    check_profile(data, err, at)
    conditions = _conditions(data, path, lines, err, rows)
    sims = [c.data for c in conditions] or [data]
    check_design_size([simulation_size(one) for one in sims], err)
    check_degradation(data, conditions, err)
    split = () if data.get("degradation") is not None else conditions
    check_uncertainty(data, conditions, err)
    return Case(path=path, text=text, data=data, variables=variables, conditions=split,
                overrides=overrides, traffic=conditions, variations=draw(data),
                budget_option=None if budget is None else int(budget))


def _conditions(data: dict, path: Path, lines: dict, err,
                rows: RowCount) -> tuple[Condition, ...]:
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
        # a condition runs the case's way unless it says otherwise, as it takes its vehicle
        # and rail profile
        c["direction"] = c["direction"] or sim.get("direction") or "enter"
        sim["direction"] = c["direction"]
        if c["irregularity"] is not None:
            c["irregularity"] = rows.add(profile_rows(c["irregularity"], path, lines, err,
                                                       at + ("irregularity",)),
                                         at + ("irregularity",))
            sim["irregularity"] = c["irregularity"]
        one = {k: v for k, v in data.items()
               if k not in ("vehicles", "conditions", "degradation")}
        one.update(vehicle=vehicle, simulation=sim)

        def cond_err(where, msg, at=at, name=c["vehicle"]):
            if where[:1] == ("vehicle",) and name != "case":   # a named vehicle's own key
                return err(("vehicles", name) + where[1:], f"{msg} (in condition {c['name']})")
            return err(at, f"{dotted(where)}: {msg}")

        check_accuracy(one, cond_err)
        check_profile(one, cond_err, ("simulation", "irregularity"))
        out.append(Condition(c["name"], float(c["weight"]), c["vehicle"], float(speed),
                             c["direction"], one))
    return tuple(out)


def parse_design(text: str, case: Case) -> np.ndarray:
    """Parse ``--design 214,155,50,5,0.6,0.7,0.3,0`` (in the units shown: pads in MN/m, spans
    and the strip in m, counts as they are) or ``--design "x_r1=214 MN/m, x_n=5"`` (as status
    prints a design; a variable left out at its reference, a bare number in SI) into a checked
    design vector in internal units (raises ValueError)."""
    if "=" in text:
        return _named_design(text, case.variables)
    try:
        x = [float(t) for t in text.replace(" ", "").split(",") if t]
    except ValueError:
        raise ValueError(f"expected comma-separated numbers, got {text!r}") from None
    return from_user(case, x)


def _named_design(text: str, variables) -> np.ndarray:
    """``x_r1=540 MN/m, x_n=0`` (a design as status prints it; a variable left out at its
    reference, a bare number in SI: N/m, m) as the checked internal design vector."""
    by_name = {v.name: v for v in variables}
    x = {v.name: v.reference for v in variables}
    given = set()
    for item in text.replace("\n", " ").split(","):
        if not item.strip():
            continue
        name, eq, value = (t.strip() for t in item.partition("="))
        if not eq or not name or not value:
            raise ValueError(f"expected name=value pairs, like 'x_r1=540 MN/m, x_n=0', got "
                             f"{item.strip()!r:.40}")
        v = by_name.get(name)
        if v is None:
            raise ValueError(f"{name} is not a design variable of this case (its variables: "
                             f"{', '.join(by_name)})")
        if name in given:      # which of the two was meant cannot be guessed
            raise ValueError(f"{name} is given twice")
        given.add(name)
        try:
            x[name] = v.from_quantity(value)
        except ValueError as exc:
            bare = split_quantity(value)      # a pad in MN/m without its unit reads as N/m
            hint = (f" (a bare number is in {v.internal_unit}: write {bare[0]:g} {v.kind.unit}?)"
                    if bare and not bare[1] and v.kind.unit not in ("", "m") else "")
            raise ValueError(f"{exc}{hint}") from None
    return np.array([x[v.name] for v in variables])


def from_user(case: Case, design) -> np.ndarray:
    """A design in the user's units (pads in MN/m, spans and the strip in m, counts as they
    are), one value per variable in the case's order, as the checked internal design vector
    (ValueError naming the variable)."""
    x = np.asarray(design, dtype=float).ravel()
    if x.size == len(case.variables):
        x = [v.from_user(xi) for v, xi in zip(case.variables, x)]
    return case.check_design(x)


def design_items(case: Case, x) -> list[str]:
    """``["x_r1=214 MN/m", ..., "x_n=5", ...]``: each variable in the units people use."""
    return [v.show(xi) for v, xi in zip(case.variables, x)]
