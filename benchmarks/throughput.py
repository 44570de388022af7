"""Throughput of the run engine against the number of local workers.

    python benchmarks/throughput.py                       # quickstart case, 40 evaluations, 1 and 2 workers
    python benchmarks/throughput.py --budget 60 --workers 1 2 4
    python benchmarks/throughput.py --cheap --workers 2 --repeat 3   # the tests' coarse simulation
    python benchmarks/throughput.py --conditions 1 2 6 --workers 1 2  # traffic conditions per design

For each worker count, runs the case (real simulator) into a temporary run directory and
reads the engine's own accounting from the journal's ``session`` line:

* wall: the ask/evaluate/tell loop (worker start-up excluded, printed apart);
* throughput = evaluations / wall, parallel efficiency = throughput(n) / (n * throughput(1));
* optimiser = time in ask/tell; bookkeeping = journal, state snapshots, results.h5, files
  written by the engine process; overhead = (optimiser + bookkeeping) / wall;
* mean simulation time per evaluation (measured in the worker);
* busy = total simulation time / (workers * wall): the share of worker time spent simulating
  (1 - busy is the time workers sat idle or were being handed their next point);
* held = worker time idle because the next proposal waited for an earlier evaluation still
  running (the cost of the reproducible order, lccopt/engine/schedule.py), share of
  workers * wall; nan for lccopt versions without the rule.

``--conditions`` gives every design that many traffic conditions (VIRM at speeds from 80 to
160 km/h, both directions; one task per design and condition) and reports designs and
simulations per second.

``--cheap`` uses the tests' coarse simulation settings (tests/conftest.py, ~0.1-0.2 s per
evaluation), where the engine's own costs and any waiting show most; ``--repeat`` runs each
worker count several times (interleaved) and prints every run and the median.
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


CHEAP = """\
simulation:
  time_step: 1.0e-3
  element_length: 0.1
  far_element_length: 0.1
  run_in: 3.0
  run_out: 1.0
"""  # as tests/conftest.py CHEAP_SIMULATION


def conditions_yaml(n: int) -> str:
    """n traffic conditions: the case's vehicle at speeds from 80 to 160 km/h, both directions."""
    if n <= 1:
        return ""
    speeds = np.linspace(80.0, 160.0, n) / 3.6
    return "conditions:\n" + "".join(
        f"  - {{name: c{i}, speed: {float(v)!r}, direction: {'enter' if i % 2 == 0 else 'leave'}}}\n"
        for i, v in enumerate(speeds))


def run_once(case: Path, budget: int, initial: int, workers: int, root: Path, cheap: bool = False,
             tag: str = "", conditions: int = 1) -> dict:
    from lccopt.engine.runner import optimise

    name = f"throughput-w{workers}-c{conditions}{tag}"
    path = root / f"{name}.yaml"
    # the worst over several conditions lies above the one-condition case's ASF worst values
    worst = "  asf:\n    worst: [50000.0, 5.0]\n" if conditions > 1 else ""
    path.write_text(f"extends: {case.resolve()}\nname: {name}\noptimisation:\n"
                    f"  budget: {budget}\n  initial_points: {initial}\n" + worst + (CHEAP if cheap else "")
                    + conditions_yaml(conditions), encoding="utf-8")
    t0 = time.perf_counter()
    run = optimise(path, workers=workers, runs=root / "runs", progress=False)
    total = time.perf_counter() - t0
    events = [json.loads(line) for line in (run / "journal.jsonl").read_text().splitlines()]
    session = next(e for e in events if e["event"] == "session")
    sims = [e["wall_time"] for e in events if e["event"] in ("evaluated", "failed")]
    return {"workers": workers, "conditions": conditions,
            "evaluations": session["evaluations"], "wall": session["wall_time"],
            "startup": total - session["wall_time"], "optimiser": session["optimiser_time"],
            "bookkeeping": session["bookkeeping_time"], "sim_mean": float(np.mean(sims)),
            "busy": float(np.sum(sims)) / (workers * session["wall_time"]),
            "held": session.get("held_time", float("nan")) / (workers * session["wall_time"])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", type=Path, default=REPO / "configs" / "quickstart.yaml")
    ap.add_argument("--budget", type=int, default=40)
    ap.add_argument("--initial", type=int, default=10)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--cheap", action="store_true", help="coarse simulation settings (as the tests)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per worker count (median reported)")
    ap.add_argument("--conditions", type=int, nargs="+", default=[1],
                    help="traffic conditions per design (one run per count)")
    args = ap.parse_args()
    keys = [(w, c) for c in args.conditions for w in args.workers]
    runs: dict[tuple, list[dict]] = {key: [] for key in keys}
    with tempfile.TemporaryDirectory(prefix="lccopt-throughput-") as tmp:
        for k in range(args.repeat):
            for w, c in keys:
                r = run_once(args.case, args.budget, args.initial, w, Path(tmp), args.cheap, f"-{k}", c)
                runs[(w, c)].append(r)
                print(f"workers {w}, conditions {c}: {r['evaluations']} designs in {r['wall']:.1f} s "
                      f"(+{r['startup']:.1f} s start-up and summary), simulations {r['sim_mean']:.3f} s "
                      f"mean per design, busy {r['busy']:.2f}, held {r['held']:.3f}", flush=True)
    rows = []
    for w, c in keys:
        rs = runs[(w, c)]
        thr = float(np.median([r["evaluations"] / r["wall"] for r in rs]))
        rows.append({"workers": w, "conditions": c, "thr": thr,
                     "busy": float(np.median([r["busy"] for r in rs])),
                     "held": float(np.median([r["held"] for r in rs])),
                     "optimiser": float(np.median([r["optimiser"] for r in rs])),
                     "bookkeeping": float(np.median([r["bookkeeping"] for r in rs])),
                     "wall": float(np.median([r["wall"] for r in rs]))})
    print(f"\ncase {args.case.name}{' (cheap simulation)' if args.cheap else ''}, budget {args.budget} "
          f"({args.initial} initial), median of {args.repeat}")
    print("conditions  workers  designs/s  simulations/s  efficiency  busy  held   optimiser[s]  "
          "bookkeeping[s]  overhead[% of wall]")
    for r in rows:
        one = next(q for q in rows if q["conditions"] == r["conditions"])  # first worker count
        eff = r["thr"] / (r["workers"] * one["thr"] / one["workers"])
        over = 100.0 * (r["optimiser"] + r["bookkeeping"]) / r["wall"]
        print(f"{r['conditions']:>10}  {r['workers']:>7}  {r['thr']:9.3f}  {r['thr'] * r['conditions']:13.3f}  "
              f"{eff:10.2f}  {r['busy']:4.2f}  {r['held']:5.3f}  {r['optimiser']:12.2f}  "
              f"{r['bookkeeping']:14.2f}  {over:19.1f}")


if __name__ == "__main__":
    main()
