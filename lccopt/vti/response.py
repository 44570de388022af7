"""Response of one simulation: time histories and the paper's four objectives (Sec. 2.2.2);
the names, units and meaning of every objective an evaluation can return (the paper's and
those of a settlement prediction, :mod:`lccopt.degradation.assessment`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Objective:
    """One objective an evaluation can return: its SI unit, what it is in words (short enough
    for one line of ``lccopt simulate`` on 80 columns: a settlement objective's after 43
    columns, at most 37 characters), what computes it and which surrogate suits it alone."""
    name: str
    unit: str
    doc: str
    # simulation: one run of the vehicle over the track (the paper's four); settlement: a
    # settlement prediction over the case's horizon (docs/settlement.md); reported: never
    # minimised, only reported
    source: str = "simulation"
    # What the optimiser fits when this objective is minimised alone on one simulation:
    # scalar (one RBF of the value), or sleeper-energies (one RBF per zone sleeper's energy,
    # scored by their max - min: each energy is smooth in the design where the spread has a
    # kink wherever another sleeper becomes the highest or the lowest;
    # benchmarks/RESULTS-optimiser.md has the measurement).
    surrogate: str = "scalar"


# Objectives of a settlement prediction are all minimised but years_to_limit, which is
# reported only: its minimisable form is maintenance_rate = 1 / years_to_limit (positive,
# smaller is better, so the ASF's reference point 0.8 x f(x_ref) and worst values
# 1.5 x f(x_ref) keep their meaning).
OBJECTIVES = {o.name: o for o in (
    Objective("F_rms", "N", "rms of the wheel-rail contact forces in the force zone"),
    Objective("F_max", "N", "max - min of the contact forces in the force zone"),
    Objective("E_rms", "J", "rms of the energy dissipated per zone sleeper"),
    Objective("E_max", "J", "max - min of the energy dissipated per zone sleeper",
              surrogate="sleeper-energies"),
    Objective("level_d1_max", "m", "largest D1 (3-25 m) level deviation", "settlement"),
    Objective("level_d1_std", "m", "std of the D1 level, approach + ERS", "settlement"),
    Objective("rail_step", "m", "rail below the slab edge within 3 m", "settlement"),
    Objective("rail_angle", "m/m", "rail slope at the interface, mm/m", "settlement"),
    Objective("differential_settlement", "m", "max - min over the settling sleepers",
              "settlement"),
    Objective("max_settlement", "m", "largest of any settling sleeper", "settlement"),
    Objective("max_void", "m", "largest void under a sleeper", "settlement"),
    Objective("level_std", "m", "std of the rail level, zone +- 3 m", "settlement"),
    Objective("force_growth", "-", "largest wheel force: settled / new", "settlement"),
    Objective("maintenance_rate", "1/year", "1 / years_to_limit", "settlement"),
    Objective("interventions", "-", "tampings over the horizon", "settlement"),
    Objective("years_to_limit", "year", "until the limit (or the horizon)", "reported"),
)}


def _named(source: str) -> tuple[str, ...]:
    return tuple(k for k, o in OBJECTIVES.items() if o.source == source)


PAPER_OBJECTIVES = _named("simulation")          # F_rms, F_max, E_rms, E_max: always reported
SETTLEMENT_OBJECTIVES = _named("settlement")
REPORTED_ONLY = _named("reported")
OBJECTIVE_UNITS = {k: o.unit for k, o in OBJECTIVES.items()}
OBJECTIVE_DOC = {k: o.doc for k, o in OBJECTIVES.items()}
# Display: (factor from SI, unit) people read each SI unit in.
_DISPLAY = {"N": (1e-3, "kN"), "J": (1.0, "J"), "m": (1e3, "mm"), "-": (1.0, ""),
            "m/m": (1e3, "mm/m"),
            "1/year": (1.0, "/year"), "year": (1.0, "years")}


def objective_unit(k: str) -> str:
    """The SI unit of an objective.

    Parameters
    ----------
    k
        an objective's name; ``F_max@name`` (a condition's), ``F_max#3`` (a realisation's),
        ``mean(F_max)`` and ``q90(F_max)`` have F_max's unit; ``p_worse(F_max)`` is a
        probability (``lccopt.uncertainty.statistics``).

    Returns
    -------
    str
        e.g. ``"N"``, ``"J"``, ``"m"``, ``"1/year"``.
    """
    from ..uncertainty import statistics

    if statistics.is_probability(k):
        return "-"
    base = statistics.objective_of(k).split("@")[0]
    return OBJECTIVE_UNITS.get(base, "N" if base.startswith("F") else "J")


def objective_doc(k: str) -> str:
    """What an objective means, in one line: OBJECTIVE_DOC's, a statistic's in words
    (``90 % quantile over the realisations of the track of max - min of ...``), a
    condition's (``F_max@v160``) or a realisation's as its objective's; else the name."""
    from ..uncertainty import statistics

    base = statistics.objective_of(k)
    doc = OBJECTIVE_DOC.get(base.split("@")[0], base)
    return statistics.describe(k, doc) if statistics.is_statistic(k) else doc


