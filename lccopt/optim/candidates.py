"""Candidate points of a proposal (paper Steps D-E): DYCORS perturbations of the best point
and the local search's points, and the extension point that makes them.

A candidate generator is any callable ``generator(request) -> [(points (m, d), phase), ...]``
that ``Strategy(candidates=...)`` is given instead of the default ``Dycors``; the strategy
adds the bound probes of a phase that goes on from a point (``bound_probes``), drops every
candidate that equals a used point, and proposes the best candidate by the merit of Eq. (11).
Whatever a generator draws it must draw from ``request.rng`` only (the strategy's generator,
part of its saved state), so that a restored strategy proposes the same points. Experiments
live in benchmarks/optimiser/variants.py, e.g. a generator that adds uniform points to the
default's::

    class WithUniform:
        def __init__(self, settings):
            self.dycors = Dycors(settings)

        def __call__(self, req):
            u = to_space(req.space, req.rng.random((100, req.space.dim)))
            return self.dycors(req) + [(u, "random")]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.special

from .settings import WEIGHTS, Settings, n_perturb
from .space import DesignSpace


@dataclass
class CandidateRequest:
    """What a candidate generator is told about one proposal.

    Attributes
    ----------
    space : DesignSpace
        The design space (candidates must be valid points of it: ``space.snap``).
    rng : numpy.random.Generator
        The strategy's random generator: draw from nothing else.
    best : ndarray (d,) or None
        The phase's best point (the centre of the perturbations); None before a result.
    sigma : float
        The step size as a fraction of each variable's range (search coordinates), doubled
        on each ``attempt`` after the first.
    probability : float
        DYCORS's probability of perturbing a coordinate at this proposal.
    movable : ndarray of bool (d,)
        The variables a candidate may change (not a fixed one, not one a subspace phase holds).
    weight : float
        The merit weight of this proposal (one of ``settings.WEIGHTS``).
    attempt : int
        0, then 1, 2, ... while every candidate of the attempts before was a used point.
    local : callable
        ``local()``: the local search's points on the surrogate (computed on the first call),
        or None before the surrogate can be fitted.
    ranked : ndarray (n, d)
        The phase's told points (with the point it went on from), best first: ``best`` is
        the first; empty before a result.
    """

    space: DesignSpace
    rng: np.random.Generator
    best: np.ndarray | None
    sigma: float
    probability: float
    movable: np.ndarray
    weight: float
    attempt: int
    local: Callable[[], np.ndarray | None]
    ranked: np.ndarray


class Dycors:
    """The default candidate generator: DYCORS perturbations of the best point (half of them
    shaped steps with ``settings.shaped_steps``), and the local search's points at the weights
    of ``settings.local_weights`` (first attempt only)."""

    def __init__(self, settings: Settings):
        self.perturbation = settings.perturbation
        self.local_weights = settings.local_weights
        self.shaped = settings.shaped_steps

    def __call__(self, req: CandidateRequest) -> list[tuple[np.ndarray, str]]:
        """[(steps (n_perturb(d), d), "adaptive"), (local points, "local")]: each if any."""
        out = []
        if req.best is not None:
            X = perturb(req.space, req.rng, req.best, n_perturb(req.space.dim), req.sigma,
                        req.probability, req.movable, self.perturbation)
            if self.shaped:
                shaped = shaped_steps(req.space, req.rng, req.ranked, len(X) // 2, req.sigma,
                                      req.probability, req.movable)
                X[:len(shaped)] = shaped
            out.append((X, "adaptive"))
        if req.attempt == 0 and (self.local_weights == "all" or req.weight == max(WEIGHTS)):
            points = req.local()
            if points is not None and len(points):
                out.append((points, "local"))
        return out


def perturb(space: DesignSpace, rng: np.random.Generator, best: np.ndarray, m: int,
            sigma: float, probability: float, movable: np.ndarray,
            perturbation: str) -> np.ndarray:
    """DYCORS: ``m`` copies of ``best``, each with a random subset of its movable coordinates
    (each with ``probability``, at least one) stepped by ``sigma`` times its range.

    Parameters
    ----------
    space, rng, best, m, sigma, probability, movable
        As in ``CandidateRequest``; m is the number of candidates.
    perturbation : {"truncnorm", "reflect"}
        See ``Settings.perturbation``.

    Returns
    -------
    ndarray (m, d)
        Valid points of the space (integers rounded, on or inside the bounds).
    """
    d = space.dim
    free_idx = np.flatnonzero(movable)
    if len(free_idx) == 0:
        return np.repeat(best[None, :], m, axis=0)
    mask = (rng.random((m, d)) < probability) & movable
    none = ~mask.any(axis=1)
    pick = free_idx[rng.integers(len(free_idx), size=m)]
    mask[np.flatnonzero(none), pick[none]] = True  # always at least one coordinate
    # in search coordinates (ln x for a log variable, x itself otherwise)
    lb, ub, b = space.search_lb, space.search_ub, space.to_search(best)
    scale = sigma * space.search_span
    ints = space.int_mask
    if perturbation == "truncnorm":
        # pySOT: integers get a scale of at least one unit, then are rounded (a rounded
        # draw may land on the best point's value; such a candidate is a duplicate).
        scale = np.where(ints, np.maximum(scale, 1.0), scale)
        X = b[None, :] + np.where(mask, scale * truncated_normal(
            rng, (lb - b) / scale, (ub - b) / scale, (m, d)), 0.0)
    else:
        step = scale * rng.standard_normal((m, d))
        # Integers move by at least one unit step, then by the rounded step.
        step[:, ints] = np.where(step[:, ints] >= 0, 1.0, -1.0) * np.maximum(
            1.0, np.rint(np.abs(step[:, ints])))
        X = b[None, :] + np.where(mask, step, 0.0)
        X = np.where(X < lb, 2 * lb - X, X)  # reflect back into the box
        X = np.where(X > ub, 2 * ub - X, X)
    return space.snap(space.from_search(X))


def shaped_steps(space: DesignSpace, rng: np.random.Generator, ranked: np.ndarray, m: int,
                 sigma: float, probability: float, movable: np.ndarray) -> np.ndarray:
    """``m`` steps from the phase's best point drawn from N(0, sigma^2 C) in the unit box.

    C is the second moment of the steps from the best point (``ranked[0]``) to the next best
    mu = min(n - 1, 2d) points in the movable coordinates: CMA-ES's rank-mu estimate of where
    the good points lie (Hansen 2016, "The CMA Evolution Strategy: A Tutorial"). On a valley
    (Zakharov's s = sum i z_i / 2 near 0, Rosenbrock's parabola) it moves the coordinates
    together, which coordinate steps late in a run (about one coordinate each) cannot. C is
    scaled to the DYCORS steps' expected squared length (movable count times
    ``probability``, in units of sigma^2): the same step length, the shape learned. The
    steps are clipped to the box and snapped (integers rounded).

    Returns
    -------
    ndarray (k, d)
        k = m steps, or none (k = 0) with fewer than d + 1 ranked points or fewer than two
        movable variables (nothing to learn a shape from).
    """
    mov = np.flatnonzero(movable)
    if len(ranked) < space.dim + 1 or len(mov) < 2 or m < 1:
        return np.empty((0, space.dim))
    U = space.to_unit(ranked)
    mu = min(len(U) - 1, 2 * space.dim)
    Y = (U[1:mu + 1] - U[0])[:, mov]
    C = Y.T @ Y / mu
    trace = np.trace(C)
    if not (np.isfinite(trace) and trace > 0):
        return np.empty((0, space.dim))
    C *= len(mov) * probability / trace
    w, V = np.linalg.eigh(C)
    root = V * np.sqrt(np.clip(w, 0.0, None))
    steps = np.repeat(U[:1], m, axis=0)
    steps[:, mov] += sigma * rng.standard_normal((m, len(mov))) @ root.T
    return space.snap(space.from_unit(np.clip(steps, 0.0, 1.0)))


def truncated_normal(rng: np.random.Generator, a: np.ndarray, b: np.ndarray, shape) -> np.ndarray:
    """Standard normal draws truncated to [a, b] per column (a <= 0 <= b), by the inverse CDF:
    with 0 inside [a, b] both CDF values are in the well-resolved part of [0, 1]."""
    lo, hi = scipy.special.ndtr(a), scipy.special.ndtr(b)
    z = scipy.special.ndtri(lo + rng.random(shape) * (hi - lo))
    return np.clip(z, a, b)


def perturb_probability(schedule: str, dim: int, n_asked: int, n_first: int, budget: int,
                        n_left: int, n_adaptive: int) -> float:
    """DYCORS's probability of perturbing a coordinate: min(20/d, 1) (1 - ln n / ln N).

    "run" (pySOT): n counts the proposals since the first initial design (``n_first``
    points) over the whole run, N the budget after it, with a floor of 1/d, so a late phase
    searches near its best point in few coordinates. "restart": n counts the phase's
    proposals after its design (``n_adaptive``), N the budget left after the design
    (``n_left``), no floor.
    """
    p = min(20.0 / dim, 1.0)
    if schedule == "run":
        n, big_n = n_asked - n_first + 1, budget - n_first
        if big_n > 1 and n >= 1:
            p *= 1.0 - math.log(n) / math.log(big_n)
        return max(p, min(1.0, 1.0 / dim))
    if n_left > 1:
        return p * max(0.0, 1.0 - math.log(n_adaptive + 1) / math.log(n_left))
    return 0.0


def bound_probes(space: DesignSpace, best: np.ndarray, phase_x: np.ndarray,
                 movable: np.ndarray) -> np.ndarray:
    """The best point with one movable integer on a bound, for each such integer and bound
    that no point of ``phase_x`` (the phase's points) has: each end of a range is asked about
    once, not again from every point a few steps away.

    An integer whose end is an "off" switch behind a wall (no strip: x_l = 0, where the
    small values are worst) is out of reach of steps of sigma from the far side; a phase
    that goes on from the run's best point, whose basin is spent, tries the ends directly.
    """
    out = []
    for j in np.flatnonzero(space.int_mask & movable):
        for bound in (space.lb[j], space.ub[j]):
            if not np.any(phase_x[:, j] == bound):
                x = best.copy()
                x[j] = bound
                out.append(x)
    return np.array(out).reshape(-1, space.dim)
