"""lccopt: level-crossing design optimisation with a vehicle-track interaction model.

The command line (``lccopt optimise CASE``) is the main way in; from Python (a notebook, a
script) the same jobs are::

    import lccopt
    case = lccopt.load_case("configs/quickstart.yaml")
    ev = lccopt.simulate(case)                        # the reference design, one simulation
    run = lccopt.optimise(case, workers=2)            # runs/quickstart/, as the command does
    lccopt.resume(run)                                # after an interruption
                                                      # (lccopt.RunInterrupted)

Nothing heavy is imported until a function is called (the command line sets the BLAS thread
count before numpy loads).
"""

from __future__ import annotations

from .errors import CaseError, EnvironmentFault, RunInterrupted, UsageError
from .version import __version__ as __version__

__all__ = ["load_case", "simulate", "optimise", "resume",
           "CaseError", "UsageError", "EnvironmentFault", "RunInterrupted"]


# -- the arguments' checks: a wrong type is a TypeError, a wrong value a ValueError, each naming
# the argument (never an error from deep inside, nor a value silently rounded)

def _path(value, name: str, what: str):
    import os

    if isinstance(value, bool) or not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"{name} must be {what} (str or pathlib.Path), not "
                        f"{type(value).__name__}")
    return value


def _case_arg(case):
    if not isinstance(case, (str, bytes)) and hasattr(case, "variables"):
        return case
    import os

    if isinstance(case, (str, os.PathLike)):
        return case
    hint = ": write the mapping to a YAML file" if isinstance(case, dict) else ""
    raise TypeError(f"case must be a case file (str or pathlib.Path) or a case from "
                    f"lccopt.load_case, not {type(case).__name__}{hint}")


def _count(value, name: str, least: int):
    """A whole number (an int or a numpy integer; never a float, a bool or a text)."""
    import operator

    if value is None:
        return None
    if isinstance(value, bool):
        raise TypeError(f"{name} must be a whole number, not {value!r}")
    try:
        n = operator.index(value)
    except TypeError:
        raise TypeError(f"{name} must be a whole number (int), not {type(value).__name__} "
                        f"{value!r}"[:120]) from None
    if n < least:
        raise ValueError(f"{name} must be at least {least}, not {n}")
    return n


def _flag(value, name: str) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"{name} must be True or False, not {type(value).__name__} {value!r}"[:120])
    return value


def _scheduler(value):
    if value is None or isinstance(value, str) or hasattr(value, "scheduler_address"):
        return value
    raise TypeError(f"scheduler must be a Dask scheduler address (str, e.g. "
                    f"'tcp://host:8786') or a Dask cluster, not {type(value).__name__}")


def load_case(path):
    """Read and validate a case file.

    Parameters
    ----------
    path : str or pathlib.Path
        the case file (YAML).

    Returns
    -------
    lccopt.config.Case
        the validated case, in SI units.

    Raises
    ------
    lccopt.errors.CaseError
        any problem of the file, as one line ``file:line: key.path: problem``.
    """
    from .config import load_case as load

    return load(_path(path, "path", "a case file"))


