"""The moving wheel-rail contacts: one step object of the Newmark loop (:mod:`.newmark`).

The coupled system of one step (Eq. 3, k wheels) is

    [A_t + k_w N Nᵀ    -k_w N Wᵀ      ] [u]   [b_t - k_w N r]
    [-k_w W Nᵀ        A_v + k_w W Wᵀ  ] [z] = [b_v + k_w W r]

with A = K + 4/Δt² M + 2/Δt C for track (t) and vehicle (v), N = [N_1 .. N_k] the Hermite
vectors at the wheels' positions, W the vehicle's wheel dofs and r the rail irregularity under
each wheel (dip positive). Eliminating the vehicle (B = A_v + k_w W Wᵀ) leaves

    (A_t + N Κ Nᵀ) u = b_t + N c0,    Κ = k_w (I - k_w Wᵀ B⁻¹ W)    (k x k),

c0 = k_w (Wᵀ B⁻¹ (b_v + k_w W r) - r), and the contact forces c = c0 - Κ δ with δ = Nᵀu. A
constant moving force P is the same with Κ = 0 and c0 = P. With A_t = UᵀU factorised once
(:class:`~.banded.BandedFactor`), y = U⁻ᵀ b_t and S = U⁻ᵀ N (rows U⁻ᵀe_j, solved when a wheel
enters an element; the next element shares a node, so that costs two rows): δ = Sᵀy + SᵀS c,
i.e. (I + SᵀS Κ) δ = Sᵀy + SᵀS c0, then u = U⁻¹(y + S c). One wheel: Sherman-Morrison on
scalars; k wheels: the k x k capacitance system of Woodbury's identity. Per step: one forward
and one backward banded triangular solve, k products with the cached rows, a k x k solve. The
solution is the coupled system's, solved outright, to round-off.

The vehicle may run either way (negative speed). The leading wheel must stay on the modelled
rail for the whole run (checked; the case's window is chosen so); a trailing wheel beyond a
rail end rests on a rigid continuation of the rail (N_i = 0: its row of S vanishes, δ_i = 0).
A trailing wheel meets the elements the leading one met: their rows are kept and copied, not
solved again, and dropped once behind the last wheel.
"""

from __future__ import annotations

from typing import Callable, Protocol

import numpy as np
import scipy.sparse as sp
from scipy.linalg import blas
from scipy.sparse.linalg import spsolve

from .assembly import hermite
from .banded import BandedFactor, Rows


class TrackLike(Protocol):
    M: sp.spmatrix
    C: sp.spmatrix
    K: sp.spmatrix
    node_x: np.ndarray      # rail node positions, increasing [m]
    rail_w: np.ndarray      # dof of rail deflection per node (-1: fixed)
    rail_th: np.ndarray     # dof of rail rotation per node


