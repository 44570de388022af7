"""`lccopt simulate` and `lccopt check` as a user runs them: subprocess, real files, real HDF5."""

import h5py
import numpy as np
import pytest

from lccopt import machine
from tests.conftest import CONFIGS

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def reference_run(tmp_path_factory):
    import os
    import subprocess

    from tests.conftest import lccopt_command
    out = tmp_path_factory.mktemp("sim")
    command = lccopt_command() + ["simulate", str(CONFIGS / "reference.yaml"), "--out", str(out)]
    proc = subprocess.run(command, capture_output=True, text=True, timeout=300,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    return proc, out


def test_simulate_prints_the_four_objectives_with_units(reference_run):
    proc, out = reference_run
    assert proc.returncode == 0, proc.stderr
    lines = {l.split("=")[0].strip(): l
             for l in proc.stdout.splitlines() if "=" in l and l.startswith("  ")}
    for name, unit in [("F_rms", "kN"), ("F_max", "kN"), ("E_rms", "J"), ("E_max", "J")]:
        assert lines[name].split("=")[1].split()[1] == unit
    assert "static wheel load 56.98 kN" in proc.stdout and "P = 100.0 kN" in proc.stdout
    # every line but those naming paths (the case file, the output) fits an 80-column terminal
    assert all(len(line) <= 80 for line in proc.stdout.splitlines()[1:] if str(out) not in line)
    assert "x_r1=1120 MN/m" in proc.stdout and "x_l=0" in proc.stdout


def test_simulate_writes_readable_histories_and_plots(reference_run):
    proc, out = reference_run
    with h5py.File(out / "simulation.h5", "r") as f:
        x = f["design"][()]
        assert list(f["design"].attrs["names"]) == ["x_r1", "x_r2", "x_r3", "x_n",
                                                    "x_s1", "x_s2", "x_s3", "x_l"]
        assert np.array_equal(x, [1120e6] * 3 + [8, 6, 6, 4, 0])
        force = f["histories/contact_force"][()]
        zone = f["histories/in_force_zone"][()].astype(bool)
        energy = f["histories/sleeper_energy"][()]
        f_max = f["objectives"].attrs["F_max"]
        e_max = f["objectives"].attrs["E_max"]
        n_steps = f["info"].attrs["n_steps"]
        assert len(force) == len(f["histories/wheel_position"][()]) == n_steps + 1
        # what decides its floating point on this machine (lccopt/machine.py), recorded
        assert {k: f["info"].attrs[k] for k in machine.describe()} == machine.describe()
        assert "vehicle:" in f["info"].attrs["case"]
    # the stored objectives are those of the stored histories
    assert f_max == pytest.approx(force[zone].max() - force[zone].min())
    assert e_max == pytest.approx(energy.max() - energy.min())
    assert len(energy) == 20 and np.all(energy > 0)
    f_max_line = next(l for l in proc.stdout.splitlines() if l.strip().startswith("F_max"))
    printed = float(f_max_line.split("=")[1].split()[0])
    assert printed == pytest.approx(f_max / 1e3, rel=1e-4)  # shown in kN
    for name in ("contact_force.png", "sleeper_energy.png", "displacement.png"):
        data = (out / name).read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 10_000


def test_simulate_another_design(run_cli, tmp_path):
    proc = run_cli("simulate", CONFIGS / "reference.yaml", "--design", "214,155,50,5,0.6,0.7,0.3,0",
                   "--out", tmp_path / "moo", "--no-plots")
    assert proc.returncode == 0, proc.stderr
    with h5py.File(tmp_path / "moo" / "simulation.h5") as f:
        assert f["design"][()][0] == 214e6
        pads = f["histories/entry_pad_stiffness"][()]
        assert list(pads[:4]) == [50e6, 155e6, 214e6, 1120e6]
    assert not list((tmp_path / "moo").glob("*.png"))


@pytest.mark.parametrize("design,said", [
    # 50 read in the old unit (0.1 m elements) is a design of the case: the message says so
    ("214,155,50,5,0.6,0.7,0.3,50",
     "x_l = 50 m is outside [0, 12] m (if that counts 0.1 m elements, write 5 m)"),
    ("214,155,50,5,0.6,0.7,0.3,130", "x_l = 130 m is outside [0, 12] m"),
])
def test_simulate_rejects_a_bad_design(run_cli, design, said):
    proc = run_cli("simulate", CONFIGS / "reference.yaml", "--design", design)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [f"lccopt: error: --design: {said}"]


def test_check_accepts_a_good_case(run_cli):
    proc = run_cli("check", CONFIGS / "reference.yaml")
    assert proc.returncode == 0
    assert "ok" in proc.stdout and "8 design variables" in proc.stdout


@pytest.mark.parametrize("old,new,expect", [
    ("    reference: 8\n", "    reference: 21\n",
     ": design.strengthened_sleepers.reference: reference x_n = 21 is outside the bounds [0, 20]"),
    ("  run_in: 2.0", "  run_in: ten", ": simulation.run_in: expected a number, got 'ten'"),
    ("  speed: 140 km/h", "  speed: 140 km/h\n  colour: red", ": vehicle.colour: unknown key"),
])
def test_check_rejects_bad_cases_with_one_line(run_cli, tmp_path, old, new, expect):
    text = (CONFIGS / "reference.yaml").read_text()
    assert old in text
    bad = tmp_path / "bad.yaml"
    bad_text = text.replace(old, new, 1)
    bad.write_text(bad_text)
    key_line = bad_text[:bad_text.index(new.strip().splitlines()[-1])].count("\n") + 1
    for command in ("check", "simulate"):
        proc = run_cli(command, bad)
        assert proc.returncode == 2
        err = proc.stderr.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"lccopt: error: {bad}:{key_line}: ")
        assert expect in err[0]


def test_missing_file_and_usage_errors(run_cli, tmp_path):
    proc = run_cli("check", tmp_path / "none.yaml")
    assert proc.returncode == 2 and "cannot read" in proc.stderr
    proc = run_cli("simulate")
    assert proc.returncode == 2


def test_design_is_given_in_mn_per_m_and_checked_in_those_units(run_cli, tmp_path):
    proc = run_cli("simulate", CONFIGS / "reference.yaml",
                   "--design", "214e6,155,50,5,0.6,0.7,0.3,0", "--out", tmp_path / "x")
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        "lccopt: error: --design: x_r1 = 2.14e+08 MN/m is outside [50, 1200] MN/m (if that is "
        "in N/m, write 214 MN/m)")


@pytest.mark.slow
def test_simulate_refuses_to_overwrite_without_force(run_cli, tmp_path):
    args = ("simulate", CONFIGS / "reference.yaml", "--out", tmp_path / "o", "--no-plots")
    assert run_cli(*args).returncode == 0
    again = run_cli(*args)
    assert again.returncode == 2 and "already holds simulation.h5" in again.stderr
    assert run_cli(*args, "--force").returncode == 0


def test_version_format_enum_and_plain_flags(run_cli):
    from lccopt import __version__
    from lccopt.version import code_fingerprint

    v = run_cli("--version")
    assert v.returncode == 0, v.stderr
    assert v.stdout.strip() == f"lccopt {__version__} (code {code_fingerprint()})"
    bad = run_cli("report", "nowhere", "--format", "pdf")
    assert bad.returncode == 2 and "'pdf' is not one of" in bad.stderr
    for cmd in ("optimise", "simulate", "resume"):
        help_text = run_cli(cmd, "--help", env={"COLUMNS": "200"}).stdout
        assert "--no-force" not in help_text and "--no-allow-changed-case" not in help_text
