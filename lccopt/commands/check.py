"""``lccopt check CASE``: validate a case file (``lccopt.config``) and say what it resolved
(``lccopt.config.describe``), without simulating."""

from __future__ import annotations

from pathlib import Path

import typer


def run_check(case: Path, overrides) -> None:
    from ..config import load_case
    from ..config.describe import case_lines

    typer.echo("\n".join(case_lines(load_case(case, overrides), case)))
