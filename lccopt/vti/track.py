"""Track model of one rail: layout from a scenario and a design, then M, C, K.

Layout (x along the track; the direction ``enter`` runs the vehicle towards +x,
``leave`` towards -x):

    0 ── ballast (entry_length) ──► x_a ══ ERS slabs ══ x_b ── ballast (exit_length) ── L

* Rail: Euler-Bernoulli beam elements, pinned at both ends (w = 0, rotation free).
* Ballast track: railpad (spring + damper) -> sleeper (mass) -> support (spring + damper).
  Entry sleepers are counted from the interface: sleeper 1 sits x_sM elements from the slab
  edge, sleeper 2 a further x_s(M-1) elements, ..., then the standard spacing. Pads of
  sleepers 1..N get x_rN..x_r1 (x_rN nearest); their damping scales with stiffness. The
  x_n sleepers nearest the interface are strengthened. A scenario's ``variation`` (one
  realisation of the built track) multiplies each sleeper's support and pad values by its
  factors.
* ERS: rail on a continuous compound (consistent matrix k∫NNᵀ on the relative deflection
  rail - slab), on slab beams (free-free, not joined), on a continuous foundation. Over
  x_l elements from the entry edge the compound is the Type II one. Compound damping:
  c = 2 ζ sqrt(k m_rail) per metre, the viscous damping that gives the rail-on-compound
  mode the damping ratio ζ of Table 3.
* Dofs are numbered along the track (rail, sleeper and slab dofs at one position next to
  each other), so every matrix is banded with a half-bandwidth of a few dofs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .assembly import Assembler, beam_stiffness, hermite_gram
from .specs import ELEMENT_UNIT, Scenario, TrackDesign
from .vehicle import vehicle_length

# dof kinds, in their order at one position
RAIL_W, RAIL_TH, SLEEPER, SLAB_W, SLAB_TH = range(5)


@dataclass
class TrackModel:
    """Assembled track of one rail. Indices refer to the free (unconstrained) dofs."""
    element_length: float           # rail element length where the wheel runs [m]
    window: tuple                   # (x_start, zone_start, zone_end, x_end), leading wheel [m]
    node_x: np.ndarray              # rail node positions [m]
    rail_w: np.ndarray              # dof of rail deflection at each node (-1 where pinned)
    rail_th: np.ndarray             # dof of rail rotation at each node
    M: sp.csr_matrix
    C: sp.csr_matrix
    K: sp.csr_matrix
    interface: tuple[float, float]  # slab edges x_a (entry), x_b (exit) [m]
    slab_edges: np.ndarray          # slab ends [m]
    entry_sleeper_x: np.ndarray     # entry sleepers, nearest the interface first [m]
    entry_sleeper_dof: np.ndarray
    entry_support_damping: np.ndarray   # c_b of each entry sleeper [N s/m]
    entry_strengthened: np.ndarray      # bool per entry sleeper
    entry_pad_stiffness: np.ndarray     # railpad stiffness per entry sleeper [N/m]
    exit_sleeper_x: np.ndarray
    type_ii_end: float              # the Type II strip covers [x_a, type_ii_end]
    info: dict = field(default_factory=dict)
    # every ballast sleeper, entry (nearest the interface first) then exit: what the unilateral
    # support model (lccopt/vti/unilateral.py) needs to know of each sleeper's support
    sleeper_x: np.ndarray | None = None
    sleeper_dof: np.ndarray | None = None
    support_stiffness: np.ndarray | None = None     # k_b [N/m]
    support_damping: np.ndarray | None = None       # c_b [N s/m]

    @property
    def n_dofs(self) -> int:
        return self.K.shape[0]

    @property
    def length(self) -> float:
        return float(self.node_x[-1])


def entry_sleeper_positions(x_a: float, spans_elements: np.ndarray, spacing: float) -> np.ndarray:
    """Entry-side sleeper positions, nearest the interface first (spans x_s1..x_sM, x_sM
    nearest)."""
    near = x_a - np.cumsum(spans_elements[::-1] * ELEMENT_UNIT)
    far = near[-1] - spacing * np.arange(1, int(near[-1] / spacing + 1e-9) + 1)
    pos = np.concatenate([near, far])
    return pos[pos > 1e-9]


def wheel_window(scenario: Scenario, entry_x: np.ndarray) -> tuple[float, float, float, float]:
    """(x_start, zone_start, zone_end, x_end) of the leading wheel [m].

    The evaluation zone begins at the farthest zone sleeper (zone_start) and the force zone
    ends at ``zones.force_zone_end`` (zone_end, a point relative to the entry or the exit
    interface: it follows the layout), whichever way the vehicle runs.
    ``enter`` (towards +x): the leading wheel starts ``run_in`` before zone_start and the run
    ends when the last wheel is ``run_out`` past zone_end. ``leave`` (towards -x, from the ERS
    onto the designed side): the leading wheel starts ``run_in`` beyond the far (exit) edge of
    the ERS, on the exit ballast, so that it crosses the whole crossing as a leaving train
    does, and the run ends when the last wheel is ``run_out`` past zone_start; then
    x_start > x_end. (Starting inside the ERS, run_in before zone_end, put E_max 10 % low for
    the 3-dof vehicle and 12 % for the VIRM half car at run_in = 2 m: the start transient next
    to the zone and the missing passage of the far interface; from the exit side E_max agrees
    to 0.2 % between 10 and 20 m of run.) A trailing wheel beyond a rail end rests on a rigid
    continuation of the rail; a case's check starts every wheel at least 2 m inside the rail
    (``config.checks.START_MARGIN``: rolling onto its end shakes the vehicle)."""
    zones, sim, layout = scenario.zones, scenario.settings, scenario.track.layout
    zone_start = float(entry_x[zones.sleepers - 1])
    zone_end = scenario.track.position(zones.force_zone_end)
    length = vehicle_length(scenario.vehicle)
    if sim.direction == "leave":
        x_b = layout.entry_length + float(sum(scenario.track.ers.slab_lengths))
        return (max(zone_end, x_b) + sim.run_in, zone_start, zone_end,
                zone_start - sim.run_out - length)
    return zone_start - sim.run_in, zone_start, zone_end, zone_end + sim.run_out + length


def wheels_span(scenario: Scenario, window: tuple) -> tuple[float, float]:
    """(lowest, highest) position of any wheel during the run [m]."""
    x_start, _, _, x_end = window
    length = vehicle_length(scenario.vehicle)
    back = -length if x_end >= x_start else length     # the other wheels trail the leading one
    ends = (x_start, x_end, x_start + back, x_end + back)
    return min(ends), max(ends)


def rail_nodes(total: float, window: tuple[float, float], fine: float, coarse: float,
               supports: np.ndarray) -> np.ndarray:
    """Rail node positions.

    Over the wheel's window (plus 2 m each side, snapped outwards to the 0.1 m grid) the
    elements are ``fine`` long. Elsewhere every support position (sleepers, slab edges) is a
    node and each gap between them is split into equal elements no longer than ``coarse``.
    """
    w0 = max(0.0, np.floor((window[0] - 2.0) / ELEMENT_UNIT + 1e-9) * ELEMENT_UNIT)
    w1 = min(total, np.ceil((window[1] + 2.0) / ELEMENT_UNIT - 1e-9) * ELEMENT_UNIT)
    fine_nodes = w0 + np.arange(int(round((w1 - w0) / fine)) + 1) * fine
    keys = np.unique(np.concatenate([[0.0, w0, w1, total], supports]).round(9))
    keys = keys[(keys <= w0) | (keys >= w1)]
    coarse_nodes = []
    for a, b in zip(keys[:-1], keys[1:]):
        if a >= w0 - 1e-9 and b <= w1 + 1e-9:
            continue                                   # the fine window
        n = max(1, int(np.ceil((b - a) / coarse - 1e-9)))
        coarse_nodes.append(a + (b - a) * np.arange(n) / n)
    nodes = np.concatenate(coarse_nodes + [fine_nodes, [total]])
    return np.unique(nodes.round(9))


def _sleeper_values(t, design: TrackDesign, variation, n_entry: int, n_exit: int) -> tuple:
    """(strengthened, pad k, pad c, mass, support k, support c) of every sleeper, entry
    (nearest the interface first) then exit, as designed and as built (``variation``)."""
    strengthened = np.arange(n_entry) < int(design.strengthened_sleepers)
    pads = np.asarray(design.railpad_stiffness, dtype=float)[::-1]  # x_rN nearest the interface
    pad_k = np.full(n_entry, t.railpad.stiffness)
    pad_k[:len(pads)] = pads[:n_entry]
    # Sec. 3.2: pad damping scales linearly with stiffness
    pad_c = t.railpad.damping * pad_k / t.railpad.stiffness
    ss = t.strengthened_sleeper
    sl_mass = np.where(strengthened, ss.mass, t.sleeper_mass)
    sl_k = np.where(strengthened, ss.support_stiffness, t.support.stiffness)
    sl_c = np.where(strengthened, ss.support_damping, t.support.damping)
    all_pad_k = np.concatenate([pad_k, np.full(n_exit, t.railpad.stiffness)])
    all_pad_c = np.concatenate([pad_c, np.full(n_exit, t.railpad.damping)])
    all_mass = np.concatenate([sl_mass, np.full(n_exit, t.sleeper_mass)])
    all_k = np.concatenate([sl_k, np.full(n_exit, t.support.stiffness)])
    all_c = np.concatenate([sl_c, np.full(n_exit, t.support.damping)])
    if variation is not None:   # the track as built: per-sleeper factors on the drawing's values
        pad_f = variation.per_sleeper("pad_stiffness", n_entry, n_exit, 1.0)
        all_pad_k, all_pad_c = all_pad_k * pad_f, all_pad_c * pad_f
        all_k = all_k * variation.per_sleeper("support_stiffness", n_entry, n_exit, 1.0)
        all_c = all_c * variation.per_sleeper("support_damping", n_entry, n_exit, 1.0)
    return strengthened, all_pad_k, all_pad_c, all_mass, all_k, all_c


def _number_dofs(n_el: int, sleeper_node: np.ndarray, slab_first, slab_last) -> tuple:
    """Dofs numbered along the track: (n, rail_w, rail_th, sleeper_dof, [(slab w, slab th)]),
    -1 where fixed (the rail's w at both ends: pinned)."""
    # sort (node, kind, slab) keys
    keys_node = [np.arange(n_el + 1), np.arange(n_el + 1), sleeper_node]
    keys_kind = [np.full(n_el + 1, RAIL_W), np.full(n_el + 1, RAIL_TH),
                 np.full(len(sleeper_node), SLEEPER)]
    keys_sub = [np.zeros(n_el + 1, int), np.zeros(n_el + 1, int), np.zeros(len(sleeper_node), int)]
    for s, (f, l) in enumerate(zip(slab_first, slab_last)):
        nodes = np.arange(f, l + 1)
        for kind in (SLAB_W, SLAB_TH):
            keys_node.append(nodes)
            keys_kind.append(np.full(len(nodes), kind))
            # a slab's last node sorts before the rail: at a joint of two slabs the dofs run
            # (ending slab, rail, starting slab), which keeps the half-bandwidth at 7, not 9
            sub = np.full(len(nodes), s + 1)
            sub[-1] = -1
            keys_sub.append(sub)
    kn, kk, ks = (np.concatenate(a) for a in (keys_node, keys_kind, keys_sub))
    # the kinds are listed so that (node, slab, kind) keeps each slab's w, th together
    order = np.lexsort((kk, ks, kn))
    full_index = np.empty(len(order), int)
    full_index[order] = np.arange(len(order))
    fixed = np.zeros(len(order), bool)
    fixed[full_index[[0, n_el]]] = True          # rail w at both ends: pinned
    free_index = np.cumsum(~fixed) - 1
    free_index[fixed] = -1
    dof = free_index[full_index]                  # dof of each key entry, -1 if fixed
    n = int((~fixed).sum())

    rail_w = dof[:n_el + 1]
    rail_th = dof[n_el + 1:2 * (n_el + 1)]
    sleeper_dof = dof[2 * (n_el + 1):2 * (n_el + 1) + len(sleeper_node)]
    slab_dofs = []
    off = 2 * (n_el + 1) + len(sleeper_node)
    for f, l in zip(slab_first, slab_last):
        m = l - f + 1
        slab_dofs.append((dof[off:off + m], dof[off + m:off + 2 * m]))
        off += 2 * m
    return n, rail_w, rail_th, sleeper_dof, slab_dofs


def build_track(scenario: Scenario, design: TrackDesign) -> TrackModel:
    """Build the track of ``scenario`` for a design (assumed checked)."""
    t = scenario.track
    le = scenario.settings.element_length
    lay, ers = t.layout, t.ers

    x_a = lay.entry_length
    ers_length = float(sum(ers.slab_lengths))
    x_b = x_a + ers_length
    total = x_b + lay.exit_length
    entry_x = entry_sleeper_positions(x_a, np.asarray(design.sleeper_spans, dtype=float),
                                      lay.sleeper_spacing)
    window = wheel_window(scenario, entry_x)
    exit_x = x_b + lay.exit_first_span + lay.sleeper_spacing * np.arange(
        int((total - x_b - lay.exit_first_span) / lay.sleeper_spacing + 1e-9) + 1)
    exit_x = exit_x[exit_x < total - 1e-9]
    slab_edges = x_a + np.concatenate([[0.0], np.cumsum(ers.slab_lengths)])
    node_x = rail_nodes(total, wheels_span(scenario, window), le,
                        scenario.settings.far_element_length,
                        np.concatenate([entry_x, exit_x, slab_edges]))
    n_el = len(node_x) - 1
    el_len = np.diff(node_x)

    def node_of(pos):  # sleepers and slab edges sit on nodes (multiples of 0.1 m)
        i = np.searchsorted(node_x, np.asarray(pos) - 1e-9)
        assert np.allclose(node_x[i], pos, atol=1e-9), "a support is off the mesh"
        return i

    n_entry, n_exit = len(entry_x), len(exit_x)
    strengthened, all_pad_k, all_pad_c, all_mass, all_k, all_c = _sleeper_values(
        t, design, scenario.variation, n_entry, n_exit)
    sleeper_x = np.concatenate([entry_x, exit_x])
    sleeper_node = node_of(sleeper_x)
    # slabs: node ranges (each slab has its own nodes; neighbouring slabs are not joined)
    slab_first = node_of(slab_edges[:-1])
    slab_last = node_of(slab_edges[1:])
    n, rail_w, rail_th, sleeper_dof, slab_dofs = _number_dofs(n_el, sleeper_node, slab_first,
                                                              slab_last)

    rail = t.rail
    ei_rail = rail.youngs_modulus * rail.second_moment
    m_rail = rail.density * rail.area
    gram = hermite_gram(el_len)  # (n_el, 4, 4)
    Mas, Cas, Kas = Assembler(n), Assembler(n), Assembler(n)

    # rail beam
    el_dofs = np.stack([rail_w[:-1], rail_th[:-1], rail_w[1:], rail_th[1:]], axis=1)
    Kas.add(el_dofs, beam_stiffness(ei_rail, el_len))
    Mas.add(el_dofs, m_rail * gram)

    # ballast track: pad between rail and sleeper, support between sleeper and ground
    rw_at = rail_w[sleeper_node][:, None]
    Kas.add_relative(rw_at, sleeper_dof[:, None], all_pad_k[:, None, None])
    Cas.add_relative(rw_at, sleeper_dof[:, None], all_pad_c[:, None, None])
    Mas.add_diagonal(sleeper_dof, all_mass)
    Kas.add_diagonal(sleeper_dof, all_k)
    Cas.add_diagonal(sleeper_dof, all_c)

    # ERS: compound (rail - slab), slab beams, foundation
    share = ers.share_per_rail
    sl = ers.slab
    b1, b2, h = sl.width_bottom, sl.width_top, sl.height
    area = 0.5 * (b1 + b2) * h * share
    # trapezoid
    second_moment = h ** 3 * (b1 * b1 + 4 * b1 * b2 + b2 * b2) / (36.0 * (b1 + b2)) * share
    ei_slab, m_slab = sl.youngs_modulus * second_moment, sl.density * area
    kf = ers.foundation.stiffness * share
    cf = ers.foundation.damping * share
    type_ii_end = x_a + float(design.type_ii_strip) * ELEMENT_UNIT
    comp, comp2 = ers.compound, ers.type_ii_compound
    c_std = 2 * comp.damping_ratio * np.sqrt(comp.stiffness * m_rail)
    c_ii = 2 * comp2.damping_ratio * np.sqrt(comp2.stiffness * m_rail)
    for (sw, sth), f, l in zip(slab_dofs, slab_first, slab_last):
        s_el = np.stack([sw[:-1], sth[:-1], sw[1:], sth[1:]], axis=1)
        g_el = gram[f:l]
        Kas.add(s_el, beam_stiffness(ei_slab, el_len[f:l]))
        Mas.add(s_el, m_slab * g_el)
        Kas.add(s_el, kf * g_el)
        Cas.add(s_el, cf * g_el)
        r_el = el_dofs[f:l]
        is_ii = (node_x[f:l] + 0.5 * el_len[f:l]) < type_ii_end
        k_compound = np.where(is_ii, comp2.stiffness, comp.stiffness)
        Kas.add_relative(r_el, s_el, k_compound[:, None, None] * g_el)
        Cas.add_relative(r_el, s_el, np.where(is_ii, c_ii, c_std)[:, None, None] * g_el)

    info = {
        "n_dofs": n,
        "n_entry_sleepers": n_entry,
        "n_exit_sleepers": n_exit,
        "slab_mass_per_m": m_slab,
        "slab_bending_stiffness": ei_slab,
        "compound_damping": c_std,
        "type_ii_compound_damping": c_ii,
        # rail and slab rotation dofs: they change sign when the track is mirrored (tests)
        "rotation_dofs": np.concatenate([rail_th[rail_th >= 0]] + [th for _, th in slab_dofs]),
    }
    return TrackModel(
        element_length=le, window=window, node_x=node_x, rail_w=rail_w, rail_th=rail_th,
        M=Mas.build(), C=Cas.build(), K=Kas.build(), interface=(x_a, x_b), slab_edges=slab_edges,
        entry_sleeper_x=entry_x, entry_sleeper_dof=sleeper_dof[:n_entry],
        entry_support_damping=all_c[:n_entry], entry_strengthened=strengthened,
        entry_pad_stiffness=all_pad_k[:n_entry],
        exit_sleeper_x=exit_x, type_ii_end=float(type_ii_end), info=info,
        sleeper_x=sleeper_x, sleeper_dof=sleeper_dof, support_stiffness=all_k,
        support_damping=all_c)


@dataclass
class WinklerBeam:
    """A uniform rail on a continuous Winkler foundation, pinned at both ends: the track of the
    closed-form solutions (tests/vti/test_theory.py) that validate the elements and the
    integrator."""
    node_x: np.ndarray
    rail_w: np.ndarray
    rail_th: np.ndarray
    M: sp.csr_matrix
    C: sp.csr_matrix
    K: sp.csr_matrix

    @classmethod
    def build(cls, length: float, element_length: float, ei: float, mass: float, k: float,
              c: float = 0.0) -> "WinklerBeam":
        n_el = int(round(length / element_length))
        node_x = np.arange(n_el + 1) * element_length
        # dofs (w_j, th_j) in node order, w at both ends fixed
        full = np.arange(2 * (n_el + 1)).reshape(-1, 2)
        fixed = np.zeros(full.size, bool)
        fixed[[0, 2 * n_el]] = True
        index = np.cumsum(~fixed) - 1
        index[fixed] = -1
        dof = index[full]
        el = np.hstack([dof[:-1], dof[1:]])
        n = int((~fixed).sum())
        gram = hermite_gram(np.full(n_el, element_length))
        mats = []
        for assemble in (lambda a: a.add(el, mass * gram),
                         lambda a: a.add(el, c * gram),
                         lambda a: (a.add(el, beam_stiffness(ei, np.full(n_el, element_length))),
                                    a.add(el, k * gram))):
            a = Assembler(n)
            assemble(a)
            mats.append(a.build())
        return cls(node_x, dof[:, 0], dof[:, 1], *mats)
