"""What the reference model must keep from the paper (issue 8): the ballast track is stiffer
than the ERS, the reference F_rms is the paper's within 15 %, the Table 7 F_max order, and
a longer Type II strip lowering F_rms of the paper's min-F_rms design (Table 5), and
the paper's vehicle (Eq. A.3 as printed) against its closed-form static load."""

import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.problem import evaluate
from lccopt.vti.deflection import static_rail_deflection
from lccopt.vti.newmark import integrate
from lccopt.vti.track import WinklerBeam, build_track
from lccopt.vti.vehicle import build_vehicle

MN = 1e6
REFERENCE_X = np.array([1120 * MN, 1120 * MN, 1120 * MN, 8, 6, 6, 4, 0])
TABLE7 = {  # Table 7 designs in the paper's F_max order, lowest first
    "MOO": [214, 155, 50, 5, 6, 7, 3, 0],
    "min F_max": [103, 50, 72, 4, 6, 6, 4, 0],
    "reference": [1120, 1120, 1120, 8, 6, 6, 4, 0],
    "min E_max": [50, 77, 50, 1, 7, 5, 4, 0],
}


@pytest.fixture(scope="module")
def case():
    return load_case("configs/reference.yaml")


def x_of(d):
    return np.array([d[0] * MN, d[1] * MN, d[2] * MN, *d[3:]], dtype=float)


def test_the_ballast_track_is_stiffer_than_the_ers(case):
    track = build_track(case.scenario(), case.track_design(REFERENCE_X))
    a = track.interface[0]
    load = build_vehicle(case.scenario().vehicle).static_wheel_load
    ballast = static_rail_deflection(track, load, np.linspace(a - 20.0, a - 19.4, 7)).mean()
    ers = static_rail_deflection(track, load, np.linspace(a + 2.5, a + 3.5, 7)).mean()
    assert 0 < ballast < 0.7 * ers


def test_reference_f_rms_within_15_percent_of_the_paper(case):
    f_rms = evaluate(case, REFERENCE_X).objectives["F_rms"]
    assert f_rms == pytest.approx(49667.0, rel=0.15)


def test_table_7_designs_keep_the_papers_f_max_order(case):
    f_max = {name: evaluate(case, x_of(d)).objectives["F_max"] for name, d in TABLE7.items()}
    assert sorted(f_max, key=f_max.get) == list(TABLE7)


@pytest.mark.slow
def test_a_longer_type_ii_strip_lowers_f_rms_of_the_papers_min_f_rms_design(case):
    """Table 5: the min-F_rms design takes x_l = 120 (the strip over all 12 m of the ERS). The
    force zone runs to the far edge of the ERS, so the whole strip counts: F_rms falls from
    x_l = 30 to 60, 90 and 120. (With the zone ending 3 m into the ERS it was the same to 1 N
    for 60, 90 and 120.)"""
    f_rms = [evaluate(case, x_of([1199, 1199, 1199, 0, 5, 7, 4, xl])).objectives["F_rms"]
             for xl in (30, 60, 90, 120)]
    assert np.all(np.diff(f_rms) < -10.0)                     # N: each 3 m of strip lowers it


def test_papers_bogie_shares_the_weight_with_the_second_wheelset(case):
    """Eq. (A.3) as printed: on a rigid rail the modelled wheel carries m_w g + (m_c + m_b) g / 2
    (the Hertz spring in series with k_s1 shifts it by k_s1/k_w = 0.2 %)."""
    veh = build_vehicle(case.scenario().vehicle)
    assert veh.model == "paper" and veh.K[1, 1] == pytest.approx(veh.k_s2 + 2 * veh.k_s1)
    rigid = WinklerBeam.build(20.0, 0.1, 210e9 * 2.337e-5, 7800 * 6.977e-3, 1e13)
    hist = integrate(rigid, 1e-4, 0.0, 10.0, 50, vehicle=veh)
    m_c, m_b, m_w = veh.masses
    expected = (m_w + (m_c + m_b) / 2) * veh.gravity
    assert hist.contact_force[0] == pytest.approx(expected, rel=3e-3)
    assert veh.static_wheel_load == pytest.approx(expected)
    # exact: the weight splits between the wheel's path (k_s1 in series with k_w) and k_s1
    k1, kw = veh.k_s1, veh.contact_stiffness
    series = k1 * kw / (k1 + kw)
    exact = m_w * veh.gravity + (m_c + m_b) * veh.gravity * series / (series + k1)
    assert hist.contact_force[0] == pytest.approx(exact, rel=1e-3)
