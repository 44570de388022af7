"""Empirical settlement laws of ballast under a sleeper: settlement from the load history.

Every law here keeps a state of the cycles each sleeper has carried: ``start(n)`` is the
state of n new sleepers, ``settlement(state)`` their permanent settlement [m],
``add(state, peaks, cycles)`` the state after rows of cycles (``peaks`` (rows, sleepers) [N],
``cycles`` (rows,)), and ``sensitivity(state, peaks, cycles)`` the settlement after them with
its derivative by each row's peaks (what the implicit block update of the iteration needs).
The force is the peak sleeper-ballast force of a load cycle (one axle passing); which force
(one rail seat or the whole sleeper) is the caller's choice (``predict_settlement``'s
``rail_seats``, docs/settlement.md). ``reset(state, mask)`` forgets the masked sleepers'
history: tamped ballast, loosened, settles as new ballast does (fast at first).

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
* :class:`SubgradeLaw`: the subgrade under a sleeper (or under the ERS slab), Li & Selig
  (1996), "Cumulative plastic deformation for fine-grained subgrade soils", J. Geotech. Eng.
  122(12) 1006-1013, doi:10.1061/(ASCE)0733-9410(1996)122:12(1006), as ROSE applies it per
  sleeper: plastic strain ε_p = a (σ_d/σ_s)^m N^b (in percent) of the layer, σ_d the
  deviator stress the load causes, σ_s the soil's static strength; a, b, m by soil class.
  Integrated over the layer, S = K_i (F/F_ref)^m N^b for a sleeper's peak force F, and
  under a changing load by strain hardening, which for a power law in N is exact and
  order-free: S^(1/b) = K^(1/b) Σ_r n_r (F_r/F_ref)^(m/b).
* :class:`SleeperLaw`: what one settling sleeper's support does, composed: the ballast law
  fed the sleeper-ballast *pressure* (its force times A_standard / A_sleeper, so that a
  standard sleeper keeps the force-fed numbers), times a per-sleeper factor, plus the
  subgrade law, plus an offset per sleeper (an initial gap, and the lift of each tamping).
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
    # one power, the others by division: powers of whole arrays cost most of the law's time
    y1 = y ** (1 - beta)
    yb = y1 / y                                  # y^-β
    yb1 = yb / y                                 # y^(-β-1)
    inv2 = 1.0 / (y * y)
    yb3 = yb1 * inv2
    h = (z0 + y1 / (1 - beta) + 0.5 * yb - beta / 12 * yb1
         + beta * (beta + 1) * (beta + 2) / 720 * yb3
         - beta * (beta + 1) * (beta + 2) * (beta + 3) * (beta + 4) / 30240 * (yb3 * inv2))
    # The recurrence only where it is needed: a few entries of a load history's cycle
    # counts are small, and running it over the whole array cost most of a prediction.
    near = np.flatnonzero((shift > 0) & (x > 0))
    if near.size:
        xs, ss, hs = x.reshape(-1)[near], shift.reshape(-1)[near], h.reshape(-1)[near]
        for j in range(int(ss.max())):
            take = ss > j                      # subtract (x + j + 1)^-β while j < shift
            hs = hs - np.where(take, (xs + j + 1) ** (-beta) * take, 0.0)
        h = np.array(h, dtype=float)
        h.reshape(-1)[near] = hs
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

    def reset(self, history: LoadHistory, mask) -> LoadHistory:
        """The history with the masked sleepers' cycles forgotten (new ballast)."""
        peaks = history.peaks.copy()
        peaks[:, np.asarray(mask, dtype=bool)] = 0.0
        return LoadHistory(peaks, history.cycles.copy())

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

    def reset(self, state, mask) -> np.ndarray:
        out = np.array(state, dtype=float)
        out[np.asarray(mask, dtype=bool)] = 0.0
        return out

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


# Li & Selig (1996) by soil class (Unified Soil Classification): (a [%], b, m), the values of
# their paper as ROSE (PlatypusBytes/ROSE, rose/model/accumulation_model.py, class LiSelig)
# tabulates them. ML: silt; MH: elastic silt; CL: lean clay; CH: fat clay.
LI_SELIG = {"ML": (0.64, 0.10, 1.7), "MH": (0.84, 0.13, 2.0), "CL": (1.1, 0.16, 2.0),
            "CH": (1.2, 0.18, 2.4)}
_F_REF = 1.0e5          # [N] forces of the subgrade law in these units (numerics only)
_S_REF = 1.0e-3         # [m] its state in (S / S_REF)^(1/b)


