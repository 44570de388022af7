"""Best-known values of the paper's problem on the current model, from the designs of any runs.

    python -m benchmarks.paper.paper_best_known RUN [RUN ...] [--top 10] [--processes 2]

A run's stored objectives are those of the model it ran on. After a change of the model (the
force zone over the whole ERS, for one) the best designs of earlier runs are still good
candidates, and a regret ratio must be measured against the best design known, not only
against the best of the runs of one benchmark. This script takes, from every run given, the
``--top`` rows by each stored objective (F_max, E_max) and by the run's own value, evaluates
those designs again with configs/reference.yaml, and prints, per case of
benchmarks/paper/paper_seeds.py, the best value and its design:

* single-F_max: F_max [N]; single-E_max: E_max [J];
* moo: the ASF of configs/moo.yaml (reference point 20 % better than the reference design's
  F_max and E_max, the case's worst values and rho), so values compare with paper_seeds.py.

Give the printed values to ``paper_seeds.py --known``.
"""

from __future__ import annotations

import argparse
import functools
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import h5py  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

from lccopt.config import load_case  # noqa: E402
from lccopt.problem import Problem, evaluate  # noqa: E402

MODEL = ROOT / "configs" / "reference.yaml"


def candidates(run: Path, top: int) -> list[tuple[tuple, str]]:
    """(design, 'parent/run #id') of the run's best rows by F_max, by E_max and by its own value."""
    with h5py.File(run / "results.h5", "r") as f:
        e = f["evaluations"]
        ok = e["status"].asstr()[()] == "ok"
        x, ids = e["x"][()], e["id"][()]
        picked = set()
        for key in ("F_max", "E_max", "value"):
            if key in e:
                v = np.where(ok, e[key][()], np.inf)
                best_first = np.argsort(v, kind="stable")[:top]
                picked.update(int(i) for i in best_first if np.isfinite(v[i]))
    return [(tuple(float(c) for c in x[i]), f"{run.parent.name}/{run.name} #{int(ids[i])}")
            for i in sorted(picked)]


@functools.cache
def model():
    return load_case(MODEL)   # once per worker process


def objectives(x: tuple) -> tuple[float, float]:
    o = evaluate(model(), np.array(x)).objectives
    return o["F_max"], o["E_max"]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--top", type=int, default=10, help="rows per stored objective and run")
    ap.add_argument("--processes", type=int, default=2)
    args = ap.parse_args(argv)
    found: dict[tuple, str] = {}
    for run in args.runs:
        if (run / "results.h5").exists():
            for x, where in candidates(run, args.top):
                found.setdefault(x, where)
    designs = list(found)
    ref_x = tuple(float(v) for v in model().reference)
    with ProcessPoolExecutor(args.processes) as pool:
        objs = list(pool.map(objectives, [ref_x] + designs, chunksize=8))
    ref, F = np.array(objs[0]), np.array(objs[1:])
    moo = Problem.from_case(load_case(ROOT / "configs" / "moo.yaml"))   # objectives [F_max, E_max]
    values = {
        "single-F_max": F[:, 0],
        "single-E_max": F[:, 1],
        "moo": moo.aggregate(moo.reference_point({"F_max": ref[0], "E_max": ref[1]}))(F),
    }
    print(f"{len(designs)} designs from {len(args.runs)} runs evaluated on {MODEL.name} "
          f"(reference design: F_max {ref[0]:.5g} N, E_max {ref[1]:.5g} J)")
    for case, v in values.items():
        i = int(np.argmin(v))
        x = designs[i]
        shown = (f"{x[0] / 1e6:.1f}, {x[1] / 1e6:.1f}, {x[2] / 1e6:.1f} MN/m; "
                 + ", ".join(f"{c:g}" for c in x[3:]))
        print(f"  {case}: {v[i]:.5g}  (F_max {F[i, 0]:.5g} N, E_max {F[i, 1]:.5g} J; "
              f"{found[x]}: {shown})")
    print("--known " + " ".join(f"{c}={float(np.min(v)):.6g}" for c, v in values.items()))


if __name__ == "__main__":
    main()
