"""What proposals in blocks cost in quality: runs with k workers and blocks of q, paired
over seeds against one point per fit, at the same number of evaluations.

    python -m benchmarks.scale.scale_quality --suite fresh --seeds 101-108 --budget 300 \
        --configs 1:1 16:16 64:64 16:1 --out benchmarks/results/scale-fresh.csv
    python -m benchmarks.scale.scale_quality --suite paper --seeds 101-108 \
        --configs 1:1 16:16 64:64 16:1 --out benchmarks/results/scale-paper.csv
    python -m benchmarks.scale.scale_quality --report benchmarks/results/scale-fresh.csv ...

A run is lccopt's Strategy driven as the run engine drives it with k workers (``drive``:
the engine's schedule rule, lccopt/engine/schedule.py, with blocks of q points) in simulated
time: every evaluation takes the same time, so the workers finish in the order they started
and a run is a function of (problem, seed, k, q) alone. ``k:q`` = ``1:1`` is one evaluation
at a time; ``16:16`` and ``64:64`` what the engine does with 16 and 64 workers
(``schedule.batch_size``); ``16:1`` what it did with 16 workers before blocks (one point per
fit, each proposal seeing the results up to 16 back).

Suites: ``fresh``, the broad benchmark's eight families of 8-variable test functions, a
fresh instance per seed (benchmarks/support/problems.py FRESH; regret f_best - f_opt); ``paper``,
the paper's three cases (configs/single-F_max.yaml, single-E_max.yaml, moo.yaml, their
budgets) with the real simulator in this process (regret ratio (f - f_best_known) /
(f_reference - f_best_known), the best known of benchmarks/RESULTS-paper.md or better).
Rows are appended to ``--out`` as runs finish (runs already there are skipped), so the
script can be stopped and started again. ``--report`` prints the tables: per suite, problem
and config, the median regret over seeds, and against 1:1 (and a config with blocks against
the same workers with one point per fit, k:1) the seeds better / worse and the median of the
paired differences.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import csv  # noqa: E402
import dataclasses  # noqa: E402
import heapq  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

from lccopt.engine.schedule import may_ask, release  # noqa: E402

PAPER_CASES = ("single-F_max", "single-E_max", "moo")
# benchmarks/RESULTS-paper.md: (reference design's value, best known value)
PAPER_KNOWN = {"single-F_max": (7557.3, 4161.4), "single-E_max": (0.41251, 0.0052657),
               "moo": (0.59256, -0.37688)}
FIELDS = ["suite", "problem", "seed", "workers", "batch", "budget", "best", "regret", "seconds"]


def drive(strategy, evaluate, k: int, q: int, reference=None) -> None:
    """Run ``strategy`` to its budget as the engine does with k workers and blocks of q.

    ``evaluate(x) -> ("ok", value[, outputs]) or ("failed", reason)``. ``reference``, for a
    multi-objective case: called with the result of evaluation 0 (which runs alone) before
    any value is computed; it sets the strategy's aggregate."""
    strategy.set_batch(q)
    multi = reference is not None
    results: dict[int, tuple] = {}
    running: list[tuple[float, int, np.ndarray]] = []
    now, ahead, ref_done = 0.0, None, not multi

    def ask():
        if strategy.done or (multi and not ref_done and strategy.n_asked >= 1):
            return None
        if not may_ask(strategy, k, multi):
            return None
        props = strategy.ask(1)
        release(strategy, k, multi, results.get)
        return props[0] if props else None

    while True:
        while len(running) < k:
            p, ahead = (ahead, None) if ahead is not None else (ask(), None)
            if p is None:
                break
            heapq.heappush(running, (now + 1.0, p.id, p.x))
        if len(running) == k and ahead is None:
            ahead = ask()
        if not running:
            break
        now, i, x = heapq.heappop(running)
        if multi and i == 0:
            results[i] = reference(x)
            ref_done = True
        else:
            results[i] = evaluate(x)
        release(strategy, k, multi, results.get)


def run_fresh(family: str, seed: int, k: int, q: int, budget: int) -> tuple[float, float]:
    from benchmarks.support import problems
    from lccopt.optim.strategy import Strategy

    p = problems.fresh(family, seed)
    s = Strategy(p.space, budget=budget, n_initial=20, seed=seed)
    drive(s, lambda x: ("ok", float(p(x))), k, q)
    best = s.best[1]
    return best, best - p.f_opt


