"""HDF5 files of single evaluations (used by ``lccopt simulate`` and the run engine).

One file holds one evaluation: ``/design`` (x with variable names as an attribute),
``/objectives`` (one attribute per objective, SI units), ``/histories/<name>`` and
``/info`` attributes. A file is built whole in memory (HDF5's core driver: HDF5 itself never
writes to the disk, so a full disk is an ordinary error of one ``write``), then written to a
temporary name and renamed (``folder.Folder.write``), so a file that exists is complete.

Where a file goes (``dest``) and where one is read from (``src``) is a path, or a
``(folder.Folder, name)`` pair: a file in a directory lccopt holds open (a run's evals/).
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np

from .folder import write_owned
from .safe_h5 import check_datasets, h5_open_owned, h5_read
from .safeio import UnsafeFile
from .uncertainty import statistics
from .vti.response import HISTORY_DOC, OBJECTIVE_UNITS, Evaluation

_images = 0


def h5_image(fill) -> bytes:
    """The bytes of a new HDF5 file that ``fill(f)`` writes (built in memory)."""
    global _images
    _images += 1
    with h5py.File(f"lccopt-image-{os.getpid()}-{_images}.h5", "w", driver="core",
                   backing_store=False) as f:
        fill(f)
        f.flush()
        return f.id.get_file_image()


def write_h5(dest, fill, durable: bool = True) -> Path:
    """Write the HDF5 file that ``fill(f)`` builds to ``dest`` whole or not at all (fsynced if
    ``durable``); return its path (for messages)."""
    return write_owned(dest, h5_image(fill), durable)


def write_evaluation(dest, evaluation: Evaluation, x, names, attrs: dict | None = None,
                     durable: bool = True) -> Path:
    """Write one evaluation atomically (no fsync unless ``durable``); return its path."""
    def fill(f):
        _write_design(f, x, names)
        _write_group(f, evaluation, attrs)

    return write_h5(dest, fill, durable)


def read_evaluation(src) -> tuple[np.ndarray, Evaluation]:
    """Read a file written by :func:`write_evaluation`; return (x, evaluation).

    Never through a link, never a FIFO, never a file that keeps data elsewhere
    (``lccopt.safeio``); the file is read through a descriptor, so another process's HDF5 lock
    on it does not stop a reader."""
    with h5_open_owned(src) as f:
        return h5_read(f["design"]), _read_group(f)


def has_time_histories(src) -> bool:
    """True if the file holds an evaluation's time histories (not only per-sleeper values)."""
    try:
        with h5_open_owned(src) as f:
            return "histories" in f and "contact_force" in f["histories"]
    except (OSError, ValueError, RuntimeError):
        return False


def evaluation_problem(src, i: int, x, run: str | None = None) -> str | None:
    """Why the file at ``src`` is not a complete evaluation ``i`` of design ``x`` (missing,
    damaged, a link, another evaluation's file put in its place, or, given the run's mark
    ``run``, another run's); None if it is."""
    try:
        with h5_open_owned(src) as f:
            if "objectives" not in f or "histories" not in f or "design" not in f:
                return "incomplete"
            if getattr(f["design"], "shape", None) != np.shape(x):  # read only a design's size
                return "holds another design"
            design = h5_read(f["design"])
            info = f["info"].attrs if "info" in f else {}
            stored = info.get("id")
            owner = info.get("run")
    except FileNotFoundError:
        return "missing"
    except UnsafeFile as exc:
        return f"refused: {exc.strerror}"
    except (OSError, ValueError, RuntimeError, KeyError) as exc:
        return f"unreadable ({type(exc).__name__})"
    if stored is not None and int(stored) != int(i):
        return f"holds evaluation #{int(stored)}"
    if run and owner is not None and str(owner) != run:
        return "belongs to another run"
    if np.shape(design) != np.shape(x) or not np.array_equal(design, np.asarray(x, dtype=float)):
        return "holds another design"
    return None


# Traffic conditions and realisations of the track (engine/conditions.py): one file per
# design holds every condition under /conditions/<name>/{objectives,histories,info} and, for a
# case with uncertainty:, every realisation r under /realisations/<r>/{objectives,histories,
# info} (its objectives combined over the conditions, the first condition's per-sleeper
# histories and info). The top level keeps the combined objectives (with each realisation's
# as F_max#r) and the first condition's histories and info on the track as drawn, so readers
# of one-simulation files read it too.

def merge_condition_files(dest, parts, names, weights, objectives: dict,
                          attrs: dict, durable: bool = True, realisations=()) -> Path:
    """Merge the per-condition files ``parts`` (in condition order; one file and no names for
    a case without conditions; paths or ``(Folder, name)``) into one file, atomically
    (``durable``: as ``write_evaluation``); ``realisations``: (objectives, first condition's
    file) of each realisation, in order."""
    def fill(f):
        for i, part in enumerate(parts):
            with h5_open_owned(part) as src:
                check_datasets(src)   # HDF5 copies them whole, unchecked by h5_read
                if i == 0:
                    for key in ("design", "histories", "info"):
                        src.copy(src[key], f, name=key)
                if names:
                    g = f.require_group("conditions").create_group(names[i])
                    for key in ("objectives", "histories", "info"):
                        src.copy(src[key], g, name=key)
        for r, (obj, part) in enumerate(realisations):
            g = f.require_group("realisations").create_group(str(r))
            with h5_open_owned(part) as src:
                check_datasets(src)
                for key in ("histories", "info"):
                    src.copy(src[key], g, name=key)
            _write_objectives(g.create_group("objectives"), obj)
        _write_objectives(f.create_group("objectives"), objectives)
        _set_attrs(f["info"], attrs)
        if names:
            _condition_attrs(f, names, weights)
        if realisations:
            f.attrs["realisations"] = len(realisations)

    return write_h5(dest, fill, durable)


