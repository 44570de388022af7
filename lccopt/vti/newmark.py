"""Newmark average-acceleration integration of the track: the one time loop.

Every simulation runs through :func:`integrate`: the track (M, C, K) and a coupling, the step
object that the loop calls once per step with the track's right-hand side and that returns
the step's displacements. The couplings:

* :class:`~lccopt.vti.wheels.Wheels`: the moving wheel-rail contacts of a vehicle with one
  wheel or k wheels on the rail (the vehicle eliminated through its Hertz springs: one moving
  rank-one term per wheel, Sherman-Morrison or Woodbury), or a constant moving force;
* :class:`~lccopt.vti.unilateral.SupportContacts`: the same with sleepers whose ballast
  support acts only in contact (voids): more low-rank terms for the sleepers off the ballast,
  and an active set per step.

The loop owns what is common: the static start (asked of the coupling), the effective matrix
A = K + 4/Δt² M + 2/Δt C factorised once (:class:`~lccopt.vti.banded.BandedFactor`: a
banded Cholesky, dofs numbered along the track), the right-hand side and the Newmark update,
and the records. The track state is kept as p = a0 u + a2 v + a, q = a1 u + v and u, so that
the right-hand side M(a0 u + a2 v + a) + C(a1 u + v) is one sparse product [M C] [p; q], and
Newmark's updates of v and a become (with a1 a2 = 2 a0) q' = 2 a1 u' - q, p' = 4 a0 u' - a2 q
- p; v = q - a1 u and a = p - a0 u - a2 v are formed only where they are recorded.

No flush of tiny values: in the reference track the smallest nonzero state value is ~1e-68,
far above the denormal range; denormals appear only where a track end lies several hundred
metres from the wheel (the exponential decay of the deflection), a band of a few hundred dofs
that every banded solve regenerates, so a periodic flush could not remove them anyway
(benchmarks/RESULTS-simulator.md, "Denormals").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp

from .banded import BandedFactor
from .unilateral import SleeperSupports, SupportContacts
from .wheels import TrackLike, Wheels


@dataclass
class History:
    time: np.ndarray
    position: np.ndarray                # of the leading wheel
    contact_force: np.ndarray           # of the leading wheel
    rail_displacement: np.ndarray       # Nᵀu under the leading wheel
    vehicle_displacement: np.ndarray    # (steps+1, vehicle dofs), e.g. carbody, bogie, wheel
    dof_displacement: np.ndarray        # (steps+1, len(record_dofs))
    dof_velocity: np.ndarray            # (steps+1, len(record_dofs))
    wheel_position: np.ndarray          # (steps+1, wheels), front first
    wheel_force: np.ndarray             # (steps+1, wheels)
    wheel_rail_displacement: np.ndarray  # (steps+1, wheels)
    # unilateral sleeper supports (lccopt/vti/unilateral.py), else None
    support_force: np.ndarray | None = None    # (steps+1, supports) ballast force [N]
    support_contact: np.ndarray | None = None  # (steps+1, supports) 1 in contact, 0 over a void
    info: dict | None = None                   # active-set statistics of the unilateral supports


@dataclass
class StepState:
    """What an ``on_step`` hook sees after step ``step``: the track's u, v, a; the vehicle's
    z, ż, z̈ (None for a moving force); the contacts' dof indices and Hermite values (wheels
    x 4) and forces (wheels); the sleepers' contact (None without unilateral supports)."""
    step: int
    u: np.ndarray
    v: np.ndarray
    a: np.ndarray
    z: np.ndarray | None
    zd: np.ndarray | None
    zdd: np.ndarray | None
    idx: np.ndarray
    vals: np.ndarray
    force: np.ndarray
    contact: np.ndarray | None = None


