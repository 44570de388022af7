"""Settlement of a transition over its traffic: dynamic passages and a settlement law, in
blocks of load cycles (docs/settlement.md).

The ballast under each settling sleeper settles by the law from the peak force of every axle
that passes; the settlement lowers the ballast surface (the sleeper's gap), and whether that
opens a void or lowers the rail follows from the unilateral support model. Three things make
the long horizon (10^7 axle passes) cheap and stable:

* **Implicit blocks.** A sleeper that settles more than its neighbours sheds load to them at
  ~30 kN per mm (the track's static flexibility). Loads frozen over a block (explicit) make
  any block longer than a few tenths of a millimetre overshoot into a checkerboard of hanging
  sleepers. Each block here is solved for the settlement at its end with the loads at its end
  (backward Euler, by Newton's method on the sleepers' settlements), the loads following the
  settlement through the track's statics (:mod:`lccopt.degradation.statics`).
* **Loads between simulations.** Load of an axle on a sleeper = its quasi-static load (the
  static wheel loads on the settled track with its voids) + the dynamic part the last
  simulation measured (simulated peak - quasi-static load then). A new simulation is run when
  the profile has changed by an allowance since the last one; the allowance adapts so that
  the error of those loads (measured at each new simulation: predicted vs simulated) stays
  near ``tolerance``. The cycles since the last simulation are then run again with the
  dynamic part blended from the last simulation's to the new one's (predictor-corrector).
* **Blocks in log N.** Settlement laws grow like N^0.2 or ln N: block ends grow geometrically
  (``steps_per_decade`` a decade of cycles), shortened while any load changes by more than
  ``tolerance`` within a block or the profile would pass the allowance.

As ``tolerance`` shrinks, both errors shrink and the result converges
(tests/degradation/test_settlement_iteration.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from .blocks import SleeperLoads, implicit_block
from .laws import SlabSettlement, SleeperLaw, VarandasLaw
from .loading import PassageKind, SettlementZone
from .rail import MEASURES, RailGrid
from .statics import ZoneStatics

# First allowance of profile change before the first re-simulation, from an assumed load error
# of 2 kN per mm of change (measured 1-1.5 kN/mm for a 5 mm dip on the paper's crossing,
# benchmarks/RESULTS-settlement.md); later allowances use the measured error.
_ERROR_PER_METRE = 2.0e6


@dataclass
class SettlementResult:
    """Histories over the blocks (index 0: the new track) of the settling sleepers.

    years, axle_passes (blocks+1,): time and cumulative load cycles (axles of all conditions);
    settlement, void (blocks+1, sleepers) [m]: lowering of the ballast surface and the void
    under the sleeper at rest; level (blocks+1, points) [m]: rail profile at rest (own weight),
    downward positive, at ``level_x`` [m] (the settling zone - 3 m to the ERS's far edge, the
    slab's own settlement included); rail: the measures of
    :mod:`lccopt.degradation.rail` per block (name -> (blocks+1,)), and ``slab`` (blocks+1,)
    [m] the ERS slab's settlement; tamped (blocks+1,) bool: the record of a tamping (the
    track just after it, at the same time as the record before); peak_force (blocks+1,
    conditions, sleepers) [N]:
    largest per-axle ballast force of each condition in the block (simulated where
    ``simulated``, else the quasi-static load plus the last simulation's dynamic part);
    wheel_force_max (blocks+1, conditions) [N]: largest wheel-rail force of the passage, NaN
    where not simulated; simulated (blocks+1,) bool: a simulation ran at the end of the block
    (inside the run on the predictor's profile, which the corrector then moves by a fraction
    of the allowance; the first and the last on the recorded profile); sleeper_x [m];
    n_simulations: single passage simulations run; info.
    """
    years: np.ndarray
    axle_passes: np.ndarray
    settlement: np.ndarray
    void: np.ndarray
    level: np.ndarray
    level_x: np.ndarray
    peak_force: np.ndarray
    wheel_force_max: np.ndarray
    simulated: np.ndarray
    sleeper_x: np.ndarray
    conditions: tuple
    n_simulations: int
    info: dict = field(default_factory=dict)
    rail: dict = field(default_factory=dict)
    tamped: np.ndarray | None = None

    def measure(self, name: str) -> np.ndarray:
        """One engineer's measure over the blocks: ``differential_settlement`` (max - min over
        the ballast sleepers of the zone), ``max_settlement``, ``max_void`` [m], and those of
        the rail (:data:`lccopt.degradation.rail.MEASURES`): ``rail_step`` [m],
        ``rail_angle`` [-], ``level_d1_std``, ``level_d1_max``, ``level_std`` [m]."""
        if name in self.rail:
            return np.asarray(self.rail[name])
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
        the horizon's passes if it never does."""
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
        """The engineer's objectives [m, -, axle passes]: the track's state at the horizon;
        for a track kept by tamping (``info['tamping']``), its worst state over the horizon.

        A tamped track's state cycles: it worsens to the limit, is tamped, and worsens again.
        Its state at the horizon is one moment of that cycle (just tamped, or about to be),
        which would rank designs by when their last tamping fell; the worst state it reaches
        is what the track's limits are applied to whenever it is measured (EN 13848-5's
        limits hold for the geometry at any time), and does not depend on the moment."""
        sims = np.flatnonzero(self.simulated)
        if self.info.get("tamping"):
            def state(v):
                return float(np.max(v))

            growth = np.max(self.wheel_force_max[sims], axis=0) / self.wheel_force_max[sims[0]]
        else:
            def state(v):
                return float(v[-1])

            growth = self.wheel_force_max[sims[-1]] / self.wheel_force_max[sims[0]]
        return {
            **{k: state(v) for k, v in self.rail.items() if k != "slab"},
            **{k: state(self.measure(k)) for k in ("differential_settlement", "max_settlement",
                                                   "max_void", "level_std")},
            "force_growth": float(np.max(growth)),
            "interventions": float(0 if self.tamped is None else np.sum(self.tamped)),
            "passes_to_limit": (float(self.axle_passes[np.argmax(self.tamped)])
                                if self.tamped is not None and self.tamped.any()
                                else self.passes_to(limit_measure, limit)),
        }


