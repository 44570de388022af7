"""CPU of one task in a local worker, and of merging a traffic design's condition files.

    python -m benchmarks.scale.task_cost --workers 4 --tasks 300

The local pool alone (lccopt/engine/executors.py LocalPool, no optimiser, no journal): the
stand-in evaluator (benchmarks/scale/standin.py) with a duration of 0 s, each task writing its
evaluation file without time histories (as a run stores all but the reference and the best
design); the CPU of the worker processes and of the forked children they reaped, from
/proc, per task. Then, in this process, the 14 part files of one design written and merged
(lccopt/store.py merge_condition_files, what the engine does per traffic design): CPU per
part and per merge, and the files' sizes. Last, where a task's CPU goes: this process forks
children as a local worker does (its imports done first, lccopt/engine/worker.py PRELOAD)
that exit at once, run the evaluation, or run it and write its file; the children's CPU and
page faults from wait4, against the same evaluation and file in this (warm) process.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ["LCCOPT_STANDIN_SECONDS"] = "0"

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[2]

from lccopt import load_case  # noqa: E402
from lccopt.engine.executors import LocalPool  # noqa: E402
from lccopt.engine.worker import Task, kept, load_evaluator  # noqa: E402
from lccopt.store import merge_condition_files, write_evaluation  # noqa: E402

STANDIN = "benchmarks.scale.standin:evaluate"


def cpu_seconds(pids) -> float:
    """utime + stime + cutime + cstime of the processes ``pids``."""
    total = 0
    for pid in pids:
        with open(f"/proc/{pid}/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        total += sum(int(v) for v in fields[11:15])
    return total / os.sysconf("SC_CLK_TCK")


def pool_cost(case, workers: int, tasks: int, where: str) -> None:
    pool = LocalPool(case, STANDIN, workers, 60.0)
    pool.start()
    pids = [s.proc.pid for s in pool._slots]
    x = list((case.lower + case.upper) / 2)

    def run(n: int) -> None:
        sent = done = 0
        while done < n:
            while sent < n and pool.free():
                pool.submit(Task(sent, x, out_path=os.path.join(where, f"{sent:06d}.h5"),
                                 histories=False))
                sent += 1
            done += len(pool.wait(0.5))

    try:
        run(2 * workers)  # every worker forked once
        c0, t0, e0 = cpu_seconds(pids), time.perf_counter(), time.process_time()
        run(tasks)
        c1, t1, e1 = cpu_seconds(pids), time.perf_counter(), time.process_time()
    finally:
        pool.close()
    print(f"local pool, {workers} workers, {tasks} tasks: workers {1e3 * (c1 - c0) / tasks:.2f} ms "
          f"of CPU per task, this process {1e3 * (e1 - e0) / tasks:.2f} ms, wall "
          f"{1e3 * (t1 - t0) / tasks:.2f} ms per task (load average {os.getloadavg()[0]:.1f})")


def merge_cost(case, where: str, designs: int = 20, conditions: int = 14) -> None:
    x = list((case.lower + case.upper) / 2)
    ev = kept(load_evaluator(STANDIN)(case, np.asarray(x)), False)
    names = [f"c{c}" for c in range(conditions)]
    write = merge = 0.0
    for i in range(designs):
        t0 = time.process_time()
        parts = [os.path.join(where, f"{i:06d}.c{c}.h5") for c in range(conditions)]
        for c, p in enumerate(parts):
            write_evaluation(p, ev, x, case.names, attrs={"id": i, "condition": c}, durable=False)
        t1 = time.process_time()
        target = os.path.join(where, f"{i:06d}.h5")
        merge_condition_files(target, parts, names, [1 / conditions] * conditions,
                              {"F_max": 1.0}, {"id": i}, durable=False)
        write, merge = write + t1 - t0, merge + time.process_time() - t1
    sizes = os.path.getsize(parts[0]), os.path.getsize(target)
    print(f"{conditions} conditions: {1e3 * write / designs / conditions:.2f} ms of CPU per part "
          f"({sizes[0]} bytes), merge {1e3 * merge / designs:.1f} ms per design ({sizes[1]} bytes)")


def fork_cost(case, where: str, n: int = 200) -> None:
    import importlib

    from lccopt.engine.worker import PRELOAD, run_task

    for module in PRELOAD:
        importlib.import_module(module)
    evaluator = load_evaluator(STANDIN)
    x = list((case.lower + case.upper) / 2)

    def task(i: int, write: bool) -> Task:
        return Task(i, x, out_path=os.path.join(where, f"f{i:06d}.h5") if write else None,
                    histories=False)

    run_task(case, task(0, True), evaluator, "warm-up")
    for what in ("fork and exit", "fork, evaluate", "fork, evaluate, write the file"):
        cpu, faults = [], []
        for i in range(n):
            pid = os.fork()
            if pid == 0:
                if what != "fork and exit":
                    run_task(case, task(i, what.endswith("file")), evaluator, "child")
                os._exit(0)
            _, _, usage = os.wait4(pid, 0)
            cpu.append(usage.ru_utime + usage.ru_stime)
            faults.append(usage.ru_minflt)
        print(f"{what}: {1e3 * np.mean(cpu):.2f} ms of CPU, {np.median(faults):.0f} page faults "
              f"per child")
    for write in (False, True):
        t0 = time.process_time()
        for i in range(n):
            run_task(case, task(i, write), evaluator, "warm")
        print(f"in this process, evaluate{', write the file' if write else ''}: "
              f"{1e3 * (time.process_time() - t0) / n:.2f} ms of CPU")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--workers", type=int, default=4)
    ap.add_argument("--tasks", type=int, default=300)
    args = ap.parse_args()
    case = load_case(REPO / "configs" / "quickstart.yaml")
    with tempfile.TemporaryDirectory() as where:
        pool_cost(case, args.workers, args.tasks, where)
        merge_cost(case, where)
        fork_cost(case, where)


if __name__ == "__main__":
    main()
