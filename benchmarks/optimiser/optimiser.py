"""Benchmark of lccopt's optimiser against pySOT, Optuna and random search.

Methods (all sequential: one evaluation at a time, each sees every earlier result):

* lccopt      -- lccopt.optim.strategy.Strategy (MSRS/DYCORS + local surrogate search),
                 20-point initial design, its defaults (or, with --variant, an experiment
                 of benchmarks/optimiser/variants.py plugged into it)
* pysot       -- pySOT 0.3.3 DYCORSStrategy with a cubic RBF + linear tail, 20-point
                 symmetric LHS, 100*d candidates (its documented set-up)
* optuna-tpe  -- Optuna 5's default sampler (TPESampler, default arguments), integers as
                 suggest_int, continuous variables as suggest_float
* optuna-gp   -- Optuna 5's GPSampler (default arguments; needs torch)
* random      -- uniform random search (integer-aware)

Problems (benchmarks/support/problems.py): BENCHMARK, 22 fixed problems with known optima (tuned on
for a dozen rounds), and FRESH (--fresh), eight families of 8-variable problems whose
instance is drawn from the seed (which variables are integer, their ranges, the optimum's
place, a rotation): each seed is a problem nobody tuned on.

Budgets: ONE run of max(budgets) evaluations per (problem, method, seed); the value at a
smaller budget b is the best of its first b evaluations (best so far). This is valid for
sequential methods, but it is the anytime performance of a run planned for max(budgets):
lccopt's and pySOT's DYCORS perturbation probability shrinks with the planned budget, so a run
given a budget of 100 from the start would not propose exactly the same points.

Per cell (problem, budget): median and interquartile range [q25, q75] over seeds per method;
lccopt against the best other method (lowest median in that cell) and against each method:
two-sided Mann-Whitney U (scipy.stats.mannwhitneyu) at alpha 0.05 on the per-seed values --
win or loss when significant (direction by the U statistic), tie otherwise; and lccopt
median <= the other median.

    python -m benchmarks.optimiser.optimiser --out r.csv  # everything (hours)
    python -m benchmarks.optimiser.optimiser --quick --problems gear ackley8 --out q.csv
    python -m benchmarks.optimiser.optimiser --fresh --methods lccopt pysot optuna-tpe --seeds \
        100-111 \
        --out benchmarks/results/optimiser-fresh.csv                    # held-out instances
    python -m benchmarks.optimiser.optimiser --methods optuna-gp --seeds 5 --resume --out r.csv
    python -m benchmarks.optimiser.optimiser --report-only --out r.csv  # tables from the file
    # parts run side by side
    python -m benchmarks.optimiser.optimiser --merge a.csv b.csv --out r.csv
    python -m benchmarks.optimiser.optimiser --timing  # lccopt ask(1) time only

--out is a CSV file with one row per run (benchmarks/support/runs_table.py: problem, method, seed,
the commit, the variant, the best value at each budget). With --resume, runs already in it
(same problem, method, seed, at least as many evaluations) are reused, so a long benchmark can
be run in parts; the tables always cover every stored run of the selected problems and
methods. Parts run at the same time must write to files of their own (each rewrites its --out
whole); --merge then gathers them into --out.
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

from benchmarks.optimiser import variants  # noqa: E402
from benchmarks.support import problems, runs_table  # noqa: E402
from benchmarks.support.runs_table import best_at  # noqa: E402
from lccopt.optim.strategy import Strategy  # noqa: E402

METHODS = ("lccopt", "pysot", "optuna-tpe", "optuna-gp", "random")
ALPHA = 0.05


# -- methods: each returns the values of its n evaluations, in order ----------------------------
def run_lccopt(p: problems.TestFunction, n: int, seed: int, variant: str) -> list[float]:
    s = Strategy(p.space, budget=n, n_initial=20, seed=seed, **variants.strategy_kwargs(variant))
    vals = []
    while not s.done:
        props = s.ask(1)
        if not props:
            break
        for pr in props:
            v = p(pr.x)
            s.tell(pr.id, v)
            vals.append(v)
    return vals  # shorter than n only if a finite space was exhausted


def run_random(p: problems.TestFunction, n: int, seed: int, variant: str) -> list[float]:
    sp = p.space
    rng = np.random.default_rng(seed)
    lo = np.where(sp.int_mask, sp.lb - 0.5, sp.lb)
    hi = np.where(sp.int_mask, sp.ub + 0.5, sp.ub)
    X = sp.snap(lo + rng.random((n, sp.dim)) * (hi - lo))
    return [float(v) for v in p(X)]


def _pysot_runner():
    """The pySOT DYCORS runner, or (None, reason) if pySOT does not work here."""
    try:
        logging.getLogger("pySOT").setLevel(logging.ERROR)
        logging.getLogger("poap").setLevel(logging.ERROR)
        from poap.controller import SerialController
        from pySOT.experimental_design import SymmetricLatinHypercube
        from pySOT.optimization_problems import OptimizationProblem
        from pySOT.strategy import DYCORSStrategy
        from pySOT.surrogate import CubicKernel, LinearTail, RBFInterpolant
    except Exception as exc:  # any import failure just drops the method
        return None, f"{type(exc).__name__}: {exc}"

    class Wrapped(OptimizationProblem):
        def __init__(self, p):
            sp = p.space
            self.dim, self.lb, self.ub = sp.dim, sp.lb, sp.ub
            self.int_var = np.flatnonzero(sp.int_mask)
            self.cont_var = np.flatnonzero(~sp.int_mask)
            self.p = p
            self.values = []

        def eval(self, x):
            v = self.p(np.asarray(x, dtype=float))
            self.values.append(v)
            return v

    def run(p: problems.TestFunction, n: int, seed: int, variant: str) -> list[float]:
        np.random.seed(seed)  # pySOT draws from numpy's global generator
        op = Wrapped(p)
        d = op.dim
        rbf = RBFInterpolant(dim=d, lb=op.lb, ub=op.ub, kernel=CubicKernel(), tail=LinearTail(d))
        ctl = SerialController(objective=op.eval)
        # pySOT rejects a design whose rounded points do not fit the linear tail ("No valid
        # design found, increase num_pts?"), e.g. 20 points on {-1, 0, 1}^12: then, and only
        # then, a larger symmetric LHS.
        for num_pts in (20, 2 * (d + 1), 4 * (d + 1)):
            try:
                slhd = SymmetricLatinHypercube(dim=d, num_pts=num_pts)
                ctl.strategy = DYCORSStrategy(max_evals=n, opt_prob=op, asynchronous=False,
                                              exp_design=slhd, surrogate=rbf,
                                              num_cand=100 * d, batch_size=1)
                break
            except ValueError as exc:
                if "No valid design" not in str(exc) or num_pts == 4 * (d + 1):
                    raise
        run.design[p.name] = num_pts
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ctl.run()
        return op.values[:n]

    run.design = {}
    try:  # smoke test: fail here rather than in the middle of the benchmark
        run(problems.gear(), 25, 0, {})
    except Exception as exc:
        return None, f"{type(exc).__name__}: {exc}"
    return run, None


def _optuna_runner(kind: str):
    """Optuna's TPE (its default sampler) or GP sampler, or (None, reason)."""
    try:
        import optuna
        optuna.logging.set_verbosity(optuna.logging.ERROR)
        if kind == "gp":
            import torch  # noqa: F401  (GPSampler needs it; fail here, not mid-run)
            torch.set_num_threads(1)
    except Exception as exc:
        return None, f"{type(exc).__name__}: {exc}"

    def run(p: problems.TestFunction, n: int, seed: int, variant: str) -> list[float]:
        sp = p.space
        names, lb, ub, im = sp.names, sp.lb, sp.ub, sp.int_mask
        sampler = (optuna.samplers.TPESampler(seed=seed) if kind == "tpe"
                   else optuna.samplers.GPSampler(seed=seed))
        vals = []

        def objective(trial):
            x = np.array([trial.suggest_int(nm, int(lo), int(hi)) if m
                          else trial.suggest_float(nm, lo, hi)
                          for nm, lo, hi, m in zip(names, lb, ub, im)], dtype=float)
            v = p(x)
            vals.append(v)
            return v

        study = optuna.create_study(direction="minimize", sampler=sampler)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            study.optimize(objective, n_trials=n)
        return vals

    try:
        run(problems.gear(), 12, 0, {})
    except Exception as exc:
        return None, f"{type(exc).__name__}: {exc}"
    return run, None


