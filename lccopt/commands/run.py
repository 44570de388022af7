"""``lccopt optimise CASE`` and ``lccopt resume RUN``: a run driven by the engine
(``lccopt.engine.runner``), which says its progress and its summary itself.

A run stopped by a signal raises :class:`lccopt.errors.RunInterrupted` once saved (its loop
has said where and how to carry it on): the command exits 130 with nothing more to say.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import typer

from ..errors import RunInterrupted

EXIT_INTERRUPTED = 130   # lccopt.cli's code for any interruption


def run_optimise(case: Path, overrides, workers: int | None, scheduler: str | None, runs: Path,
                 force: bool, budget: int | None = None) -> None:
    from ..config import load_case
    from ..engine.runner import optimise

    with _exit_when_interrupted():
        given = overrides or budget is not None
        optimise(load_case(case, overrides or (), budget=budget) if given else case,
                 workers=workers, scheduler=scheduler, runs=runs, force=force)


def run_resume(run: Path, workers: int | None, scheduler: str | None, case: Path | None,
               allow_changed_case: bool, budget: int | None, repair_journal: bool) -> None:
    from ..engine.runner import resume

    with _exit_when_interrupted():
        resume(run, workers=workers, scheduler=scheduler, case=case,
               allow_changed_case=allow_changed_case, budget=budget,
               repair_journal=repair_journal)


@contextlib.contextmanager
def _exit_when_interrupted():
    try:
        yield
    except RunInterrupted:
        raise typer.Exit(EXIT_INTERRUPTED) from None
