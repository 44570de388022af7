"""results.h5: the table of a run's evaluations (layout in docs/runs.md, 'results.h5'), written
whole or not at all from the run as its journal describes it (``run.Run``).

:func:`columns` is that table in memory, one array per column: results.h5 is written from it,
and the report builds the same table from it when it reads the journal instead of the file.
"""

from __future__ import annotations

import json
import math

import numpy as np

from .run import Run
from .rundir import now_iso, sha256_text, versions

RESULTS_FORMAT = "lccopt-results"
RESULTS_VERSION = 1
OBJECTIVE_NAMES = ("F_rms", "F_max", "E_rms", "E_max")   # the paper's: always a column
STRING_COLUMNS = ("status", "reason", "phase", "worker", "file")


def objective_columns(rows: list[dict], objectives) -> list[str]:
    """The objective columns of results.h5's /evaluations.

    The paper's four, then the case's objectives, then every other objective an evaluation
    returned (e.g. a settlement prediction's, a robust statistic), in the order first met; a
    condition's own values (``F_max@name``) go to /conditions and a realisation's
    (``F_max#r``) to /realisations instead.

    Parameters
    ----------
    rows
        the table's finished rows (each with an ``objectives`` dict).
    objectives
        the case's objectives.

    Returns
    -------
    list of str
    """
    out = list(OBJECTIVE_NAMES)
    for k in [*objectives, *(k for r in rows for k in r["objectives"])]:
        if k not in out and (k in objectives or ("@" not in k and "#" not in k)):
            out.append(k)
    return out


def columns(rows: list[dict], d: int, objectives, conditions=(), realisations: int = 0) -> dict:
    """The table of the finished ``rows`` (``Run.done_rows``) as arrays, one per column.

    ``d``: values of a design; ``objectives``: the case's (the Pareto front is theirs);
    ``conditions``: the traffic conditions whose own objectives (``F_max@name``) get a table
    each (``cond_obj``); ``realisations``: the realisations of the track whose objectives
    (``F_max#r``) get an (evaluations, realisations) table each (``real_obj``)."""
    from ..optim.scalarise import pareto_mask
    from ..uncertainty.statistics import is_realisation_key, objective_of

    n = len(rows)

    def column(key: str) -> np.ndarray:
        return np.array([float(r["objectives"].get(key, math.nan)) for r in rows], dtype=float)

    obj = {k: column(k) for k in objective_columns(rows, objectives)}
    status = np.array([r["status"] for r in rows], dtype=object)
    F = np.column_stack([obj[k] for k in objectives]) if n else np.zeros((0, len(objectives)))
    F[status != "ok"] = math.nan
    bases = list(dict.fromkeys(objective_of(k) for r in rows for k in r["objectives"]
                               if is_realisation_key(k)))
    return {
        "ids": np.array([r["id"] for r in rows], dtype=np.int64),
        "x": np.array([r["x"] for r in rows], dtype=float).reshape(n, d), "obj": obj,
        "value": np.array([r["value"] for r in rows], dtype=float), "status": status,
        **{k: np.array([str(r[k]) for r in rows], dtype=object)
           for k in STRING_COLUMNS if k != "status"},
        "restart": np.array([r["restart"] for r in rows], dtype=np.int64),
        "wall_time": np.array([r["wall_time"] for r in rows], dtype=float),
        "pareto": pareto_mask(F) if n else np.zeros(0, dtype=bool),
        "cond_obj": {c: {k: column(f"{k}@{c}") for k in OBJECTIVE_NAMES} for c in conditions},
        "real_obj": {b: np.array([[float(r["objectives"].get(f"{b}#{j}", math.nan))
                                   for j in range(realisations)] for r in rows],
                                 dtype=float).reshape(n, realisations) for b in bases},
    }


