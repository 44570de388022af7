"""The benchmark problems: each stated optimum is attained at its stated point, the point is
a valid point of the space, and nothing checked is better (so that a typo cannot hide)."""

import math

import numpy as np
import pytest

from benchmarks.support import problems as P


def _tol(f_opt):
    return 1e-9 + 1e-9 * abs(f_opt)


@pytest.mark.parametrize("name", P.BENCHMARK)
def test_optimum_attained_at_a_valid_point(name):
    p = P.get(name)
    assert p.name == name
    x = p.space.check(p.x_opt, what=f"{name} x_opt")  # in bounds, integers integral
    assert math.isfinite(p.f_opt)
    assert p(x) == pytest.approx(p.f_opt, rel=1e-12, abs=1e-12)
    assert p.category in P.CATEGORIES and p.source
    assert 4 <= p.space.dim <= 12


@pytest.mark.parametrize("name", P.BENCHMARK)
def test_nothing_better_along_coordinates_or_at_random(name):
    """Every coordinate line through x_opt (all integers; 2001 continuous values) and 5000
    random points: no value below f_opt (a necessary condition of a global minimum)."""
    p = P.get(name)
    sp = p.space
    for i in range(sp.dim):
        vals = (np.arange(sp.lb[i], sp.ub[i] + 1) if sp.int_mask[i]
                else np.linspace(sp.lb[i], sp.ub[i], 2001))
        X = np.repeat(p.x_opt[None, :], len(vals), axis=0)
        X[:, i] = vals
        assert p(X).min() >= p.f_opt - _tol(p.f_opt), f"{name}: coordinate {i}"
    rng = np.random.default_rng(1)
    X = sp.snap(sp.lb + rng.random((5000, sp.dim)) * (sp.ub - sp.lb))
    assert p(X).min() >= p.f_opt - _tol(p.f_opt)


def test_coverage_of_the_benchmark_set():
    ps = [P.get(n) for n in P.BENCHMARK]
    assert len(ps) >= 20
    pure = [p for p in ps if p.space.int_mask.all()]
    mixed = [p for p in ps if p.space.int_mask.any() and not p.space.int_mask.all()]
    assert len(pure) >= 5 and len(mixed) >= 5
    sizes = {int(hi - lo + 1)
             for p in ps for lo, hi, m in zip(p.space.lb, p.space.ub, p.space.int_mask) if m}
    assert min(sizes) == 3 and 100 in sizes
    assert {p.category for p in ps} == set(P.CATEGORIES)
    assert len({p.name for p in ps}) == len(ps)


def _exhaustive_min(p, chunk=500_000):
    grid_axes = [np.arange(lo, hi + 1) for lo, hi in zip(p.space.lb, p.space.ub)]
    G = np.stack(np.meshgrid(*grid_axes, indexing="ij"), axis=-1).reshape(-1, len(grid_axes))
    return min(float(p(G[k:k + chunk]).min()) for k in range(0, len(G), chunk))


@pytest.mark.parametrize("name", ["gear", "trap_int6", "quad_int12"])
def test_global_optimum_of_small_integer_problems_by_enumeration(name):
    p = P.get(name)
    assert _exhaustive_min(p) >= p.f_opt - _tol(p.f_opt)


def test_gear4_optimum_by_enumeration():
    """gear4's continuous x5 has a closed-form best value for each integer assignment:
    with h = 1e6 x1 x2/(x3 x4) - 144279.32477276, min over x5 in [0, 100] is -h (h <= 0),
    h (0 < h <= 100) or 9h - 800 (h > 100); check that f* is the minimum of that."""
    p = P.get("gear4")
    a = np.arange(12, 61, dtype=float)
    A, B, C, D = np.meshgrid(a, a, a, a, indexing="ij")
    h = 1e6 * A * B / (C * D) - P._GEAR_TARGET
    best = np.where(h <= 0, -h, np.where(h <= 100, h, 9 * h - 800)).min()
    assert best == pytest.approx(p.f_opt, rel=1e-9)
    # and the closed form agrees with the function at a few points
    x = np.array([[19, 16, 43, 49, 0.0], [19, 16, 43, 49, 50.0], [12, 12, 60, 60, 3.0]])
    r = 1e6 * x[:, 0] * x[:, 1] / (x[:, 2] * x[:, 3])
    expect = -r + 2 * x[:, 4] + P._GEAR_TARGET + 10 * np.maximum(0, r - x[:, 4] - P._GEAR_TARGET)
    np.testing.assert_allclose(p(x), expect)


def test_existing_names_still_work():
    for n in ["ackley", "ackley8", "gear", "nvs09"]:
        assert P.get(n).space.dim in (4, 8, 10)
    with pytest.raises(KeyError):
        P.get("nope")


@pytest.mark.parametrize("name", P.FRESH)
def test_fresh_instances_have_their_stated_optimum(name):
    """Each seed's instance: f* at x*, a valid point; nothing better along every coordinate
    line through x* or at random points (rotated families included)."""
    for seed in (0, 7, 101):
        p = P.get(name, seed)
        sp = p.space
        assert p.name == name and sp.dim == 8 and p.category in P.CATEGORIES
        x = sp.check(p.x_opt, what=f"{name} x_opt")
        assert p(x) == pytest.approx(p.f_opt, rel=1e-12, abs=1e-12)
        assert int(sp.int_mask.sum()) == (8 if name.endswith("_int") else 5)
        if name.startswith("fresh5-"):
            assert set((sp.ub - sp.lb)[sp.int_mask]) == {4.0}  # 5 values each
        rng = np.random.default_rng(seed)
        for i in range(sp.dim):
            vals = (np.arange(sp.lb[i], sp.ub[i] + 1) if sp.int_mask[i]
                    else np.linspace(sp.lb[i], sp.ub[i], 2001))
            X = np.repeat(p.x_opt[None, :], len(vals), axis=0)
            X[:, i] = vals
            assert p(X).min() >= p.f_opt - _tol(p.f_opt), f"{name} seed {seed}: coordinate {i}"
        X = sp.snap(sp.lb + rng.random((5000, sp.dim)) * (sp.ub - sp.lb))
        assert p(X).min() >= p.f_opt - _tol(p.f_opt)


def test_fresh_instances_differ_by_seed_and_repeat_for_one():
    for name in P.FRESH:
        a, b, c = P.get(name, 3), P.get(name, 3), P.get(name, 4)
        np.testing.assert_array_equal(a.x_opt, b.x_opt)
        assert a.f_opt == c.f_opt  # the family's own optimum value
        assert not (np.array_equal(a.x_opt, c.x_opt) and np.array_equal(a.space.ub, c.space.ub))
        x = a.space.snap(a.space.lb + 0.37 * (a.space.ub - a.space.lb))
        assert a(x) == b(x)
    masks = {tuple(P.get("fresh-ackley", s).space.int_mask) for s in range(10)}
    assert len(masks) > 3  # which variables are integer is drawn too
