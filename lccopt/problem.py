"""Case -> optimisation problem: the design space, the simulation of a design and the scalar
value the optimiser minimises.

Pure and small: no files, no processes. :func:`evaluate` simulates one design of a case (the
workers' entry point: it builds the simulator's typed inputs from the case). The run engine
asks :class:`Problem` for

* ``space`` (a :class:`lccopt.optim.space.DesignSpace` with the reference design as the one
  given point, so the reference design is always evaluation 0),
* ``value(objectives, reference_point)``: the objective itself for a single-objective case,
  the augmented Chebyshev ASF of the paper's Eq. (7) for two or more objectives,
* ``aggregate(reference_point)``: the same ASF as a function of objective vectors, which the
  composite surrogate of a multi-objective run (``strategy()``) scores its candidates with;
  for a case that minimises E_max alone, ``sleeper_energy_spread``: E_max from the sleepers'
  energies, which its composite surrogate fits one by one (``surrogate``, ``outputs``),
* ``reference_point(reference_objectives)``: f^r = (1 - improvement) * f(x_ref), the paper's
  "20 % better than the reference design" (only for two or more objectives),
* ``with_reference(reference_objectives)``: the problem with the ASF's worst values set, the
  case's or, where the case gives none, ``DEFAULT_WORST_FACTOR`` x f(x_ref).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .config import Case, Variable
from .errors import CaseError
from .uncertainty import statistics as robust
from .vti.response import OBJECTIVES

# The ASF's worst values when a case gives none: 1.5 x the reference design's objectives. The
# paper takes them from the single-objective optima, which cost a run per objective; this
# needs none. With f^r = 0.8 f(x_ref), kappa_i (f_i - f^r_i) = (f_i / f_i(x_ref) - 0.8) / 0.7:
# each objective counts by its change relative to the reference design, the "equal
# importance" of the paper's Sec. 3.2, and a design 50 % worse than the reference in one
# objective scores as badly there as the worst value allows.
DEFAULT_WORST_FACTOR = 1.5


def evaluate(case: Case, x):
    """Simulate design ``x`` of ``case``: one simulation (a case with traffic conditions gives
    each condition's case by ``case.condition_case(i)``), or for a case with ``degradation:``
    one settlement prediction under all its traffic (:mod:`lccopt.degradation.assessment`).

    Parameters
    ----------
    case
        a validated case (:func:`lccopt.config.load_case`).
    x
        the design vector in the case's order, SI units.

    Returns
    -------
    lccopt.vti.response.Evaluation
        the objectives, time histories and facts of the run.

    Raises
    ------
    ValueError
        x is not a valid design of the case.
    """
    if case.degradation is not None:
        from .degradation.assessment import assess_settlement as predict

        return predict(case.degradation_spec(), case.track_design(x))
    from .vti.passage import simulate_passage as simulate

    return simulate(case.scenario(), case.track_design(x))


@dataclass(frozen=True)
class Problem:
    variables: tuple[Variable, ...]       # the design variables, internal units
    objectives: tuple[str, ...]
    budget: int
    initial_points: int
    seed: int
    timeout: float
    rho: float
    improvement: float
    worst: tuple[float, ...] | None
    conditions: tuple[str, ...] = ()      # traffic conditions (none: the case's one simulation)
    weights: tuple[float, ...] = ()
    condition_mode: str = "worst"
    # conditions simulated inside one evaluation (a settlement prediction's traffic)
    traffic: tuple[str, ...] = ()
    # realisations of the track every design is simulated on (a case with uncertainty:), and
    # the robust statistics recorded for every design (``complete``)
    realisations: int = 0
    statistics: tuple[str, ...] = ()

    @classmethod
    def from_case(cls, case: Case) -> "Problem":
        opt = case.optimisation
        if opt is None:
            raise CaseError(f"{case.path}:1: optimisation: missing section (objectives, budget, "
                            f"initial_points, ...); 'lccopt optimise' needs it")
        for key in ("objectives", "budget"):
            if opt.get(key) is None:
                raise CaseError(f"{case.path}:1: optimisation: missing key '{key}' "
                                f"('lccopt optimise' needs it)")
        asf = opt["asf"]          # rho and improvement: the schema's defaults where absent
        worst = asf.get("worst")
        conditions = tuple(c.name for c in case.conditions)
        mode = case.condition_mode
        objectives = tuple(opt["objectives"])
        if conditions and mode == "each":  # objective-major: F_max@a, F_max@b, E_max@a, ...
            if worst is not None and len(worst) == len(objectives):
                worst = [w for w in worst for _ in conditions]
            objectives = tuple(robust.at_condition(k, c) for k in objectives for c in conditions)
        return cls(
            variables=tuple(case.variables),
            objectives=objectives,
            budget=int(opt["budget"]),
            initial_points=int(opt["initial_points"]),
            seed=int(opt["seed"]),
            timeout=float(opt["timeout"]),
            rho=float(asf["rho"]),
            improvement=float(asf["improvement"]),
            worst=None if worst is None else tuple(float(w) for w in worst),
            conditions=conditions,
            weights=tuple(c.weight for c in case.conditions),
            condition_mode=mode,
            traffic=(tuple(c.name for c in case.traffic) if case.degradation is not None
                     else ()),
            realisations=case.realisations,
            statistics=tuple(robust.recorded(objectives)) if case.realisations else (),
        )

    # -- design space -----------------------------------------------------------------------
    @property
    def dim(self) -> int:
        return len(self.variables)

    # the variables' names, bounds, kinds and reference design, one tuple each
    names = property(lambda self: tuple(v.name for v in self.variables))
    lower = property(lambda self: tuple(v.lower for v in self.variables))
    upper = property(lambda self: tuple(v.upper for v in self.variables))
    integer = property(lambda self: tuple(v.integer for v in self.variables))
    reference = property(lambda self: tuple(v.reference for v in self.variables))

    @property
    def log(self) -> tuple[bool, ...]:
        """Variables searched on a log scale (empty: none)."""
        log = tuple(v.log for v in self.variables)
        return log if any(log) else ()

    @property
    def surrogate(self) -> str:
        """What the optimiser's surrogate fits (recorded in the journal's first line):

        * ``composite``: two or more objectives, one RBF each, scored by the ASF;
        * the one objective's own choice (``lccopt.vti.response.OBJECTIVES``) when it is
          minimised on one simulation per design (no traffic conditions): ``sleeper-energies``
          for E_max, one RBF per zone sleeper's energy, scored by their max - min;
        * ``scalar``: one RBF of the value (F_max, whose high and low are themselves maxima
          over time, measured worse with its parts fitted apart; and every traffic case)."""
        if self.multi:
            return "composite"
        one = OBJECTIVES.get(self.objectives[0])
        if one is not None and not self.conditions and len(self.traffic) <= 1:
            return one.surrogate
        return "scalar"

    @property
    def multi(self) -> bool:
        return len(self.objectives) > 1

    @property
    def reference_first(self) -> bool:
        """The reference design's result comes before any other design's value: it fixes the
        ASF's reference point (two or more objectives) or what p_worse compares with."""
        return self.multi or any(robust.parse(k) is not None and robust.parse(k)[0] == "p_worse"
                                 for k in self.objectives)

    @property
    def scalarisation(self) -> str:
        return "asf" if self.multi else "single"

    def space(self):
        from .optim.space import DesignSpace

        return DesignSpace.of(self.variables, given=[list(self.reference)])

    def optimiser_settings(self):
        """The optimiser settings of a new run of this problem (``optim.settings.Settings``):
        those of its surrogate, scalar or composite (``surrogate``)."""
        from .optim.settings import Settings

        return Settings.default(composite=self.surrogate != "scalar")

    def strategy(self, budget: int | None = None, settings=None):
        """The optimiser of a run of this problem: ``optimiser_settings()``, or the settings a
        run recorded (``Settings`` or its dict), with the aggregate of a single objective set
        (a multi-objective run's ASF waits for the reference design's result)."""
        from .optim.strategy import Strategy

        strategy = Strategy(self.space(), budget=self.budget if budget is None else int(budget),
                            n_initial=self.initial_points, seed=self.seed,
                            settings=self.optimiser_settings() if settings is None else settings)
        if not self.multi:
            strategy.set_aggregate(self.aggregate(None))
        return strategy

    def outputs(self, objectives: dict, parts=None) -> list[float] | None:
        """What the composite surrogate fits for one evaluation: the objective vector
        (two or more objectives), the sleepers' energies (``parts``, E_max alone), or None."""
        if self.multi:
            return [float(v) for v in self.objective_vector(objectives or {})]
        if self.surrogate == "sleeper-energies" and parts is not None:
            return [float(v) for v in parts]
        return None

    def aggregate(self, reference_point, worst=None, rho=None):
        """The value as a function of output vectors F (n, k), for the composite surrogate:
        the ASF with this reference point (and worst, rho: the case's unless given);
        ``sleeper_energy_spread`` for E_max alone; else None."""
        if not self.multi:
            return sleeper_energy_spread if self.surrogate == "sleeper-energies" else None
        if reference_point is None:
            return None
        from .optim.scalarise import ASF

        return ASF(reference_point, self.worst if worst is None else worst,
                   self.rho if rho is None else rho)

    def same_space(self, other: "Problem") -> bool:
        """Same variables, bounds, scales, reference design and objectives (what a resume must
        keep: the optimiser's proposals depend on them)."""
        keys = ("names", "lower", "upper", "integer", "reference", "objectives", "conditions",
                "weights", "condition_mode", "log", "realisations")
        return all(getattr(self, k) == getattr(other, k) for k in keys)

    # -- scalar value ------------------------------------------------------------------------
    def worst_values(self, reference_objectives: dict) -> tuple[float, ...] | None:
        """The ASF's worst values: the case's, else ``DEFAULT_WORST_FACTOR`` x the reference
        design's objectives (None for a single objective)."""
        if not self.multi:
            return None
        if self.worst is not None:
            return self.worst
        return tuple(DEFAULT_WORST_FACTOR * float(reference_objectives[k])
                     for k in self.objectives)

    def with_reference(self, reference_objectives: dict) -> "Problem":
        """The problem with its worst values set from the reference design's objectives where
        the case gives none (``worst_values``); the same problem otherwise."""
        if not self.multi or self.worst is not None:
            return self
        return replace(self, worst=self.worst_values(reference_objectives))

    def reference_point(self, reference_objectives: dict) -> list[float] | None:
        """f^r = (1 - improvement) f(x_ref) for a multi-objective case, else None.

        Raises CaseError when a worst value does not exceed its reference point (kappa_i
        would be infinite or negative)."""
        if not self.multi:
            return None
        from .optim.scalarise import improvement_target

        f = [float(reference_objectives[k]) for k in self.objectives]
        point = [float(v) for v in improvement_target(f, self.improvement)]
        for name, w, r, f0 in zip(self.objectives, self.worst_values(reference_objectives), point,
                                  f):
            if w > r:
                continue
            if self.worst is None:  # the default: the user set no worst value
                raise CaseError(f"{name}: the reference design's {name} is {f0:g}, so the ASF's "
                                f"default worst value (1.5 x that) does not exceed its reference "
                                f"point ({r:g}, {self.improvement:.0%} better): set "
                                f"optimisation.asf.worst (then resume with "
                                f"--allow-changed-case), or minimise another objective")
            raise CaseError(f"{name}: optimisation.asf.worst = {w:g} must exceed the reference "
                            f"point {r:g} (reference design {name} = {f0:g} improved by "
                            f"{self.improvement:.0%})")
        return point

    def objective_vector(self, objectives: dict) -> np.ndarray:
        return np.array([float(objectives.get(k, math.nan)) for k in self.objectives])

    def finite(self, objectives: dict) -> str | None:
        """None if every objective of the case is a finite number, else the reason."""
        bad = [f"{k}={objectives.get(k)!r}" for k in self.objectives
               if not isinstance(objectives.get(k), (int, float))
               or not math.isfinite(objectives[k])]
        return f"non-finite objectives: {', '.join(bad)}" if bad else None

    def value(self, objectives: dict, reference_point=None) -> float:
        """The scalar the optimiser minimises."""
        if not self.multi:
            return float(objectives[self.objectives[0]])
        if reference_point is None:
            raise ValueError("a multi-objective value needs the reference point")
        from .optim.scalarise import asf

        return float(asf(self.objective_vector(objectives), reference_point,
                         self.worst, rho=self.rho))

    # -- realisations of the track -------------------------------------------------------------
    def realisation_objectives(self, tracks: list[dict]) -> dict:
        """Each realisation's objectives as ``F_max#r`` from the objectives of each
        realisation's track (in order): every combined objective, and a condition's own
        (``F_max@name``) where a statistic of the case names it."""
        named = {robust.objective_of(k) for k in self.statistics}
        out = {}
        for r, objectives in enumerate(tracks):
            for k, v in objectives.items():
                if "@" not in k or k in named:
                    out[robust.realisation_key(k, r)] = float(v)
        return out

    def complete(self, objectives: dict, reference_objectives: dict | None) -> dict:
        """The objectives with the robust statistics the run records (``statistics``): the
        mean and quantiles of a design's realisations, and p_worse against the reference
        design's (``reference_objectives``; the design's own for the reference design)."""
        if not self.statistics:
            return objectives
        out = dict(objectives)
        for k in self.statistics:
            out[k] = robust.statistic(k, objectives, self.realisations, reference_objectives)
        return out

    # -- traffic conditions ------------------------------------------------------------------
    def combine(self, per_condition: list[dict]) -> dict:
        """The objectives of one design from its conditions' objectives (in case order).

        F_rms, F_max, E_rms, E_max combine by the case's rule: worst = the largest over the
        conditions, mean = the weighted mean (each: the largest, for display; the optimiser
        then minimises every F_max@name, ... of its own). Every condition's own values are
        kept as F_max@name etc."""
        return combine_conditions(per_condition, self.conditions, self.weights, self.condition_mode)


def sleeper_energy_spread(F) -> np.ndarray:
    """E_max (max - min over the zone's sleepers) of each row of sleeper energies F (n, k)."""
    F = np.asarray(F, dtype=float)
    return F.max(axis=1) - F.min(axis=1)


# A lower energy can raise the spread as much as a higher one: the composite surrogate must
# not median-cap the energies (Strategy.set_aggregate; measured in benchmarks/RESULTS-optimiser.md).
sleeper_energy_spread.increasing = False


def combine_conditions(per_condition: list[dict], names, weights, mode: str) -> dict:
    """See :meth:`Problem.combine`."""
    out: dict[str, float] = {}
    keys = [k for k in per_condition[0] if "@" not in k]
    w = np.asarray(weights, dtype=float)
    for k in keys:
        v = np.array([float(o[k]) for o in per_condition])
        out[k] = float(np.sum(w * v) / np.sum(w)) if mode == "mean" else float(v.max())
    for name, o in zip(names, per_condition):
        for k in keys:
            out[f"{k}@{name}"] = float(o[k])
    return out

