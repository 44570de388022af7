"""Case keys of the traffic physics: vehicle.type and its keys, simulation.direction and the
spectrum form of simulation.irregularity; one line (file:line: key: message) for each
problem; the bundled vehicle cases load and simulate."""

import h5py
import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.errors import CaseError
from lccopt.problem import evaluate
from tests.conftest import CHEAP_SIMULATION, CONFIGS

REFERENCE = CONFIGS / "reference.yaml"
HALF_CAR = CONFIGS / "vehicles" / "virm-half-car.yaml"


def case_error(tmp_path, text):
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(CaseError) as exc:
        load_case(p)
    msg = str(exc.value)
    assert "\n" not in msg
    return p, msg


def line_of(text, needle):
    return next(i for i, l in enumerate(text.splitlines(), 1) if needle in l)


SPECTRUM = "  irregularity: {{spectrum: {spectrum}, seed: 3, wavelengths: [{lo}, {hi}]}}\n"
WAVELENGTHS = "simulation.irregularity.wavelengths"
HALF_CAR_WITHOUT_BOGIE_DISTANCE = ("vehicle:\n  type: half-car\n  wheelbase: 2.5\n"
                                   "  bogie_pitch_inertia: 1400\n  carbody_pitch_inertia: 1.6e6\n")

BAD = [  # (extra YAML after extends/name, key in the message, words, the line holding the needle)
    ("vehicle:\n  type: tram\n", "vehicle.type", "must be one of three-dof, bogie, half-car",
     "type: tram"),
    ("vehicle:\n  type: bogie\n  wheelbase: 2.5\n", "vehicle.bogie_pitch_inertia",
     "missing key 'bogie_pitch_inertia' (vehicle type bogie needs it)", "vehicle:"),
    (HALF_CAR_WITHOUT_BOGIE_DISTANCE,
     "vehicle.bogie_distance", "missing key 'bogie_distance'", "vehicle:"),
    (HALF_CAR_WITHOUT_BOGIE_DISTANCE + "  bogie_distance: 2.0\n",
     "vehicle.bogie_distance", "must exceed the wheelbase", "bogie_distance: 2.0"),
    ("vehicle:\n  wheelbase: -2.5\n", "vehicle.wheelbase", "must be > 0", "wheelbase: -2.5"),
    ("simulation:\n  direction: backwards\n", "simulation.direction", "must be one of enter, leave",
     "direction: backwards"),
    ("simulation:\n" + SPECTRUM.format(spectrum="fra-9", lo=1, hi=50),
     "simulation.irregularity.spectrum", "must be one of erri-low", "irregularity:"),
    ("simulation:\n" + SPECTRUM.format(spectrum="erri-low", lo=50, hi=1), WAVELENGTHS,
     "must increase", "irregularity:"),
    ("simulation:\n" + SPECTRUM.format(spectrum="erri-low", lo=1, hi=500), WAVELENGTHS,
     "exceeds the track", "irregularity:"),
    ("simulation:\n" + SPECTRUM.format(spectrum="erri-low", lo=0.1, hi=50), WAVELENGTHS,
     "below what the mesh and time step resolve", "irregularity:"),
    ("simulation:\n" + SPECTRUM.format(spectrum="erri-low", lo=10.2, hi=10.25), WAVELENGTHS,
     "holds no wavelength", "irregularity:"),
    ("simulation:\n  irregularity: {spectrum: erri-low, wavelengths: [1, 50]}\n",
     "simulation.irregularity", "missing key 'seed'", "irregularity:"),
    ("simulation:\n  irregularity: [1, 2]\n", "simulation.irregularity",
     "expected a file name or a mapping", "irregularity:"),
    ("simulation:\n  direction: leave\n  run_in: 40.0\n", "simulation.run_in",
     "beyond the modelled rail [0, 134] m less 1 m at each end (vehicle 0 m long): shorten "
     "run_in/run_out or lengthen track.layout.exit_length", "run_in: 40.0"),
    ("simulation:\n  run_in: 99.0\n", "simulation.run_in", "or lengthen track.layout.entry_length",
     "run_in: 99.0"),
]


@pytest.mark.parametrize("extra,key,words,needle", BAD, ids=[b[1] + ":" + b[2][:20] for b in BAD])
def test_bad_traffic_keys_name_file_line_and_key(tmp_path, extra, key, words, needle):
    text = f"extends: {REFERENCE}\nname: bad\n" + extra
    p, msg = case_error(tmp_path, text)
    assert msg.startswith(f"{p}:{line_of(text, needle)}: {key}: "), msg
    assert words in msg, msg


