"""A clean-up after a robust run, measured on the runs of the robust-design study
(docs/robust.md, "Study"; Boesel, Nelson & Kim, "Using ranking and selection to 'clean up'
after simulation optimization", Operations Research 51(5), 2003): the run's best few designs
by its own objective are simulated on validation realisations the run never saw, and the one
best there is the answer. Minimising a quantile over a few realisations picks the design whose
tracks happened to favour it (the winner's curse); fresh tracks judge the finalists without
that bias.

Run after ``robust_study`` into the same folder (it reads the robust runs and the study's
fresh judging case, and judges the chosen designs there):

    nice -n 10 python -m benchmarks.robust.cleanup_study settlement --seeds 1 2 3 \\
        --keep 5 --validation 16 --out /tmp/robust-b80

``--with-nominal`` adds the study's nominal optimum to the finalists; with ``--keep 1`` the
choice is between the two optima only, and the table adds the choice that keeps the nominal
optimum unless the validation tracks show the robust one clearly lower (the 95 % interval of
the paired difference below 0: docs/robust.md, "Using it", what a user does with ``lccopt
simulate --against``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import h5py
import numpy as np

from benchmarks.robust.robust_study import (
    CASES,
    LEVEL,
    VARIATION,
    case_text,
    display,
    judge,
    kept_design,
)
from lccopt.uncertainty import statistics as stats


def finalists(run: Path, keep: int) -> dict[str, np.ndarray]:
    """The ``keep`` best distinct designs of a run by the value it minimised, best first,
    named ``#id``."""
    with h5py.File(run / "results.h5") as f:
        ev = f["evaluations"]
        x, value, ids = ev["x"][()], ev["value"][()], ev["id"][()]
        best = int(f["best"].attrs["id"])
    out: dict[str, np.ndarray] = {}
    for i in np.argsort(value, kind="stable"):
        if np.isfinite(value[i]) and not any(np.array_equal(x[i], y) for y in out.values()):
            out[f"#{int(ids[i])}"] = x[i]
        if len(out) == keep:
            break
    assert next(iter(out)) == f"#{best}", (run, best, list(out))
    return out


