"""benchmarks/paper/paper_seeds.py --report-only summarises finished runs as they are stored
(results.h5, journal.jsonl) and runs nothing: unfinished runs are left out, two folders compare
on the seeds finished in both against one best-known value, runs of different models are
refused, and rows of an earlier session's CSV stand in for run folders that are gone."""

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _run(folder: Path, seed: int, fs: list[float], budget: int = 4, wall: float = 10.0,
         shift: float = 0.0, optimiser: dict | None = None) -> None:
    """A stored single-F_max run: the reference design (id 0, F_max 100) and the designs
    x = (F_max, seed) (``shift`` moves the reference's objectives, as another model would)."""
    run = folder / f"single-F_max-s{seed}"
    run.mkdir(parents=True)
    values = np.array([100.0 + shift] + fs)
    n = len(values)
    x = np.array([[0.0, 0.0]] + [[v, float(seed)] for v in fs])
    with h5py.File(run / "results.h5", "w") as f:
        f.attrs.update(n_evaluations=n, budget=budget, n_pending=0,
                       objectives=["F_max"], objective_columns=["F_max"])
        e = f.create_group("evaluations")
        e["id"], e["x"], e["value"], e["F_max"] = np.arange(n), x, values, values
        e["status"] = np.array(["ok"] * n, dtype=h5py.string_dtype())
    events = [{"seq": 0, "event": "run", "budget": budget, "optimiser": optimiser or {}},
              {"seq": 1, "event": "session", "wall_time": wall}]
    (run / "journal.jsonl").write_text("".join(json.dumps(e) + "\n" for e in events))


def _report(tmp_path, *args):
    return subprocess.run([sys.executable, "-m", "benchmarks.paper.paper_seeds",
                           "--report-only", "--cases", "single-F_max", *args],
                          cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)},
                          capture_output=True, text=True, timeout=60)


def test_report_only_compares_finished_runs_side_by_side(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    _run(a, 1, [60.0, 50.0, 40.0], wall=30.0)   # best 40
    _run(a, 2, [80.0, 70.0, 60.0], wall=50.0)   # best 60
    _run(a, 3, [90.0], budget=4)                # unfinished: 2 of 4
    _run(b, 1, [30.0, 20.0, 50.0], wall=20.0)   # best 20: the best known
    _run(b, 2, [70.0, 60.0, 55.0], wall=40.0)
    _run(b, 3, [90.0, 80.0, 70.0])
    out = tmp_path / "rows.csv"
    p = _report(tmp_path, "--seeds", "1-3", "--runs", "a", "--against", "b", "--out", str(out))
    assert p.returncode == 0, p.stderr
    assert "single-F_max seed 3: no finished run in a; left out" in p.stderr
    # regret (best - 20) / (100 - 20): a 0.25, 0.5; b 0, 0.4375
    assert "| single-F_max | 2 | 20 | 0.375 / 0.500 | 0.219 / 0.438 | 40 / 30 |" in p.stdout
    rows = list(csv.DictReader(out.open()))
    assert [(r["seed"], float(r["regret"]), float(r["best_known"])) for r in rows] == [
        ("1", 0.25, 20.0), ("2", 0.5, 20.0)]
    assert not (tmp_path / "a" / "cases").exists()  # nothing was run


def test_report_only_refuses_runs_of_different_models(tmp_path):
    _run(tmp_path / "a", 1, [60.0, 50.0, 40.0])
    _run(tmp_path / "b", 1, [60.0, 50.0, 40.0], shift=1.0)  # the reference design differs
    p = _report(tmp_path, "--seeds", "1", "--runs", "a", "--against", "b")
    assert p.returncode != 0
    assert "the same design with other objectives" in p.stderr


def test_report_merges_an_earlier_sessions_rows_for_the_seeds_it_lacks(tmp_path):
    _run(tmp_path / "old", 1, [60.0, 50.0, 40.0], wall=30.0)   # best 40
    _run(tmp_path / "old", 2, [30.0, 25.0, 20.0], wall=50.0)   # best 20: the best known
    first = tmp_path / "first.csv"
    p = _report(tmp_path, "--seeds", "1-2", "--runs", "old", "--out", str(first))
    assert p.returncode == 0, p.stderr
    _run(tmp_path / "new", 2, [30.0, 25.0, 20.0], wall=40.0)   # seed 2 again: the same best
    _run(tmp_path / "new", 3, [70.0, 60.0, 60.0], wall=20.0)   # best 60
    out = tmp_path / "all.csv"
    p = _report(tmp_path, "--seeds", "1-3", "--runs", "new", "--merge", str(first),
                "--out", str(out))
    assert p.returncode == 0, p.stderr
    # regret (best - 20) / (100 - 20): seed 1 (from first.csv) 0.25, seed 2 0, seed 3 0.5
    assert "| single-F_max | 3 | 20 | 0.250 / 0.500 | 30 |" in p.stdout
    rows = list(csv.DictReader(out.open()))
    assert [(r["seed"], float(r["regret"]), r["wall_s"]) for r in rows] == [
        ("1", 0.25, "30"), ("2", 0.0, "40"), ("3", 0.5, "20")]


def test_report_refuses_earlier_rows_of_another_optimiser_or_result(tmp_path):
    _run(tmp_path / "old", 1, [60.0, 50.0, 40.0])
    first = tmp_path / "first.csv"
    assert _report(tmp_path, "--seeds", "1", "--runs", "old", "--out", str(first)).returncode == 0
    _run(tmp_path / "other", 2, [60.0, 50.0], budget=3, optimiser={"switches": False})
    p = _report(tmp_path, "--seeds", "1-2", "--runs", "other", "--merge", str(first))
    assert p.returncode != 0 and "other optimisers" in p.stderr
    _run(tmp_path / "again", 1, [60.0, 50.0, 45.0])   # seed 1 again, another best
    p = _report(tmp_path, "--seeds", "1", "--runs", "again", "--merge", str(first))
    assert p.returncode != 0 and "best 45.0 here, 40.0 in --merge" in p.stderr
