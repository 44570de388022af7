"""The run's evaluations as a table: results.h5 when it matches the journal, otherwise rebuilt
from the journal (both checked against size limits before anything is read), and the run's
case as the report loads it."""

from __future__ import annotations

import json
import math

import numpy as np

from ..safe_h5 import h5_open_owned, h5_read
from ..vti.response import PAPER_OBJECTIVES as OBJECTIVE_NAMES  # always a column


def _s(v) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


def load_run_case(rd, resolved_text: str | None):
    """The run's case (resolved copy, read through the run directory held open), or
    (None, why)."""
    from ..config import load_case
    from ..config.reading import MAX_CASE_FILE_BYTES, case_text
    from ..errors import CaseError

    why = "no case.yaml in the run directory"
    if rd.folder.is_file("case.yaml"):   # never a link planted in the run
        try:
            data = rd.folder.read("case.yaml", MAX_CASE_FILE_BYTES)
            return load_case(rd.case_path, text=case_text(data, rd.case_path)), ""
        except (CaseError, OSError) as exc:
            why = str(exc)
    if resolved_text:
        # e.g. an irregularity file relative to the original case: load without it
        import yaml

        try:
            data = yaml.safe_load(resolved_text)
            if isinstance(data, dict) and isinstance(data.get("simulation"), dict):
                data["simulation"].pop("irregularity", None)
            return load_case(rd.case_path, text=yaml.safe_dump(data, sort_keys=False)), ""
        except Exception as exc:  # noqa: BLE001 - a report without the case is still a report
            why = f"{why}; {exc}"
    return None, why


def results_match(res: dict, events: list[dict], line_mark, damaged: bool) -> bool:
    """Whether results.h5 (``res``) is this run's (its first journal line's mark) and reflects
    a state of it the journal holds (the mark of the line it says it reflects). Files written
    before results.h5 carried its identity are taken as they are."""
    if not res.get("run_mark"):
        return True
    if res["run_mark"] != line_mark(events[0]):
        return False
    seq = res["journal_seq"]
    if 0 <= seq < len(events):
        return res.get("journal_mark") == line_mark(events[seq])
    return damaged   # beyond the lines before a damaged one: cannot say otherwise


def read_results(src) -> dict:
    """Everything the report needs from results.h5, read at once into memory (``src``: a path
    or ``(Folder, name)``)."""

    with h5_open_owned(src, evals_links=True) as f:
        a = f.attrs
        e = f["evaluations"]
        _check_table(f, e)
        ids = h5_read(e["id"]).astype(int)
        n = len(ids)
        names = [_s(v) for v in e["x"].attrs.get("names", e.attrs.get("names", []))]
        strs = {k: np.array([_s(v) for v in h5_read(e[k])], dtype=object) if n else np.array(
            [], dtype=object) for k in ("status", "reason", "phase", "file")}
        ref = f["reference"]
        objectives = [_s(v) for v in a["objectives"]]
        columns = [_s(v) for v in a.get("objective_columns", OBJECTIVE_NAMES)]
        worst = np.asarray(a.get("worst", []), dtype=float)
        return {
            "name": _s(a.get("case_name", "")), "objectives": objectives,
            "scalarisation": _s(a.get("scalarisation", "single")),
            "budget": int(a.get("budget", n)),
            "names": names, "ids": ids, "x": h5_read(e["x"]).reshape(n, len(names)),
            "obj": {k: h5_read(e[k]).astype(float) for k in columns if k in e},
            "value": h5_read(e["value"]).astype(float), **strs,
            "restart": h5_read(e["restart"]).astype(int),
            "wall_time": h5_read(e["wall_time"]).astype(float),
            "pareto": h5_read(e["pareto"]).astype(bool) if "pareto" in e else np.zeros(n, bool),
            "ref_x": h5_read(ref["x"]).astype(float),
            "ref_objectives": ({k: float(v) for k, v in ref["objectives"].attrs.items()}
                               if "objectives" in ref else {}),
            "ref_point": h5_read(ref["point"]).astype(float) if "point" in ref else None,
            "worst": worst if worst.size else None, "rho": float(a.get("rho", math.nan)),
            "improvement": float(a.get("improvement", math.nan)),
            "n_pending": int(a.get("n_pending", 0)), "finished": bool(a.get("finished", False)),
            "journal_seq": int(a.get("journal_seq", -1)), "created": _s(a.get("created", "")),
            "run_mark": _s(a.get("run_mark", "")), "journal_mark": _s(a.get("journal_mark", "")),
            "updated": _s(a.get("updated", "")),
            "resolved": _s(h5_read(f["case/resolved"])) if "case/resolved" in f else None,
            "conditions": [_s(c) for c in a.get("conditions", [])],
            "cond_obj": {_s(c): {k: h5_read(f["conditions"][_s(c)][k]).astype(float)
                                 for k in OBJECTIVE_NAMES if k in f["conditions"][_s(c)]}
                         for c in a.get("conditions", []) if "conditions" in f},
            **_read_realisations(f),
        }


