import numpy as np
import pytest

from lccopt.optim.rbf import CubicRBF


def f_test(X):
    return np.sin(3 * X[:, 0]) + X[:, 1] ** 2 - 0.5 * X[:, 2] * X[:, 0]


def test_interpolates_data_exactly():
    rng = np.random.default_rng(0)
    X = rng.random((40, 4))
    f = f_test(X)
    s = CubicRBF().fit(X, f)
    np.testing.assert_allclose(s(X), f, rtol=0, atol=1e-8)
    assert not s.used_lstsq
    # and approximates in between (a smooth function, 40 points in 4-D)
    Xq = rng.random((200, 4))
    assert np.abs(s(Xq) - f_test(Xq)).mean() < 0.2


def test_linear_function_reproduced_everywhere():
    rng = np.random.default_rng(1)
    X = rng.random((15, 3))
    def lin(Z):
        return 2.0 - Z @ np.array([1.0, -3.0, 0.5])

    s = CubicRBF().fit(X, lin(X))
    Xq = rng.random((50, 3)) * 2 - 0.5  # also outside the data's box
    np.testing.assert_allclose(s(Xq), lin(Xq), atol=1e-9)
    np.testing.assert_allclose(s.lam, 0.0, atol=1e-9)


def test_saddle_system_side_condition():
    rng = np.random.default_rng(2)
    X = rng.random((25, 3))
    s = CubicRBF().fit(X, f_test(X))
    # P^T lambda = 0 (Eq. 9, second block row)
    P = np.hstack([np.ones((25, 1)), X])
    np.testing.assert_allclose(P.T @ s.lam, 0.0, atol=1e-9)


def test_near_duplicates_stay_finite():
    rng = np.random.default_rng(3)
    X = rng.random((20, 3))
    X = np.vstack([X, X[:5] + 1e-13, X[5:7]])  # near and exact duplicates
    f = f_test(X)
    s = CubicRBF().fit(X, f)
    v = s(rng.random((100, 3)))
    assert np.all(np.isfinite(v))
    assert np.all(np.isfinite(s.lam))
    np.testing.assert_allclose(s(X), f, atol=1e-5)
    assert np.abs(v).max() < 10 * np.abs(f).max() + 10


def test_rank_deficient_tail():
    rng = np.random.default_rng(4)
    X = rng.random((12, 4))
    X[:, 2] = 0.25  # a coordinate constant over the data: P has a dependent column
    f = f_test(X)
    s = CubicRBF().fit(X, f)
    np.testing.assert_allclose(s(X), f, atol=1e-8)
    # points on a line in 3-D (rank P = 2 < d + 1 even after dropping constant columns)
    t = np.linspace(0, 1, 6)[:, None]
    L = np.hstack([t, 2 * t, 1 - t])
    s2 = CubicRBF().fit(L, np.sin(5 * t[:, 0]))
    assert s2.used_lstsq
    np.testing.assert_allclose(s2(L), np.sin(5 * t[:, 0]), atol=1e-7)
    assert np.all(np.isfinite(s2(rng.random((20, 3)))))


def test_too_few_points():
    s = CubicRBF().fit(np.array([[0.1, 0.2, 0.3], [0.5, 0.5, 0.5]]), np.array([1.0, 2.0]))
    assert np.all(np.isfinite(s(np.random.default_rng(0).random((5, 3)))))
    np.testing.assert_allclose(s(np.array([[0.1, 0.2, 0.3]])), [1.0], atol=1e-8)


def test_incremental_fit_bit_identical_to_fresh():
    rng = np.random.default_rng(5)
    X = rng.random((60, 8))
    f = f_test(X)
    inc = CubicRBF()
    for n in (20, 21, 35, 60):
        inc.fit(X[:n], f[:n])
    fresh = CubicRBF().fit(X, f)
    Xq = rng.random((30, 8))
    assert np.array_equal(inc.lam, fresh.lam)
    assert np.array_equal(inc(Xq), fresh(Xq))


def test_gradient_matches_finite_differences():
    rng = np.random.default_rng(6)
    X = rng.random((30, 4))
    s = CubicRBF().fit(X, f_test(X))
    x = rng.random(4)
    h = 1e-6
    fd = np.array([(s(x + h * e) - s(x - h * e)) / (2 * h) for e in np.eye(4)])
    np.testing.assert_allclose(s.gradient(x), fd, rtol=1e-5, atol=1e-6)


def test_distances_are_bit_identical_to_the_coordinate_loop():
    """The broadcast path (small arrays) sums in the loop's order: same bits (exact resume)."""
    from lccopt.optim import rbf

    def loop(A, B):
        acc = np.zeros((A.shape[0], B.shape[0]))
        for k in range(A.shape[1]):
            diff = A[:, k, None] - B[None, :, k]
            acc += diff * diff
        return np.sqrt(acc)

    rng = np.random.default_rng(3)
    for m, n, d in [(1, 40, 8), (7, 13, 12), (0, 5, 3), (5, 0, 3), (3, 4, 0), (300, 300, 9)]:
        A, B = rng.random((m, d)) * 1e3, rng.random((n, d))
        assert loop(A, B).tobytes() == rbf.distances(A, B).tobytes()


