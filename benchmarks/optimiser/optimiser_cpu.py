"""The optimiser's own CPU time per run, this checkout against another, side by side.

    python -m benchmarks.optimiser.optimiser_cpu [--other DIR] [--budget 400] [--seeds 0-2] \
        [--rounds 2]

A run is the ask/tell loop of a 400-evaluation run on a cheap test function of the paper's
box (8 variables, 5 integer; benchmarks/support/problems.py), one evaluation at a time, with each
kind of surrogate the paper's cases use: "scalar" (single-F_max: one RBF of the value, on
ackley8) and "composite" (moo: one RBF per objective scored by the ASF of Eq. 7, on the pair
ackley8, rastrigin8). The CPU time is the process's (time.process_time) less the test
function's own; one BLAS thread. ``--other DIR`` runs the same in DIR (a checkout or worktree
of another commit, e.g. ``git worktree add /tmp/before <commit>``: its lccopt and
benchmarks/support/problems.py, this script) in a subprocess, the two
alternating ``--rounds`` times so that a busy machine weighs on both alike.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

HERE = Path(__file__).resolve().parents[2]


def measure(root: Path, budget: int, seeds: list[int]) -> dict:
    """CPU seconds of the optimiser per run, by surrogate, in checkout ``root``."""
    import numpy as np

    try:
        from benchmarks.support import problems
    except ImportError:  # a checkout from before benchmarks/ became a package
        from benchmarks import problems
    from lccopt.optim.scalarise import ASF
    from lccopt.optim.strategy import Strategy

    out = {}
    f1, f2 = problems.paper_size("ackley"), problems.paper_size("rastrigin")
    for kind in ("scalar", "composite"):
        cpu = []
        for seed in seeds:
            composite = kind == "composite"
            s = Strategy(f1.space, budget=budget, n_initial=20, seed=seed, composite=composite)
            if composite:
                s.set_aggregate(ASF([0.0, 0.0], [20.0, 150.0]))
            t_eval = 0.0
            t0 = time.process_time()
            while not s.done:
                for p in s.ask(1):
                    t1 = time.process_time()
                    F = np.array([f1(p.x), f2(p.x)])
                    t_eval += time.process_time() - t1
                    if composite:
                        s.tell(p.id, float(s.aggregate(F[None, :])[0]), F)
                    else:
                        s.tell(p.id, float(F[0]))
            cpu.append(time.process_time() - t0 - t_eval)
        out[kind] = cpu
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--other", type=Path, default=None)
    ap.add_argument("--budget", type=int, default=400)
    ap.add_argument("--seeds", default="0-2")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None, metavar="ROOT",
                    help="measure the checkout ROOT and print the result as JSON only")
    args = ap.parse_args(argv)
    a, _, b = args.seeds.partition("-")
    seeds = list(range(int(a), int(b or a) + 1))
    if args.json:
        print(json.dumps(measure(args.json, args.budget, seeds)))
        return
    roots = {"this": HERE} | ({"other": args.other.resolve()} if args.other else {})
    got: dict = {name: {"scalar": [], "composite": []} for name in roots}
    for _ in range(args.rounds):
        for name, root in roots.items():
            cmd = [sys.executable, __file__, "--json", str(root),
                   "--budget", str(args.budget), "--seeds", args.seeds]
            env = {**os.environ, "PYTHONPATH": str(root)}
            res = json.loads(subprocess.run(cmd, capture_output=True, text=True, env=env,
                                            check=True, cwd=root).stdout)
            for kind, v in res.items():
                got[name][kind] += v
    print(f"optimiser CPU per {args.budget}-evaluation run (s), seeds {args.seeds}, "
          f"{args.rounds} rounds; median [min, max]")
    for name, root in roots.items():
        for kind, v in got[name].items():
            print(f"  {name} ({root}) {kind}: {statistics.median(v):.1f} "
                  f"[{min(v):.1f}, {max(v):.1f}]")


if __name__ == "__main__":
    main()