def run_paper(case_name: str, seed: int, k: int, q: int, budget: int | None) -> tuple[float, float]:
    from lccopt.config import load_case
    from lccopt.problem import Problem, evaluate

    case = load_case(ROOT / "configs" / f"{case_name}.yaml")
    pb = dataclasses.replace(Problem.from_case(case), seed=seed)
    s = pb.strategy(budget=budget or pb.budget)
    state = {"point": None}

    def simulate(x):
        ev = evaluate(case, x)
        obj = {key: float(v) for key, v in ev.objectives.items()}
        energy = (ev.histories or {}).get("sleeper_energy")
        return obj, None if energy is None else [float(v) for v in np.ravel(energy)]

    def plain(x):
        obj, parts = simulate(x)
        bad = pb.finite(obj)
        if bad is not None:
            return ("failed", bad)
        return ("ok", pb.value(obj, state["point"]), pb.outputs(obj, parts))

    def reference(x):
        obj, _ = simulate(x)
        state["point"] = pb.reference_point(obj)
        s.set_aggregate(pb.aggregate(state["point"]))
        return ("ok", pb.value(obj, state["point"]), pb.outputs(obj, None))

    drive(s, plain, k, q, reference if pb.multi else None)
    best = s.best[1]
    ref, known = PAPER_KNOWN[case_name]
    known = min(known, best)
    return best, (best - known) / (ref - known)


def seeds_arg(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def run(args) -> None:
    from benchmarks.support import problems

    out = Path(args.out)
    done = set()
    if out.exists():
        with out.open() as fh:
            done = {(r["suite"], r["problem"], int(r["seed"]), int(r["workers"]), int(r["batch"]))
                    for r in csv.DictReader(fh)}
    else:
        out.parent.mkdir(parents=True, exist_ok=True)
        with out.open("w", newline="") as fh:
            csv.DictWriter(fh, FIELDS).writeheader()
    names = args.problems or (PAPER_CASES if args.suite == "paper" else problems.FRESH)
    configs = [tuple(int(v) for v in c.split(":")) for c in args.configs]
    for k, q in configs:
        for name in names:
            for seed in seeds_arg(args.seeds):
                if (args.suite, name, seed, k, q) in done:
                    continue
                t0 = time.perf_counter()
                if args.suite == "paper":
                    best, regret = run_paper(name, seed, k, q, args.budget)
                else:
                    best, regret = run_fresh(name, seed, k, q, args.budget or 300)
                row = {"suite": args.suite, "problem": name, "seed": seed, "workers": k, "batch": q,
                       "budget": args.budget or "", "best": repr(best), "regret": repr(regret),
                       "seconds": f"{time.perf_counter() - t0:.1f}"}
                with out.open("a", newline="") as fh:
                    csv.DictWriter(fh, FIELDS).writerow(row)
                print(f"{name} seed {seed} k={k} q={q}: best {best:.6g}, regret {regret:.4g} "
                      f"({row['seconds']} s)", flush=True)


def report(paths: list[str]) -> None:
    rows = []
    for p in paths:
        with open(p) as fh:
            rows += list(csv.DictReader(fh))
    by: dict[tuple, dict[int, float]] = {}
    for r in rows:
        key = (r["suite"], r["problem"], int(r["workers"]), int(r["batch"]))
        by.setdefault(key, {})[int(r["seed"])] = float(r["regret"])
    for suite in sorted({k[0] for k in by}):
        probs = sorted({k[1] for k in by if k[0] == suite})
        configs = sorted({(k[2], k[3]) for k in by if k[0] == suite})
        print(f"\n{suite}: median regret over seeds; against 1:1, then (blocks) against k:1, "
              f"paired by seed: better / worse seeds, median paired difference")
        print("| problem | " + " | ".join(f"{k}:{q}" for k, q in configs) + " |")
        print("|---|" + "---|" * len(configs))
        for prob in probs + ["all (median of per-problem medians)"]:
            cells = []
            for k, q in configs:
                if prob.startswith("all"):
                    meds = [statistics.median(by[(suite, p, k, q)].values()) for p in probs
                            if (suite, p, k, q) in by]
                    cells.append(f"{statistics.median(meds):.4g}" if meds else "")
                    continue
                v = by.get((suite, prob, k, q))
                if not v:
                    cells.append("")
                    continue
                cell = f"{statistics.median(v.values()):.4g}"
                for base in [by.get((suite, prob, 1, 1)) if (k, q) != (1, 1) else None,
                             by.get((suite, prob, k, 1)) if q > 1 else None]:
                    common = sorted(set(v) & set(base or {}))
                    d = [v[s] - base[s] for s in common]
                    if d:
                        better, worse = sum(x < 0 for x in d), sum(x > 0 for x in d)
                        cell += f" ({better}/{worse}, {statistics.median(d):+.3g})"
                cells.append(cell)
            print(f"| {prob} | " + " | ".join(cells) + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--suite", choices=("fresh", "paper"), default="fresh")
    ap.add_argument("--problems", nargs="+")
    ap.add_argument("--seeds", default="101-108")
    ap.add_argument("--budget", type=int, default=None,
                    help="evaluations (fresh: 300; paper: the case's)")
    ap.add_argument("--configs", nargs="+", default=["1:1", "16:16", "64:64", "16:1"],
                    help="workers:batch pairs")
    ap.add_argument("--out", default="benchmarks/results/scale-quality.csv")
    ap.add_argument("--report", nargs="+", help="print the tables of these CSV files")
    args = ap.parse_args()
    if args.report:
        report(args.report)
    else:
        run(args)


if __name__ == "__main__":
    main()
