"""Candidate points: DYCORS steps, their probability, bound probes, the generator extension."""

import numpy as np
import pytest

from benchmarks.support import problems
from lccopt.optim.candidates import (
    CandidateRequest,
    Dycors,
    bound_probes,
    perturb,
    perturb_probability,
    shaped_steps,
)
from lccopt.optim.sampling import to_space
from lccopt.optim.settings import Settings
from lccopt.optim.space import DesignSpace
from lccopt.optim.strategy import Strategy
from tests.optim.helpers import run_serial, xs

SPACE3 = DesignSpace(["x", "y", "n"], [0.0, 0.0, 0], [1.0, 1.0, 4], [False, False, True])
ALL = np.array([True, True, True])


def test_truncated_normal_steps_stay_in_the_box_with_the_scale_of_sigma():
    """"truncnorm" (pySOT): each perturbed coordinate is drawn from a normal of scale
    sigma * range truncated to the bounds; integers get a scale of at least one unit and are
    rounded."""
    rng = np.random.default_rng(2)
    best = np.array([0.0, 0.5, 2.0])
    C = perturb(SPACE3, rng, best, 20000, 0.1, 1.0, ALL, "truncnorm")
    assert np.all((C >= SPACE3.lb) & (C <= SPACE3.ub))
    x, y, n = C[:, 0], C[:, 1], C[:, 2]
    # at the lower bound: one-sided, a half normal of scale 0.1 (mean 0.1 sqrt(2/pi))
    assert np.all(x >= 0.0) and abs(x[x > 0].mean() - 0.1 * np.sqrt(2 / np.pi)) < 0.004
    # inside: the truncation is 5 sigma away, a plain normal of scale 0.1
    assert abs((y[y != 0.5] - 0.5).std() - 0.1) < 0.004 and np.all(y != 0.5)
    # integer of range 4: sigma * range = 0.4 < 1, so the scale is one unit, truncated to
    # [-2, 2] units; rounded, it moves in P(1/2 < |z| < 2) / P(|z| < 2) = 0.599 of the draws
    assert np.all(n == np.rint(n)) and n.min() == 0.0 and n.max() == 4.0
    assert abs(np.mean(n != 2.0) - 0.599) < 0.015


def test_reflected_steps_move_every_perturbed_integer_and_stay_in_the_box():
    """"reflect": a normal step reflected at a bound; a perturbed integer moves by at least
    one unit (then by the rounded step)."""
    rng = np.random.default_rng(3)
    best = np.array([0.05, 0.5, 2.0])
    C = perturb(SPACE3, rng, best, 20000, 0.1, 1.0, ALL, "reflect")
    assert np.all((C >= SPACE3.lb) & (C <= SPACE3.ub))
    assert np.all(C[:, 2] != 2.0)  # probability 1: every integer perturbed, and it moved
    assert np.mean(C[:, 0] < 0.05) < np.mean(C[:, 0] > 0.05)  # reflected off the bound at 0


def test_at_least_one_coordinate_moves_and_a_held_one_never_does():
    rng = np.random.default_rng(4)
    best = np.array([0.5, 0.5, 2.0])
    held = np.array([True, True, False])
    for kind in ("truncnorm", "reflect"):
        C = perturb(SPACE3, rng, best, 5000, 0.2, 0.0, held, kind)
        assert np.all(C[:, 2] == 2.0)
        assert np.all(np.sum(C[:, :2] != best[:2], axis=1) == 1)  # probability 0: one each


