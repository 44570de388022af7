"""The paper's problem as an optimiser benchmark: many seeds of its three studies.

    python -m benchmarks.paper.paper_seeds [--seeds 1-8] [--cases single-F_max,single-E_max,moo]
                                     [--workers 2] [--runs bench-runs/paper-seeds] [--long 0]
                                     [--out RESULTS.csv]

For each case (configs/<case>.yaml: single-F_max and single-E_max with 200 evaluations, moo
with 400) and each seed, runs ``lccopt optimise`` on a copy of the case with that seed into
``RUNS/<case>-s<seed>/`` (a finished run is reused, an unfinished one resumed, so the script
can be stopped and started again). ``--long N`` adds one run of each case with N evaluations
(seed 1000) that only serves to find a better best-known value; ``--known CASE=VALUE`` gives a
better value found elsewhere (benchmarks/paper/paper_best_known.py re-evaluates the best designs of
any runs, e.g. of an earlier model or version, on the current model). ``--out`` writes one CSV
row per run (case, seed, budget, best value, regret ratio, the commit, the optimiser settings
the run recorded). The runs are lccopt's own: an experiment with the optimiser plugs into
``Strategy`` in an ask/tell loop of its own (benchmarks/optimiser/variants.py,
benchmarks/paper/paper_composite.py).

``--report-only`` starts, resumes and changes nothing: it summarises the finished runs in
RUNS (a missing or unfinished run is named and left out), with each run's wall time from its
journal (``--out``: the rows of RUNS' finished runs). ``--against DIR`` adds the finished runs
of DIR (another optimiser's runs of the same cases and seeds) side by side, on the seeds
finished in both, regret against the best of both: the designs evaluated in both runs of a
seed must have the same objectives (the same model), or it stops. ``--merge FILE...`` adds the
rows of earlier ``--out`` files (runs of another session whose folders are gone) for the seeds
RUNS lacks: they must have the reference value and the optimiser settings of RUNS' runs, and a
seed in both must have the same best value, or it stops; ``--out`` then holds them all.

Per case it prints the reference design's value, the best-known value (the best over all runs,
the long one included), the median and worst seed, and each seed's regret ratio
(f_seed - f_best) / (f_reference - f_best): 0 is the best known, 1 no better than the
reference design. The value is the objective itself for a single objective and the ASF of
Eq. (7) for moo (the case's fixed reference point and worst values, so values of different
runs compare).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def seeds_arg(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def run_one(case: str, seed: int, runs: Path, workers: int, budget: int | None = None) -> Path:
    """Optimise configs/CASE.yaml with SEED into RUNS/<name>; reuse or resume what is there."""
    name = f"{case}-s{seed}" + (f"-b{budget}" if budget else "")
    run = runs / name
    cases = runs / "cases"
    cases.mkdir(parents=True, exist_ok=True)
    text = (f"extends: {ROOT / 'configs' / (case + '.yaml')}\nname: {name}\n"
            f"optimisation:\n  seed: {seed}\n")
    if budget:
        text += f"  budget: {budget}\n"
    path = cases / f"{name}.yaml"
    path.write_text(text)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    exe = [sys.executable, "-m", "lccopt.cli"]
    if (run / "journal.jsonl").exists():
        cmd = exe + ["resume", str(run), "--workers", str(workers), "--case", str(path)]
    else:
        cmd = exe + ["optimise", str(path), "--runs", str(runs), "--workers", str(workers)]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    print(f"  {name}: {time.monotonic() - t0:.0f} s", file=sys.stderr)
    return run


def run_values(run: Path) -> dict:
    """Best value of the run, the reference design's value, and the best row's objectives."""
    with h5py.File(run / "results.h5", "r") as f:
        e = f["evaluations"]
        ok = e["status"].asstr()[()] == "ok"
        value = np.where(ok, e["value"][()], np.inf)
        i = int(np.argmin(value))
        ids = e["id"][()]
        ref_i = int(np.flatnonzero(ids == 0)[0])
        objectives = [str(k) for k in f.attrs["objectives"]] if "objectives" in f.attrs else []
        return {"best": float(value[i]), "reference": float(e["value"][ref_i]), "id": int(ids[i]),
                "objectives": {k: float(e[k][i]) for k in objectives if k in e},
                "n": int(f.attrs["n_evaluations"])}


def finished_values(run: Path) -> dict | None:
    """``run_values`` of a finished run (its budget evaluated, nothing pending), else None."""
    if not (run / "results.h5").exists():
        return None
    with h5py.File(run / "results.h5", "r") as f:
        done = (int(f.attrs["n_evaluations"]) >= int(f.attrs["budget"])
                and int(f.attrs.get("n_pending", 0)) == 0)
    return run_values(run) if done else None


def wall_time(run: Path) -> float:
    """The run's wall time: the sum over the sessions its journal recorded."""
    import json

    with (run / "journal.jsonl").open() as fh:
        return sum(e.get("wall_time", 0.0) for e in map(json.loads, fh)
                   if e.get("event") == "session")


