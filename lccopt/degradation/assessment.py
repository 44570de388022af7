"""One design judged by its settlement under its traffic: the evaluation of a case with a
``degradation:`` section (docs/settlement.md).

``assess_settlement(spec, design)`` runs, for one design,

* the paper's simulation of every traffic condition on the new track
  (:func:`lccopt.vti.passage.simulate_passage`): F_rms, F_max, E_rms and E_max, combined over the
  conditions by the case's rule (worst or weighted mean), and the time histories of the first
  condition's (the report's contact-force and sleeper-energy figures);
* one settlement prediction (:func:`~lccopt.degradation.iteration.predict_settlement`) in
  which every condition with passages simulates at every simulation point, all on the same
  settling track: the settlement objectives (``lccopt.vti.response.SETTLEMENT_OBJECTIVES``)
  and the settlement histories (``settlement_*``, one row per block).

The whole prediction is one evaluation (one worker task): its conditions are coupled through
the track they settle together, so they cannot be split over workers the way the paper's
independent simulations are.

Its typed inputs (:mod:`lccopt.degradation.inputs`) are built by the config layer from a
validated case; this module imports nothing from it.
"""

from __future__ import annotations

import time

import numpy as np

from ..vti.passage import simulate_passage
from ..vti.response import PAPER_OBJECTIVES, REPORTED_ONLY, SETTLEMENT_OBJECTIVES, Evaluation
from ..vti.specs import TrackDesign
from ..vti.track import build_track
from ..vti.vehicle import build_vehicle
from .inputs import DegradationSpec, LawSpec, Limit, SubgradeSpec, Traffic
from .iteration import SettlementResult, Tamping, predict_settlement
from .laws import LAWS, SlabSettlement, SleeperLaw, SubgradeLaw
from .loading import PassageKind, entry_zone, vti_passage_kind


def assess_settlement(spec: DegradationSpec, design: TrackDesign) -> Evaluation:
    """The paper's objectives on the new track and the settlement of ``design`` over
    ``spec``'s horizon.

    Parameters
    ----------
    spec
        the traffic, the law and the iteration's settings.
    design
        the design of the entry side (checked by the caller, as for the paper's simulation).

    Returns
    -------
    lccopt.vti.response.Evaluation
        objectives: the paper's four (combined over the conditions; each condition's also as
        ``F_max@name`` etc. when there are several) and the settlement objectives; histories:
        the first condition's time histories and the ``settlement_*`` histories; info: the
        first condition's facts and the prediction's (``settlement_*``).
    """
    t0 = time.perf_counter()
    passages = [simulate_passage(t.scenario, design) for t in spec.traffic]
    objectives = _paper_objectives(spec, [p.objectives for p in passages])
    result = predict(spec, design)
    objectives.update(settlement_objectives(result, spec.limit))
    first = passages[0]
    histories = {**first.histories, **settlement_histories(result)}
    info = {**first.info, **_settlement_info(result, spec)}
    info["paper_wall_time"] = float(sum(p.info.get("wall_time", 0.0) for p in passages))
    info["wall_time"] = time.perf_counter() - t0
    return Evaluation(objectives, histories, info)


def predict(spec: DegradationSpec, design: TrackDesign) -> SettlementResult:
    """The settlement prediction of ``design`` under the conditions with passages.

    Each condition simulates on its own track model (the mesh follows its vehicle's run), all
    on the gaps of one settling zone; the statics are those of the first condition's track.

    Parameters
    ----------
    spec
        the traffic, the law and the iteration's settings.
    design
        the design of the entry side.

    Returns
    -------
    lccopt.degradation.iteration.SettlementResult
    """
    conditions, tracks = [], []
    for t in spec.settling_traffic:
        track = build_track(t.scenario, design)
        tracks.append(track)
        conditions.append(_passage_kind(t, track, spec))
    track = tracks[0]
    zone = entry_zone(track, spec.settling_sleepers, spec.follower_flat, spec.follower_taper)
    support = spec.settling_traffic[0].scenario.track.support.stiffness
    return predict_settlement(track, zone, conditions, horizon_years=spec.horizon_years,
                              law=sleeper_law(spec, track, support), tolerance=spec.tolerance,
                              steps_per_decade=spec.steps_per_decade,
                              max_simulations=spec.max_simulations,
                              rail_seats=spec.rail_seats, reading=spec.reading,
                              slab=slab_settlement(spec, conditions), tamping=tamping(spec))


def tamping(spec: DegradationSpec) -> Tamping | None:
    """The tamping of the prediction: when the case's limit is reached, every settling
    sleeper but the ``unreachable_sleepers`` nearest the slab; None without ``tamping``."""
    t = spec.tamping
    if t is None:
        return None
    reachable = np.arange(spec.settling_sleepers) >= t.unreachable_sleepers
    return Tamping(spec.limit.measure, spec.limit.value, reachable, t.min_interval)