def load_methods(wanted: list[str]) -> tuple[dict, dict]:
    """Runners of the wanted methods that work here, and a note for each one that does not."""
    runners, notes = {}, {}
    for m in wanted:
        if m == "lccopt":
            runners[m] = run_lccopt
        elif m == "random":
            runners[m] = run_random
        else:
            fn, why = (_pysot_runner() if m == "pysot"
                       else _optuna_runner("tpe" if m == "optuna-tpe" else "gp"))
            if fn is None:
                notes[m] = f"skipped: {why}"
                print(f"# {m}: skipped ({why})", flush=True)
            else:
                runners[m] = fn
    return runners, notes


# -- statistics ---------------------------------------------------------------------------------
def quartiles(v) -> tuple[float, float, float]:
    q25, q50, q75 = np.percentile(np.asarray(v, dtype=float), [25, 50, 75])
    return float(q50), float(q25), float(q75)


def compare(a, b) -> tuple[str, float]:
    """'win'/'tie'/'loss' of sample a (lower is better) against b, and the p value."""
    from scipy.stats import mannwhitneyu
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if np.array_equal(np.unique(a), np.unique(b)) and len(np.unique(a)) == 1:
        return "tie", 1.0  # every value the same on both sides
    res = mannwhitneyu(a, b, alternative="two-sided")
    p = float(res.pvalue)
    if not p < ALPHA:
        return "tie", p
    # U of a counts pairs with a > b (ties half): large U means a is worse (larger).
    return ("loss" if res.statistic > len(a) * len(b) / 2 else "win"), p


