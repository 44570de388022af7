import os

# One BLAS thread per process: the tests run simulations in worker processes side by side, and
# threads fighting over the two cores made the suite several times slower.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"


def lccopt_command() -> list[str]:
    """The installed console script, as a user runs it (falls back to the module)."""
    exe = shutil.which("lccopt")
    return [exe] if exe else [sys.executable, "-m", "lccopt.cli"]


@pytest.fixture
def run_cli(tmp_path):
    """Run ``lccopt ARGS`` in a subprocess from tmp_path; return the CompletedProcess."""
    def run(*args, cwd=None, timeout=600, env=None):
        return subprocess.run(lccopt_command() + [str(a) for a in args], cwd=cwd or tmp_path,
                              capture_output=True, text=True, timeout=timeout,
                              env={**os.environ, "MPLBACKEND": "Agg", **(env or {})})
    return run


@pytest.fixture(autouse=True)
def _repo_root_cwd(monkeypatch):
    """Tests refer to configs/... relative to the repository root."""
    monkeypatch.chdir(ROOT)
