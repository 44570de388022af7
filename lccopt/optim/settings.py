"""The optimiser's settings, which a run records and a resume rebuilds, and its constants.

``Settings`` holds what differs between the two kinds of surrogate: a scalar one (one RBF
of the minimised value) and a composite one (one RBF per output, scored by the aggregate of
their predictions). Each field was chosen where that surrogate is used (the scalar on the
broad benchmark of test functions, the composite on the paper's E_max and ASF cases:
benchmarks/RESULTS-optimiser.md), so the defaults are two profiles, ``Settings.default``.
Everything else is a constant of the method (below) or depends only on the design space.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

# The merit weights of the paper's Eq. (11), one per proposal in turn: w * scaled surrogate
# value + (1 - w) * scaled distance to the points already used.
WEIGHTS = (0.3, 0.5, 0.8, 0.95)
# DYCORS step size, as a fraction of each variable's range: its start and ceiling, and the
# floor below which the phase has converged and the run restarts (six halvings).
SIGMA_INIT = 0.2
SIGMA_MAX = 0.2
SIGMA_MIN = 0.2 * 0.5 ** 6
SUCCESS_TOL = 3             # successes in a row that double sigma
IMPROVEMENT_TOL = 1e-3      # a success: f < f_best - IMPROVEMENT_TOL * |f_best|
# Duplicate radius in the unit box, times sqrt(number of continuous variables): a candidate
# this close to a used point with the same integers is not proposed. Small enough that a
# sharp minimum can be refined past three digits of the unit box.
DIST_TOL = 1e-4
N_BRANCHES = 3              # integer assignments tried by the local search besides the best's
LOCAL_MAXITER = 30          # L-BFGS-B iterations per branch of the local search
# Largest all-integer grid that is listed point by point once the candidates stop finding
# unused points (so that a nearly exhausted grid is still searched to the end).
ENUMERATE_LIMIT = 200_000


def n_perturb(dim: int) -> int:
    """DYCORS candidates per proposal."""
    return min(5000, 100 * dim)


def fail_tol(dim: int) -> int:
    """Failures in a row that halve sigma; also the failed evaluations in a row that end a
    phase, and the proposals a subspace phase gets to prove itself."""
    return max(dim, 5)


_CHOICES = {
    "composite": (False, True),
    "perturbation": ("truncnorm", "reflect"),
    "probability_schedule": ("run", "restart"),
    "local_weights": ("greedy", "all"),
    "restart_keeps_points": (True, False),
    "restart_from": ("endgame", "fresh"),
    "subspace_start": ("endgame", "stalled"),
    "switches": (True, False),
    "shaped_steps": (True, False),
}


@dataclass(frozen=True)
class Settings:
    """What a run's proposals depend on beyond the space, budget, initial design and seed.

    Attributes
    ----------
    composite : bool
        One RBF per told output, candidates scored by the aggregate of their predictions
        (``Strategy.set_aggregate``); False: one RBF of the told value.
    perturbation : {"truncnorm", "reflect"}
        DYCORS steps: each perturbed coordinate drawn from a normal truncated to the bounds
        (integers with a scale of at least one unit, then rounded; pySOT's), or a normal
        step reflected at a bound with every perturbed integer moved by at least one unit.
    probability_schedule : {"run", "restart"}
        The perturbation probability min(20/d, 1)(1 - ln n / ln N) counts proposals over the
        whole run with a floor of 1/d (pySOT's), or within each phase without a floor.
    local_weights : {"greedy", "all"}
        Merit weights at which the local search's points compete: the greediest only, or all.
    restart_keeps_points : bool
        A fresh phase's surrogate also fits the earlier phases' points (a phase that goes on
        from a point always does).
    restart_from : {"endgame", "fresh"}
        A restart with less budget left than the run's phases took on average goes on from
        the run's best point ("endgame"), or every restart starts a fresh design.
    subspace_start : {"endgame", "stalled"}
        Which restart takes the run's one probe-and-subspace step: the first that goes on
        from the run's best point, or the first after a phase that found nothing better.
    switches : bool
        A variable whose 0 leaves a component out (``DesignSpace.switch``: the Type II strip)
        is searched as off or on, each half of its search range; False: as one range, as
        runs recorded before this setting were.
    shaped_steps : bool
        Half of each proposal's DYCORS steps are drawn with the shape of the steps from the
        phase's best point to its next best points (``candidates.shaped_steps``), the other
        half as coordinate steps; False: all coordinate steps.
    """

    composite: bool = False
    perturbation: str = "truncnorm"
    probability_schedule: str = "run"
    local_weights: str = "greedy"
    restart_keeps_points: bool = True
    restart_from: str = "endgame"
    subspace_start: str = "endgame"
    switches: bool = True
    shaped_steps: bool = True

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not any(value is c or (value == c and type(value) is type(c))
                       for c in _CHOICES[f.name]):
                allowed = ", ".join(repr(c) for c in _CHOICES[f.name])
                raise ValueError(f"optimiser setting {f.name} = {value!r}: not one of {allowed}")

    @classmethod
    def default(cls, composite: bool = False) -> "Settings":
        """The settings of a scalar or a composite surrogate."""
        return _COMPOSITE if composite else _SCALAR

    def replace(self, **changes) -> "Settings":
        """These settings with some fields changed (unknown names raise TypeError)."""
        unknown = set(changes) - set(_CHOICES)
        if unknown:
            raise TypeError(f"unknown optimiser settings: {sorted(unknown)}")
        return Settings(**{**asdict(self), **changes})

    def to_dict(self) -> dict:
        """Plain JSON types, every field (what a journal's first line records)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "Settings":
        """The settings a ``to_dict`` wrote; ValueError naming any key or value this lccopt
        does not have, or a missing key."""
        if not isinstance(d, dict):
            raise ValueError(f"optimiser settings must be a mapping, got {d!r}")
        unknown = sorted(set(d) - set(_CHOICES))
        if unknown:
            raise ValueError(f"unknown optimiser setting {unknown[0]!r}")
        missing = sorted(set(_CHOICES) - set(d))
        if missing:
            raise ValueError(f"optimiser setting {missing[0]!r} missing")
        return cls(**d)


_SCALAR = Settings()
_COMPOSITE = Settings(composite=True, perturbation="reflect", probability_schedule="restart",
                      local_weights="all", restart_keeps_points=False, restart_from="fresh",
                      subspace_start="stalled", shaped_steps=False)
