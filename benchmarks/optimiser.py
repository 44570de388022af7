"""Benchmark of lccopt's optimiser on mixed-integer problems of the paper's size.

Compares, at equal budgets of evaluations, the median (over seeds) best value found by

* lccopt     -- lccopt.optim.strategy.Strategy (MSRS/DYCORS + local surrogate search)
* pysot      -- pySOT 0.3.3 DYCORSStrategy with a cubic RBF + linear tail, 20-point
                symmetric LHS, 100*d candidates (its documented set-up), if it imports
* random     -- uniform random search (integer-aware)
* lhs        -- one Latin hypercube of the whole budget

and times lccopt's ``ask`` at 400 evaluated points in 8 dimensions.

    python benchmarks/optimiser.py                      # full: budgets 100 200 400, 10 seeds
    python benchmarks/optimiser.py --quick              # budget 100, 3 seeds, no pySOT
    python benchmarks/optimiser.py --budgets 100 --seeds 5 --problems ackley8 gear
    python benchmarks/optimiser.py --timing-only
"""

from __future__ import annotations

import argparse
import logging
import os
import statistics
import sys
import time
import warnings

# One BLAS thread: the matrices are small, and several busy-waiting BLAS threads per
# process make parallel runs on a small machine many times slower.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from lccopt.optim import problems  # noqa: E402
from lccopt.optim.sampling import latin_hypercube  # noqa: E402
from lccopt.optim.strategy import Strategy  # noqa: E402

DEFAULT_PROBLEMS = [f"{n}8" for n in problems.PAPER_SIZE] + ["gear", "nvs09"]


# -- methods: each returns the best value found in `budget` evaluations ---------------------
def run_lccopt(p: problems.Problem, budget: int, seed: int, settings: dict) -> float:
    s = Strategy(p.space, budget=budget, n_initial=20, seed=seed, **settings)
    while not s.done:
        props = s.ask(1)
        if not props:
            break
        for pr in props:
            s.tell(pr.id, p(pr.x))
    return s.best[1]


def run_random(p: problems.Problem, budget: int, seed: int, settings: dict) -> float:
    sp = p.space
    rng = np.random.default_rng(seed)
    lo = np.where(sp.int_mask, sp.lb - 0.5, sp.lb)
    hi = np.where(sp.int_mask, sp.ub + 0.5, sp.ub)
    X = sp.snap(lo + rng.random((budget, sp.dim)) * (hi - lo))
    return float(p(X).min())


def run_lhs(p: problems.Problem, budget: int, seed: int, settings: dict) -> float:
    X = latin_hypercube(p.space, budget, np.random.default_rng(seed))
    return float(p(X).min())