def shared_designs(a: Path, b: Path) -> int:
    """How many designs runs A and B both evaluated; stops if any has other objectives there
    (the runs were made on different models, so their values do not compare)."""
    def table(run: Path) -> dict:
        with h5py.File(run / "results.h5", "r") as f:
            e = f["evaluations"]
            ok = e["status"].asstr()[()] == "ok"
            cols = [str(k) for k in f.attrs["objective_columns"]]
            obj = np.column_stack([e[k][()] for k in cols])[ok]
            return {x.tobytes(): o for x, o in zip(e["x"][()][ok], obj)}

    ta, tb = table(a), table(b)
    common = set(ta) & set(tb)
    if any(not np.array_equal(ta[k], tb[k]) for k in common):
        sys.exit(f"{a} and {b}: the same design with other objectives (other models)")
    return len(common)


def stored_run(run: Path) -> dict | None:
    """A finished run as a CSV row holds it: ``finished_values`` plus its budget, wall time,
    recorded optimiser settings and commit (None: this checkout's)."""
    import json

    got = finished_values(run)
    if got is None:
        return None
    first = json.loads((run / "journal.jsonl").open().readline())
    return {**got, "budget": int(first["budget"]), "wall": wall_time(run), "commit": None,
            "settings": json.dumps(first.get("optimiser"), sort_keys=True, separators=(",", ":"))}


def merged_rows(paths: list[str]) -> dict:
    """{(case, seed): stored run} from earlier ``--out`` files."""
    import csv

    out = {}
    for path in paths:
        with open(path, newline="") as fh:
            for r in csv.DictReader(fh):
                out[r["case"], int(r["seed"])] = {
                    "best": float(r["best"]), "reference": float(r["reference"]),
                    "budget": int(r["budget"]), "commit": r["commit"], "settings": r["settings"],
                    "wall": float(r["wall_s"]) if r.get("wall_s") else float("nan")}
    return out


def _merge(case: str, seed: int, got, earlier: dict | None):
    """The run of RUNS, or the earlier row where RUNS has none; stops where they disagree."""
    if earlier is None:
        return got
    if got is not None and got["best"] != earlier["best"]:
        sys.exit(f"{case} seed {seed}: best {got['best']!r} here, {earlier['best']!r} in --merge "
                 "(another optimiser or model)")
    return got or earlier


def report_only(cases: list[str], seeds: list[int], runs: Path, against: Path | None,
                known: dict, merge: dict | None = None) -> list:
    """Summarise the finished runs of RUNS (with MERGE's rows, or AGAINST side by side); run
    nothing. Returns (case, seed, stored run, regret, best known) rows for ``write_rows``."""
    merge = merge or {}
    folders = [runs] + ([against] if against else [])
    table, rows = [], []
    for case in cases:
        res: dict[Path, dict] = {d: {} for d in folders}
        for s in seeds:
            got = {d: stored_run(d / f"{case}-s{s}") for d in folders}
            got[runs] = _merge(case, s, got[runs], merge.get((case, s)))
            if any(v is None for v in got.values()):
                missing = ", ".join(str(d) for d, v in got.items() if v is None)
                print(f"  {case} seed {s}: no finished run in {missing}; left out",
                      file=sys.stderr)
                continue
            if against:
                shared_designs(runs / f"{case}-s{s}", against / f"{case}-s{s}")
            for d in folders:
                res[d][s] = got[d]
        done = sorted(res[runs])
        if not done:
            print(f"\n{case}: no seed finished in every folder")
            continue
        for what in ("reference", "settings"):
            seen = {r[what] for d in folders for r in res[d].values()}
            if len(seen) > 1 and (what == "reference" or not against):
                sys.exit(f"{case}: the runs have {len(seen)} values of {what} "
                         f"({'other models' if what == 'reference' else 'other optimisers'})")
        f_ref = res[runs][done[0]]["reference"]
        f_best = min([r["best"] for d in folders for r in res[d].values()]
                     + ([known[case]] if case in known else []))
        print(f"\n{case}: per seed (best value, regret ratio) in " + " | ".join(map(str, folders)))
        row = [case, f"{len(done)}", f"{f_best:.5g}"]
        walls = []
        regrets = {d: {s: (r["best"] - f_best) / (f_ref - f_best) for s, r in res[d].items()}
                   for d in folders}
        for d in folders:
            row.append(f"{statistics.median(regrets[d].values()):.3f} / "
                       f"{max(regrets[d].values()):.3f}")
            walls.append(statistics.median(res[d][s]["wall"] for s in done))
        rows += [(case, s, res[runs][s], regrets[runs][s], f_best) for s in done]
        for s in done:
            print(f"  seed {s}: " + " | ".join(f"{res[d][s]['best']:.5g}  regret "
                                               f"{regrets[d][s]:.3f}" for d in folders))
        table.append(row + [" / ".join(f"{w:.0f}" for w in walls)])
    print("\n| case | seeds | best known | " + " | ".join(
        f"{d} median / worst regret" for d in folders) + " | wall time per run, median (s) |")
    print("|---" * (len(folders) + 4) + "|")
    for row in table:
        print("| " + " | ".join(row) + " |")
    return rows