@dataclass(frozen=True)
class Tamping:
    """Tamping over the life: when ``measure`` (a :meth:`SettlementResult.measure`) reaches
    ``value`` and at least ``min_interval`` years have passed since the last tamping, the
    ``reachable`` settling sleepers (bool per sleeper, nearest the interface first) are lifted
    to the slab's level and their ballast starts anew (:meth:`SleeperLaw.tamp`); the others
    stay as they are. The followers (the open track beyond) are tamped with the farthest
    settling sleeper. A tamping that leaves the measure at the limit ends the tamping (the
    machine cannot cure it; ``info['tamping_ineffective']``)."""
    measure: str
    value: float
    reachable: np.ndarray
    min_interval: float = 0.1


def predict_settlement(track, zone: SettlementZone, conditions: Sequence[PassageKind], *,
                       horizon_years: float, law=None, tolerance: float = 2.0e3,
                       steps_per_decade: float = 8.0, max_simulations: int = 30,
                       rail_seats: float = 1.0, reading: str = "axle",
                       slab: SlabSettlement | None = None,
                       tamping: Tamping | None = None) -> SettlementResult:
    """Settlement of ``zone`` of ``track`` under ``conditions`` up to ``horizon_years``.

    law: a :class:`~lccopt.degradation.laws.SleeperLaw`, or a ballast law of
    :mod:`lccopt.degradation.laws` alone (default :class:`VarandasLaw`, fed the force of
    standard sleepers), fed with ``rail_seats`` times the modelled support force (1: the force
    under one rail seat, as the law's defaults are applied in ROSE; docs/settlement.md).
    reading: ``axle`` (each axle's own peak is a load cycle) or ``passage`` (every axle of a
    passage counts with the passage's largest peak). tolerance [N]: the
    error allowed in the loads the law is fed (between simulations, and by a load's change
    within one block). steps_per_decade: blocks per decade of load cycles at most.
    max_simulations: the most simulations per condition, the first and the last included; the
    profile allowance grows so that those left spread over the profile change still to come
    (``info['budget_bound']`` says it did), and past them the loads come from the last one.
    slab: the ERS slab's own settlement (None: it does not settle). The gaps the track model
    sees are the settlement less the slab's (the slab the model's fixed reference); the
    level, the settlement and the measures are absolute.
    tamping: :class:`Tamping` over the life, or None (never tamped). After a tamping the
    blocks start short again (the tamped ballast settles fast at first) and every condition
    is simulated on the tamped track."""
    law = law or VarandasLaw()
    if not isinstance(law, SleeperLaw):
        law = SleeperLaw.plain(law, zone.n_settling)
    if reading not in ("axle", "passage"):
        raise ValueError(f"reading: axle or passage, not {reading!r}")
    if not (horizon_years > 0 and tolerance > 0 and steps_per_decade > 0 and rail_seats > 0
            and max_simulations >= 2):
        raise ValueError("horizon_years, tolerance, steps_per_decade, rail_seats must be > 0, "
                         "max_simulations >= 2")
    conditions = tuple(conditions)
    rates = [c.passes_per_year for c in conditions]
    if not conditions or min(rates) < 0 or sum(rates) <= 0:
        raise ValueError("conditions: at least one, passes_per_year >= 0, some > 0")
    grid = RailGrid.of(track, zone.supports.x[:zone.n_settling])
    if tamping is not None and np.shape(tamping.reachable) != (zone.n_settling,):
        raise ValueError("tamping.reachable: one value per settling sleeper")
    run = _Run(track, zone, conditions, law, rail_seats, grid, reading, slab, tamping)
    return run.to_horizon(horizon_years, tolerance, 10.0 ** (1.0 / steps_per_decade),
                          max_simulations)



