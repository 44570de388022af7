"""Variance-based sensitivity indices of a surrogate, against functions whose indices are known."""

from __future__ import annotations

import numpy as np
from scipy.stats import qmc

from lccopt.report.sensitivity import sobol_indices


def test_an_additive_function_gives_its_known_shares():
    # f = 3 u1 + u2 (+ nothing from u3), u uniform: Var = (9 + 1) / 12, S1 = 0.9, S2 = 0.1, S3 = 0
    x = qmc.LatinHypercube(3, seed=1).random(60)
    f = 3 * x[:, 0] + x[:, 1]
    ind = sobol_indices(x, f, [0, 0, 0], [1, 1, 1], [False] * 3, [False] * 3)
    np.testing.assert_allclose(ind.first, [0.9, 0.1, 0.0], atol=0.02)
    np.testing.assert_allclose(ind.total, [0.9, 0.1, 0.0], atol=0.02)
    assert ind.loo_error < 1e-3      # the RBF's linear tail holds it exactly


def test_the_ishigami_function_with_its_interaction():
    # Ishigami (a = 7, b = 0.1) on [-pi, pi]^3: S = 0.314, 0.442, 0; ST = 0.558, 0.442, 0.244
    x = qmc.LatinHypercube(3, seed=2).random(600) * 2 * np.pi - np.pi
    f = np.sin(x[:, 0]) + 7 * np.sin(x[:, 1]) ** 2 + 0.1 * x[:, 2] ** 4 * np.sin(x[:, 0])
    ind = sobol_indices(x, f, [-np.pi] * 3, [np.pi] * 3, [False] * 3, [False] * 3)
    np.testing.assert_allclose(ind.first, [0.314, 0.442, 0.0], atol=0.06)
    np.testing.assert_allclose(ind.total, [0.558, 0.442, 0.244], atol=0.06)


def test_integers_and_log_scales_are_sampled_as_the_optimiser_sees_them():
    # f = ln(k) for k searched on a log scale over [1, 100] is linear in the unit box: all its
    # variance; an integer that takes 2 values with a step of 1: f = k2 adds Var 1/4
    rng = np.random.default_rng(3)
    k = np.exp(rng.uniform(0, np.log(100), 80))
    n = rng.integers(0, 2, 80).astype(float)
    x = np.column_stack([k, n])
    f = np.log(k) / np.log(100) * np.sqrt(3) + n          # Var: 1/4 (log part) + 1/4 (integer)
    ind = sobol_indices(x, f, [1, 0], [100, 1], [False, True], [True, False])
    np.testing.assert_allclose(ind.total, [0.5, 0.5], atol=0.03)


def test_too_few_points_or_a_flat_objective_give_none():
    x = np.random.default_rng(0).random((4, 3))
    assert sobol_indices(x, x[:, 0], [0] * 3, [1] * 3, [False] * 3, [False] * 3) is None
    x = np.random.default_rng(0).random((40, 3))
    assert sobol_indices(x, np.ones(40), [0] * 3, [1] * 3, [False] * 3, [False] * 3) is None