def write_rows(path: str, rows: list, made_by: str | None) -> None:
    """One CSV row per run: case, seed, budget, best, regret ratio, reference, best known,
    commit, settings, wall time."""
    import csv

    from benchmarks.support.runs_table import commit

    with open(path, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["case", "seed", "budget", "best", "regret", "reference", "best_known",
                    "commit", "settings", "wall_s"])
        for case, s, run, regret, f_best in rows:
            w.writerow([case, s, run["budget"], repr(run["best"]), f"{regret:.6g}",
                        repr(run["reference"]), repr(f_best),
                        run["commit"] or made_by or commit(), run["settings"],
                        f"{run['wall']:.0f}"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1-8")
    ap.add_argument("--cases", default="single-F_max,single-E_max,moo")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--runs", default="bench-runs/paper-seeds")
    ap.add_argument("--long", type=int, default=0,
                    help="budget of one extra long run per case (0: none)")
    ap.add_argument("--known", nargs="*", default=[], metavar="CASE=VALUE",
                    help="best-known values found elsewhere (benchmarks/paper/paper_best_known.py)")
    ap.add_argument("--out", default=None, help="CSV file: one row per run")
    ap.add_argument("--commit", default=None,
                    help="the commit that made the runs, for --out (default: this checkout's)")
    ap.add_argument("--report-only", action="store_true",
                    help="summarise the finished runs in RUNS only: start or resume nothing")
    ap.add_argument("--against", default=None, metavar="DIR",
                    help="with --report-only: the finished runs of DIR side by side")
    ap.add_argument("--merge", nargs="+", default=[], metavar="FILE",
                    help="with --report-only: rows of earlier --out files for seeds RUNS lacks")
    args = ap.parse_args()
    known = {k: float(v) for k, _, v in (item.partition("=") for item in args.known)}
    runs = Path(args.runs)
    seeds = seeds_arg(args.seeds)
    if args.report_only or args.against or args.merge:
        if not args.report_only or args.long or (args.against and args.merge):
            ap.error("--against and --merge (one of them) need --report-only, which does not "
                     "take --long")
        rows = report_only(args.cases.split(","), seeds, runs,
                           Path(args.against) if args.against else None, known,
                           merged_rows(args.merge))
        if args.out:
            write_rows(args.out, rows, args.commit)
        return
    rows = []
    for case in args.cases.split(","):
        results = {s: run_values(run_one(case, s, runs, args.workers)) for s in seeds}
        long = run_values(run_one(case, 1000, runs, args.workers, args.long)) if args.long else None
        f_ref = results[seeds[0]]["reference"]
        f_best = min([r["best"] for r in results.values()] + ([long["best"]] if long else [])
                     + ([known[case]] if case in known else []))
        regret = {s: (r["best"] - f_best) / (f_ref - f_best) for s, r in results.items()}
        vals = sorted(r["best"] for r in results.values())
        rows.append((case, f_ref, f_best, statistics.median(vals), vals[-1],
                     statistics.median(regret.values()), max(regret.values()), regret, long))
        print(f"\n{case}: per seed (best value, regret ratio, best evaluation)")
        for s, r in results.items():
            objs = ", ".join(f"{k} {v:.5g}" for k, v in r["objectives"].items())
            print(f"  seed {s}: {r['best']:.5g}  regret {regret[s]:.3f}  #{r['id']}  ({objs})")
        if long:
            print(f"  long run ({long['n']} evaluations, seed 1000): {long['best']:.5g}")
        if case in known:
            print(f"  known from elsewhere (--known): {known[case]:.5g}")
    if args.out:
        write_rows(args.out, [(case, s, stored_run(runs / f"{case}-s{s}"), regret[s], f_best)
                              for case, _, f_best, _, _, _, _, regret, _ in rows
                              for s in sorted(regret)], args.commit)
    print("\n| case | reference | best known | median seed | worst seed | median regret "
          "| worst regret |")
    print("|---|---|---|---|---|---|---|")
    for case, f_ref, f_best, med, worst, mreg, wreg, _, _ in rows:
        print(f"| {case} | {f_ref:.5g} | {f_best:.5g} | {med:.5g} | {worst:.5g} | {mreg:.3f} "
              f"| {wreg:.3f} |")


if __name__ == "__main__":
    main()
