"""What runs in a worker: one evaluation of one design, and the local worker process loop.

The evaluator is named by a ``module:function`` string so that it can be sent to any
worker (a local process or a Dask worker) and imported there. The default is the
simulator, ``lccopt.problem:evaluate``.

Testing hook: the environment variable ``LCCOPT_EVALUATOR=module:function`` replaces the
simulator (tests point it at faulty evaluators that raise, return NaN, kill their process
or hang). The function takes ``(case, x)`` and returns a
:class:`lccopt.vti.response.Evaluation`.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import signal
import socket
import sys
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, Callable

from .. import machine  # no numpy at import
from ..fanout import die_with_parent, ignore_stop_signals

DEFAULT_EVALUATOR = "lccopt.problem:evaluate"
ENV_EVALUATOR = "LCCOPT_EVALUATOR"
# Imported by a local worker before it forks its first evaluation: what every evaluation
# needs (the evaluation file's writer, h5py; the simulator and its solvers). Imported in each
# forked child instead, they would cost ~0.2 s of CPU per evaluation (the import time of
# h5py and of the simulator's modules), more than the paper-case simulation itself.
PRELOAD = ("lccopt.store", "lccopt.vti.passage")


def choose_evaluator(evaluator: str | Callable | None = None) -> str | Callable:
    """The evaluator to use: the argument, else $LCCOPT_EVALUATOR, else the simulator."""
    if evaluator is not None:
        return evaluator
    return os.environ.get(ENV_EVALUATOR) or DEFAULT_EVALUATOR


def load_evaluator(evaluator: str | Callable) -> Callable:
    if callable(evaluator):
        return evaluator
    module, _, name = str(evaluator).partition(":")
    if not module or not name:
        raise ValueError(f"evaluator {evaluator!r}: expected 'module:function'")
    fn = getattr(importlib.import_module(module), name, None)
    if not callable(fn):
        raise ValueError(f"evaluator {evaluator!r}: {module} has no function {name}")
    return fn


@dataclass
class Task:
    """One evaluation to run: proposal id and design vector (plus file-writing details)."""
    id: int
    x: list[float]
    phase: str = ""
    restart: int = 0
    out_path: str | None = None  # local pool: the worker writes evals/NNNNNN.h5 itself
    condition: int = -1          # traffic condition (engine/conditions.py); -1: the case as it is
    histories: bool = True       # keep the time histories (else only the per-sleeper ones)
    realisation: int = -1        # realisation of the track (uncertainty:); -1: as drawn
    # (st_dev, st_ino) of the run's evals/: the worker writes there only if out_path's folder is
    # that directory (not if the run directory was moved or a link put in its place)
    out_dir_id: tuple | None = None
    probe: tuple | None = None   # Dask: (file name, content) the worker must find in that folder
    run: str = ""                # the run's mark (its first journal line's): recorded in the file


# Histories small enough to keep for every design (one value per sleeper, not per time step):
# the sleeper-energy profile, the track's layout, and a settlement prediction's (settlement_*).
PER_SLEEPER = ("sleeper_position", "sleeper_energy", "sleeper_strengthened",
               "entry_sleeper_position", "entry_pad_stiffness", "entry_strengthened")


def kept(ev, histories: bool):
    """The evaluation as it is stored: whole, or without its time histories."""
    if histories:
        return ev
    from ..vti.response import Evaluation

    per_sleeper = {k: v for k, v in (ev.histories or {}).items()
                   if k in PER_SLEEPER or k.startswith("settlement_")}
    return Evaluation(ev.objectives, per_sleeper, ev.info)


@dataclass
class Outcome:
    """What came back for a task: ``objectives`` (ok) or ``error`` (failed)."""
    id: int
    condition: int = -1           # the task's traffic condition
    realisation: int = -1         # and realisation of the track
    objectives: dict | None = None
    parts: list | None = None     # the zone sleepers' energies (composite surrogate of E_max)
    info: dict = field(default_factory=dict)
    evaluation: Any = None        # the whole Evaluation when the worker did not write the file
    file_written: bool = False
    error: str | None = None
    fault: str | None = None      # the machine refused to store the result (disk full, ...)
    wall_time: float = float("nan")
    worker: str = ""
    # The worker's floating-point entries (machine.py): on a Dask cluster each evaluation's
    # own machine, recorded in its file.
    machine: dict = field(default_factory=dict)

    @classmethod
    def of(cls, task: "Task", **fields) -> "Outcome":
        """The outcome of ``task`` (its id, traffic condition and realisation)."""
        return cls(task.id, condition=task.condition, realisation=task.realisation, **fields)


def run_task(case, task: Task, evaluator: Callable, worker: str) -> Outcome:
    """Evaluate one design (under one traffic condition, on one realisation of the track);
    never raises (an exception becomes a failed Outcome)."""
    import numpy as np

    t0 = time.perf_counter()
    try:
        one = case.part_case(task.condition, task.realisation)
        ev = evaluator(one, np.asarray(task.x, dtype=float))
        objectives = {k: float(v) for k, v in ev.objectives.items()}
        energy = (ev.histories or {}).get("sleeper_energy")
        parts = None if energy is None else [float(v) for v in np.ravel(energy)]
    except Exception as exc:  # noqa: BLE001 - every failure of a simulation is data
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" ({os.path.basename(tb[-1].filename)}:{tb[-1].lineno})" if tb else ""
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        return Outcome.of(task, error=f"{type(exc).__name__}: {msg}{where}"[:500],
                       wall_time=time.perf_counter() - t0, worker=worker)
    wall = time.perf_counter() - t0
    out = Outcome.of(task, objectives=objectives, parts=parts, info=_plain(ev.info), wall_time=wall,
                     worker=worker, machine=machine.describe())
    folder = _out_folder(task) if task.out_path else None
    if folder is not None:
        try:
            from ..store import write_evaluation

            attrs = {"id": task.id, "phase": task.phase, "restart": task.restart,
                     "worker": worker, "wall_time": wall, "condition": task.condition,
                     "realisation": task.realisation,
                     **({"run": task.run} if task.run else {}), **out.machine}
            write_evaluation((folder, os.path.basename(task.out_path)), kept(ev, task.histories),
                             task.x, case.names, attrs=attrs, durable=False)
            out.file_written = True
        except Exception as exc:  # noqa: BLE001
            from ..errors import describe_os_error, environment_errno

            if environment_errno(exc) is not None:  # not the design's fault: the run must stop
                out.objectives = None
                out.fault = describe_os_error(exc)
            else:
                out.objectives, out.error = None, f"could not write {task.out_path}: {exc}"
        finally:
            folder.close()
    else:
        out.evaluation = kept(ev, task.histories)
    return out


def _out_folder(task: Task):
    """The run's evals/ as this worker sees it at ``task.out_path``'s folder, held open; None
    (the evaluation goes back whole, for the lccopt process to write) if that path does not
    lead to the run's own directory: the run directory was moved or a link put in its place,
    or, on Dask, this worker does not see it."""
    from ..folder import Folder

    try:
        folder = Folder.open(os.path.dirname(task.out_path))
    except OSError:
        return None
    try:
        if task.probe is not None:
            name, content = task.probe
            if folder.read(name, 100).decode("ascii", "replace") != content:
                raise OSError("not the run's folder")
        elif task.out_dir_id is not None and folder.identity != tuple(task.out_dir_id):
            raise OSError("not the run's folder")
    except OSError:
        folder.close()
        return None
    return folder


def _plain(info: dict) -> dict:
    out = {}
    for k, v in (info or {}).items():
        if hasattr(v, "item") and getattr(v, "ndim", 1) == 0:
            v = v.item()
        if isinstance(v, (bool, int, float, str)):
            out[k] = v
    return out


def local_worker_main(fd: int, parent_pid: int, slot: int) -> None:
    """Loop of a local worker process (started by ``LocalPool`` with ``python -c``).

    Receives ("init", case, evaluator, sys.path) (the evaluator "module:function" or a
    callable), then Tasks; sends back ("ready", pid) and ("done", Outcome). Ignores the
    stopping signals (``errors.STOP_SIGNALS``: Ctrl-C, SIGTERM, SIGHUP, ..., sent to the whole
    process group by a terminal, Slurm or systemd: the parent decides what they mean, and an
    evaluation stopped with the run stays pending) and dies with its parent.

    Each task runs in a child forked from this process as it stands after start-up, so
    every evaluation starts from the same process state whatever ran before it: results
    do not depend on the history of the worker (numerical libraries can round differently
    with the memory layout), and a leak or a crash stays with one evaluation.
    """
    from multiprocessing.connection import Connection

    ignore_stop_signals()
    die_with_parent(parent_pid)
    conn = Connection(fd)
    try:
        _, case, evaluator, path = conn.recv()
    except (EOFError, OSError):
        return
    for p in path:
        if p not in sys.path:
            sys.path.append(p)
    name = f"{socket.gethostname()}:local-{slot}:pid{os.getpid()}"
    try:
        evaluator = load_evaluator(evaluator)
    except Exception as exc:  # noqa: BLE001
        with contextlib.suppress(OSError):  # the parent may be gone already
            conn.send(("fatal", f"cannot load the evaluator {evaluator!r}: {type(exc).__name__}: "
                                f"{exc}"))
        return
    machine.describe()  # once here, not in every forked child (it loads scipy.linalg)
    for module in PRELOAD:  # likewise: an import in a forked child dies with it
        try:
            importlib.import_module(module)
        except Exception:  # noqa: BLE001 - the evaluation that needs it reports the failure
            pass
    fork = hasattr(os, "fork")
    try:
        conn.send(("ready", os.getpid()))
    except OSError:  # the parent stopped (a signal) while this worker started: nothing to do
        return
    while True:
        if fork:
            me = os.getpid()
            try:
                pid = os.fork()
            except OSError as exc:  # no memory or processes left: the machine's fault, not
                # the design's (the run stops with the evaluation pending)
                with contextlib.suppress(OSError):
                    conn.send(("fault", f"cannot start an evaluation process: "
                                        f"{exc.strerror or exc}"))
                return
            if pid == 0:  # the child takes one task from the pipe and answers it
                code = 1
                try:
                    die_with_parent(me)
                    code = _serve_one(conn, case, evaluator, name)
                finally:
                    os._exit(code)
            _, status = os.waitpid(pid, 0)
            code = os.waitstatus_to_exitcode(status)
            if code == _STOP:  # stop message, or the pipe closed
                return
            if code != 0:      # the evaluation's process died: report it for the task
                try:
                    conn.send(("crashed", _death_reason(code), code < 0))
                except OSError:
                    return
        else:
            if _serve_one(conn, case, evaluator, name) == _STOP:
                return


_STOP = 213  # exit status of a task child that read the stop message (or found the pipe closed)


def _serve_one(conn, case, evaluator, name: str) -> int:
    try:
        task = conn.recv()
    except (EOFError, OSError):
        return _STOP
    if task is None:
        return _STOP
    out = run_task(case, task, evaluator, name)
    try:
        conn.send(("done", out))
    except OSError:
        return _STOP
    return 0


def _death_reason(exitcode) -> str:
    if exitcode is None:
        return "worker process died"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        return f"worker process died (killed by {name})"
    return f"worker process died (exit code {exitcode})"