def integrate(track: TrackLike, dt: float, speed: float, x_start: float, n_steps: int, *,
              vehicle=None, load: float = 0.0, irregularity: Callable[[float], float] | None = None,
              supports: SleeperSupports | None = None, record_dofs: np.ndarray | None = None,
              initial: tuple | None = None, vehicle_offset: np.ndarray | None = None,
              on_step: Callable[[StepState], None] | None = None,
              max_iterations: int = 8) -> History:
    """Run ``n_steps`` Newmark steps from static equilibrium with the wheels in place.

    vehicle: a vehicle (:func:`lccopt.vti.vehicle.build_vehicle`) coupled through its Hertz
    springs, its leading wheel starting at ``x_start`` and the others ``wheel_offsets``
    behind it; or None for one constant moving force ``load`` [N]. speed may be negative (the
    vehicle runs towards -x).
    irregularity: the rail's dip [m] at a position [m] (none: a smooth rail).
    supports: sleepers whose ballast support acts only in contact
    (:class:`~lccopt.vti.unilateral.SleeperSupports`, with their voids); the History then has
    their forces and contact, and the active set's statistics (``max_iterations`` passes a
    step at most). None: every support is linear.
    record_dofs: dofs whose displacement and velocity are recorded every step.
    initial: (u, v) of the track instead of static equilibrium (a moving force on linear
    supports only), e.g. a known steady state; the accelerations follow from equilibrium.
    vehicle_offset: displacements added to the vehicle's static position at t = 0 (free
    vibration from a chosen shape).
    on_step: called with a :class:`StepState` after each step (tests).
    """
    wheels = Wheels(track, dt, speed, x_start, n_steps, vehicle=vehicle, load=load,
                    irregularity=irregularity)
    if supports is None:
        return run(track, dt, wheels, record_dofs, initial=initial,
                   vehicle_offset=vehicle_offset, on_step=on_step)
    if initial is not None:
        raise ValueError("an initial track state is supported on linear supports only")
    return run(track, dt, SupportContacts(wheels, supports, max_iterations), record_dofs,
               vehicle_offset=vehicle_offset, on_step=on_step)


def run(track: TrackLike, dt: float, coupling, record_dofs=None, *, initial=None,
        vehicle_offset=None, on_step: Callable[[StepState], None] | None = None) -> History:
    """The Newmark loop over ``coupling.steps`` - 1 steps of ``dt`` (module docstring).

    coupling: a step object with ``start(track, initial, vehicle_offset) -> (u0, v0, a0)``,
    ``begin(factor)``, ``step(s, rhs, q) -> u``, ``watch_dofs`` (dofs whose q and u it wants
    recorded), ``state(s)`` (for ``on_step``) and ``history(q, u) -> fields of History``.
    """
    M, C, K = track.M.tocsr(), track.C.tocsr(), track.K.tocsr()
    n = K.shape[0]
    a0, a1, a2 = 4.0 / dt ** 2, 2.0 / dt, 4.0 / dt
    u0, v0, acc0 = coupling.start(track, initial, vehicle_offset)
    coupling.begin(BandedFactor(K + a0 * M + a1 * C))
    MC = sp.hstack([M, C]).tocsr()
    S = np.zeros((3, n))                # rows p, q, u
    S_next = np.zeros((3, n))
    S[0] = a0 * u0 + a2 * v0 + acc0
    S[1] = a1 * u0 + v0
    S[2] = u0
    R = np.array([[-1.0, -a2, 4.0 * a0], [0.0, -1.0, 2.0 * a1]])   # [p; q; u'] -> [p'; q']
    own = np.asarray(record_dofs if record_dofs is not None else [], dtype=int)
    dofs = np.concatenate([own, coupling.watch_dofs]).astype(int)
    steps = coupling.steps
    rec = np.zeros((steps, 2, len(dofs)))       # q and u at the recorded dofs
    rec[0, 0] = a1 * u0[dofs] + v0[dofs]
    rec[0, 1] = u0[dofs]
    # the records gathered from the flat state (one index, not two: a fair share of a step)
    rec_flat, at = rec.reshape(steps, -1), np.concatenate([n + dofs, 2 * n + dofs])
    flat, flat_next = S.reshape(-1), S_next.reshape(-1)
    step = coupling.step
    for s in range(1, steps):
        S[2] = step(s, MC @ S[:2].reshape(-1), S[1])
        np.dot(R, S, out=S_next[:2])
        S_next[2] = S[2]
        S, S_next, flat, flat_next = S_next, S, flat_next, flat
        rec_flat[s] = flat[at]
        if on_step is not None:
            u = S[2]
            v = S[1] - a1 * u
            on_step(StepState(s, u, v, S[0] - a0 * u - a2 * v, **coupling.state(s)))
    rec_u, rec_q = rec[:, 1], rec[:, 0]
    mine = len(own)
    return History(time=coupling.time, dof_displacement=rec_u[:, :mine],
                   dof_velocity=rec_q[:, :mine] - a1 * rec_u[:, :mine],
                   **coupling.history(q=rec_q[:, mine:], u=rec_u[:, mine:]))
