"""The paper's single-objective cases with the optimisers a user would pick instead of lccopt.

    python -m benchmarks.paper.paper_others [--cases single-F_max,single-E_max] [--seeds 1-16]
        [--methods pysot,optuna-tpe,random] [--processes 2] [--out paper-others.csv]
        [--known single-F_max=4161.41 single-E_max=0.0069137]

Each method minimises the case's objective (configs/<case>.yaml: F_max in N or E_max in J,
200 evaluations) over the case's design space (a log-scaled variable as its logarithm), one
simulation at a time in-process, with the runners of benchmarks/optimiser/optimiser.py and their
defaults (pySOT 0.3.3 DYCORS with a cubic RBF and a 20-point symmetric Latin hypercube; Optuna
5's TPE sampler; uniform random search). Unlike
``lccopt optimise`` they do not get the reference design as a first point; it only sets the
regret ratio's scale. The results file keeps one row per run (case, method, seed,
evaluations, best value, seconds, commit), so the script can be stopped and started again
(``--out``, runs already there are kept). It prints,
per case and method, the best value per seed and the median and worst regret ratio
(f_seed - f_best) / (f_reference - f_best), with f_best from ``--known`` (the best-known values
of benchmarks/paper/paper_seeds.py, README "Many seeds") or the best of the runs if lower.
lccopt's own runs of the same cases come from benchmarks/paper/paper_seeds.py.
"""

from __future__ import annotations

import argparse
import csv
import functools
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

from benchmarks.optimiser import optimiser as bench  # noqa: E402  (the method runners of the broad benchmark)
from benchmarks.paper.paper_seeds import seeds_arg  # noqa: E402
from benchmarks.support.problems import TestFunction as BenchProblem  # noqa: E402
from benchmarks.support.runs_table import commit  # noqa: E402
from lccopt.config import load_case  # noqa: E402
from lccopt.optim.space import DesignSpace  # noqa: E402
from lccopt.problem import Problem, evaluate  # noqa: E402

OBJECTIVE = {"single-F_max": "F_max", "single-E_max": "E_max"}


def paper_problem(case: str) -> tuple[BenchProblem, np.ndarray, int]:
    """The case as a benchmark problem (no given points), its reference design and budget.

    Variables the case searches on a log scale (the pads of the bundled cases) are handed to
    every method as ln x, the same representation lccopt gets (for Optuna it is what
    ``log=True`` does); the design is mapped back, onto the bounds, before it is simulated.
    The Type II strip goes over as the paper's one range 0-120 (as their figures in
    benchmarks/RESULTS-paper.md were measured), not as lccopt's on/off switch."""
    model = load_case(ROOT / "configs" / f"{case}.yaml")
    p = Problem.from_case(model)
    key = OBJECTIVE[case]
    cased = p.space().without_switches()   # the case's bounds, integers, log scales
    space = DesignSpace(names=list(p.names), lower=list(cased.search_lb),
                        upper=list(cased.search_ub), integer=list(p.integer))

    def fun(X):
        X = cased.snap(cased.from_search(np.atleast_2d(np.asarray(X, dtype=float))))
        return np.array([evaluate(model, x).objectives[key] for x in X])

    return (BenchProblem(case, space, fun, float("nan"), np.full(p.dim, np.nan)),
            cased.to_search(np.array(p.reference)), p.budget)


@functools.cache
def runners(method: str) -> tuple[dict, dict]:
    """load_methods once per worker process (it smoke-tests each method)."""
    return bench.load_methods([method])


def one_run(task: tuple[str, str, int]) -> tuple[str, dict]:
    case, method, seed = task
    found, notes = runners(method)
    if method not in found:
        return f"{case}/{method}/{seed}", {"skipped": notes[method]}
    p, _, budget = paper_problem(case)
    t0 = time.monotonic()
    vals = found[method](p, budget, seed, "default")
    return f"{case}/{method}/{seed}", {"best": float(min(vals)), "evaluations": len(vals),
                                       "seconds": time.monotonic() - t0}


