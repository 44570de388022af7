"""How much of "at or below pySOT's median in N of 24 cells" is the seeds drawn, not the method.

    python -m benchmarks.optimiser.criterion_noise RUNS.csv [RUNS.csv ...] \
        [--seeds 300-315,400-415] [--draw 16] [--budgets 200 400] [--resamples 4000]

From result files of benchmarks/optimiser/optimiser.py (one lccopt run and one pySOT run per
family and seed; lccopt rows of a variant are left out): per cell (family, budget), over all
the seeds given, lccopt's and pySOT's medians, how many lccopt runs are at or below pySOT's
median, a two-sided Mann-Whitney p, and the chance that lccopt's median is at or below
pySOT's when ``--draw`` seeds are drawn (a bootstrap: each method's runs resampled
independently, ``--resamples`` times, a fixed generator). Then the distribution of the
count of such cells over the same draws: what a judging of ``--draw`` seeds would count for a
method that is as good as these runs say, seed luck aside.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.stats import mannwhitneyu

from benchmarks.paper.paper_seeds import seeds_arg
from benchmarks.support.runs_table import best_at, load, merge


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", help="result CSVs of benchmarks/optimiser/optimiser.py")
    ap.add_argument("--seeds", type=seeds_arg, default=seeds_arg("300-315,400-415"))
    ap.add_argument("--draw", type=int, default=16, help="seeds per judging (16)")
    ap.add_argument("--budgets", type=int, nargs="+", default=[200, 400])
    ap.add_argument("--resamples", type=int, default=4000)
    args = ap.parse_args()
    runs = merge(load(args.files[0]), args.files[1:])["runs"]

    def values(family: str, method: str, b: int) -> np.ndarray | None:
        out = []
        for s in args.seeds:
            run = runs.get(f"{family}|{method}|{s}")
            if run is None or (method == "lccopt" and run.get("settings", "default") != "default"):
                return None
            value = best_at(run, b)
            if value is None:  # a run shorter than the budget
                return None
            out.append(value)
        return np.array(out, dtype=float)

    families = sorted({k.split("|")[0] for k in runs})
    rng = np.random.default_rng(0)
    n, m = len(args.seeds), args.draw
    wins, at_or_below = [], 0
    print(f"{n} seeds; chance per cell with {m} seeds drawn ({args.resamples} resamples)\n")
    print("| family | budget | lccopt median | pySOT median | lccopt runs at or below "
          "pySOT's median | Mann-Whitney p | P(median at or below) |")
    print("|---|---|---|---|---|---|---|")
    for fam in families:
        for b in args.budgets:
            lv, pv = values(fam, "lccopt", b), values(fam, "pysot", b)
            if lv is None or pv is None:
                print(f"| {fam} | {b} | (not every seed has a default lccopt and a pySOT run "
                      f"this long) |")
                continue
            draw_l = lv[rng.integers(0, n, (args.resamples, m))]
            draw_p = pv[rng.integers(0, n, (args.resamples, m))]
            win = np.median(draw_l, axis=1) <= np.median(draw_p, axis=1)
            wins.append(win)
            at_or_below += np.median(lv) <= np.median(pv)
            p = mannwhitneyu(lv, pv).pvalue
            print(f"| {fam} | {b} | {np.median(lv):.4g} | {np.median(pv):.4g} | "
                  f"{int(np.sum(lv <= np.median(pv)))} of {n} | {p:.3f} | {win.mean():.2f} |")
    if not wins:
        raise SystemExit("no cell has a default lccopt and a pySOT run on every seed")
    count = np.sum(wins, axis=0)
    q05, q50, q95 = np.quantile(count, [0.05, 0.5, 0.95])
    print(f"\ncells at or below pySOT on all {n} seeds: {at_or_below} of {len(wins)}")
    print(f"count with {m} seeds drawn: median {q50:g}, 5-95 % {q05:g}-{q95:g}; "
          + ", ".join(f"P(>= {k}) {np.mean(count >= k):.2f}"
                      for k in range(int(q50), len(wins) + 1)[:5]))


if __name__ == "__main__":
    main()
