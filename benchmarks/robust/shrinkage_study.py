"""A robust run's designs chosen again by a shrunk quantile, measured on the runs of the
robust-design study (docs/robust.md, "Study"): a design's q90 over the run's few tracks is
its drawing plus a deviation, and the deviation's differences between designs are partly the
tracks' noise. Empirical Bayes (Efron & Morris, "Data analysis using Stein's estimator and
its generalizations", JASA 70, 1975) shrinks each deviation toward the run's mean deviation
by the share of its spread that the noise explains:

    q90_shrunk(x) = drawn(x) + m + w (q90(x) - drawn(x) - m),  w = 1 - noise / spread

with the noise from a paired bootstrap of the run's tracks (the same resampled tracks for
every design: the run compares designs on common tracks). The design with the lowest shrunk
value among those the run evaluated is judged on the study's fresh tracks. Only the choice is
redone, not the search: a first look at whether the statistic would pick better.

    nice -n 10 python -m benchmarks.robust.shrinkage_study paper --seeds 1 2 3 \\
        --out /tmp/robust-paper          # after robust_study into the same folder
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import h5py
import numpy as np

from benchmarks.robust.robust_study import CASES, LEVEL, display, judge, kept_design
from lccopt.uncertainty import statistics as stats


def _q(rows: np.ndarray) -> np.ndarray:
    return np.array([stats.quantile(r, LEVEL) for r in rows])


def shrunk(drawn: np.ndarray, tracks: np.ndarray, draws: int = 300) -> tuple[np.ndarray, float]:
    """Each design's shrunk q90 and the weight w (seed 0 for the bootstrap)."""
    rng = np.random.default_rng(0)
    dev = _q(tracks) - drawn
    spread = float(np.var(dev - dev.mean(), ddof=1))
    n = tracks.shape[1]
    pattern = []
    for _ in range(draws):
        d = _q(tracks[:, rng.integers(0, n, n)]) - drawn
        pattern.append(d - d.mean())
    noise = float(np.mean(np.var(np.array(pattern), axis=0)))
    w = max(0.0, 1.0 - noise / spread) if spread > 0 else 0.0
    return drawn + dev.mean() + w * (dev - dev.mean()), w


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case", choices=sorted(CASES))
    ap.add_argument("--seeds", type=int, nargs="+", required=True)
    ap.add_argument("--fresh", type=int, default=None,
                    help="fresh tracks of the study (default: 100 paper, 40 settlement)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args()
    obj = CASES[a.case]["objective"]
    fresh_n = a.fresh or (100 if a.case == "paper" else 40)
    scale, unit = display(obj)
    summary = {}
    print("| seed | weight w | nominal | robust optimum (#) | shrunk choice (#) |\n"
          "|---:|---:|---:|---:|---:|")
    for seed in a.seeds:
        run = a.out / "runs" / f"{a.case}-robust-s{seed}"
        with h5py.File(run / "results.h5") as f:
            ev = f["evaluations"]
            x, ids, value = ev["x"][()], ev["id"][()], ev["value"][()]
            drawn, tracks = ev[obj][()], f[f"realisations/{obj}"][()]
        ok = np.isfinite(drawn) & np.all(np.isfinite(tracks), axis=1) & np.isfinite(value)
        s, w = shrunk(drawn[ok], tracks[ok])
        pick = int(np.argmin(s))
        first = int(np.argmin(value[ok]))
        robust_x = x[ok][first]
        designs = {f"nominal s{seed}": kept_design(a.out, f"nominal s{seed}"),
                   f"robust s{seed}": robust_x}
        name = f"robust s{seed}" if pick == first else f"shrunk s{seed}"
        designs[name] = x[ok][pick]
        got = judge(a.out / f"{a.case}-fresh.yaml", designs, fresh_n, a.workers, obj,
                    a.out / "fresh")
        q = {k: stats.quantile(v["tracks"], LEVEL) for k, v in got.items()}
        n_, r_, c_ = q[f"nominal s{seed}"], q[f"robust s{seed}"], q[name]
        summary[seed] = {"weight": w, "robust_id": int(ids[ok][first]),
                         "shrunk_id": int(ids[ok][pick]), "fresh_q90": q}
        print(f"| {seed} | {w:.2f} | {n_ * scale:.3f} | {r_ * scale:.3f} (#{ids[ok][first]}) | "
              f"{c_ * scale:.3f} (#{ids[ok][pick]}), {(c_ - n_) / n_:+.1%} |", flush=True)
    (a.out / f"{a.case}-shrinkage-s{'-'.join(map(str, a.seeds))}.json").write_text(
        json.dumps(summary, indent=1, default=float))
    print(f"(q90 on the {fresh_n} fresh tracks [{unit}]; the shrunk choice against nominal)")


if __name__ == "__main__":
    main()
