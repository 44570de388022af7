"""lccopt: level-crossing design optimisation with a vehicle-track interaction model.

The command line (``lccopt optimise CASE``) is the main way in; from Python (a notebook, a
script) the same jobs are::

    import lccopt
    case = lccopt.load_case("configs/quickstart.yaml")
    ev = lccopt.simulate(case)                        # the reference design, one simulation
    run = lccopt.optimise(case, workers=2)            # runs/quickstart/, as the command does
    lccopt.resume(run)                                # after an interruption

Nothing heavy is imported until a function is called (the command line sets the BLAS thread
count before numpy loads).
"""

from __future__ import annotations

from .version import __version__ as __version__

__all__ = ["load_case", "simulate", "optimise", "resume"]


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

    return load(path)


def simulate(case, design=None):
    """Simulate one design of a case (one simulation per traffic condition).

    Parameters
    ----------
    case : str, pathlib.Path or lccopt.config.Case
        the case, or its file.
    design : sequence of float, optional
        the design vector in the case's order and SI units (pad stiffness in N/m, spans and
        the strip in 0.1 m elements); default the case's reference design.

    Returns
    -------
    lccopt.vti.response.Evaluation or dict
        objectives (N, J), time histories and facts of the run; for a case with traffic
        conditions a dict {condition name: Evaluation}.

    Raises
    ------
    ValueError
        the design is not a valid design of the case.
    """
    from .problem import evaluate

    is_loaded = not isinstance(case, (str, bytes)) and hasattr(case, "variables")
    case = case if is_loaded else load_case(case)
    x = case.reference if design is None else design
    if case.conditions:
        return {c.name: evaluate(case.condition_case(i), x) for i, c in enumerate(case.conditions)}
    return evaluate(case, x)


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
    lccopt.errors.CaseError, lccopt.errors.UsageError
        a bad case, bad options, a run directory that exists or is in use.
    """
    from pathlib import Path

    from .engine.runner import optimise as run

    return run(case, workers=workers, scheduler=scheduler, runs=Path(runs), force=force,
               progress=progress)


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
    """
    from pathlib import Path

    from .engine.runner import resume as carry_on

    return carry_on(Path(run), workers=workers, scheduler=scheduler, budget=budget,
                    progress=progress)
