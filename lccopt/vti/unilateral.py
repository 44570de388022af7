"""Sleepers that can lift off the ballast: unilateral supports with voids, in Newmark steps.

A ballast sleeper's support (spring k_b and damper c_b) acts only while the sleeper touches the
ballast. Displacements u are those of the linear model: downward positive, measured from the
static equilibrium of the void-free track under its own weight, in which sleeper i rests
``rest_i`` below its weightless position. The ballast surface under sleeper i lies ``gap_i``
below the as-built level (the sleeper's weightless position), so with U_i = u_i + rest_i the
sleeper's absolute displacement

    penetration  p_i = u_i + rest_i - gap_i,   in contact iff p_i >= 0,
    support force F_i = k_b p_i + c_b u̇_i in contact, 0 over the void.

Relative to the linear model (spring k_b u_i, damper c_b u̇_i) that is, per sleeper, a
constant load k_b gap_i in contact, and out of contact the spring and damper removed and the
sleeper's static support force k_b rest_i (its weight share) set free. A sleeper whose gap
exceeds what the track's own weight closes hangs from the rail through its pad.

The effective matrix A = K + a0 M + a1 C (every support in) is factorised once, A = UᵀU, by
the Newmark loop (:mod:`lccopt.vti.newmark`). A sleeper over a void is a rank-one term
-(k_b + a1 c_b) e eᵀ; with the k moving wheel contacts (:mod:`lccopt.vti.wheels`) that makes
one Woodbury (capacitance) system of size k + m for m sleepers off the ballast, in the
factored form with rows U⁻ᵀe_j (kept per sleeper). Each step starts from the previous step's
contact set and iterates (active set) until every sleeper's state agrees with its
penetration, flipping every disagreeing sleeper at once. The damper makes a consistent set not
always exist (it can pull up a sleeper whose penetration says "in"); after ``max_iterations``
passes the sleepers still changing keep their state of the step before, and the step is
counted in ``History.info['unsettled']``. Where no sleeper is off the ballast a step is the
wheels' own step plus a gather of the sleepers' displacements (without voids, a run in which
no sleeper lifts is the linear run, bit for bit): no refactorisation, ever.

Discrete energy balance (THEORY.md's, extended): with the support forces' trapezoidal work
½(F_n + F_{n+1})·Δu the balance is exact; the spring's energy ½ k_b ⟨p⟩² differs from that
work only in a step where the sleeper switches, by ½ k_b p_n p_{n+1} (p_n, p_{n+1} on either
side of zero), which shrinks as Δt² (tests/vti/test_voids_energy.py).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from .banded import BandedFactor, Rows
from .wheels import Wheels

GRAVITY = 9.81


@dataclass(frozen=True)
class SleeperSupports:
    """Ballast sleepers whose support acts only in contact (arrays of one value per sleeper)."""
    dof: np.ndarray          # the sleeper's dof in the track model
    x: np.ndarray            # position along the track [m]
    stiffness: np.ndarray    # k_b [N/m]
    damping: np.ndarray      # c_b [N s/m]
    rest: np.ndarray         # deflection under the track's own weight, void-free track [m]
    gap: np.ndarray          # lowering of the ballast surface below the as-built level [m]

    def with_gaps(self, gap) -> "SleeperSupports":
        """The same sleepers over a ballast surface lowered by ``gap`` [m] (>= 0)."""
        gap = np.asarray(gap, dtype=float)
        if gap.shape != self.dof.shape or np.any(gap < 0) or not np.all(np.isfinite(gap)):
            raise ValueError("gaps: one finite value >= 0 per sleeper")
        return replace(self, gap=gap.copy())

    def penetration(self, u: np.ndarray) -> np.ndarray:
        """p = u + rest - gap at each sleeper for track displacements u [m]."""
        return u[self.dof] + self.rest - self.gap

    def free_loads(self, contact: np.ndarray) -> np.ndarray:
        """Constant load per sleeper in u-coordinates: k gap in contact, k rest over a void."""
        return self.stiffness * np.where(contact, self.gap, self.rest)


def self_weight_deflection(track, gravity: float = GRAVITY) -> np.ndarray:
    """Static displacement [m] of every dof under the track's own weight (void-free track).

    The weight is g M t with t = 1 on translational dofs, 0 on rotations: for the Hermite
    beams that is the consistent load of the mass per metre (the translational shape functions
    of an element sum to one)."""
    t = np.ones(track.K.shape[0])
    t[np.asarray(track.info["rotation_dofs"], dtype=int)] = 0.0
    return spsolve(track.K.tocsc(), gravity * (track.M @ t))


def sleeper_supports(track, sleepers=None, gravity: float = GRAVITY) -> SleeperSupports:
    """Unilateral supports for ballast sleepers of a built track, no voids yet.

    sleepers: indices into the track's sleepers (entry sleepers nearest the interface first,
    then exit sleepers; ``track.sleeper_x``); None for all of them."""
    idx = np.arange(len(track.sleeper_dof)) if sleepers is None else np.asarray(sleepers, int)
    dof = np.asarray(track.sleeper_dof)[idx]
    rest = self_weight_deflection(track, gravity)[dof]
    return SleeperSupports(dof=dof, x=np.asarray(track.sleeper_x, float)[idx],
                           stiffness=np.asarray(track.support_stiffness, float)[idx],
                           damping=np.asarray(track.support_damping, float)[idx],
                           rest=rest, gap=np.zeros(len(idx)))


def static_equilibrium(Kg, rhs: np.ndarray, supports: SleeperSupports,
                       max_iterations: int = 50) -> tuple[np.ndarray, np.ndarray]:
    """Solve Kg u = rhs with the unilateral sleepers (active set); return (u, contact).

    Kg: a stiffness (track, or track and vehicle bordered) whose leading dofs are the track's,
    with every support in. Each pass solves with the current contact set and flips every
    sleeper whose penetration disagrees with it."""
    Kg = sp.csc_matrix(Kg)
    dof, k = supports.dof, supports.stiffness
    contact = supports.gap <= supports.rest            # where the track's weight closes it
    for _ in range(max_iterations):
        out = ~contact
        a = Kg - sp.csc_matrix((k[out], (dof[out], dof[out])), shape=Kg.shape) if out.any() else Kg
        b = np.array(rhs, dtype=float)
        np.add.at(b, dof, supports.free_loads(contact))
        u = spsolve(a.tocsc(), b)
        now = supports.penetration(u) >= 0.0
        if np.array_equal(now, contact):
            return u, contact
        contact = now
    raise RuntimeError(f"static contact of the sleepers did not settle in {max_iterations} passes")


def rest_state(track, supports: SleeperSupports) -> np.ndarray:
    """Track displacements u [m] at rest (own weight only) over the voids of ``supports``:
    the unloaded track geometry relative to the as-built one."""
    return static_equilibrium(track.K, np.zeros(track.K.shape[0]), supports)[0]


class SupportContacts:
    """Unilateral sleeper supports with the wheels' moving contacts: the step object of the
    Newmark loop (:func:`lccopt.vti.newmark.integrate` with ``supports``; module docstring).

    The loop records q and u at the sleepers (``watch_dofs``): the support forces follow from
    them. ``info``: {"iterations": most active-set passes of a step, "unsettled": steps whose
    contact set did not settle, "switches": contact changes}."""

    def __init__(self, wheels: Wheels, supports: SleeperSupports, max_iterations: int = 8):
        self.wheels, self.sup, self.max_iterations = wheels, supports, max_iterations
        self.steps, self.time = wheels.steps, wheels.time
        self.watch_dofs = supports.dof
        self.contact = np.zeros((wheels.steps, len(supports.dof)), dtype=bool)
        self.low = supports.gap - supports.rest          # in contact iff u >= gap - rest
        self.a1 = 2.0 / wheels.dt
        self.stats = {"iterations": 0, "unsettled": 0, "switches": 0}

    def start(self, track, initial=None, vehicle_offset=None):
        """(u0, v0, a0): the static equilibrium with the wheels in place over the voids."""
        K = track.K.tocsr()
        n = K.shape[0]
        Kg, rhs = self.wheels.static_system(K)
        sol, self.contact[0] = static_equilibrium(Kg, rhs, self.sup)
        return self.wheels.take_start(sol, n, vehicle_offset), np.zeros(n), np.zeros(n)

    def begin(self, factor: BandedFactor) -> None:
        self.wheels.begin(factor)
        self.factor = factor
        self.rows = Rows(factor)
        self.free = np.zeros(factor.n)   # constant support loads of the current contact set
        np.add.at(self.free, self.sup.dof, self.sup.free_loads(self.contact[0]))
        self.out = _OutSet(self.rows, self.sup, self.contact[0], self.a1)

    def step(self, s: int, rhs: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Start from the previous step's contact set and iterate until every sleeper's state
        agrees with its penetration, flipping every disagreeing sleeper at once; after
        ``max_iterations`` passes the sleepers still changing keep their state of the step
        before (a damper can pull up a sleeper whose penetration says "in")."""
        wheels, out, sup, stats = self.wheels, self.out, self.sup, self.stats
        wheels.prepare(s)
        rhs += self.free
        if len(out.dofs):                  # the dampers of the sleepers off the ballast
            rhs[out.dofs] -= out.c_out * q[out.dofs]
        y = self.factor.forward(rhs)
        c0 = wheels.offsets(s)
        start = out.contact.copy()
        last = self.max_iterations + 1
        for it in range(1, last + 1):
            delta, u = self._solve(y, c0)
            now = u[sup.dof] >= self.low
            changed = now ^ out.contact
            if not changed.any():
                break
            if it == last:                 # the step's last solve: accepted as it is
                stats["unsettled"] += 1
                break
            if it == self.max_iterations:
                now = np.where(changed, start, out.contact)
                changed = now ^ out.contact
                if not changed.any():
                    stats["unsettled"] += 1
                    break
            # move the changed sleepers' constant loads (and dampers) into y
            y = y + np.dot(out.switch(now, changed, q), self.rows.get(sup.dof[changed]))
            self.free[sup.dof[changed]] = sup.free_loads(now)[changed]
            stats["switches"] += int(changed.sum())
        stats["iterations"] = max(stats["iterations"], it)
        wheels.finish(s, delta)
        self.contact[s] = out.contact
        return u

    def _solve(self, y: np.ndarray, c0):
        """(δ, u') for the current contact set: the wheels' own update where every sleeper
        touches the ballast."""
        wheels = self.wheels
        if not len(self.out.dofs):
            delta, coef = wheels.solve(y, c0)
            return delta, self.factor.backward(wheels.correct(y, coef))
        z, delta = self.out.solve(y, wheels.Sm, np.atleast_1d(c0), wheels.rider.kap)
        return (delta if wheels.k > 1 else delta[0]), self.factor.backward(z)

    def state(self, s: int) -> dict:
        return dict(self.wheels.state(s), contact=self.out.contact.copy())

    def history(self, q: np.ndarray, u: np.ndarray) -> dict:
        """The wheels' History fields and the supports' forces from their recorded u, q."""
        sup = self.sup
        force = np.where(self.contact, sup.stiffness * (u + sup.rest - sup.gap)
                         + sup.damping * (q - self.a1 * u), 0.0)
        return dict(self.wheels.history(q, u), support_force=force,
                    support_contact=self.contact.astype(np.int8), info=dict(self.stats))


