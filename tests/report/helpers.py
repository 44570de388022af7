"""Shared helpers of the report tests: a cheap real case, CLI subprocesses, PNG checks."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "configs" / "reference.yaml"
FIGURES = ("search-history", "objective-space", "best-vs-reference", "contact-force", "sleeper-energy",
           "track-layout", "sensitivity")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

# The reference case on a coarse mesh with a short run-in: ~0.3 s per simulation.
CHEAP = """\
simulation:
  time_step: 1.0e-3
  element_length: 0.1
  far_element_length: 0.1
  run_in: 3.0
  run_out: 1.0
"""


def write_case(directory: Path, name: str, objectives=("F_max", "E_max"), budget: int = 12,
               initial: int = 5, seed: int = 1) -> Path:
    lines = [f"extends: {REFERENCE}", f"name: {name}", "optimisation:",
             f"  objectives: [{', '.join(objectives)}]", f"  budget: {budget}",
             f"  initial_points: {initial}", f"  seed: {seed}", "  timeout: 120"]
    if len(objectives) > 1:
        lines += ["  asf:", "    worst: [60000.0, 5.0]"]
    path = Path(directory) / f"{name}.yaml"
    path.write_text("\n".join(lines) + "\n" + CHEAP, encoding="utf-8")
    return path


def lccopt(*args, env: dict | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    e = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""),
         "MPLBACKEND": "Agg", **(env or {})}
    return subprocess.run([sys.executable, "-m", "lccopt.cli", *map(str, args)], env=e, cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) of a PNG file; AssertionError if it is not one."""
    data = Path(path).read_bytes()
    assert data[:8] == PNG_MAGIC, f"{path} is not a PNG"
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])
