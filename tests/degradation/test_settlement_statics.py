"""Statics in the supports' coordinates (lccopt/degradation/statics.py) against the full static
equilibrium of the track with unilateral supports (lccopt/vti/unilateral.py)."""

import numpy as np
import pytest

from lccopt.degradation.statics import ZoneStatics
from lccopt.vti.unilateral import rest_state, sleeper_supports, static_equilibrium
from lccopt.vti.wheels import contact_vectors
from tests.vti.test_voids import discrete_track

OFFSETS = np.array([0.0, 2.5])
LOADS = np.array([96e3, 90e3])


@pytest.fixture(scope="module")
def voided():
    """A track with a stiffness step and a settled profile: voids under some sleepers."""
    tr = discrete_track(n_sleepers=40, stiff_from=15.0, stiff_factor=4.0)
    idx = np.arange(len(tr.sleeper_x))
    soft = idx[tr.sleeper_x < 15.0]
    sup = sleeper_supports(tr, soft)
    x = sup.x
    gap = 2e-3 + 1.5e-3 * np.exp(-((x - 12.0) / 1.0) ** 2)
    gap[x > 13.5] = 0.5e-3                 # next to the stiff side: hanging
    gap[x < 3.0] = 0.0
    return tr, sup.with_gaps(gap)


def full_state(tr, sup, positions, loads):
    rhs = np.zeros(tr.K.shape[0])
    _, idx, vals = contact_vectors(tr, positions)
    np.add.at(rhs, idx.ravel(), (vals * loads[:, None]).ravel())
    return static_equilibrium(tr.K, rhs, sup)


def test_wheel_cases_give_the_full_static_equilibrium(voided):
    tr, sup = voided
    n = 12
    zs = ZoneStatics(tr, sup)
    cases = zs.wheel_cases(sup.x[:n], OFFSETS, LOADS, direction=-1.0)
    forces, contact = zs.peak_forces(sup.gap, cases)
    assert (~contact).any() and contact.any()          # voids closed by some wheels, not all
    for w in range(2):
        for i in range(n):
            lead = sup.x[i] - OFFSETS[w]                 # running towards -x
            u, c = full_state(tr, sup, lead + OFFSETS, LOADS)
            p = u[sup.dof[i]] + sup.rest[i] - sup.gap[i]
            expected = sup.stiffness[i] * p if c[i] else 0.0
            assert forces[w, i] == pytest.approx(expected, rel=1e-9, abs=1e-6)
            assert np.array_equal(contact[w * n + i], c)


def test_rest_state_is_the_full_one(voided):
    tr, sup = voided
    level_dofs = tr.rail_w[tr.rail_w >= 0]
    void, level, contact = ZoneStatics(tr, sup, level_dofs).rest(sup.gap)
    u = rest_state(tr, sup)
    assert void.max() > 0.5e-3                           # the hanging sleepers
    np.testing.assert_allclose(void, np.maximum(sup.gap - sup.rest - u[sup.dof], 0.0),
                               atol=1e-12)
    np.testing.assert_allclose(level, u[level_dofs], atol=1e-12)
    # the level anywhere along the rail: the elements' Hermite interpolation of the same state
    x = np.linspace(1.0, tr.node_x[-1] - 1.0, 301)
    _, at, _ = ZoneStatics(tr, sup, level_x=x).rest(sup.gap)
    _, idx, vals = contact_vectors(tr, x)
    np.testing.assert_allclose(at, np.sum(vals * u[idx], axis=1), atol=1e-12)


def test_load_shedding_jacobian_is_the_derivative(voided):
    tr, sup = voided
    zs = ZoneStatics(tr, sup)
    cases = zs.wheel_cases(sup.x[:12], OFFSETS, LOADS, direction=-1.0)
    f0, contact = zs.peak_forces(sup.gap, cases)
    jac = zs.peak_jacobian(cases, contact)
    h = 1e-8
    for j in (0, 5, 9, 11, 20):
        g = sup.gap.copy()
        g[j] += h
        f1, c1 = zs.peak_forces(g, cases, contact)
        assert np.array_equal(c1, contact)
        np.testing.assert_allclose((f1 - f0) / h, jac[..., j], rtol=1e-5, atol=1e-3 * 1e6)
    # a sleeper that settles sheds load; a hanging sleeper's load does not change
    own = jac[:, np.arange(12), np.arange(12)]
    loaded = f0 > 0
    assert np.all(own[loaded] < -1e6) and np.all(own[~loaded] == 0.0)
