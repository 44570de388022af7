"""Empirical settlement laws of ballast under a sleeper: settlement from the load history.

Every law here keeps a state of the cycles each sleeper has carried: ``start(n)`` is the
state of n new sleepers, ``settlement(state)`` their permanent settlement [m],
``add(state, peaks, cycles)`` the state after rows of cycles (``peaks`` (rows, sleepers) [N],
``cycles`` (rows,)), and ``sensitivity(state, peaks, cycles)`` the settlement after them with
its derivative by each row's peaks (what the implicit block update of the iteration needs).
The force is the peak sleeper-ballast force of a load cycle (one axle passing); which force
(one rail seat or the whole sleeper) is the caller's choice (``predict_settlement``'s
``rail_seats``, docs/settlement.md).

* :class:`VarandasLaw` (default): Varandas, Hölscher & Silva (2014), "Settlement of ballasted
  track under traffic loading: application to transition zones", Proc IMechE Part F 228(3)
  242-259, doi:10.1177/0954409712471610. The settlement of load cycle n is

      u_n = γ / M · ∫_0^{F_n} F^α (h_n(F) + 1)^(-β) dF,
      M = F0^(α+1) / (α+1) · Σ_{i=1}^{N0} i^(-β),

  h_n(F) the number of earlier cycles whose peak reached F. γ is the settlement after N0
  cycles of the constant peak F0. Parameters: α = 0.6, β = 0.82, γ = 10 mm, F0 = 50 kN,
  N0 = 10^6, the defaults of the implementation of this law in ROSE (Deltares / TU Delft,
  PlatypusBytes/ROSE, rose/model/accumulation_model.py, which cites the paper); the paper
  itself could not be read. Summing over cycles, the settlement is a function of the load
  histogram alone, whatever the order of the cycles:

      S = γ / H(N0) · Σ_j H(C_j) [(F_j/F0)^(α+1) - (F_{j+1}/F0)^(α+1)]

  over the distinct peaks F_1 > F_2 > ... (F_{J+1} = 0), C_j the number of cycles whose peak
  reached F_j and H(x) = Σ_{i=1}^{x} i^(-β) (the generalised harmonic number, continued to real
  x). For a constant peak F: S = γ (F/F0)^1.6 H(N)/H(N0), about γ (F/F0)^1.6 (N/N0)^0.18.
* :class:`LogarithmicLaw` (alternative): S = s1 (F/F0)^m (1 + C ln N), the logarithmic form of
  Hettler's tests with their load exponent m = 1.6 (as ROSE writes it, with log10 N: a factor
  ln 10 in C). s1 and C have no default: no source reachable here gives values, so a case
  must give them. Under a changing load it is applied as strain hardening (the cycles already
  carried count as the number at the new load that gives the present settlement), the rows of
  one block as their equivalent load F_eq^m = Σ n_r F_r^m / Σ n_r.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.special import zeta

_EM_FROM = 20.0     # Euler-Maclaurin from here on; below, the recurrence H(x) = H(x+1) - (x+1)^-β


def harmonic(x, beta: float) -> np.ndarray:
    """H_β(x) = Σ_{i=1}^{x} i^(-β) for real x >= 0 (0 < β < 1): ζ(β) - ζ(β, x+1), from the
    Euler-Maclaurin expansion of the Hurwitz zeta (error < 1e-12 from x = 20 on; below, the
    recurrence down from there)."""
    x = np.asarray(x, dtype=float)
    z0 = float(zeta(beta))
    shift = np.where(x < _EM_FROM, np.ceil(_EM_FROM - x), 0.0)
    y = x + shift
    h = (z0 + y ** (1 - beta) / (1 - beta) + 0.5 * y ** (-beta) - beta / 12 * y ** (-beta - 1)
         + beta * (beta + 1) * (beta + 2) / 720 * y ** (-beta - 3)
         - beta * (beta + 1) * (beta + 2) * (beta + 3) * (beta + 4) / 30240 * y ** (-beta - 5))
    for j in range(int(shift.max(initial=0.0))):
        take = shift > j                       # subtract (x + j + 1)^-β while j < shift
        h = h - np.where(take, (x + j + 1) ** (-beta) * take, 0.0)
    return np.where(x <= 0.0, 0.0, h)


@dataclass
class LoadHistory:
    """Cycles carried by each sleeper: peaks (rows, sleepers) [N] and cycles per row."""
    peaks: np.ndarray
    cycles: np.ndarray

    @classmethod
    def empty(cls, n: int) -> "LoadHistory":
        return cls(np.zeros((0, n)), np.zeros(0))

    def add(self, force, cycles: float) -> "LoadHistory":
        """A new history with ``cycles`` more cycles of peak ``force`` (one per sleeper)."""
        return self.extend(np.atleast_2d(force), [cycles])

    def extend(self, peaks, cycles) -> "LoadHistory":
        """A new history with rows ``peaks`` (rows, sleepers) of ``cycles`` (rows,) cycles."""
        f = np.maximum(np.atleast_2d(np.asarray(peaks, dtype=float)), 0.0)
        return LoadHistory(np.vstack([self.peaks, f]),
                           np.concatenate([self.cycles, np.asarray(cycles, dtype=float)]))


@dataclass(frozen=True)
class VarandasLaw:
    """Varandas et al. (2014) accumulation law (module docstring); γ in m, F0 in N.

    State: the :class:`LoadHistory` (the law depends on the load histogram)."""
    alpha: float = 0.6
    beta: float = 0.82
    gamma: float = 10.0e-3
    f0: float = 50.0e3
    n0: float = 1.0e6
    name: str = field(default="varandas", init=False)

    def start(self, n: int) -> LoadHistory:
        """The state of ``n`` new sleepers."""
        return LoadHistory.empty(n)

    def settlement(self, history: LoadHistory) -> np.ndarray:
        """Settlement [m] per sleeper after the cycles of ``history``."""
        p = history.peaks
        if p.shape[0] == 0:
            return np.zeros(p.shape[1])
        order = np.argsort(-p, axis=0, kind="stable")
        f = np.take_along_axis(p, order, axis=0) / self.f0          # descending
        c = np.cumsum(history.cycles[order], axis=0)                # cycles reaching F_j
        a = self.alpha + 1.0
        fa = f ** a
        band = fa - np.vstack([fa[1:], np.zeros((1, fa.shape[1]))])
        total = np.sum(harmonic(c, self.beta) * band, axis=0)
        return self.gamma * total / harmonic(self.n0, self.beta)

    def add(self, history: LoadHistory, peaks, cycles) -> LoadHistory:
        """The state after rows ``peaks`` (rows, sleepers) [N] of ``cycles`` (rows,)."""
        return history.extend(peaks, cycles)

    def sensitivity(self, history: LoadHistory, peaks, cycles):
        """(settlement (sleepers,) after adding the rows, d settlement / d peaks (rows,
        sleepers)). Raising row r's peak from F to F + dF adds its cycles to the band
        [F, F + dF]: dS = γ/H(N0) d(F/F0)^(α+1) [H(C + n_r) - H(C)], C the cycles of the other
        rows above F (new rows that tie count in row order, so that rows rising together get
        the band's whole count)."""
        peaks = np.maximum(np.atleast_2d(np.asarray(peaks, dtype=float)), 0.0)
        cycles = np.asarray(cycles, dtype=float)
        s = self.settlement(history.extend(peaks, cycles))
        above = (history.cycles[:, None, None]
                 * (history.peaks[:, None, :] > peaks[None, :, :])).sum(axis=0)
        r = np.arange(len(cycles))
        tie = (peaks[:, None, :] == peaks[None, :, :]) & (r[:, None] < r[None, :])[..., None]
        beats = (peaks[:, None, :] > peaks[None, :, :]) | tie       # row q above row r
        above = above + (cycles[:, None, None] * beats).sum(axis=0)
        a = self.alpha + 1.0
        gain = harmonic(above + cycles[:, None], self.beta) - harmonic(above, self.beta)
        d = a * (peaks / self.f0) ** self.alpha / self.f0 * gain
        return s, self.gamma * d / harmonic(self.n0, self.beta)

    def constant(self, force, cycles) -> np.ndarray:
        """Settlement [m] after ``cycles`` cycles of a constant peak ``force`` [N]."""
        f = np.asarray(force, dtype=float) / self.f0
        return (self.gamma * f ** (self.alpha + 1.0) * harmonic(cycles, self.beta)
                / harmonic(self.n0, self.beta))


@dataclass(frozen=True)
class LogarithmicLaw:
    """S = s1 (F/F0)^m (1 + C ln N) (module docstring): ``first_cycle`` s1 [m] and
    ``log_rate`` C [-] have no default (no reachable source gives them); m = ``exponent``.

    State: the settlement per sleeper (strain hardening needs nothing else)."""
    first_cycle: float
    log_rate: float
    exponent: float = 1.6
    f0: float = 50.0e3
    name: str = field(default="logarithmic", init=False)

    def __post_init__(self):
        if not (self.first_cycle > 0 and self.log_rate > 0 and self.exponent > 0
                and self.f0 > 0):
            raise ValueError("logarithmic law: first_cycle, log_rate, exponent, f0 must be > 0")

    def start(self, n: int) -> np.ndarray:
        return np.zeros(n)

    def settlement(self, state: np.ndarray) -> np.ndarray:
        return np.asarray(state, dtype=float)

    def constant(self, force, cycles) -> np.ndarray:
        a = self.first_cycle * (np.asarray(force, float) / self.f0) ** self.exponent
        n = np.asarray(cycles, dtype=float)
        return a * np.where(n >= 1.0, 1.0 + self.log_rate * np.log(np.maximum(n, 1.0)), n)

    def add(self, state, peaks, cycles) -> np.ndarray:
        """Strain hardening under the rows' equivalent load (F_eq^m = Σ n_r F_r^m / Σ n_r)."""
        peaks = np.maximum(np.atleast_2d(np.asarray(peaks, dtype=float)), 0.0)
        cycles = np.asarray(cycles, dtype=float)
        total = float(cycles.sum())
        if total <= 0.0:
            return np.asarray(state, dtype=float).copy()
        feq = (cycles @ peaks ** self.exponent / total) ** (1.0 / self.exponent)
        return self._harden(np.asarray(state, dtype=float), feq, total)

    def sensitivity(self, state, peaks, cycles):
        """(settlement after the rows, d settlement / d peaks) by central differences."""
        peaks = np.atleast_2d(np.asarray(peaks, dtype=float))
        s = self.add(state, peaks, cycles)
        d = np.zeros_like(peaks)
        for r in range(peaks.shape[0]):
            h = 1e-6 * np.maximum(peaks[r], self.f0)
            up, down = peaks.copy(), peaks.copy()
            up[r] += h
            down[r] = np.maximum(down[r] - h, 0.0)
            d[r] = (self.add(state, up, cycles) - self.add(state, down, cycles)) / (up[r] - down[r])
        return s, d

    def _harden(self, s, force, cycles):
        a = self.first_cycle * (force / self.f0) ** self.exponent
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            ratio = np.where(a > 0, s / a, np.inf)
            # equivalent cycles already carried at this load
            log_neq = np.where(ratio >= 1.0, (ratio - 1.0) / self.log_rate,
                               np.log(np.maximum(ratio, 1e-300)))
            neq = np.exp(np.minimum(log_neq, 700.0))
            n_new = neq + cycles
            grown = a * np.where(n_new >= 1.0, 1.0 + self.log_rate * np.log(np.maximum(n_new, 1.0)),
                                 n_new)
        return np.where((a > 0) & (cycles > 0), np.maximum(grown, s), s)


LAWS = {"varandas": VarandasLaw, "logarithmic": LogarithmicLaw}
