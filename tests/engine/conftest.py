"""Helpers for the run-engine tests: cheap case files, results tables, CLI subprocesses."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "configs" / "reference.yaml"
if str(REPO) not in sys.path:  # 'tests.engine.fakesim' importable here and in spawned workers
    sys.path.insert(0, str(REPO))

FAKE = "tests.engine.fakesim:evaluate"
FAULTY = "tests.engine.fakesim:faulty"
REAL = "lccopt.problem:evaluate"

from tests.conftest import CHEAP_SIMULATION, write_case  # noqa: E402,F401 (shared with tests/report)

COLUMNS = ("id", "x", "F_rms", "F_max", "E_rms", "E_max", "value", "status", "reason", "phase",
           "restart", "file")



def journal_events(run: Path) -> list[dict]:
    """The committed events of a run's journal."""
    from lccopt.engine.journal import read_journal

    return read_journal(run / "journal.jsonl")[0]


def n_done(run: Path) -> int:
    """Evaluations with a result in the journal (0 while it is not there or being written)."""
    try:
        return sum(e["event"] in ("evaluated", "failed") for e in journal_events(run))
    except Exception:  # noqa: BLE001 - the journal is not there yet, or being written
        return 0


def wait_for(cond, timeout: float = 120.0, what: str = "condition") -> None:
    """Poll ``cond`` every 50 ms until it holds; fail after ``timeout`` seconds."""
    t0 = time.monotonic()
    while not cond():
        if time.monotonic() - t0 > timeout:
            raise AssertionError(f"gave up waiting for {what}")
        time.sleep(0.05)

def read_table(run: Path) -> dict:
    """The evaluation table of results.h5 as numpy arrays (strings decoded)."""
    with h5py.File(Path(run) / "results.h5", "r") as f:
        e = f["evaluations"]
        out = {}
        for k in e:
            v = e[k][()]
            if v.dtype.kind == "O":
                v = np.array([s.decode() if isinstance(s, bytes) else s for s in v], dtype=object)
            out[k] = v
    return out


def assert_same_evaluations(a: dict, b: dict, columns=COLUMNS) -> None:
    for k in columns:
        va, vb = a[k], b[k]
        assert va.shape == vb.shape, (k, va.shape, vb.shape)
        if va.dtype.kind == "f":
            np.testing.assert_array_equal(va, vb, err_msg=k)
        else:
            assert list(va.ravel()) == list(vb.ravel()), k


def optimise_on_local_dask(case: Path, runs: Path, evaluator: str, n_workers: int = 1) -> Path:
    """``optimise`` on a local Dask cluster of n_workers single-threaded worker processes;
    the run directory (skips the test when distributed is not installed)."""
    distributed = pytest.importorskip("distributed")
    from lccopt.engine.runner import optimise

    with distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        return optimise(case, scheduler=cluster.scheduler_address, runs=runs, evaluator=evaluator,
                        progress=False)


def cli(*args, env: dict | None = None, cwd: Path | None = None, **kw) -> subprocess.Popen:
    e = {**os.environ, "PYTHONPATH": str(REPO), **(env or {})}
    # What the `lccopt` console script runs (python -m lccopt.cli would make a second copy of
    # the cli module as __main__, with its own UsageError class).
    main = "import sys; from lccopt.cli import main; sys.exit(main())"
    return subprocess.Popen([sys.executable, "-c", main, *map(str, args)], env=e, cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def cli_run(*args, env=None, cwd=None, timeout=300) -> subprocess.CompletedProcess:
    p = cli(*args, env=env, cwd=cwd)
    out, err = p.communicate(timeout=timeout)
    return subprocess.CompletedProcess(p.args, p.returncode, out, err)


@pytest.fixture
def fake_env(monkeypatch):
    """Use the analytic stand-in in workers started from this process."""
    monkeypatch.setenv("LCCOPT_EVALUATOR", FAKE)
    return {"LCCOPT_EVALUATOR": FAKE}


def pinned_numerics_env() -> dict:
    """The environment that makes floating point the same on any x86-64 CPU with AVX2:
    OpenBLAS's Haswell kernels and numpy's X86_V3 loops only (docs/runs.md, Reproducibility).
    Skips the test where that baseline is not available (not x86-64, no AVX2, no OpenBLAS)."""
    import platform

    from lccopt import machine

    if (platform.machine() not in ("x86_64", "AMD64")
            or machine.describe()["blas_kernels"] == "unknown"):
        pytest.skip("needs OpenBLAS on x86-64 to pin the floating point of a stored run")
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:
        pytest.skip("numpy does not say which SIMD targets it dispatches to")
    if not __cpu_features__.get("X86_V3"):
        pytest.skip("needs an x86-64-v3 (AVX2) CPU to repeat a stored run's floating point")
    above = [f for f in __cpu_dispatch__ if f != "X86_V3"]
    return {"OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": " ".join(above),
            "OPENBLAS_NUM_THREADS": "1"}
