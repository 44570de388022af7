"""Where a run's best was found and what the run did after it: why a seed stalls.

    python -m benchmarks.optimiser.stalls --problem fresh5-ackley --seeds 300-307 [--budget 400]
                                [--variant NAME] [--setting local_weights=all] [--first 200]
    python -m benchmarks.optimiser.stalls RUN [RUN ...]  # lccopt run directories (journal.jsonl)

Per run: the best value and the proposal that found it; each phase of the search (restart
index, how it started: a design, from a point, bound probes; its proposals; its best and
whether that beat the phases before it); and after the run's last improvement (by the step
rule's IMPROVEMENT_TOL): how many proposals, of which kinds (DYCORS "adaptive", "local" search,
"initial" designs, "random"), how many distinct integer assignments they tried, and how far
(unit box) they stayed from the best point. For a test function, also how many of the best
point's integers differ from the optimum's. Then, over the first ``--first`` proposals, which
kinds of point were proposed and how many improved on the best of the phase so far, the local
search's points split by whether they keep that best point's integer assignment (summed over
the runs at the end). ``--setting NAME=VALUE`` runs a test function with one of the
optimiser's settings changed (lccopt.optim.settings).
"""

from __future__ import annotations

import argparse
import json
import os
from collections import Counter
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

from benchmarks.optimiser import variants  # noqa: E402
from benchmarks.paper.paper_seeds import seeds_arg  # noqa: E402
from benchmarks.support import problems  # noqa: E402
from lccopt.optim.settings import IMPROVEMENT_TOL, Settings  # noqa: E402
from lccopt.optim.strategy import Strategy  # noqa: E402


def from_problem(name: str, seed: int, budget: int, variant: str, settings: dict | None = None):
    """(records, space, test function) of an ask/tell run as benchmarks/optimiser/optimiser.py runs
    it (``settings``: optimiser settings changed)."""
    p = problems.get(name, seed)
    s = Strategy(p.space, budget=budget, n_initial=20, seed=seed,
                 **variants.strategy_kwargs(variant), **(settings or {}))
    while not s.done:
        props = s.ask(1)
        if not props:
            break
        for pr in props:
            s.tell(pr.id, p(pr.x))
    return s.history, p.space, p


def from_run(run: Path):
    """(records, space, None) of an lccopt run directory, from its journal."""
    lines = [json.loads(t) for t in (run / "journal.jsonl").read_text().splitlines() if t]
    recs: dict[int, dict] = {}
    for ev in lines:
        if ev.get("event") == "asked":
            recs[ev["id"]] = {"id": ev["id"], "x": np.array(ev["x"], dtype=float),
                              "phase": ev["phase"], "restart": ev["restart"],
                              "status": "pending", "value": None}
        elif ev.get("event") == "evaluated" and ev["id"] in recs:
            recs[ev["id"]].update(status="ok", value=float(ev["value"]))
        elif ev.get("event") == "failed" and ev["id"] in recs:
            recs[ev["id"]]["status"] = "failed"
    from lccopt.config import load_case
    from lccopt.problem import Problem

    space = Problem.from_case(load_case(run / "case.yaml")).space()
    return [recs[i] for i in sorted(recs)], space, None


def analyse(records: list[dict], space, p=None) -> dict:
    ok = [r for r in records if r["status"] == "ok"]
    best = min(ok, key=lambda r: (r["value"], r["id"]))
    # the last improvement by the step rule's tolerance (relative)
    last_imp, f = 0, np.inf
    for r in ok:
        if r["value"] < f - IMPROVEMENT_TOL * abs(f) if np.isfinite(f) else True:
            last_imp, f = r["id"], r["value"]
    phases = []
    for k in sorted({r["restart"] for r in records}):
        rs = [r for r in records if r["restart"] == k]
        vals = [r["value"] for r in rs if r["status"] == "ok"]
        before = [r["value"] for r in ok if r["restart"] < k]
        kinds = Counter(r["phase"] for r in rs)
        phases.append({"k": k, "start": rs[0]["id"], "n": len(rs), "design": kinds["initial"],
                       "best": min(vals) if vals else None,
                       "better": bool(vals) and (not before or min(vals) < min(before))})
    after = [r for r in records if r["id"] > last_imp]
    ints = np.array([], dtype=bool) if space is None else space.int_mask
    out = {"best": best["value"], "best_id": best["id"], "last_improvement": last_imp,
           "n": len(records), "phases": phases,
           "after": dict(Counter(r["phase"] for r in after)),
           "after_assignments": len({tuple(r["x"][ints]) for r in after}),
           "best_x": best["x"]}
    if space is not None and after:
        u0 = space.to_unit(best["x"])
        d = [float(np.linalg.norm(space.to_unit(r["x"]) - u0)) for r in after]
        out["after_distance"] = (float(np.median(d)), float(np.max(d)))
        out["after_int_moves"] = float(np.mean([np.sum(r["x"][ints] != best["x"][ints])
                                                for r in after]))
    if p is not None:
        out["ints_wrong"] = int(np.sum(best["x"][ints] != p.x_opt[ints]))
        out["f_opt"] = p.f_opt
    return out


