"""Unilateral sleeper supports (voids): a voided sleeper carries no load until the rail closes
its gap, against closed forms from linear solves of the track without that support."""

from dataclasses import dataclass, field

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from lccopt.config import load_case
from lccopt.vti.assembly import Assembler, beam_stiffness, hermite_gram
from lccopt.vti.newmark import integrate
from lccopt.vti.track import build_track
from lccopt.vti.unilateral import GRAVITY, rest_state, sleeper_supports
from lccopt.vti.vehicle import build_vehicle
from lccopt.vti.wheels import contact_vector
from tests.conftest import CONFIGS

EI = 210e9 * 2.337e-5
M_RAIL = 7800 * 6.977e-3


@dataclass
class DiscreteTrack:
    """A uniform ballast track (rail, pads, sleepers, supports), pinned rail ends: the
    TrackModel fields the unilateral supports and the settlement iteration use."""
    node_x: np.ndarray
    rail_w: np.ndarray
    rail_th: np.ndarray
    M: sp.csr_matrix
    C: sp.csr_matrix
    K: sp.csr_matrix
    sleeper_x: np.ndarray
    sleeper_dof: np.ndarray
    support_stiffness: np.ndarray
    support_damping: np.ndarray
    info: dict = field(default_factory=dict)


def discrete_track(n_sleepers=60, spacing=0.6, element=0.1, k_pad=1120e6, c_pad=120e3,
                   m_sleeper=125.5, k_b=45e6, c_b=96e3, stiff_from=None, stiff_factor=1.0):
    """Sleepers at (i + 1) * spacing, numbered from the far end (+x) first, as the entry side
    of a built track numbers them from the interface. ``stiff_from`` [m]: supports beyond it
    are ``stiff_factor`` times stiffer (a stiffness step)."""
    length = (n_sleepers + 1) * spacing
    n_el = int(round(length / element))
    node_x = np.arange(n_el + 1) * element
    sx = (np.arange(n_sleepers) + 1) * spacing
    snode = np.rint(sx / element).astype(int)
    # dofs along the track: w, th per node, the sleeper after its node's rail dofs
    keys = ([(i, 0) for i in range(n_el + 1)] + [(i, 1) for i in range(n_el + 1)]
            + [(i, 2) for i in snode])
    order = sorted(range(len(keys)), key=lambda j: keys[j])
    full = np.empty(len(keys), int)
    full[order] = np.arange(len(keys))
    fixed = np.zeros(len(keys), bool)
    fixed[full[[0, n_el]]] = True
    free = np.cumsum(~fixed) - 1
    free[fixed] = -1
    dof = free[full]
    n = int((~fixed).sum())
    rail_w, rail_th, sdof = dof[:n_el + 1], dof[n_el + 1:2 * (n_el + 1)], dof[2 * (n_el + 1):]
    el = np.stack([rail_w[:-1], rail_th[:-1], rail_w[1:], rail_th[1:]], axis=1)
    L = np.full(n_el, element)
    kb = np.full(n_sleepers, k_b)
    if stiff_from is not None:
        kb[sx > stiff_from] *= stiff_factor
    Ma, Ca, Ka = Assembler(n), Assembler(n), Assembler(n)
    Ka.add(el, beam_stiffness(EI, L))
    Ma.add(el, M_RAIL * hermite_gram(L))
    rw = rail_w[snode][:, None]
    Ka.add_relative(rw, sdof[:, None], np.full((n_sleepers, 1, 1), k_pad))
    Ca.add_relative(rw, sdof[:, None], np.full((n_sleepers, 1, 1), c_pad))
    Ma.add_diagonal(sdof, np.full(n_sleepers, m_sleeper))
    Ka.add_diagonal(sdof, kb)
    Ca.add_diagonal(sdof, np.full(n_sleepers, c_b))
    rev = slice(None, None, -1)
    return DiscreteTrack(node_x, rail_w, rail_th, Ma.build(), Ca.build(), Ka.build(), sx[rev],
                         sdof[rev], kb[rev], np.full(n_sleepers, c_b),
                         {"rotation_dofs": rail_th[rail_th >= 0], "n_entry_sleepers": n_sleepers})


def gravity_load(track):
    t = np.ones(track.K.shape[0])
    t[track.info["rotation_dofs"]] = 0.0
    return GRAVITY * (track.M @ t)


def closed_form_support_force(track, i_dof, k, load, x, gap):
    """Force of one unilateral support under the track's weight and a static point load at x:
    with U_free and f the displacement and flexibility at the sleeper of the track without
    that support, R = k (U_free - gap) / (1 + k f) where positive, else 0."""
    K_minus = (track.K - sp.csr_matrix(([k], ([i_dof], [i_dof])), shape=track.K.shape)).tocsc()
    idx, vals = contact_vector(track, x)
    f = gravity_load(track)
    np.add.at(f, idx, load * vals)
    u_free = spsolve(K_minus, f)[i_dof]
    e = np.zeros(track.K.shape[0])
    e[i_dof] = 1.0
    flex = spsolve(K_minus, e)[i_dof]
    return max(k * (u_free - gap) / (1.0 + k * flex), 0.0)


