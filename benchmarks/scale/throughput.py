"""Throughput of the run engine against the number of workers, and the time of a proposal.

    python -m benchmarks.scale.throughput       # quickstart case, 40 evaluations, 1 and 2 workers
    python -m benchmarks.scale.throughput --budget 60 --workers 1 2 4
    # the tests' coarse simulation
    python -m benchmarks.scale.throughput --cheap --workers 2 --repeat 3
    python -m benchmarks.scale.throughput --conditions 1 2 6 --workers 1 2  # traffic conditions

Scale on any machine, with the stand-in evaluator (benchmarks/scale/standin.py: it sleeps, so 128
workers need no 128 cores):

    python -m benchmarks.scale.throughput --standin 0.15 --workers 2 8 16 32 64 --budget 240 \
        --from 80
    python -m benchmarks.scale.throughput --standin 0.15 --dask --workers 16 64 --budget 240 \
        --from 80
    python -m benchmarks.scale.throughput --standin 0.5 --case configs/traffic.yaml --workers 64 \
        --budget 40 --from 10 --initial 10
    python -m benchmarks.scale.throughput --asks --case configs/moo.yaml --points 1000 --batch \
        1 16 64

For each worker count, runs the case into a temporary run directory and reads the engine's
own accounting from the journal's ``session`` line:

* wall: the ask/evaluate/tell loop (worker start-up excluded, printed apart);
* throughput = evaluations / wall; with ``--from N``, the marginal throughput between the
  N-th committed evaluation and the last (the journal's commit times: start-up, the initial
  design and the reference design running alone left out);
* efficiency: with ``--standin D``, throughput / (workers / D) (what the workers could do if
  never idle); else throughput(n) / (n * throughput(first count));
* optimiser = time in ask/tell; bookkeeping = journal, state snapshots, results.h5, files
  written by the engine process; overhead = (optimiser + bookkeeping) / wall;
* busy = total evaluation time / (workers * wall): the share of worker time spent evaluating;
* held = worker time idle because the next proposal waited for an earlier evaluation still
  running (the reproducible order, lccopt/engine/schedule.py), share of workers * wall.

``--dask`` starts a Dask scheduler and ``dask worker --nworkers N --nthreads 1`` as
subprocesses of this machine (N = the worker count) and runs through ``--scheduler``.
``--profile`` runs the engine under cProfile and prints where its time goes.

``--asks`` measures the optimiser alone (no engine, no processes): a Strategy on the case's
design space told the stand-in's values, asked in blocks of ``--batch`` points; prints the
time of an ask (per block and per point) at each multiple of 100 points.

``--conditions`` gives every design that many traffic conditions (VIRM at speeds from 80 to
160 km/h, both directions; one task per design and condition) and reports designs and
simulations per second. ``--cheap`` uses the tests' coarse simulation settings
(tests/conftest.py, ~0.1-0.2 s per evaluation); ``--repeat`` runs each worker count several
times (interleaved) and prints every run and the median.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # as the lccopt command does (lccopt/cli.py)

import argparse  # noqa: E402
import contextlib  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
STANDIN = "benchmarks.scale.standin:evaluate"

CHEAP = """\
simulation:
  time_step: 1.0e-3
  element_length: 0.1
  far_element_length: 0.1
  run_in: 3.0
  run_out: 1.0
"""  # as tests/conftest.py CHEAP_SIMULATION


def conditions_yaml(n: int) -> str:
    """n traffic conditions: the case's vehicle at speeds from 80 to 160 km/h, both directions."""
    if n <= 1:
        return ""
    speeds = np.linspace(80.0, 160.0, n) / 3.6
    return "conditions:\n" + "".join(
        f"  - {{name: c{i}, speed: {float(v)!r}, "
        f"direction: {'enter' if i % 2 == 0 else 'leave'}}}\n"
        for i, v in enumerate(speeds))