def _pysot_runner():
    """The pySOT DYCORS runner, or None with the reason if pySOT does not work here."""
    try:
        logging.getLogger("pySOT").setLevel(logging.ERROR)
        logging.getLogger("poap").setLevel(logging.ERROR)
        from poap.controller import SerialController
        from pySOT.experimental_design import SymmetricLatinHypercube
        from pySOT.optimization_problems import OptimizationProblem
        from pySOT.strategy import DYCORSStrategy
        from pySOT.surrogate import CubicKernel, LinearTail, RBFInterpolant
    except Exception as exc:  # any import failure just drops the column
        return None, f"{type(exc).__name__}: {exc}"

    class Wrapped(OptimizationProblem):
        def __init__(self, p):
            sp = p.space
            self.dim, self.lb, self.ub = sp.dim, sp.lb, sp.ub
            self.int_var = np.flatnonzero(sp.int_mask)
            self.cont_var = np.flatnonzero(~sp.int_mask)
            self.p = p

        def eval(self, x):
            return self.p(np.asarray(x, dtype=float))

    def run(p: problems.Problem, budget: int, seed: int, settings: dict) -> float:
        np.random.seed(seed)  # pySOT draws from numpy's global generator
        op = Wrapped(p)
        d = op.dim
        rbf = RBFInterpolant(dim=d, lb=op.lb, ub=op.ub, kernel=CubicKernel(), tail=LinearTail(d))
        slhd = SymmetricLatinHypercube(dim=d, num_pts=20)
        ctl = SerialController(objective=op.eval)
        ctl.strategy = DYCORSStrategy(max_evals=budget, opt_prob=op, asynchronous=False,
                                      exp_design=slhd, surrogate=rbf, num_cand=100 * d,
                                      batch_size=1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = ctl.run()
        return float(res.value)

    # Smoke test: pySOT 0.3.3 is old; fail here rather than in the middle of the table.
    try:
        run(problems.gear(), 25, 0, {})
    except Exception as exc:
        return None, f"{type(exc).__name__}: {exc}"
    return run, None


# -- timing -------------------------------------------------------------------------------------
def time_ask(n_points: int = 400, repeats: int = 30, seed: int = 0) -> dict:
    """Median wall time of ask(1) (fit + candidates + local search) at about n_points."""
    p = problems.paper_size("ackley")
    # No restarts, so that the surrogate really holds all n_points (the worst case).
    s = Strategy(p.space, budget=n_points + repeats + 1, seed=seed, sigma_min=0.0)
    while s.n_told < n_points:
        for pr in s.ask(1):
            s.tell(pr.id, p(pr.x))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        props = s.ask(1)
        times.append(time.perf_counter() - t0)
        for pr in props:
            s.tell(pr.id, p(pr.x))
    return {"n": n_points, "median_ms": 1e3 * statistics.median(times),
            "max_ms": 1e3 * max(times), "fitted": len(s._rbf.X)}


# -- main -----------------------------------------------------------------------------------------
def _fmt(v: float) -> str:
    return f"{v:.4g}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--budgets", type=int, nargs="+", default=[100, 200, 400])
    ap.add_argument("--seeds", type=int, default=10, help="number of seeds (0..n-1)")
    ap.add_argument("--problems", nargs="+", default=DEFAULT_PROBLEMS,
                    help=f"default: {' '.join(DEFAULT_PROBLEMS)}")
    ap.add_argument("--no-pysot", action="store_true", help="skip the pySOT comparison")
    ap.add_argument("--quick", action="store_true", help="budget 100, 3 seeds, no pySOT")
    ap.add_argument("--timing-only", action="store_true")
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                    help="override a Strategy setting, e.g. --set n_branches=0")
    args = ap.parse_args(argv)
    if args.quick:
        args.budgets, args.seeds, args.no_pysot = [100], 3, True
    settings = {k: eval(v, {}) for k, v in (kv.split("=", 1) for kv in args.set)}

    print(f"# numpy {np.__version__}; settings override: {settings or 'none'}", flush=True)
    if not args.timing_only:
        methods = {"lccopt": run_lccopt}
        pysot_note = "skipped (--no-pysot)"
        if not args.no_pysot:
            runner, why = _pysot_runner()
            if runner is None:
                pysot_note = f"unavailable: {why}"
            else:
                methods["pysot"] = runner
                pysot_note = "pySOT DYCORSStrategy"
        methods.update({"random": run_random, "lhs": run_lhs})
        print(f"# pySOT: {pysot_note}")
        print(f"# seeds 0..{args.seeds - 1}; median best value over seeds (gap = median - f*)\n")
        wins = total = 0
        for budget in args.budgets:
            cols = list(methods)
            print(f"## budget {budget}\n")
            print("| problem | f* | " + " | ".join(f"{m} median (gap)" for m in cols) + " |")
            print("|---|---|" + "---|" * len(cols))
            for name in args.problems:
                p = problems.get(name)
                med = {}
                t_used = {}
                for m, fn in methods.items():
                    t0 = time.perf_counter()
                    vals = [fn(p, budget, seed, settings) for seed in range(args.seeds)]
                    t_used[m] = time.perf_counter() - t0
                    med[m] = float(np.median(vals))
                cells = [f"{_fmt(med[m])} ({_fmt(med[m] - p.f_opt)})" for m in cols]
                if "pysot" in med:
                    total += 1
                    wins += med["lccopt"] <= med["pysot"]
                print(f"| {p.name} | {_fmt(p.f_opt)} | " + " | ".join(cells) + " |", flush=True)
                print(f"<!-- {p.name} b={budget} seconds: "
                      + ", ".join(f"{m} {t:.1f}" for m, t in t_used.items()) + " -->", flush=True)
            print()
        if total:
            print(f"lccopt median <= pySOT DYCORS median in {wins} of {total} problem/budget cells\n")
    t = time_ask()
    print(f"ask(1) at {t['n']} evaluated points ({t['fitted']} in the surrogate), 8-D: median {t['median_ms']:.1f} ms, "
          f"max {t['max_ms']:.1f} ms (goal < 50 ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
