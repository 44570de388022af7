"""The traffic study (issue 10): designs condition by condition under configs/traffic.yaml.

    lccopt optimise configs/traffic.yaml              # the robust design (~30 min, 2 cores)
    python -m benchmarks.scale.traffic_study runs/traffic   # the table for the README

Compares, under every condition of the case, the reference design, the single-condition
optimum of this model (configs/moo.yaml, seed 1: the README's Tables 5-7), the paper's MOO
design (Table 7) and the best design of the traffic run (worst case over the conditions).
Prints F_max [kN] and E_max [J] per condition and design, and the worst case.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[2]

from lccopt.config import load_case, parse_design  # noqa: E402
from lccopt.problem import combine_conditions, evaluate  # noqa: E402

DESIGNS = {  # name -> design in --design units (pads MN/m)
    "reference": "1120,1120,1120,8,6,6,4,0",
    "one-condition optimum (moo seed 1)": "459.4,584.5,166.8,0,6,6,3,0",
    "paper MOO (Table 7)": "214,155,50,5,6,7,3,0",
}


def best_of_run(run: Path, case) -> np.ndarray:
    import h5py

    with h5py.File(run / "results.h5", "r") as f:
        return np.asarray(f["best/x"][()], dtype=float)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, nargs="?", help="run directory of configs/traffic.yaml")
    ap.add_argument("--case", type=Path, default=REPO / "configs" / "traffic.yaml")
    args = ap.parse_args()
    case = load_case(args.case)
    designs = {k: parse_design(v, case) for k, v in DESIGNS.items()}
    if args.run is not None:
        designs["robust (traffic run)"] = best_of_run(args.run, case)
    names = [c.name for c in case.conditions]
    weights = [c.weight for c in case.conditions]
    table = {}
    for label, x in designs.items():
        per = [evaluate(case.condition_case(i), x).objectives for i in range(len(names))]
        table[label] = (per, combine_conditions(per, names, weights, case.condition_mode))
        print(f"{label}: {', '.join(f'{v:g}' for v in x)}", file=sys.stderr, flush=True)
    labels = list(designs)
    print("| condition | " + " | ".join(labels) + " |")
    print("|---|" + "---|" * len(labels))
    for i, n in enumerate(names):
        cells = [f"{table[k][0][i]['F_max'] / 1e3:.1f} kN, {table[k][0][i]['E_max']:.2f} J"
                 for k in labels]
        print(f"| {n} | " + " | ".join(cells) + " |")
    cells = [f"**{table[k][1]['F_max'] / 1e3:.1f} kN, {table[k][1]['E_max']:.2f} J**"
             for k in labels]
    print("| worst case | " + " | ".join(cells) + " |")
    ref = table["reference"][1]
    cells = [f"{(table[k][1]['F_max'] / ref['F_max'] - 1) * 100:+.0f} %, "
             f"{(table[k][1]['E_max'] / ref['E_max'] - 1) * 100:+.0f} %" for k in labels]
    print("| worst case vs reference | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