def test_leave_one_out_residuals_are_those_of_fits_without_the_point():
    """Rippa's formula gives f_i - s_{-i}(x_i) of the interpolant fitted without point i."""
    rng = np.random.default_rng(0)
    X = rng.random((30, 3))
    f = np.sin(3 * X).sum(1)
    g = np.exp(X[:, 0] * 4)
    e_f, e_g = CubicRBF().fit(X, f).loo_residuals([f, g])
    for i in (0, 5, 17, 29):
        keep = np.arange(30) != i
        loo_f = f[i] - CubicRBF().fit(X[keep], f[keep])(X[i])
        loo_g = g[i] - CubicRBF().fit(X[keep], g[keep])(X[i])
        assert e_f[i] == pytest.approx(loo_f, rel=1e-7, abs=1e-12)
        assert e_g[i] == pytest.approx(loo_g, rel=1e-7, abs=1e-12)


def _quadratic(Z, seed=7):
    """A rotated, ill-conditioned quadratic with a linear part (the quadratic tail's span)."""
    rng = np.random.default_rng(seed)
    d = Z.shape[1]
    Q = np.linalg.qr(rng.standard_normal((d, d)))[0]
    H = Q @ np.diag(np.logspace(0, 3, d)) @ Q.T
    b = rng.standard_normal(d)
    return np.einsum("ij,jk,ik->i", Z, H, Z) + Z @ b + 1.5


def test_quadratic_tail_reproduces_a_quadratic_everywhere():
    rng = np.random.default_rng(8)
    X = rng.random((40, 5))  # 21 tail terms
    s = CubicRBF().fit(X, _quadratic(X), tail="quadratic")
    assert len(s.quad_i) == 15 and not s.used_lstsq
    Xq = rng.random((50, 5)) * 2 - 0.5  # also outside the data's box
    np.testing.assert_allclose(s(Xq), _quadratic(Xq), rtol=1e-8, atol=1e-7)
    np.testing.assert_allclose(s.lam, 0.0, atol=1e-7)
    # the linear tail only approximates it
    lin = CubicRBF().fit(X, _quadratic(X))
    assert np.abs(lin(Xq) - _quadratic(Xq)).max() > 1.0


def test_quadratic_tail_gradient_matches_finite_differences():
    rng = np.random.default_rng(9)
    X = rng.random((40, 4))
    s = CubicRBF().fit(X, f_test(X), tail="quadratic")
    assert len(s.quad_i) == 10
    for x in rng.random((3, 4)):
        h = 1e-6
        fd = np.array([(s(x + h * e) - s(x - h * e)) / (2 * h) for e in np.eye(4)])
        np.testing.assert_allclose(s.gradient(x), fd, rtol=1e-5, atol=1e-6)


def test_quadratic_tail_needs_points_that_determine_it():
    rng = np.random.default_rng(10)
    X = rng.random((15, 4))  # 15 tail terms: not more points than terms
    s = CubicRBF().fit(X, f_test(X), tail="quadratic")
    assert len(s.quad_i) == 0  # linear tail
    np.testing.assert_allclose(s(X), f_test(X), atol=1e-8)
    # a coordinate with two values: its square is 1 and u in the data, so it is left out
    X = rng.random((40, 4))
    X[:, 1] = np.round(X[:, 1])
    s = CubicRBF().fit(X, f_test(X), tail="quadratic")
    pairs = set(zip(s.quad_i.tolist(), s.quad_j.tolist()))
    assert (1, 1) not in pairs and (0, 1) in pairs and len(pairs) == 9
    assert not s.used_lstsq
    np.testing.assert_allclose(s(X), f_test(X), atol=1e-8)
    # a constant coordinate has no tail terms at all
    X[:, 2] = 0.5
    s = CubicRBF().fit(X, f_test(X), tail="quadratic")
    assert 2 not in s.quad_i and 2 not in s.quad_j and 2 not in s.tail_dims
    with pytest.raises(ValueError, match="tail"):
        CubicRBF().fit(X, f_test(X), tail="cubic")


def test_quadratic_tail_leave_one_out_residuals():
    rng = np.random.default_rng(11)
    X = rng.random((30, 3))
    f = np.sin(3 * X).sum(1)
    e = CubicRBF().fit(X, f, tail="quadratic").loo_residuals([f])[0]
    for i in (0, 13, 29):
        keep = np.arange(30) != i
        ref = f[i] - CubicRBF().fit(X[keep], f[keep], tail="quadratic")(X[i])
        assert e[i] == pytest.approx(ref, rel=1e-7, abs=1e-12)
