"""One vehicle-track simulation of one design.

``simulate_passage(scenario, design)`` builds the track for the design, runs the scenario's vehicle
(3-dof, bogie or half car: ``VehicleSpec.type``) over it from static equilibrium and returns
the objectives and time histories as an :class:`Evaluation`.

The run (``SimulationSettings.direction``, lccopt.vti.track.wheel_window): ``enter``, the
leading wheel starts ``run_in`` before the evaluation zone, which begins at the farthest zone
sleeper, and runs towards +x; ``leave``, it starts ``run_in`` beyond the far edge of the ERS
(on the exit ballast) and runs towards -x over the whole crossing. The contact force of every
wheel is measured while that wheel is between the farthest zone sleeper and
``zones.force_zone_end`` (a point relative to an interface); the run ends when the last wheel
is ``run_out`` past the zone so the zone's sleepers have settled. Sleeper energies use mid-step
velocities, which makes them exactly the dissipation of Newmark's discrete energy balance.

A scenario whose variation leaves sleepers over voids runs with unilateral supports
(:mod:`lccopt.vti.unilateral`); a sleeper's energy then counts the steps it touches the
ballast.
"""

from __future__ import annotations

import time

import numpy as np

from .newmark import integrate
from .response import Evaluation, objectives_from
from .specs import Scenario, TrackDesign
from .track import build_track
from .unilateral import sleeper_supports
from .vehicle import build_vehicle


def simulate_passage(scenario: Scenario, design: TrackDesign) -> Evaluation:
    """Simulate one design in one scenario.

    Parameters
    ----------
    scenario
        the vehicle, the track, the settings, the evaluation zones and the rail profile.
    design
        the design of the entry side (assumed checked: ``lccopt.config.Case.track_design``
        checks a design vector against its case).

    Returns
    -------
    Evaluation
        the objectives, the time histories (``response.HISTORY_DOC``) and facts of the run.
    """
    t0 = time.perf_counter()
    track = build_track(scenario, design)
    vehicle = build_vehicle(scenario.vehicle)
    dt = scenario.settings.time_step
    x_start, zone_start, zone_end, x_end = track.window
    leave = x_end < x_start                       # direction: leave (towards -x)
    speed = -vehicle.speed if leave else vehicle.speed
    n_steps = int(np.ceil(abs(x_end - x_start) / (vehicle.speed * dt)))
    n_zone = scenario.zones.sleepers
    zone_dofs = track.entry_sleeper_dof[:n_zone]

    irregularity = None
    profile = scenario.irregularity
    if profile is not None:
        px, pr = profile[:, 0], profile[:, 1]
        def irregularity(pos: float) -> float:
            return float(np.interp(pos, px, pr, left=0.0, right=0.0))

    voids = _initial_voids(scenario, track)
    # sleepers over voids: their supports act only in contact (lccopt.vti.unilateral)
    supports = None if voids is None else sleeper_supports(track).with_gaps(voids)
    h = integrate(track, dt, speed, x_start, n_steps, vehicle=vehicle, irregularity=irregularity,
                  supports=supports, record_dofs=zone_dofs)
    # entry sleepers come first, in zone order
    in_contact = 1.0 if voids is None else h.support_contact[1:, :n_zone]

    v_mid = 0.5 * (h.dof_velocity[1:] + h.dof_velocity[:-1])
    # the ballast damper dissipates only while its sleeper touches the ballast
    energy = dt * track.entry_support_damping[:n_zone] * np.sum(v_mid ** 2 * in_contact, axis=0)
    # every wheel's force while that wheel is in the force zone (the same stretch of rail
    # whichever way the vehicle runs)
    wheel_pos, wheel_force = h.wheel_position, h.wheel_force
    # a wheel within 1 nm of a zone end counts as in it: where a step falls exactly on an end
    # (e.g. on a mirrored track) round-off must not decide
    zone_lo, zone_hi = min(zone_start, zone_end) - 1e-9, max(zone_start, zone_end) + 1e-9
    in_zone_w = (wheel_pos >= zone_lo) & (wheel_pos <= zone_hi)
    # F_max also takes the force at the zone's exact ends (linear between the steps): the
    # force can still be rising or falling there, and otherwise F_max would depend on where
    # the last step before zone_end happens to fall (up to 2 % at 0.4 ms steps).
    order = slice(None, None, -1) if leave else slice(None)   # np.interp: increasing positions
    ends = np.concatenate([np.interp([zone_start, zone_end], wheel_pos[order, i],
                                     wheel_force[order, i])
                           for i in range(wheel_pos.shape[1])])
    forces = wheel_force.T[in_zone_w.T]            # wheel by wheel, each in step order
    objectives = objectives_from(forces, energy, force_ends=ends)
    info = _info(vehicle, track, h, n_steps, dt, leave)
    if voids is not None:
        info["void_sleepers"] = int(np.count_nonzero(voids > 0.0))
        info["unsettled_steps"] = int(h.info["unsettled"])
    info["wall_time"] = time.perf_counter() - t0
    histories = _histories(vehicle, track, h, n_zone, energy, in_zone_w, profile)
    return Evaluation(objectives, histories, info)