def test_spectrum_irregularity_is_resolved_at_load_time_and_the_same_for_every_design(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text(f"extends: {REFERENCE}\nname: rough\n"
                 + "simulation:\n" + SPECTRUM.format(spectrum="erri-high", lo=1.0, hi=40.0))
    case = load_case(p)
    assert case.simulation["irregularity"]["amplitude_scale"] == 1.0
    prof = case.irregularity
    assert prof.shape[1] == 2 and prof[0, 0] == 0.0 and prof[-1, 0] == pytest.approx(134.0)
    assert np.array_equal(load_case(p).irregularity, prof)            # deterministic
    cheap_settings = dict(time_step=1e-3, element_length=0.1, far_element_length=0.1, run_in=3.0,
                          run_out=1.0)
    cheap = case.with_simulation(**cheap_settings)
    x2 = cheap.reference.copy()
    x2[4:7] = [7, 7, 7]                                                # another mesh
    for x in (cheap.reference, x2):
        ev = evaluate(cheap, x)
        pos = ev.histories["wheel_position"]
        assert np.allclose(ev.histories["irregularity_at_wheel"],
                           np.interp(pos, prof[:, 0], prof[:, 1]))
    smooth = evaluate(load_case(REFERENCE).with_simulation(**cheap_settings), cheap.reference)
    assert ev.objectives["F_max"] > smooth.objectives["F_max"]


def test_the_csv_irregularity_still_loads(tmp_path):
    np.savetxt(tmp_path / "p.csv", np.c_[[0.0, 50.0, 134.0], [0.0, 1e-4, 0.0]], delimiter=",")
    p = tmp_path / "c.yaml"
    p.write_text(f"extends: {REFERENCE}\nname: csv\nsimulation:\n  irregularity: p.csv\n")
    case = load_case(p)
    assert case.simulation["irregularity"]["source"] == "p.csv"
    assert np.array_equal(case.irregularity, np.c_[[0.0, 50.0, 134.0], [0.0, 1e-4, 0.0]])


# The real static wheel load of each bundled vehicle, from the whole vehicle: half its axle
# load. VIRM: Table 2's car (carbody 56 378 kg, two bogies of 3 772 kg, four wheelsets of
# 1 819 kg) on 4 axles, g = 9.8 (Eq. A.11); freight: a 22.5 t axle, g = 9.81.
VIRM_AXLE = (56378 + 2 * 3772 + 4 * 1819) / 4 * 9.8
FREIGHT_AXLE = 22.5e3 * 9.81
REAL_WHEEL_LOAD = {"virm-bogie.yaml": VIRM_AXLE / 2, "virm-half-car.yaml": VIRM_AXLE / 2,
                   "freight-22.5t.yaml": FREIGHT_AXLE / 2, "traffic.yaml:virm": VIRM_AXLE / 2,
                   "traffic.yaml:freight": FREIGHT_AXLE / 2}


def _bundled_vehicles():
    """(label, vehicle section) of every vehicle in configs/vehicles/ and configs/traffic.yaml."""
    out = [(p.name, load_case(p).vehicle) for p in sorted((CONFIGS / "vehicles").glob("*.yaml"))]
    traffic = load_case(CONFIGS / "traffic.yaml")
    return out + [(f"traffic.yaml:{k}", v) for k, v in traffic.data["vehicles"].items()]


def test_every_bundled_vehicle_carries_its_real_wheel_load():
    """Each modelled wheel carries half its real axle load within 1 % (a wheel is one end of
    its axle: half the wheelset is on it), so that a multi-axle vehicle is the real vehicle
    on one rail."""
    from lccopt.config.build import vehicle_spec
    from lccopt.vti.vehicle import build_vehicle

    vehicles = _bundled_vehicles()
    assert {label for label, _ in vehicles} == set(REAL_WHEEL_LOAD)   # every one is checked
    for label, vehicle in vehicles:
        loads = build_vehicle(vehicle_spec(vehicle)).static_wheel_loads
        assert loads == pytest.approx(REAL_WHEEL_LOAD[label], rel=0.01), label


def test_the_papers_vehicle_keeps_its_printed_wheel_load():
    """The paper's 3-dof vehicle (Eq. A.3 as printed: the bogie also rests on an unmodelled
    second wheelset) carries m_w g + (m_c + m_b) g / 2 = 57.0 kN, as configs/reference.yaml
    documents; the reading that reproduces the paper's stated facts is kept."""
    from lccopt.config.build import vehicle_spec
    from lccopt.vti.vehicle import build_vehicle

    v = load_case(REFERENCE).vehicle
    load = build_vehicle(vehicle_spec(v)).static_wheel_load
    assert load == pytest.approx((1819 + (7047.25 + 943) / 2) * 9.8)
    assert load == pytest.approx(56.98e3, abs=10)


@pytest.mark.parametrize("name,kind,wheels,load", [
    ("virm-bogie.yaml", "bogie", 2, VIRM_AXLE / 2),
    ("virm-half-car.yaml", "half-car", 4, VIRM_AXLE / 2),
    ("freight-22.5t.yaml", "half-car", 4, FREIGHT_AXLE / 2),
])
@pytest.mark.parametrize("direction", ["enter", "leave"])
def test_bundled_vehicle_cases_load_and_simulate(tmp_path, name, kind, wheels, load, direction):
    p = tmp_path / "c.yaml"
    # half a 1.2 t wheelset on its contact spring rings at 243 Hz: 0.8 ms steps at most
    simulation = (CHEAP_SIMULATION.replace("1.0e-3", "8.0e-4") if "freight" in name
                  else CHEAP_SIMULATION)
    p.write_text(f"extends: {CONFIGS / 'vehicles' / name}\nname: t\n" + simulation
                 + f"  direction: {direction}\n")
    case = load_case(p)
    assert case.vehicle["type"] == kind
    ev = evaluate(case, case.reference)
    assert ev.info["n_wheels"] == wheels and ev.info["direction"] == direction
    assert ev.info["static_wheel_load"] == pytest.approx(load)
    f = ev.histories["contact_force_wheels"]
    assert f.shape == (ev.info["n_steps"] + 1, wheels)
    assert np.allclose(f[0], load, rtol=3e-3)          # static start (the Hertz spring in series)
    assert ev.objectives["F_rms"] == pytest.approx(load, rel=0.05)
    assert 0 < ev.objectives["F_max"] < load and ev.objectives["E_max"] > 0
    assert ev.info["contact_loss_steps"] == 0


@pytest.mark.slow
def test_simulate_command_runs_a_half_car(tmp_path):
    import os
    import subprocess
    import sys

    p = tmp_path / "c.yaml"
    p.write_text(f"extends: {HALF_CAR}\nname: hc\n" + CHEAP_SIMULATION)
    # this interpreter's lccopt (the one under test), whatever `lccopt` is on PATH
    command = [sys.executable, "-m", "lccopt.cli", "simulate", str(p),
               "--out", str(tmp_path / "out")]
    proc = subprocess.run(command, capture_output=True, text=True, timeout=300,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    assert proc.returncode == 0, proc.stderr
    with h5py.File(tmp_path / "out" / "simulation.h5") as f:
        assert f["histories/contact_force_wheels"].shape[1] == 4
        assert f["info"].attrs["vehicle_type"] == "half-car"


@pytest.mark.parametrize("direction,key,short,fits", [("enter", "entry_length", 37.0, 38.0),
                                                      ("leave", "exit_length", 25.0, 26.0)])
def test_a_wheel_that_would_start_off_the_rail_or_at_its_end_is_refused(tmp_path, direction, key,
                                                                        short, fits):
    """Every wheel of a half car starts at least 2 m inside the modelled rail: its last wheel
    rolling onto the rail's end puts F_max and E_max off by percents (docs/model.md); the
    message names the layout length that is short, and by how much."""
    text = (f"extends: {CONFIGS / 'vehicles' / 'virm-half-car.yaml'}\nname: c\nsimulation:\n"
            f"  direction: {direction}\ntrack:\n  layout:\n    {key}: {short}\n")
    p, msg = case_error(tmp_path, text)
    assert msg.startswith(f"{p}:{line_of(text, key)}: track.layout.{key}: the vehicle's last "
                          f"wheel would start at "), msg
    assert "shakes the vehicle through the run (every wheel starts at least 2 m inside)" in msg
    assert msg.endswith(f"{key} {short:g} m is {0.8 if direction == 'enter' else 0.5:g} m "
                        f"short"), msg
    p.write_text(text.replace(f"{key}: {short}", f"{key}: {fits}"))
    assert load_case(p).data["track"]["layout"][key] == fits
