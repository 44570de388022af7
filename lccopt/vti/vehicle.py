"""Quarter-car vehicle on one rail (Sec. 2.1.1, Eqs. A.1-A.3): carbody, bogie, wheelset.

Dofs (carbody, bogie, wheel), vertical, downward positive. One primary and one secondary
suspension per wheel (the 1/8-car reduction of the case file), so the bogie row carries
k_s1 once, not twice as Eq. (A.3) prints it for a two-wheelset bogie.
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

    @classmethod
    def from_case(cls, case: Case) -> "Vehicle":
        v = case.vehicle
        return cls(np.array([v["carbody_mass"], v["bogie_mass"], v["wheelset_mass"]]),
                   v["primary_stiffness"], v["primary_damping"], v["secondary_stiffness"],
                   v["secondary_damping"], v["speed"], v["gravity"], v["hertz_constant"], v["hertz_load"])

    @property
    def M(self) -> np.ndarray:
        return np.diag(self.masses)

    @staticmethod
    def _chain(k1: float, k2: float) -> np.ndarray:
        return np.array([[k2, -k2, 0.0], [-k2, k2 + k1, -k1], [0.0, -k1, k1]])

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
        return float(self.weight_load.sum())

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
