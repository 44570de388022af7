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
