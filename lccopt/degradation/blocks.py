"""A block of load cycles on the settling sleepers: the loads of every axle as a function of the
sleepers' settlement, and the settlement at the end of a block solved implicitly."""

from __future__ import annotations

import numpy as np

from .loading import SettlementZone
from .statics import ZoneStatics

_NEWTON_TOLERANCE = 1.0e-8          # [m] residual of a block's settlement


class SleeperLoads:
    """Loads of every axle of every condition on the settling sleepers, as a function of their
    settlement: quasi-static part (the track's statics) + the last simulation's dynamic part."""

    def __init__(self, statics: ZoneStatics, zone: SettlementZone, conditions, rail_seats,
                 reading: str = "axle"):
        n = zone.n_settling
        self.statics, self.zone, self.scale = statics, zone, rail_seats
        self.reading = reading
        self.cases = [statics.wheel_cases(zone.supports.x[:n], c.axles.offsets, c.axles.loads,
                                          c.axles.direction) for c in conditions]
        self.rows = np.array([len(c.axles.offsets) for c in conditions])
        self.dynamic = [np.zeros(cs.shape) for cs in self.cases]
        self.blend = None                 # (s0, s1, dynamic parts at s1) while correcting
        self.shift = 0.0                  # the slab's settlement: the model's reference
        self._contact = [None] * len(self.cases)
        # d gap / d settlement: the settling sleepers, then the followers of the farthest one
        self.dgap = np.zeros((len(zone.supports.dof), n))
        self.dgap[np.arange(n), np.arange(n)] = 1.0
        self.dgap[n:, n - 1] = zone.follower_weight

    def gaps(self, settlement):
        """The gaps of the track model: every support's settlement less the slab's (>= 0)."""
        return self.zone.gaps(np.maximum(np.asarray(settlement) - self.shift, 0.0))

    def quasi_static(self, settlement):
        gap = self.gaps(settlement)
        out = []
        for j, cs in enumerate(self.cases):
            f, self._contact[j] = self.statics.peak_forces(gap, cs, self._contact[j])
            out.append(f)
        return out

    def measured(self, settlement, loadings):
        """(dynamic parts of simulated ``loadings`` at ``settlement``, the largest error [N]
        the present dynamic parts made there)."""
        n = self.zone.n_settling
        qs = self.quasi_static(settlement)
        error, parts = 0.0, []
        for j, (q, ld) in enumerate(zip(qs, loadings)):
            if ld.peak_force.shape[0] != q.shape[0] or ld.peak_force.shape[1] < n:
                raise ValueError(f"a simulation gave peak forces of shape {ld.peak_force.shape}"
                                 f", expected ({q.shape[0]} axles, >= {n} sleepers)")
            sim = ld.peak_force[:, :n]
            error = max(error, float(np.max(np.abs(np.maximum(q + self.dynamic[j], 0.0) - sim))))
            parts.append(sim - q)
        return parts, error

    def _theta(self, settlement):
        """Progress of ``settlement`` from s0 to s1 of the blend, in [0, 1], and its gradient."""
        s0, s1, _ = self.blend
        d = s1 - s0
        dd = float(d @ d)
        if dd == 0.0:
            return 1.0, None
        t = float((settlement - s0) @ d) / dd
        return min(max(t, 0.0), 1.0), (d / dd if 0.0 < t < 1.0 else None)

    def _dynamic(self, settlement):
        """(dynamic parts at ``settlement``, their progress gradient or None)."""
        if self.blend is None:
            return self.dynamic, None
        theta, grad = self._theta(settlement)
        return [d + theta * (e - d) for d, e in zip(self.dynamic, self.blend[2])], grad

    def __call__(self, settlement, jacobian: bool = True):
        """(rows (axles of all conditions, sleepers) [N] fed to the law, d rows / d settlement
        (rows, sleepers, sleepers)), rows in condition order."""
        qs = self.quasi_static(settlement)
        dyn, grad = self._dynamic(settlement)
        f = np.vstack([np.maximum(q + d, 0.0) for q, d in zip(qs, dyn)])
        pick = self._passage_peaks(f) if self.reading == "passage" else None
        if pick is not None:
            f = np.take_along_axis(f, pick, axis=0)
        if not jacobian:
            return self.scale * f, None
        dgap = self.dgap * (np.asarray(settlement) > self.shift)
        jac = np.concatenate([
            self.statics.peak_jacobian(cs, self._contact[j]) @ dgap
            for j, cs in enumerate(self.cases)])
        if grad is not None:
            change = np.vstack([e - d for d, e in zip(self.dynamic, self.blend[2])])
            jac += change[..., None] * grad
        if pick is not None:
            jac = np.take_along_axis(jac, pick[..., None], axis=0)
        jac *= (f > 0.0)[..., None]
        return self.scale * f, self.scale * jac

    def _passage_peaks(self, f):
        """(rows, sleepers) row index whose load every row of its condition takes: the
        passage's largest per sleeper (the ``passage`` reading)."""
        pick = np.empty(f.shape, dtype=int)
        start = 0
        for k in self.rows:
            top = start + np.argmax(f[start:start + k], axis=0)
            pick[start:start + k] = top[None, :]
            start += k
        return pick


def implicit_block(law, state, settlement, loads: SleeperLoads, cycles):
    """The settlement at the end of a block whose cycles (rows) carry the loads of the end:
    s = law(state + rows(s)), by Newton's method; (s, rows), or None if it does not converge.

    The residual has kinks (a sleeper touching or leaving the ballast, a load passing its
    largest so far): a step that does not reduce it is halved, and if no halving helps the full
    step is taken anyway (non-monotone), which crosses the kink."""
    s = settlement.copy()
    rows, jac = loads(s)
    new, dnew = law.sensitivity(state, rows, cycles)
    res = s - new
    for _ in range(40):
        size = float(np.max(np.abs(res)))
        if size <= _NEWTON_TOLERANCE:
            return s, rows
        J = np.eye(len(s)) - np.einsum("rs,rst->st", dnew, jac)
        step = np.linalg.solve(J, -res)
        full = None
        for lam in 0.5 ** np.arange(8):
            trial = np.maximum(s + lam * step, settlement)    # settlement never goes back
            t_rows, t_jac = loads(trial)
            t_new, t_dnew = law.sensitivity(state, t_rows, cycles)
            got = (trial, t_rows, t_jac, t_new, t_dnew, trial - t_new)
            if full is None:
                full = got
            if float(np.max(np.abs(got[5]))) < size:
                break
        else:
            got = full
        s, rows, jac, new, dnew, res = got
    return None
