"""Empirical settlement laws of ballast under a sleeper: settlement from the load history.

Every law here is a state function of the cycles a sleeper has carried: ``settlement(state)``
gives the permanent settlement [m] of each sleeper, ``add(state, force, cycles)`` adds cycles
of a peak sleeper-ballast force. Forces are those under a whole sleeper [N] (both rail seats);
arrays run over sleepers.

* :class:`VarandasLaw` (default): Varandas, Hölscher & Silva (2014), "Settlement of ballasted
  track under traffic loading: application to transition zones", Proc IMechE Part F 228(3)
  242-259, doi:10.1177/0954409712471610. The settlement of load cycle n is

      u_n = γ / M · ∫_0^{F_n} F^α (h_n(F) + 1)^(-β) dF,
      M = F0^(α+1) / (α+1) · Σ_{i=1}^{N0} i^(-β),

  h_n(F) the number of earlier cycles whose peak reached F. γ is the settlement after N0
  cycles of the constant peak F0. Parameters (the defaults of the TU Delft implementation of
  this law in ROSE, PlatypusBytes/ROSE, which cites the paper): α = 0.6, β = 0.82, γ = 10 mm,
  F0 = 50 kN, N0 = 10^6. Summing over cycles, the settlement is a function of the load
  histogram alone, whatever the order of the cycles:

      S = γ / H(N0) · Σ_j H(C_j) [(F_j/F0)^(α+1) - (F_{j+1}/F0)^(α+1)]

  over the distinct peaks F_1 > F_2 > ... (F_{J+1} = 0), C_j the number of cycles whose peak
  reached F_j and H(x) = Σ_{i=1}^{x} i^(-β) (the generalised harmonic number, continued to real
  x). For a constant peak F: S = γ (F/F0)^1.6 H(N)/H(N0), about γ (F/F0)^1.6 (N/N0)^0.18.
* :class:`LogarithmicLaw` (alternative): the logarithmic form of Hettler's tests as presented in
  the reviews of Dahlberg (2001; SUPERTRACK 2004): S = s1 (F/F0)^m (1 + C ln N), with m = 1.6
  and C = 0.43 as quoted there (check against the primary source before relying on them); s1
  is calibrated so that the law meets the default law at (F0, N0), not a published value.
  Under a changing load it is applied as strain hardening: the cycles already carried count as
  the number at the new load that gives the present settlement.
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
    """Cycles carried by each sleeper: peaks (blocks, sleepers) [N] and cycles per block."""
    peaks: np.ndarray
    cycles: np.ndarray

    @classmethod
    def empty(cls, n: int) -> "LoadHistory":
        return cls(np.zeros((0, n)), np.zeros(0))

    def add(self, force, cycles: float) -> "LoadHistory":
        """A new history with ``cycles`` more cycles of peak ``force`` (one per sleeper)."""
        f = np.maximum(np.asarray(force, dtype=float), 0.0)[None, :]
        return LoadHistory(np.vstack([self.peaks, f]), np.append(self.cycles, float(cycles)))


@dataclass(frozen=True)
class VarandasLaw:
    """Varandas et al. (2014) accumulation law (module docstring); γ in m, F0 in N."""
    alpha: float = 0.6
    beta: float = 0.82
    gamma: float = 10.0e-3
    f0: float = 50.0e3
    n0: float = 1.0e6
    name: str = field(default="varandas", init=False)

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

    def constant(self, force, cycles) -> np.ndarray:
        """Settlement [m] after ``cycles`` cycles of a constant peak ``force`` [N]."""
        f = np.asarray(force, dtype=float) / self.f0
        return (self.gamma * f ** (self.alpha + 1.0) * harmonic(cycles, self.beta)
                / harmonic(self.n0, self.beta))


@dataclass(frozen=True)
class LogarithmicLaw:
    """S = s1 (F/F0)^m (1 + C ln N) with strain hardening (module docstring)."""
    exponent: float = 1.6
    log_rate: float = 0.43
    f0: float = 50.0e3
    s1: float | None = None          # None: calibrated to VarandasLaw() at (F0, N0)
    name: str = field(default="logarithmic", init=False)

    @property
    def first_cycle(self) -> float:
        if self.s1 is not None:
            return self.s1
        v = VarandasLaw()
        return float(v.gamma / (1.0 + self.log_rate * np.log(v.n0)))

    def constant(self, force, cycles) -> np.ndarray:
        a = self.first_cycle * (np.asarray(force, float) / self.f0) ** self.exponent
        n = np.asarray(cycles, dtype=float)
        return a * np.where(n >= 1.0, 1.0 + self.log_rate * np.log(np.maximum(n, 1.0)), n)

    def settlement(self, history: LoadHistory) -> np.ndarray:
        s = np.zeros(history.peaks.shape[1])
        for f, n in zip(history.peaks, history.cycles):
            s = self._add(s, f, n)
        return s

    def _add(self, s, force, cycles):
        a = self.first_cycle * (np.maximum(force, 0.0) / self.f0) ** self.exponent
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            ratio = np.where(a > 0, s / a, np.inf)
            # equivalent cycles already carried at this load
            log_neq = np.where(ratio >= 1.0, (ratio - 1.0) / self.log_rate,
                               np.log(np.maximum(ratio, 1e-300)))
            neq = np.exp(np.minimum(log_neq, 700.0))
            n_new = neq + cycles
            log_n = np.log(np.maximum(n_new, 1.0))
            grown = a * np.where(n_new >= 1.0, 1.0 + self.log_rate * log_n, n_new)
        return np.where((a > 0) & (cycles > 0), np.maximum(grown, s), s)


LAWS = {"varandas": VarandasLaw, "logarithmic": LogarithmicLaw}