def _initial_voids(scenario: Scenario, track) -> np.ndarray | None:
    """The gaps under the track's sleepers (entry then exit, ``track.sleeper_x``) of the
    scenario's variation, or None where every sleeper rests on its ballast as drawn (the
    linear model, bit for bit)."""
    variation = scenario.variation
    if variation is None or variation.void is None:
        return None
    n_entry, n_exit = len(track.entry_sleeper_x), len(track.exit_sleeper_x)
    gaps = variation.per_sleeper("void", n_entry, n_exit, 0.0)
    return gaps if np.any(gaps > 0.0) else None


def _info(vehicle, track, h, n_steps: int, dt: float, leave: bool) -> dict:
    """Scalars describing the run (``Evaluation.info``)."""
    x_start, zone_start, zone_end, x_end = track.window
    loss = h.wheel_force <= 0.0
    return {
        "speed": vehicle.speed,
        "static_wheel_load": vehicle.static_wheel_load,
        "hertz_load": vehicle.hertz_load,
        "contact_stiffness": vehicle.contact_stiffness,
        "contact_loss_steps": int(loss.any(axis=1).sum()),
        "contact_loss_first_position": (float(h.wheel_position[loss][0]) if loss.any()
                                        else float("nan")),
        "vehicle_type": vehicle.type,
        "n_wheels": int(h.wheel_position.shape[1]),
        "direction": "leave" if leave else "enter",
        "n_dofs": track.n_dofs,
        "n_steps": n_steps,
        "time_step": dt,
        "element_length": track.element_length,
        "x_start": x_start,
        "zone_start": zone_start,
        "zone_end": zone_end,
        "x_end": x_end,
        "interface_entry": track.interface[0],
        "interface_exit": track.interface[1],
        "type_ii_end": track.type_ii_end,
    }


def _histories(vehicle, track, h, n_zone: int, energy, in_zone_w, profile) -> dict:
    """Named time histories and zone arrays (``response.HISTORY_DOC``)."""
    out = {
        "time": h.time,
        "wheel_position": h.position,
        "contact_force": h.contact_force,
        "wheel_displacement": h.vehicle_displacement[:, vehicle.wheel_dofs[0]],
        "carbody_displacement": h.vehicle_displacement[:, 0],
        "rail_displacement": h.rail_displacement,
        "in_force_zone": in_zone_w[:, 0].astype(np.int8),
        "sleeper_position": track.entry_sleeper_x[:n_zone],
        "sleeper_energy": energy,
        "sleeper_strengthened": track.entry_strengthened[:n_zone].astype(np.int8),
        "sleeper_displacement": h.dof_displacement.astype(np.float32),
        "entry_sleeper_position": track.entry_sleeper_x,
        "entry_pad_stiffness": track.entry_pad_stiffness,
        "entry_strengthened": track.entry_strengthened.astype(np.int8),
        "wheel_positions": h.wheel_position,
        "contact_force_wheels": h.wheel_force,
        "in_force_zone_wheels": in_zone_w.astype(np.int8),
    }
    if profile is not None:
        out["irregularity_at_wheel"] = np.interp(h.position, profile[:, 0], profile[:, 1],
                                                 left=0.0, right=0.0)
    return out