class CpuSampler:
    """CPU time [s] of this process and of all its descendants (the workers and their forked
    children, or the Dask processes), sampled every 0.2 s from /proc, so that the CPU per
    evaluation between two moments of a run (start-up left out) can be read off."""

    def __init__(self):
        import threading

        self.samples: list[tuple[float, float, float]] = []
        self._stop = threading.Event()
        self._tick = os.sysconf("SC_CLK_TCK")
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()

    def _stat(self) -> dict[int, tuple[int, float]]:
        out = {}
        for d in os.listdir("/proc"):
            if d.isdigit():
                try:
                    with open(f"/proc/{d}/stat") as fh:
                        f = fh.read().rsplit(")", 1)[1].split()
                except OSError:
                    continue
                # ppid; utime + stime + cutime + cstime (children already waited for)
                out[int(d)] = (int(f[1]), sum(int(v) for v in f[11:15]) / self._tick)
        return out

    def _run(self) -> None:
        me = os.getpid()
        while not self._stop.is_set():
            st = self._stat()
            kids, todo = set(), [me]
            while todo:
                p = todo.pop()
                for q, (pp, _) in st.items():
                    if pp == p and q not in kids:
                        kids.add(q)
                        todo.append(q)
            own = st.get(me, (0, 0.0))[1]
            self.samples.append((time.time(), own, sum(st[q][1] for q in kids)))
            self._stop.wait(0.2)

    def between(self, t0: float, t1: float) -> tuple[float, float]:
        """CPU seconds (this process, its descendants) used between wall-clock times t0, t1."""
        t = np.array([s[0] for s in self.samples])
        own = np.interp([t0, t1], t, [s[1] for s in self.samples])
        kids = np.interp([t0, t1], t, [s[2] for s in self.samples])
        return float(own[1] - own[0]), float(kids[1] - kids[0])


@contextlib.contextmanager
def dask_cluster(n: int, env: dict):
    """A scheduler and ``dask worker --nworkers n --nthreads 1`` as subprocesses; its address."""
    from distributed import Client

    with tempfile.TemporaryDirectory(prefix="lccopt-dask-") as tmp:
        sfile = Path(tmp) / "scheduler.json"
        penv = {**os.environ, **env, "PYTHONPATH": str(REPO)}
        common = ["--no-dashboard"]
        sched = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                                  "--port", "0", "--scheduler-file", str(sfile), *common],
                                 env=penv, cwd=REPO, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
        workers = None
        try:
            while not sfile.exists():
                time.sleep(0.1)
            time.sleep(0.2)
            address = json.loads(sfile.read_text())["address"]
            workers = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker",
                                        address, "--nworkers", str(n), "--nthreads", "1",
                                        "--memory-limit", "0", *common], env=penv, cwd=REPO,
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            with Client(address, set_as_default=False) as c:
                c.wait_for_workers(n, timeout=600)
            yield address
        finally:
            for p in (workers, sched):
                if p is not None:
                    p.terminate()
            for p in (workers, sched):
                if p is not None:
                    try:
                        p.wait(30)
                    except subprocess.TimeoutExpired:
                        p.kill()


