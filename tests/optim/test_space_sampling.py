import numpy as np
import pytest

from lccopt.optim.sampling import latin_hypercube
from lccopt.optim.space import DesignSpace


def paper_space(given=()):
    return DesignSpace(
        names=["r1", "r2", "r3", "n", "s1", "s2", "s3", "l"],
        lower=[50, 50, 50, 0, 3, 3, 3, 0], upper=[1200, 1200, 1200, 20, 7, 7, 7, 120],
        integer=[False] * 3 + [True] * 5, given=list(given))


@pytest.mark.parametrize("kwargs, match", [
    (dict(lower=[1.0], upper=[0.0], integer=[False]), "lower bound"),
    (dict(lower=[0.0], upper=[2.5], integer=[True]), "must be integers"),
    (dict(lower=[0.0], upper=[2.0], integer=[True], given=[[1.5]]), "not integral"),
    (dict(lower=[0.0], upper=[2.0], integer=[False], given=[[3.0]]), "outside"),
    (dict(lower=[0.0], upper=[2.0], integer=[False], given=[[1.0], [1.0]]), "same point"),
    (dict(lower=[0.0, 1.0], upper=[2.0], integer=[False]), "entries"),
])
def test_space_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        DesignSpace(names=["a"], **kwargs)


def test_space_unit_mapping_and_snap():
    sp = paper_space()
    x = np.array([50, 1200, 625, 10, 3, 7, 5, 60.0])
    u = sp.to_unit(x)
    assert u.min() == 0.0 and u.max() == 1.0
    np.testing.assert_allclose(sp.from_unit(u), x)
    snapped = sp.snap(np.array([-5, 2000, 600.3, 10.4, 2.0, 7.6, 4.5, 59.5]))
    assert snapped.tolist() == [50, 1200, 600.3, 10, 3, 7, 4, 60]
    assert sp.n_grid == np.inf
    assert DesignSpace(["a", "b"], [0, 1], [2, 3], [True, True]).n_grid == 9


def test_lhs_distinct_in_bounds_and_integral():
    sp = paper_space()
    X = latin_hypercube(sp, 19, np.random.default_rng(3))
    assert X.shape == (19, 8)
    assert np.all(X >= sp.lb) and np.all(X <= sp.ub)
    assert np.all(X[:, 3:] == np.rint(X[:, 3:]))
    assert len(np.unique(X, axis=0)) == 19
    # Continuous columns keep the Latin property: one point per stratum.
    for j in range(3):
        strata = np.floor(sp.to_unit(X)[:, j] * 19).astype(int)
        assert sorted(strata) == list(range(19))


def test_lhs_integer_end_values_not_undersampled():
    # 0..2 stretched to [-0.5, 2.5] before rounding: each value owns exactly a third of
    # the strata. Plain rounding of [0, 2] would give the end values only a quarter each.
    sp = DesignSpace(["k", "y"], [0, 0], [2, 1], [True, False])
    X = latin_hypercube(sp, 300, np.random.default_rng(0))
    counts = np.bincount(X[:, 0].astype(int), minlength=3)
    assert counts.tolist() == [100, 100, 100]


def test_lhs_small_grid_and_exclude():
    sp = DesignSpace(["a", "b"], [0, 0], [1, 2], [True, True])  # 6 points
    rng = np.random.default_rng(1)
    X = latin_hypercube(sp, 10, rng)
    assert len(X) == 6 and len(np.unique(X, axis=0)) == 6
    excl = np.array([[0, 0], [1, 2]], dtype=float)
    Y = latin_hypercube(sp, 10, rng, exclude=excl)
    assert len(Y) == 4
    assert not any((Y == e).all(axis=1).any() for e in excl)


def test_lhs_is_reproducible():
    sp = paper_space()
    a = latin_hypercube(sp, 19, np.random.default_rng(7))
    b = latin_hypercube(sp, 19, np.random.default_rng(7))
    assert np.array_equal(a, b)


def log_space(given=()):
    """The paper's space with its pad stiffnesses (N/m) searched on a log scale."""
    return DesignSpace(
        names=["r1", "r2", "r3", "n", "s1", "s2", "s3", "l"],
        lower=[50e6] * 3 + [0, 3, 3, 3, 0], upper=[1200e6] * 3 + [20, 7, 7, 7, 120],
        integer=[False] * 3 + [True] * 5, given=list(given), log=[True] * 3 + [False] * 5)


@pytest.mark.parametrize("kwargs, match", [
    (dict(lower=[0.0], upper=[2.0], integer=[False], log=[True]), "positive bounds"),
    (dict(lower=[-1.0], upper=[2.0], integer=[False], log=[True]), "positive bounds"),
    (dict(lower=[1.0], upper=[4.0], integer=[True], log=[True]), "continuous"),
    (dict(lower=[1.0], upper=[4.0], integer=[False], log=[True, False]), "entries"),
])
def test_log_scale_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        DesignSpace(names=["a"], **kwargs)


