"""Throughput of the run engine against the number of local workers.

    python benchmarks/throughput.py                       # quickstart case, 40 evaluations, 1 and 2 workers
    python benchmarks/throughput.py --budget 60 --workers 1 2 4

For each worker count, runs the case (real simulator) into a temporary run directory and
reads the engine's own accounting from the journal's ``session`` line:

* wall: the ask/evaluate/tell loop (worker start-up excluded, printed apart);
* throughput = evaluations / wall, parallel efficiency = throughput(n) / (n * throughput(1));
* optimiser = time in ask/tell; bookkeeping = journal, state snapshots, results.h5, files
  written by the engine process; overhead = (optimiser + bookkeeping) / wall;
* mean simulation time per evaluation (measured in the worker).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # as the lccopt command does (lccopt/cli.py)

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def run_once(case: Path, budget: int, initial: int, workers: int, root: Path) -> dict:
    from lccopt.engine.runner import optimise

    name = f"throughput-w{workers}"
    path = root / f"{name}.yaml"
    path.write_text(f"extends: {case.resolve()}\nname: {name}\noptimisation:\n"
                    f"  budget: {budget}\n  initial_points: {initial}\n", encoding="utf-8")
    t0 = time.perf_counter()
    run = optimise(path, workers=workers, runs=root / "runs", progress=False)
    total = time.perf_counter() - t0
    events = [json.loads(line) for line in (run / "journal.jsonl").read_text().splitlines()]
    session = next(e for e in events if e["event"] == "session")
    sims = [e["wall_time"] for e in events if e["event"] in ("evaluated", "failed")]
    return {"workers": workers, "evaluations": session["evaluations"], "wall": session["wall_time"],
            "startup": total - session["wall_time"], "optimiser": session["optimiser_time"],
            "bookkeeping": session["bookkeeping_time"], "sim_mean": float(np.mean(sims))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", type=Path, default=REPO / "configs" / "quickstart.yaml")
    ap.add_argument("--budget", type=int, default=40)
    ap.add_argument("--initial", type=int, default=10)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="lccopt-throughput-") as tmp:
        for w in args.workers:
            r = run_once(args.case, args.budget, args.initial, w, Path(tmp))
            rows.append(r)
            print(f"workers {w}: {r['evaluations']} evaluations in {r['wall']:.1f} s "
                  f"(+{r['startup']:.1f} s start-up and summary), simulation {r['sim_mean']:.3f} s mean", flush=True)
    base = rows[0]["evaluations"] / rows[0]["wall"] / rows[0]["workers"]
    print(f"\ncase {args.case.name}, budget {args.budget} ({args.initial} initial)")
    print("workers  evals/s  efficiency  optimiser[s]  bookkeeping[s]  overhead[% of wall]")
    for r in rows:
        thr = r["evaluations"] / r["wall"]
        eff = thr / (r["workers"] * base)
        over = 100.0 * (r["optimiser"] + r["bookkeeping"]) / r["wall"]
        print(f"{r['workers']:>7}  {thr:7.3f}  {eff:10.2f}  {r['optimiser']:12.2f}  {r['bookkeeping']:14.2f}  "
              f"{over:19.1f}")


if __name__ == "__main__":
    main()
