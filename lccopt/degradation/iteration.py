"""Settlement of a transition over its traffic: dynamic passages and a settlement law, in
blocks of load cycles.

Each block: simulate every traffic condition on the current track (sleepers over their voids),
take each settling sleeper's peak ballast force per axle, add the block's cycles of those
peaks to the sleeper's load history, and lower the ballast surface under the sleeper by the
settlement the law gives. The lowered surface is the sleeper's gap: where the rail holds the
sleeper up, a void opens; where the track's weight pulls rail and sleeper down with it, the
rail's profile changes (the track geometry). Both follow from the unilateral support model,
not from a choice made here (docs/settlement.md).

Block sizes adapt: a block is as long as keeps the change of the zone's differential settlement
within ``tolerance + relative`` times the differential settlement reached (the loads are those
at the block's start, so the result converges as both shrink;
tests/vti/test_settlement_iteration.py shows it).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from ..vti.unilateral import SleeperSupports, rest_state
from .laws import LoadHistory, VarandasLaw
from .loading import Loading, SettlementZone


@dataclass(frozen=True)
class Condition:
    """One kind of passage: ``passes_per_year`` passages simulated by ``simulate``."""
    name: str
    passes_per_year: float
    simulate: Callable[[SleeperSupports], Loading]


@dataclass
class SettlementResult:
    """Histories over the blocks (index 0: the new track) of the settling sleepers.

    years (blocks+1,), axle_passes (blocks+1,) cumulative load cycles of all conditions;
    settlement, void (blocks+1, sleepers) [m]: lowering of the ballast surface and the void
    under the sleeper at rest; level (blocks+1, points) [m]: rail profile at rest (own weight),
    downward positive, at ``level_x`` [m]; peak_force (blocks+1, conditions, sleepers) [N]:
    largest per-axle ballast force at the modelled rail seat; wheel_force_max (blocks+1,
    conditions) [N]; sleeper_x [m]; n_simulations; info.
    """
    years: np.ndarray
    axle_passes: np.ndarray
    settlement: np.ndarray
    void: np.ndarray
    level: np.ndarray
    level_x: np.ndarray
    peak_force: np.ndarray
    wheel_force_max: np.ndarray
    sleeper_x: np.ndarray
    conditions: tuple
    n_simulations: int
    info: dict = field(default_factory=dict)

    def measure(self, name: str) -> np.ndarray:
        """One engineer's measure over the blocks: ``differential_settlement`` (max - min over
        the zone), ``max_settlement``, ``max_void`` [m], ``level_std`` (standard deviation of
        the rail profile at rest over the level span) [m]."""
        if name == "differential_settlement":
            return np.ptp(self.settlement, axis=1)
        if name == "max_settlement":
            return self.settlement.max(axis=1)
        if name == "max_void":
            return self.void.max(axis=1)
        if name == "level_std":
            return self.level.std(axis=1)
        raise ValueError(f"unknown settlement measure {name!r}")

    def passes_to(self, name: str, limit: float) -> float:
        """Axle passes until measure ``name`` first reaches ``limit`` (linear between blocks);
        the horizon's passes if it never does (``info['limit_reached']`` says which)."""
        m = self.measure(name)
        hit = np.flatnonzero(m >= limit)
        if hit.size == 0:
            return float(self.axle_passes[-1])
        i = int(hit[0])
        if i == 0:
            return 0.0
        f = (limit - m[i - 1]) / (m[i] - m[i - 1])
        return float(self.axle_passes[i - 1] + f * (self.axle_passes[i] - self.axle_passes[i - 1]))

    def objectives(self, limit_measure: str = "level_std", limit: float = 1.0e-3) -> dict:
        """The engineer's objectives at the horizon [m, -, axle passes]."""
        growth = self.wheel_force_max[-1] / self.wheel_force_max[0]
        return {
            "differential_settlement": float(self.measure("differential_settlement")[-1]),
            "max_settlement": float(self.measure("max_settlement")[-1]),
            "max_void": float(self.measure("max_void")[-1]),
            "level_std": float(self.measure("level_std")[-1]),
            "force_growth": float(np.max(growth)),
            "passes_to_limit": self.passes_to(limit_measure, limit),
        }