def cells(data: dict, probs: list[str], methods: list[str], budgets: list[int]) -> list[dict]:
    out = []
    for name in probs:
        for b in budgets:
            samples = {}
            for m in methods:
                v = [best_at(r, b) for k, r in data["runs"].items()
                     if k.startswith(f"{name}|{m}|")]
                v = [x for x in v if x is not None]
                if v:
                    samples[m] = v
            cell = {"problem": name, "budget": b, "samples": samples,
                    "stats": {m: quartiles(v) for m, v in samples.items()}}
            others = [m for m in samples if m != "lccopt"]
            if "lccopt" in samples and others:
                best = min(others, key=lambda m: cell["stats"][m][0])
                res, p = compare(samples["lccopt"], samples[best])
                cell.update(best_other=best, result=res, p=p,
                            criterion=cell["stats"]["lccopt"][0] <= cell["stats"][best][0])
                cell["each"] = {m: (compare(samples["lccopt"], samples[m])[0],
                                    cell["stats"]["lccopt"][0] <= cell["stats"][m][0])
                                for m in others}
            out.append(cell)
    return out


# -- report -------------------------------------------------------------------------------------
def _fmt(v: float) -> str:
    if v == 0:
        return "0"
    return f"{v:.3g}" if 1e-3 <= abs(v) < 1e5 else f"{v:.2e}"