class _Run:
    """The track's state through the blocks and what is recorded of it."""

    def __init__(self, track, zone, conditions, law, rail_seats, grid: RailGrid,
                 reading="axle", slab: SlabSettlement | None = None,
                 tamping: Tamping | None = None):
        self.zone, self.conditions, self.law = zone, conditions, law
        self.tamping = tamping
        self.seg_start = 0.0               # years of the last tamping (0: the new track)
        self.ineffective = None            # years of a tamping that did not cure the limit
        self.post_tamp = None              # dynamic parts simulated just after a tamping
        self.rail_seats = rail_seats
        self.grid, self.slab = grid, slab
        self.statics = ZoneStatics(track, zone.supports, level_x=grid.x)
        self.loads = SleeperLoads(self.statics, zone, conditions, rail_seats, reading)
        self.level_x = grid.x[grid.shown]
        # axle passes a year of each condition (the slab's load cycles)
        self.axle_rates = np.array([c.passes_per_year * len(c.axles.offsets)
                                    for c in conditions])
        self.per_year = np.repeat([c.passes_per_year for c in conditions], self.loads.rows)
        self.state = law.start(zone.n_settling)
        self.settlement = law.settlement(self.state)
        self.years, self.passes, self.sims = 0.0, 0.0, 0
        self.rec = {k: [] for k in ("years", "passes", "s", "void", "level", "force", "wheel",
                                    "simulated", "rail", "slab", "tamped")}
        self.errors, self.blocks_tried, self._contact = [], 0, None

    def simulate(self):
        """Simulate every condition on the current track: (dynamic parts, the largest error
        [N] of the present ones), and the record of the simulated loads for the last block."""
        sup = self.zone.supports.with_gaps(self.loads.gaps(self.settlement))
        loadings = [c.simulate(sup) for c in self.conditions]
        self.sims += len(self.conditions)
        parts, error = self.loads.measured(self.settlement, loadings)
        n = self.zone.n_settling
        mark = ([ld.peak_force[:, :n].max(axis=0) for ld in loadings],
                [ld.wheel_force_max for ld in loadings])
        return parts, error, mark

    def slab_at(self, years: float) -> float:
        """The slab's settlement [m] after ``years`` of the traffic."""
        return 0.0 if self.slab is None else self.slab.at(self.axle_rates * years)

    def mark(self, mark) -> None:
        self.rec["force"][-1], self.rec["wheel"][-1] = mark
        self.rec["simulated"][-1] = True

    def state_at(self, settlement, years):
        """(void (sleepers,), level at the grid, measures) of the track at rest with the
        settling sleepers' ``settlement`` after ``years``."""
        self.loads.shift = self.slab_at(years)
        void, level, self._contact = self.statics.rest(self.loads.gaps(settlement),
                                                       self._contact)
        level = level + self.loads.shift
        n = self.zone.n_settling
        m = self.grid.measures(level)
        m.update(differential_settlement=float(np.ptp(settlement)),
                 max_settlement=float(np.max(settlement)), max_void=float(np.max(void[:n])))
        return void[:n], level, m

    def record(self, rows) -> None:
        """Record the present state; ``rows`` the loads of the block that led to it (None:
        those of the record before, for a tamping's row)."""
        void, level, m = self.state_at(self.settlement, self.years)
        r = self.rec
        if rows is None:
            force = [f.copy() for f in r["force"][-1]]
        else:
            per = np.split(rows / self.rail_seats, np.cumsum(self.loads.rows)[:-1])
            force = [p.max(axis=0) for p in per]
        r["years"].append(self.years)
        r["passes"].append(self.passes)
        r["s"].append(self.settlement.copy())
        r["void"].append(void)
        r["level"].append(level[self.grid.shown])
        r["rail"].append({k: m[k] for k in MEASURES})
        r["slab"].append(self.loads.shift)
        r["force"].append(force)
        r["wheel"].append([np.nan] * len(self.conditions))
        r["simulated"].append(False)
        r["tamped"].append(False)
        self._now = m

    # --- tamping
    def _allowed(self, years) -> bool:
        """Whether a tamping may be done at ``years``."""
        t = self.tamping
        return (t is not None and self.ineffective is None
                and years >= self.seg_start + t.min_interval - 1e-12)

    def _due(self) -> bool:
        t = self.tamping
        return self._allowed(self.years) and self._now[t.measure] >= t.value * (1.0 - 1e-9)

    def _tamp(self) -> None:
        """Tamp the reachable sleepers up to the slab's level; record the tamped track."""
        n = self.zone.n_settling
        self.state = self.law.tamp(self.state, self.tamping.reachable,
                                   np.full(n, self.slab_at(self.years)))
        self.settlement = self.law.settlement(self.state)
        self.seg_start = self.years
        self.record(None)
        self.rec["tamped"][-1] = True
        if self._now[self.tamping.measure] >= self.tamping.value:
            self.ineffective = self.years

    def to_horizon(self, horizon, tolerance, ratio, max_simulations) -> SettlementResult:
        self.record(np.zeros((int(self.loads.rows.sum()), self.zone.n_settling)))
        parts, _, mark = self.simulate()
        self.loads.dynamic = parts
        self.mark(mark)
        allowance = tolerance / _ERROR_PER_METRE
        one_pass = 1.0 / float(sum(c.passes_per_year for c in self.conditions))
        dt, bounded = one_pass, False
        seg_settlement = self.settlement.copy()
        while self.years < horizon * (1.0 - 1e-12):
            if self.sims // len(self.conditions) + 2 > max_simulations:
                self._epoch(horizon, dt, one_pass, ratio, tolerance, None, inline=True)
                bounded = True
                break
            start = self._snapshot()
            dt_next = self._epoch(horizon, dt, one_pass, ratio, tolerance,
                                  (start[1], allowance), stop=True)
            change = float(np.max(np.abs(self.settlement - start[1])))
            parts, error, mark = self.simulate()
            self.errors.append(error)
            # corrector: the same cycles again, the dynamic parts blended from the epoch's
            # start to those just measured at its end (trapezoidal in the loads)
            target = self.years
            self.loads.blend = (start[1], self.settlement.copy(), parts)
            self._restore(start)
            self._epoch(target, dt, one_pass, ratio, tolerance, None)
            self.loads.blend = None
            self.loads.dynamic = parts
            self.mark(mark)
            dt = dt_next
            allowance = change * float(np.clip(tolerance / max(error, 1e-3), 0.5, 3.0))
            if self._due():
                # the tamped track is a new one: short blocks, a new simulation, the first
                # allowance again
                self._tamp()
                parts, _, mark = self.simulate()
                self.loads.dynamic = self.post_tamp = parts
                self.mark(mark)
                dt, allowance = one_pass, tolerance / _ERROR_PER_METRE
                seg_settlement = self.settlement.copy()
                continue
            # the budget: the simulations left (one kept for the end) spread over the profile
            # change still to come, extrapolated in log time (since the last tamping) from
            # this epoch's rate
            left = max_simulations - self.sims // len(self.conditions) - 1
            seg = self.seg_start
            rate = max(change / np.log((target - seg + one_pass) / (start[2] - seg + one_pass)),
                       float(np.max(np.abs(self.settlement - seg_settlement)))
                       / np.log((target - seg + one_pass) / one_pass))
            coming = rate * np.log((horizon - seg + one_pass) / (target - seg + one_pass))
            need = coming / max(left, 1e-9)
            if need > allowance:
                allowance, bounded = need, True
        parts, error, mark = self.simulate()
        self.errors.append(error)
        self.mark(mark)
        return self._result(bounded, tolerance)

    def _epoch(self, until, dt, one_pass, ratio, tolerance, profile, stop=False,
               inline=False) -> float:
        """Blocks up to ``until`` years, or (profile = (settlement at the last simulation,
        allowance)) until the profile has changed by 3/4 of the allowance, or (``stop``) until
        a tamping is due; ``inline``: tamp when due and go on (no simulation). Returns the
        next block length."""
        watch = self.tamping is not None and (stop or inline)
        while self.years < until * (1.0 - 1e-12):
            dt = min(dt, until - self.years)
            if watch and self.ineffective is None:
                # no block across the first moment a tamping may be done
                ok = self.seg_start + self.tamping.min_interval
                if self.years < ok - 1e-12:
                    dt = min(dt, ok - self.years)
            s, rows, dt = self._block(dt, one_pass, tolerance, profile, watch)
            cycles = self.per_year * dt
            self.state = self.law.add(self.state, rows, cycles)
            self.settlement = s
            self.years += dt
            self.passes += float(cycles.sum())
            self.record(rows)
            dt = max(one_pass, min((self.years - self.seg_start) * (ratio - 1.0), 2.0 * dt))
            if watch and self._due():
                if stop:
                    break
                self._tamp()
                if self.post_tamp is not None:
                    # no simulation left: the freshly tamped track loads as the last freshly
                    # tamped one that was simulated, not as the worn track before it
                    self.loads.dynamic = self.post_tamp
                dt = one_pass
            if profile is not None and np.max(np.abs(s - profile[0])) >= 0.75 * profile[1]:
                break
        return dt

    def _snapshot(self):
        return (self.state, self.settlement.copy(), self.years, self.passes,
                len(self.rec["years"]), self._now)

    def _restore(self, snap) -> None:
        self.state, s, self.years, self.passes, length, self._now = snap
        self.settlement = s.copy()
        for v in self.rec.values():
            del v[length:]

    def _block(self, dt, one_pass, tolerance, profile, watch=False):
        """Solve one block of ``dt`` years, shortened while a load changes by more than
        ``tolerance`` in it, the profile passes its allowance or (``watch``) the tamping's
        measure passes its limit by more than 2 %; (s, rows, dt)."""
        self.loads.shift = self.slab_at(self.years)
        before, _ = self.loads(self.settlement, jacobian=False)
        while True:
            self.blocks_tried += 1
            cycles = self.per_year * dt
            self.loads.shift = self.slab_at(self.years + dt)
            solved = implicit_block(self.law, self.state, self.settlement, self.loads, cycles)
            if solved is None:
                if dt <= one_pass * (1.0 + 1e-9):
                    raise RuntimeError("a settlement block of one pass did not converge")
                dt = max(one_pass, 0.5 * dt)
                continue
            s, rows = solved
            load_change = float(np.max(np.abs(rows - before))) / self.rail_seats
            shrink = load_change / tolerance
            if profile is not None:
                at_sim, allowance = profile
                shrink = max(shrink, float(np.max(np.abs(s - at_sim))) / allowance)
            if shrink <= 1.0 and watch and self._allowed(self.years + dt) \
                    and dt > one_pass * (1.0 + 1e-9):
                t = self.tamping
                m0 = self._now[t.measure]
                m1 = self.state_at(s, self.years + dt)[2][t.measure]
                if m0 < t.value and m1 > 1.02 * t.value:
                    dt = max(one_pass, dt * max(0.1, 0.95 * (t.value - m0) / (m1 - m0)))
                    continue
            if shrink <= 1.0 or dt <= one_pass * (1.0 + 1e-9):
                return s, rows, dt
            dt = max(one_pass, dt * max(0.1, 0.8 / shrink))

    def _result(self, bounded, tolerance) -> SettlementResult:
        r = self.rec
        return SettlementResult(
            years=np.array(r["years"]), axle_passes=np.array(r["passes"]),
            settlement=np.array(r["s"]), void=np.array(r["void"]), level=np.array(r["level"]),
            level_x=self.level_x, peak_force=np.array(r["force"]),
            rail={**{k: np.array([m[k] for m in r["rail"]]) for k in r["rail"][0]},
                  "slab": np.array(r["slab"])},
            wheel_force_max=np.array(r["wheel"], dtype=float),
            simulated=np.array(r["simulated"]), tamped=np.array(r["tamped"], dtype=bool),
            sleeper_x=self.zone.supports.x[:self.zone.n_settling].copy(),
            conditions=tuple(c.name for c in self.conditions), n_simulations=self.sims,
            info={"blocks": len(r["years"]) - 1, "blocks_tried": self.blocks_tried,
                  "tamping": self.tamping is not None,
                  "budget_bound": bounded, "tolerance": tolerance,
                  "tamping_ineffective": self.ineffective,
                  "load_errors": list(self.errors),
                  "law": getattr(self.law, "name", type(self.law).__name__)})