def test_log_scale_maps_equal_ratios_to_equal_steps():
    sp = log_space()
    x = np.array([50e6, 1200e6, np.sqrt(50e6 * 1200e6), 10, 3, 7, 5, 60.0])
    u = sp.to_unit(x)
    np.testing.assert_allclose(u[:3], [0.0, 1.0, 0.5], atol=1e-12)  # geometric mean: the middle
    assert u[3:].tolist() == paper_space().to_unit(x)[3:].tolist()   # the others: unchanged
    np.testing.assert_allclose(sp.from_unit(u), x, rtol=1e-12)
    # 100 -> 200 MN/m is as far as 600 -> 1200 MN/m
    a, b = sp.to_unit(np.array([[100e6] * 3 + [0] * 5, [200e6] * 3 + [0] * 5])), \
        sp.to_unit(np.array([[600e6] * 3 + [0] * 5, [1200e6] * 3 + [0] * 5]))
    np.testing.assert_allclose(a[1, 0] - a[0, 0], b[1, 0] - b[0, 0], rtol=1e-12)
    assert DesignSpace.from_dict(sp.to_dict()).log == sp.log
    assert "log" not in paper_space().to_dict()  # a linear space's dict is as before


def test_linear_space_maps_bit_for_bit_as_before():
    # No log variable: to_unit/from_unit are the plain affine maps (runs resume bit for bit).
    sp = paper_space()
    X = latin_hypercube(sp, 19, np.random.default_rng(3))
    assert np.array_equal(sp.to_unit(X), (X - sp.lb) / sp.span)
    U = np.random.default_rng(4).random((5, 8))
    assert np.array_equal(sp.from_unit(U), sp.lb + U * sp.span)


def test_lhs_on_a_log_scale_has_strata_of_equal_ratio():
    sp = log_space()
    X = latin_hypercube(sp, 24, np.random.default_rng(5))
    assert np.all(X >= sp.lb) and np.all(X <= sp.ub)
    for j in range(3):  # one point per stratum of ln x: as many below 245 MN/m as above
        strata = np.floor(sp.to_unit(X)[:, j] * 24).astype(int)
        assert sorted(strata) == list(range(24))
        assert np.sum(X[:, j] < np.sqrt(50e6 * 1200e6)) == 12
    # on a linear scale only about a sixth would lie below 245 MN/m
    Y = latin_hypercube(paper_space(), 24, np.random.default_rng(5))
    assert np.sum(Y[:, 0] < 245) <= 5


# -- an on/off switch: a variable whose 0 leaves a component out (the Type II strip) ----------

def strip_space(switch: bool) -> DesignSpace:
    return DesignSpace(names=["r", "l"], lower=[0.0, 0], upper=[1.0, 120], integer=[False, True],
                       switch=[False, switch])


@pytest.mark.parametrize("kwargs, match", [
    (dict(lower=[1.0], upper=[5.0], integer=[True], switch=[True]), "on/off switch"),
    (dict(lower=[0.0], upper=[0.0], integer=[True], switch=[True]), "on/off switch"),
    (dict(lower=[1.0], upper=[5.0], integer=[False], log=[True], switch=[True]), "on/off switch"),
    (dict(lower=[0.0], upper=[5.0], integer=[False], switch=[True, False]), "entries"),
])
def test_switch_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        DesignSpace(names=["a"], **kwargs)


def test_switch_gives_off_half_the_search_range_and_maps_back():
    sp = strip_space(True)
    assert sp.search_lb.tolist() == [0.0, -120.0] and sp.search_ub.tolist() == [1.0, 120.0]
    x = np.array([[0.5, 0.0], [0.5, 1.0], [0.5, 120.0]])
    assert sp.to_search(x)[:, 1].tolist() == [-60.0, 1.0, 120.0]
    assert sp.to_unit(x)[:, 1].tolist() == [0.25, 121 / 240, 1.0]
    # the whole off half is 0; the on half is the value itself
    s = np.array([[0.5, -120.0], [0.5, -0.2], [0.5, 37.0]])
    assert sp.snap(sp.from_search(s))[:, 1].tolist() == [0.0, 0.0, 37.0]
    back = DesignSpace.from_dict(sp.to_dict())
    assert back.switch == [False, True] and np.array_equal(back.search_lb, sp.search_lb)
    assert "switch" not in strip_space(False).to_dict()   # older spaces read the same
    assert strip_space(True).without_switches().to_dict() == strip_space(False).to_dict()


def test_lhs_draws_off_as_often_as_on_with_a_switch():
    rng = np.random.default_rng(3)
    with_switch = latin_hypercube(strip_space(True), 200, rng)[:, 1]
    plain = latin_hypercube(strip_space(False), 200, np.random.default_rng(3))[:, 1]
    assert 0.45 <= np.mean(with_switch == 0) <= 0.55
    assert np.mean(plain == 0) < 0.03                       # one value of 121
    on = with_switch[with_switch > 0]
    assert on.min() >= 1 and on.max() <= 120 and len(np.unique(on)) > 60   # the range covered
