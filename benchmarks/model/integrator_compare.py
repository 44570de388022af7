"""The simulator of this checkout against another one (e.g. main before a change of the
integrator), side by side: the same outputs bit for bit, and the time of the same runs.

    python -m benchmarks.model.integrator_compare --before DIR [--rounds 5] [--repeat 5] \
        [--no-speed]

DIR is another checkout of lccopt (e.g. ``git worktree add --detach /tmp/before main``). Each
checkout runs in its own subprocess (``PYTHONPATH=<checkout>``, one BLAS thread); the timing
rounds alternate between the two, so that the machine's load hits both alike.

Identity: every integrator path the package has, each run once in both checkouts and every
array compared for exact equality (or the largest relative difference where not equal): the
three-dof vehicle on the reference design and a lively one (one moving contact), a rough rail,
the VIRM half car leaving over a rough rail and the freight wagon (four contacts), a bogie,
sleepers over voids under the three-dof vehicle and the half car (unilateral supports), a
moving constant force (from a given state, and over voids), a vehicle started off its rest
shape, and the settlement prediction of configs/settlement.yaml (the bogie over unilateral
supports, re-simulated block by block).

Speed: per round and checkout, the median of ``--repeat`` evaluations (after one warm-up) of
the reference design (configs/reference.yaml), the VIRM half car leaving over the rough rail
(configs/traffic.yaml), the reference design with three sleepers over voids, and one
``lccopt simulate configs/settlement.yaml`` (the command as a user runs it: start-up, the
prediction, its files and plots). Times are CPU seconds of the process (of the command's
process for ``lccopt simulate``): on a machine shared with other work the wall time measures
the others' load as much as this code; the wall time of the command is printed too. Each round
also runs the checkout's own ``benchmarks/model/simulator_speed.py --naive-steps 0`` and takes its
figure for the current method (the median wall time of ``--repeat`` reference evaluations).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CASES = ROOT / "configs"
LIVELY = [300e6, 100e6, 60e6, 6, 6, 6, 4, 40]


def _env(tree: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[var] = "1"
    return env


# --- run inside a checkout ---------------------------------------------------------------

def _integrators():
    """(integrate, integrate over unilateral supports) of the checkout on the path."""
    from lccopt.vti import newmark, unilateral

    over_supports = getattr(unilateral, "integrate_unilateral", None) or newmark.integrate
    return newmark.integrate, over_supports


def _history(out: dict, name: str, h) -> None:
    for field in ("time", "position", "contact_force", "rail_displacement",
                  "vehicle_displacement", "dof_displacement", "dof_velocity", "wheel_position",
                  "wheel_force", "wheel_rail_displacement", "support_force", "support_contact"):
        value = getattr(h, field, None)
        if value is not None:
            out[f"{name}/{field}"] = value
    for k, v in (getattr(h, "info", None) or {}).items():
        out[f"{name}/info/{k}"] = v


def _evaluation(out: dict, name: str, ev) -> None:
    import numpy as np

    for k, v in ev.objectives.items():
        out[f"{name}/objective/{k}"] = np.float64(v)
    for k, v in ev.histories.items():
        out[f"{name}/history/{k}"] = np.asarray(v)
    for k, v in ev.info.items():
        if "wall_time" not in k and isinstance(v, (int, float)):
            out[f"{name}/info/{k}"] = v


def _voids(n, at, gaps):
    import numpy as np

    g = np.zeros(n)
    g[list(at)] = gaps
    return g


def identity_outputs(path: str, settlement: bool) -> None:
    """Every path's outputs into the npz file ``path``."""
    import numpy as np

    from lccopt.config import load_case
    from lccopt.problem import evaluate
    from lccopt.vti import passage as vti
    from lccopt.vti.specs import TrackVariation
    from lccopt.vti.track import WinklerBeam, build_track
    from lccopt.vti.unilateral import sleeper_supports
    from lccopt.vti.vehicle import build_vehicle

    integrate, over_supports = _integrators()
    out: dict = {}
    ref = load_case(CASES / "reference.yaml")
    _evaluation(out, "reference", evaluate(ref, ref.reference))
    lively = ref.check_design(np.array(LIVELY, float))
    _evaluation(out, "lively", evaluate(ref, lively))
    traffic = load_case(CASES / "traffic.yaml")
    names = [c.name for c in traffic.traffic]
    for cond in ("virm-140-leave-rough", "freight-100-enter-rough", "virm-80-enter-rough"):
        case = traffic.condition_case(names.index(cond))
        _evaluation(out, cond, evaluate(case, case.reference))
    with tempfile.TemporaryDirectory() as tmp:     # the three-dof vehicle on a rough rail
        (Path(tmp) / "rough.yaml").write_text(
            f"extends: {CASES / 'reference.yaml'}\nname: rough\nsimulation:\n  irregularity:\n"
            "    {spectrum: erri-low, seed: 2, wavelengths: [3.0, 25.0]}\n")
        rough = load_case(Path(tmp) / "rough.yaml")
        _evaluation(out, "three-dof-rough", evaluate(rough, rough.reference))
    bogie = load_case(CASES / "vehicles" / "virm-bogie.yaml")
    _evaluation(out, "bogie", evaluate(bogie, bogie.check_design(np.array(LIVELY, float))))
    half = traffic.condition_case(names.index("virm-140-leave-rough"))
    for name, case in (("voids-three-dof", ref), ("voids-half-car", half)):
        sc = case.scenario()
        entry = _voids(400, [1, 2, 4, 7], [1.5e-3, 0.3e-3, 0.1e-3, 0.2e-3])
        variation = TrackVariation(void=(entry, _voids(400, [3], [0.4e-3])))
        _evaluation(out, name, vti.simulate_passage(dataclasses.replace(sc, variation=variation),
                                            case.track_design(case.reference)))

    # a moving force from a given state, a vehicle off its rest shape, a force over voids
    beam = WinklerBeam.build(40.0, 0.1, 210e9 * 2.337e-5, 54.4, 100e6)
    n = beam.K.shape[0]
    rng = np.random.default_rng(3)
    u0, v0 = 1e-4 * rng.standard_normal(n), 1e-3 * rng.standard_normal(n)
    _history(out, "load-initial", integrate(beam, 2e-4, 60.0, 10.0, 300, load=80e3,
                                            initial=(u0, v0), record_dofs=np.arange(0, n, 37)))
    quarter = load_case(CASES / "reference.yaml")
    quarter.data["vehicle"]["model"] = "quarter-car"
    veh = build_vehicle(quarter.scenario().vehicle)
    _history(out, "vehicle-offset", integrate(beam, 1e-4, 0.0, 20.0, 400, vehicle=veh,
                                              vehicle_offset=np.array([1e-4, -5e-5, 2e-5])))
    tr = build_track(ref.scenario(), ref.track_design(lively))
    sup = sleeper_supports(tr, np.arange(0, 30))
    sup = sup.with_gaps(_voids(30, [1, 2, 5], [0.5e-3, 0.2e-3, 0.1e-3]))
    x0 = float(tr.window[0])
    _history(out, "load-voids", over_supports(tr, 5e-4, 38.9, x0, 600, load=90e3, supports=sup,
                                              record_dofs=sup.dof))
    _history(out, "load-voids-leave", over_supports(tr, 5e-4, -38.9, x0 + 10.0, 300, load=90e3,
                                                    supports=sup))
    _history(out, "quarter-car-voids", over_supports(tr, 5e-4, 38.9, x0, 600, vehicle=veh,
                                                     supports=sup, record_dofs=sup.dof))
    if settlement:
        case = load_case(CASES / "settlement.yaml")
        _evaluation(out, "settlement", evaluate(case, case.reference))
    np.savez(path, **out)


