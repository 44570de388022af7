"""benchmarks/optimiser/optimiser.py --quick runs end to end (lccopt and random only: no pySOT or
Optuna needed) and writes a well-formed table and CSV; --resume reuses the stored runs."""

import csv
import os
import subprocess
import sys

import pytest

# seconds a test: the benchmark scripts' runs
pytestmark = pytest.mark.slow

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = ["-m", "benchmarks.optimiser.optimiser"]


def _run(*args):
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, *SCRIPT, *args], capture_output=True, text=True,
                       timeout=120, env=env, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    return r.stdout


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_quick_benchmark_table_and_csv(tmp_path):
    out = tmp_path / "r.csv"
    text = _run("--quick", "--problems", "gear", "trap_int6", "--methods", "lccopt", "random",
                "--out", str(out))
    runs = _rows(out)
    assert len(runs) == 2 * 2 * 3  # problems x methods x seeds: one row per run
    assert list(runs[0])[:8] == ["problem", "method", "seed", "evaluations", "evaluated",
                                 "seconds", "commit", "settings"]
    for run in runs:
        assert run["problem"] in ("gear", "trap_int6") and run["method"] in ("lccopt", "random")
        assert run["evaluations"] == run["evaluated"] == "40" and run["settings"] == "default"
        assert len(run["commit"]) >= 7
        assert float(run["best_40"]) <= float(run["best_20"])  # best so far never gets worse
    # one table per budget, a row per problem, the summary with W/T/L
    for b in (20, 40):
        assert f"#### budget {b}" in text
    lines = text.splitlines()
    rows = [ln for ln in lines if ln.startswith(("| gear |", "| trap_int6 |"))]
    assert len(rows) == 4
    header = next(ln for ln in lines if ln.startswith("| problem |"))
    ncol = header.count("|")
    assert all(r.count("|") == ncol for r in rows)
    assert "| budget | cells | lccopt median <= best other median | wins | ties | losses |" in text
    summary = [ln for ln in text.splitlines() if ln.startswith("| 40 | 2 |")]
    assert len(summary) == 1
    w, t, l_ = (int(v) for v in summary[0].strip("| ").split(" | ")[3:6])
    assert w + t + l_ == 2
    # resume: nothing is run again, the same runs come back
    text2 = _run("--quick", "--problems", "gear", "trap_int6", "--methods", "lccopt", "random",
                 "--out", str(out), "--resume")
    assert "runs," not in text2  # no "# <problem> <method>: N runs" lines
    assert _rows(out) == runs


def _runs(path):
    return {(r["problem"], r["method"], r["seed"]): r for r in _rows(path)}


def _values(path):
    return {k: {c: v for c, v in r.items() if c.startswith("best_")}
            for k, r in _runs(path).items()}


def test_merge_gathers_parts_and_refuses_conflicts(tmp_path):
    a, b, out = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "all.csv"
    whole = tmp_path / "whole.csv"
    common = ("--quick", "--problems", "gear", "--methods", "lccopt", "random")
    _run(*common, "--seeds", "0-0", "--out", str(a))
    _run(*common, "--seeds", "1-1", "--out", str(b))
    _run(*common, "--seeds", "0-1", "--out", str(whole))
    text = _run(*common, "--merge", str(a), str(b), "--out", str(out))
    merged = _values(out)
    # the same runs as one process makes (deterministic)
    assert merged == _values(whole) and len(merged) == 2 * 2
    assert "| gear |" in text  # the tables of the merged file
    # merging again changes nothing
    _run(*common, "--merge", str(a), str(b), "--out", str(out))
    assert _values(out) == merged
    # a run of the same length with other values (other settings) is refused, out unchanged
    lines = b.read_text().splitlines()
    cells = lines[1].split(",")
    cells[-1] = repr(float(cells[-1]) - 1.0)
    b.write_text("\n".join([lines[0], ",".join(cells)] + lines[2:]) + "\n")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, *SCRIPT, *common, "--merge", str(b), "--out", str(out)],
                       capture_output=True, text=True, timeout=120, env=env, cwd=ROOT)
    assert r.returncode != 0 and "|".join(cells[:3]) in r.stderr and "differs" in r.stderr
    assert _values(out) == merged


