import os

# One BLAS thread per process: the tests run simulations in worker processes side by side, and
# threads fighting over the two cores made the suite several times slower.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import contextlib  # noqa: E402
import shutil  # noqa: E402  (after the thread settings, as every import below)
import signal  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"
REFERENCE = CONFIGS / "reference.yaml"


def lccopt_command() -> list[str]:
    """The installed console script, as a user runs it (falls back to the module): the one
    installed beside this Python first, so that another lccopt on PATH (an older install in
    another environment) is never the one tested."""
    beside = Path(sys.executable).parent / "lccopt"
    exe = str(beside) if beside.is_file() else shutil.which("lccopt")
    return [exe] if exe else [sys.executable, "-m", "lccopt.cli"]


def subprocess_env(base=None, **extra) -> dict:
    """The environment for an lccopt subprocess.  A test evaluator (``tests.engine.fakesim``)
    lives in this repository, not in the installed package: the subprocess then needs the
    repository on its path, which a plain (non-editable) install, as CI makes, lacks."""
    env = {**(os.environ if base is None else base), "MPLBACKEND": "Agg", **extra}
    if env.get("LCCOPT_EVALUATOR", "").startswith("tests."):
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
    return env


def group_alive(pgid: int) -> bool:
    """Whether any process of process group ``pgid`` is left (no orphan left behind)."""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


@contextlib.contextmanager
def leaves_no_process(pgid: int, within: float = 10.0):
    """The block ends a process group's leader; then every process of the group must be gone
    within ``within`` seconds (else the test fails); whatever is left is killed anyway."""
    try:
        yield
        t0 = time.monotonic()
        while group_alive(pgid):
            assert time.monotonic() - t0 < within, "a process outlived its caller"
            time.sleep(0.05)
    finally:
        if group_alive(pgid):
            os.killpg(pgid, signal.SIGKILL)


@pytest.fixture
def run_cli(tmp_path):
    """Run ``lccopt ARGS`` in a subprocess from tmp_path; return the CompletedProcess."""
    def run(*args, cwd=None, timeout=600, env=None):
        return subprocess.run(lccopt_command() + [str(a) for a in args], cwd=cwd or tmp_path,
                              capture_output=True, text=True, timeout=timeout,
                              env=subprocess_env(**(env or {})))
    return run


@pytest.fixture(autouse=True)
def _repo_root_cwd(monkeypatch):
    """Tests refer to configs/... relative to the repository root."""
    monkeypatch.chdir(ROOT)


# A short, coarse simulation: same model, ~0.1-0.2 s per evaluation instead of ~1 s.
CHEAP_SIMULATION = """\
simulation:
  time_step: 1.0e-3
  element_length: 0.1
  far_element_length: 0.1
  run_in: 3.0
  run_out: 1.0
"""


def write_case(directory: Path, name: str = "t", objectives=("F_max", "E_max"), budget: int = 12,
               initial: int = 5, seed: int = 1, timeout: float = 60.0, worst=(60000.0, 5.0),
               cheap: bool = True, extra: str = "", per_fit: int | None = None) -> Path:
    lines = [f"extends: {REFERENCE}", f"name: {name}", "optimisation:",
             f"  objectives: [{', '.join(objectives)}]", f"  budget: {budget}",
             f"  initial_points: {initial}", f"  seed: {seed}", f"  timeout: {timeout}"]
    if per_fit is not None:
        lines.append(f"  proposals_per_fit: {per_fit}")
    if len(objectives) > 1:
        lines += ["  asf:", f"    worst: [{', '.join(str(w) for w in worst)}]"]
    text = "\n".join(lines) + "\n" + (CHEAP_SIMULATION if cheap else "") + extra
    path = Path(directory) / f"{name}.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def restart_starts(s):
    """(restart, id of its first proposal, its phase, whether its budget left was shorter than
    the mean of the phases before it) for every restart of a finished run."""
    h = s.history
    out = []
    for r in range(1, s.restart + 1):
        first = next(rec for rec in h if rec["restart"] == r)
        lengths = [sum(rec["restart"] == q for rec in h[: first["id"]]) for q in range(r)]
        out.append((r, first["id"], first["phase"],
                    s.budget - first["id"] < sum(lengths) / len(lengths)))
    return out