@pytest.mark.slow
def test_the_perturbation_probability_shrinks_over_the_whole_run():
    """"run" (pySOT): min(20/d, 1) (1 - ln n / ln N) with n the proposals since the first
    initial design and N the budget after it, floored at 1/d, not reset by a restart;
    "restart" starts again at each phase (after its design), without the floor."""
    sp = problems.paper_size("ackley").space  # d = 8: 20/d > 1
    s = Strategy(sp, budget=220, n_initial=20, seed=0)
    expected = []
    while s.n_told < 200:
        if s.n_asked >= 20 and not s._queue:
            n = s.n_asked - 20 + 1
            expected.append((s._probability(), max(1 - np.log(n) / np.log(200), 1 / 8)))
        for pr in s.ask(1):
            s.tell(pr.id, 0.0 if pr.id == 0 else 1.0)  # nothing improves: sigma collapses
    assert s.restart >= 1, "the test needs a restart"
    got, want = np.array(expected).T
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert got[-1] == 1 / 8 and np.all(np.diff(got) <= 0)
    assert perturb_probability("restart", 8, 150, 20, 220, 100, 0) == 1.0
    assert perturb_probability("restart", 8, 150, 20, 220, 100, 9) == pytest.approx(
        1 - np.log(10) / np.log(100))
    assert perturb_probability("restart", 8, 219, 20, 220, 1, 0) == 0.0


SPACE4 = DesignSpace(["a", "b", "c", "n"], [0.0, 0.0, 0.0, 0], [1.0, 2.0, 1.0, 40],
                     [False, False, False, True])


def test_shaped_steps_follow_the_line_the_good_points_lie_on():
    """The best points on a line through the best one (in the unit box): every step lies on
    that line, a held variable never moves, and the mean squared step is the DYCORS steps'
    (movable count x probability x sigma^2; here 3 x 0.5 x 0.01^2), with no clipping."""
    best = np.array([0.5, 1.0, 0.5, 20.0])
    v = np.array([0.6, 0.0, -0.8])                     # unit-box direction in a, b, c
    t = np.array([0.0, 0.05, -0.03, 0.1, -0.08, 0.02, 0.04, -0.06])
    U = SPACE4.to_unit(best) + np.outer(t, np.r_[v, 0.0])
    ranked = SPACE4.from_unit(U)
    held = np.array([True, True, True, False])
    X = shaped_steps(SPACE4, np.random.default_rng(5), ranked, 20000, 0.01, 0.5, held)
    assert X.shape == (20000, 4) and np.all(X[:, 3] == 20.0)
    S = SPACE4.to_unit(X)[:, :3] - SPACE4.to_unit(best)[:3]
    assert np.abs(np.cross(S, v)).max() < 1e-8        # along v (steps ~1e-2), not across
    assert np.mean((S ** 2).sum(axis=1)) == pytest.approx(3 * 0.5 * 0.01 ** 2, rel=0.03)


def test_shaped_steps_round_integers_stay_in_the_box_and_need_a_shape():
    """Integers rounded and every step a valid point; fewer than d + 1 ranked points (no
    shape to learn) or one movable variable: no steps."""
    rng = np.random.default_rng(6)
    ranked = to_space(SPACE4, rng.random((12, 4)))
    X = shaped_steps(SPACE4, rng, ranked, 5000, 0.5, 1.0, np.ones(4, bool))
    assert len(X) == 5000 and np.all((X >= SPACE4.lb) & (X <= SPACE4.ub))
    assert np.all(X[:, 3] == np.rint(X[:, 3])) and len(np.unique(X[:, 3])) > 10
    assert len(shaped_steps(SPACE4, rng, ranked[:4], 10, 0.5, 1.0, np.ones(4, bool))) == 0
    one = np.array([True, False, False, False])
    assert len(shaped_steps(SPACE4, rng, ranked, 10, 0.5, 1.0, one)) == 0


def test_half_the_scalar_steps_are_shaped_and_none_of_the_composite():
    """The scalar surrogate's candidates: the first half shaped steps, the rest DYCORS's own
    draws; the composite's: all coordinate steps (the same draws as ``perturb``)."""
    sp = problems.paper_size("zakharov").space
    rng = np.random.default_rng(7)
    ranked = to_space(sp, rng.random((30, sp.dim)))
    free = sp.ub > sp.lb
    for composite in (False, True):
        req = CandidateRequest(sp, np.random.default_rng(8), ranked[0], 0.1, 0.3, free,
                               0.5, 0, lambda: None, ranked)
        settings = Settings.default(composite)
        (X, kind), = Dycors(settings)(req)
        plain = perturb(sp, np.random.default_rng(8), ranked[0], len(X), 0.1, 0.3, free,
                        settings.perturbation)
        half = len(X) // 2
        assert kind == "adaptive" and np.array_equal(X[half:], plain[half:])
        if composite:
            assert np.array_equal(X, plain)
        else:  # a shaped step moves every continuous coordinate, a coordinate step ~30 %
            cont = ~sp.int_mask
            assert np.mean(X[:half, cont] != ranked[0, cont]) > 0.99
            assert np.mean(plain[:half, cont] != ranked[0, cont]) < 0.5