def run_once(case: Path, budget: int, initial: int, workers: int, root: Path, args, tag: str = "",
             conditions: int = 1) -> dict:
    from lccopt.engine.runner import optimise

    name = f"throughput-w{workers}-c{conditions}{tag}"
    path = root / f"{name}.yaml"
    # the worst over several conditions lies above the one-condition case's ASF worst values
    worst = "  asf:\n    worst: [50000.0, 5.0]\n" if conditions > 1 else ""
    # blocks of one round of the workers (--per-fit 0, the default here) or of --per-fit
    per_fit = args.per_fit or workers
    path.write_text(f"extends: {case.resolve()}\nname: {name}\noptimisation:\n"
                    f"  budget: {budget}\n  initial_points: {initial}\n"
                    f"  proposals_per_fit: {per_fit}\n" + worst
                    + (CHEAP if args.cheap else "") + conditions_yaml(conditions), encoding="utf-8")
    evaluator = STANDIN if args.standin else None
    env = {"LCCOPT_STANDIN_SECONDS": str(args.standin)} if args.standin else {}
    os.environ.update(env)
    import resource

    cpu = lambda who: (lambda u: u.ru_utime + u.ru_stime)(resource.getrusage(who))  # noqa: E731
    own0, kids0 = cpu(resource.RUSAGE_SELF), cpu(resource.RUSAGE_CHILDREN)
    load0 = os.getloadavg()[0]  # the machine's other work: on shared cores it sets the figures
    t0 = time.perf_counter()
    with contextlib.ExitStack() as stack:
        sampler = stack.enter_context(CpuSampler())
        scheduler = stack.enter_context(dask_cluster(workers, env)) if args.dask else None
        t0 = time.perf_counter()
        kw = dict(runs=root / "runs", progress=False, evaluator=evaluator)
        if args.profile:
            import cProfile
            import pstats

            prof = cProfile.Profile()
            run = prof.runcall(optimise, path, workers=None if args.dask else workers,
                               scheduler=scheduler, **kw)
            pstats.Stats(prof).sort_stats("cumulative").print_stats(45)
        else:
            run = optimise(path, workers=None if args.dask else workers, scheduler=scheduler, **kw)
        total = time.perf_counter() - t0
    own, kids = cpu(resource.RUSAGE_SELF) - own0, cpu(resource.RUSAGE_CHILDREN) - kids0
    events = [json.loads(line) for line in (run / "journal.jsonl").read_text().splitlines()]
    session = next(e for e in events if e["event"] == "session")
    done = [e for e in events if e["event"] in ("evaluated", "failed")]
    sims = [e["wall_time"] for e in done]
    wall = session["wall_time"]
    thr = session["evaluations"] / wall
    at = [e["at"] for e in done]
    first = args.start if args.start and len(done) > args.start + 1 else 1
    if args.start and len(done) > args.start + 1:
        thr = (len(at) - args.start) / (at[-1] - at[args.start - 1])
    # marginal CPU per evaluation over the same stretch (start-up and shut-down left out)
    m_own, m_kids = sampler.between(at[first - 1], at[-1])
    m_n = len(at) - first
    from lccopt.config import load_case

    conditions = max(conditions, len(load_case(run / "case.yaml").conditions))  # the case's own
    return {"workers": workers, "conditions": conditions, "thr": thr,
            "evaluations": session["evaluations"], "wall": wall,
            "startup": total - wall, "optimiser": session["optimiser_time"],
            "bookkeeping": session["bookkeeping_time"], "sim_mean": float(np.mean(sims)),
            "busy": float(np.sum(sims)) / (workers * wall),
            # CPU per evaluation [ms]: this process (the engine; with --dask also the client)
            # and its children (the workers with their forked children, or the Dask processes)
            "cpu_engine": 1e3 * own / len(done), "cpu_workers": 1e3 * kids / len(done),
            "mcpu_engine": 1e3 * m_own / m_n, "mcpu_workers": 1e3 * m_kids / m_n,
            "held": session.get("held_time", float("nan")) / (workers * wall),
            "load": (load0, os.getloadavg()[0]),
            "batch": next((e.get("batch", 1) for e in events if e["event"] == "schedule"), 1)}


