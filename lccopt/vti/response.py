"""Response of one simulation: time histories and the paper's four objectives (Sec. 2.2.2)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

OBJECTIVE_UNITS = {"F_rms": "N", "F_max": "N", "E_rms": "J", "E_max": "J"}
OBJECTIVE_DOC = {  # short enough for one line of `lccopt simulate` on 80 columns
    "F_rms": "rms of the wheel-rail contact forces in the force zone",
    "F_max": "max - min of the contact forces in the force zone",
    "E_rms": "rms of the energy dissipated per zone sleeper",
    "E_max": "max - min of the energy dissipated per zone sleeper",
}


def objective_display(k: str) -> tuple[float, str]:
    """(scale, unit) in which people read objective k: forces in kN, energies in J."""
    return (1e-3, "kN") if OBJECTIVE_UNITS.get(k, "N" if k.startswith("F") else "J") == "N" else (1.0, "J")


@dataclass
class Evaluation:
    """What one vehicle-track simulation of one design returns.

    objectives: F_rms, F_max [N] of the contact forces of all wheels, each while that wheel is
                in the force zone (F_max also at each wheel's zone ends);
                E_rms, E_max [J] over the energies dissipated under the zone's sleepers
                during the whole run (until the last wheel is run_out past the zone).
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
    "sleeper_position": "positions of the evaluation-zone sleepers [m], nearest the interface first",
    "sleeper_energy": "energy dissipated in the support under each zone sleeper [J], same order",
    "sleeper_strengthened": "1 for a strengthened zone sleeper, else 0, same order",
    "sleeper_displacement": "displacement of each zone sleeper [m] against time (steps x sleepers)",
    "wheel_positions": "position of every wheel [m] (steps x wheels), leading wheel first",
    "contact_force_wheels": "contact force of every wheel [N] (steps x wheels), same order",
    "in_force_zone_wheels": "1 where that wheel is inside the force zone, else 0 (steps x wheels)",
    "irregularity_at_wheel": "rail irregularity (dip) under the leading wheel [m], when there is one",
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