def slab_settlement(spec: DegradationSpec, conditions) -> SlabSettlement | None:
    """The ERS slab's own settlement: the subgrade layer's law under the slab, the same soil
    as under the sleepers (None without a subgrade).

    One rail's share of the slab (``share_per_rail`` of its width) carries each axle's wheel
    (the condition's heaviest static wheel load) and spreads it as a beam on an elastic
    foundation: the peak foundation pressure of a point load P is P β / (2 b), β = (k /
    (4 EI))^(1/4) (Hetényi), so the loaded area is A = 2 b / β; the layer below is then
    loaded as a sleeper's is (:func:`lccopt.degradation.laws.li_selig_coefficient`).

    Parameters
    ----------
    spec
        the prediction's inputs.
    conditions
        the prediction's conditions (their axles' static loads), in ``spec.settling_traffic``'s
        order.

    Returns
    -------
    lccopt.degradation.laws.SlabSettlement or None
    """
    sub = spec.subgrade
    if sub is None:
        return None
    track = spec.settling_traffic[0].scenario.track
    ers = track.ers
    b1, b2, h = ers.slab.width_bottom, ers.slab.width_top, ers.slab.height
    second_moment = h ** 3 * (b1 * b1 + 4 * b1 * b2 + b2 * b2) / (36.0 * (b1 + b2))
    beta = (ers.foundation.stiffness / (4.0 * ers.slab.youngs_modulus * second_moment)) ** 0.25
    area = 2.0 * b1 * ers.share_per_rail / beta
    law = SubgradeLaw.of_soil(sub.soil, subgrade_strength(sub, track.support.stiffness),
                              [area], sub.depth, sub.thickness)
    return SlabSettlement(law, np.array([float(np.max(c.axles.loads)) for c in conditions]))


def bearing_areas(spec: DegradationSpec, track) -> np.ndarray:
    """The bearing area [m^2] per rail seat of each settling sleeper of a built track
    (strengthened or standard), nearest the interface first."""
    strengthened = np.asarray(track.entry_strengthened, bool)[:spec.settling_sleepers]
    return np.where(strengthened, spec.strengthened_bearing_area, spec.bearing_area)


def subgrade_strength(sub: SubgradeSpec, support_stiffness: float) -> float:
    """The subgrade's static strength [Pa] under a support of ``support_stiffness`` [N/m per
    rail seat]: ``sub.strength`` scaled by the support's stiffness over the one it was given
    for (a softer subgrade of the same soil is a weaker one; docs/settlement.md)."""
    return sub.strength * support_stiffness / sub.reference_stiffness


def sleeper_law(spec: DegradationSpec, track, support_stiffness: float) -> SleeperLaw:
    """The settlement law of each settling sleeper of ``track``: the ballast law fed the
    pressure of its bearing area, the subgrade layer (if any) and the per-sleeper factors
    and initial gaps of ``spec``.

    Parameters
    ----------
    spec
        the prediction's inputs.
    track
        the built track of the design (its strengthened sleepers).
    support_stiffness
        the standard sleepers' support stiffness per rail seat [N/m] of the case.

    Returns
    -------
    lccopt.degradation.laws.SleeperLaw
    """
    n = spec.settling_sleepers
    area = bearing_areas(spec, track)
    sub = spec.subgrade
    subgrade = None if sub is None else SubgradeLaw.of_soil(
        sub.soil, subgrade_strength(sub, support_stiffness), area, sub.depth, sub.thickness)
    return SleeperLaw(law(spec.law), spec.bearing_area / area,
                      np.ones(n) if spec.sleeper_gamma is None
                      else np.asarray(spec.sleeper_gamma, float),
                      subgrade,
                      None if spec.initial_gap is None else np.asarray(spec.initial_gap, float))


def law(spec: LawSpec):
    """The settlement law of ``spec``.

    Parameters
    ----------
    spec
        the law's name (``LAW_NAMES``) and its class's arguments.

    Returns
    -------
    VarandasLaw or LogarithmicLaw
        an instance of ``lccopt.degradation.laws.LAWS[spec.name]``.
    """
    return LAWS[spec.name](**dict(spec.parameters))


def _passage_kind(traffic: Traffic, track, spec: DegradationSpec) -> PassageKind:
    """A condition of the prediction: ``traffic``'s passage over ``track`` (run as
    :func:`lccopt.vti.passage.simulate_passage` runs it), on the gaps the iteration gives for the
    settling zone, applied to this track's own supports of the same sleepers."""
    sc = traffic.scenario
    vehicle = build_vehicle(sc.vehicle)
    dt = sc.settings.time_step
    x_start, _, _, x_end = track.window
    speed = -vehicle.speed if x_end < x_start else vehicle.speed
    n_steps = int(np.ceil(abs(x_end - x_start) / (vehicle.speed * dt)))
    irregularity = None
    if sc.irregularity is not None:
        px, pr = sc.irregularity[:, 0], sc.irregularity[:, 1]

        def irregularity(pos: float) -> float:
            return float(np.interp(pos, px, pr, left=0.0, right=0.0))
    own = entry_zone(track, spec.settling_sleepers, spec.follower_flat,
                     spec.follower_taper).supports
    base = vti_passage_kind(traffic.name, traffic.passages_per_year, track, vehicle, dt=dt,
                         speed=speed, x_start=x_start, n_steps=n_steps,
                         irregularity=irregularity)

    def simulate(supports):
        if supports.x.shape != own.x.shape or not np.allclose(supports.x, own.x):
            raise ValueError(f"condition {traffic.name}: its track's settling sleepers are "
                             f"not those of the prediction's zone")
        return base.simulate(own.with_gaps(supports.gap))
    return PassageKind(base.name, base.passes_per_year, simulate, base.axles)