def throughput(args) -> None:
    keys = [(w, c) for c in args.conditions for w in args.workers]
    runs: dict[tuple, list[dict]] = {key: [] for key in keys}
    with tempfile.TemporaryDirectory(prefix="lccopt-throughput-") as tmp:
        for k in range(args.repeat):
            for w, c in keys:
                r = run_once(args.case, args.budget, args.initial, w, Path(tmp), args, f"-{k}", c)
                runs[(w, c)].append(r)
                print(f"workers {w}, conditions {c}: {r['evaluations']} designs in "
                      f"{r['wall']:.1f} s (+{r['startup']:.1f} s start-up and summary), "
                      f"evaluations {r['sim_mean']:.3f} s mean per design, {r['thr']:.1f}/s, "
                      f"busy {r['busy']:.2f}, held {r['held']:.3f}, "
                      f"load average {r['load'][0]:.1f} -> {r['load'][1]:.1f}", flush=True)
    rows = []
    for w, c in keys:
        rs = runs[(w, c)]
        rows.append({"workers": w, "conditions": rs[0]["conditions"], **{
            k: float(np.median([r[k] for r in rs]))
            for k in ("thr", "busy", "held", "optimiser", "bookkeeping", "wall", "evaluations",
                      "batch", "cpu_engine", "cpu_workers", "mcpu_engine", "mcpu_workers")}})
    how = (f"stand-in evaluations of {args.standin} s" if args.standin
           else "cheap simulation" if args.cheap else "simulator")
    stretch = f"marginal from evaluation {args.start}" if args.start else "whole loop"
    print(f"\ncase {args.case.name} ({how}, {'Dask' if args.dask else 'local pool'}), budget "
          f"{args.budget} ({args.initial} initial), {stretch}, median of {args.repeat}")
    print("| conditions | workers | batch | designs/s | simulations/s | efficiency | busy | held | "
          "optimiser [s] | bookkeeping [s] | overhead [% wall] | CPU engine [ms/design] | "
          "CPU workers [ms/design] | marginal CPU engine / workers [ms/design] | cores needed |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if args.standin:
            eff = r["thr"] * r["conditions"] * args.standin / r["workers"]
        else:
            one = next(q for q in rows if q["conditions"] == r["conditions"])  # first worker count
            eff = r["thr"] / (r["workers"] * one["thr"] / one["workers"])
        over = 100.0 * (r["optimiser"] + r["bookkeeping"]) / r["wall"]
        print(f"| {r['conditions']} | {r['workers']} | {r['batch']:.0f} | {r['thr']:.2f} | "
              f"{r['thr'] * r['conditions']:.1f} | {eff:.2f} | {r['busy']:.2f} | {r['held']:.3f} | "
              f"{r['optimiser']:.2f} | {r['bookkeeping']:.2f} | {over:.1f} | "
              f"{r['cpu_engine']:.1f} | {r['cpu_workers']:.1f} | "
              f"{r['mcpu_engine']:.1f} / {r['mcpu_workers']:.1f} | "
              f"{need(r, args):.2f} |")


def need(r: dict, args) -> float:
    """Cores the engine and its workers would use at full efficiency: the marginal CPU per
    design times the designs per second the workers could do (workers / (conditions * D))."""
    if not args.standin:
        return float("nan")
    ideal = r["workers"] / (r["conditions"] * args.standin)
    return ideal * 1e-3 * (r["mcpu_engine"] + r["mcpu_workers"])


def asks(args) -> None:
    """Time of the optimiser's asks against the number of points (no engine)."""
    from benchmarks.scale.standin import objectives
    from lccopt.config import load_case
    from lccopt.problem import Problem

    case = load_case(args.case)
    pb = Problem.from_case(case)
    print(f"case {args.case.name}: surrogate {pb.surrogate}, {pb.dim} variables, "
          f"{args.points} points")
    print("| batch | points | ask [ms per block] | ask [ms per point] | tell [ms per point] |")
    print("|---|---|---|---|---|")
    for q in args.batch:
        s = pb.strategy(budget=args.points)
        ref = None
        if pb.multi:
            ref = pb.reference_point(objectives(case, np.array(pb.reference))[0])
            s.set_aggregate(pb.aggregate(ref))
        blocks: dict[int, list] = {}
        t_tell = 0.0
        while not s.done:
            t0 = time.perf_counter()
            props = s.ask(q)
            dt = time.perf_counter() - t0
            blocks.setdefault(100 * ((s.n_asked - 1) // 100 + 1), []).append((dt, len(props)))
            t0 = time.perf_counter()
            for p in props:
                obj, energy = objectives(case, p.x)
                value = pb.value(obj, ref)
                s.tell(p.id, value, pb.outputs(obj, [float(v) for v in energy]))
            t_tell += time.perf_counter() - t0
        for n, b in sorted(blocks.items()):
            per_block = 1e3 * np.median([dt for dt, _ in b])
            per_point = 1e3 * sum(dt for dt, _ in b) / sum(m for _, m in b)
            print(f"| {q} | {n - 99}-{n} | {per_block:.1f} | {per_point:.2f} | "
                  f"{1e3 * t_tell / s.n_told:.2f} |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", type=Path, default=REPO / "configs" / "quickstart.yaml")
    ap.add_argument("--budget", type=int, default=40)
    ap.add_argument("--initial", type=int, default=10)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--cheap", action="store_true",
                    help="coarse simulation settings (as the tests)")
    ap.add_argument("--standin", type=float, default=0.0,
                    help="the stand-in evaluator of this duration [s] instead of the simulator")
    ap.add_argument("--dask", action="store_true", help="a Dask scheduler and worker processes")
    ap.add_argument("--per-fit", type=int, default=0,
                    help="optimisation.proposals_per_fit (0: the worker count, as measured)")
    ap.add_argument("--from", dest="start", type=int, default=0,
                    help="marginal throughput from this committed evaluation on")
    ap.add_argument("--profile", action="store_true", help="cProfile of the engine process")
    ap.add_argument("--repeat", type=int, default=1, help="runs per worker count (median reported)")
    ap.add_argument("--conditions", type=int, nargs="+", default=[1],
                    help="traffic conditions per design (one run per count)")
    ap.add_argument("--asks", action="store_true", help="time the optimiser's asks alone")
    ap.add_argument("--points", type=int, default=1000, help="--asks: points (the budget)")
    ap.add_argument("--batch", type=int, nargs="+", default=[1], help="--asks: points per ask")
    args = ap.parse_args()
    asks(args) if args.asks else throughput(args)


if __name__ == "__main__":
    main()
