"""Convergence study of the simulation settings (time step, element length, run-in, run-out).

For several designs spread over the design space, F_max and E_max (and F_rms, E_rms) at the
case's settings are compared with runs that halve the time step, halve the element length,
double the run-in and double the run-out. The defaults are accepted when every change is
below 1%.

    python -m benchmarks.model.convergence [configs/reference.yaml]
"""

from __future__ import annotations

import sys
import time

import numpy as np

from lccopt.config import load_case
from lccopt.problem import evaluate

DESIGNS = {  # x = [x_r1, x_r2, x_r3, x_n, x_s1, x_s2, x_s3, x_l]
    "reference": None,
    "paper MOO": [214e6, 155e6, 50e6, 5, 6, 7, 3, 0],
    "paper min F_max": [103e6, 50e6, 72e6, 4, 6, 6, 4, 0],
    "soft, wide, Type II": [50e6, 50e6, 50e6, 0, 7, 7, 7, 120],
    "stiff, close, 20 strengthened": [1200e6, 1200e6, 1200e6, 20, 3, 3, 3, 60],
}


def main(path: str = "configs/reference.yaml") -> None:
    case = load_case(path)
    sim = case.simulation
    variants = {
        "dt/2": dict(time_step=sim["time_step"] / 2),
        "elements/2": dict(element_length=sim["element_length"] / 2,
                           far_element_length=sim["far_element_length"] / 2),
        "run-in x2": dict(run_in=2 * sim["run_in"]),
        "run-out x2": dict(run_out=2 * sim["run_out"]),
    }
    print(f"case {path}: dt = {sim['time_step']:g} s, element = {sim['element_length']:g} m, "
          f"(far {sim['far_element_length']:g} m), run-in = {sim['run_in']:g} m, "
          f"run-out = {sim['run_out']:g} m\n")
    variant_columns = " | ".join(f"{v}: ΔF_max, ΔE_max" for v in variants)
    print("| design | F_max [N] | E_max [J] | " + variant_columns + " |")
    print("|---|---|---|" + "---|" * len(variants))
    worst = 0.0
    for name, x in DESIGNS.items():
        x = case.reference if x is None else np.array(x, float)
        base = evaluate(case, x).objectives
        cells = []
        for settings in variants.values():
            o = evaluate(case.with_simulation(**settings), x).objectives
            d = [abs(o[k] - base[k]) / abs(base[k]) * 100 for k in ("F_max", "E_max")]
            worst = max(worst, *d)
            cells.append(f"{d[0]:.2f}%, {d[1]:.2f}%")
        print(f"| {name} | {base['F_max']:.1f} | {base['E_max']:.4f} | " + " | ".join(cells) + " |",
              flush=True)
    print(f"\nlargest change: {worst:.2f}% ({'within' if worst <= 1.0 else 'NOT within'} 1%)")


if __name__ == "__main__":
    t0 = time.perf_counter()
    main(*sys.argv[1:])
    print(f"({time.perf_counter() - t0:.0f} s)")
