"""The Python entry points a notebook uses: lccopt.load_case, simulate, optimise, resume."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

import lccopt
from tests.conftest import write_case


def test_importing_lccopt_loads_no_numerics():
    # the command line sets the BLAS thread count before numpy loads: the package must not load it
    code = "import sys, lccopt; print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_simulate_a_case_file_and_a_design(tmp_path):
    case = lccopt.load_case(write_case(tmp_path, "api"))
    ref = lccopt.simulate(case)
    assert set(ref.objectives) == {"F_rms", "F_max", "E_rms", "E_max"}
    assert all(np.isfinite(v) and v > 0 for v in ref.objectives.values())
    other = case.reference.copy()
    other[:3] = 200e6                                # softer pads, N/m
    assert lccopt.simulate(case, other).objectives != ref.objectives
    again = lccopt.simulate(tmp_path / "api.yaml")   # a path works too
    assert again.objectives == ref.objectives


def test_simulate_a_traffic_case_gives_each_condition(tmp_path):
    conditions = "conditions:\n  - {name: slow, speed: 22.0}\n  - {name: fast, speed: 40.0}\n"
    out = lccopt.simulate(write_case(tmp_path, "apitr", extra=conditions))
    assert list(out) == ["slow", "fast"]
    assert out["fast"].objectives["F_max"] != out["slow"].objectives["F_max"]


def test_optimise_and_resume_from_python(tmp_path, monkeypatch):
    monkeypatch.setenv("LCCOPT_EVALUATOR", "tests.engine.fakesim:evaluate")
    case = write_case(tmp_path, "apiopt", budget=6, initial=4)
    run = lccopt.optimise(case, workers=1, runs=tmp_path / "runs", progress=False)
    assert (run / "results.h5").is_file()
    assert lccopt.resume(run, progress=False) == run     # finished: nothing to do
