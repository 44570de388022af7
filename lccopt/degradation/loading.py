"""What one passage does to the ballast: per-axle peak sleeper forces from a simulation, the
traffic conditions that cause them, and the settlement zone of a built transition track
(which sleepers settle, which follow).

The settlement iteration (:mod:`lccopt.degradation.iteration`) sees a traffic condition as a
:class:`PassageKind`: how often it passes, ``simulate(supports) -> Loading`` and its axles
(static wheel loads and spacing, for the iteration's quasi-static load model);
:func:`vti_passage_kind` builds one from a track, a vehicle and a run, so that the iteration
itself knows nothing of how the passage is simulated.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..vti.newmark import History, integrate
from ..vti.unilateral import SleeperSupports, sleeper_supports


@dataclass(frozen=True)
class Loading:
    """One passage of a vehicle over the current track.

    peak_force: (load cycles per passage, sleepers) peak ballast force under each sleeper of
                the supports [N] (modelled rail seat), one row per axle: a load cycle.
    wheel_force_max: largest wheel-rail contact force of the passage [N].
    """
    peak_force: np.ndarray
    wheel_force_max: float


def axle_peaks(history: History, sleeper_x: np.ndarray) -> np.ndarray:
    """(wheels, sleepers) peak support force per axle: for each sleeper, the largest force
    while that wheel is the nearest one to the sleeper (each axle loads a sleeper once)."""
    pos = np.asarray(history.wheel_position, dtype=float)          # (steps, wheels)
    f = np.asarray(history.support_force, dtype=float)             # (steps, sleepers)
    dist = np.abs(pos[:, :, None] - np.asarray(sleeper_x, float)[None, None, :])
    nearest = np.argmin(dist, axis=1)                               # (steps, sleepers)
    k = pos.shape[1]
    return np.stack([np.where(nearest == w, f, -np.inf).max(axis=0) for w in range(k)]).clip(0.0)


@dataclass(frozen=True)
class Axles:
    """The wheels of one passage on the modelled rail: ``offsets`` [m] behind the leading wheel
    (front first, as the rows of :attr:`Loading.peak_force`), static ``loads`` [N] per wheel,
    ``direction`` +1 (towards +x) or -1."""
    offsets: np.ndarray
    loads: np.ndarray
    direction: float = 1.0


@dataclass(frozen=True)
class PassageKind:
    """One kind of passage: ``passes_per_year`` passages simulated by ``simulate``, with the
    axles ``axles``."""
    name: str
    passes_per_year: float
    simulate: Callable[[SleeperSupports], Loading]
    axles: Axles


def vti_passage_kind(name: str, passes_per_year: float, track, vehicle, *, dt: float,
                  speed: float, x_start: float, n_steps: int,
                  irregularity: Callable[[float], float] | None = None) -> PassageKind:
    """A :class:`PassageKind`: ``vehicle`` running over ``track`` (the arguments of
    :func:`~lccopt.vti.newmark.integrate`) ``passes_per_year`` times a year."""
    def simulate(supports: SleeperSupports) -> Loading:
        h = integrate(track, dt, speed, x_start, n_steps, vehicle=vehicle,
                      supports=supports, irregularity=irregularity)
        return Loading(axle_peaks(h, supports.x), float(np.max(h.wheel_force)))
    axles = Axles(np.asarray(vehicle.wheel_offsets, dtype=float),
                  np.asarray(vehicle.static_wheel_loads, dtype=float),
                  -1.0 if speed < 0 else 1.0)
    return PassageKind(name, float(passes_per_year), simulate, axles)


@dataclass(frozen=True)
class SettlementZone:
    """The sleepers of a transition that settle.

    supports: unilateral supports of every sleeper that may get a gap: first the ``n_settling``
              sleepers that settle by their own simulated loads (nearest the interface first),
              then followers, whose gap is ``follower_weight`` times the settlement of the last
              settling sleeper (the open track's, as far from the interface as the zone
              reaches), tapering to zero far away, where the rail's pinned end would
              otherwise hold the settled track up.
    """
    supports: SleeperSupports
    n_settling: int
    follower_weight: np.ndarray

    def gaps(self, settlement: np.ndarray) -> np.ndarray:
        """Gap of every support for the settlement of the settling sleepers [m]."""
        s = np.asarray(settlement, dtype=float)
        return np.concatenate([s, self.follower_weight * s[-1]])


def entry_zone(track, n_settling: int, flat: float = 10.0, taper: float = 20.0) -> SettlementZone:
    """The settlement zone of the entry side of a built level-crossing track: the
    ``n_settling`` entry sleepers nearest the interface settle by their loads; the entry
    sleepers beyond follow the farthest of them over ``flat`` metres, then a half-cosine taper
    to zero over ``taper`` metres. Exit sleepers and the ERS do not settle."""
    n_entry = int(track.info["n_entry_sleepers"])
    if not 1 <= n_settling <= n_entry:
        raise ValueError(f"n_settling must be 1..{n_entry}")
    x = np.asarray(track.sleeper_x, float)[:n_entry]
    beyond = x[n_settling - 1] - x[n_settling:]                     # distance past the zone
    w = np.where(beyond <= flat, 1.0,
                 0.5 * (1.0 + np.cos(np.pi * np.clip((beyond - flat) / taper, 0.0, 1.0))))
    keep = w > 0.0
    idx = np.concatenate([np.arange(n_settling), n_settling + np.flatnonzero(keep)])
    return SettlementZone(sleeper_supports(track, idx), n_settling, w[keep])
