"""The tree is ruff clean: lint and import order, with the rules in pyproject.toml [tool.ruff].

CI installs '.[test]' (which brings ruff) and runs pytest, so this test is the CI lint step.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_check_finds_nothing():
    result = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "lccopt", "tests", "benchmarks"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    exit_code, report = result.returncode, result.stdout + result.stderr
    assert exit_code == 0, f"ruff check found problems:\n{report}"