def proposal_kinds(records: list[dict], space, first: int) -> Counter:
    """Over the first ``first`` records: per kind the proposals ("n <kind>") and those that
    improved on the best of their phase so far by the step rule's tolerance ("won <kind>");
    the local search's points also as "local own" / "local other" (the phase best's integer
    assignment kept or not)."""
    out = Counter()
    ints = space.int_mask
    best: dict[int, dict] = {}  # per phase: its best told record so far
    for r in records[:first]:
        b = best.get(r["restart"])
        kinds = [r["phase"]]
        if r["phase"] == "local" and b is not None:
            kinds.append("local own" if np.all(r["x"][ints] == b["x"][ints]) else "local other")
        for k in kinds:
            out[f"n {k}"] += 1
            if r["status"] == "ok" and b is not None and \
                    r["value"] < b["value"] - IMPROVEMENT_TOL * abs(b["value"]):
                out[f"won {k}"] += 1
        if r["status"] == "ok" and (b is None or r["value"] < b["value"]):
            best[r["restart"]] = r
    return out


def show_kinds(label: str, c: Counter) -> None:
    kinds = ("initial", "adaptive", "local", "local own", "local other", "random")
    print(f"    {label}: " + ", ".join(f"{k} {c[f'n {k}']} (improved {c[f'won {k}']})"
                                        for k in kinds if c[f"n {k}"]))


def show(label: str, a: dict) -> None:
    ph = " ".join(f"[{q['k']}:{q['start']}+{q['n']}{'d' if q['design'] else ''}"
                  f"{'*' if q['better'] else ''}]" for q in a["phases"])
    extra = f" ints wrong {a['ints_wrong']}" if "ints_wrong" in a else ""
    dist = a.get("after_distance")
    print(f"{label}: best {a['best']:.5g} at #{a['best_id']} (last improvement #"
          f"{a['last_improvement']} of {a['n']}){extra}")
    print(f"    phases {ph}")
    if dist:
        print(f"    after: {a['after']}; {a['after_assignments']} integer assignments, "
              f"{a['after_int_moves']:.2f} integers moved on average, distance median "
              f"{dist[0]:.3f} max {dist[1]:.3f}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="*", type=Path)
    ap.add_argument("--problem")
    ap.add_argument("--seeds", default="300-307")
    ap.add_argument("--budget", type=int, default=400)
    ap.add_argument("--variant", default="default")
    ap.add_argument("--setting", action="append", default=[], metavar="NAME=VALUE",
                    help="an optimiser setting changed (test functions; repeatable)")
    ap.add_argument("--first", type=int, default=None,
                    help="proposals counted by kind (default: all)")
    args = ap.parse_args(argv)
    settings = {}
    for item in args.setting:
        name, sep, value = item.partition("=")
        if not sep:
            ap.error(f"--setting {item!r}: expected NAME=VALUE")
        settings[name] = {"true": True, "false": False}.get(value.lower(), value)
    try:
        Settings.default().replace(**settings)
    except (TypeError, ValueError) as exc:
        ap.error(f"--setting: {exc}")
    first = args.first or 10 ** 9
    total = Counter()
    if args.problem:
        for seed in seeds_arg(args.seeds):
            recs, space, p = from_problem(args.problem, seed, args.budget, args.variant,
                                          settings)
            show(f"{args.problem} seed {seed}", analyse(recs, space, p))
            kinds = proposal_kinds(recs, space, first)
            show_kinds(f"first {min(first, len(recs))} by kind", kinds)
            total += kinds
    for run in args.runs:
        recs, space, _ = from_run(run)
        show(str(run), analyse(recs, space))
        kinds = proposal_kinds(recs, space, first)
        show_kinds(f"first {min(first, len(recs))} by kind", kinds)
        total += kinds
    if total:
        show_kinds("all runs", total)


if __name__ == "__main__":
    main()