def _paper_objectives(spec: DegradationSpec, per_condition: list[dict]) -> dict:
    """The paper's four objectives, combined over the conditions (worst: the largest;
    mean: the weighted mean), and each condition's as ``F_max@name`` when there are several."""
    if len(per_condition) == 1:
        return {k: float(per_condition[0][k]) for k in PAPER_OBJECTIVES}
    w = np.array([t.weight for t in spec.traffic], dtype=float)
    out = {}
    for k in PAPER_OBJECTIVES:
        v = np.array([float(o[k]) for o in per_condition])
        out[k] = float(w @ v / w.sum()) if spec.condition_mode == "mean" else float(v.max())
    for t, o in zip(spec.traffic, per_condition):
        for k in PAPER_OBJECTIVES:
            out[f"{k}@{t.name}"] = float(o[k])
    return out


def settlement_objectives(result: SettlementResult, limit: Limit) -> dict:
    """The settlement objectives at the horizon and ``years_to_limit``.

    Years and axle passes are proportional (the traffic is the same every year), so the
    passes until the limit become years; ``years_to_limit`` is the horizon if the limit is
    never reached.

    Parameters
    ----------
    result
        the prediction.
    limit
        the measure and value that ``years_to_limit`` counts to.

    Returns
    -------
    dict
        ``SETTLEMENT_OBJECTIVES`` and ``years_to_limit`` -> float, SI units.
    """
    o = result.objectives(limit.measure, limit.value)
    per_year = result.axle_passes[-1] / result.years[-1]
    years = o.pop("passes_to_limit") / per_year
    o["maintenance_rate"] = 1.0 / years
    o["years_to_limit"] = years
    order = [k for k in (*SETTLEMENT_OBJECTIVES, *REPORTED_ONLY) if k in o]
    return {k: float(o[k]) for k in order + [k for k in o if k not in order]}


def settlement_histories(result: SettlementResult) -> dict:
    """The prediction's histories as an evaluation file keeps them.

    Parameters
    ----------
    result
        the prediction.

    Returns
    -------
    dict
        ``settlement_*`` -> array, one row per block (``lccopt.vti.response.HISTORY_DOC``).
    """
    return {
        "settlement_years": result.years,
        "settlement_axle_passes": result.axle_passes,
        "settlement_sleeper_x": result.sleeper_x,
        "settlement_sleepers": result.settlement,
        "settlement_void": result.void,
        "settlement_level": result.level.astype(np.float32),   # sub-micrometre: enough
        "settlement_level_x": result.level_x,
        "settlement_peak_force": result.peak_force,
        "settlement_wheel_force_max": result.wheel_force_max,
        "settlement_simulated": result.simulated.astype(np.int8),
        "settlement_tamped": (np.zeros(len(result.years), np.int8) if result.tamped is None
                              else result.tamped.astype(np.int8)),
        "settlement_load_errors": np.asarray(result.info["load_errors"], dtype=float),
        **{f"settlement_{k}": np.asarray(v, dtype=float) for k, v in result.rail.items()},
    }


def _settlement_info(result: SettlementResult, spec: DegradationSpec) -> dict:
    limit = spec.limit
    reached = bool(np.any(result.measure(limit.measure) >= limit.value))
    return {
        "settlement_simulations": int(result.n_simulations),
        "settlement_blocks": int(result.info["blocks"]),
        "settlement_budget_bound": bool(result.info["budget_bound"]),
        "settlement_law": str(result.info["law"]),
        "settlement_conditions": ",".join(result.conditions),
        "settlement_horizon_years": float(spec.horizon_years),
        "settlement_limit_measure": limit.measure,
        "settlement_limit_value": float(limit.value),
        "settlement_limit_reached": reached,
        "settlement_tamping": spec.tamping is not None,
        "settlement_unreachable_sleepers": (-1 if spec.tamping is None
                                            else int(spec.tamping.unreachable_sleepers)),
        "settlement_interventions": int(0 if result.tamped is None else result.tamped.sum()),
        "settlement_tamping_ineffective": (-1.0 if result.info.get("tamping_ineffective") is None
                                           else float(result.info["tamping_ineffective"])),
    }