class _OutSet:
    """The sleepers off the ballast in a step: their rows U⁻ᵀe_j, the Woodbury terms, the solve.

    With D = diag(k_b + a1 c_b) over the m sleepers off the ballast, E their rows and S the
    wheels' rows, the step's displacements are u' = U⁻¹(y + Sᵀc + Eᵀ D σ) with the wheel
    forces c = c0 - Κ δ, where δ = S(...) and σ = E(...) solve

        [I + S Sᵀ Κ    -S Eᵀ D] [δ]   [S y + S Sᵀ c0]
        [E Sᵀ Κ     I - E Eᵀ D] [σ] = [E y + E Sᵀ c0].
    """

    def __init__(self, rows: Rows, sup: SleeperSupports, contact, a1):
        self.rows, self.sup, self.a1 = rows, sup, a1
        self.contact = np.array(contact, dtype=bool)
        self._refresh()

    def _refresh(self):
        out = ~self.contact
        self.dofs = self.sup.dof[out]
        self.c_out = self.sup.damping[out]
        self.d = self.sup.stiffness[out] + self.a1 * self.c_out
        self.E = self.rows.get(self.dofs) if out.any() else np.zeros((0, self.rows.factor.n))
        self.GEE = self.E @ self.E.T

    def switch(self, now, changed, q) -> np.ndarray:
        """Update the contact set; return the change of the right-hand side at the changed
        sleepers (constant loads k gap <-> k rest, and the damper term c_b q)."""
        sup = self.sup
        i = np.flatnonzero(changed)
        goes_out = ~now[i]
        dload = sup.free_loads(now)[i] - sup.free_loads(self.contact)[i]
        dq = dload + np.where(goes_out, -1.0, 1.0) * sup.damping[i] * q[sup.dof[i]]
        self.contact = now.copy()
        self._refresh()
        return dq

    def solve(self, y, Sm, c0, kap):
        """(y + Sᵀc + Eᵀ D σ, δ): the vector to solve backward for u', and δ (m > 0)."""
        k, m = Sm.shape[0], len(self.dofs)
        E, D = self.E, self.d
        gN, gE = Sm @ y, E @ y
        GNN, GNE = Sm @ Sm.T, Sm @ E.T
        A = np.empty((k + m, k + m))      # filled in place: np.block costs more than the solve
        A[:k, :k] = GNN @ kap
        A[:k, k:] = -GNE * D
        A[k:, :k] = GNE.T @ kap
        A[k:, k:] = -(self.GEE * D)
        A.flat[::k + m + 1] += 1.0
        b = np.concatenate([gN + GNN @ c0, gE + GNE.T @ c0])
        w = np.linalg.solve(A, b)
        delta, sigma = w[:k], w[k:]
        return y + (c0 - kap @ delta) @ Sm + (D * sigma) @ E, delta
