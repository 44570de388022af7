"""``lccopt status RUN``: where a run stands (``lccopt.engine.status``), safe while it runs."""

from __future__ import annotations

from pathlib import Path

import typer

from ..errors import UsageError


def run_status(run: Path) -> None:
    from ..engine.journal import JournalError
    from ..engine.rundir import RunError
    from ..engine.status import status_lines

    try:
        lines = status_lines(run)
    except (RunError, JournalError) as exc:
        raise UsageError(str(exc)) from None
    typer.echo("\n".join(lines))