def write_results(dest, run: Run, *, case, problem, meta: dict) -> None:
    """Write results.h5 (layout in docs/runs.md, 'results.h5') whole or not at all (``dest``: a
    path or ``(Folder, name)``, as ``store.write_h5``)."""
    import h5py

    from ..store import write_h5
    from ..vti.response import objective_unit
    from .journal import line_mark

    rows = run.done_rows()
    n = len(rows)
    sdt = h5py.string_dtype()
    realisations = int(getattr(problem, "realisations", 0) or 0)
    table = columns(rows, len(run.names), problem.objectives, problem.conditions, realisations)

    def fill(f):
        a = f.attrs
        a["format"], a["format_version"] = RESULTS_FORMAT, RESULTS_VERSION
        a["case_name"] = case.name
        a["objectives"] = list(problem.objectives)
        a["scalarisation"] = problem.scalarisation
        a["rho"], a["improvement"] = problem.rho, problem.improvement
        a["worst"] = np.array(problem.worst if problem.worst else [], dtype=float)
        a["budget"], a["seed"] = problem.budget, problem.seed
        a["initial_points"] = problem.initial_points
        a["n_evaluations"], a["n_failed"] = n, run.n_failed
        a["n_pending"] = len(run.pending_ids())
        a["finished"] = bool(run.finished)
        a["journal_seq"] = run.seq
        # which run and which state of it: a reader takes the table from the journal when
        # these do not match its lines (another run's results.h5 put in its place)
        a["run_mark"] = run.head_mark
        a["journal_mark"] = line_mark(run.last_event) if run.last_event else ""
        a["created"], a["updated"] = meta.get("created", ""), now_iso()
        _write_case(f, case, meta, sdt)
        _write_reference(f, run, problem)

        e = f.create_group("evaluations")
        e.attrs["names"] = list(run.names)
        e.create_dataset("id", data=table["ids"])
        x = e.create_dataset("x", data=table["x"])
        x.attrs["names"] = list(run.names)
        a["objective_columns"] = list(table["obj"])
        for k, values in table["obj"].items():
            e.create_dataset(k, data=values).attrs["unit"] = objective_unit(k)
        if problem.conditions:  # every condition's objectives
            a["conditions"] = list(problem.conditions)
            a["condition_weights"] = np.array(problem.weights, dtype=float)
            a["condition_mode"] = problem.condition_mode
            cg = f.create_group("conditions")  # rows as in /evaluations
            for c, w in zip(problem.conditions, problem.weights):
                g_c = cg.create_group(c)
                g_c.attrs["weight"] = w
                for k, values in table["cond_obj"][c].items():
                    g_c.create_dataset(k, data=values).attrs["unit"] = objective_unit(k)
        if realisations:  # every realisation's objectives: (n, R) each
            _write_realisations(f, table["real_obj"], realisations, meta)
        e.create_dataset("value", data=table["value"])
        for k in STRING_COLUMNS:
            e.create_dataset(k, data=[str(v) for v in table[k]], dtype=sdt)
        e.create_dataset("restart", data=table["restart"])
        e.create_dataset("wall_time", data=table["wall_time"]).attrs["unit"] = "s"
        e.create_dataset("pareto", data=table["pareto"])

        links = f.create_group("evals")  # external links: f["evals/000012/histories/contact_force"]
        for r in rows:
            if r["file"]:
                links[f"{r['id']:06d}"] = h5py.ExternalLink(r["file"], "/")

        g = f.create_group("best")
        best = run.best()
        if best is not None:
            g.attrs["id"], g.attrs["value"] = best["id"], best["value"]
            ds = g.create_dataset("x", data=np.array(best["x"], dtype=float))
            ds.attrs["names"] = list(run.names)
            for k, v in best["objectives"].items():
                g.attrs[k] = v

    write_h5(dest, fill)


def _write_case(f, case, meta: dict, sdt) -> None:
    """/case (the case as written and resolved) and /versions (now and at the run's start)."""
    g = f.create_group("case")
    g.create_dataset("text", data=case.text, dtype=sdt)
    g.create_dataset("resolved", data=case.resolved, dtype=sdt)
    g.attrs["sha256"] = sha256_text(case.resolved)
    g.attrs["file"] = meta.get("case_file", "")

    g = f.create_group("versions")
    for k, v in versions().items():
        g.attrs[k] = v
    g.attrs["run_started_with"] = json.dumps(meta.get("versions", {}))


def _write_reference(f, run: Run, problem) -> None:
    """/reference: the reference design, its objectives and the ASF's point and worst values."""
    g = f.create_group("reference")
    ds = g.create_dataset("x", data=np.array(problem.reference, dtype=float))
    ds.attrs["names"] = list(run.names)
    ref = run.reference or {}
    og = g.create_group("objectives")
    for k, v in (ref.get("objectives") or {}).items():
        og.attrs[k] = v
    if ref.get("point") is not None:
        g.create_dataset("point", data=np.array(ref["point"], dtype=float))
    if problem.worst:
        g.create_dataset("worst", data=np.array(problem.worst, dtype=float))


def _write_realisations(f, real_obj: dict, count: int, meta: dict) -> None:
    """/realisations: the run's realisations of the track (count, seed, fingerprint) and, for
    each objective recorded per realisation, an (evaluations, realisations) table in the rows
    of /evaluations."""
    from ..vti.response import objective_unit

    g = f.create_group("realisations")
    g.attrs["count"] = count
    g.attrs["seed"] = int(meta.get("realisations", {}).get("seed", -1))
    g.attrs["fingerprint"] = str(meta.get("realisations", {}).get("fingerprint", ""))
    for base, values in real_obj.items():
        g.create_dataset(base, data=values).attrs["unit"] = objective_unit(base)