def write_condition_evaluations(dest, evaluations, x, design_names, names, weights,
                                objectives: dict, attrs: dict, durable: bool = True,
                                realisations=(), against=None) -> Path:
    """Write the evaluations of one design under every condition (in order; one evaluation
    and no names for a case without conditions) as one file (``durable``: as
    ``write_evaluation``); ``realisations``: (objectives, first condition's evaluation) of
    each realisation, in order; ``against``: (x, objectives) of a second design on the same
    tracks, kept as group ``against`` (its design and objectives, no histories)."""
    def fill(f):
        _write_design(f, x, design_names)
        first = evaluations[0]
        _write_group(f, Evaluation(objectives, first.histories, first.info), attrs)
        if names:
            for ev, name in zip(evaluations, names):
                _write_group(f.require_group("conditions").create_group(name), ev)
            _condition_attrs(f, names, weights)
        for r, (obj, ev) in enumerate(realisations):
            _write_group(f.require_group("realisations").create_group(str(r)),
                         Evaluation(obj, ev.histories, ev.info))
        if realisations:
            f.attrs["realisations"] = len(realisations)
        if against is not None:
            g = f.create_group("against")
            _write_design(g, against[0], design_names)
            _write_objectives(g.create_group("objectives"), against[1])

    return write_h5(dest, fill, durable)


def read_conditions(src) -> dict[str, Evaluation]:
    """Every condition's evaluation of a merged file, in condition order ({} for a file of
    one simulation)."""
    with h5_open_owned(src) as f:
        if "conditions" not in f:
            return {}
        return {str(name): _read_group(f["conditions"][name]) for name in f.attrs["conditions"]}


def read_realisations(src) -> list[Evaluation]:
    """Every realisation's evaluation of a merged file, in order ([] for a file without):
    objectives combined over the conditions, the first condition's per-sleeper histories."""
    with h5_open_owned(src) as f:
        n = int(f.attrs.get("realisations", 0))
        return [_read_group(f["realisations"][str(r)]) for r in range(n)]


# -- one evaluation in an HDF5 group --------------------------------------------------------------

# Time histories (thousands of values) are compressed; a per-sleeper array (20-166 values) is
# stored as it is: a chunk and a zlib state of its own would cost more CPU than it saves bytes.
GZIP = {"compression": "gzip", "compression_opts": 4, "shuffle": True}
COMPRESS_FROM = 1024  # values


def _write_design(f, x, names) -> None:
    d = f.create_dataset("design", data=np.asarray(x, dtype=float))
    d.attrs["names"] = list(names)


def _write_group(g, evaluation: Evaluation, attrs: dict | None = None) -> None:
    """objectives (attributes, with units), histories (datasets) and info (attributes)."""
    _write_objectives(g.create_group("objectives"), evaluation.objectives)
    hist = g.create_group("histories")
    for k, v in evaluation.histories.items():
        v = np.asarray(v)
        packed = GZIP if v.size >= COMPRESS_FROM else {}
        ds = hist.create_dataset(k, data=v, **packed)
        if k in HISTORY_DOC:
            ds.attrs["description"] = HISTORY_DOC[k]
    _set_attrs(g.create_group("info"), {**evaluation.info, **(attrs or {})})


def _write_objectives(g, objectives: dict) -> None:
    for k, v in objectives.items():   # F_max, F_max@<condition>, F_max#<realisation>, q90(F_max)
        g.attrs[k] = v
        g.attrs[k + "_unit"] = stored_unit(k)


def stored_unit(k: str) -> str:
    """The unit an evaluation file writes beside objective ``k`` ("" when unknown)."""
    if statistics.parse(k) is not None and statistics.parse(k)[0] == "p_worse":
        return "-"
    return OBJECTIVE_UNITS.get(statistics.objective_of(k).split("@")[0], "")


def _set_attrs(g, attrs: dict) -> None:
    for k, v in attrs.items():
        g.attrs[k] = v


def _condition_attrs(f, names, weights) -> None:
    f.attrs["conditions"] = list(names)
    f.attrs["weights"] = np.asarray(weights, dtype=float)
    for i, (name, w) in enumerate(zip(names, weights)):
        f["conditions"][name].attrs["weight"], f["conditions"][name].attrs["index"] = float(w), i


def _read_group(g) -> Evaluation:
    objectives = {k: float(v) for k, v in g["objectives"].attrs.items() if not k.endswith("_unit")}
    histories = {k: h5_read(g["histories"][k]) for k in g["histories"]}
    info = {k: (v.item() if hasattr(v, "item") else v) for k, v in g["info"].attrs.items()}
    return Evaluation(objectives, histories, info)
