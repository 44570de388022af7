"""A lever of issue 9 measured on the paper's problem: the composite surrogate for one objective.

    python -m benchmarks.paper.paper_composite [--cases single-E_max,single-F_max] [--seeds 1-8]
                                         [--processes 2] [--f-parts high-low|segments]
                                         [--composite-only]

E_max is max - min of 20 sleeper energies and F_max max - min of a force history: kinked
functions of the design where a smooth part takes over from another. The composite surrogate
(``Strategy(composite=True)`` with ``set_aggregate``, as lccopt uses for the ASF of a
multi-objective case) fits one cubic RBF per part and scores candidates by the aggregate of
the predicted parts: for E_max the 20 sleeper energies and max - min, for F_max the force's
highest and lowest value in the zone and their difference.

Each run is a plain ask/evaluate/tell loop, one evaluation at a time, of the case's budget
(configs/<case>.yaml, the given seed), once with the scalar surrogate lccopt uses for a single
objective and once with the composite one. Prints the best value per seed and variant, the
medians and the worst seeds. Not the engine: ``lccopt optimise`` with k workers proposes each
point with the last k results still pending (lccopt/engine/schedule.py), so its runs
propose other points.
"""

from __future__ import annotations

import argparse
import os
import statistics
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

from benchmarks.paper.paper_seeds import seeds_arg  # noqa: E402
from lccopt.config import load_case  # noqa: E402
from lccopt.optim.strategy import Strategy  # noqa: E402
from lccopt.problem import Problem, evaluate, sleeper_energy_spread  # noqa: E402


def high_minus_low(F) -> np.ndarray:
    """F_max from rows [high, low] (n, 2) (the predicted high may fall below the low)."""
    F = np.asarray(F, dtype=float)
    return F[:, 0] - F[:, 1]


def highs_minus_lows(F) -> np.ndarray:
    """F_max from rows [high_1 .. high_m, low_1 .. low_m] of m stretches of the zone."""
    F = np.asarray(F, dtype=float)
    m = F.shape[1] // 2
    return F[:, :m].max(axis=1) - F[:, m:].min(axis=1)


SEGMENTS = 12  # stretches of the force zone for --f-parts segments (2 m each on the reference)


def parts(ev, objective: str, f_parts: str = "high-low") -> list[float]:
    if objective == "E_max":
        return [float(v) for v in ev.histories["sleeper_energy"]]
    h = ev.histories
    inside = h["in_force_zone_wheels"].astype(bool)
    force = h["contact_force_wheels"][inside]
    low = float(force.min())
    if f_parts == "high-low":
        return [low + ev.objectives["F_max"], low]   # F_max also takes the zone's exact ends
    # the force's high and low while the wheels are over each of SEGMENTS equal stretches
    lo, hi = sorted((ev.info["zone_start"], ev.info["zone_end"]))
    segment = ((h["wheel_positions"][inside] - lo) / (hi - lo) * SEGMENTS).astype(int)
    where = np.clip(segment, 0, SEGMENTS - 1)
    highs = np.full(SEGMENTS, low)
    lows = np.full(SEGMENTS, float(force.max()))
    np.maximum.at(highs, where, force)
    np.minimum.at(lows, where, force)
    return [float(v) for v in highs] + [float(v) for v in lows]


def run(job: tuple) -> tuple[str, bool, int, float]:
    case_name, composite, seed, f_parts = job
    case = load_case(ROOT / "configs" / f"{case_name}.yaml")
    problem = Problem.from_case(case)
    objective = problem.objectives[0]
    strategy = Strategy(problem.space(), budget=problem.budget, n_initial=problem.initial_points,
                        seed=seed, composite=composite)
    if composite:
        strategy.set_aggregate(sleeper_energy_spread if objective == "E_max" else
                               high_minus_low if f_parts == "high-low" else highs_minus_lows)
    best = np.inf
    while not strategy.done:
        proposals = strategy.ask(1)
        if not proposals:
            break
        p = proposals[0]
        ev = evaluate(case, p.x)
        value = ev.objectives[objective]
        strategy.tell(p.id, value, parts(ev, objective, f_parts) if composite else None)
        best = min(best, value)
    return case_name, composite, seed, float(best)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="single-E_max,single-F_max")
    ap.add_argument("--seeds", default="1-8")
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--f-parts", choices=("high-low", "segments"), default="high-low",
                    help="F_max's parts: the zone's force high and low, or the high and low over "
                         f"each of {SEGMENTS} equal stretches of the zone")
    ap.add_argument("--composite-only", action="store_true", help="leave out the scalar runs")
    args = ap.parse_args(argv)
    seeds = seeds_arg(args.seeds)
    variants = (True,) if args.composite_only else (False, True)
    jobs = [(c, comp, s, args.f_parts)
            for c in args.cases.split(",") for s in seeds for comp in variants]
    with ProcessPoolExecutor(args.processes) as pool:
        out = list(pool.map(run, jobs))
    best = {(c, comp, s): v for c, comp, s, v in out}
    for c in args.cases.split(","):
        print(f"\n{c}: best value per seed ({', '.join(map(str, seeds))})")
        for comp in variants:
            vals = [best[c, comp, s] for s in seeds]
            print(f"  {'composite' if comp else 'scalar   '}: " + " ".join(f"{v:.5g}" for v in vals)
                  + f"   median {statistics.median(vals):.5g}, worst {max(vals):.5g}")
        if len(variants) == 2:
            wins = sum(best[c, True, s] < best[c, False, s] for s in seeds)
            print(f"  composite better on {wins} of {len(seeds)} seeds")


if __name__ == "__main__":
    main()
