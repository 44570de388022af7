"""lccopt's default against a variant on the stored benchmark, cell by cell.

    python -m benchmarks.optimiser.optimiser --methods lccopt --seeds 0-19 --variant uniform \
        --out v.csv
    python -m benchmarks.optimiser.optimiser_compare v.csv [--base BASE.csv]

Per budget: cells where the variant's median is better / worse than the default's (the lccopt
runs of benchmarks/results/optimiser.csv, or of --base: a results file of
benchmarks/optimiser/optimiser.py, CSV or the earlier JSON, e.g. ``git show
48adb51:benchmarks/results/optimiser-generation-6.json``; on the seeds the variant file has),
and the cells where a two-sided Mann-Whitney U test (alpha 0.05) finds a difference (+ better,
- worse).
Then, paired by seed (the same seed starts both from the same design, so a change that acts
late in a run leaves most seeds equal): the runs better / worse / equal, and the cells where a
two-sided Wilcoxon signed-rank test (alpha 0.05) finds a difference.
"""
import argparse
from pathlib import Path

import numpy as np
from scipy.stats import mannwhitneyu, rankdata, wilcoxon

from benchmarks.support.runs_table import load


def vals(runs, prob, b, seeds):
    """Per seed (in seed order) the best value of the first b evaluations."""
    keys = sorted((k for k in runs if k.split("|")[0] == prob and k.split("|")[1] == "lccopt"
                   and int(k.split("|")[2]) in seeds), key=lambda k: int(k.split("|")[2]))
    return np.array([runs[k]["best_at"][str(b)] for k in keys])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("variant")
    ap.add_argument("--base",
                    default=Path(__file__).resolve().parents[1] / "results" / "optimiser.csv")
    args = ap.parse_args()
    base = load(str(args.base))["runs"]
    var = load(args.variant)["runs"]
    seeds = {int(k.split("|")[2]) for k in var}
    probs = sorted({k.split("|")[0] for k in var})
    for b in (100, 200, 400):
        better = worse = 0
        rows = []
        for p in probs:
            a, v = vals(base, p, b, seeds), vals(var, p, b, seeds)
            ma, mv = np.median(a), np.median(v)
            better += mv < ma
            worse += mv > ma
            if np.array_equal(np.sort(a), np.sort(v)):
                continue
            test = mannwhitneyu(v, a)
            if test.pvalue < 0.05:
                # U counts the pairs where the variant is the higher (worse): below half, better
                # (the medians may be equal, e.g. both at the optimum).
                rows.append(("+" if test.statistic < len(v) * len(a) / 2 else "-") + p)
        print(f"budget {b}: variant median better in {better} cells, worse in {worse}; "
              f"significant: {' '.join(rows) or 'none'}")
        if len(seeds) < 2:
            continue
        n_better = n_worse = n_equal = 0
        rows = []
        for p in probs:
            a, v = vals(base, p, b, seeds), vals(var, p, b, seeds)
            if len(a) != len(v):
                continue  # the base lacks some of the variant's seeds: no pairing
            n_better += int((v < a).sum())
            n_worse += int((v > a).sum())
            n_equal += int((v == a).sum())
            if np.any(v != a) and wilcoxon(v, a).pvalue < 0.05:
                d = (v - a)[v != a]
                r = rankdata(np.abs(d))  # direction: the larger signed-rank sum
                rows.append(("+" if r[d < 0].sum() > r[d > 0].sum() else "-") + p)
        print(f"  paired by seed: runs better {n_better}, worse {n_worse}, equal {n_equal}; "
              f"significant (Wilcoxon): {' '.join(rows) or 'none'}")


if __name__ == "__main__":
    main()