COLUMNS = ("case", "method", "seed", "evaluations", "best", "seconds", "commit")


def load(path: Path) -> dict:
    """The runs of a results file: {"case/method/seed": {"best", "evaluations", ...}}."""
    if not path.exists():
        return {}
    with open(path, newline="") as fh:
        return {f"{r['case']}/{r['method']}/{r['seed']}":
                {"best": float(r["best"]), "evaluations": int(r["evaluations"]),
                 "seconds": float(r["seconds"]), "commit": r["commit"]}
                for r in csv.DictReader(fh)}


def _case_method_seed(key: str) -> tuple[str, str, int]:
    """Sort key of a 'case/method/seed' run key: seeds in numeric order."""
    parts = key.split("/")
    return parts[0], parts[1], int(parts[2])


def save(path: Path, data: dict) -> None:
    tmp = path.with_suffix(".tmp")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(COLUMNS)
        for key in sorted(data, key=_case_method_seed):
            r = data[key]
            w.writerow(key.split("/") + [r["evaluations"], repr(r["best"]), round(r["seconds"], 1),
                                         r["commit"]])
    tmp.replace(path)   # a kill never leaves a half-written file


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="single-F_max,single-E_max")
    ap.add_argument("--seeds", default="1-16")
    ap.add_argument("--methods", default="pysot,optuna-tpe,random")
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--out", default="paper-others.csv")
    ap.add_argument("--known", nargs="*", default=[], metavar="CASE=VALUE")
    args = ap.parse_args(argv)
    seeds = seeds_arg(args.seeds)
    cases, methods = args.cases.split(","), args.methods.split(",")
    for case in cases:
        if case not in OBJECTIVE:
            sys.exit(f"--cases: unknown case {case!r} (known: {', '.join(OBJECTIVE)})")
    out = Path(args.out)
    data = load(out)
    todo = [(c, m, s) for c in cases for m in methods for s in seeds if f"{c}/{m}/{s}" not in data]
    made_by = commit()
    with ProcessPoolExecutor(args.processes) as pool:
        for key, rec in pool.map(one_run, todo):
            if "skipped" in rec:
                print(f"  {key}: {rec['skipped']}", file=sys.stderr, flush=True)
                continue
            data[key] = {**rec, "commit": made_by}
            save(out, data)
            print(f"  {key}: {rec['best']:.5g} ({rec['seconds']:.0f} s)", file=sys.stderr,
                  flush=True)
    known = {k: float(v) for k, _, v in (item.partition("=") for item in args.known)}
    print("| case | method | seeds | median seed | worst seed | median regret | worst regret |")
    print("|---|---|---|---|---|---|---|")
    for case in cases:
        p, ref_x, _ = paper_problem(case)
        f_ref = float(p(ref_x))
        best = {m: {s: data[f"{case}/{m}/{s}"]["best"] for s in seeds
                    if f"{case}/{m}/{s}" in data} for m in methods}
        f_best = min([known.get(case, np.inf)] + [v for b in best.values() for v in b.values()])
        for m in methods:
            if not best[m]:
                continue
            v = sorted(best[m].values())
            r = [(x - f_best) / (f_ref - f_best) for x in v]
            print(f"| {case} | {m} | {len(v)} | {statistics.median(v):.5g} | {v[-1]:.5g} "
                  f"| {statistics.median(r):.3f} | {r[-1]:.3f} |")
            regrets = " ".join(f"{(best[m][s] - f_best) / (f_ref - f_best):.3f}"
                               for s in sorted(best[m]))
            print(f"<!-- {case} {m} regret per seed: " + regrets + " -->")
        print(f"<!-- {case}: reference {f_ref:.5g}, best known {f_best:.5g} -->")


if __name__ == "__main__":
    main()
