"""The 3-dof vehicle on one rail (Sec. 2.1.1, Eqs. A.1-A.3): carbody, bogie, wheelset.

Dofs (carbody, bogie, wheel), vertical, downward positive. Two readings (``vehicle.model``):

* ``paper`` (default): Eqs. (A.2)-(A.3) as printed. The bogie row carries k_s2 + 2 k_s1 and
  c_s2 + 2 c_s1: the bogie has two primary suspensions, one to the modelled wheelset and one
  to the second wheelset, which is not modelled and stays where it is (a fixed point). The
  bogie's and carbody's weight is then shared by the two primary suspensions, and the static
  wheel load is m_w g + (m_c + m_b) g / 2 on a rigid rail.
* ``quarter-car``: one primary suspension per wheel (k_s1 once in the bogie row); the whole
  weight rests on the modelled wheel. Kept for the closed-form theory tests and comparisons.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..case import Case


@dataclass(frozen=True)
class Vehicle:
    masses: np.ndarray      # (m_c, m_b, m_w) [kg]
    k_s1: float
    c_s1: float
    k_s2: float
    c_s2: float
    speed: float            # [m/s]
    gravity: float          # [m/s^2]
    hertz_constant: float   # G [m/N^(2/3)]
    hertz_load: float       # P [N] at which the Hertz spring is linearised
    model: str = "paper"    # "paper" (Eq. A.3 as printed) or "quarter-car"

    @classmethod
    def from_case(cls, case: Case) -> "Vehicle":
        v = case.vehicle
        return cls(np.array([v["carbody_mass"], v["bogie_mass"], v["wheelset_mass"]]),
                   v["primary_stiffness"], v["primary_damping"], v["secondary_stiffness"],
                   v["secondary_damping"], v["speed"], v["gravity"], v["hertz_constant"], v["hertz_load"],
                   v.get("model") or "paper")

    @property
    def M(self) -> np.ndarray:
        return np.diag(self.masses)

    @property
    def primary_sets(self) -> int:
        """Primary suspensions on the bogie: 2 in Eq. (A.3) as printed, 1 for the quarter car."""
        return 2 if self.model == "paper" else 1

    def _chain(self, k1: float, k2: float) -> np.ndarray:
        n = self.primary_sets
        return np.array([[k2, -k2, 0.0], [-k2, k2 + n * k1, -k1], [0.0, -k1, k1]])

    @property
    def K(self) -> np.ndarray:
        return self._chain(self.k_s1, self.k_s2)

    @property
    def C(self) -> np.ndarray:
        return self._chain(self.c_s1, self.c_s2)

    @property
    def weight_load(self) -> np.ndarray:
        """Gravity loads (Eq. A.11) [N]."""
        return self.masses * self.gravity

    @property
    def static_wheel_load(self) -> float:
        """Static contact force on a rigid rail [N] (the second primary suspension of the paper's
        bogie takes its share of the weight above it)."""
        m_c, m_b, m_w = self.masses
        return float((m_w + (m_c + m_b) / self.primary_sets) * self.gravity)

    @property
    def contact_stiffness(self) -> float:
        """Linearised Hertz spring k_w = 3/(2G) P^(1/3) [N/m]."""
        return 1.5 / self.hertz_constant * self.hertz_load ** (1.0 / 3.0)

    def rigid_track_frequencies(self) -> np.ndarray:
        """Natural frequencies [Hz] with the wheel on a rigid rail through the Hertz spring."""
        from scipy.linalg import eigh

        k = self.K.copy()
        k[2, 2] += self.contact_stiffness
        lam = eigh(k, self.M, eigvals_only=True)
        return np.sqrt(lam) / (2 * np.pi)
