"""Vehicles on one rail: the paper's 3-dof model, a bogie and a half car (``vehicle.type``).

Dofs are vertical, downward positive; pitch angles are positive nose down, so a point a
distance s ahead of a body's centre moves z + s θ.

**The per-rail reading** (one rail is modelled; configs/reference.yaml explains it for the
paper's vehicle). A :class:`~lccopt.vti.specs.VehicleSpec` gives every mass and suspension
value as the share of one wheel:
``carbody_mass`` = m_c / 8 and ``bogie_mass`` = m_b / 4 for a 4-axle car (one bogie side carries
two wheels), ``wheelset_mass`` = the unsprung mass on the wheel (half a wheelset for the
multi-axle vehicles, each wheel being one end of its axle; the paper's 3-dof reading puts the
whole wheelset on its one wheel, Eq. A.1 with m_w = 1819 kg), ``primary_*`` per axle box = per
wheel and ``secondary_*`` per wheel (half the spring of one bogie side). The multi-axle
vehicles are built from the same per-wheel values:

* ``bogie``: one bogie side with its two wheels, both on the modelled rail; bogie bounce and
  pitch, and the carbody share resting on that bogie side (bounce only: 2 x carbody_mass =
  m_c / 4). Bogie side mass 2 x bogie_mass, secondary spring 2 x secondary_* (one air spring
  per bogie side), ``bogie_pitch_inertia`` per rail, ``wheelbase``. 5 dofs
  (carbody, bogie, bogie pitch, wheel 1, wheel 2).
* ``half-car``: the carbody half on the modelled rail (4 x carbody_mass = m_c / 2, bounce and
  pitch with ``carbody_pitch_inertia`` per rail) on two such bogies ``bogie_distance`` apart.
  10 dofs (carbody, carbody pitch, bogie 1, pitch 1, bogie 2, pitch 2, wheels 1-4).

Unlike the ``paper`` 3-dof model, no wheelset is a fixed point: every wheel of a bogie is
modelled, so the static wheel load of the multi-axle vehicles is the whole share
(wheelset_mass + bogie_mass + carbody_mass) g per wheel (87.2 kN for the VIRM, its real wheel
load), where the paper's bogie puts half of the weight above the wheel on its unmodelled
second wheelset (57 kN).

Wheels are numbered from the front; ``wheel_offsets`` are their distances behind the
leading wheel [m].

The types come from one registry, :data:`VEHICLE_TYPES` (:class:`VehicleType`: what a case of
each type gives, what one passage of it stands for, how it is built); the config layer and
the simulation ask it (:func:`vehicle_type`, :func:`build_vehicle`, :func:`vehicle_length`)
rather than naming types.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np

from .specs import VehicleSpec


class _Common:
    """What every vehicle offers the integrator and the simulation."""

    @property
    def contact_stiffness(self) -> float:
        """Linearised Hertz spring k_w = 3/(2G) P^(1/3) [N/m]."""
        return 1.5 / self.hertz_constant * self.hertz_load ** (1.0 / 3.0)

    @property
    def weight_load(self) -> np.ndarray:
        """Gravity loads (Eq. A.11) [N] per dof (zero on pitch dofs)."""
        return np.diag(self.M) * self.translational * self.gravity

    @property
    def n_wheels(self) -> int:
        return len(self.wheel_dofs)

    @property
    def length(self) -> float:
        """Distance from the leading to the last wheel [m]."""
        return float(self.wheel_offsets[-1])

    def rigid_track_frequencies(self) -> np.ndarray:
        """Natural frequencies [Hz] with every wheel on a rigid rail through its Hertz spring."""
        from scipy.linalg import eigh

        k = self.K.copy()
        k[self.wheel_dofs, self.wheel_dofs] += self.contact_stiffness
        lam = eigh(k, self.M, eigvals_only=True)
        return np.sqrt(lam) / (2 * np.pi)


@dataclass(frozen=True)
class Vehicle(_Common):
    """The paper's 3-dof vehicle (Sec. 2.1.1, Eqs. A.1-A.3): carbody, bogie, wheelset.

    Two readings (``vehicle.model``):

    * ``paper`` (default): Eqs. (A.2)-(A.3) as printed. The bogie row carries k_s2 + 2 k_s1 and
      c_s2 + 2 c_s1: the bogie has two primary suspensions, one to the modelled wheelset and
      one to the second wheelset, which is not modelled and stays where it is (a fixed
      point). The bogie's and carbody's weight is then shared by the two primary
      suspensions, and the static wheel load is m_w g + (m_c + m_b) g / 2 on a rigid rail.
    * ``quarter-car``: one primary suspension per wheel (k_s1 once in the bogie row); the
      whole weight rests on the modelled wheel. Kept for the closed-form theory tests.
    """
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

    type = "three-dof"
    wheel_dofs = np.array([2])
    wheel_offsets = np.array([0.0])
    translational = np.ones(3)

    @classmethod
    def from_spec(cls, v: VehicleSpec) -> "Vehicle":
        """The three-dof vehicle of a spec."""
        return cls(np.array([v.carbody_mass, v.bogie_mass, v.wheelset_mass]),
                   v.primary_stiffness, v.primary_damping, v.secondary_stiffness,
                   v.secondary_damping, v.speed, v.gravity, v.hertz_constant, v.hertz_load,
                   v.model)

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
    def static_wheel_loads(self) -> np.ndarray:
        return np.array([self.static_wheel_load])


class Bodies(NamedTuple):
    """The rigid bodies of a multi-axle vehicle on the modelled rail, one dof each entry."""
    names: list             # dof names
    mass: list              # mass [kg] or pitch inertia [kg m^2] of each dof
    translational: list     # 1 for a vertical dof, 0 for a pitch dof
    carbody: tuple          # (bounce dof, pitch dof or None)
    bogies: list            # (bounce dof, pitch dof, centre ahead of the carbody's [m]) each
    wheels_of: list         # (front wheel dof, rear wheel dof) under each bogie
    offsets: list           # each wheel's distance behind the leading one [m], front first


def _bogie(v: VehicleSpec) -> Bodies:
    """One bogie side and its carbody share (bounce only): 5 dofs."""
    return Bodies(["carbody", "bogie", "bogie pitch", "wheel 1", "wheel 2"],
                  [2 * v.carbody_mass, 2 * v.bogie_mass, v.bogie_pitch_inertia, v.wheelset_mass,
                   v.wheelset_mass],
                  [1, 1, 0, 1, 1], (0, None), [(1, 2, 0.0)], [(3, 4)], [0.0, v.wheelbase])


def _half_car(v: VehicleSpec) -> Bodies:
    """The carbody half (bounce and pitch) on two bogies: 10 dofs."""
    d = v.bogie_distance
    return Bodies(["carbody", "carbody pitch", "bogie 1", "bogie 1 pitch", "bogie 2",
                   "bogie 2 pitch", "wheel 1", "wheel 2", "wheel 3", "wheel 4"],
                  [4 * v.carbody_mass, v.carbody_pitch_inertia, 2 * v.bogie_mass,
                   v.bogie_pitch_inertia, 2 * v.bogie_mass, v.bogie_pitch_inertia]
                  + [v.wheelset_mass] * 4,
                  [1, 0, 1, 0, 1, 0, 1, 1, 1, 1], (0, 1), [(2, 3, d / 2), (4, 5, -d / 2)],
                  [(6, 7), (8, 9)], [0.0, v.wheelbase, d, d + v.wheelbase])


@dataclass(frozen=True)
class MultiAxleVehicle(_Common):
    """A bogie or a half car on one rail, every wheel on the modelled rail (module docstring).

    Built from springs between points of rigid bodies: M, C, K are (n, n); ``wheel_dofs`` the
    dof of each wheel, front first."""
    type: str
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    translational: np.ndarray   # 1 for a vertical dof, 0 for a pitch dof
    wheel_dofs: np.ndarray
    wheel_offsets: np.ndarray   # [m] behind the leading wheel
    dof_names: tuple
    speed: float
    gravity: float
    hertz_constant: float
    hertz_load: float
    carbody_dof: int            # the carbody's bounce dof
    bogie_dofs: tuple           # each bogie's bounce dof

    @classmethod
    def from_spec(cls, v: VehicleSpec, bodies: Bodies) -> "MultiAxleVehicle":
        """The vehicle of a spec (per-wheel values, module docstring) with its ``bodies``."""
        n = len(bodies.names)
        K, C = np.zeros((n, n)), np.zeros((n, n))

        def spring(k, c, g):
            g = np.asarray(g, float)
            K[:] += k * np.outer(g, g)
            C[:] += c * np.outer(g, g)

        def point(bounce, pitch, s):
            g = np.zeros(n)
            g[bounce] = 1.0
            if pitch is not None:
                g[pitch] = s
            return g

        wheelbase = v.wheelbase
        for (bz, bp, centre), (w1, w2) in zip(bodies.bogies, bodies.wheels_of):
            # secondary: the carbody point above the bogie centre to the bogie centre
            spring(2 * v.secondary_stiffness, 2 * v.secondary_damping,
                   point(*bodies.carbody, centre) - point(bz, bp, 0.0))
            # primary: the bogie point above each wheel (wheelbase/2 ahead, behind) to the wheel
            for w, s in ((w1, wheelbase / 2), (w2, -wheelbase / 2)):
                g = point(bz, bp, s)
                g[w] -= 1.0
                spring(v.primary_stiffness, v.primary_damping, g)
        offsets = bodies.offsets
        return cls(v.type, np.diag(np.asarray(bodies.mass, float)), C, K,
                   np.asarray(bodies.translational, float),
                   np.array([bodies.names.index(f"wheel {i + 1}") for i in range(len(offsets))]),
                   np.asarray(offsets, float), tuple(bodies.names), v.speed, v.gravity,
                   v.hertz_constant, v.hertz_load, bodies.carbody[0],
                   tuple(b[0] for b in bodies.bogies))

    @property
    def static_wheel_loads(self) -> np.ndarray:
        """Static contact force of each wheel [N] from the statics of the rigid bodies: each body
        is carried by two supports symmetric about its centre (a bogie: its two wheels; a
        carbody on two bogies: the bogies), so each takes half the load above it, whatever
        the stiffnesses."""
        m = np.diag(self.M)
        above = (m[self.carbody_dof] / len(self.bogie_dofs) + m[self.bogie_dofs[0]]) / 2
        return (m[self.wheel_dofs] + above) * self.gravity

    @property
    def static_wheel_load(self) -> float:
        return float(self.static_wheel_loads.mean())


# --- the registry of vehicle types

@dataclass(frozen=True)
class VehicleType:
    """One kind of vehicle on the modelled rail: what a case of it gives, what one passage of
    it stands for, and how it is built."""
    name: str
    doc: str                    # what it models (the case reference)
    keys: tuple                 # VehicleSpec fields it needs beyond the common ones
    wheels: int                 # wheels on the modelled rail: load cycles per passage
    passage: str                # what one passage of it is called in traffic counts
    models: tuple               # readings of its equations (``vehicle.model``), if any
    build: Callable             # VehicleSpec -> Vehicle or MultiAxleVehicle
    offsets: Callable           # VehicleSpec -> each wheel's distance behind the leading one
    check: Callable = lambda spec: None     # VehicleSpec -> (key, problem) or None

    def length(self, spec: VehicleSpec) -> float:
        """Distance from the leading to the last wheel [m]."""
        return float(self.offsets(spec)[-1])


def _bogies_apart(v: VehicleSpec):
    if v.bogie_distance <= v.wheelbase:
        return ("bogie_distance", f"{v.bogie_distance:g} m must exceed the wheelbase "
                                  f"({v.wheelbase:g} m): the bogies would overlap")
    return None


def _multi_axle(bodies: Callable[[VehicleSpec], Bodies]) -> dict:
    return dict(build=lambda v: MultiAxleVehicle.from_spec(v, bodies(v)),
                offsets=lambda v: bodies(v).offsets)


VEHICLE_TYPES: dict[str, VehicleType] = {t.name: t for t in (
    VehicleType("three-dof", "the paper's carbody-bogie-wheelset model (one wheel)", (), 1,
                "wheel", ("paper", "quarter-car"), Vehicle.from_spec, lambda v: [0.0]),
    VehicleType("bogie", "one bogie side with both wheelsets on the modelled rail (bounce and "
                "pitch) under its carbody share", ("wheelbase", "bogie_pitch_inertia"), 2,
                "bogie", (), **_multi_axle(_bogie)),
    VehicleType("half-car", "the carbody (bounce and pitch) on two such bogies",
                ("wheelbase", "bogie_pitch_inertia", "carbody_pitch_inertia", "bogie_distance"),
                4, "half-car", (), check=_bogies_apart, **_multi_axle(_half_car)),
)}
DEFAULT_TYPE = "three-dof"      # a case that names no type: the paper's vehicle


def vehicle_type(name: str | None) -> VehicleType:
    """The registry's entry of type ``name`` (None: the paper's three-dof)."""
    try:
        return VEHICLE_TYPES[name or DEFAULT_TYPE]
    except KeyError:
        raise ValueError(f"unknown vehicle type {name!r} (expected one of "
                         f"{', '.join(VEHICLE_TYPES)})") from None


def build_vehicle(spec: VehicleSpec):
    """The vehicle of a spec, built as its type says."""
    kind = vehicle_type(spec.type)
    missing = [key for key in kind.keys if getattr(spec, key) is None]
    if missing:
        raise ValueError(f"vehicle type {kind.name} needs {', '.join(missing)}")
    return kind.build(spec)


def vehicle_length(spec: VehicleSpec) -> float:
    """Distance from the leading to the last wheel of a spec's vehicle [m]."""
    return vehicle_type(spec.type).length(spec)
