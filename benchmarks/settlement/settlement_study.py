"""The settlement study (docs/settlement.md, "Study"): the reference design, the paper's MOO
design (Table 7) and lccopt's optimum of each seed of ``configs/settlement.yaml``, side by
side: their objectives at the horizon (a Markdown table) and two figures, the settlement per
sleeper against axle passes and the profile at chosen times.

    # the runs (one after the other, 2 workers each):
    for s in 1 2 3; do lccopt optimise configs/settlement.yaml --set optimisation.budget=60 \\
        --set optimisation.seed=$s --set name=settlement-s$s --workers 2; done
    python -m benchmarks.settlement.settlement_study runs/settlement-s1 runs/settlement-s2 \\
        runs/settlement-s3 --out benchmarks/results/settlement-study

The MOO design is simulated here once, on the first run's case (as its workers evaluate).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from lccopt.config import load_case
from lccopt.problem import evaluate
from lccopt.report.data import BEST_COLOR, OKABE_ITO, REF_COLOR, load_run, read_history
from lccopt.report.settlement import (
    Design,
    fig_settlement_history,
    fig_settlement_profile,
    limit_of,
)

MOO = [214e6, 155e6, 50e6, 5, 6, 7, 3, 0]          # the paper's Table 7, spans in 0.1 m
COLUMNS = ("differential_settlement", "F_max", "max_settlement", "max_void", "level_std",
           "force_growth", "years_to_limit")
SHOWN = {"F_max": (1e-3, "kN"), "force_growth": (1.0, "-"), "years_to_limit": (1.0, "year")}


def _design_text(names, x) -> str:
    out = []
    for k, v in zip(names, x):
        if k.startswith("x_r"):
            out.append(f"{v / 1e6:.0f}")
        elif k.startswith(("x_s", "x_l")):
            out.append(f"{v / 10:.1f}")
        else:
            out.append(f"{v:g}")
    return ", ".join(out)


def _row(label: str, objectives: dict, names, x) -> str:
    cells = []
    for k in COLUMNS:
        scale, _ = SHOWN.get(k, (1e3, "mm"))
        cells.append(f"{objectives[k] * scale:.3g}")
    return f"| {label} | {' | '.join(cells)} | {_design_text(names, x)} |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, default=Path("settlement-study"))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    runs = [load_run(r) for r in args.runs]
    first = runs[0]
    names = list(first.names)
    ri = first.ref_index()
    rows, designs = [], []
    ref_obj = {k: float(first.obj[k][ri]) for k in COLUMNS}
    rows.append(_row("reference", ref_obj, names, first.x[ri]))
    h, info, _ = read_history(first, ri)
    designs.append(Design("reference", h, info, REF_COLOR, "--"))

    case = load_case(first.path / "case.yaml")
    t0 = time.perf_counter()
    moo = evaluate(case, np.array(MOO, dtype=float))
    wall = time.perf_counter() - t0
    rows.append(_row("paper's MOO (Table 7)", moo.objectives, names, MOO))
    designs.append(Design("paper's MOO", moo.histories, moo.info, OKABE_ITO["green"], ":"))

    best = None
    for run in runs:
        bi = run.best_index()
        obj = {k: float(run.obj[k][bi]) for k in COLUMNS}
        rows.append(_row(f"lccopt best, {run.path.name} (#{run.ids[bi]} of {run.n})", obj,
                         names, run.x[bi]))
        if best is None or run.value[bi] < best[0].value[best[1]]:
            best = (run, bi)
    head = " | ".join(f"{k} [{SHOWN.get(k, (1e3, 'mm'))[1]}]" for k in COLUMNS)
    print(f"| design | {head} | x_r1..3 [MN/m], x_n, x_s1..3 [m], x_l [m] |")
    print("|" + " --- |" * (len(COLUMNS) + 2))
    print("\n".join(rows))
    print(f"\nMOO design evaluated in {wall:.1f} s "
          f"({moo.info.get('settlement_simulations')} simulations)")
    # the figures: reference, MOO and the lowest ASF value of all seeds (the values of the
    # seeds are comparable: same reference point and worst values, from the same reference)
    run, bi = best
    h, info, note = read_history(run, bi)
    if h is None:
        raise SystemExit(f"{run.path}: {note}")
    designs.append(Design(f"lccopt best ({run.path.name} #{run.ids[bi]})", h, info,
                          BEST_COLOR, "-"))
    title = "Settlement of the approach: reference, the paper's MOO design, lccopt's optimum"
    print(fig_settlement_history(designs, args.out, title, limit_of(info)))
    print(fig_settlement_profile(designs, args.out, title, years=[1.0, 10.0]))


if __name__ == "__main__":
    main()
