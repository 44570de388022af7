"""What one simulation takes: typed, immutable inputs in SI units.

The simulator reads only these. The config layer (``lccopt.config``) builds them from a
validated case; tests and scripts may build them directly. Nothing here knows about YAML,
files or optimisation.

* :class:`VehicleSpec`: the vehicle on one rail, every mass and suspension value the share of
  one wheel (``lccopt.vti.vehicle`` explains the reading);
* :class:`TrackSpec`: rail, layout, ballast track, strengthened sleepers and the ERS;
* :class:`SimulationSettings`: time step, mesh, run-in and run-out, direction;
* :class:`EvaluationZones`: where the objectives are measured (the force zone's end as a
  :class:`LayoutPoint`, relative to a named point of the layout);
* :class:`TrackDesign`: one design of the entry side next to the interface (the design vector
  split into its groups);
* :class:`Scenario`: one simulation's inputs but the design (vehicle, track, settings, zones,
  the rail profile and, for one realisation of an uncertain track, its :class:`TrackVariation`).
* :class:`TrackVariation`: the track as built rather than as drawn: per-sleeper factors on the
  drawing's supports and pads, and voids under sleepers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# [m] sleeper spans and the Type II strip are counted in 0.1 m elements (paper, Table 4)
ELEMENT_UNIT = 0.1
# named points of the layout that lengths are measured from (TrackSpec.position)
ZONE_POINTS = ("entry_interface", "exit_interface")


@dataclass(frozen=True, kw_only=True)
class VehicleSpec:
    """The vehicle on one rail (per-wheel values; ``lccopt.vti.vehicle``, whose registry
    ``VEHICLE_TYPES`` says what each type needs and builds it)."""
    type: str = "three-dof"         # a key of lccopt.vti.vehicle.VEHICLE_TYPES
    model: str = "paper"            # three-dof only: paper (Eq. A.3 as printed) or quarter-car
    speed: float                    # [m/s]
    carbody_mass: float             # [kg]
    bogie_mass: float               # [kg]
    wheelset_mass: float            # [kg]
    primary_stiffness: float        # [N/m]
    primary_damping: float          # [N s/m]
    secondary_stiffness: float      # [N/m]
    secondary_damping: float        # [N s/m]
    hertz_constant: float           # G [m/N^(2/3)]
    hertz_load: float               # P [N] at which the Hertz spring is linearised
    gravity: float = 9.81           # [m/s^2]
    wheelbase: float | None = None              # bogie, half-car [m]
    bogie_pitch_inertia: float | None = None    # bogie, half-car [kg m^2]
    carbody_pitch_inertia: float | None = None  # half-car [kg m^2]
    bogie_distance: float | None = None         # half-car [m]


@dataclass(frozen=True)
class SpringDamper:
    stiffness: float
    damping: float


@dataclass(frozen=True, kw_only=True)
class Rail:
    youngs_modulus: float   # [Pa]
    second_moment: float    # [m^4]
    area: float             # [m^2]
    density: float          # [kg/m^3]


@dataclass(frozen=True, kw_only=True)
class Layout:
    entry_length: float     # ballast before the ERS [m]
    exit_length: float      # ballast after it [m]
    sleeper_spacing: float  # [m]
    exit_first_span: float  # slab edge to the first exit sleeper [m]


@dataclass(frozen=True, kw_only=True)
class StrengthenedSleeper:
    mass: float
    support_stiffness: float
    support_damping: float


@dataclass(frozen=True, kw_only=True)
class Compound:
    stiffness: float        # per metre of rail [N/m^2]
    damping_ratio: float


@dataclass(frozen=True, kw_only=True)
class Slab:
    youngs_modulus: float
    density: float
    width_bottom: float     # whole slab [m]
    width_top: float
    height: float


@dataclass(frozen=True, kw_only=True)
class ERS:
    slab_lengths: tuple[float, ...]     # in running order, not joined [m]
    compound: Compound
    type_ii_compound: Compound
    share_per_rail: float               # of the whole-track slab and foundation
    slab: Slab
    foundation: SpringDamper            # per metre of slab, whole slab

    @property
    def length(self) -> float:
        return float(sum(self.slab_lengths))


@dataclass(frozen=True, kw_only=True)
class TrackSpec:
    """One rail of the track: values per rail seat or per metre of rail (``lccopt.vti.track``)."""
    rail: Rail
    layout: Layout
    railpad: SpringDamper
    sleeper_mass: float
    support: SpringDamper
    strengthened_sleeper: StrengthenedSleeper
    ers: ERS

    @property
    def length(self) -> float:
        """Length of the modelled track [m] (the same for every design)."""
        return float(self.layout.entry_length + self.ers.length + self.layout.exit_length)

    def position(self, point: "LayoutPoint") -> float:
        """x [m] of a point given relative to a named point of the layout (``ZONE_POINTS``):
        the entry interface (the slab edge the designed ballast meets) or the exit interface
        (the ERS's far edge), plus the point's offset towards the exit side."""
        named = {"entry_interface": self.layout.entry_length,
                 "exit_interface": self.layout.entry_length + self.ers.length}
        if point.at not in named:
            raise ValueError(f"unknown point of the layout {point.at!r} (expected one of "
                             f"{', '.join(ZONE_POINTS)})")
        return float(named[point.at] + point.offset)


@dataclass(frozen=True, kw_only=True)
class SimulationSettings:
    time_step: float            # Newmark time step [s]
    element_length: float       # rail elements where the wheels run [m]
    far_element_length: float   # longest rail element elsewhere [m]
    run_in: float               # run before the evaluation zone [m]
    run_out: float              # run after the force zone [m]
    direction: str = "enter"    # enter (towards +x, into the ERS) or leave (towards -x)


@dataclass(frozen=True)
class LayoutPoint:
    """A point of the track given relative to a named point of the layout, so that it
    follows the layout (another slab length moves it with the ERS's far edge)."""
    at: str                 # one of ZONE_POINTS
    offset: float = 0.0     # [m] towards the exit side (+x); negative: towards the entry side


@dataclass(frozen=True, kw_only=True)
class EvaluationZones:
    sleepers: int                       # zone sleepers next to the interface
    force_zone_end: LayoutPoint         # where the force zone ends (TrackSpec.position)


@dataclass(frozen=True, kw_only=True, eq=False)
class TrackDesign:
    """One design of the entry side next to the interface (paper, Table 4)."""
    railpad_stiffness: np.ndarray   # x_r1 (farthest) .. x_rN (nearest) [N/m]
    strengthened_sleepers: float    # x_n, whole number
    sleeper_spans: np.ndarray       # x_s1 (farthest) .. x_sM (slab edge to first sleeper), elements
    type_ii_strip: float            # x_l, elements from the entry slab edge


@dataclass(frozen=True, kw_only=True, eq=False)
class TrackVariation:
    """Per-sleeper departures of the built track from its drawing (one realisation).

    Each field is None (as drawn) or a pair ``(entry, exit)`` of arrays, one value per
    ballast sleeper counted outwards from the ERS on each side (``entry[0]``: the entry
    sleeper next to the slab, ``exit[0]``: the exit sleeper next to the slab). They belong to
    the sleeper, not to a point of the track: a design that moves its sleepers moves their
    values with them. Arrays at least as long as the track's sleepers on that side.

    support_stiffness, support_damping, pad_stiffness: factors on the drawing's value (pad
    damping follows pad stiffness, as the design's pads do); void: the ballast surface under
    the sleeper lies this far below the as-built level [m] (``lccopt.vti.unilateral``: the
    track's weight closes a small one, a larger one leaves the sleeper hanging from the rail);
    settlement: a factor on the settlement law's coefficient (a settlement prediction).
    """
    support_stiffness: tuple | None = None
    support_damping: tuple | None = None
    pad_stiffness: tuple | None = None
    void: tuple | None = None
    settlement: tuple | None = None

    def per_sleeper(self, name: str, n_entry: int, n_exit: int, fill: float) -> np.ndarray:
        """The values of ``name`` for the track's ``n_entry`` entry then ``n_exit`` exit
        sleepers (each side from the slab outwards), ``fill`` where it is as drawn."""
        pair = getattr(self, name)
        if pair is None:
            return np.full(n_entry + n_exit, float(fill))
        entry, exit_ = (np.asarray(a, dtype=float) for a in pair)
        if entry.size < n_entry or exit_.size < n_exit:
            raise ValueError(f"{name}: values for {entry.size} entry and {exit_.size} exit "
                             f"sleepers, the track has {n_entry} and {n_exit}")
        return np.concatenate([entry[:n_entry], exit_[:n_exit]])


@dataclass(frozen=True, kw_only=True)
class Scenario:
    """One simulation's inputs but the design: a vehicle running over a track."""
    vehicle: VehicleSpec
    track: TrackSpec
    settings: SimulationSettings
    zones: EvaluationZones
    # (N, 2) positions [m] and dips [m, downward positive] of the rail profile, increasing
    # positions; None: a smooth rail
    irregularity: np.ndarray | None = field(default=None, compare=False, repr=False)
    # one realisation of the track's variability (lccopt.uncertainty); None: as drawn
    variation: TrackVariation | None = field(default=None, compare=False, repr=False)
