"""Units in case files: a quantity written with a unit is converted to SI when the case is
read (the resolved case holds SI numbers only); a bare number outside a key's range that
another of its units fits is refused with that unit proposed, naming the key itself; `check`
and `simulate` print the speed in km/h and the vehicle."""

import h5py
import pytest
import yaml

from lccopt.config import load_case
from lccopt.errors import CaseError
from tests.conftest import CHEAP_SIMULATION, CONFIGS

REFERENCE = CONFIGS / "reference.yaml"


def case_with(tmp_path, body: str, name="c.yaml"):
    p = tmp_path / name
    p.write_text(f"extends: {REFERENCE}\nname: u\n" + body)
    return p


def error(path) -> str:
    with pytest.raises(CaseError) as exc:
        load_case(path)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


@pytest.mark.parametrize("body, path, si", [
    ("vehicle:\n  speed: 140 km/h\n", ("vehicle", "speed"), 140 / 3.6),
    ("vehicle:\n  speed: 160km/h\n", ("vehicle", "speed"), 160 / 3.6),
    ("vehicle:\n  speed: 100 mph\n", ("vehicle", "speed"), 44.704),
    ("vehicle:\n  speed: 38.5 m/s\n", ("vehicle", "speed"), 38.5),
    ("vehicle:\n  carbody_mass: 7.04725 t\n", ("vehicle", "carbody_mass"), 7047.25),
    ("vehicle:\n  primary_stiffness: 2445 kN/m\n", ("vehicle", "primary_stiffness"), 2.445e6),
    ("vehicle:\n  secondary_damping: 25.05 kN s/m\n", ("vehicle", "secondary_damping"), 25050.0),
    ("vehicle:\n  secondary_damping: 25.05 kNs/m\n", ("vehicle", "secondary_damping"), 25050.0),
    ("vehicle:\n  hertz_load: 100 kN\n", ("vehicle", "hertz_load"), 1e5),
    ("track:\n  railpad:\n    stiffness: 1120 MN/m\n", ("track", "railpad", "stiffness"), 1.12e9),
    ("track:\n  railpad:\n    stiffness: 1120 kN/mm\n", ("track", "railpad", "stiffness"), 1.12e9),
    ("track:\n  rail:\n    youngs_modulus: 210 GPa\n", ("track", "rail", "youngs_modulus"), 2.1e11),
    ("track:\n  rail:\n    second_moment: 2337 cm^4\n", ("track", "rail", "second_moment"),
     2.337e-5),
    ("track:\n  rail:\n    area: 69.77 cm²\n", ("track", "rail", "area"), 6.977e-3),
    ("track:\n  ers:\n    compound:\n      stiffness: 27 MN/m/m\n",
     ("track", "ers", "compound", "stiffness"), 2.7e7),
    ("track:\n  ers:\n    slab:\n      height: 580 mm\n", ("track", "ers", "slab", "height"), 0.58),
    ("track:\n  ers:\n    slab_lengths: [6 m, 600 cm]\n", ("track", "ers", "slab_lengths"),
     [6.0, 6.0]),
    ("simulation:\n  time_step: 0.5 ms\n", ("simulation", "time_step"), 5e-4),
])
def test_a_quantity_with_a_unit_is_read_in_si(tmp_path, body, path, si):
    case = load_case(case_with(tmp_path, body))
    value = case.data
    for k in path:
        value = value[k]
    assert value == pytest.approx(si, rel=1e-12)
    # the resolved case (what a run keeps and fingerprints) holds the SI number, no unit
    resolved = yaml.safe_load(case.resolved)
    for k in path:
        resolved = resolved[k]
    assert resolved == pytest.approx(si, rel=1e-12)


def test_km_per_h_gives_the_same_case_as_the_si_number(tmp_path):
    a = load_case(case_with(tmp_path, "vehicle:\n  speed: 140 km/h\n", "a.yaml"))
    b = load_case(case_with(tmp_path, "vehicle:\n  speed: 38.88888888888889\n", "b.yaml"))
    assert a.resolved == b.resolved


@pytest.mark.parametrize("body, line, key, words", [
    ("vehicle:\n  speed: 140\n", 4, "vehicle.speed",
     "140 m/s is 504 km/h, above 250 km/h (no level crossing's line speed is higher): did you "
     "mean `speed: 140 km/h`?"),
    ("vehicle:\n  speed: 300 km/h\n", 4, "vehicle.speed", "must be <= 250 km/h"),
    ("vehicle:\n  speed: 140 kmh\n", 4, "vehicle.speed",
     "unknown unit 'kmh' (did you mean 'km/h'?); it takes m/s, km/h, mph"),
    ("vehicle:\n  speed: 140 KM/H\n", 4, "vehicle.speed", "did you mean 'km/h'?"),
    ("vehicle:\n  speed: 140 kN\n", 4, "vehicle.speed", "unknown unit 'kN'"),
    ("vehicle:\n  wheelset_mass: 1.819\n", 4, "vehicle.wheelset_mass",
     "did you mean `wheelset_mass: 1.819 t`?"),
    ("track:\n  railpad:\n    stiffness: 1120\n", 5, "track.railpad.stiffness",
     "1120 N/m is 0.00112 MN/m, below 10 MN/m (railpads are 20-2000 MN/m): did you mean "
     "`stiffness: 1120 MN/m`?"),
    ("track:\n  rail:\n    youngs_modulus: 210\n", 5, "track.rail.youngs_modulus",
     "did you mean `youngs_modulus: 210 GPa`?"),
    ("optimisation:\n  seed: 3 m\n", 4, "optimisation.seed", "takes a plain number, got the unit"),
    ("design:\n  railpad_stiffness:\n    bounds: [50, 1200]\n", 5,
     "design.railpad_stiffness.bounds[0]", "did you mean `bounds: 50 MN/m`?"),
])
def test_a_value_in_the_wrong_unit_is_refused_naming_its_own_key(tmp_path, body, line, key,
                                                                  words):
    p = case_with(tmp_path, body)
    msg = error(p)
    assert msg.startswith(f"{p}:{line}: {key}: "), msg
    assert words in msg, msg