def li_selig_coefficient(soil: str, strength, bearing_area, depth: float,
                         thickness: float) -> np.ndarray:
    """K of :class:`SubgradeLaw` (S = K (F/F_ref)^m N^b) for a subgrade layer of ``soil``
    (a key of ``LI_SELIG``) with static strength ``strength`` [Pa] from ``depth`` to
    ``depth + thickness`` [m] below a bearing area ``bearing_area`` [m^2] (one per sleeper).

    The deviator stress is taken as the vertical stress of the 2:1 spread of the sleeper's
    force over a square of the same area, σ_d(z) = F / (√A + z)^2 (horizontal stress changes
    neglected, neighbouring sleepers' loads not superposed, as ROSE takes each sleeper's own
    force); the strain ε_p [%] integrated over the layer in closed form:
    S = a/100 (F/σ_s)^m [(c+d)^(1-2m) - (c+d+t)^(1-2m)] / (2m-1) N^b, c = √A."""
    a, _, m = LI_SELIG[soil]
    c = np.sqrt(np.atleast_1d(np.asarray(bearing_area, dtype=float)))
    strength = np.broadcast_to(np.asarray(strength, dtype=float), c.shape)
    depth_integral = ((c + depth) ** (1 - 2 * m) - (c + depth + thickness) ** (1 - 2 * m)) \
        / (2 * m - 1)
    return (a / 100.0) * (_F_REF / strength) ** m * depth_integral


@dataclass(frozen=True, eq=False)
class SubgradeLaw:
    """Li & Selig (1996) per sleeper (module docstring): S = K_i (F/F_ref)^m N^b, strain
    hardening under a changing load. ``coefficient``: K_i [m] (:func:`li_selig_coefficient`).

    State: X = (S / 1 mm)^(1/b) per sleeper (additive over rows)."""
    coefficient: np.ndarray
    exponent: float
    cycle_exponent: float
    name: str = field(default="li-selig", init=False)

    @classmethod
    def of_soil(cls, soil: str, strength, bearing_area, depth: float,
                thickness: float) -> "SubgradeLaw":
        """The law of a soil class under the given bearing areas (one per sleeper)."""
        _, b, m = LI_SELIG[soil]
        return cls(li_selig_coefficient(soil, strength, bearing_area, depth, thickness), m, b)

    def _unit(self) -> np.ndarray:
        """(K / S_REF)^(1/b): the state one cycle of F_ref adds."""
        return (np.asarray(self.coefficient, float) / _S_REF) ** (1.0 / self.cycle_exponent)

    def start(self, n: int) -> np.ndarray:
        return np.zeros(n)

    def settlement(self, state) -> np.ndarray:
        return _S_REF * np.asarray(state, dtype=float) ** self.cycle_exponent

    def add(self, state, peaks, cycles) -> np.ndarray:
        peaks = np.maximum(np.atleast_2d(np.asarray(peaks, dtype=float)), 0.0) / _F_REF
        q = self.exponent / self.cycle_exponent
        return np.asarray(state, float) + self._unit() * (np.asarray(cycles, float) @ peaks ** q)

    def constant(self, force, cycles) -> np.ndarray:
        """Settlement [m] after ``cycles`` cycles of a constant ``force`` [N]."""
        return (np.asarray(self.coefficient, float) * (np.asarray(force, float) / _F_REF)
                ** self.exponent * np.asarray(cycles, float) ** self.cycle_exponent)

    def sensitivity(self, state, peaks, cycles):
        """(settlement after the rows, d settlement / d peaks (rows, sleepers)), analytic."""
        peaks = np.maximum(np.atleast_2d(np.asarray(peaks, dtype=float)), 0.0) / _F_REF
        cycles = np.asarray(cycles, dtype=float)
        b, q = self.cycle_exponent, self.exponent / self.cycle_exponent
        x = self.add(state, peaks * _F_REF, cycles)
        with np.errstate(divide="ignore", invalid="ignore"):
            dx = self._unit() * cycles[:, None] * q * peaks ** (q - 1.0) / _F_REF
            ds = np.where(x > 0, _S_REF * b * x ** (b - 1.0), 0.0)
        return self.settlement(x), np.nan_to_num(ds * dx)