def ranked_right(nominal, robust, sizes, draws: int = 4000) -> dict:
    """For n tracks drawn at random from the fresh ones (without replacement, ``draws``
    times, seed 0): how often the q90 and the mean of n tracks put the nominal optimum
    below the robust one, as all the fresh tracks do. How noisy a run's statistic over n
    tracks is for this pair; a robust run chose its optimum by such a statistic among all
    its designs, which favours the design its tracks happen to favour."""
    a, b = np.asarray(nominal, float), np.asarray(robust, float)
    rng = np.random.default_rng(0)
    out = {}
    for n in sizes:
        picks = [rng.choice(len(a), n, replace=False) for _ in range(draws)]
        q = np.mean([stats.quantile(a[i], LEVEL) < stats.quantile(b[i], LEVEL) for i in picks])
        m = np.mean([a[i].mean() < b[i].mean() for i in picks])
        out[n] = (float(q), float(m))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case", choices=sorted(CASES))
    ap.add_argument("--seeds", type=int, nargs="+", required=True)
    ap.add_argument("--keep", type=int, default=5)
    ap.add_argument("--validation", type=int, default=16)
    ap.add_argument("--validation-seed", type=int, default=2000,
                    help="the validation tracks of optimiser seed s are drawn from this + s")
    ap.add_argument("--fresh", type=int, default=40)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--with-nominal", action="store_true",
                    help="the study's nominal optimum among the finalists")
    a = ap.parse_args()
    what = CASES[a.case]
    obj = what["objective"]
    judged = stats.quantile_name(obj, LEVEL)
    scale, unit = display(obj)
    fresh_path = a.out / f"{a.case}-fresh.yaml"
    summary = {}
    print(f"| seed | nominal | robust (#) | cleaned up (#) | q90 of the {a.keep} finalists "
          f"on {a.validation} validation tracks |\n|---|---:|---:|---:|---|")
    for seed in a.seeds:
        run = a.out / "runs" / f"{a.case}-robust-s{seed}"
        with h5py.File(run / "results.h5") as f:
            budget = int(f.attrs["budget"])
        final = finalists(run, a.keep)
        nominal = kept_design(a.out, f"nominal s{seed}")
        if a.with_nominal and not any(np.array_equal(nominal, y) for y in final.values()):
            final["nominal"] = nominal
        variation = VARIATION.format(realisations=a.validation,
                                     seed=a.validation_seed + seed) + what["variation"]
        vpath = a.out / f"{a.case}-validation-s{seed}.yaml"
        vpath.write_text(case_text(f"{a.case}-validation-s{seed}", what, judged, budget, seed,
                                   variation))
        val = judge(vpath, final, a.validation, a.workers, obj,
                    a.out / "validation" / f"s{seed}")
        q_val = {k: stats.quantile(v["tracks"], LEVEL) for k, v in val.items()}
        chosen = min(q_val, key=q_val.get)
        first = next(iter(final))
        clearly = None
        if len(final) == 2 and "nominal" in final:
            _, _, high = stats.paired_difference(val[first]["tracks"], val["nominal"]["tracks"],
                                                 LEVEL)
            clearly = "robust" if high < 0 else "nominal"
        # the run's own optimum and the nominal one are judged under the study's names
        # (their kept values reused)
        name = (f"robust s{seed}" if chosen == first else
                f"nominal s{seed}" if np.array_equal(final[chosen], nominal) else
                f"cleanup s{seed}")
        designs = {f"nominal s{seed}": nominal, f"robust s{seed}": final[first],
                   name: final[chosen]}
        fresh = judge(fresh_path, designs, a.fresh, a.workers, obj, a.out / "fresh")
        q = {k: stats.quantile(v["tracks"], LEVEL) for k, v in fresh.items()}
        ranked = ranked_right(fresh[f"nominal s{seed}"]["tracks"],
                              fresh[f"robust s{seed}"]["tracks"], (8, 16))
        summary[seed] = {"finalists": {k: float(v) for k, v in q_val.items()},
                         "chosen": chosen, "chosen_q90": float(q[name]),
                         "clearly_lower_choice": clearly,
                         "fresh_q90": {k: float(v) for k, v in q.items()},
                         "ranked_right": ranked}
        fin = ", ".join(f"{k} {v * scale:.3f}" for k, v in q_val.items())
        print(f"| {seed} | {q[f'nominal s{seed}'] * scale:.3f} | "
              f"{q[f'robust s{seed}'] * scale:.3f} ({first}) | {q[name] * scale:.3f} "
              f"({chosen}) | {fin} |", flush=True)
    tag = "-with-nominal" if a.with_nominal else ""
    (a.out / f"{a.case}-cleanup{tag}-s{'-'.join(map(str, a.seeds))}.json").write_text(
        json.dumps(summary, indent=1))
    for seed, s in summary.items():
        n, c = s["fresh_q90"][f"nominal s{seed}"], s["chosen_q90"]
        if s["clearly_lower_choice"] is not None:
            k = s["clearly_lower_choice"]
            v = s["fresh_q90"][f"{k} s{seed}"]
            print(f"seed {seed}: kept unless the robust optimum is clearly lower: {k}, q90 "
                  f"{v * scale:.4g} {unit} ({(v - n) / n:+.1%})")
        print(f"seed {seed}: cleaned-up q90 {c * scale:.4g} vs nominal {n * scale:.4g} {unit} "
              f"({(c - n) / n:+.1%}); the nominal optimum ranked below the robust one by "
              + ", ".join(f"{m} of {k} random fresh tracks in {p:.0%} of draws"
                          for k, (pq, pm) in s["ranked_right"].items()
                          for m, p in (("q90", pq), ("the mean", pm))))


if __name__ == "__main__":
    main()