def predict_settlement(track, zone: SettlementZone, conditions: Sequence[Condition], *,
                       horizon_years: float, law=None, tolerance: float = 0.5e-3,
                       relative: float = 0.0, growth: float = 10.0, max_blocks: int = 60,
                       rail_seats: float = 2.0,
                       level_span: tuple[float, float] | None = None) -> SettlementResult:
    """Settlement of ``zone`` of ``track`` under ``conditions`` up to ``horizon_years``.

    law: a settlement law of :mod:`lccopt.degradation.laws` (default :class:`VarandasLaw`),
    fed with ``rail_seats`` times the modelled rail seat's force (the laws take the force under
    a whole sleeper; one rail is modelled, loaded as its twin). tolerance [m], relative [-]: the
    largest change of the zone's differential settlement (each sleeper's increment minus the
    farthest settling sleeper's) in one block is tolerance + relative x the differential
    settlement reached; a block is at most ``growth`` times longer than the one before.
    After ``max_blocks`` blocks the rest of the horizon is one block (``info['truncated']``).
    level_span: (x_from, x_to) [m] of the rail profile measured; default the settling zone
    plus 3 m either side."""
    law = law or VarandasLaw()
    if horizon_years <= 0 or tolerance <= 0 or relative < 0 or growth <= 1:
        raise ValueError("horizon_years, tolerance must be > 0, relative >= 0, growth > 1")
    n = zone.n_settling
    sup = zone.supports
    xs = sup.x[:n]
    span = level_span or (float(xs.min()) - 3.0, float(xs.max()) + 3.0)
    lx = np.asarray(track.node_x, float)
    pick = (lx >= span[0]) & (lx <= span[1]) & (np.asarray(track.rail_w) >= 0)
    state = _State(track, zone, conditions, law, rail_seats, pick)
    state.record(0.0, 0.0)
    t, last, truncated = 0.0, None, False
    while t < horizon_years * (1 - 1e-12):
        left = horizon_years - t
        if len(state.years) - 1 >= max_blocks:
            step, truncated = left, True
        else:
            step = left if last is None else min(left, growth * last)
            reached = float(np.max(np.abs(state.settlement - state.settlement[-1])))
            step = state.fit(step, tolerance + relative * reached)
        state.advance(step)
        t += step
        last = step
        state.record(t, step)
    return state.result(truncated, (tolerance, relative))


class _State:
    """The track's state through the blocks and what is recorded of it."""

    def __init__(self, track, zone, conditions, law, rail_seats, pick):
        self.track, self.zone, self.law, self.rail_seats = track, zone, law, rail_seats
        self.conditions = tuple(conditions)
        self.pick = pick
        self.history = LoadHistory.empty(zone.n_settling)
        self.settlement = np.zeros(zone.n_settling)
        self.passes = 0.0
        self.sims = 0
        self.years, self.axles, self.s_rec, self.v_rec, self.l_rec = [], [], [], [], []
        self.f_rec, self.w_rec = [], []
        self.loads = None

    def supports(self) -> SleeperSupports:
        return self.zone.supports.with_gaps(self.zone.gaps(self.settlement))

    def record(self, years: float, step: float) -> None:
        sup = self.supports()
        self.loads = [c.simulate(sup) for c in self.conditions]
        self.sims += len(self.conditions)
        u = rest_state(self.track, sup)
        n = self.zone.n_settling
        void = np.maximum(sup.gap - sup.rest - u[sup.dof], 0.0)[:n]
        self.years.append(years)
        self.axles.append(self.passes)
        self.s_rec.append(self.settlement.copy())
        self.v_rec.append(void)
        self.l_rec.append(u[np.asarray(self.track.rail_w)[self.pick]])
        self.f_rec.append([ld.peak_force[:, :n].max(axis=0) for ld in self.loads])
        self.w_rec.append([ld.wheel_force_max for ld in self.loads])

    def _grown(self, step: float) -> LoadHistory:
        h = self.history
        n = self.zone.n_settling
        for c, ld in zip(self.conditions, self.loads):
            for peaks in ld.peak_force[:, :n]:
                h = h.add(self.rail_seats * peaks, c.passes_per_year * step)
        return h

    def fit(self, step: float, tolerance: float) -> float:
        """The longest step (up to ``step``) whose differential settlement change stays within
        ``tolerance``, by shrinking (the law alone: no simulation)."""
        for _ in range(60):
            ds = self.law.settlement(self._grown(step)) - self.settlement
            change = float(np.max(np.abs(ds - ds[-1])))
            if change <= tolerance:
                return step
            step *= max(0.05, 0.8 * tolerance / change)
        return step

    def advance(self, step: float) -> None:
        self.history = self._grown(step)
        self.settlement = self.law.settlement(self.history)
        self.passes += step * sum(c.passes_per_year * ld.peak_force.shape[0]
                                  for c, ld in zip(self.conditions, self.loads))

    def result(self, truncated: bool, tolerance: float) -> SettlementResult:
        lx = np.asarray(self.track.node_x, float)[self.pick]
        return SettlementResult(
            years=np.array(self.years), axle_passes=np.array(self.axles),
            settlement=np.array(self.s_rec), void=np.array(self.v_rec), level=np.array(self.l_rec),
            level_x=lx, peak_force=np.array(self.f_rec), wheel_force_max=np.array(self.w_rec),
            sleeper_x=self.zone.supports.x[:self.zone.n_settling].copy(),
            conditions=tuple(c.name for c in self.conditions), n_simulations=self.sims,
            info={"blocks": len(self.years) - 1, "truncated": truncated, "tolerance": tolerance,
                  "law": getattr(self.law, "name", type(self.law).__name__)})
