"""Shared helpers of the report tests: a cheap real case, CLI subprocesses, PNG checks."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "configs" / "reference.yaml"
FIGURES = ("search-history", "objective-space", "best-vs-reference", "contact-force",
           "sleeper-energy",
           "track-layout", "sensitivity")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

from tests.conftest import write_case  # noqa: E402,F401 (the cheap reference case, shared)


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