def test_paper_others_hands_the_log_scaled_pads_over_as_logarithms():
    # The other tools get the representation lccopt gets: ln x for the pads, mapped back onto
    # the bounds before the simulation (a design on a pad bound must not fail the case check).
    import numpy as np

    from benchmarks.paper import paper_others

    p, ref, budget = paper_others.paper_problem("single-F_max")
    assert budget == 200
    np.testing.assert_allclose(p.space.lb[:3], np.log(50e6))
    np.testing.assert_allclose(p.space.ub[:3], np.log(1200e6))
    assert p.space.lb[3:].tolist() == [0, 3, 3, 3, 0]          # the integers as they are
    np.testing.assert_allclose(ref[:3], np.log(1120e6))
    assert abs(float(p(ref)) - 7557.26) < 0.01                # the reference design's F_max
    corner = np.r_[p.space.lb[:3], ref[3:]]   # every pad at 50 MN/m: exp(ln 50e6) < 50e6
    assert np.isfinite(float(p(corner)))


def test_criterion_noise_counts_cells_and_their_chances(tmp_path):
    """criterion_noise on runs where lccopt is below pySOT on every seed of one family and
    above on every seed of the other: P 1.00 and 0.00, 2 of 4 cells, a count of exactly 2 in
    every draw; a variant's lccopt rows are not the default's and are left out."""
    out = tmp_path / "runs.csv"
    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["problem", "method", "seed", "evaluations", "evaluated", "seconds",
                    "commit", "settings", "best_200", "best_400"])
        for s in range(10):
            w.writerow(["a", "lccopt", s, 400, 400, 1, "x", "default", 1 + s, 0.5 + s])
            w.writerow(["a", "pysot", s, 400, 400, 1, "", "default", 20 + s, 20 + s])
            w.writerow(["b", "lccopt", s, 400, 400, 1, "x", "default", 50 + s, 50 + s])
            w.writerow(["b", "pysot", s, 400, 400, 1, "", "default", 1 + s, 1 + s])
    r = subprocess.run([sys.executable, "-m", "benchmarks.optimiser.criterion_noise", str(out),
                        "--seeds", "0-9", "--draw", "5", "--resamples", "200"],
                       capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    rows = [line.split(" | ") for line in r.stdout.splitlines() if line.startswith("| a |")
            or line.startswith("| b |")]
    assert [(row[0], row[1], row[-1]) for row in rows] == [
        ("| a", "200", "1.00 |"), ("| a", "400", "1.00 |"),
        ("| b", "200", "0.00 |"), ("| b", "400", "0.00 |")]
    assert "cells at or below pySOT on all 10 seeds: 2 of 4" in r.stdout
    assert "median 2, 5-95 % 2-2" in r.stdout
    variant = tmp_path / "variant.csv"
    variant.write_text(out.read_text().replace(",x,default,", ",x,refine,"))
    r = subprocess.run([sys.executable, "-m", "benchmarks.optimiser.criterion_noise",
                        str(variant), "--seeds", "0-9"],
                       capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode != 0 and "no cell has a default lccopt" in r.stderr


def test_stalls_counts_which_kinds_of_point_improved_on_their_phase():
    """proposal_kinds: an improvement is judged against the best of the point's own phase so
    far (the step rule's tolerance); a local point keeps or leaves that best's integers."""
    import numpy as np

    from benchmarks.optimiser.stalls import proposal_kinds
    from lccopt.optim.space import DesignSpace

    space = DesignSpace(["u", "k"], [0.0, 0.0], [1.0, 5.0], [False, True])

    def rec(i, kind, restart, x, value):
        return {"id": i, "phase": kind, "restart": restart, "status": "ok",
                "x": np.array(x, dtype=float), "value": value}

    records = [rec(0, "initial", 0, [0.1, 1], 10.0), rec(1, "initial", 0, [0.2, 2], 8.0),
               rec(2, "local", 0, [0.3, 2], 7.0),       # own integers, improves
               rec(3, "local", 0, [0.3, 4], 7.0),       # other integers, no better than 7
               rec(4, "adaptive", 0, [0.4, 2], 7.0 - 7e-4),  # below 7 within the tolerance
               rec(5, "initial", 1, [0.9, 5], 20.0),    # a new phase: its own best
               rec(6, "local", 1, [0.8, 3], 19.0)]      # other than phase 1's best: improves
    c = proposal_kinds(records, space, first=10)
    assert (c["n initial"], c["won initial"]) == (3, 1)
    assert (c["n local"], c["won local"]) == (3, 2)
    assert (c["n local own"], c["won local own"]) == (1, 1)
    assert (c["n local other"], c["won local other"]) == (2, 1)
    assert (c["n adaptive"], c["won adaptive"]) == (1, 0)
    assert proposal_kinds(records, space, first=3)["n local"] == 1