def timings(repeat: int) -> None:
    """Median seconds of each timed evaluation, as JSON on stdout."""
    import numpy as np

    from lccopt.config import load_case
    from lccopt.problem import evaluate
    from lccopt.vti import passage as vti
    from lccopt.vti.specs import TrackVariation

    ref = load_case(CASES / "reference.yaml")
    traffic = load_case(CASES / "traffic.yaml")
    half = traffic.condition_case([c.name for c in traffic.traffic].index("virm-140-leave-rough"))
    voided = dataclasses.replace(ref.scenario(), variation=TrackVariation(
        void=(_voids(400, [1, 2, 4], [1.5e-3, 0.3e-3, 0.1e-3]), np.zeros(400))))
    runs = {
        "reference": lambda: evaluate(ref, ref.reference),
        "half-car": lambda: evaluate(half, half.reference),
        "voids": lambda: vti.simulate_passage(voided, ref.track_design(ref.reference)),
    }
    result = {}
    for name, run in runs.items():
        run()
        times = []
        for _ in range(repeat):
            t0 = time.process_time()
            run()
            times.append(time.process_time() - t0)
        result[name] = statistics.median(times)
    print(json.dumps(result))


# --- the comparison ------------------------------------------------------------------------

def _run_in(tree: Path, *args: str) -> str:
    cmd = [sys.executable, str(Path(__file__).resolve()), *args]
    done = subprocess.run(cmd, env=_env(tree), cwd=tree, capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"{tree}: {' '.join(args)} failed:\n{done.stderr}")
    return done.stdout