def _read_realisations(f) -> dict:
    """results.h5's /realisations: their count, record and each objective's (n, count) table."""
    if "realisations" not in f:
        return {}
    g = f["realisations"]
    return {"realisations": int(g.attrs.get("count", 0)),
            "real_record": {"seed": int(g.attrs.get("seed", -1)),
                            "fingerprint": _s(g.attrs.get("fingerprint", ""))},
            "real_obj": {k: h5_read(g[k]).astype(float) for k in g}}


MAX_ROWS = 1_000_000        # evaluations of a run: the budget is at most 100 000
MAX_COLUMNS = 10_000        # values per row of a table column (design variables)


def _check_table(f, e) -> None:
    """results.h5's tables have one row per evaluation, as many in every column, before any
    is read: a file that claims 10^11 rows (a few bytes of HDF5 can) is refused, not
    allocated (ValueError)."""
    import h5py

    rows = e["id"].shape
    if len(rows) != 1 or rows[0] > MAX_ROWS:
        raise ValueError(f"/evaluations/id has shape {rows}, not one row per evaluation "
                         f"(at most {MAX_ROWS})")
    groups = [e] + [g for g in f.get("conditions", {}).values() if isinstance(g, h5py.Group)]
    if isinstance(f.get("realisations"), h5py.Group):   # (evaluations, realisations) tables
        groups.append(f["realisations"])
    for g in groups:
        for name, d in g.items():
            if isinstance(d, h5py.Dataset) and (
                    not d.shape or d.shape[0] != rows[0] or d.size > rows[0] * MAX_COLUMNS):
                raise ValueError(f"{d.name} has shape {d.shape}, where the table has "
                                 f"{rows[0]} rows")
    for d in f.get("reference", {}).values():
        if isinstance(d, h5py.Dataset) and d.size > MAX_COLUMNS:
            raise ValueError(f"{d.name} has {d.size} values")


def table_from_journal(rd, run, res: dict | None) -> dict:
    """The same table as results.h5 (``engine.results.columns``), of the run its committed
    journal lines describe (``run``: an ``engine.run.Run``); ``res``: results.h5's table, if
    any, for what the journal does not hold (variable names, the resolved case)."""
    from ..engine.results import columns

    head = run.head
    objectives = list(head.get("objectives") or (res or {}).get("objectives") or ["F_max"])
    budget = int(run.budget or (res or {}).get("budget") or 0)
    d = run.dimension or len((res or {}).get("names", []))
    names = list((res or {}).get("names") or [])
    if len(names) != d:
        names = _names_from_case_yaml(rd) or [f"x{i + 1}" for i in range(d)]
    rows = run.done_rows()
    conditions = list(dict.fromkeys(k.split("@", 1)[1] for r in rows for k in r["objectives"]
                                    if "@" in k and "#" not in k and "(" not in k))
    count = int((head.get("realisations") or {}).get("count", 0))
    table = columns(rows, d, objectives, conditions, count)
    ref = run.reference or {}
    ref_x = np.asarray(ref.get("x") or (res or {}).get("ref_x") if (ref.get("x") or res) else
                       (rows[0]["x"] if rows and rows[0]["id"] == 0 else [math.nan] * d),
                       dtype=float)
    worst = ref.get("worst") or ((res or {}).get("worst"))
    return {
        "name": (res or {}).get("name") or _case_name(rd), "objectives": objectives,
        "scalarisation": "asf" if len(objectives) > 1 else "single",
        "budget": budget, "names": names,
        **{k: table[k] for k in ("ids", "x", "obj", "value", "status", "reason", "phase",
                                 "restart", "file", "wall_time", "pareto")},
        "ref_x": ref_x, "ref_objectives": dict(ref.get("objectives") or {}),
        "ref_point": np.asarray(ref["point"], float) if ref.get("point") is not None else None,
        "worst": np.asarray(worst, float) if worst is not None else None,
        "rho": float(ref.get("rho", math.nan) or math.nan),
        "improvement": float(ref.get("improvement", math.nan) or math.nan),
        "n_pending": len(run.pending_ids()), "finished": run.finished,
        "created": head.get("time", ""),
        "updated": (run.last_event or {}).get("time", ""),
        "resolved": (res or {}).get("resolved"), "conditions": conditions,
        "cond_obj": table["cond_obj"], "realisations": count, "real_obj": table["real_obj"],
        "real_record": head.get("realisations"),
    }


def _names_from_case_yaml(rd) -> list[str] | None:
    case, _ = load_run_case(rd, None)
    return None if case is None else case.names


def _case_name(rd) -> str:
    try:
        meta = json.loads(rd.read_text("run.json", 1_000_000))
        return str(meta.get("name", rd.path.name))
    except (OSError, ValueError, AttributeError):
        return rd.path.name
