"""Mixed-integer surrogate optimisation as an ask/tell state machine (paper Steps A, C-G).

Metric Stochastic Response Surface (Regis & Shoemaker) with DYCORS perturbations:

* Step A: the given points, then an integer-aware Latin hypercube (``sampling``).
* Step C: a surrogate of the told results (``surrogates``): one cubic RBF of the values, or
  with a composite surrogate one per told output, scored by the aggregate of their
  predictions (``set_aggregate``).
* Steps D-E: candidates (``candidates``: DYCORS perturbations of the phase's best point and
  the points of a local search of the surrogate, ``local_search``; the bound probes of a
  phase that goes on from a point), scored by the merit of Eq. (11) with the weight cycling
  through ``settings.WEIGHTS``; the best-scoring candidate is proposed. A candidate equal to
  a point already evaluated, failed or pending (same integers, continuous part within the
  duplicate radius) is never proposed; when every candidate near the best point is taken
  the steps widen and uniform points (an all-integer grid's unused points) fill in.
* Step F: the step size sigma adapted by success/failure counters; a restart when it
  collapses or evaluations keep failing (``restarts``: a fresh design, on from the run's best
  point, bound probes and a subspace phase).
* Step G: stop at a budget of told evaluations (failures included).

The object holds no references to files, processes or clocks: every decision depends only
on its state, which ``state_dict`` writes out completely (random generator included) as
plain JSON types (``state``), so a restored strategy proposes exactly what the original
would have. ``ask(k)`` fits the surrogate once for its k proposals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .candidates import Dycors
from .restarts import NextPhase, Phase, RestartPolicy
from .sampling import latin_hypercube
from .selection import CandidateSelection
from .settings import (
    IMPROVEMENT_TOL,
    SIGMA_INIT,
    SIGMA_MAX,
    SUCCESS_TOL,
    Settings,
    fail_tol,
)
from .space import DesignSpace
from .state import from_state, load, save, state_dict
from .surrogates import CompositeFit, ScalarSurrogate

PHASES = ("initial", "adaptive", "random", "local")


@dataclass
class Proposal:
    """A point to evaluate: its id (tell it by this), x, the phase kind that proposed it
    (one of PHASES) and the restart index."""

    id: int
    x: np.ndarray
    phase: str
    restart: int


class Strategy(CandidateSelection):
    """MSRS/DYCORS mixed-integer ask/tell optimiser; see the module docstring.

    Parameters
    ----------
    space : DesignSpace
        The variables; its given points are proposed first.
    budget : int
        Told evaluations (failures included) after which the strategy is ``done``.
    n_initial : int
        Points of the initial design (given points included) and of each fresh restart.
    seed : int or None
        Seed of the random generator (the whole run is a function of it and the results).
    settings : Settings or dict, optional
        The settings (``Settings.default(composite)`` if not given).
    candidates : callable, optional
        A candidate generator (``candidates.CandidateRequest`` -> list of (points, phase));
        default ``candidates.Dycors(settings)``. Not part of the state: pass the same one to
        ``from_state``.
    restarts : object, optional
        A restart policy (``restarts.RestartPolicy`` is the default and the interface).
    **changes
        Fields of ``Settings`` to change (``composite=True`` picks the composite defaults).
    """

    def __init__(self, space: DesignSpace, budget: int = 200, n_initial: int = 20,
                 seed: int | None = 0, *, settings: Settings | dict | None = None,
                 candidates=None, restarts=None, **changes):
        if not isinstance(space, DesignSpace):
            raise TypeError("space must be a DesignSpace")
        if int(budget) < 1:
            raise ValueError("budget must be >= 1")
        if int(n_initial) < 1:
            raise ValueError("n_initial must be >= 1")
        if settings is None:
            settings = Settings.default(bool(changes.get("composite", False)))
        elif isinstance(settings, dict):
            settings = Settings.from_dict(settings)
        self._setup(space, int(budget), int(n_initial), seed, settings.replace(**changes),
                    candidates, restarts)
        space = self.space
        self.rng = np.random.default_rng(seed)
        self.records: list[dict] = []
        self.exhausted = False
        self._ahead: list[dict] = []     # records of the last block not handed out yet
        self._ahead_exhausted = False    # the space was exhausted when it was computed
        given = space.given_array
        lhs = latin_hypercube(space, max(0, self.n_initial - len(given)), self.rng, exclude=given)
        self._begin_phase(NextPhase(list(given) + list(lhs)), index=0)

    def _setup(self, space, budget, n_initial, seed, settings: Settings, candidates,
               restarts) -> None:
        self.space = space if settings.switches else space.without_switches()
        self.budget = budget
        self.n_initial = n_initial
        self.seed = None if seed is None else int(seed)
        self.settings = settings
        self.candidates = Dycors(settings) if candidates is None else candidates
        self.restarts = RestartPolicy() if restarts is None else restarts
        self._scalar = ScalarSurrogate()    # caches only (distance matrices), never state
        self._composite = CompositeFit()
        self._aggregate = None  # composite: outputs (n, k) -> values (n,); not state
        self._free = space.ub - space.lb > 0
        self.batch = 1  # points per block (set_batch); not state

    def _begin_phase(self, plan: NextPhase, index: int) -> None:
        """Start a phase: its design queued, the step size and counters reset; a phase that
        goes on from a record starts with that record's value as its best."""
        self.phase = Phase(index, len(self.records), len(plan.design), plan.anchor,
                           plan.frozen, plan.end, plan.trial)
        self._queue = [np.asarray(x, dtype=float) for x in plan.design]
        self.sigma = SIGMA_INIT
        self._n_fail = self._n_succ = 0
        self.failed_row = 0
        self._n_adaptive = 0
        self._w_index = 0
        self._fbest_phase: float | None = (
            None if plan.anchor is None else float(self.records[plan.anchor]["value"]))

    def set_aggregate(self, aggregate) -> None:
        """The function that maps output vectors F (n, k) to the scalar values (n,), or None.

        An aggregate with a true attribute ``increasing`` says it never decreases when an
        output grows (a scalarising function of objectives to minimise): its outputs are then
        median-capped before fitting; without it they are fitted as told. Not part of the
        state: whoever restores a strategy sets it again (it must be the same deterministic
        function for a resumed run to propose the same points).

        Parameters
        ----------
        aggregate : callable or None
            ``aggregate(F (n, k)) -> (n,)``; used only with ``settings.composite``.
        """
        if aggregate is not None and not callable(aggregate):
            raise TypeError("aggregate must be callable or None")
        self._aggregate = aggregate

    @property
    def aggregate(self):
        """The aggregate given to ``set_aggregate`` (None: none)."""
        return self._aggregate

    # -- public read-only view ------------------------------------------------------
    @property
    def n_asked(self) -> int:
        """Proposals made."""
        return len(self.records)

    @property
    def n_told(self) -> int:
        """Proposals told (evaluated or failed)."""
        return sum(r["status"] != "pending" for r in self.records)

    @property
    def pending(self) -> list[int]:
        """Ids of the proposals not told yet, in id order."""
        return [r["id"] for r in self.records if r["status"] == "pending"]

    @property
    def done(self) -> bool:
        """Budget of told evaluations used up (or the space exhausted with nothing pending)."""
        return self.n_told >= self.budget or (self.exhausted and not self.pending)

    @property
    def restart(self) -> int:
        """The current phase's index (0 before the first restart)."""
        return self.phase.index

    @property
    def best(self):
        """(x, value) of the best told result (lowest value, then lowest id), or None."""
        ok = [r for r in self.records if r["status"] == "ok"]
        if not ok:
            return None
        r = min(ok, key=lambda r: (r["value"], r["id"]))
        return r["x"].copy(), r["value"]

    @property
    def history(self) -> list[dict]:
        """Copies of the records: id, x, phase, restart, status, value, reason, outputs."""
        return [{**r, "x": r["x"].copy()} for r in self.records]

    def success_bar(self, f_best: float) -> float:
        """The value a point must beat to improve on f_best (the step rule's success)."""
        return f_best - IMPROVEMENT_TOL * abs(f_best)

    # -- ask ------------------------------------------------------------------------------
    def ask(self, k: int = 1) -> list[Proposal]:
        """Up to k new points; fewer only at the budget or when the space is exhausted.

        Points are computed in blocks of at least ``batch`` (``set_batch``): a block fits
        the surrogate once and picks its points one after the other from one scored set of
        candidates, each pick joining the distance criterion before the next (``_block``).
        What a block computed beyond k is handed out by the next asks (it is state, so a
        replay of the same calls gives the same points).

        Parameters
        ----------
        k : int
            Points wanted.

        Returns
        -------
        list of Proposal
        """
        out: list[Proposal] = []
        while len(out) < int(k) and self.n_asked < self.budget and not self.exhausted:
            if not self._ahead:
                want = min(max(int(k) - len(out), self.batch), self.budget - self.n_asked)
                n0 = self.n_asked
                self._block(want)
                self._ahead = self.records[n0:]  # handed out below, in order
                del self.records[n0:]
                if not self._ahead:
                    break
            rec = self._ahead.pop(0)
            self.records.append(rec)
            if not self._ahead and self._ahead_exhausted:
                self.exhausted, self._ahead_exhausted = True, False
            out.append(Proposal(rec["id"], rec["x"].copy(), rec["phase"], rec["restart"]))
        return out

    def set_batch(self, batch: int) -> None:
        """Points computed per block from now on (1: one point per surrogate fit). A run
        engine sets it from its worker count; it is not state: whoever restores a strategy
        sets it again (as ``set_aggregate``), and a block already computed is handed out
        first whatever the new size."""
        if int(batch) < 1:
            raise ValueError("batch must be >= 1")
        self.batch = int(batch)

    @property
    def n_ahead(self) -> int:
        """Points of the last block not handed out yet."""
        return len(self._ahead)

    def _block(self, m: int) -> None:
        """Compute up to m proposals as records (fewer when the space is exhausted)."""
        ctx = pool = None
        made = 0
        while made < m:
            if not self._queue and self.restarts.phase_over(self):
                self._begin_phase(self.restarts.next_phase(self), self.phase.index + 1)
                ctx = pool = None
            if self._queue:
                x, kind = self._queue.pop(0), "initial"
                if ctx is not None:
                    ctx.add(x)
                    if pool is not None:
                        pool.add(x)
            else:
                if ctx is None:
                    ctx = self._prepare()
                if m == 1:  # one point: the full selection (candidates drawn for it alone)
                    pick = self._select(ctx)
                else:
                    if pool is None:
                        pool = self._pool(ctx)
                    pick = self._pick(ctx, pool) or self._select(ctx)
                if pick is None:
                    if made:
                        self._ahead_exhausted = True
                    else:
                        self.exhausted = True
                    break
                x, kind = pick
                ctx.add(x)
                if pool is not None:
                    pool.add(x)
            self.records.append({"id": self.n_asked, "x": np.asarray(x, dtype=float).copy(),
                                 "phase": kind, "restart": self.phase.index,
                                 "status": "pending", "value": None, "reason": None,
                                 "outputs": None})
            made += 1

    def _movable(self) -> np.ndarray:
        """Variables the steps and the local search may change (not a held one)."""
        if self.phase.frozen is None:
            return self._free
        m = self._free.copy()
        m[self.phase.frozen] = False
        return m


    # -- tell -----------------------------------------------------------------------------------
    def _find(self, x_or_id) -> dict:
        if isinstance(x_or_id, (int, np.integer)):
            i = int(x_or_id)
            if not 0 <= i < len(self.records):
                raise KeyError(f"no proposal with id {i}")
            rec = self.records[i]
        elif isinstance(x_or_id, Proposal):
            rec = self.records[x_or_id.id]
        else:
            x = np.asarray(x_or_id, dtype=float)
            hits = [r for r in self.records if np.array_equal(r["x"], x)]
            if not hits:
                raise KeyError(f"point {x.tolist()} was never proposed")
            pend = [r for r in hits if r["status"] == "pending"]
            rec = pend[0] if pend else hits[0]
        if rec["status"] != "pending":
            raise ValueError(f"proposal {rec['id']} was already told ({rec['status']})")
        return rec

    def tell(self, x_or_id, value: float, outputs=None) -> None:
        """The result of a proposal. A non-finite value counts as failed.

        Parameters
        ----------
        x_or_id : int, Proposal or array
            The proposal (by id, Proposal or its x).
        value : float
            The minimised value.
        outputs : array, optional
            The vector the value aggregates (fitted by a composite surrogate).
        """
        rec = self._find(x_or_id)
        value = float(value)
        if not math.isfinite(value):
            self._fail(rec, f"non-finite value {value!r}")
            return
        rec["status"], rec["value"] = "ok", value
        rec["outputs"] = None if outputs is None else [float(v) for v in np.ravel(outputs)]
        if rec["restart"] != self.phase.index:
            return  # a straggler from before the restart: recorded, not counted
        self.failed_row = 0
        fb = self._fbest_phase
        if rec["phase"] != "initial" and fb is not None:
            self._count(value < self.success_bar(fb))
        if fb is None or value < fb:
            self._fbest_phase = value

    def tell_failed(self, x_or_id, reason: str = "") -> None:
        """A failed evaluation: uses budget, never proposed again, not fitted."""
        self._fail(self._find(x_or_id), str(reason))

    def _fail(self, rec: dict, reason: str) -> None:
        rec["status"], rec["reason"] = "failed", reason
        if rec["restart"] != self.phase.index:
            return
        self.failed_row += 1
        if rec["phase"] != "initial":
            self._count(False)

    def _count(self, success: bool) -> None:
        """The step rule: sigma halves after fail_tol(d) failures in a row, doubles (up to
        SIGMA_MAX) after SUCCESS_TOL successes in a row."""
        if success:
            self._n_succ, self._n_fail = self._n_succ + 1, 0
        else:
            self._n_fail, self._n_succ = self._n_fail + 1, 0
        if self._n_fail >= fail_tol(self.space.dim):
            self.sigma, self._n_fail = self.sigma / 2.0, 0
        if self._n_succ >= SUCCESS_TOL:
            self.sigma, self._n_succ = min(2.0 * self.sigma, SIGMA_MAX), 0

    # -- state ----------------------------------------------------------------------------------
    def state_dict(self) -> dict:
        """The whole state as plain JSON types (floats round-trip exactly through json)."""
        return state_dict(self)

    @classmethod
    def from_state(cls, d: dict, candidates=None, restarts=None) -> "Strategy":
        """The strategy a ``state_dict`` describes (with the candidate generator and restart
        policy it ran with, if not the defaults); ValueError if it is not such a state."""
        return from_state(cls, d, candidates, restarts)

    def save(self, path) -> None:
        """Atomic write of the state: temporary file in the same directory, fsync, rename."""
        save(self, path)

    @classmethod
    def load(cls, path) -> "Strategy":
        """The strategy saved at ``path``."""
        return load(cls, path)
