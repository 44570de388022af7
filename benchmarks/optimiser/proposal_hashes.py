"""Fingerprints of the optimiser's proposals: does a change of lccopt/optim change them?

    python -m benchmarks.optimiser.proposal_hashes --out benchmarks/results/proposal-hashes.json
    python -m benchmarks.optimiser.proposal_hashes --check benchmarks/results/proposal-hashes.json
    # one group (see GROUPS)
    python -m benchmarks.optimiser.proposal_hashes --check FILE --only broad

Each item runs the optimiser and hashes (sha256) the sequence of its proposals (id, x as
exact floats, phase, restart). Groups:

* ``engine-fake``: ``lccopt optimise`` on copies of the bundled cases (quickstart, moo,
  single-F_max, single-E_max; the ASF's worst values raised to fit the stand-in's
  objectives) with the stand-in evaluator ``tests.engine.fakesim:evaluate``: the scalar
  surrogate through bound probes and a subspace phase (single-F_max, seed 2), the sleeper
  energies' composite surrogate and the ASF's through a fresh restart, one and two workers.
* ``engine-real``: the same through the real simulator with a short, coarse simulation
  (single-F_max, single-E_max, quickstart at 50-60 evaluations).
* ``broad``: every problem of the broad benchmark (benchmarks/support/problems.py), seeds 0-2,
  budget 150, serial ask/tell as benchmarks/optimiser/optimiser.py runs them.
* ``off-switch``: the tests' off-switch functions (an integer whose bound is best behind a
  wall), scalar and composite surrogates, two evaluations in flight: bound probes, subspace
  phases, their trial, a composite run's stalled-phase step.

Hashes depend on the machine (BLAS kernels, numpy and scipy versions): compare them on one
machine. ``--check`` exits 1 and names the items that differ.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

from benchmarks.support import problems  # noqa: E402
from lccopt.optim.space import DesignSpace  # noqa: E402
from lccopt.optim.strategy import Strategy  # noqa: E402

FAKE = "tests.engine.fakesim:evaluate"
REAL = "lccopt.problem:evaluate"
ASF_FOR_FAKE = "  asf:\n    worst: [60000.0, 5.0]\n"
CHEAP = ("simulation:\n  time_step: 1.0e-3\n  element_length: 0.1\n  far_element_length: 0.1\n"
         "  run_in: 3.0\n  run_out: 1.0\n")

# name: (case, seed, budget, workers, evaluator, extra YAML)
ENGINE_RUNS = {
    "quickstart-fake": ("quickstart", 1, 100, 1, FAKE, ASF_FOR_FAKE),
    "moo-fake-s2": ("moo", 2, 180, 1, FAKE, ASF_FOR_FAKE),
    "single-F_max-fake-s2": ("single-F_max", 2, 200, 1, FAKE, ""),
    "single-F_max-fake-s1-w2": ("single-F_max", 1, 160, 2, FAKE, ""),
    "single-E_max-fake-s1": ("single-E_max", 1, 160, 1, FAKE, ""),
    "single-E_max-fake-s3-w2": ("single-E_max", 3, 130, 2, FAKE, ""),
    "single-F_max-real": ("single-F_max", 1, 60, 1, REAL, CHEAP),
    "single-E_max-real": ("single-E_max", 1, 60, 1, REAL, CHEAP),
    "quickstart-real": ("quickstart", 1, 50, 1, REAL, CHEAP),
}
GROUPS = ("engine-fake", "engine-real", "broad", "off-switch")


def digest(proposals: list) -> str:
    """sha256 of the proposals (id, x, phase, restart); floats by their exact repr."""
    text = json.dumps([[int(i), [float(v) for v in x], str(ph), int(r)]
                       for i, x, ph, r in proposals], separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def engine_run(name: str, work: Path) -> list:
    case, seed, budget, workers, evaluator, extra = ENGINE_RUNS[name]
    path = work / f"{name}.yaml"
    path.write_text(f"extends: {ROOT / 'configs' / (case + '.yaml')}\nname: {name}\n"
                    f"optimisation:\n  seed: {seed}\n  budget: {budget}\n"
                    + extra, encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "LCCOPT_EVALUATOR": evaluator}
    cmd = [sys.executable, "-c", "import sys; from lccopt.cli import main; sys.exit(main())",
           "optimise", str(path), "--workers", str(workers), "--runs", str(work / "runs")]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{name}: lccopt optimise failed ({r.returncode}):\n{r.stderr}")
    lines = (work / "runs" / name / "journal.jsonl").read_text().splitlines()
    events = [json.loads(line) for line in lines]
    return [(e["id"], e["x"], e["phase"], e["restart"]) for e in events if e["event"] == "asked"]


def serial_run(s: Strategy, f, outputs=None) -> list:
    while not s.done:
        props = s.ask(1)
        if not props:
            break
        for p in props:
            if outputs is None:
                s.tell(p.id, f(p.x))
            else:
                F = outputs(p.x)
                s.tell(p.id, float(F.sum()), F)
    return [(r["id"], r["x"], r["phase"], r["restart"]) for r in s.history]


def delayed_run(s: Strategy, f, outputs=None, workers: int = 2) -> list:
    """``workers`` proposals in flight, told oldest first (as the engine does)."""
    pending = []
    while not s.done:
        pending += s.ask(workers - len(pending))
        if not pending:
            break
        p = pending.pop(0)
        if outputs is None:
            s.tell(p.id, f(p.x))
        else:
            F = outputs(p.x)
            s.tell(p.id, float(F.sum()), F)
    return [(r["id"], r["x"], r["phase"], r["restart"]) for r in s.history]


# -- the tests' off-switch functions (tests/optim/test_strategy.py) -----------------------------
OFF_SWITCH_SPACE = DesignSpace(["x", "y", "n"], [0.0, 0.0, 0], [1.0, 1.0, 100],
                               [False, False, True])


def off_switch(x):
    n = x[2]
    wall = 0.0 if n == 0 else (3.0 if n <= 15 else 1.0 + (n - 70) ** 2 / 2000)
    return (x[0] - 0.6) ** 2 + (x[1] - 0.3) ** 2 + wall


def off_switch_elsewhere(x):
    if x[2] == 0:
        return (x[0] - 0.2) ** 2 + (x[1] - 0.8) ** 2
    wall = 3.0 if x[2] <= 15 else 0.1 + (x[2] - 70) ** 2 / 500
    return (x[0] - 0.7) ** 2 + (x[1] - 0.3) ** 2 + wall


def off_switch_poor(x):
    return off_switch_elsewhere(x) + (0.5 if x[2] == 0 else 0.0)


def two_outputs(f):
    def outputs(x):
        g = (x[1] - 0.3) ** 2
        return np.array([f(x) - g, g])
    return outputs


def off_switch_items() -> dict:
    funs = {"plain": off_switch, "elsewhere": off_switch_elsewhere, "poor": off_switch_poor}
    out = {}
    for fname, f in funs.items():
        for seed in range(3):
            s = Strategy(OFF_SWITCH_SPACE, budget=100, n_initial=10, seed=seed)
            out[f"off-switch-{fname}-scalar-s{seed}"] = lambda s=s, f=f: delayed_run(s, f)

            def composite(seed=seed, f=f):
                c = Strategy(OFF_SWITCH_SPACE, budget=150, n_initial=10, seed=seed, composite=True)
                c.set_aggregate(lambda F: F.sum(axis=1))
                return delayed_run(c, f, outputs=two_outputs(f))
            out[f"off-switch-{fname}-composite-s{seed}"] = composite
    return out


def broad_items() -> dict:
    out = {}
    for name in problems.BENCHMARK:
        for seed in range(3):
            def run(name=name, seed=seed):
                p = problems.get(name)
                return serial_run(Strategy(p.space, budget=150, n_initial=20, seed=seed), p)
            out[f"broad-{name}-s{seed}"] = run
    return out


def items(groups: list[str], work: Path) -> dict:
    out = {}
    for g in groups:
        if g in ("engine-fake", "engine-real"):
            ev = FAKE if g == "engine-fake" else REAL
            for name, spec in ENGINE_RUNS.items():
                if spec[4] == ev:
                    out[name] = lambda name=name: engine_run(name, work)
        elif g == "broad":
            out.update(broad_items())
        elif g == "off-switch":
            out.update(off_switch_items())
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", help="write the hashes to this JSON file")
    ap.add_argument("--check", help="compare with the hashes of this JSON file")
    ap.add_argument("--only", nargs="+", choices=GROUPS, default=list(GROUPS))
    args = ap.parse_args(argv)
    stored = json.loads(Path(args.check).read_text())["hashes"] if args.check else {}
    hashes, differ = {}, []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="lccopt-hashes-") as tmp:
        for name, run in items(args.only, Path(tmp)).items():
            props = run()
            hashes[name] = {"sha256": digest(props), "proposals": len(props),
                            "restarts": max(p[3] for p in props)}
            same = ""
            if args.check:
                old = stored.get(name, {}).get("sha256")
                same = (" same" if old == hashes[name]["sha256"]
                        else " NEW" if old is None else " DIFFERS")
                if old is not None and old != hashes[name]["sha256"]:
                    differ.append(name)
            print(f"{name}: {hashes[name]['sha256'][:16]} ({len(props)} proposals, "
                  f"{hashes[name]['restarts']} restarts){same}", flush=True)
    print(f"# {len(hashes)} items, {time.perf_counter() - t0:.0f} s")
    if args.out:
        import scipy

        from lccopt.engine.rundir import versions
        old = json.loads(Path(args.out).read_text())["hashes"] if Path(args.out).exists() else {}
        doc = {"format": "lccopt-proposal-hashes/1", "made": time.strftime("%Y-%m-%d %H:%M:%S"),
               "machine": platform.node(), "versions": versions(), "numpy": np.__version__,
               "scipy": scipy.__version__, "hashes": {**old, **hashes}}
        Path(args.out).write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")
    if differ:
        print("DIFFERENT: " + ", ".join(differ))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