def test_bound_probes_are_the_best_point_with_one_integer_on_a_bound():
    """Each movable integer to each bound that no point of the phase has yet (the best point
    is one of them); continuous coordinates and one-value integers get none."""
    space = DesignSpace(["x", "n", "k", "c"], [0.0, 0, 3, 2], [1.0, 120, 7, 2],
                        [False, True, True, True])
    free = space.ub > space.lb
    best = np.array([0.5, 113.0, 3.0, 2.0])
    np.testing.assert_array_equal(bound_probes(space, best, best[None, :], free),
                                  [[0.5, 0.0, 3.0, 2.0], [0.5, 120.0, 3.0, 2.0],
                                   [0.5, 113.0, 7.0, 2.0]])
    asked = np.array([best, [0.7, 120.0, 5.0, 2.0]])  # the phase has been at n = 120
    np.testing.assert_array_equal(bound_probes(space, best, asked, free),
                                  [[0.5, 0.0, 3.0, 2.0], [0.5, 113.0, 7.0, 2.0]])


def test_the_local_search_competes_at_the_greedy_weight_only_by_default():
    """A scalar run's "local" proposals come at w = 0.95 (one in four); "all": at any."""
    p = problems.paper_size("levy")
    weights = {}
    for lw in ("greedy", "all"):
        s = Strategy(p.space, budget=80, seed=1, local_weights=lw)
        seen = []
        real = s._select

        def select(ctx, s=s, real=real, seen=seen):
            w = s._w_index % 4
            pick = real(ctx)
            if pick is not None and pick[1] == "local":
                seen.append(w)
            return pick

        s._select = select
        run_serial(s, p)
        weights[lw] = set(seen)
    assert weights["greedy"] == {3} and len(weights["all"]) > 1


class Uniform:
    """A generator that adds uniform points to the default's (drawn from the request's rng)."""

    def __init__(self, settings):
        self.dycors = Dycors(settings)
        self.requests = []

    def __call__(self, req: CandidateRequest):
        self.requests.append(req)
        u = to_space(req.space, req.rng.random((50, req.space.dim)))
        return self.dycors(req) + [(u, "random")]


def test_a_candidate_generator_plugs_in_and_its_runs_resume_exactly():
    p = problems.paper_size("rastrigin")
    gen = Uniform(Settings.default())
    s = Strategy(p.space, budget=60, seed=2, candidates=gen)
    for pr in s.ask(40):
        s.tell(pr.id, p(pr.x))
    t = Strategy.from_state(s.state_dict(), candidates=Uniform(Settings.default()))
    run_serial(s, p)
    run_serial(t, p)
    assert xs(s) == xs(t) and "random" in {r["phase"] for r in s.history}
    req = gen.requests[-1]
    assert req.rng is s.rng and req.attempt == 0 and req.weight in (0.3, 0.5, 0.8, 0.95)
    assert req.best is not None and 0.0 < req.probability <= 1.0 and req.movable.all()
    # the phase's told points, best first (a generator may centre steps on any of them)
    phase = [r for r in s.history if r["restart"] == s.restart and r["status"] == "ok"
             and r["id"] < len(s.history) - 1]
    values = [p(x) for x in req.ranked]
    assert np.array_equal(req.ranked[0], req.best) and values == sorted(values)
    assert len(req.ranked) >= min(len(phase), 2)
    plain = run_serial(Strategy(p.space, budget=60, seed=2), p)
    assert xs(plain) != xs(s)
