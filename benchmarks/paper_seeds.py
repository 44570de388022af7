"""The paper's problem as an optimiser benchmark: many seeds of its three studies.

    python benchmarks/paper_seeds.py [--seeds 1-8] [--cases single-F_max,single-E_max,moo]
                                     [--workers 2] [--runs bench-runs/paper-seeds] [--long 0]
                                     [--out RESULTS.csv]

For each case (configs/<case>.yaml: single-F_max and single-E_max with 200 evaluations, moo
with 400) and each seed, runs ``lccopt optimise`` on a copy of the case with that seed into
``RUNS/<case>-s<seed>/`` (a finished run is reused, an unfinished one resumed, so the script
can be stopped and started again). ``--long N`` adds one run of each case with N evaluations
(seed 1000) that only serves to find a better best-known value; ``--known CASE=VALUE`` gives a
better value found elsewhere (benchmarks/paper_best_known.py re-evaluates the best designs of
any runs, e.g. of an earlier model or version, on the current model). ``--out`` writes one CSV
row per run (case, seed, budget, best value, regret ratio, the commit, the optimiser settings
the run recorded). The runs are lccopt's own: an experiment with the optimiser plugs into
``Strategy`` in an ask/tell loop of its own (benchmarks/variants.py, benchmarks/paper_composite.py).

Per case it prints the reference design's value, the best-known value (the best over all runs,
the long one included), the median and worst seed, and each seed's regret ratio
(f_seed - f_best) / (f_reference - f_best): 0 is the best known, 1 no better than the
reference design. The value is the objective itself for a single objective and the ASF of
Eq. (7) for moo (the case's fixed reference point and worst values, so values of different
runs compare).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def seeds_arg(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def run_one(case: str, seed: int, runs: Path, workers: int, budget: int | None = None) -> Path:
    """Optimise configs/CASE.yaml with SEED into RUNS/<name>; reuse or resume what is there."""
    name = f"{case}-s{seed}" + (f"-b{budget}" if budget else "")
    run = runs / name
    cases = runs / "cases"
    cases.mkdir(parents=True, exist_ok=True)
    text = (f"extends: {ROOT / 'configs' / (case + '.yaml')}\nname: {name}\n"
            f"optimisation:\n  seed: {seed}\n")
    if budget:
        text += f"  budget: {budget}\n"
    path = cases / f"{name}.yaml"
    path.write_text(text)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    exe = [sys.executable, "-m", "lccopt.cli"]
    if (run / "journal.jsonl").exists():
        cmd = exe + ["resume", str(run), "--workers", str(workers), "--case", str(path)]
    else:
        cmd = exe + ["optimise", str(path), "--runs", str(runs), "--workers", str(workers)]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    print(f"  {name}: {time.monotonic() - t0:.0f} s", file=sys.stderr)
    return run


def run_values(run: Path) -> dict:
    """Best value of the run, the reference design's value, and the best row's objectives."""
    with h5py.File(run / "results.h5", "r") as f:
        e = f["evaluations"]
        ok = e["status"].asstr()[()] == "ok"
        value = np.where(ok, e["value"][()], np.inf)
        i = int(np.argmin(value))
        ids = e["id"][()]
        ref_i = int(np.flatnonzero(ids == 0)[0])
        objectives = [str(k) for k in f.attrs["objectives"]] if "objectives" in f.attrs else []
        return {"best": float(value[i]), "reference": float(e["value"][ref_i]), "id": int(ids[i]),
                "objectives": {k: float(e[k][i]) for k in objectives if k in e},
                "n": int(f.attrs["n_evaluations"])}


def write_rows(path: str, runs: Path, rows: list, seeds: list[int], made_by: str | None) -> None:
    """One CSV row per run: case, seed, budget, best, regret ratio, commit, settings."""
    import csv
    import json

    sys.path.insert(0, str(ROOT))
    from benchmarks.runs_table import commit

    with open(path, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["case", "seed", "budget", "best", "regret", "reference", "best_known",
                    "commit", "settings"])
        for case, f_ref, f_best, _, _, _, _, regret, _ in rows:
            for s in seeds:
                run = runs / f"{case}-s{s}"
                first = json.loads((run / "journal.jsonl").open().readline())
                best = run_values(run)["best"]
                w.writerow([case, s, first["budget"], repr(best), f"{regret[s]:.6g}",
                            repr(f_ref), repr(f_best), made_by or commit(),
                            json.dumps(first.get("optimiser"), sort_keys=True,
                                       separators=(",", ":"))])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1-8")
    ap.add_argument("--cases", default="single-F_max,single-E_max,moo")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--runs", default="bench-runs/paper-seeds")
    ap.add_argument("--long", type=int, default=0,
                    help="budget of one extra long run per case (0: none)")
    ap.add_argument("--known", nargs="*", default=[], metavar="CASE=VALUE",
                    help="best-known values found elsewhere (benchmarks/paper_best_known.py)")
    ap.add_argument("--out", default=None, help="CSV file: one row per run")
    ap.add_argument("--commit", default=None,
                    help="the commit that made the runs, for --out (default: this checkout's)")
    args = ap.parse_args()
    known = {k: float(v) for k, _, v in (item.partition("=") for item in args.known)}
    runs = Path(args.runs)
    seeds = seeds_arg(args.seeds)
    rows = []
    for case in args.cases.split(","):
        results = {s: run_values(run_one(case, s, runs, args.workers)) for s in seeds}
        long = run_values(run_one(case, 1000, runs, args.workers, args.long)) if args.long else None
        f_ref = results[seeds[0]]["reference"]
        f_best = min([r["best"] for r in results.values()] + ([long["best"]] if long else [])
                     + ([known[case]] if case in known else []))
        regret = {s: (r["best"] - f_best) / (f_ref - f_best) for s, r in results.items()}
        vals = sorted(r["best"] for r in results.values())
        rows.append((case, f_ref, f_best, statistics.median(vals), vals[-1],
                     statistics.median(regret.values()), max(regret.values()), regret, long))
        print(f"\n{case}: per seed (best value, regret ratio, best evaluation)")
        for s, r in results.items():
            objs = ", ".join(f"{k} {v:.5g}" for k, v in r["objectives"].items())
            print(f"  seed {s}: {r['best']:.5g}  regret {regret[s]:.3f}  #{r['id']}  ({objs})")
        if long:
            print(f"  long run ({long['n']} evaluations, seed 1000): {long['best']:.5g}")
        if case in known:
            print(f"  known from elsewhere (--known): {known[case]:.5g}")
    if args.out:
        write_rows(args.out, runs, rows, seeds, args.commit)
    print("\n| case | reference | best known | median seed | worst seed | median regret "
          "| worst regret |")
    print("|---|---|---|---|---|---|---|")
    for case, f_ref, f_best, med, worst, mreg, wreg, _, _ in rows:
        print(f"| {case} | {f_ref:.5g} | {f_best:.5g} | {med:.5g} | {worst:.5g} | {mreg:.3f} "
              f"| {wreg:.3f} |")


if __name__ == "__main__":
    main()
