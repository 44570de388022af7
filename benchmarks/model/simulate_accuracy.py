"""Accuracy of the default simulation against the method before issue 11.

For the reference design, the designs of benchmarks/model/convergence.py and ``--random`` designs
drawn uniformly over the bounds (integers rounded; fixed seed), F_max and E_max (and F_rms,
E_rms) of ``evaluate(case, x)`` at the case's settings are compared with the pre-issue-11
method: its integrator (benchmarks/support/legacy_newmark.py) at its settings
(REFERENCE_SETTINGS: dt = 0.2 ms, 10 m run-in, 3 m run-out, far elements <= 0.3 m).
Accepted when every |relative difference| of F_max and E_max is at most 0.5 %.

    python -m benchmarks.model.simulate_accuracy [--case configs/reference.yaml] [--random 24] \
        [--seed 11]

The figures: benchmarks/RESULTS-simulator.md.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

# One core: set before numpy loads BLAS, so the imports below follow it (noqa: E402).
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import numpy as np  # noqa: E402

from benchmarks.model.convergence import DESIGNS  # noqa: E402
from benchmarks.support.legacy_newmark import REFERENCE_SETTINGS, evaluate_legacy  # noqa: E402
from lccopt.config import Case, load_case  # noqa: E402
from lccopt.problem import evaluate  # noqa: E402

TOLERANCE = 0.5   # % on F_max and E_max


def random_designs(case: Case, count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        x = np.array([rng.uniform(v.lower, v.upper) if not v.integer
                      else rng.integers(int(v.lower), int(v.upper) + 1)
                      for v in case.variables], float)
        try:
            out.append(case.check_design(x))
        except ValueError:
            continue
    return out


def differences(case: Case, x) -> tuple[dict, dict]:
    """(new objectives, old objectives) of design x."""
    new = evaluate(case, x).objectives
    old = evaluate_legacy(case.with_simulation(**REFERENCE_SETTINGS), x).objectives
    return new, old


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", default="configs/reference.yaml")
    ap.add_argument("--random", type=int, default=24)
    ap.add_argument("--seed", type=int, default=11)
    args = ap.parse_args()
    case = load_case(args.case)
    sim = case.simulation
    print(f"case {args.case}: new settings dt = {sim['time_step']:g} s, "
          f"run-in = {sim['run_in']:g} m, run-out = {sim['run_out']:g} m, "
          f"far elements <= {sim['far_element_length']:g} m; "
          f"old: {REFERENCE_SETTINGS}\n")
    designs = [(name, case.reference if x is None else case.check_design(x))
               for name, x in DESIGNS.items()]
    randoms = random_designs(case, args.random, args.seed)
    designs += [(f"random {i + 1}", x) for i, x in enumerate(randoms)]
    print("| design | F_max old [N] | ΔF_max | E_max old [J] | ΔE_max | ΔF_rms | ΔE_rms |")
    print("|---|---|---|---|---|---|---|")
    worst = {k: 0.0 for k in ("F_max", "E_max", "F_rms", "E_rms")}
    for name, x in designs:
        new, old = differences(case, x)
        d = {k: (new[k] - old[k]) / abs(old[k]) * 100 for k in worst}
        for k in worst:
            worst[k] = max(worst[k], abs(d[k]))
        print(f"| {name} | {old['F_max']:.1f} | {d['F_max']:+.3f}% | {old['E_max']:.4f} "
              f"| {d['E_max']:+.3f}% | {d['F_rms']:+.3f}% | {d['E_rms']:+.3f}% |", flush=True)
    ok = worst["F_max"] <= TOLERANCE and worst["E_max"] <= TOLERANCE
    print(f"\n{len(designs)} designs; max |Δ|: F_max {worst['F_max']:.3f}%, "
          f"E_max {worst['E_max']:.3f}%, F_rms {worst['F_rms']:.3f}%, E_rms {worst['E_rms']:.3f}% "
          f"({'within' if ok else 'NOT within'} {TOLERANCE}% on F_max and E_max)")
    return 0 if ok else 1


if __name__ == "__main__":
    t0 = time.perf_counter()
    code = main()
    print(f"({time.perf_counter() - t0:.0f} s)")
    sys.exit(code)