@dataclass(frozen=True, eq=False)
class SlabSettlement:
    """The ERS slab's own settlement: its subgrade's law (a :class:`SubgradeLaw` of one
    element, under the slab's loaded area) loaded once per axle passing by ``loads`` [N]
    (one per traffic condition: the axle's load on the slab, both rails)."""
    law: SubgradeLaw
    loads: np.ndarray

    def at(self, cycles) -> float:
        """Settlement [m] after ``cycles`` axle passes of each condition."""
        n = len(self.loads)
        x = self.law.add(self.law.start(1), np.asarray(self.loads, float).reshape(n, 1),
                         np.asarray(cycles, float).reshape(n))
        return float(self.law.settlement(x)[0])


@dataclass(frozen=True)
class SleeperState:
    """The state of a :class:`SleeperLaw`: its ballast law's, its subgrade law's (None
    without one) and the offsets [m] (initial gaps, tamping lifts)."""
    ballast: object
    subgrade: np.ndarray | None
    offset: np.ndarray


@dataclass(frozen=True, eq=False)
class SleeperLaw:
    """The settlement of each settling sleeper's support (module docstring).

    ballast: a ballast law (:class:`VarandasLaw`, :class:`LogarithmicLaw`); pressure_scale:
    A_standard / A_i per sleeper (the ballast law is fed F A_standard / A_i, the force a
    standard sleeper would carry at sleeper i's pressure); ballast_factor: per-sleeper factor
    on the ballast law's settlement (γ of a sleeper over the law's); subgrade: a
    :class:`SubgradeLaw` or None; initial_gap [m]: each sleeper's gap before any traffic (an
    initial void). Arrays are one value per sleeper."""
    ballast: object
    pressure_scale: np.ndarray
    ballast_factor: np.ndarray
    subgrade: SubgradeLaw | None = None
    initial_gap: np.ndarray | None = None

    @classmethod
    def plain(cls, ballast, n: int) -> "SleeperLaw":
        """The ballast law alone, fed the force, on ``n`` standard sleepers."""
        return cls(ballast, np.ones(n), np.ones(n))

    @property
    def name(self) -> str:
        return self.ballast.name + (f"+{self.subgrade.name}" if self.subgrade else "")

    def start(self, n: int) -> SleeperState:
        for k in ("pressure_scale", "ballast_factor"):
            if np.shape(getattr(self, k)) != (n,):
                raise ValueError(f"{k}: one value per settling sleeper ({n})")
        gap = np.zeros(n) if self.initial_gap is None else np.array(self.initial_gap, float)
        if gap.shape != (n,):
            raise ValueError(f"initial_gap: one value per settling sleeper ({n})")
        return SleeperState(self.ballast.start(n),
                            None if self.subgrade is None else self.subgrade.start(n), gap)

    def _fed(self, peaks) -> np.ndarray:
        return np.atleast_2d(np.asarray(peaks, dtype=float)) * self.pressure_scale

    def parts(self, state: SleeperState) -> dict:
        """Settlement [m] per sleeper by part: ballast (since its last tamping), subgrade,
        offset."""
        return {"ballast": self.ballast_factor * self.ballast.settlement(state.ballast),
                "subgrade": (np.zeros_like(state.offset) if self.subgrade is None
                             else self.subgrade.settlement(state.subgrade)),
                "offset": state.offset}

    def settlement(self, state: SleeperState) -> np.ndarray:
        p = self.parts(state)
        return p["ballast"] + p["subgrade"] + p["offset"]

    def add(self, state: SleeperState, peaks, cycles) -> SleeperState:
        return SleeperState(self.ballast.add(state.ballast, self._fed(peaks), cycles),
                            None if self.subgrade is None
                            else self.subgrade.add(state.subgrade, peaks, cycles),
                            state.offset)

    def sensitivity(self, state: SleeperState, peaks, cycles):
        s, d = self.ballast.sensitivity(state.ballast, self._fed(peaks), cycles)
        s = self.ballast_factor * s + state.offset
        d = d * (self.ballast_factor * self.pressure_scale)
        if self.subgrade is not None:
            s2, d2 = self.subgrade.sensitivity(state.subgrade, peaks, cycles)
            s, d = s + s2, d + d2
        return s, d

    def tamp(self, state: SleeperState, mask, level) -> SleeperState:
        """The state after tamping the masked sleepers up to ``level`` [m] (their settlement
        becomes ``level``): their ballast starts anew, their subgrade keeps its history."""
        mask = np.asarray(mask, dtype=bool)
        sub = self.parts(state)["subgrade"]
        offset = np.where(mask, np.asarray(level, float) - sub, state.offset)
        return SleeperState(self.ballast.reset(state.ballast, mask), state.subgrade, offset)


LAWS = {"varandas": VarandasLaw, "logarithmic": LogarithmicLaw}
