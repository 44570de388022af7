"""The phases of optimisation runs: where each run's budget went and which phase found what.

    python -m benchmarks.paper.paper_phases RUN [RUN ...] [--reference F_REF --best F_BEST]

For each run directory (its results.h5) one line: the final best value, then per phase (the
first design and each restart, in order) its kind, its evaluations and the best value it
reached: ``F`` a fresh design (its first proposal is an initial point), ``B`` a restart that
went on from the run's best point (a late restart; its probes count as a design). With --reference
and --best, runs whose regret ratio (f - best) / (reference - best) is above 0.25 are marked,
and the count of fresh phases that got below it is printed: a run of a few long phases is
only as robust as one phase is likely to find the good basin.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import h5py
import numpy as np


def phases(run: Path) -> tuple[float, list[tuple[str, int, float]]]:
    with h5py.File(run / "results.h5", "r") as f:
        ev = f["evaluations"]
        restart = ev["restart"][()]
        phase = ev["phase"][()].astype(str)
        ok = ev["status"][()].astype(str) == "ok"
        value = ev["value"][()]
    out = []
    for r in np.unique(restart):
        rows = np.flatnonzero(restart == r)
        good = rows[ok[rows]]
        kind = "F" if phase[rows[0]] == "initial" else "B"
        out.append((kind, len(rows), float(value[good].min()) if len(good) else float("nan")))
    return (float(value[ok].min()) if ok.any() else float("nan")), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--reference", type=float, help="the reference design's value")
    ap.add_argument("--best", type=float, help="the best-known value")
    a = ap.parse_args()
    cut = None
    if a.reference is not None and a.best is not None:
        cut = a.best + 0.25 * (a.reference - a.best)
    fresh = []
    for run in a.runs:
        final, ph = phases(run)
        mark = "  " if cut is None or final <= cut else " >"
        text = " ".join(f"{k}{n}:{v:.5g}" for k, n, v in ph)
        print(f"{run.name:24s} {final:10.5g}{mark} {text}")
        if cut is not None:
            fresh += [v <= cut for k, n, v in ph if k == "F"]
    if cut is not None:
        print("regret above 0.25 marked '>'; fresh phases that got below it: "
              f"{sum(fresh)} of {len(fresh)}")


if __name__ == "__main__":
    main()