def compare_identity(before: Path, after: Path, settlement: bool) -> bool:
    import numpy as np

    with tempfile.TemporaryDirectory() as tmp:
        files = {}
        for label, tree in (("before", before), ("after", after)):
            files[label] = Path(tmp) / f"{label}.npz"
            args = ["--outputs", str(files[label])] + (["--settlement"] if settlement else [])
            _run_in(tree, *args)
        a, b = np.load(files["before"]), np.load(files["after"])
        same = True
        for key in sorted(set(a.files) | set(b.files)):
            if key not in a.files or key not in b.files:
                print(f"  {key}: only {'after' if key in b.files else 'before'}")
                same = False
                continue
            x, y = a[key], b[key]
            if x.shape != y.shape:
                print(f"  {key}: shape {x.shape} before, {y.shape} after")
                same = False
            elif not np.array_equal(x, y, equal_nan=True):
                scale = max(float(np.max(np.abs(x))), 1e-300)
                print(f"  {key}: differs, max |diff| / max |value| "
                      f"{float(np.max(np.abs(x.astype(float) - y.astype(float)))) / scale:.2e}")
                same = False
        print(f"identity: {len(a.files)} arrays, "
              + ("all bit for bit" if same else "NOT all bit for bit (above)"))
        return same


def _settlement(tree: Path) -> tuple[float, float]:
    """(CPU seconds, wall seconds) of ``lccopt simulate configs/settlement.yaml``."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "lccopt", "simulate", str(CASES / "settlement.yaml"),
               "--out", str(Path(tmp) / "out")]
        t0, c0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
        done = subprocess.run(cmd, env=_env(tree), cwd=tree, capture_output=True, text=True)
        c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        wall = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"{tree}: lccopt simulate failed:\n{done.stderr}")
    return c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime, wall


def _simulator_speed(tree: Path, repeat: int) -> float:
    """The checkout's own simulator_speed.py: its median of the current method [s]."""
    script = tree / "benchmarks" / "model" / "simulator_speed.py"
    if not script.exists():  # a checkout from before benchmarks/ had subfolders
        script = tree / "benchmarks" / "simulator_speed.py"
    cmd = [sys.executable, str(script), "--naive-steps", "0",
           "--repeat", str(repeat), "--case", str(CASES / "reference.yaml")]
    done = subprocess.run(cmd, env=_env(tree), cwd=tree, capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"{tree}: simulator_speed.py failed:\n{done.stderr}")
    line = next(x for x in done.stdout.splitlines() if "evaluate: median" in x)
    return float(line.split("median")[1].split()[0])


def compare_speed(before: Path, after: Path, rounds: int, repeat: int) -> None:
    got = {"before": [], "after": []}
    for r in range(rounds):
        order = (("before", before), ("after", after))
        for label, tree in (order if r % 2 == 0 else order[::-1]):
            t = json.loads(_run_in(tree, "--timings", str(repeat)))
            t["settlement (lccopt simulate)"], t["  its wall time"] = _settlement(tree)
            t["simulator_speed.py (wall)"] = _simulator_speed(tree, repeat)
            got[label].append(t)
            print(f"  round {r + 1} {label:6s} "
                  + ", ".join(f"{k} {v:.3f} s" for k, v in t.items()), flush=True)
    print(f"medians over {rounds} rounds, CPU seconds but where it says wall (1-min load "
          f"average now {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores):")
    for key in got["before"][0]:
        b = statistics.median(t[key] for t in got["before"])
        a = statistics.median(t[key] for t in got["after"])
        print(f"  {key:30s} before {b:7.3f} s   after {a:7.3f} s   after/before {a / b:.3f}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", type=Path, help="the other checkout")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-speed", action="store_true")
    ap.add_argument("--no-settlement", action="store_true",
                    help="leave the settlement prediction out of the identity check")
    ap.add_argument("--outputs", help=argparse.SUPPRESS)
    ap.add_argument("--settlement", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--timings", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.outputs:
        identity_outputs(args.outputs, args.settlement)
        return
    if args.timings:
        timings(args.timings)
        return
    if args.before is None:
        ap.error("--before DIR is required")
    before = args.before.resolve()
    print(f"before: {before}, after: {ROOT}")
    same = compare_identity(before, ROOT, not args.no_settlement)
    if not args.no_speed:
        compare_speed(before, ROOT, args.rounds, args.repeat)
    raise SystemExit(0 if same else 1)


if __name__ == "__main__":
    main()
