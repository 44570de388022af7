"""The machine entries of a run (OpenBLAS kernels, numpy's SIMD targets): recorded, compared on
resume, and the environment that pins them named (README, "Reproducibility")."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys

import h5py
import pytest

from lccopt import machine
from lccopt.engine.journal import read_journal
from lccopt.store import read_evaluation

from .conftest import FAKE, REPO, cli_run, optimise_on_local_dask, write_case

# seconds a test: runs resumed under other floating-point kernels
pytestmark = pytest.mark.slow

NATIVE = machine.describe()
# Kernels other than this machine's that any x86-64 CPU can run
OTHER = "Nehalem" if NATIVE["blas_kernels"] != "Nehalem" else "Sandybridge"
x86_openblas = pytest.mark.skipif(
    platform.machine() not in ("x86_64", "AMD64") or NATIVE["blas_kernels"] == "unknown",
    reason="needs OpenBLAS on x86-64 (the kernel names are x86's)")


def _describe_with(env: dict) -> dict:
    """The entries of a new process started with ENV on top of this one's environment (which
    may pin kernels or SIMD targets itself: the tests compare with this process, NATIVE)."""
    code = "import json; from lccopt import machine; print(json.dumps(machine.describe()))"
    out = subprocess.run([sys.executable, "-c", code],
                         env={**os.environ, "PYTHONPATH": str(REPO), **env},
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


@x86_openblas
def test_the_recorded_kernels_follow_openblas_coretype():
    assert _describe_with({})["blas_kernels"] == NATIVE["blas_kernels"]
    assert _describe_with({"OPENBLAS_CORETYPE": OTHER})["blas_kernels"] == OTHER


def test_the_recorded_simd_targets_follow_npy_disable_cpu_features():
    on = NATIVE["numpy_simd"].split()
    if len(on) < 2 or "unknown" in on:
        pytest.skip("numpy dispatches to fewer than two SIMD targets here")
    off = os.environ.get("NPY_DISABLE_CPU_FEATURES", "").split() + on[1:]   # the user's, and more
    assert _describe_with({"NPY_DISABLE_CPU_FEATURES": " ".join(off)})["numpy_simd"] == on[0]


def test_resume_note_names_what_changed_and_how_to_pin_it():
    started = {"numpy": "2.4.6", "blas_kernels": "Haswell", "numpy_simd": "X86_V3"}
    now = {"numpy": "2.4.6", "blas_kernels": "SkylakeX", "numpy_simd": "X86_V3 X86_V4 AVX512_ICL"}
    note = machine.resume_note(started, now)
    assert "blas_kernels Haswell" in note and "blas_kernels SkylakeX" in note
    assert 'OPENBLAS_CORETYPE=Haswell NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL"' in note
    assert machine.resume_note(started, dict(started)) is None
    # a library version or a SIMD target this CPU lacks cannot be pinned: said, no advice
    note = machine.resume_note({**started, "numpy": "2.4.5"}, now)
    assert "numpy 2.4.5" in note and "resume with" not in note
    note = machine.resume_note({"numpy_simd": "X86_V3 X86_V4"}, {"numpy_simd": "X86_V3"})
    assert "numpy_simd X86_V3 X86_V4" in note and "resume with" not in note
    # a run of an lccopt that did not record the machine: nothing to compare
    assert machine.resume_note({"numpy": "2.4.6"}, now) is None
    assert machine.resume_note(None, now) is None


@x86_openblas
def test_a_run_records_its_kernels_and_a_resume_elsewhere_says_how_to_match_them(tmp_path):
    case = write_case(tmp_path, "m", budget=4, initial=3)
    runs, run = tmp_path / "runs", tmp_path / "runs" / "m"
    env = {"LCCOPT_EVALUATOR": FAKE, "OPENBLAS_CORETYPE": OTHER}
    r = cli_run("optimise", case, "--workers", "1", "--runs", runs, env=env)
    assert r.returncode == 0, r.stderr
    events, _, _ = read_journal(run / "journal.jsonl")
    assert json.loads((run / "run.json").read_text())["versions"]["blas_kernels"] == OTHER
    assert events[0]["versions"]["blas_kernels"] == OTHER
    assert [e["versions"]["blas_kernels"] for e in events if e["event"] == "session"] == [OTHER]
    with h5py.File(run / "results.h5", "r") as f:
        assert json.loads(f["versions"].attrs["run_started_with"])["blas_kernels"] == OTHER
    _, ev = read_evaluation(run / "evals" / "000001.h5")
    assert ev.info["blas_kernels"] == OTHER

    # the same machine entries: a resume (of a run given more budget) says nothing about them
    case.write_text(case.read_text().replace("budget: 4", "budget: 5"))
    r = cli_run("resume", run, "--allow-changed-case", env=env)
    assert r.returncode == 0 and "may differ" not in r.stderr, r.stderr
    # this machine's own kernels: said once, with the setting that gives the run's back
    case.write_text(case.read_text().replace("budget: 5", "budget: 6"))
    r = cli_run("resume", run, "--allow-changed-case", env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0, r.stderr
    notes = [line for line in r.stderr.splitlines() if "may differ" in line]
    assert len(notes) == 1 and f"resume with OPENBLAS_CORETYPE={OTHER}" in notes[0], r.stderr
    events, _, _ = read_journal(run / "journal.jsonl")
    assert [e["versions"]["blas_kernels"] for e in events if e["event"] == "session"] == \
        [OTHER, OTHER, NATIVE["blas_kernels"]]


def test_resume_note_shows_and_suggests_nothing_a_crafted_journal_puts_there():
    started = {"blas_kernels": "Haswell; rm -rf ~", "numpy_simd": "X86_V3\x1b[2J",
               "numpy": "2" * 500}
    now = {"blas_kernels": "SkylakeX", "numpy_simd": "X86_V3 X86_V4", "numpy": "2.4.6"}
    note = machine.resume_note(started, now)
    assert "rm" not in note and "\x1b" not in note and "222" not in note
    assert "resume with" not in note
    assert "blas_kernels unknown" in note


@x86_openblas
def test_each_evaluation_file_records_the_machine_of_the_worker_that_ran_it(tmp_path, monkeypatch):
    """On Dask the parent writes the files from the evaluations the workers send back: the
    entries must be the workers' (here: workers started with other kernels than the parent's)."""
    monkeypatch.setenv("OPENBLAS_CORETYPE", OTHER)  # the workers' start; this process keeps its own
    case = write_case(tmp_path, "w", budget=3, initial=3)
    run = optimise_on_local_dask(case, tmp_path / "runs", FAKE, n_workers=1)
    for i in range(3):
        _, ev = read_evaluation(run / f"evals/{i:06d}.h5")
        assert ev.info["blas_kernels"] == OTHER and ev.info["numpy_simd"] == NATIVE["numpy_simd"]
    assert machine.describe()["blas_kernels"] == NATIVE["blas_kernels"] != OTHER


def test_a_run_resumed_by_other_code_says_so_and_each_file_names_the_code_that_computed_it(
        tmp_path):
    """The version number changes at releases only; the code's fingerprint tells two checkouts
    apart. A run begun by one copy of lccopt and resumed by an edited copy: the resume says so
    once, `status` lists both codes in order, each evaluation file names its own."""
    import re
    import shutil

    code = tmp_path / "code"
    shutil.copytree(REPO / "lccopt", code / "lccopt", symlinks=True,
                    ignore=shutil.ignore_patterns("__pycache__"))
    # run from tmp_path: `python -c` puts the working directory (a checkout) first on the path
    env = {"LCCOPT_EVALUATOR": FAKE, "PYTHONPATH": f"{code}{os.pathsep}{REPO}"}

    def version() -> str:
        r = cli_run("--version", env=env, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        return re.fullmatch(r"lccopt \S+ \(code ([0-9a-f]{16})\)\n", r.stdout).group(1)

    case = write_case(tmp_path, "c", budget=4, initial=3)
    run = tmp_path / "runs" / "c"
    first = version()
    r = cli_run("optimise", case, "--workers", "1", "--runs", tmp_path / "runs", env=env,
                cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads((run / "run.json").read_text())["versions"]["lccopt_code"] == first
    r = cli_run("status", run, env=env, cwd=tmp_path)
    assert r.returncode == 0 and "code changed" not in r.stdout, r.stdout

    with open(code / "lccopt" / "vti" / "track.py", "a") as fh:   # another model, same version
        fh.write("\n# edited\n")
    second = version()
    assert second != first
    case.write_text(case.read_text().replace("budget: 4", "budget: 6"))
    r = cli_run("resume", run, "--allow-changed-case", env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    notes = [line for line in r.stderr.splitlines() if "lccopt's code" in line]
    assert len(notes) == 1 and first in notes[0] and second in notes[0], r.stderr
    assert "may differ" in notes[0] and "resume with" not in notes[0], notes
    r = cli_run("status", run, env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (f"  lccopt's code changed between sessions (values may not compare):\n"
            f"    {first}, then {second}\n") in r.stdout, r.stdout
    codes = [read_evaluation(run / "evals" / f"{i:06d}.h5")[1].info["lccopt_code"]
             for i in range(6)]
    assert codes == [first] * 4 + [second] * 2, codes
