"""Each design variable changes the assembled track exactly as documented in lccopt/vti/track.py."""

import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.vti.track import build_track


@pytest.fixture(scope="module")
def case():
    return load_case("configs/reference.yaml")


def design(case, **changes):
    x = case.reference.copy()
    for name, value in changes.items():
        x[case.names.index(name)] = value
    return case.check_design(x)


def rail_dof_at(track, pos):
    return track.rail_w[int(np.argmin(np.abs(track.node_x - pos)))]


def test_sleeper_positions_follow_the_spans(case):
    t = build_track(case.scenario(), case.track_design(design(case, x_s1=7, x_s2=3, x_s3=5)))
    # x_s3 = slab edge to sleeper 1, then x_s2, x_s1, then the standard 0.6 m
    assert t.entry_sleeper_x[:5] == pytest.approx([99.5, 99.2, 98.5, 97.9, 97.3])
    ref = build_track(case.scenario(), case.track_design(case.reference))
    # the first sleeper 0.4 m away
    assert ref.entry_sleeper_x[:4] == pytest.approx([99.6, 99.0, 98.4, 97.8])
    assert np.all(np.diff(ref.entry_sleeper_x[3:]) == pytest.approx(-0.6))
    assert ref.exit_sleeper_x[0] == pytest.approx(112.4)
    for track in (t, ref):                 # every sleeper sits on a rail node and on its pad
        for pos, dof in zip(track.entry_sleeper_x[:25], track.entry_sleeper_dof[:25]):
            assert track.K[rail_dof_at(track, pos), dof] < 0


def test_railpads_stiffness_and_damping_at_the_right_seats(case):
    x = design(case, x_r1=300e6, x_r2=200e6, x_r3=100e6)
    t = build_track(case.scenario(), case.track_design(x))
    pad_c_per_k = 120e3 / 1120e6
    expected = [100e6, 200e6, 300e6, 1120e6, 1120e6]      # sleeper 1 (nearest) carries x_r3
    for pos, dof, k in zip(t.entry_sleeper_x, t.entry_sleeper_dof, expected):
        r = rail_dof_at(t, pos)
        assert -t.K[r, dof] == pytest.approx(k)
        assert -t.C[r, dof] == pytest.approx(k * pad_c_per_k)   # damping scales with stiffness
    assert list(t.entry_pad_stiffness[:4]) == pytest.approx(expected[:4])


@pytest.mark.parametrize("n_strong", [0, 1, 8, 20])
def test_strengthened_sleepers(case, n_strong):
    t = build_track(case.scenario(), case.track_design(design(case, x_n=n_strong)))
    ss, std = case.track["strengthened_sleeper"], case.track
    for i, dof in enumerate(t.entry_sleeper_dof[:25]):
        strong = i < n_strong
        assert t.M[dof, dof] == pytest.approx(ss["mass"] if strong else std["sleeper"]["mass"])
        pad = -t.K[rail_dof_at(t, t.entry_sleeper_x[i]), dof]
        assert t.K[dof, dof] - pad == pytest.approx(ss["support_stiffness"] if strong
                                                   else std["support"]["stiffness"])
        assert t.entry_support_damping[i] == (ss["support_damping"] if strong
                                              else std["support"]["damping"])
    assert t.entry_strengthened.sum() == n_strong


@pytest.mark.parametrize("x_l", [1, 37, 120])
def test_type_ii_strip_length(case, x_l):
    """The Type II compound replaces the standard one exactly on [100, 100 + 0.1 x_l] m."""
    ref = build_track(case.scenario(), case.track_design(case.reference))
    t = build_track(case.scenario(), case.track_design(design(case, x_l=x_l)))
    assert t.type_ii_end == pytest.approx(100.0 + 0.1 * x_l)
    dk = (t.K - ref.K).tocsr()
    dc = (t.C - ref.C).tocsr()
    ers = case.track["ers"]
    k1, k2 = ers["compound"]["stiffness"], ers["type_ii_compound"]["stiffness"]
    m_rail = case.track["rail"]["density"] * case.track["rail"]["area"]
    c1 = 2 * ers["compound"]["damping_ratio"] * np.sqrt(k1 * m_rail)
    c2 = 2 * ers["type_ii_compound"]["damping_ratio"] * np.sqrt(k2 * m_rail)
    x, end = t.node_x, 100.0 + 0.1 * x_l
    in_strip = (x[:-1] >= 100.0 - 1e-9) & (x[1:] <= end + 1e-9)     # elements under the strip
    L = np.diff(x)
    # the rail's own diagonal gets k∫N1² = k·156L/420 from each adjacent element
    per_node = np.zeros(len(x))
    per_node[:-1] += np.where(in_strip, 156 * L / 420, 0.0)
    per_node[1:] += np.where(in_strip, 156 * L / 420, 0.0)
    w = t.rail_w
    ok = w >= 0
    assert dk[w[ok], w[ok]].A1 == pytest.approx((k2 - k1) * per_node[ok], abs=1e-6 * k1)
    assert dc[w[ok], w[ok]].A1 == pytest.approx((c2 - c1) * per_node[ok], abs=1e-6 * c1)
    # nothing else in the track changes: rows touched are the strip's rail and slab dofs only
    touched_rail = np.isin(w[ok], np.unique(dk.nonzero()[0]))
    assert np.array_equal(touched_rail, per_node[ok] > 0)


def test_dofs_are_banded(case):
    t = build_track(case.scenario(), case.track_design(case.reference))
    coo = t.K.tocoo()
    assert np.max(np.abs(coo.row - coo.col)) <= 10
    assert t.n_dofs < 4500