@pytest.mark.parametrize("gap_mm", [0.0, 0.05, 0.2, 0.4, 0.6, 2.0])
def test_static_load_over_a_voided_sleeper_matches_the_closed_form(gap_mm):
    """A 100 kN load standing over sleeper 30 of a uniform track: the sleeper's ballast force
    falls as its void grows and is zero once the rail no longer closes the gap."""
    tr = discrete_track()
    sup = sleeper_supports(tr, [30])                  # the one unilateral support
    i = 0
    gaps = np.array([gap_mm * 1e-3])
    sup = sup.with_gaps(gaps)
    x = float(sup.x[i])
    h = integrate(tr, 1e-3, 0.0, x, 3, load=100e3, supports=sup)
    expected = closed_form_support_force(tr, int(sup.dof[i]), float(sup.stiffness[i]), 100e3, x,
                                         gaps[i])
    assert h.support_force[0, i] == pytest.approx(expected, rel=1e-9, abs=1e-6)
    if gap_mm >= 2.0:
        assert expected == 0.0 and h.support_contact[0, i] == 0
    if gap_mm == 0.0:
        assert expected > 20e3                       # a real share of the load
    # standing still from static equilibrium: nothing moves
    assert np.max(np.abs(h.support_force - h.support_force[0])) < 1e-6 * 100e3


def test_slowly_moving_load_meets_the_voided_sleeper_only_when_the_rail_closes_the_gap():
    """A 100 kN load at 1 m/s over a sleeper with a 0.3 mm void: its ballast force follows the
    quasi-static closed form at every position, zero while the load is far."""
    tr = discrete_track()
    sup = sleeper_supports(tr, [30])
    i = 0
    gaps = np.array([0.3e-3])
    sup = sup.with_gaps(gaps)
    x0 = float(sup.x[i]) - 2.0
    h = integrate(tr, 2e-3, 1.0, x0, 2000, load=100e3, supports=sup)
    pos = h.position[::50]
    got = h.support_force[::50, i]
    exp = np.array([closed_form_support_force(tr, int(sup.dof[i]), float(sup.stiffness[i]),
                                              100e3, p, gaps[i]) for p in pos])
    assert np.max(np.abs(got - exp)) < 0.01 * exp.max()
    far = np.abs(pos - sup.x[i]) > 1.2
    assert np.all(exp[far] == 0.0) and np.all(np.abs(got[far]) < 0.002 * exp.max())
    assert exp.max() > 10e3


def test_sleepers_lift_off_where_the_linear_model_pulls():
    """All sleepers unilateral, no voids, a load standing still: exactly the sleepers whose
    linear support force (weight share included) would be tensile lift off."""
    tr = discrete_track()
    sup = sleeper_supports(tr, np.arange(20, 40))
    x = float(sup.x[10])
    h = integrate(tr, 1e-3, 0.0, x, 2, load=100e3, supports=sup)
    idx, vals = contact_vector(tr, x)
    f = np.zeros(tr.K.shape[0])
    np.add.at(f, idx, 100e3 * vals)
    u_lin = spsolve(tr.K.tocsc(), f)
    linear_force = sup.stiffness * (u_lin[sup.dof] + sup.rest)
    assert np.any(linear_force < 0)                  # the uplift lobes of the deflection bowl
    assert np.array_equal(h.support_contact[0] == 0, linear_force < 0)


def test_hanging_sleeper_rests_on_its_pad():
    """No load, a 2 mm void: the sleeper hangs from the rail, its pad carrying its weight, its
    support nothing; the rail's rest profile dips over it by less than the void."""
    tr = discrete_track()
    sup = sleeper_supports(tr, np.arange(20, 40))
    gaps = np.zeros(20)
    gaps[10] = 2e-3
    sup = sup.with_gaps(gaps)
    u = rest_state(tr, sup)
    d = int(sup.dof[10])
    node = int(np.argmin(np.abs(tr.node_x - sup.x[10])))
    rail = int(tr.rail_w[node])
    u_g = spsolve(tr.K.tocsc(), gravity_load(tr))         # void-free weight state
    pad_compression = (u[d] + u_g[d]) - (u[rail] + u_g[rail])
    assert pad_compression * 1120e6 == pytest.approx(125.5 * GRAVITY, rel=1e-9)
    assert sup.penetration(u)[10] < -1.5e-3                  # still hanging
    assert 0.0 < u[rail] < 0.2e-3


# the paper's vehicle over the sleepers it passes; the bogie's two 87 kN wheels lift some of
# those out of their bowls' uplift lobes, so the bogie runs with unilateral sleepers beyond
@pytest.mark.parametrize("base,first", [("reference.yaml", 10), ("vehicles/virm-bogie.yaml", 40)])
def test_zero_gaps_on_a_stiff_track_give_the_linear_result(base, first):
    """Unilateral supports without voids, none lifting off: the linear model's run, bit for
    bit (no sleeper off the ballast leaves the wheels' own update, on the same right-hand
    side: the supports' constant loads k gap are zero)."""
    case = load_case(CONFIGS / base).with_simulation(run_in=2.0, run_out=1.0)
    tr = build_track(case.scenario(), case.track_design(case.reference))
    veh = build_vehicle(case.scenario().vehicle)
    dt = case.simulation["time_step"]
    x_start = tr.window[0]
    steps = int(4.0 / (veh.speed * dt))                  # 4 m on the ballast, before the slab
    sup = sleeper_supports(tr, np.arange(first, first + 20))
    lin = integrate(tr, dt, veh.speed, x_start, steps, vehicle=veh, record_dofs=sup.dof)
    uni = integrate(tr, dt, veh.speed, x_start, steps, vehicle=veh, supports=sup,
                    record_dofs=sup.dof)
    assert uni.info["switches"] == 0 and np.all(uni.support_contact == 1)
    for name in ("wheel_force", "wheel_rail_displacement", "vehicle_displacement",
                 "dof_displacement", "dof_velocity"):
        assert np.array_equal(getattr(uni, name), getattr(lin, name)), name
    # the supports' forces: the linear springs' k u + c v plus the weight share
    assert np.all(uni.support_force >= 0.0)
