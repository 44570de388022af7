"""HDF5 files of single evaluations (used by ``lccopt simulate`` and the run engine).

One file holds one evaluation: ``/design`` (x with variable names as an attribute),
``/objectives`` (one attribute per objective, SI units), ``/histories/<name>`` and
``/info`` attributes. Files are written to a temporary name, fsynced and renamed, so a
file that exists is complete.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from .atomic import atomic_path
from .vti.response import HISTORY_DOC, OBJECTIVE_UNITS, Evaluation


def write_evaluation(path: str | Path, evaluation: Evaluation, x, names, attrs: dict | None = None) -> Path:
    """Write one evaluation atomically (tmp + fsync + rename); return the path."""
    path = Path(path)
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        d = f.create_dataset("design", data=np.asarray(x, dtype=float))
        d.attrs["names"] = list(names)
        obj = f.create_group("objectives")
        for k, v in evaluation.objectives.items():
            obj.attrs[k] = v
            obj.attrs[k + "_unit"] = OBJECTIVE_UNITS.get(k, "")
        hist = f.create_group("histories")
        for k, v in evaluation.histories.items():
            ds = hist.create_dataset(k, data=np.asarray(v), compression="gzip", compression_opts=4,
                                     shuffle=True)
            if k in HISTORY_DOC:
                ds.attrs["description"] = HISTORY_DOC[k]
        info = f.create_group("info")
        for k, v in {**evaluation.info, **(attrs or {})}.items():
            info.attrs[k] = v
    return path


def read_evaluation(path: str | Path) -> tuple[np.ndarray, Evaluation]:
    """Read a file written by :func:`write_evaluation`; return (x, evaluation)."""
    with h5py.File(path, "r") as f:
        x = f["design"][()]
        objectives = {k: float(v) for k, v in f["objectives"].attrs.items() if not k.endswith("_unit")}
        histories = {k: f["histories"][k][()] for k in f["histories"]}
        info = {k: (v.item() if hasattr(v, "item") else v) for k, v in f["info"].attrs.items()}
    return x, Evaluation(objectives, histories, info)
