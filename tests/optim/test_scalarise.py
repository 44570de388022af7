import numpy as np
import pytest

from lccopt.optim.scalarise import asf, improvement_target, pareto_mask

REF = np.array([8508.5, 0.2941])
WORST = np.array([16000.0, 0.6])


def test_negative_below_reference_zero_at_it():
    F = REF * np.array([[0.9, 0.9], [0.5, 0.99], [0.99, 0.1]])
    assert np.all(asf(F, REF, WORST) < 0)
    assert asf(REF, REF, WORST) == 0.0
    # one objective above its target is enough to make it positive
    assert asf(REF * np.array([1.01, 0.5]), REF, WORST, rho=0.0) > 0


def test_formula_and_kappa():
    f = np.array([10000.0, 0.25])
    k = 1.0 / (WORST - REF)
    dev = k * (f - REF)
    assert asf(f, REF, WORST, rho=0.05) == pytest.approx(dev.max() + 0.05 * dev.sum())
    # kappa normalises: the worst point scores 1 per objective
    assert asf(WORST, REF, WORST, rho=0.05) == pytest.approx(1.0 + 0.05 * 2)


def test_monotone_in_each_objective():
    rng = np.random.default_rng(0)
    F = REF + (WORST - REF) * rng.uniform(-0.5, 1.5, size=(500, 2))
    g = asf(F, REF, WORST)
    for i in range(2):
        G = F.copy()
        G[:, i] += (WORST[i] - REF[i]) * rng.uniform(1e-3, 0.5, size=500)
        assert np.all(asf(G, REF, WORST) > g)  # strictly, because rho > 0


def test_rho_role():
    # f1 is the most deviated objective; raising f2 (not the max) changes g only via rho.
    f = np.array([[12000.0, 0.30], [12000.0, 0.35]])
    g0 = asf(f, REF, WORST, rho=0.0)
    assert g0[0] == g0[1]  # pure Chebyshev ignores the other objective
    g = asf(f, REF, WORST, rho=0.05)
    assert g[1] - g[0] == pytest.approx(0.05 * 0.05 / (WORST[1] - REF[1]))
    # larger rho, larger weight of the sum term
    assert np.all(asf(f, REF, WORST, rho=0.2) > g)


def test_shapes_and_validation():
    assert asf(np.zeros((7, 2)), REF, WORST).shape == (7,)
    assert np.ndim(asf(REF, REF, WORST)) == 0
    with pytest.raises(ValueError):
        asf(REF, REF, REF)
    with pytest.raises(ValueError):
        asf(np.zeros(3), REF, WORST)
    np.testing.assert_allclose(improvement_target([10635.6, 0.3676]), [8508.48, 0.29408])


def test_pareto_mask_small():
    F = np.array([[1, 5], [2, 2], [3, 1], [3, 3], [2, 2], [5, 5], [np.nan, 0], [4, 1]], float)
    assert pareto_mask(F).tolist() == [True, True, True, False, True, False, False, False]


def test_pareto_mask_matches_brute_force():
    rng = np.random.default_rng(1)
    F = rng.integers(0, 6, size=(300, 3)).astype(float)
    naive = [not any(np.all(G <= f) and np.any(G < f) for G in F) for f in F]
    assert pareto_mask(F).tolist() == naive
