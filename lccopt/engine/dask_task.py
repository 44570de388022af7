"""What runs on a Dask worker (``--scheduler ADDRESS``): one evaluation, and how the worker
knows it sees the run directory.

A worker that sees the run directory (the same machine, or a shared file system: it finds in
the evals/ folder it opens the probe file the driver wrote, with its random content) writes
the evaluation file itself, through that folder held open, as a local worker does; any other
returns the whole evaluation and the driver writes it.
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path

from ..folder import Folder
from .worker import Outcome, Task, load_evaluator, run_task

_DASK_EVALUATORS: dict = {}


def dask_task(case, task: Task, evaluator, probe=None) -> Outcome:
    """Runs on a Dask worker: writes the evaluation file if it sees the run directory (finds
    the ``probe``, (path, content), in the folder of the evaluation file; checked for every
    task: worker.run_task), else returns the whole Evaluation for the parent to write."""
    try:
        from distributed import get_worker

        name = get_worker().address
    except Exception:  # noqa: BLE001
        name = "dask"
    if task.out_path is not None:
        if probe is None:
            task.out_path = None
        else:   # the folder's identity differs on another machine: the probe tells instead
            task.probe, task.out_dir_id = (os.path.basename(probe[0]), probe[1]), None
    key = evaluator if isinstance(evaluator, str) else id(evaluator)
    fn = _DASK_EVALUATORS.get(key)
    if fn is None:
        try:
            fn = _DASK_EVALUATORS[key] = load_evaluator(evaluator)
        except Exception as exc:  # noqa: BLE001
            return Outcome.of(task, worker=name,
                              error=f"cannot load the evaluator {evaluator!r} on {name}: {exc}")
    return run_task(case, task, fn, name)


def write_probe(directory: Path, identity=None):
    """(folder, (path, content)): a file of random content in the run's evals/ (named ``*.tmp``:
    a resume removes one left behind), by which a Dask worker knows it sees the run directory;
    (folder, None) if ``directory`` is not the run's evals/ (``identity``) any more."""
    folder = Folder.open(directory)
    if identity is not None and folder.identity != tuple(identity):
        return folder, None
    content = uuid.uuid4().hex
    name = f"dask-probe.{content[:8]}.tmp"
    fd = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644,
                 dir_fd=folder.fd)
    with os.fdopen(fd, "w", encoding="ascii") as fh:
        fh.write(content)
    return folder, (str(directory / name), content)