def test_a_speed_without_its_unit_never_blames_another_key(tmp_path, run_cli):
    """`speed: 140` (meant km/h) once failed with a message about the base file's
    time_step; following its advice simulated at 504 km/h."""
    p = case_with(tmp_path, "vehicle:\n  speed: 140\n")
    r = run_cli("check", p)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [
        f"lccopt: error: {p}:4: vehicle.speed: 140 m/s is 504 km/h, above 250 km/h (no level "
        f"crossing's line speed is higher): did you mean `speed: 140 km/h`?"]
    # a plausible speed that the time step cannot follow names the speed it moves at
    p = case_with(tmp_path, "vehicle:\n  speed: 60\nsimulation:\n  element_length: 0.01\n")
    msg = error(p)
    assert "simulation.time_step: 0.0005 s moves the wheel 0.03 m per step at 216 km/h " \
           "(vehicle.speed)" in msg


def test_check_and_simulate_print_the_speed_in_km_h_and_the_vehicle(tmp_path, run_cli):
    p = case_with(tmp_path, "vehicle:\n  speed: 160 km/h\n" + CHEAP_SIMULATION)
    r = run_cli("check", p)
    assert r.returncode == 0, r.stderr
    assert "  vehicle: three-dof (paper), 160 km/h, static wheel load 56.98 kN per wheel" \
        in r.stdout.splitlines()
    r = run_cli("simulate", p, "--out", tmp_path / "o", "--no-plots")
    assert r.returncode == 0, r.stderr
    assert "vehicle: three-dof (paper), 160 km/h, static wheel load 56.98 kN per wheel" \
        in r.stdout.splitlines()
    with h5py.File(tmp_path / "o" / "simulation.h5") as f:
        assert f["info"].attrs["speed"] == pytest.approx(160 / 3.6)
        assert "speed: 44.44444444444444" in f["info"].attrs["case"]


def test_traffic_conditions_show_each_vehicle_and_speed(run_cli):
    r = run_cli("check", CONFIGS / "traffic.yaml")
    assert r.returncode == 0, r.stderr
    out = r.stdout.splitlines()
    assert "    virm-160-leave-rough: virm (half-car, 87.2 kN), 160 km/h, leave" in out
    assert "    freight-100-enter-smooth: freight (half-car, 110.4 kN), 100 km/h, enter" in out
    assert all(len(line) <= 80 for line in out[1:])


@pytest.mark.parametrize("body, fix", [
    # a bare number: a whole one counted 0.1 m elements before, any other meant m
    ("design:\n  sleeper_spans: {bounds: [3, 7]}\n", "did you mean `bounds: [0.3 m, 0.7 m]`?"),
    ("design:\n  sleeper_spans: {bounds: [0.3, 0.7]}\n", "did you mean `bounds: [0.3 m, 0.7 m]`?"),
    ("design:\n  sleeper_spans: {reference: [6, 6, 0.4 m]}\n",
     "did you mean `reference: [0.6 m, 0.6 m, 0.4 m]`?"),
    ("design:\n  type_ii_strip: {reference: 5}\n", "did you mean `reference: 0.5 m`?"),
    ("design:\n  sleeper_spans: {reference: [60 cm, 0.65 m, 0.4 m]}\n",
     "0.65 m is not a multiple of 0.1 m"),
    ("design:\n  type_ii_strip: {reference: 2 ft}\n", "unknown unit 'ft'"),
])
def test_a_length_of_the_design_needs_its_unit(tmp_path, body, fix):
    """Spans and the strip are written with their unit, in steps of 0.1 m (the rail's
    elements); a bare number is refused with what to write."""
    msg = error(case_with(tmp_path, body))
    assert fix in msg and "\n" not in msg


def test_a_length_in_any_unit_is_the_same_design(tmp_path):
    metres = load_case(case_with(tmp_path, "design:\n  sleeper_spans: {reference: "
                                           "[0.6 m, 0.6 m, 0.4 m]}\n  type_ii_strip: "
                                           "{bounds: [0 m, 8 m], reference: 1.2 m}\n"))
    other = load_case(case_with(tmp_path, "design:\n  sleeper_spans: {reference: "
                                          "[60 cm, 600 mm, 0.4 m]}\n  type_ii_strip: "
                                          "{bounds: [0, 8000 mm], reference: 120 cm}\n"))
    assert metres.resolved == other.resolved
    assert metres.reference[4:].tolist() == [6.0, 6.0, 4.0, 12.0]    # 0.1 m elements inside
    assert metres.upper[-1] == 80.0
