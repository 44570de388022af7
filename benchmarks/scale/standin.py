"""A stand-in for the simulator that takes a fixed time and uses no CPU: it sleeps.

    LCCOPT_EVALUATOR=benchmarks.scale.standin:evaluate LCCOPT_STANDIN_SECONDS=0.15 \
        lccopt optimise configs/quickstart.yaml --workers 64

With it the engine's own costs (proposals, journal, files, the executor's hand-offs) can be
measured at 1-128 workers on a machine of two cores: the workers wait, they do not compute.
(Run from the repository root, or with it on PYTHONPATH, so that ``benchmarks`` imports.)

``evaluate(case, x)`` sleeps ``LCCOPT_STANDIN_SECONDS`` (default 0.15 s, what a paper-case
simulation takes) and returns an Evaluation shaped as the simulator's: the four objectives,
smooth multimodal functions of the design in the unit box of the case's bounds (scaled by the
vehicle speed, so that traffic conditions differ), the per-sleeper values (20 zone sleepers'
energies, which the E_max composite surrogate fits; 166 entry sleepers) and time histories
of the simulator's length (1483 steps), kept only where the run keeps histories.
"""

from __future__ import annotations

import os
import time

import numpy as np

from lccopt.vti.response import Evaluation

N_STEPS = 1483        # time steps of a paper-case simulation
N_ZONE = 20           # zone sleepers (their energies: E_max and its composite surrogate)
N_ENTRY = 166         # entry sleepers
REFERENCE_SPEED = 38.88888888888889  # [m/s] the paper's case (140 km/h)

# fixed coefficients of the stand-in's objectives (any 8-variable design space)
_A = np.array([0.3, 0.2, 0.1, 0.25, 0.5, 0.5, 0.25, 0.0])
_B = np.array([0.9, 0.8, 0.7, 0.1, 0.6, 0.4, 0.2, 0.3])
_S = np.linspace(0.0, 1.0, N_ZONE)


def seconds() -> float:
    """The stand-in's duration [s] ($LCCOPT_STANDIN_SECONDS, default 0.15)."""
    return float(os.environ.get("LCCOPT_STANDIN_SECONDS", "0.15") or 0.15)


def objectives(case, x) -> tuple[dict, np.ndarray]:
    """(the four objectives, the zone sleepers' energies) of design x."""
    x = np.asarray(x, dtype=float)
    span = np.where(case.upper > case.lower, case.upper - case.lower, 1.0)
    u = (x - case.lower) / span
    a, b = np.resize(_A, len(u)), np.resize(_B, len(u))
    speed = case.vehicle["speed"] / REFERENCE_SPEED
    # scaled so that the paper's reference design gets its F_max and E_max (7557 N, 0.41 J)
    f = 0.2873 * (5000.0 + 12000.0 * np.sum((u - a) ** 2) + 300.0 * np.sin(7.0 * u).sum()) * speed
    # one energy per zone sleeper: a bump whose place and height the design moves
    centre = float(np.mean(u[: len(u) // 2]))
    height = 1.416 * (0.1 + 0.5 * np.sum((u - b) ** 2) + 0.01 * np.cos(5.0 * u).sum())
    energy = speed * speed * (0.05 + height * np.exp(-((_S - centre) / 0.3) ** 2))
    e_max = float(energy.max() - energy.min())
    obj = {"F_rms": 49000.0 + 0.1 * f, "F_max": float(f), "E_rms": 1.5 + 0.5 * e_max,
           "E_max": e_max}
    return obj, energy


def evaluate(case, x) -> Evaluation:
    """Sleep ``seconds()``, then return the stand-in's Evaluation of design x."""
    time.sleep(seconds())
    x = case.check_design(x)
    obj, energy = objectives(case, x)
    t = np.linspace(0.0, 0.74, N_STEPS)
    force = 56978.0 + obj["F_max"] * np.sin(60.0 * t) ** 2
    histories = {
        "time": t, "contact_force": force, "wheel_position": 86.2 + 38.9 * t,
        "sleeper_position": np.linspace(88.2, 112.0, N_ZONE), "sleeper_energy": energy,
        "sleeper_strengthened": np.zeros(N_ZONE),
        "sleeper_displacement": np.outer(np.sin(20.0 * t), energy),
        "entry_sleeper_position": np.linspace(0.0, 100.0, N_ENTRY),
        "entry_pad_stiffness": np.full(N_ENTRY, 1.0e8), "entry_strengthened": np.zeros(N_ENTRY),
    }
    return Evaluation(obj, histories, {"speed": float(case.vehicle["speed"]), "standin": True,
                                       "wall_time": seconds()})
