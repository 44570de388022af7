"""Experiments with lccopt's optimiser, plugged in through its extension points.

The product has one strategy; an idea to measure is a candidate generator
(``lccopt.optim.candidates``: ``generator(request) -> [(points, phase), ...]``) or a restart
policy (``lccopt.optim.restarts.RestartPolicy``'s interface) given to ``Strategy`` here, never
a setting of the package. ``VARIANTS`` names them for ``benchmarks/optimiser/optimiser.py
--variant``;
each maps the run's settings to the Strategy keyword arguments that plug it in. Levers that
were measured this way (or as settings before) and not adopted are in RESULTS-optimiser.md
(one line each; the sections named below are in its history, git show
7c763ea:benchmarks/RESULTS-optimiser.md).

* ``uniform``: uniform points (10 d, at most 1000) compete with the DYCORS steps at the merit
  weight 0.3, as lccopt's first optimiser had them (RESULTS-optimiser.md, "Levers tried on
  this benchmark": they spent evaluations without finding better points).
* ``int-bound-jumps``: in 5 % of the DYCORS candidates one perturbed integer goes to a bound
  the best point is not on, in every phase ("Integer bound candidates with a composite
  surrogate": it frees the paper's moo from its trap and costs its single-E_max).
* ``alternate-restarts``: every odd restart goes on from the run's best point, every even
  one starts a fresh design (after BIPOP-CMA-ES; "Two restart rules": a trade).
"""

from __future__ import annotations

import numpy as np

from lccopt.optim.candidates import CandidateRequest, Dycors
from lccopt.optim.restarts import NextPhase, RestartPolicy
from lccopt.optim.sampling import to_space
from lccopt.optim.settings import Settings


class UniformCandidates:
    """The default candidates plus uniform points at the merit weight ``weight``."""

    def __init__(self, settings: Settings, weight: float = 0.3):
        self.dycors, self.weight = Dycors(settings), weight

    def __call__(self, req: CandidateRequest) -> list:
        out = self.dycors(req)
        if req.weight == self.weight and req.attempt == 0:
            m = min(1000, 10 * req.space.dim)
            out.append((to_space(req.space, req.rng.random((m, req.space.dim))), "random"))
        return out


class IntBoundJumps:
    """The default candidates, with one moved integer of a fraction ``q`` of the DYCORS
    candidates put on a bound (either, not the best point's own value)."""

    def __init__(self, settings: Settings, q: float = 0.05):
        self.dycors, self.q = Dycors(settings), q

    def __call__(self, req: CandidateRequest) -> list:
        out = self.dycors(req)
        if not out or out[0][1] != "adaptive":
            return out
        X, sp, rng = out[0][0], req.space, req.rng
        moved = (X != req.best[None, :]) & (sp.int_mask & req.movable)[None, :]
        rows = np.flatnonzero((rng.random(len(X)) < self.q) & moved.any(axis=1))
        for i in rows:
            j = rng.choice(np.flatnonzero(moved[i]))
            lo, hi, v = sp.lb[j], sp.ub[j], req.best[j]
            X[i, j] = lo if v >= hi else hi if v <= lo else (hi if rng.random() < 0.5 else lo)
        return out


class AlternateRestarts(RestartPolicy):
    """The default policy, except that an odd restart goes on from the run's best point and an
    even one starts a fresh design (the probe-and-subspace step and trials as by default)."""

    def next_phase(self, s) -> NextPhase:
        plan = super().next_phase(s)
        if plan.anchor is not None:
            return plan  # probes, a subspace phase or the run's best point: as by default
        if (s.phase.index + 1) % 2 == 1:  # (the fresh design the default drew is dropped)
            ok = [r for r in s.records if r["status"] == "ok"]
            if ok:
                return NextPhase([], anchor=min(ok, key=lambda r: (r["value"], r["id"]))["id"])
        return plan


VARIANTS = {
    "uniform": lambda settings: {"candidates": UniformCandidates(settings)},
    "int-bound-jumps": lambda settings: {"candidates": IntBoundJumps(settings)},
    "alternate-restarts": lambda settings: {"restarts": AlternateRestarts()},
}


def strategy_kwargs(variant: str, settings: Settings | None = None) -> dict:
    """The Strategy keyword arguments of ``variant`` ("default": none)."""
    if variant == "default":
        return {}
    return VARIANTS[variant](settings or Settings.default())
