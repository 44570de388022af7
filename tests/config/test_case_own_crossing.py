"""A user's own crossing, as the tutorial writes it: another slab length, the speed in km/h,
another vehicle (the bundled VIRM half car, or one's own vehicle section with units). Each
case file below is the text a tutorial can give; `lccopt check` and `lccopt simulate` run it
as a user would, and no length or unit needs a second edit."""

import h5py
import pytest

from tests.conftest import ROOT

OWN_CROSSING = """\
# A 9 m crossing (one slab) on a 160 km/h line, passed by a VIRM half car.
extends: configs/vehicles/virm-half-car.yaml
name: my-crossing
track:
  ers:
    slab_lengths: [9.0]        # one 9 m slab: the force zone (2 m before its far edge) and the
                               # Type II strip's range (the whole ERS) follow it
vehicle:
  speed: 160 km/h
optimisation:
  objectives: [F_max, E_max]   # initial_points (20) and asf.worst (1.5 x reference) default
  budget: 100
"""

OWN_VEHICLE = """\
# The same crossing, passed by one's own four-axle car as a half car on one rail: each
# value per wheel (carbody / 8, bogie / 4, half a wheelset, one axle box's primary spring,
# half the secondary spring of a bogie side).
extends: my-crossing.yaml
name: my-vehicle
vehicle:
  type: half-car
  speed: 120 km/h
  carbody_mass: 5.5 t            # a 44 t carbody / 8
  bogie_mass: 0.75 t             # a 3 t bogie / 4
  wheelset_mass: 0.7 t           # a 1.4 t wheelset / 2
  primary_stiffness: 1.2 MN/m
  primary_damping: 10 kN s/m
  secondary_stiffness: 0.4 MN/m
  secondary_damping: 15 kN s/m
  hertz_constant: 5.13e-8
  hertz_load: 70 kN              # about the static wheel load
  gravity: 9.81
  wheelbase: 2.6 m
  bogie_pitch_inertia: 1.2 t m^2
  carbody_pitch_inertia: 1300 t m^2
  bogie_distance: 17.5 m
"""


@pytest.fixture
def cases(tmp_path):
    """The two case files in a clone's root (configs/ beside them), as a user writes them."""
    (tmp_path / "configs").symlink_to(ROOT / "configs")
    (tmp_path / "my-crossing.yaml").write_text(OWN_CROSSING)
    (tmp_path / "my-vehicle.yaml").write_text(OWN_VEHICLE)
    return tmp_path


def test_check_follows_the_slab_length_and_the_speed(cases, run_cli):
    r = run_cli("check", "my-crossing.yaml", cwd=cases)
    assert r.returncode == 0, r.stderr
    out = r.stdout.splitlines()
    assert "  vehicle: half-car, 160 km/h, static wheel load 87.22 kN per wheel" in out
    assert "  zone: 20 sleepers; force to 2 m before the exit interface," in out
    assert "        7 m past the entry slab edge" in out
    assert "x_l [0, 9] m in 0.1 m steps" in r.stdout
    assert "  optimisation: F_max, E_max; budget 100, 20 initial points; histories: best" in out
    assert "    asf.worst: 1.5 x the reference design's objectives (the default)" in out
    r = run_cli("check", "my-vehicle.yaml", cwd=cases)
    assert r.returncode == 0, r.stderr
    # (5500 + 750 + 700) kg x 9.81 = 68.2 kN: the vehicle's real wheel load, 55.6 t / 8
    assert "  vehicle: half-car, 120 km/h, static wheel load 68.18 kN per wheel" \
        in r.stdout.splitlines()


def test_simulate_runs_the_own_vehicle_on_the_own_crossing(cases, run_cli):
    r = run_cli("simulate", "my-vehicle.yaml", "--no-plots",
                "--set", "simulation.time_step=0.8 ms", "--set", "simulation.element_length=0.1",
                cwd=cases)
    assert r.returncode == 0, r.stderr
    with h5py.File(cases / "runs" / "my-vehicle-simulate" / "simulation.h5") as f:
        info = f["info"].attrs
        assert info["vehicle_type"] == "half-car"
        assert info["speed"] == pytest.approx(120 / 3.6)
        assert info["interface_exit"] == pytest.approx(109.0)
        assert info["zone_end"] == pytest.approx(107.0)
        assert info["static_wheel_load"] == pytest.approx((5500 + 750 + 700) * 9.81)
        assert f["objectives"].attrs["F_max"] > 0
