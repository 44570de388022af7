"""lccopt's default against a variant on the stored benchmark, cell by cell.

    python benchmarks/optimiser.py --methods lccopt --seeds 0-9 --set capping=False --out v.json
    python benchmarks/optimiser_compare.py v.json [--base BASE.json]

Per budget: cells where the variant's median is better / worse than the default's (from
benchmarks/results/optimiser.json, or the lccopt runs of --base, e.g.
benchmarks/results/optimiser-generation-6.json; on the seeds the variant file has), and the
cells where a two-sided Mann-Whitney U test (alpha 0.05) finds a difference (+ better, - worse).
"""
import argparse
import json
from pathlib import Path

import numpy as np
from scipy.stats import mannwhitneyu

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("variant")
ap.add_argument("--base", default=Path(__file__).resolve().parent / "results" / "optimiser.json")
args = ap.parse_args()
base = json.load(open(args.base))["runs"]
var = json.load(open(args.variant))["runs"]


SEEDS = {int(k.split("|")[2]) for k in var}


def vals(runs, prob, b):
    return np.array([v["best_at"][str(b)] for k, v in runs.items()
                     if k.split("|")[0] == prob and k.split("|")[1] == "lccopt" and int(k.split("|")[2]) in SEEDS])


probs = sorted({k.split("|")[0] for k in var})
for b in (100, 200, 400):
    better = worse = 0
    rows = []
    for p in probs:
        a, v = vals(base, p, b), vals(var, p, b)
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
