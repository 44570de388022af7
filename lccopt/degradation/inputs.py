"""What a settlement prediction of a design takes: typed, immutable inputs in SI units.

The config layer builds them from a case's ``degradation:`` section (lccopt/config/
degradation.py); :func:`lccopt.degradation.assessment.assess_settlement` reads them. Nothing
here knows about YAML or files, and importing it loads no numerics.
"""

from __future__ import annotations

from dataclasses import dataclass, field

LAW_NAMES = ("varandas", "logarithmic")
SOILS = ("ML", "MH", "CL", "CH")           # Li & Selig's classes (lccopt.degradation.laws)
# how the law reads a passage's load cycles: each axle its own peak (axle), or every axle the
# passage's peak (passage: ROSE's code takes the largest force of the whole train)
READINGS = ("axle", "passage")
# measures a limit may be set on (lengths: SettlementResult.measure)
LIMIT_MEASURES = ("level_d1_max", "level_d1_std", "rail_step", "rail_angle",
                  "differential_settlement", "max_settlement", "max_void", "level_std")


@dataclass(frozen=True)
class Traffic:
    """One traffic condition: its simulation (a ``lccopt.vti.specs.Scenario``), how often its
    vehicle passes a year, and its weight in the weighted mean of the paper's objectives."""
    name: str
    scenario: object
    passages_per_year: float
    weight: float = 1.0


@dataclass(frozen=True)
class LawSpec:
    """A settlement law of :mod:`lccopt.degradation.laws` by name (``LAW_NAMES``) and the
    arguments of its class (``VarandasLaw(alpha, beta, gamma, f0, n0)``,
    ``LogarithmicLaw(first_cycle, log_rate, exponent, f0)``), SI units."""
    name: str = "varandas"
    parameters: tuple = ()            # ((argument, value), ...)


@dataclass(frozen=True)
class Limit:
    """The limit that ``years_to_limit`` counts to: ``measure`` (one of LIMIT_MEASURES)
    reaching ``value`` [m]."""
    measure: str = "differential_settlement"
    value: float = 3.0e-3


@dataclass(frozen=True)
class SubgradeSpec:
    """The subgrade layer under the ballast and under the ERS slab (Li & Selig 1996):
    ``soil`` (one of SOILS), static ``strength`` [Pa] of the soil under a support of
    ``reference_stiffness`` [N/m per rail seat] (the strength scales with the support
    stiffness of the case's standard sleepers), the layer from ``depth`` below the sleeper
    base (the ballast and sub-ballast) over ``thickness`` [m]."""
    soil: str = "CL"
    strength: float = 150.0e3
    reference_stiffness: float = 45.0e6
    depth: float = 0.5
    thickness: float = 2.0


@dataclass(frozen=True)
class TampingSpec:
    """Tamping over the life when the limit is reached: the ``unreachable_sleepers`` next to
    the slab are not lifted (a tamping machine cannot reach them), the others are; at most
    one tamping each ``min_interval`` [year]."""
    unreachable_sleepers: int = 2
    min_interval: float = 0.1


@dataclass(frozen=True)
class DegradationSpec:
    """A settlement prediction of a design (docs/settlement.md, the case's ``degradation:``).

    traffic: every condition (those without passages count for the paper's objectives only);
    horizon_years [year]; law; settling_sleepers, follower_flat, follower_taper [m]:
    :func:`~lccopt.degradation.loading.entry_zone`; rail_seats, tolerance [N],
    steps_per_decade, max_simulations (per condition):
    :func:`~lccopt.degradation.iteration.predict_settlement`; condition_mode: worst or mean,
    how the paper's objectives of several conditions combine.

    The ballast law is fed the sleeper-ballast pressure: bearing_area and
    strengthened_bearing_area [m^2] per rail seat (the law's reference_force acts on a
    standard sleeper's area); subgrade: the layer below (None: the ballast law alone);
    reading: one of READINGS; tamping: tamping when ``limit`` is reached (None: never).
    Per settling sleeper (nearest the interface first; None: the
    same for all): sleeper_gamma, a factor on the ballast law's settlement, and initial_gap
    [m], a void before any traffic."""
    traffic: tuple
    horizon_years: float
    law: LawSpec = field(default_factory=LawSpec)
    settling_sleepers: int = 20
    follower_flat: float = 10.0
    follower_taper: float = 20.0
    rail_seats: float = 1.0
    tolerance: float = 2.0e3
    steps_per_decade: float = 8.0
    max_simulations: int = 30
    limit: Limit = field(default_factory=Limit)
    condition_mode: str = "worst"
    bearing_area: float = 0.375
    strengthened_bearing_area: float = 0.375
    subgrade: SubgradeSpec | None = None
    reading: str = "axle"
    sleeper_gamma: tuple | None = None
    initial_gap: tuple | None = None
    tamping: TampingSpec | None = None

    @property
    def settling_traffic(self) -> tuple:
        """The conditions with passages: those the settlement prediction simulates."""
        return tuple(t for t in self.traffic if t.passages_per_year > 0)
