"""Mixed-integer surrogate optimisation as an ask/tell state machine (paper Steps A, C-G).

Metric Stochastic Response Surface (Regis & Shoemaker) with DYCORS perturbations:

* Step A: the given points, then an integer-aware Latin hypercube (``sampling``).
* Step C: a cubic RBF (``rbf``) on the evaluated points (of the whole run, or of the current
  restart only: ``restart_keeps_points``), in the unit box, with a linear tail or a quadratic
  one (``tail``), fitted to the values or to median-capped ones (values above the median
  replaced by the median, as in Regis & Shoemaker; pySOT 0.3.3 does not cap), as
  leave-one-out cross-validation decides (``_scalar``).
* Steps D-E: candidates (DYCORS perturbations of the best point and, at the weights of
  ``local_weights``, a local mixed-integer search of the surrogate; uniform points only if
  ``n_uniform`` > 0, or when everything near the best point is taken), scored by the merit of
  Eq. (11) with the weight cycling through 0.3, 0.5, 0.8, 0.95; the best-scoring candidate is
  proposed.
  A candidate equal to a point already evaluated, failed or pending (same integers,
  continuous part within a tolerance) is never proposed.
* Step F: step size sigma adapted by success/failure counters; restart with a fresh
  design when sigma collapses or evaluations keep failing (late in a run, with a scalar
  surrogate, from the run's best point instead: ``restart_from``). Such a restart also
  tries the best point with one integer on a bound (``bound_probes``) and, if none improves,
  searches the subspace of the best such probe with that integer held on its bound for as
  long as it proves itself (generation 11: "subspace" with ``subspace_trial``). A composite
  surrogate's runs, which always restart fresh, take that step after the first fresh phase
  that found nothing better than the run's best (generation 12: ``subspace_start``).
* Step G: stop at a budget of told evaluations (failures included).

Composite surrogate (setting ``composite``): when the minimised value is an aggregate of
several outputs (e.g. a scalarising function of objectives), ``tell`` may also be given the
output vector, and ``set_aggregate`` the function ``aggregate(F (n, k)) -> (n,)``. Then one
cubic RBF is fitted per output (median-capped per output if ``composite_capping``; "auto":
only when the aggregate says it is increasing in every output, see ``set_aggregate``) and the
candidates and the local search are scored by ``aggregate(predicted outputs)`` instead of an
RBF of the (possibly kinked) scalar value. Success/failure counting and the best point stay on
the told scalar value. The told outputs are part of the state; the aggregate function is not
(the caller rebuilds it). Without an aggregate or outputs the scalar surrogate is used.

The object holds no references to files, processes or clocks: every decision depends only
on its state, which ``state_dict`` writes out completely (random generator included) as
plain JSON types, so a restored strategy proposes exactly what the original would have.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.optimize
import scipy.special
from scipy.spatial.distance import cdist

from .rbf import CubicRBF, distances
from .sampling import latin_hypercube, to_space
from .space import DesignSpace

STATE_FORMAT = "lccopt.optim.strategy"
STATE_VERSION = 1
PHASES = ("initial", "adaptive", "random", "local")

# Largest all-integer grid that is listed point by point once random candidates stop
# finding unused points (so that a nearly exhausted grid is still searched to the end).
_ENUMERATE_LIMIT = 200_000

# Least unit-box distance between the starts of the local search's global branches.
_START_SEPARATION = 0.25


@dataclass
class Proposal:
    id: int
    x: np.ndarray
    phase: str
    restart: int


# The optimiser's generations: each changed the default proposals, and a run keeps the
# generation it started with (the engine journals it), so that it resumes as it began.
#   1: lccopt before issue 9: uniform candidates beside the DYCORS ones
#   2: issue 9's DYCORS-only candidates (reflected steps, probability schedule per restart,
#      median capping, the local search at every weight of the cycle)
#   3: pySOT-like DYCORS steps (see _default_settings), measured in benchmarks/RESULTS-optimiser.md
#   4: with a composite surrogate generation 2's candidates again (_AUTO_SETTINGS)
#   5: without a composite surrogate, a restart's surrogate fits every point of the run
#   6: a composite surrogate median-caps its outputs only when the aggregate is increasing in
#      each of them (the ASF: yes, unchanged; E_max's max - min of sleeper energies: no)
#   7: a scalar surrogate's tail is quadratic when cross-validation says so (tail "auto")
#   8: with a scalar surrogate, a restart that cannot last as long as the run's phases did goes
#      on from the run's best point (restart_from "endgame")
#   9: a duplicate radius a tenth of before (dist_tol 1e-4): a sharp minimum can be refined
#      past three digits of the unit box
#  10: a restart that goes on from the run's best point also tries that point with one
#      integer on a bound (bound_probes "anchor")
#  11: such a restart asks its probes first; behind a failed one, a phase in the probe's
#      subspace that must beat the run's best within max_failed_row proposals (bound_probes
#      "subspace", subspace_trial "auto")
#  12: with a composite surrogate (fresh restarts), the same probes and subspace phase after
#      the first phase that found nothing better than the run's best (subspace_start "auto")
GENERATION = 12


def generation_settings(space: DesignSpace, generation: int) -> dict:
    """Settings that make Strategy propose as the optimiser of ``generation`` did (on top of
    the defaults of GENERATION): what each later generation changed, undone newest first."""
    if not (isinstance(generation, int) and 1 <= generation <= GENERATION):
        raise ValueError(f"unknown optimiser generation {generation!r} (known: 1 to {GENERATION})")
    out: dict = {}
    for g in range(GENERATION, generation, -1):
        out.update(_BEFORE_GENERATION[g])
    if generation == 1:
        out["n_uniform"] = min(1000, 10 * space.dim)
    return out


# What the settings added or changed by generation 3 were before it (also what a saved state
# of an earlier lccopt, which lacks the new keys, is read with).
_BEFORE_GENERATION_3 = {"perturbation": "reflect", "probability_schedule": "restart",
                        "capping": True, "n_branches": 3, "local_weights": None}
_ADDED_IN_GENERATION_3 = ("perturbation", "probability_schedule", "local_weights")
# The same for generation 5 (the key exists since before generation 3, always False then).
_BEFORE_GENERATION_5 = {"restart_keeps_points": False}
# Each generation's settings before it (generation 2's, uniform candidates, depend on the space:
# generation_settings). Generation 4 made the candidate settings "auto"; before, generation 3's
# held with either surrogate. Generation 6's key is in every saved state (it dates from 1).
_BEFORE_GENERATION = {
    2: {},
    3: _BEFORE_GENERATION_3,
    4: {"perturbation": "truncnorm", "probability_schedule": "run", "local_weights": [0.95]},
    5: _BEFORE_GENERATION_5,
    6: {"composite_capping": True},
    7: {"tail": "linear"},
    8: {"restart_from": "fresh"},
    9: {"dist_tol": 1e-3},
    10: {"bound_probes": None},
    11: {"bound_probes": "anchor", "subspace_trial": None},
    12: {"subspace_start": "endgame"},
}


def _default_settings(space: DesignSpace) -> dict:
    d = space.dim
    return {
        "weights": [0.3, 0.5, 0.8, 0.95],
        "n_perturb": min(5000, 100 * d),   # DYCORS candidates per proposal
        # Uniform candidates per proposal (at the weights below). Off since issue 9: on the
        # benchmark and the paper's problem they spent evaluations without finding better
        # points (benchmarks/RESULTS-optimiser.md); runs started before keep theirs.
        "n_uniform": 0,
        "uniform_weights": [0.3],          # weights of the cycle at which they compete
        "n_branches": 3,                   # integer assignments tried by the local search
        # Weights of the cycle at which the local search's points compete (None: all); "auto":
        # see _AUTO_SETTINGS.
        "local_weights": "auto",
        "local_maxiter": 30,               # L-BFGS-B iterations per branch
        "n_global_starts": 0,              # relaxed surrogate minimisations from other good points
        "sigma_init": 0.2,
        "sigma_max": 0.2,
        "sigma_min": 0.2 * 0.5 ** 6,       # restart when sigma falls below this
        "fail_tol": max(d, 5),             # failures in a row that halve sigma
        "succ_tol": 3,                     # successes in a row that double sigma
        "improvement_tol": 1e-3,           # success: f < f_best - tol * |f_best|
        "max_failed_row": max(d, 5),       # failed evaluations in a row that force a restart
        # Median-cap values before fitting (True/False), or "auto": cap when that predicts the
        # better half of the points better, by leave-one-out (``_capping_helps``).
        "capping": "auto",
        "force_int_move": True,            # reflect: selected integers move >= 1 unit (else pySOT-like)
        # DYCORS steps: "truncnorm" draws each perturbed coordinate from a normal truncated to
        # the bounds (pySOT; integers with a scale of at least one unit, then rounded);
        # "reflect" (lccopt before issue 9's pySOT comparison) reflects a normal step at a bound.
        # "auto": see _AUTO_SETTINGS.
        "perturbation": "auto",
        # Perturbation probability: "run" shrinks it over the whole run with a floor of 1/d
        # (pySOT); "restart" starts it again at each restart and lets it fall to one coordinate.
        # "auto": see _AUTO_SETTINGS.
        "probability_schedule": "auto",
        # Duplicate radius (unit box, times sqrt(d_cont)): a candidate this close to a used point
        # with the same integers is not proposed. 1e-3 before generation 9 stopped a sharp
        # minimum's refinement at about three digits (Schoen's functions); pySOT's radius is
        # 1e-3 of the problem's own units (benchmarks/RESULTS-optimiser.md).
        "dist_tol": 1e-4,
        "composite": False,                # one RBF per told output, scored by the aggregate
        # Median-cap each output before fitting (composite), or "auto": only when the aggregate
        # is increasing in every output (``set_aggregate``): capping a high value that the
        # aggregate rewards elsewhere (a spread max - min) hides what the surrogate must see.
        "composite_capping": "auto",
        # A restart's surrogate also fits the earlier restarts' points (the perturbations still
        # centre on the restart's own best point). "auto": see _AUTO_SETTINGS. A phase that goes
        # on from a point (the run's best, a probe) always does: it carries on the run's search.
        "restart_keeps_points": "auto",
        "clip_to_bounds": False,           # a step past a bound stops on it (else: reflected)
        # The scalar surrogate's polynomial tail: "linear" (paper Eq. 8), "quadratic" (every
        # product of two coordinates too, once the points determine them), or chosen at each
        # proposal by leave-one-out cross-validation as capping is (``_scalar``): "auto"
        # (generation 7; smooth ill-conditioned problems solved, no significant loss on the
        # broad benchmark) or "auto-half" (measured, a trade: benchmarks/RESULTS-optimiser.md).
        "tail": "auto",
        # What a restart starts from: "fresh", a new Latin hypercube design; "endgame", fresh
        # unless the budget left is shorter than the run's phases so far were on average, when
        # it goes on from the run's best point instead (no design, the step size reset: a late
        # fresh design rarely gets anywhere); "alternate", every odd restart from the run's best
        # point, every even one fresh (after BIPOP-CMA-ES; measured, a trade). "auto": see
        # _AUTO_SETTINGS.
        "restart_from": "auto",
        # Bound probes (generation 10: "anchor"; 11: "subspace"; None: none): in a restart that
        # goes on from the run's best point, where the run's basin is spent and a fresh design
        # would not get far, the best point with one integer on a bound joins the candidates at
        # every weight, for each integer and bound that no point of the restart has yet. An integer
        # whose end is an "off" switch behind a wall (no strip: x_l = 0) is out of reach of
        # steps of sigma from the far side. RESULTS-optimiser.md, "Generation 10". "late":
        # the same, and a late restart that starts fresh (composite surrogate) puts those
        # probes of the run's best point first in its design; a probe joins the restart (its
        # best point, surrogate and distances) only if it improves on the run's best value by
        # improvement_tol, so a probe that fails leaves the fresh restart as it would have been.
        # RESULTS-optimiser.md, "Bound probes in a late fresh restart". "stalled": as
        # "late", but the fresh restart probes when the phase before it did not improve on the
        # run's best by improvement_tol (a whole fresh design found no better basin), late or
        # not; RESULTS-optimiser.md, "Bound probes after a stalled phase". "subspace": the
        # first restart that goes on from the run's best point asks its probes first (a design);
        # once all are told, unless one improved on the run's best by improvement_tol, half the
        # budget left goes to a phase from the best probe with its integer held on that bound
        # (an "off" switch whose own optimum lies away from the run's basin), then the run goes
        # on as before. RESULTS-optimiser.md, "Subspace phases behind a failed bound probe".
        "bound_probes": "subspace",
        # "subspace" (generation 11, with "auto"): proposals the subspace phase has to improve
        # on the run's best (by improvement_tol) before it may run on to its end; a phase that
        # has not ends there and the run goes on from its best point. "auto": max_failed_row (as
        # many proposals as the failures in a row that end any phase); None: no trial.
        # RESULTS-optimiser.md, "Generation 11".
        "subspace_trial": "auto",
        # Which restart takes the run's one probe-and-subspace step of "subspace": "endgame",
        # the first that goes on from the run's best point (generation 11); "stalled", the first
        # after a phase that did not improve on the best of the phases before it by
        # improvement_tol (a whole fresh design found no better basin). "auto": see
        # _AUTO_SETTINGS.
        "subspace_start": "auto",
        # Fraction of the DYCORS candidates in which one perturbed integer coordinate is put on
        # a bound (either, not the best point's own value) instead of stepped, in every phase,
        # at the weights of int_bound_weights (None: all). Measured, not a default
        # (RESULTS-optimiser.md, "Generation 10" and "Integer bound candidates with a composite
        # surrogate"): it pays where the optimum has integers on bounds (the paper's moo) and
        # costs where it has not (its single-E_max; the broad benchmark at every weight).
        "int_bound_candidates": 0.0,
        "int_bound_weights": None,
    }


# What "auto" means for the candidate settings, by the surrogate in use at a proposal: with a
# scalar surrogate pySOT-like steps and the local search at the greedy weight (generation 3,
# chosen on the broad benchmark of 22 functions); with a composite one, whose aggregate of
# smooth fits is a better model of the kinked value, generation 2's reflected steps, per-restart
# schedule and local search at every weight (better on the paper's E_max and ASF cases over
# 16 seeds; benchmarks/RESULTS-optimiser.md). A restart's surrogate keeps the run's points
# with a scalar surrogate (generation 5: better on the broad benchmark and the paper's F_max),
# not with a composite one (a trade on the paper's moo and E_max cases). The candidate
# settings follow the surrogate a proposal is scored with; restart_keeps_points, which decides
# what is fitted, follows whether a composite surrogate is set up (``_keeps_points``). The
# probe-and-subspace step of "subspace" comes where a run's basin looks spent: with a scalar
# surrogate at the first restart from the run's best point; with a composite one, whose
# restarts are fresh, after a fresh phase that found nothing better (generation 12: the
# paper's moo, RESULTS-optimiser.md "Generation 12"). Scalar runs keep "endgame": probes
# after a stalled phase were a trade on the broad benchmark (bound_probes "stalled").
_AUTO_SETTINGS = {
    "scalar": {"perturbation": "truncnorm", "probability_schedule": "run", "local_weights": "greedy",
               "restart_keeps_points": True, "restart_from": "endgame", "subspace_start": "endgame"},
    "composite": {"perturbation": "reflect", "probability_schedule": "restart", "local_weights": None,
                  "restart_keeps_points": False, "restart_from": "fresh", "subspace_start": "stalled"},
}
_AUTO_KEYS = ("perturbation", "probability_schedule", "local_weights", "restart_keeps_points",
              "restart_from", "subspace_start")


class Strategy:
    """MSRS/DYCORS mixed-integer strategy; see the module docstring."""

    def __init__(self, space: DesignSpace, budget: int = 200, n_initial: int = 20,
                 seed: int | None = 0, **settings):
        if not isinstance(space, DesignSpace):
            raise TypeError("space must be a DesignSpace")
        if int(budget) < 1:
            raise ValueError("budget must be >= 1")
        if int(n_initial) < 1:
            raise ValueError("n_initial must be >= 1")
        self._setup(space, int(budget), int(n_initial), seed, settings)
        self._rng = np.random.default_rng(seed)
        self._records: list[dict] = []
        self._restart = 0
        self._subspace_tried = False  # "subspace": the run's one probe-and-subspace step taken
        self._subspace_probes: range | None = None  # its probes, until the phase they lead to
        given = space.given_array
        lhs = latin_hypercube(space, max(0, self.n_initial - len(given)), self._rng, exclude=given)
        self._begin_restart_state(list(given) + list(lhs))

    def _setup(self, space: DesignSpace, budget: int, n_initial: int, seed, settings: dict) -> None:
        unknown = set(settings) - set(_default_settings(space))
        if unknown:
            raise TypeError(f"unknown Strategy settings: {sorted(unknown)}")
        self.space = space
        self.budget = budget
        self.n_initial = n_initial
        self.seed = None if seed is None else int(seed)
        self.settings = {**_default_settings(space), **settings}
        ibc = self.settings["int_bound_candidates"]
        if not (isinstance(ibc, (int, float)) and not isinstance(ibc, bool) and 0.0 <= ibc <= 1.0):
            raise ValueError("int_bound_candidates must be a fraction in [0, 1]")
        lw = self.settings["local_weights"]
        if isinstance(lw, str) and lw != "auto":
            raise ValueError("local_weights must be a list of weights, None (all) or 'auto'")
        for key in ("weights", "uniform_weights", "local_weights", "int_bound_weights"):
            if self.settings[key] is not None and self.settings[key] != "auto":
                self.settings[key] = [float(w) for w in self.settings[key]]
        for key, on in (("uniform_weights", "n_uniform"), ("local_weights", "n_branches"),
                        ("int_bound_weights", "int_bound_candidates")):
            ws = self.settings[key]
            if (self.settings[on] > 0 and ws is not None and ws != "auto"
                    and not set(ws) & set(self.settings["weights"])):
                raise ValueError(f"{key} {ws} has no weight of the cycle {self.settings['weights']}")
        if self.settings["capping"] not in (True, False, "auto"):
            raise ValueError("capping must be True, False or 'auto'")
        if self.settings["perturbation"] not in ("truncnorm", "reflect", "auto"):
            raise ValueError("perturbation must be 'truncnorm', 'reflect' or 'auto'")
        if self.settings["probability_schedule"] not in ("run", "restart", "auto"):
            raise ValueError("probability_schedule must be 'run', 'restart' or 'auto'")
        if self.settings["restart_keeps_points"] not in (True, False, "auto"):
            raise ValueError("restart_keeps_points must be True, False or 'auto'")
        if self.settings["tail"] not in ("linear", "quadratic", "auto", "auto-half"):
            raise ValueError("tail must be 'linear', 'quadratic', 'auto' or 'auto-half'")
        if self.settings["restart_from"] not in ("fresh", "endgame", "alternate", "auto"):
            raise ValueError("restart_from must be 'fresh', 'endgame', 'alternate' or 'auto'")
        if self.settings["subspace_start"] not in ("endgame", "stalled", "auto"):
            raise ValueError("subspace_start must be 'endgame', 'stalled' or 'auto'")
        if self.settings["bound_probes"] not in (None, "anchor", "late", "stalled", "subspace"):
            raise ValueError("bound_probes must be None, 'anchor', 'late', 'stalled' or 'subspace'")
        trial = self.settings["subspace_trial"]
        if not (trial is None or trial == "auto" or isinstance(trial, int)
                and not isinstance(trial, bool) and trial >= 1):
            raise ValueError("subspace_trial must be None, 'auto' or an integer >= 1")
        if self.settings["composite_capping"] not in (True, False, "auto"):
            raise ValueError("composite_capping must be True, False or 'auto'")
        if not self.settings["weights"] or not all(0.0 <= w <= 1.0 for w in self.settings["weights"]):
            raise ValueError("weights must be a non-empty list of numbers in [0, 1]")
        self._steps = self._candidate_settings(composite=False)  # set again by each _select
        self._rbf = CubicRBF()  # cache only (distance matrix); never part of the state
        self._rbfs: list[CubicRBF] = []  # composite: one per output (cache only, as above)
        self._aggregate = None  # composite: outputs (n, k) -> values (n,); not state
        span = space.ub - space.lb
        self._int = space.int_mask
        self._cont = ~self._int & (span > 0)
        self._free = span > 0
        self._span = space.search_span  # steps are drawn in search coordinates (log scales)

    def _begin_restart_state(self, design: list, anchor: int | None = None,
                             frozen: int | None = None, end: int | None = None) -> None:
        # anchor: id of the record a restart without a design goes on from (the run's best, or
        # a subspace phase's probe); frozen: the variable a subspace phase holds at the
        # anchor's value; end:
        # the number of proposals at which the phase ends (None: by the step rule only)
        self._anchor = anchor
        self._frozen, self._phase_end = frozen, end
        self._trial: tuple[int, float] | None = None  # a subspace phase's trial: (end, bar)
        self._queue = [np.asarray(x, dtype=float) for x in design]
        self._restart_start_n = len(self._records)
        self._n_init_restart = len(self._queue)
        self._sigma = float(self.settings["sigma_init"])
        self._n_fail = 0
        self._n_succ = 0
        self._failed_row = 0
        self._n_adaptive = 0
        self._w_index = 0
        self._fbest_restart: float | None = (
            None if anchor is None else float(self._records[anchor]["value"]))
        self._exhausted = False
        # bound probes of a fresh restart ("late", "stalled"): their ids and the value one
        # must beat to join the restart
        self._probe_ids, self._probe_bar = range(0), 0.0

    def set_aggregate(self, aggregate) -> None:
        """The function that maps output vectors F (n, k) to the scalar values (n,), or None.

        An aggregate with a true attribute ``increasing`` says it never decreases when an
        output grows (a scalarising function of objectives to minimise): its outputs may then
        be median-capped (``composite_capping`` "auto"); without it they are fitted as told.
        Not part of the state: whoever restores a strategy sets it again (it must be the same
        deterministic function for a resumed run to propose the same points)."""
        if aggregate is not None and not callable(aggregate):
            raise TypeError("aggregate must be callable or None")
        self._aggregate = aggregate

    @property
    def aggregate(self):
        return self._aggregate

    # -- public read-only view ------------------------------------------------------
    @property
    def n_asked(self) -> int:
        return len(self._records)

    @property
    def n_told(self) -> int:
        return sum(r["status"] != "pending" for r in self._records)

    @property
    def pending(self) -> list[int]:
        return [r["id"] for r in self._records if r["status"] == "pending"]

    @property
    def exhausted(self) -> bool:
        """True once every point of a finite (all-integer) space has been proposed."""
        return self._exhausted

    @property
    def done(self) -> bool:
        """Budget of told evaluations used up (or the space exhausted with nothing pending)."""
        return self.n_told >= self.budget or (self._exhausted and not self.pending)

    @property
    def restart(self) -> int:
        return self._restart

    @property
    def sigma(self) -> float:
        return self._sigma

    @property
    def best(self):
        ok = [r for r in self._records if r["status"] == "ok"]
        if not ok:
            return None
        r = min(ok, key=lambda r: (r["value"], r["id"]))
        return r["x"].copy(), r["value"]

    @property
    def history(self) -> list[dict]:
        return [{**r, "x": r["x"].copy()} for r in self._records]

    # -- ask ------------------------------------------------------------------------------
    def ask(self, k: int = 1) -> list[Proposal]:
        """Up to k new points; fewer only at the budget or when the space is exhausted."""
        out: list[Proposal] = []
        ctx = None
        for _ in range(int(k)):
            if self.n_asked >= self.budget or self._exhausted:
                break
            if not self._queue and self._needs_restart():
                self._start_restart()
                ctx = None
            if self._queue:
                x, phase = self._queue.pop(0), "initial"
                if ctx is not None:
                    ctx.add(x)
            else:
                if ctx is None:
                    ctx = self._prepare()
                pick = self._select(ctx)
                if pick is None:
                    self._exhausted = True
                    break
                x, phase = pick
                ctx.add(x)
            rec = {"id": self.n_asked, "x": np.asarray(x, dtype=float).copy(), "phase": phase,
                   "restart": self._restart, "status": "pending", "value": None, "reason": None, "outputs": None}
            self._records.append(rec)
            out.append(Proposal(rec["id"], rec["x"].copy(), phase, self._restart))
        return out

    def _needs_restart(self) -> bool:
        s = self.settings
        return (self._sigma < s["sigma_min"] or self._failed_row >= s["max_failed_row"]
                or self._phase_end is not None and self.n_asked >= self._phase_end
                or self._subspace_probes is not None and not any(  # "subspace": probes told
                    self._records[i]["status"] == "pending" for i in self._subspace_probes)
                or self._trial_failed())

    def _trial_failed(self) -> bool:
        """A subspace phase at the end of its trial, the trial's points told and none below the
        bar (while some are pending the phase goes on: the verdict waits for them)."""
        if self._trial is None or self.n_asked < self._trial[0]:
            return False
        end, bar = self._trial
        return not any(r["status"] == "pending" or r["status"] == "ok" and r["value"] < bar
                       for r in self._records[self._restart_start_n:end])

    def _start_restart(self) -> None:
        """Fresh design, or none from the run's best point (``restart_from``); earlier points
        stay in the record and the duplicate set (and the surrogate: restart_keeps_points)."""
        trial_failed = self._trial_failed()  # of the phase that ends
        self._restart += 1
        auto = self._candidate_settings(self._composite_set_up())
        rule, subspace_start = auto["restart_from"], auto["subspace_start"]
        mode = self.settings["bound_probes"]
        # late: the budget left is shorter than the phases so far (the first design's and every
        # restart's, by their proposals) were on average
        lengths = np.bincount([r["restart"] for r in self._records], minlength=self._restart)
        late = self.budget - self.n_asked < lengths[: self._restart].mean()
        from_best = late if rule == "endgame" else rule == "alternate" and self._restart % 2 == 1
        ok = [r for r in self._records if r["status"] == "ok"]
        best = min(ok, key=lambda r: (r["value"], r["id"])) if ok else None
        if self._subspace_probes is not None:  # the probes of "subspace" are told (or asked)
            if self._start_subspace_phase(ok):
                return
            from_best = True  # a probe improved on the run's best: go on from it
        elif trial_failed:
            from_best = True  # back to the run's best point: its basin is the best found
        elif (best and mode == "subspace" and not self._subspace_tried
              and (from_best if subspace_start == "endgame" else self._last_phase_stalled(ok))):
            self._subspace_tried = True
            P = self._new_bound_probes(best["x"])
            if P:
                self._begin_restart_state(P, best["id"])
                self._subspace_probes = range(len(self._records), len(self._records) + len(P))
                return
        if from_best and best:
            self._begin_restart_state([], best["id"])
            return
        taken = np.array([r["x"] for r in self._records]).reshape(-1, self.space.dim)
        design = list(latin_hypercube(self.space, self.n_initial, self._rng, exclude=taken))
        probes = []
        stalled = mode == "stalled" and self._last_phase_stalled(ok)
        if best and (mode == "late" and late or stalled):
            probes = self._new_bound_probes(best["x"])
        self._begin_restart_state(probes + design)
        # A probe joins the restart by a success of the step rule's tolerance, not by a hair
        # (a longer strip with the same E_max to 4 digits).
        fb = float(best["value"]) if probes else 0.0
        self._probe_ids = range(len(self._records), len(self._records) + len(probes))
        self._probe_bar = self._success_bar(fb)

    def _new_bound_probes(self, best: np.ndarray) -> list:
        """The bound probes of ``best`` that no point of the run has taken yet."""
        P = self._bound_probes(best, best[None, :])
        taken = np.array([r["x"] for r in self._records]).reshape(-1, self.space.dim)
        return list(P[~_Context(self, taken, taken[:0]).is_taken(P)])

    def _start_subspace_phase(self, ok: list[dict]) -> bool:
        """After the bound probes of "subspace": unless one of them improved on the run's best,
        a phase from the best of them with its integer held on that bound, for half the budget
        left. The run's basin and the probe's side of the bound are different problems: an "off"
        switch (no strip) with the other variables tuned for "on" is a poor point of a subspace
        whose own optimum a step of sigma from the run's best never reaches."""
        ids, self._subspace_probes = self._subspace_probes, None
        anchor = self._records[self._anchor]
        probes = [r for r in ok if r["id"] in ids]
        if not probes or min(r["value"] for r in ok) < self._success_bar(anchor["value"]):
            return False
        p = min(probes, key=lambda r: (r["value"], r["id"]))
        j = int(np.flatnonzero(p["x"] != anchor["x"])[0])
        end = self.n_asked + (self.budget - self.n_asked) // 2
        self._begin_restart_state([], p["id"], frozen=j, end=end)
        trial = self.settings["subspace_trial"]
        if trial is not None:
            trial = self.settings["max_failed_row"] if trial == "auto" else trial
            run_best = min(r["value"] for r in ok)
            self._trial = (self.n_asked + trial, self._success_bar(run_best))
        return True

    def _movable(self) -> np.ndarray:
        """Variables the steps and the local search may change (not the frozen one)."""
        if self._frozen is None:
            return self._free
        m = self._free.copy()
        m[self._frozen] = False
        return m

    def _last_phase_stalled(self, ok: list[dict]) -> bool:
        """Whether the phase that just ended failed to improve on the best of the phases before
        it by improvement_tol (the step rule's success): a fresh design found no better basin."""
        before = [r["value"] for r in ok if r["restart"] < self._restart - 1]
        last = [r["value"] for r in ok if r["restart"] == self._restart - 1]
        if not before:
            return False
        return not (last and min(last) < self._success_bar(min(before)))

    def _success_bar(self, f_best: float) -> float:
        """The value a point must beat to improve on f_best (the step rule's success)."""
        return f_best - self.settings["improvement_tol"] * abs(f_best)

    # -- surrogate and candidates -------------------------------------------------------------
    def _prepare(self) -> "_Context":
        sp = self.space
        recs = self._records
        taken = np.array([r["x"] for r in recs]).reshape(-1, sp.dim)
        # Distance criterion: points of this restart (any status; with the point it went on
        # from) and everything in flight.
        own = [(r["restart"] == self._restart or r["id"] == self._anchor) and not self._aside(r)
               for r in recs]
        near = [r["x"] for r, o in zip(recs, own) if o or r["status"] == "pending"]
        ctx = _Context(self, taken, np.array(near).reshape(-1, sp.dim))
        ctx.probing = (self.settings["bound_probes"] is not None and self._anchor is not None
                       and self._frozen is None)
        if ctx.probing:
            ctx.phase_x = np.array([r["x"] for r, o in zip(recs, own) if o]).reshape(-1, sp.dim)
        ok = sorted((r for r, o in zip(recs, own) if r["status"] == "ok" and o), key=lambda r: r["id"])
        if ok:
            ib = min(range(len(ok)), key=lambda i: (ok[i]["value"], ok[i]["id"]))
            ctx.best = ok[ib]["x"]
            ctx.starts = self._global_starts(ok, ib)
        if self._keeps_points() and ok:
            ok = sorted((r for r in recs if r["status"] == "ok"), key=lambda r: r["id"])
        if len(ok) >= 2:
            X = sp.to_unit(np.array([r["x"] for r in ok]))
            f = np.array([r["value"] for r in ok])
            ctx.rbf = self._composite(X, ok)
            if ctx.rbf is None:
                ctx.rbf = self._scalar(X, f)
            ctx.local_search = self._local_search  # run when first needed (no RNG use)
        return ctx

    def _composite_set_up(self) -> bool:
        """The composite setting on and an aggregate given."""
        return bool(self.settings["composite"] and self._aggregate is not None)

    def _keeps_points(self) -> bool:
        """restart_keeps_points, "auto" resolved (_AUTO_SETTINGS) by whether a composite
        surrogate is set up: it decides which points are fitted, so it is known before the
        surrogate is (restart_from likewise decides a restart's design). A phase anchored on a
        point (a composite run's subspace phase too) fits the run's points."""
        if self._anchor is not None:
            return True  # a phase that goes on from a point goes on with the run's points
        return bool(self._candidate_settings(self._composite_set_up())["restart_keeps_points"])

    def _scalar(self, X: np.ndarray, f: np.ndarray) -> CubicRBF:
        """The scalar surrogate: the cubic RBF of the values or of the median-capped values
        (``capping``), with a linear or a quadratic tail (``tail``). "auto" choices are made by
        leave-one-out cross-validation (``_loo_scores``): the capping and tail whose predictions
        rank the better half of the points best (ties: linear before quadratic, uncapped before
        capped), where tail "auto" (generation 7) takes the quadratic one only if it also ranks
        all the points better than the linear one (its predictions of f, or of the capped
        values when ``capping`` is True); "auto-half" does not ask that."""
        cap, tail = self.settings["capping"], self.settings["tail"]
        capped = np.minimum(f, np.median(f))
        choose_tail = tail in ("auto", "auto-half")
        if cap != "auto" and not choose_tail:
            return self._rbf.fit(X, capped if cap else f, tail)
        caps = (False, True) if cap == "auto" else (cap,)
        best, choice, overall = -np.inf, None, {}
        for t in (("linear", "quadratic") if choose_tail else (tail,)):
            fit = self._rbf.fit(X, f, t)
            if choose_tail and t == "quadratic" and not len(fit.quad_i):
                fit = None  # too few points for the quadratic tail: the linear fit stands
                break
            *scores, overall[t] = self._loo_scores(fit, f, [capped if c else f for c in caps])
            if t == "quadratic" and tail == "auto" and not overall["quadratic"] > overall["linear"]:
                continue  # better on the better half only: not taken (a cost elsewhere)
            for c, sc in zip(caps, scores):
                if choice is None or sc > best:
                    best, choice = sc, (t, c)
        t, c = choice
        if fit is not None and not c and t == ("quadratic" if len(fit.quad_i) else "linear"):
            return fit  # the last fit is the choice
        return self._rbf.fit(X, capped if c else f, t)

    @staticmethod
    def _loo_scores(fit: CubicRBF, f: np.ndarray, values: list) -> list:
        """For each vector of ``values`` (f or f median-capped), how well the interpolant of
        ``fit``'s points and tail ranks the better half of the points by f: the rank
        correlation of its leave-one-out predictions with f there; then the same for the first
        vector over all the points. Fewer than 8 points: 0 for the first, -inf for the others."""
        import scipy.stats

        n = len(f)
        if n < 8:
            return [0.0] + [-np.inf] * (len(values) - 1) + [0.0]
        half = np.argsort(f, kind="stable")[: n // 2]
        residuals = fit.loo_residuals(values)
        scores = []
        for rows, vals, e in [(half, v, e) for v, e in zip(values, residuals)] + [
                (slice(None), values[0], residuals[0])]:
            pred = (vals - e)[rows]
            if not np.all(np.isfinite(pred)):
                scores.append(-np.inf)
                continue
            with warnings.catch_warnings():  # constant input: no correlation (NaN)
                warnings.simplefilter("ignore", scipy.stats.ConstantInputWarning)
                r = scipy.stats.spearmanr(pred, f[rows])[0]
            scores.append(r if np.isfinite(r) else -np.inf)
        return scores

    @classmethod
    def _capping_helps(cls, plain: CubicRBF, f: np.ndarray) -> bool:
        """Whether the median-capped values give the better surrogate where it matters
        (``_loo_scores`` of ``plain``, the RBF fitted to f; ties: no capping)."""
        scores = cls._loo_scores(plain, f, [f, np.minimum(f, np.median(f))])
        return bool(scores[1] > scores[0])  # the better half's, with and without capping

    def _global_starts(self, ok: list, ib: int) -> list:
        """Best points of the restart, in value order, each at least _START_SEPARATION (unit
        box) from the best point and from one another: starts of the global branches."""
        n = int(self.settings["n_global_starts"])
        if n <= 0:
            return []
        order = sorted(range(len(ok)), key=lambda i: (ok[i]["value"], ok[i]["id"]))
        chosen = [self.space.to_unit(ok[ib]["x"])]
        starts = []
        for i in order:
            u = self.space.to_unit(ok[i]["x"])
            if min(np.linalg.norm(u - c) for c in chosen) >= _START_SEPARATION:
                chosen.append(u)
                starts.append(ok[i]["x"])
                if len(starts) >= n:
                    break
        return starts

    def _composite(self, X: np.ndarray, ok: list) -> "_CompositeSurrogate | None":
        """One RBF per output of the ok points, or None (setting off, no aggregate, outputs
        missing or of different lengths)."""
        if not self.settings["composite"] or self._aggregate is None:
            return None
        outs = [r.get("outputs") for r in ok]
        if any(o is None for o in outs) or len({len(o) for o in outs}) != 1 or len(outs[0]) == 0:
            return None
        F = np.array(outs, dtype=float)
        if not np.all(np.isfinite(F)):
            return None
        cap = self.settings["composite_capping"]
        if cap == "auto":
            cap = bool(getattr(self._aggregate, "increasing", False))
        if cap:
            F = np.minimum(F, np.median(F, axis=0)[None, :])
        while len(self._rbfs) < F.shape[1]:
            self._rbfs.append(CubicRBF())
        rbfs = [self._rbfs[j].fit(X, F[:, j]) for j in range(F.shape[1])]
        return _CompositeSurrogate(rbfs, self._aggregate)

    def _select(self, ctx: "_Context"):
        """Best candidate by the merit of Eq. (11), or None if the space is exhausted."""
        if math.isfinite(ctx.n_grid) and len(ctx.taken) >= ctx.n_grid:
            return None
        s = self.settings
        self._steps = self._candidate_settings(isinstance(ctx.rbf, _CompositeSurrogate))
        w = s["weights"][self._w_index % len(s["weights"])]
        n_pert, n_unif, sigma = s["n_perturb"], s["n_uniform"], self._sigma
        jumps = s["int_bound_weights"] is None or w in s["int_bound_weights"]
        for attempt in range(8):
            C, src = [], []
            if ctx.best is not None and n_pert > 0:
                C.append(self._perturb(ctx.best, n_pert, sigma, jumps=jumps))
                src += ["adaptive"] * n_pert
            lw = self._steps["local_weights"]
            if attempt == 0 and (lw is None or w in lw) and ctx.local is not None and len(ctx.local):
                C.append(ctx.local)
                src += ["local"] * len(ctx.local)
            if attempt == 0 and ctx.best is not None and ctx.probing:
                P = self._bound_probes(ctx.best, ctx.phase_x)
                C.append(P)
                src += ["adaptive"] * len(P)
            if n_unif > 0 and (attempt > 0 or w in s["uniform_weights"]):
                C.append(self._uniform(n_unif))
                src += ["random"] * n_unif
            if attempt >= 3 and math.isfinite(ctx.n_grid) and ctx.n_grid <= _ENUMERATE_LIMIT:
                G = self.space.grid()
                C.append(G)
                src += ["random"] * len(G)
            C = np.vstack(C) if C else np.empty((0, self.space.dim))
            free = ~ctx.is_taken(C)
            if free.any():
                C, src = C[free], [t for t, f in zip(src, free) if f]
                break
            # Everything near the best is used up: widen the steps, add more uniform points.
            sigma = min(1.0, 2.0 * sigma)
            n_unif = max(2 * n_unif, 100)
        else:
            return None
        if len(C) == 0:
            return None
        Cu = self.space.to_unit(C)
        dist = cdist(Cu, ctx.near_u).min(axis=1) if len(ctx.near_u) else np.ones(len(C))
        dd = _scale(dist.max() - dist)
        if ctx.rbf is None:
            i = int(np.argmin(dd))  # no surrogate yet: pure space filling
        else:
            i = int(np.argmin(w * _scale(ctx.rbf(Cu)) + (1.0 - w) * dd))
            self._w_index += 1
        self._n_adaptive += 1
        return C[i].copy(), src[i]

    def _candidate_settings(self, composite: bool) -> dict:
        """The settings of _AUTO_KEYS, "auto" resolved for a scalar or composite surrogate
        (_AUTO_SETTINGS)."""
        auto = _AUTO_SETTINGS["composite" if composite else "scalar"]
        out = {k: auto[k] if self.settings[k] == "auto" else self.settings[k] for k in _AUTO_KEYS}
        if out["local_weights"] == "greedy":
            out["local_weights"] = [max(self.settings["weights"])]
        return out

    def _perturb(self, best: np.ndarray, m: int, sigma: float, jumps: bool = True) -> np.ndarray:
        """DYCORS: perturb each coordinate with a probability that shrinks with the budget."""
        sp, rng = self.space, self._rng
        d = sp.dim
        movable = self._movable()
        free_idx = np.flatnonzero(movable)
        if len(free_idx) == 0:
            return np.repeat(best[None, :], m, axis=0)
        p = self._perturb_probability()
        mask = (rng.random((m, d)) < p) & movable
        none = ~mask.any(axis=1)
        pick = free_idx[rng.integers(len(free_idx), size=m)]
        mask[np.flatnonzero(none), pick[none]] = True  # always at least one coordinate
        # in search coordinates (ln x for a log variable, x itself otherwise)
        lb, ub, b = sp.search_lb, sp.search_ub, sp.to_search(best)
        scale = sigma * self._span
        if self._steps["perturbation"] == "truncnorm":
            # pySOT: integers get a scale of at least one unit, then are rounded (a rounded
            # draw may land on the best point's value; such a candidate is a duplicate).
            scale = np.where(self._int, np.maximum(scale, 1.0), scale)
            X = b[None, :] + np.where(mask, scale * _truncated_normal(
                rng, (lb - b) / scale, (ub - b) / scale, (m, d)), 0.0)
        else:
            step = scale * rng.standard_normal((m, d))
            # Integers move by at least one unit step, then by the rounded step.
            if self.settings["force_int_move"]:
                step[:, self._int] = np.where(step[:, self._int] >= 0, 1.0, -1.0) * np.maximum(
                    1.0, np.rint(np.abs(step[:, self._int])))
            else:  # pySOT-like: scale at least one unit, plain rounding (may not move)
                factor = np.maximum(scale, 1.0) / scale
                step[:, self._int] = np.rint(step[:, self._int] * factor[self._int])
            X = b[None, :] + np.where(mask, step, 0.0)
            if self.settings["clip_to_bounds"]:  # optima on a bound get candidates on it
                X = np.clip(X, lb, ub)
            else:
                X = np.where(X < lb, 2 * lb - X, X)  # reflect back into the box
                X = np.where(X > ub, 2 * ub - X, X)
        X = sp.snap(sp.from_search(X))
        return self._bound_jumps(X, mask, best) if jumps else X

    def _bound_jumps(self, X: np.ndarray, mask: np.ndarray, best: np.ndarray) -> np.ndarray:
        """int_bound_candidates: in that fraction of the rows, one perturbed integer coordinate
        (at random) goes to a bound, drawn at random from those the best point is not on."""
        q = float(self.settings["int_bound_candidates"])
        cols = self._int & self._movable()
        if q <= 0.0 or not cols.any():
            return X  # no RNG use: runs without the setting propose as before
        rng, sp = self._rng, self.space
        m = len(X)
        rows = np.flatnonzero((rng.random(m) < q) & (mask & cols).any(axis=1))
        if len(rows) == 0:
            return X
        # one of the row's perturbed integer coordinates, uniformly
        weights = (mask & cols)[rows].astype(float)
        u = rng.random(len(rows))[:, None] * weights.sum(axis=1)[:, None]
        pick = (weights.cumsum(axis=1) > u).argmax(axis=1)
        lo, hi, v = sp.lb[pick], sp.ub[pick], best[pick]
        to_hi = np.where(v <= lo, True, np.where(v >= hi, False, rng.random(len(rows)) < 0.5))
        X[rows, pick] = np.where(to_hi, hi, lo)
        return X

    def _aside(self, rec: dict) -> bool:
        """A probe of a fresh restart that has not (yet) beaten the run's best value."""
        return rec["id"] in self._probe_ids and not (
            rec["status"] == "ok" and rec["value"] < self._probe_bar)

    def _bound_probes(self, best: np.ndarray, phase_x: np.ndarray) -> np.ndarray:
        """The best point with one free integer on a bound, for each integer and bound that no
        point of the restart (``phase_x``) has: each end of a range is asked about once, not
        again from every point a few steps away."""
        sp = self.space
        out = []
        for j in np.flatnonzero(self._int & self._free):
            for bound in (sp.lb[j], sp.ub[j]):
                if not np.any(phase_x[:, j] == bound):
                    x = best.copy()
                    x[j] = bound
                    out.append(x)
        return np.array(out).reshape(-1, sp.dim)

    def _perturb_probability(self) -> float:
        """DYCORS's probability of perturbing a coordinate: min(20/d, 1) (1 - ln n / ln N).

        "run" (pySOT): n counts the proposals since the first initial design over the whole
        run, N the budget after it, with a floor of 1/d, so a restart searches near its best
        point in few coordinates. "restart": n and N count within the restart, no floor."""
        d = self.space.dim
        p = min(20.0 / d, 1.0)
        if self._steps["probability_schedule"] == "run":
            n0 = max(self.n_initial, len(self.space.given))
            n, big_n = self.n_asked - n0 + 1, self.budget - n0
            if big_n > 1 and n >= 1:
                p *= 1.0 - math.log(n) / math.log(big_n)
            return max(p, min(1.0, 1.0 / d))
        n_left = self.budget - self._restart_start_n - self._n_init_restart
        if n_left > 1:
            return p * max(0.0, 1.0 - math.log(self._n_adaptive + 1) / math.log(n_left))
        return 0.0

    def _uniform(self, m: int) -> np.ndarray:
        sp = self.space
        return to_space(sp, self._rng.random((m, sp.dim)))

    def _local_search(self, ctx: "_Context") -> np.ndarray:
        """Node-limited branch-and-bound stand-in on the surrogate (no RNG use).

        An RBF gives no valid lower bound, so branches are heuristic integer assignments:
        the best point's, the rounded minimiser of the relaxed (all-continuous) surrogate,
        and the best unused unit-step neighbours of the best point by surrogate value. On
        each branch the continuous part is minimised with L-BFGS-B from the best point.
        With ``n_global_starts``, the same from good points away from the best as well.
        """
        sp, rbf, best = self.space, ctx.rbf, ctx.best
        s = self.settings
        if best is None or s["n_branches"] <= 0:
            return np.empty((0, sp.dim))
        bu = sp.to_unit(best)
        opts = {"maxiter": int(s["local_maxiter"])}

        def minimise(u0: np.ndarray, dims: np.ndarray) -> np.ndarray:
            if len(dims) == 0:
                return u0
            u = u0.copy()

            def fg(z):
                u[dims] = z
                v, g = rbf.value_and_gradient(u)
                return v, g[dims]

            res = scipy.optimize.minimize(fg, u0[dims], jac=True, method="L-BFGS-B",
                                          bounds=[(0.0, 1.0)] * len(dims), options=opts)
            out = u0.copy()
            out[dims] = np.clip(res.x, 0.0, 1.0)
            return out

        cont = np.flatnonzero(self._cont)
        movable = self._movable()
        ints = np.flatnonzero(self._int & movable)
        free = np.flatnonzero(movable)
        branches = [(best[ints], best)]  # (integer assignment, start of the continuous part)
        if len(ints):
            relaxed = sp.snap(sp.from_unit(minimise(bu, free)))
            branches.append((relaxed[ints], best))
            nb = np.repeat(best[None, :], 2 * len(ints), axis=0)
            nb[np.arange(len(ints)), ints] += 1.0
            nb[len(ints) + np.arange(len(ints)), ints] -= 1.0
            inside = np.all((nb >= sp.lb) & (nb <= sp.ub), axis=1)
            nb = nb[inside]
            if len(cont) == 0:
                nb = nb[~ctx.is_taken(nb)]
            order = np.argsort(rbf(sp.to_unit(nb)), kind="stable")
            branches += [(nb[j, ints], best) for j in order]
        pts, seen = [], set()
        for b, start in branches:
            key = tuple(np.asarray(b).tolist())
            if key in seen:
                continue
            seen.add(key)
            pts.append(self._local_branch(b, start, ints, cont, minimise))
            if len(pts) >= s["n_branches"] + 1:
                break
        # Global starts (n_global_starts): the relaxed surrogate minimised from good evaluated
        # points away from the best, rounded, then the continuous part minimised: a second
        # valley the surrogate already shows is proposed, not only the one around the best.
        for x0 in ctx.starts[: int(s["n_global_starts"])]:
            relaxed = sp.snap(sp.from_unit(minimise(sp.to_unit(x0), free)))
            x = self._local_branch(relaxed[ints], relaxed, ints, cont, minimise)
            if not any(np.array_equal(x, p) for p in pts):
                pts.append(x)
        return np.array(pts).reshape(-1, sp.dim)

    def _local_branch(self, b, start, ints, cont, minimise) -> np.ndarray:
        """The continuous part minimised on the surrogate with the integers fixed at b."""
        sp = self.space
        x0 = np.asarray(start, dtype=float).copy()
        x0[ints] = b
        return sp.snap(sp.from_unit(minimise(sp.to_unit(x0), cont)))

    # -- tell -----------------------------------------------------------------------------------
    def _find(self, x_or_id) -> dict:
        if isinstance(x_or_id, (int, np.integer)):
            i = int(x_or_id)
            if not 0 <= i < len(self._records):
                raise KeyError(f"no proposal with id {i}")
            rec = self._records[i]
        elif isinstance(x_or_id, Proposal):
            rec = self._records[x_or_id.id]
        else:
            x = np.asarray(x_or_id, dtype=float)
            hits = [r for r in self._records if np.array_equal(r["x"], x)]
            if not hits:
                raise KeyError(f"point {x.tolist()} was never proposed")
            pend = [r for r in hits if r["status"] == "pending"]
            rec = pend[0] if pend else hits[0]
        if rec["status"] != "pending":
            raise ValueError(f"proposal {rec['id']} was already told ({rec['status']})")
        return rec

    def tell(self, x_or_id, value: float, outputs=None) -> None:
        """Result of a proposal (by id, Proposal or x). A non-finite value counts as failed.

        ``outputs``: optionally the vector the value aggregates (composite surrogate)."""
        rec = self._find(x_or_id)
        value = float(value)
        if not math.isfinite(value):
            self._fail(rec, f"non-finite value {value!r}")
            return
        rec["status"], rec["value"] = "ok", value
        rec["outputs"] = None if outputs is None else [float(v) for v in np.ravel(outputs)]
        if rec["restart"] != self._restart or self._aside(rec):
            return  # a straggler from before the restart, or a failed probe: recorded, not used
        self._failed_row = 0
        fb = self._fbest_restart
        if rec["phase"] != "initial" and fb is not None:
            self._count(value < self._success_bar(fb))
        if fb is None or value < fb:
            self._fbest_restart = value

    def tell_failed(self, x_or_id, reason: str = "") -> None:
        """A failed evaluation: uses budget, never proposed again, not fitted."""
        self._fail(self._find(x_or_id), str(reason))

    def _fail(self, rec: dict, reason: str) -> None:
        rec["status"], rec["reason"] = "failed", reason
        if rec["restart"] != self._restart:
            return
        self._failed_row += 1
        if rec["phase"] != "initial":
            self._count(False)

    def _count(self, success: bool) -> None:
        s = self.settings
        if success:
            self._n_succ, self._n_fail = self._n_succ + 1, 0
        else:
            self._n_fail, self._n_succ = self._n_fail + 1, 0
        if self._n_fail >= s["fail_tol"]:
            self._sigma, self._n_fail = self._sigma / 2.0, 0
        if self._n_succ >= s["succ_tol"]:
            self._sigma, self._n_succ = min(2.0 * self._sigma, s["sigma_max"]), 0

    # -- state ----------------------------------------------------------------------------------
    def state_dict(self) -> dict:
        """The whole state as plain JSON types (floats round-trip exactly through json)."""
        return {
            "format": STATE_FORMAT,
            "version": STATE_VERSION,
            "space": self.space.to_dict(),
            "budget": self.budget,
            "n_initial": self.n_initial,
            "seed": self.seed,
            "settings": {k: (list(v) if isinstance(v, (list, tuple)) else v)
                         for k, v in self.settings.items()},
            "rng": self._rng.bit_generator.state,
            "records": [{**r, "x": [float(v) for v in r["x"]]} for r in self._records],
            "queue": [[float(v) for v in x] for x in self._queue],
            "restart": self._restart,
            "restart_start_n": self._restart_start_n,
            "n_init_restart": self._n_init_restart,
            "sigma": self._sigma,
            "n_fail": self._n_fail,
            "n_succ": self._n_succ,
            "failed_row": self._failed_row,
            "n_adaptive": self._n_adaptive,
            "w_index": self._w_index,
            "fbest_restart": self._fbest_restart,
            "exhausted": self._exhausted,
            "anchor": self._anchor,
            "late_probes": [self._probe_ids.start, self._probe_ids.stop, self._probe_bar],
            "subspace": {"frozen": self._frozen, "end": self._phase_end,
                         "tried": self._subspace_tried,
                         "trial": None if self._trial is None else list(self._trial),
                         "probes": None if self._subspace_probes is None else
                         [self._subspace_probes.start, self._subspace_probes.stop]},
        }

    @classmethod
    def from_state(cls, d: dict) -> "Strategy":
        if d.get("format") != STATE_FORMAT:
            raise ValueError("not an lccopt strategy state")
        if d.get("version") != STATE_VERSION:
            raise ValueError(f"unsupported strategy state version {d.get('version')}")
        s = cls.__new__(cls)
        settings = {**{k: _BEFORE_GENERATION_3[k] for k in _ADDED_IN_GENERATION_3},
                    **_BEFORE_GENERATION_5, **_BEFORE_GENERATION[7], **_BEFORE_GENERATION[8],
                    # newest first: a state without bound_probes predates generation 10
                    **_BEFORE_GENERATION[12], **_BEFORE_GENERATION[11], **_BEFORE_GENERATION[10],
                    **d["settings"]}
        s._setup(DesignSpace.from_dict(d["space"]), int(d["budget"]), int(d["n_initial"]),
                 d["seed"], settings)
        bg = getattr(np.random, d["rng"]["bit_generator"])()
        bg.state = d["rng"]
        s._rng = np.random.Generator(bg)
        s._records = [{"outputs": None, **r, "x": np.array(r["x"], dtype=float)} for r in d["records"]]
        s._queue = [np.array(x, dtype=float) for x in d["queue"]]
        s._restart = int(d["restart"])
        s._restart_start_n = int(d["restart_start_n"])
        s._n_init_restart = int(d["n_init_restart"])
        s._sigma = float(d["sigma"])
        s._n_fail, s._n_succ = int(d["n_fail"]), int(d["n_succ"])
        s._failed_row = int(d["failed_row"])
        s._n_adaptive, s._w_index = int(d["n_adaptive"]), int(d["w_index"])
        s._fbest_restart = None if d["fbest_restart"] is None else float(d["fbest_restart"])
        s._exhausted = bool(d["exhausted"])
        s._anchor = None if d.get("anchor") is None else int(d["anchor"])
        start, stop, bar = d.get("late_probes", [0, 0, 0.0])
        s._probe_ids, s._probe_bar = range(int(start), int(stop)), float(bar)
        sub = d.get("subspace") or {}
        fr, pr = sub.get("frozen"), sub.get("probes")
        s._frozen = None if fr is None else int(fr)
        s._phase_end = None if sub.get("end") is None else int(sub["end"])
        s._subspace_tried = bool(sub.get("tried", False))
        tr = sub.get("trial")
        s._trial = None if tr is None else (int(tr[0]), float(tr[1]))
        s._subspace_probes = None if pr is None else range(int(pr[0]), int(pr[1]))
        return s

    def save(self, path) -> None:
        """Atomic write: temporary file in the same directory, fsync, rename."""
        from ..atomic import atomic_write_text

        atomic_write_text(path, json.dumps(self.state_dict(), allow_nan=False))

    @classmethod
    def load(cls, path) -> "Strategy":
        with open(path, encoding="utf-8") as fh:
            return cls.from_state(json.load(fh))


def _truncated_normal(rng: np.random.Generator, a: np.ndarray, b: np.ndarray, shape) -> np.ndarray:
    """Standard normal draws truncated to [a, b] per column (a <= 0 <= b), by the inverse CDF:
    with 0 inside [a, b] both CDF values are in the well-resolved part of [0, 1]."""
    lo, hi = scipy.special.ndtr(a), scipy.special.ndtr(b)
    z = scipy.special.ndtri(lo + rng.random(shape) * (hi - lo))
    return np.clip(z, a, b)


def _scale(v: np.ndarray) -> np.ndarray:
    lo, hi = float(v.min()), float(v.max())
    return (v - lo) / (hi - lo) if hi > lo else np.zeros_like(v)


class _CompositeSurrogate:
    """aggregate(one RBF per output): called and differentiated like a CubicRBF."""

    def __init__(self, rbfs: list, aggregate):
        self.rbfs, self.aggregate = rbfs, aggregate
        self._shared = None  # see _shared_points

    def _agg(self, F: np.ndarray) -> np.ndarray:
        return np.asarray(self.aggregate(F), dtype=float).reshape(len(F))

    def __call__(self, Xq: np.ndarray):
        Xq = np.asarray(Xq, dtype=float)
        single = Xq.ndim == 1
        Xq = np.atleast_2d(Xq)
        shared = self._shared_points()
        if shared:  # one distance matrix for all the RBFs (same operations as each would do)
            r = distances(Xq, shared.X)
            r3 = r * r * r
            F = np.column_stack([rb.predict_from(Xq, r3) for rb in self.rbfs])
        else:
            F = np.column_stack([rb(Xq) for rb in self.rbfs])
        v = self._agg(F)
        return v[0] if single else v

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """Chain rule with forward differences of the aggregate in each output (a one-sided
        derivative at a kink of the aggregate, enough for the heuristic local search)."""
        return self.value_and_gradient(x)[1]

    def value_and_gradient(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """``(float(self(x)), gradient(x))`` at one point x (d,), the outputs predicted once
        for both (the local search asks for both at every step); the same numbers as the two
        calls give: the value is the aggregate of the same (1, k) row as ``__call__``'s."""
        x = np.asarray(x, dtype=float)
        shared = self._shared_points()
        if shared:  # the RBFs' distances to x computed once for all (same operations)
            xq = x[None, :]
            r = distances(xq, shared.X)
            r3 = r * r * r
            f = np.array([rb.predict_from(xq, r3)[0] for rb in self.rbfs], dtype=float)
        else:
            f = np.array([r(x) for r in self.rbfs], dtype=float)
        value = float(self._agg(f[None, :])[0])
        h = 1e-7 * np.maximum(1.0, np.abs(f))
        F = np.vstack([f[None, :], f[None, :] + np.diag(h)])
        a = self._agg(F)
        dA = (a[1:] - a[0]) / h
        g = np.zeros_like(x)
        diff = rn = None
        for j, rb in enumerate(self.rbfs):
            if dA[j] != 0.0:
                if not shared:
                    g += dA[j] * rb.gradient(x)
                    continue
                if diff is None:  # as CubicRBF.gradient computes them
                    diff = x[None, :] - shared.X
                    rn = np.sqrt(np.einsum("ij,ij->i", diff, diff))
                g += dA[j] * rb.gradient_from(diff, rn, x)
        return value, g

    def _shared_points(self):
        """The first RBF if every RBF was fitted to the same points (as ``_composite`` fits
        them: the same X, hence the same tail columns), else None."""
        if self._shared is None:
            r0 = self.rbfs[0] if self.rbfs else None
            ok = r0 is not None and all(
                np.array_equal(r.X, r0.X) and np.array_equal(r.tail_dims, r0.tail_dims)
                and np.array_equal(r.quad_i, r0.quad_i) and np.array_equal(r.quad_j, r0.quad_j)
                for r in self.rbfs)
            self._shared = (r0,) if ok else ()
        return self._shared[0] if self._shared else None


class _Context:
    """Per-ask working data: the fitted surrogate and the points to keep away from."""

    def __init__(self, strategy: Strategy, taken: np.ndarray, near: np.ndarray):
        sp = strategy.space
        self.space = sp
        self.int = strategy._int
        self.cont = strategy._cont
        self.tol = strategy.settings["dist_tol"] * math.sqrt(max(1, int(self.cont.sum())))
        self.n_grid = sp.n_grid
        self.taken = taken
        self.near_u = sp.to_unit(near)
        self.best: np.ndarray | None = None
        self.probing = False  # bound probes join the candidates (a restart from the best point)
        self.phase_x = np.empty((0, sp.dim))  # points of this restart, with the one it went on from
        self.rbf: CubicRBF | None = None
        self.local_search = None  # the strategy's local search, once a surrogate is fitted
        self._local: np.ndarray | None = None
        self.starts: list = []

    @property
    def local(self) -> np.ndarray | None:
        """The local search's points (computed on first use: with local_weights, most
        proposals do not need them)."""
        if self._local is None and self.local_search is not None:
            self._local = self.local_search(self)
        return self._local

    def add(self, x: np.ndarray) -> None:
        self.taken = np.vstack([self.taken, x[None, :]])
        self.near_u = np.vstack([self.near_u, self.space.to_unit(x)[None, :]])

    def is_taken(self, C: np.ndarray) -> np.ndarray:
        """Same integer values and continuous part within tol of a used point."""
        nt = len(self.taken)
        if nt == 0 or len(C) == 0:
            return np.zeros(len(C), dtype=bool)
        if self.int.any():
            # Group rows by their integer part (exact float equality; + 0.0 makes -0.0 equal
            # to 0.0, as a comparison would) instead of comparing every pair.
            ints = np.vstack([self.taken[:, self.int], C[:, self.int]]) + 0.0
            key = np.unique(ints, axis=0, return_inverse=True)[1].ravel()
            kt, kc = key[:nt], key[nt:]
            match = np.isin(kc, kt)
        else:
            kt, kc = np.zeros(nt, dtype=int), np.zeros(len(C), dtype=int)
            match = np.ones(len(C), dtype=bool)
        if not self.cont.any() or not match.any():
            return match
        out = np.zeros(len(C), dtype=bool)
        Cu = self.space.to_unit(C[match])[:, self.cont]
        Tu = self.space.to_unit(self.taken)[:, self.cont]
        ci, kcm = np.flatnonzero(match), kc[match]
        for k in np.unique(kcm):  # continuous part within tol of a used point with the same integers
            rows = kcm == k
            out[ci[rows]] = (cdist(Cu[rows], Tu[kt == k]) < self.tol).any(axis=1)
        return out
