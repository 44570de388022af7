"""The objective's landscape along one design variable, over every design of some runs.

    python -m benchmarks.optimiser.landscape RUN [RUN ...] --variable x_l \\
        --bands 0-0 1-5 6-20 21-60 61-100 101-120

For each band of the variable's values (in the run's internal units: elements for lengths,
N/m for pads, as results.h5 stores x), the number of evaluated designs of all the runs
together, the best value and the 10 % quantile of the value (the ASF for moo, the objective
for a single one); then how many of the runs' initial-design points fell in each band. A
basin that occupies a narrow band of one variable behind a ridge of poor values is what a
Latin hypercube and steps around one best point rarely reach.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import h5py
import numpy as np


def band(text: str) -> tuple[float, float]:
    lo, _, hi = text.partition("-")
    return float(lo), float(hi or lo)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--variable", required=True, help="a design variable's name, e.g. x_l")
    ap.add_argument("--bands", nargs="+", type=band, required=True,
                    help="inclusive ranges LO-HI of the variable's stored values")
    a = ap.parse_args()
    xs, values, initial = [], [], []
    for run in a.runs:
        with h5py.File(run / "results.h5") as f:
            ev = f["evaluations"]
            names = [n.decode() if isinstance(n, bytes) else str(n)
                     for n in ev.attrs["names"]]
            j = names.index(a.variable)
            v = ev["value"][()]
            ok = np.isfinite(v)
            xs.append(ev["x"][()][ok, j])
            values.append(v[ok])
            initial.append(np.array([p in (b"initial", "initial") for p in ev["phase"][()][ok]]))
    x, v, init = np.concatenate(xs), np.concatenate(values), np.concatenate(initial)
    print(f"{len(a.runs)} runs, {len(v)} designs; {a.variable} by band\n")
    print(f"| {a.variable} | designs | best value | 10 % quantile | initial-design points |")
    print("|---|---:|---:|---:|---:|")
    for lo, hi in a.bands:
        m = (x >= lo) & (x <= hi)
        if not m.any():
            print(f"| {lo:g}-{hi:g} | 0 | – | – | 0 |")
            continue
        print(f"| {lo:g}-{hi:g} | {m.sum()} | {v[m].min():.3f} | {np.quantile(v[m], 0.1):.3f} "
              f"| {np.count_nonzero(m & init)} of {init.sum()} |")


if __name__ == "__main__":
    main()