def contact_vectors(track: TrackLike, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element index, dof indices (n, 4) and Hermite values (n, 4) of N at positions x.

    Fixed dofs get index 0 and value 0, so they take no part in the products."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    nx = track.node_x
    e = np.clip(np.searchsorted(nx, x, side="right") - 1, 0, len(nx) - 2)
    vals = hermite(x - nx[e], nx[e + 1] - nx[e])
    idx = np.stack([track.rail_w[e], track.rail_th[e], track.rail_w[e + 1], track.rail_th[e + 1]],
                   axis=1)
    vals[idx < 0] = 0.0
    idx[idx < 0] = 0
    return e, idx, vals


def contact_vector(track: TrackLike, x: float) -> tuple[np.ndarray, np.ndarray]:
    """Dof indices and Hermite values of N at one position x."""
    _, idx, vals = contact_vectors(track, x)
    return idx[0], vals[0]


def _check_on_rail(track: TrackLike, positions) -> None:
    """Every wheel stays on the modelled rail for the whole run (the window is chosen so; a
    wheel beyond a rail end would be extrapolated from the end element)."""
    p = np.asarray(positions, dtype=float)
    lo, hi = float(track.node_x[0]), float(track.node_x[-1])
    if p.min() < lo - 1e-9 or p.max() > hi + 1e-9:
        raise ValueError(f"a wheel runs from {p.min():.3f} m to {p.max():.3f} m, beyond the "
                         f"modelled rail [{lo:g}, {hi:g}] m: lengthen the track or shorten the run")


class _Force:
    """A constant moving force ``load`` [N] on one contact: Κ = 0, c0 = P, no vehicle dofs."""

    def __init__(self, load: float, steps: int):
        self.load = float(load)
        self.k, self.nv, self.kap, self.kap1 = 1, 0, np.zeros((1, 1)), 0.0
        self.z = np.zeros((steps, 0))

    def static_system(self, K, Nm, idx, vals, r0):
        return K.tocsc(), Nm @ np.full(1, self.load)

    def start(self, z, delta, r0, offset) -> np.ndarray:
        if offset is not None:
            raise ValueError("vehicle_offset needs a vehicle")
        return np.full(1, self.load)

    def offsets(self, r):
        return self.load

    def finish(self, s, r, delta):
        return self.load

    def state(self):
        return None, None, None


class _Vehicle:
    """A vehicle on its wheels' Hertz springs, eliminated (module docstring): its state
    t = [z, ż, z̈, 1, r (k), δ (k)] moves by small products, c0 = Crow t and t' = G t."""

    def __init__(self, vehicle, dt: float, steps: int):
        a0, a1, a2 = 4.0 / dt ** 2, 2.0 / dt, 4.0 / dt
        Mv, Cv, Kv, fv = (np.asarray(a, dtype=float)
                          for a in (vehicle.M, vehicle.C, vehicle.K, vehicle.weight_load))
        self.Mv, self.Kv, self.fv = Mv, Kv, fv
        self.nv = nv = Mv.shape[0]
        self.W = W = np.asarray(vehicle.wheel_dofs, dtype=int)
        self.k = k = len(W)
        self.kw = kw = vehicle.contact_stiffness
        B = Kv + a0 * Mv + a1 * Cv
        B[W, W] += kw
        Binv = np.linalg.inv(B)
        self.kap = kw * (np.eye(k) - kw * Binv[np.ix_(W, W)])
        self.kap1 = self.kap[0, 0]
        # z0 = Q t (the vehicle's displacements without the rail's), z' = Qd t; with
        # Newmark's ż', z̈' from z, ż, z̈, z' that makes t' = G t, and c0 = Crow t
        kb = kw * Binv[:, W]
        Q = np.hstack([Binv @ (a0 * Mv + a1 * Cv), Binv @ (a2 * Mv + Cv), Binv @ Mv,
                       (Binv @ fv)[:, None], kb, np.zeros((nv, k))])
        Qd = Q.copy()
        Qd[:, 3 * nv + 1 + k:] = kb
        I, O = np.eye(nv), np.zeros((nv, nv))
        Rv = np.block([[O, O, O, I], [-a1 * I, -I, O, a1 * I], [-a0 * I, -a2 * I, -I, a0 * I]])
        self.G = Rv[:, 3 * nv:] @ Qd
        self.G[:, :3 * nv] += Rv[:, :3 * nv]
        sel_r = np.zeros((k, Q.shape[1]))
        sel_r[:, 3 * nv + 1:3 * nv + 1 + k] = np.eye(k)
        crow = kw * (Q[W] - sel_r)
        # where r and δ go in t, and the wheel dofs: one wheel's as scalars (c0, δ, the force)
        if k == 1:
            self.crow, self.w_at = crow[0].copy(), W[0]
            self.r_at, self.d_at = 3 * nv + 1, 3 * nv + 2
        else:
            self.crow, self.w_at = crow, W
            self.r_at = slice(3 * nv + 1, 3 * nv + 1 + k)
            self.d_at = slice(3 * nv + 1 + k, 3 * nv + 1 + 2 * k)
        self.n3 = 3 * nv
        self.t = np.zeros(3 * nv + 1 + 2 * k)
        self.z = np.zeros((steps, nv))

    def static_system(self, K, Nm, idx, vals, r0):
        """The track and the vehicle bordered, every wheel on its contact spring."""
        n, nv, k, W, kw = K.shape[0], self.nv, self.k, self.W, self.kw
        Wm = sp.csr_matrix((np.ones(k), (W, np.arange(k))), shape=(nv, k))
        Kg = sp.bmat([[K + kw * (Nm @ Nm.T), -kw * (Nm @ Wm.T)],
                      [-kw * (Wm @ Nm.T), sp.csr_matrix(self.Kv) + kw * (Wm @ Wm.T)]],
                     format="csc")
        rhs = np.zeros(n + nv)
        np.add.at(rhs, idx.ravel(), -kw * (r0[:, None] * vals).ravel())
        rhs[n:] = self.fv
        rhs[n + W] += kw * r0
        return Kg, rhs

    def start(self, z, delta, r0, offset) -> np.ndarray:
        """Take the static displacements z (plus ``offset``: free vibration from a chosen
        shape, from the consistent accelerations); the contact forces."""
        zdd = np.zeros(self.nv)
        if offset is not None:
            z = z + np.asarray(offset, dtype=float)
            fc = self.kw * (z[self.W] - delta - r0)
            load = self.fv - self.Kv @ z
            load[self.W] -= fc
            zdd = np.linalg.solve(self.Mv, load)
        self.t[:] = np.concatenate([z, np.zeros(self.nv), zdd, [1.0], np.zeros(2 * self.k)])
        self.z[0] = z
        return self.kw * (z[self.W] - delta - r0)

    def offsets(self, r):
        """c0 for the rail dips r under the wheels."""
        t = self.t
        t[self.r_at] = r
        return np.dot(self.crow, t)

    def finish(self, s, r, delta):
        """The vehicle's state after the step with rail displacements δ; the contact forces."""
        t = self.t
        t[self.d_at] = delta
        t[:self.n3] = np.dot(self.G, t)
        self.z[s] = t[:self.nv]
        return self.kw * (t[self.w_at] - delta - r)

    def state(self):
        nv, t = self.nv, self.t
        return t[:nv].copy(), t[nv:2 * nv].copy(), t[2 * nv:3 * nv].copy()


class Wheels:
    """The k moving contacts of a vehicle (or one constant moving force ``load``) running from
    ``x_start`` at ``speed`` for ``n_steps`` steps of ``dt``: the coupling the Newmark loop
    calls each step (module docstring)."""

    watch_dofs = np.zeros(0, dtype=int)

    def __init__(self, track: TrackLike, dt: float, speed: float, x_start: float, n_steps: int,
                 *, vehicle=None, load: float = 0.0,
                 irregularity: Callable[[float], float] | None = None):
        self.steps = steps = n_steps + 1
        self.dt = dt
        self.time = dt * np.arange(steps)
        self.lead = x_start + speed * self.time
        _check_on_rail(track, self.lead)
        self.rider = _Force(load, steps) if vehicle is None else _Vehicle(vehicle, dt, steps)
        self.k = k = self.rider.k
        offsets = np.zeros(1) if vehicle is None else np.asarray(vehicle.wheel_offsets, float)
        self.pos = self.lead[:, None] - (-1.0 if speed < 0 else 1.0) * offsets[None, :]
        elem, idx, vals = contact_vectors(track, self.pos.ravel())
        self.elem, self.idx, self.vals = (elem.reshape(steps, k), idx.reshape(steps, k, 4),
                                          vals.reshape(steps, k, 4))
        off = (self.pos < track.node_x[0] - 1e-9) | (self.pos > track.node_x[-1] + 1e-9)
        self.vals[off], self.idx[off], self.elem[off] = 0.0, 0, -1
        self.entering = np.r_[True, True, (self.elem[2:] != self.elem[1:-1]).any(axis=1)]
        self.r = (np.array([irregularity(p) for p in self.pos.ravel()], float).reshape(steps, k)
                  if irregularity is not None else np.zeros((steps, k)))
        self.r_step = self.r[:, 0] if k == 1 else self.r      # one wheel: scalars
        self.forward_travel = speed >= 0
        self.force = np.zeros((steps, k))
        self.rail = np.zeros((steps, k))

    # --- the start: static equilibrium with every wheel in place
    def static_system(self, K) -> tuple:
        """(Kg, rhs): the static system with every wheel at its start position; its first
        K.shape[0] unknowns are the track's, the rest the vehicle's."""
        n, k, idx, vals = K.shape[0], self.k, self.idx[0], self.vals[0]
        Nm = sp.csr_matrix((vals.ravel(), (idx.ravel(), np.repeat(np.arange(k), 4))),
                           shape=(n, k))
        return self.rider.static_system(K, Nm, idx, vals, self.r[0])

    def take_start(self, sol: np.ndarray, n: int, vehicle_offset=None) -> np.ndarray:
        """The track's displacements u0 at t = 0 from the static system's solution ``sol``
        (or the track's state); the vehicle's go to its state (plus ``vehicle_offset``)."""
        u0 = sol[:n]
        delta = np.array([v @ u0[i] for v, i in zip(self.vals[0], self.idx[0])])
        self.rail[0] = delta
        self.force[0] = self.rider.start(sol[n:].copy(), delta, self.r[0], vehicle_offset)
        return u0

    def start(self, track, initial=None, vehicle_offset=None):
        """(u0, v0, a0) of the track at t = 0: static equilibrium with every wheel in place, or
        ``initial`` = (u0, v0) for a moving force (its accelerations from equilibrium)."""
        K = track.K.tocsr()
        n = K.shape[0]
        Kg, rhs = self.static_system(K)
        if initial is None:
            return self.take_start(spsolve(Kg, rhs), n, vehicle_offset), np.zeros(n), np.zeros(n)
        if self.rider.nv:
            raise ValueError("an initial track state is supported for a moving load only")
        u0, v0 = (np.asarray(a, dtype=float).copy() for a in initial)
        self.take_start(u0, n, vehicle_offset)
        return u0, v0, spsolve(track.M.tocsc(), rhs - K @ u0 - track.C @ v0)

    # --- the steps
    def begin(self, factor: BandedFactor) -> None:
        """Take the factorised effective matrix; the first step follows."""
        n, k = factor.n, self.k
        self.factor = factor
        self.rows = Rows(factor, cache=k > 1)
        self.scols = np.zeros((k, 4, n))
        self.Sm = np.zeros((k, n))
        self.s_vec, self.vals1 = self.Sm[0], self.vals[:, 0]
        self.force1, self.rail1 = self.force[:, 0], self.rail[:, 0]
        self.prev = [-10] * k
        self.on = []                     # (wheel, its rows, its row of S) on the rail
        self._eye = np.eye(k)
        if k == 1:                       # the same step, written out on scalars
            self.step = self._step_one

    def _enter(self, s: int) -> None:
        """Rows U⁻ᵀe_j of the elements the wheels enter at step s."""
        scols, fill, idx, prev = self.scols, self.rows.fill, self.idx[s], self.prev
        for i, e in enumerate(self.elem[s].tolist()):
            p = prev[i]
            if e == p:
                continue
            if e < 0:                            # off the modelled rail: no coupling
                self.Sm[i] = 0.0
                e = -10
            elif e == p + 1:                     # the next element shares a node: two rows
                scols[i, :2] = scols[i, 2:]
                fill(scols[i, 2:], idx[i, 2:])
            elif e == p - 1:
                scols[i, 2:] = scols[i, :2]
                fill(scols[i, :2], idx[i, :2])
            else:
                fill(scols[i], idx[i])
            prev[i] = e
        self.on = [(i, scols[i], self.Sm[i]) for i, p in enumerate(prev) if p >= 0]

    def prepare(self, s: int) -> None:
        """S = U⁻ᵀN of step s (rows of the wheels on the rail)."""
        if self.entering[s]:
            self._enter(s)
        if self.k > 1 and s % 64 == 0:
            on = self.elem[s] >= 0
            held = self.idx[s][on][self.vals[s][on] != 0.0]
            if held.size:
                self.rows.forget_behind(int(held.min()), int(held.max()), self.forward_travel)
        if self.k == 1:
            np.dot(self.vals1[s], self.scols[0], out=self.s_vec)
            return
        vals = self.vals[s]
        for i, rows, out in self.on:
            np.dot(vals[i], rows, out=out)

    def offsets(self, s: int):
        """c0 of step s (a scalar for one wheel)."""
        return self.rider.offsets(self.r_step[s])

    def solve(self, y: np.ndarray, c0):
        """(δ, c): rail displacements under the wheels and contact forces (or their Woodbury
        coefficients) for y = U⁻ᵀb_t."""
        if self.k == 1:
            sv, kap = self.s_vec, self.rider.kap1
            g2 = np.dot(sv, sv)
            delta = (np.dot(sv, y) + c0 * g2) / (1.0 + kap * g2)
            return delta, c0 - kap * delta
        Sm, kap = self.Sm, self.rider.kap
        G2 = np.dot(Sm, Sm.T)
        delta = np.linalg.solve(self._eye + np.dot(G2, kap), np.dot(Sm, y) + np.dot(G2, c0))
        return delta, c0 - np.dot(kap, delta)

    def correct(self, y: np.ndarray, coef) -> np.ndarray:
        """y + S c (a new array), to be solved backward for u."""
        if self.k == 1:
            return blas.daxpy(self.s_vec, y.copy(), a=coef)
        return y + np.dot(coef, self.Sm)

    def finish(self, s: int, delta) -> None:
        """Record step s: the vehicle moves on, the contact forces."""
        self.force[s] = self.rider.finish(s, self.r_step[s], delta)
        self.rail[s] = delta

    def step(self, s: int, rhs: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Displacements u of step s for the track's right-hand side ``rhs`` (overwritten); one
        wheel takes :meth:`_step_one` instead."""
        self.prepare(s)
        factor, rider, r = self.factor, self.rider, self.r_step[s]
        y = factor.forward(rhs)
        delta, coef = self.solve(y, rider.offsets(r))
        self.force[s] = rider.finish(s, r, delta)
        self.rail[s] = delta
        return factor.backward(self.correct(y, coef))

    def _step_one(self, s: int, rhs: np.ndarray, q: np.ndarray) -> np.ndarray:
        """:meth:`step` of one wheel, :meth:`prepare`, :meth:`solve` and :meth:`correct`
        written out on scalars (the Python around a step is a fair part of its cost)."""
        if self.entering[s]:
            self._enter(s)
        sv, rider, chol, kd = self.s_vec, self.rider, self.factor.chol, self.factor.kd
        np.dot(self.vals1[s], self.scols[0], out=sv)
        y = blas.dtbsv(kd, chol, rhs, trans=1, overwrite_x=1)
        r = self.r_step[s]
        c0, kap, g2 = rider.offsets(r), rider.kap1, np.dot(sv, sv)
        delta = (np.dot(sv, y) + c0 * g2) / (1.0 + kap * g2)
        self.force1[s] = rider.finish(s, r, delta)
        self.rail1[s] = delta
        return blas.dtbsv(kd, chol, blas.daxpy(sv, y, a=c0 - kap * delta), overwrite_x=1)

    # --- what the run gives
    def state(self, s: int) -> dict:
        """The step's contacts and vehicle state, for an ``on_step`` hook."""
        z, zd, zdd = self.rider.state()
        return dict(z=z, zd=zd, zdd=zdd, idx=self.idx[s], vals=self.vals[s],
                    force=self.force[s].copy())

    def history(self, q: np.ndarray, u: np.ndarray) -> dict:
        """History fields of the wheels (q, u: the watched dofs' records, none here)."""
        return dict(position=self.lead, contact_force=self.force[:, 0].copy(),
                    rail_displacement=self.rail[:, 0].copy(), vehicle_displacement=self.rider.z,
                    wheel_position=self.pos, wheel_force=self.force,
                    wheel_rail_displacement=self.rail)