def report(data: dict, probs: list[str], methods: list[str], budgets: list[int]) -> str:
    cs = cells(data, probs, methods, budgets)
    lines = []
    present = [m for m in methods if any(m in c["samples"] for c in cs)]
    for b in budgets:
        lines += [f"#### budget {b}", "",
                  "Median [q25, q75] of the best value over seeds (n = seeds). `vs` = the best "
                  "other method (lowest median); `test` = lccopt against it, Mann-Whitney U, "
                  f"two-sided, alpha {ALPHA}; `<=` = lccopt median <= best other median.", "",
                  "| problem | kind | f* | " + " | ".join(present) + " | vs | test (p) | <= |",
                  "|---|---|---|" + "---|" * len(present) + "---|---|---|"]
        for c in (c for c in cs if c["budget"] == b):
            p = problems.get(c["problem"])
            row = [c["problem"], p.category, _fmt(p.f_opt)]
            for m in present:
                if m in c["stats"]:
                    q50, q25, q75 = c["stats"][m]
                    row.append(f"{_fmt(q50)} [{_fmt(q25)}, {_fmt(q75)}] n={len(c['samples'][m])}")
                else:
                    row.append("-")
            if "result" in c:
                row += [c["best_other"], f"{c['result']} ({c['p']:.2g})",
                        "yes" if c["criterion"] else "no"]
            else:
                row += ["-", "-", "-"]
            lines.append("| " + " | ".join(row) + " |")
        lines.append("")
    lines += ["#### summary", "",
              "| budget | cells | lccopt median <= best other median | wins | ties | losses |",
              "|---|---|---|---|---|---|"]
    for b in budgets:
        bc = [c for c in cs if c["budget"] == b and "result" in c]
        if not bc:
            continue
        n_ok = sum(c["criterion"] for c in bc)
        w, t, l_ = (sum(c["result"] == r for c in bc) for r in ("win", "tie", "loss"))
        share = f"{n_ok} ({100 * n_ok / len(bc):.0f} %)"
        lines.append(f"| {b} | {len(bc)} | {share} | {w} | {t} | {l_} |")
    lines += ["", "By kind of problem (all budgets): cells with lccopt median <= best other "
              "median; W/T/L", "",
              "| kind | cells | <= | W/T/L |", "|---|---|---|---|"]
    for cat in problems.CATEGORIES:
        bc = [c for c in cs if "result" in c and problems.get(c["problem"]).category == cat]
        if bc:
            w, t, l_ = (sum(c["result"] == r for c in bc) for r in ("win", "tie", "loss"))
            n_ok = sum(c["criterion"] for c in bc)
            lines.append(f"| {cat} | {len(bc)} | {n_ok} | {w}/{t}/{l_} |")
    lines += ["", "lccopt against each method (all budgets): cells with lccopt median <= its "
              "median; W/T/L by Mann-Whitney", "", "| method | budget | cells | <= | W/T/L |",
              "|---|---|---|---|---|"]
    for m in (m for m in present if m != "lccopt"):
        for b in budgets:
            bc = [c["each"][m] for c in cs if c["budget"] == b and m in c.get("each", {})]
            if bc:
                w, t, l_ = (sum(r == x for r, _ in bc) for x in ("win", "tie", "loss"))
                n_ok = sum(le for _, le in bc)
                lines.append(f"| {m} | {b} | {len(bc)} | {n_ok} | {w}/{t}/{l_} |")
    lines += ["", "Best other method per cell: " + ", ".join(
        f"{m} {sum(c.get('best_other') == m for c in cs)}" for m in present if m != "lccopt"), ""]
    secs = {m: [r["seconds"] for k, r in data["runs"].items()
                if k.split("|")[1] == m and k.split("|")[0] in probs] for m in present}
    lines.append("Mean wall time per run (s): " + ", ".join(
        f"{m} {statistics.mean(v):.1f} ({len(v)} runs)" for m, v in secs.items() if v))
    return "\n".join(lines) + "\n"


# -- timing -------------------------------------------------------------------------------------
def time_ask(n_points: int = 400, repeats: int = 30, seed: int = 0) -> dict:
    """Median wall time of ask(1) (fit + candidates + local search) at about n_points."""
    p = problems.paper_size("ackley")
    # The scalar surrogate fits every point of the run, restarts or not (the worst case).
    s = Strategy(p.space, budget=n_points + repeats + 1, seed=seed)
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
            "max_ms": 1e3 * max(times), "fitted": len(s._scalar.rbf.X)}