def objective_display(k: str) -> tuple[float, str]:
    """The scale and unit people read an objective in: forces in kN,
    energies in J, settlements in mm.

    Parameters
    ----------
    k
        an objective's name.

    Returns
    -------
    tuple of (float, str)
        (factor from SI, unit).
    """
    return _DISPLAY.get(objective_unit(k), (1.0, objective_unit(k)))


def improvement_sign(k: str) -> float:
    """Which way an objective improves.

    Parameters
    ----------
    k
        an objective's name.

    Returns
    -------
    float
        +1 where smaller is better (every objective the optimiser may minimise), -1 for the
        reported-only ``years_to_limit``.
    """
    return -1.0 if k.split("@")[0] in REPORTED_ONLY else 1.0


@dataclass
class Evaluation:
    """What one vehicle-track simulation of one design returns.

    objectives: F_rms, F_max [N] of the contact forces of all wheels, each while that wheel is
                in the force zone (F_max also at each wheel's zone ends);
                E_rms, E_max [J] over the energies dissipated under the zone's sleepers
                during the whole run (until the last wheel is run_out past the zone);
                with a settlement prediction also SETTLEMENT_OBJECTIVES and years_to_limit
                (``OBJECTIVE_UNITS``).
    histories:  named arrays in SI units (see ``HISTORY_DOC``).
    info:       scalars describing the run (static load, contact stiffness, contact loss, ...).
    """
    objectives: dict[str, float]
    histories: dict[str, np.ndarray] = field(repr=False)
    info: dict = field(default_factory=dict)


HISTORY_DOC = {
    "time": "time [s], one value per step",
    "wheel_position": "wheel position along the track [m]",
    "contact_force": "wheel-rail contact force [N], compression positive",
    "wheel_displacement": "wheelset displacement [m], downward positive, from the unloaded state",
    "rail_displacement": "rail displacement under the wheel [m], downward positive",
    "carbody_displacement": "carbody displacement [m], downward positive",
    "in_force_zone": "1 where the wheel is inside the force zone, else 0",
    "sleeper_position": "positions "
                        "of the evaluation-zone sleepers [m], nearest the interface first",
    "sleeper_energy": "energy dissipated in the support under each zone sleeper [J], same order",
    "sleeper_strengthened": "1 for a strengthened zone sleeper, else 0, same order",
    "sleeper_displacement": "displacement of each zone sleeper [m] against time (steps x sleepers)",
    "wheel_positions": "position of every wheel [m] (steps x wheels), leading wheel first",
    "contact_force_wheels": "contact force of every wheel [N] (steps x wheels), same order",
    "in_force_zone_wheels": "1 where that wheel is inside the force zone, else 0 (steps x wheels)",
    "irregularity_at_wheel": "rail irregularity (dip) under the leading wheel [m], when there is "
                             "one",
    # a settlement prediction (lccopt.degradation.assessment): one row per block of load cycles,
    # row 0 the new track
    "settlement_years": "time at the end of each block [year]",
    "settlement_axle_passes": "axle passes at the end of each block, all conditions [-]",
    "settlement_sleeper_x": "positions of the settling sleepers [m], nearest the interface first",
    "settlement_sleepers": "settlement of each settling sleeper's ballast [m] (blocks x sleepers)",
    "settlement_void": "void under each settling sleeper at rest [m] (blocks x sleepers)",
    "settlement_level": "rail level at rest, downward positive [m] (blocks x points), the "
                        "ERS slab's settlement included",
    "settlement_level_x": "positions of the rail level's points [m]",
    "settlement_peak_force": "largest ballast force of an axle in the block [N] (blocks x "
                             "conditions x sleepers), simulated where settlement_simulated",
    "settlement_wheel_force_max": "largest wheel-rail force of a simulated passage [N] (blocks x "
                                  "conditions), NaN where not simulated",
    "settlement_simulated": "1 where every condition was simulated at the block's end",
    "settlement_tamped": "1 for the record of a tamping (the track just after it)",
    "settlement_load_errors": "largest error of the predicted loads at each re-simulation [N]",
    "settlement_slab": "settlement of the ERS slab [m] per block",
    "settlement_rail_step": "rail_step [m] per block (lccopt/degradation/rail.py)",
    "settlement_rail_angle": "rail_angle [-] per block",
    "settlement_level_d1_std": "level_d1_std [m] per block",
    "settlement_level_d1_max": "level_d1_max [m] per block",
    "settlement_level_std": "level_std [m] per block",
}
# wheel_position, contact_force, wheel_displacement, rail_displacement and in_force_zone are
# those of the leading wheel (the only one of the three-dof vehicle).


def objectives_from(force_in_zone: np.ndarray, sleeper_energy: np.ndarray,
                    force_ends=None) -> dict[str, float]:
    """Eq. (4) and the rms / max-min metrics of Sec. 2.2.2.

    force_ends: the force at the force zone's exact ends, also taken for F_max (not F_rms)."""
    f = np.asarray(force_in_zone, dtype=float)
    e = np.asarray(sleeper_energy, dtype=float)
    fm = f if force_ends is None else np.concatenate([f, np.asarray(force_ends, dtype=float)])
    return {
        "F_rms": float(np.sqrt(np.mean(f ** 2))),
        "F_max": float(fm.max() - fm.min()),
        "E_rms": float(np.sqrt(np.mean(e ** 2))),
        "E_max": float(e.max() - e.min()),
    }
