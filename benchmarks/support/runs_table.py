"""Result files of benchmarks/optimiser/optimiser.py: one row per run, as CSV.

Columns: ``problem, method, seed, evaluations`` (the run's planned length), ``evaluated``
(fewer only where a finite space ran out), ``seconds``, ``commit`` (the lccopt commit that
ran it, ``+`` if the tree had changes), ``settings`` (``default`` or the name of a variant of
benchmarks/optimiser/variants.py), then ``best_<b>``: the best value of the first b evaluations, for
each budget b the run was read at. Files of an earlier format (JSON with the best value every
10 evaluations; ``git show 48adb51:benchmarks/results/<name>.json``) are read too.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
from pathlib import Path

import numpy as np

FIXED = ("problem", "method", "seed", "evaluations", "evaluated", "seconds", "commit", "settings")
LEGACY_FORMAT = "lccopt-benchmark-optimiser/1"


def key(problem: str, method: str, seed: int) -> str:
    return f"{problem}|{method}|{seed}"


def commit() -> str:
    """The short hash of the checkout's HEAD, + if it has changes (or "unknown")."""
    root = Path(__file__).resolve().parents[2]
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, text=True,
                              capture_output=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "lccopt"], cwd=root,
                               text=True, capture_output=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+" if dirty else "")


def record(vals: list[float], n: int, seconds: float, budgets, settings: str) -> dict:
    """A run's row: the best value of its first b evaluations for each budget b (and n)."""
    best = np.minimum.accumulate(np.asarray(vals, dtype=float)) if vals else np.array([np.inf])
    marks = sorted({int(b) for b in budgets if b <= n} | {n})
    return {"n": n, "n_evaluated": len(vals), "seconds": round(seconds, 3), "commit": commit(),
            "settings": settings,
            "best_at": {str(b): float(best[min(b, len(best)) - 1]) for b in marks}}


def load(path) -> dict:
    """{"runs": {key: run}} of a CSV results file (or of the earlier JSON format); empty if
    the file does not exist."""
    if not path or not os.path.exists(path):
        return {"runs": {}}
    if str(path).endswith(".json"):
        with open(path) as fh:
            data = json.load(fh)
        if data.get("format") != LEGACY_FORMAT:
            raise SystemExit(f"{path}: not a results file of this benchmark "
                             f"({data.get('format')!r})")
        return {"runs": data["runs"]}
    runs = {}
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            best = {k[5:]: float(v) for k, v in row.items() if k.startswith("best_") and v != ""}
            runs[key(row["problem"], row["method"], int(row["seed"]))] = {
                "n": int(row["evaluations"]), "n_evaluated": int(row["evaluated"]),
                "seconds": float(row["seconds"]), "commit": row["commit"],
                "settings": row["settings"], "best_at": best}
    return {"runs": runs}


def save(path, data: dict) -> None:
    """Write the runs as CSV, sorted by problem, method and seed (atomically)."""
    if not path:
        return
    runs = data["runs"]
    marks = sorted({int(b) for r in runs.values() for b in r["best_at"]})
    tmp = f"{path}.tmp"
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(FIXED + tuple(f"best_{b}" for b in marks))
        order = sorted((k.split("|") for k in runs), key=lambda t: (t[0], t[1], int(t[2])))
        for problem, method, seed in order:
            r = runs[key(problem, method, int(seed))]
            w.writerow([problem, method, seed, r["n"], r["n_evaluated"], r["seconds"],
                        r.get("commit", ""), r.get("settings", "default")]
                       + [repr(r["best_at"][str(b)]) if str(b) in r["best_at"] else ""
                          for b in marks])
    os.replace(tmp, path)


def merge(data: dict, paths: list[str]) -> dict:
    """The runs of the files at ``paths`` added to ``data``: of two runs of the same problem,
    method and seed the longer one is kept; two of the same length must agree (else the files
    were made with different settings, and mixing them would be wrong)."""
    for path in paths:
        if not os.path.exists(path):
            raise SystemExit(f"{path}: no such results file")
        for k, run in load(path)["runs"].items():
            old = data["runs"].get(k)
            if old is not None and old["n"] == run["n"] and old["best_at"] != run["best_at"]:
                raise SystemExit(f"{path}: run {k} differs from the one already merged "
                                 "(different settings or versions?)")
            if old is None or run["n"] > old["n"]:
                data["runs"][k] = run
    return data


def best_at(run: dict, b: int) -> float | None:
    """The best value of the run's first b evaluations, None if the run does not say."""
    if run["n"] < b:
        return None
    if str(b) in run["best_at"]:
        return run["best_at"][str(b)]
    if run["n_evaluated"] < b:  # exhausted finite space: nothing more to find
        return run["best_at"][str(run["n"])]
    return None