# -- main -----------------------------------------------------------------------------------------
def _seeds(spec: list[str]) -> list[int]:
    """'20' -> 0..19; '10-19' -> 10..19; several items are joined."""
    out = []
    for s in spec:
        if "-" in s:
            a, b = s.split("-")
            out += range(int(a), int(b) + 1)
        else:
            out += range(int(s))
    return sorted(set(out))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--problems", nargs="+", default=list(problems.BENCHMARK),
                    help="default: all of problems.BENCHMARK; fresh instances: problems.FRESH "
                         "(or --fresh)")
    ap.add_argument("--fresh", action="store_true", help="the problems of problems.FRESH")
    ap.add_argument("--methods", nargs="+", default=None, choices=METHODS,
                    help=f"default: {' '.join(METHODS)} (--quick: lccopt random)")
    ap.add_argument("--seeds", nargs="+", default=["20"],
                    help="N (seeds 0..N-1) or A-B (seeds A..B); default 20")
    ap.add_argument("--budgets", type=int, nargs="+", default=[100, 200, 400])
    ap.add_argument("--out", default=None, help="CSV file of the runs (one row per run)")
    ap.add_argument("--resume", action="store_true",
                    help="reuse the runs already in --out instead of running them again")
    ap.add_argument("--report-only", action="store_true", help="only print the tables of --out")
    ap.add_argument("--merge", nargs="+", default=None, metavar="FILE",
                    help="add the runs of these results files to --out (kept: the longer run of "
                         "each problem, method and seed), then print the tables")
    ap.add_argument("--quick", action="store_true",
                    help="budgets 20 40, 3 seeds, methods lccopt random unless given")
    ap.add_argument("--timing", "--timing-only", action="store_true",
                    help="only time lccopt's ask(1) at 400 points")
    ap.add_argument("--no-pysot", action="store_true", help="leave pySOT out of the methods")
    ap.add_argument("--variant", default="default", choices=("default",) + tuple(variants.VARIANTS),
                    help="lccopt with an experiment of benchmarks/optimiser/variants.py plugged in")
    args = ap.parse_args(argv)
    if args.timing:
        t = time_ask()
        print(f"ask(1) at {t['n']} evaluated points ({t['fitted']} in the surrogate), 8-D: median "
              f"{t['median_ms']:.1f} ms, max {t['max_ms']:.1f} ms (goal < 50 ms)")
        return 0
    if args.fresh:
        args.problems = list(problems.FRESH)
    if args.quick:
        args.budgets = [20, 40]
        if args.seeds == ["20"]:
            args.seeds = ["3"]
        args.methods = args.methods or ["lccopt", "random"]
    methods = [m for m in (args.methods or METHODS) if not (args.no_pysot and m == "pysot")]
    seeds = _seeds(args.seeds)
    budgets = sorted(set(args.budgets))
    for name in args.problems:
        problems.get(name)  # unknown names fail now
    if args.variant != "default" and args.resume:
        raise SystemExit("--variant and --resume together would mix variants in one file")

    if args.merge is not None:
        if not args.out:
            raise SystemExit("--merge needs --out, the file to merge into")
        data = runs_table.merge(runs_table.load(args.out), args.merge)
        runs_table.save(args.out, data)
        args.report_only = True
    else:
        data = runs_table.load(args.out if (args.resume or args.report_only) else None)
    if not args.report_only:
        _run_grid(data, args, methods, seeds, budgets)
    print()
    print(report(data, args.problems, methods, budgets))
    return 0


def _run_grid(data: dict, args, methods: list[str], seeds: list[int], budgets: list[int]) -> None:
    """Run every (problem, method, seed) that --out does not hold yet, saving after each."""
    n = max(budgets)
    runners, _ = load_methods(methods)
    print(f"# {len(args.problems)} problems x {len(runners)} methods x {len(seeds)} seeds, "
          f"{n} evaluations per run; numpy {np.__version__}", flush=True)
    for name in args.problems:
        for m, fn in runners.items():
            done = 0
            t0 = time.perf_counter()
            for seed in seeds:
                k = runs_table.key(name, m, seed)
                old = data["runs"].get(k)
                if old is not None and old["n"] >= n:
                    continue
                p = problems.get(name, seed)
                t1 = time.perf_counter()
                vals = fn(p, n, seed, args.variant)
                settings = args.variant if m == "lccopt" else "default"
                data["runs"][k] = runs_table.record(vals, n, time.perf_counter() - t1, budgets,
                                                    settings)
                done += 1
                runs_table.save(args.out, data)
            if done:
                print(f"# {name} {m}: {done} runs, {time.perf_counter() - t0:.1f} s", flush=True)


if __name__ == "__main__":
    sys.exit(main())
