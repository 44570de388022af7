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
        _write_histories(f.create_group("histories"), evaluation.histories)
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


# Traffic conditions (engine/conditions.py): one file per design holds every condition under
# /conditions/<name>/{objectives,histories,info}; the top level keeps the combined objectives
# and the first condition's histories and info, so readers of one-condition files read it too.

def _condition_attrs(f, names, weights, objectives: dict, attrs: dict) -> None:
    obj = f.require_group("objectives")
    for k, v in objectives.items():
        obj.attrs[k] = v
        obj.attrs[k + "_unit"] = OBJECTIVE_UNITS.get(k.split("@")[0], "")
    f.attrs["conditions"] = list(names)
    f.attrs["weights"] = np.asarray(weights, dtype=float)
    info = f.require_group("info")
    for k, v in attrs.items():
        info.attrs[k] = v


def merge_condition_files(path: str | Path, parts, names, weights, objectives: dict,
                          attrs: dict) -> Path:
    """Merge the per-condition files ``parts`` (in condition order) into one file, atomically."""
    path = Path(path)
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        for i, (part, name) in enumerate(zip(parts, names)):
            with h5py.File(part, "r") as src:
                if i == 0:
                    for key in ("design", "histories", "info"):
                        src.copy(src[key], f, name=key)
                g = f.require_group("conditions").create_group(name)
                for key in ("objectives", "histories", "info"):
                    src.copy(src[key], g, name=key)
                g.attrs["weight"], g.attrs["index"] = float(weights[i]), i
        _condition_attrs(f, names, weights, objectives, attrs)
    return path


def write_condition_evaluations(path: str | Path, evaluations, x, design_names, names, weights,
                                objectives: dict, attrs: dict) -> Path:
    """Write the evaluations of one design under every condition (in order) as one file."""
    path = Path(path)
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        for i, (ev, name) in enumerate(zip(evaluations, names)):
            groups = [f.require_group("conditions").create_group(name)]
            if i == 0:
                d = f.create_dataset("design", data=np.asarray(x, dtype=float))
                d.attrs["names"] = list(design_names)
                groups.append(f)
            for g in groups:
                if g is not f:
                    og = g.create_group("objectives")
                    for k, v in ev.objectives.items():
                        og.attrs[k] = v
                        og.attrs[k + "_unit"] = OBJECTIVE_UNITS.get(k, "")
                    g.attrs["weight"], g.attrs["index"] = float(weights[i]), i
                _write_histories(g.create_group("histories"), ev.histories)
                ig = g.create_group("info")
                for k, v in ev.info.items():
                    ig.attrs[k] = v
        _condition_attrs(f, names, weights, objectives, attrs)
    return path


def _write_histories(hist, histories: dict) -> None:
    for k, v in histories.items():
        ds = hist.create_dataset(k, data=np.asarray(v), compression="gzip", compression_opts=4,
                                 shuffle=True)
        if k in HISTORY_DOC:
            ds.attrs["description"] = HISTORY_DOC[k]


def read_conditions(path: str | Path) -> dict[str, Evaluation]:
    """Every condition's evaluation of a merged file, in condition order ({} for a file of
    one simulation)."""
    with h5py.File(path, "r") as f:
        if "conditions" not in f:
            return {}
        out = {}
        for name in f.attrs["conditions"]:
            g = f["conditions"][name]
            objectives = {k: float(v) for k, v in g["objectives"].attrs.items() if not k.endswith("_unit")}
            histories = {k: g["histories"][k][()] for k in g["histories"]}
            info = {k: (v.item() if hasattr(v, "item") else v) for k, v in g["info"].attrs.items()}
            out[str(name)] = Evaluation(objectives, histories, info)
    return out