def simulate(case, design=None, realisation=None):
    """Simulate one design of a case (one simulation per traffic condition).

    Parameters
    ----------
    case : str, pathlib.Path or lccopt.config.Case
        the case, or its file.
    design : sequence of float, optional
        the design in the case's order (``case.names``) and the units people write it in,
        as ``--design`` and the case file's ``reference`` take it: pad stiffness in MN/m,
        spans and the Type II strip in m (multiples of 0.1 m), counts as they are; default
        the case's reference design.
    realisation : int, optional
        for a case with ``uncertainty:``, the realisation of the track to simulate the design
        on (0 to ``uncertainty.realisations`` - 1, the same tracks a run uses); default the
        track as drawn. (``lccopt simulate`` runs the drawing and every realisation.)

    Returns
    -------
    lccopt.vti.response.Evaluation or dict
        objectives (N, J), time histories and facts of the run; for a case with traffic
        conditions a dict {condition name: Evaluation}.

    Raises
    ------
    TypeError
        ``case`` or ``design`` of a wrong type.
    ValueError
        the design is not a valid design of the case, or the case has no such realisation.
    """
    import numpy as np

    from .config.case import from_user
    from .problem import evaluate

    case = _case_arg(case)
    case = case if hasattr(case, "variables") else load_case(case)
    if design is None:
        x = case.reference
    else:
        try:
            x = np.asarray(design, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"design must be a sequence of numbers, one per design variable "
                            f"({', '.join(case.names)}), not {design!r}"[:200]) from None
        try:
            x = from_user(case, x)
        except ValueError as exc:
            raise ValueError(f"design: {exc}") from None
    r = -1
    if realisation is not None:
        if isinstance(realisation, bool) or not isinstance(realisation, (int, np.integer)):
            raise TypeError(f"realisation must be a whole number, not {realisation!r}"[:200])
        if not 0 <= realisation < case.realisations:
            raise ValueError(f"realisation {realisation}: the case has "
                             + (f"realisations 0-{case.realisations - 1}" if case.realisations
                                else "no uncertainty: section, only the track as drawn"))
        r = int(realisation)
    if case.conditions:
        return {c.name: evaluate(case.part_case(i, r), x) for i, c in enumerate(case.conditions)}
    return evaluate(case.part_case(-1, r), x)


def optimise(case, *, workers=None, scheduler=None, runs="runs", force=False, progress=True):
    """Run the surrogate optimisation of a case, as ``lccopt optimise`` does.

    Parameters
    ----------
    case : str, pathlib.Path or lccopt.config.Case
        the case, with an ``optimisation`` section.
    workers : int, optional
        local worker processes (default: the number of cores).
    scheduler : str or distributed cluster, optional
        a Dask scheduler address (``tcp://host:8786``) or cluster object, instead of workers.
    runs : str or pathlib.Path
        the folder that holds run directories; the run goes to ``runs/<case name>/``.
    force : bool
        replace an lccopt run directory of the same name.
    progress : bool
        progress lines on stderr.

    Returns
    -------
    pathlib.Path
        the run directory (results.h5, journal, evaluation files).

    Raises
    ------
    TypeError, ValueError
        an argument of a wrong type or value (named).
    lccopt.errors.CaseError, lccopt.errors.UsageError
        a bad case, bad options, a run directory that exists or is in use.
    lccopt.errors.EnvironmentFault
        the machine refused a read or a write (disk full, read-only); nothing is lost.
    lccopt.errors.RunInterrupted
        the run was stopped by a signal (Ctrl-C, SIGTERM, ...) and saved: carry it on with
        :func:`resume` (a ``KeyboardInterrupt``; docs/runs.md, "From Python").
    """
    from pathlib import Path

    from .engine.runner import optimise as run

    return run(_case_arg(case), workers=_count(workers, "workers", 1),
               scheduler=_scheduler(scheduler),
               runs=Path(_path(runs, "runs", "the folder of run directories")),
               force=_flag(force, "force"), progress=_flag(progress, "progress"))


def resume(run, *, budget=None, workers=None, scheduler=None, progress=True):
    """Carry on an interrupted (or extended) run, as ``lccopt resume`` does.

    Parameters
    ----------
    run : str or pathlib.Path
        the run directory.
    budget : int, optional
        carry the run on to this many evaluations in all (a finished run too).
    workers, scheduler, progress
        as for :func:`optimise`.

    Returns
    -------
    pathlib.Path
        the run directory.

    Raises
    ------
    TypeError, ValueError
        an argument of a wrong type or value (named).
    lccopt.errors.UsageError
        not a run directory, a run in use, a budget below what the run asked.
    lccopt.errors.EnvironmentFault, lccopt.errors.RunInterrupted
        as for :func:`optimise`.
    """
    from pathlib import Path

    from .engine.runner import resume as carry_on

    return carry_on(Path(_path(run, "run", "a run directory")),
                    workers=_count(workers, "workers", 1), scheduler=_scheduler(scheduler),
                    budget=_count(budget, "budget", 2), progress=_flag(progress, "progress"))
