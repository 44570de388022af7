"""Time one reference evaluation at the default settings, on one core, against the method
before issue 11 in the same run.

Prints the median wall time of ``evaluate(case, reference)`` (the current method at the case's
settings) and of the pre-issue-11 method (benchmarks/support/legacy_newmark.py: its integrator at
its
settings, dt = 0.2 ms, 10 m run-in, far elements <= 0.3 m), timed alternately in the same
process, with the ratio; where the current method's time goes per step (sparse product for the
right-hand side, the two banded triangular solves, the U^-T rows when the wheel enters an
element, and the rest: Python and small products); and the time of the straightforward approach
(assemble the coupled vehicle-track matrix with the contact at the wheel's position and
factorise it with SuperLU every step), measured over a slice of the run and scaled to the full
number of steps. The straightforward and the current integrator are checked to agree.

    python -m benchmarks.model.simulator_speed [--repeat 7] [--naive-steps 300] [--flush] \
        [--scaling]

The figures and their history: benchmarks/RESULTS-simulator.md.

--flush also times the old method without its periodic flush of tiny values (denormals).
--scaling times the current method for longer entry tracks and other time steps.
"""

from __future__ import annotations

import argparse
import copy
import os
import statistics
import time

# One core: set before numpy loads BLAS, so the imports below follow it (noqa: E402).
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
from scipy.linalg import blas, lapack  # noqa: E402
from scipy.sparse.linalg import splu  # noqa: E402

from benchmarks.support import legacy_newmark  # noqa: E402
from benchmarks.support.legacy_newmark import REFERENCE_SETTINGS, evaluate_legacy  # noqa: E402
from lccopt.config import load_case  # noqa: E402
from lccopt.problem import evaluate  # noqa: E402
from lccopt.vti.assembly import to_upper_banded  # noqa: E402
from lccopt.vti.banded import forward_columns  # noqa: E402
from lccopt.vti.newmark import integrate  # noqa: E402
from lccopt.vti.track import build_track  # noqa: E402
from lccopt.vti.vehicle import build_vehicle  # noqa: E402
from lccopt.vti.wheels import contact_vector  # noqa: E402


def naive_steps(track, veh, dt, x_start, steps):
    """Newmark on the full coupled system, re-assembled and re-factorised every step."""
    M, C, K = track.M, track.C, track.K
    n = K.shape[0]
    Mg = sp.block_diag([M, sp.csr_matrix(veh.M)]).tocsr()
    Cg = sp.block_diag([C, sp.csr_matrix(veh.C)]).tocsr()
    Kg0 = sp.block_diag([K, sp.csr_matrix(veh.K)]).tocsr()
    kw = veh.contact_stiffness
    f = np.zeros(n + 3)
    f[n:] = veh.weight_load
    a0, a1, a2 = 4 / dt ** 2, 2 / dt, 4 / dt

    def contact(x):
        idx, vals = contact_vector(track, x)
        g = np.zeros(n + 3)
        np.add.at(g, idx, -vals)
        g[n + 2] = 1.0
        gs = sp.csr_matrix(g.reshape(-1, 1))
        return kw * (gs @ gs.T)

    u = splu((Kg0 + contact(x_start)).tocsc()).solve(f)
    v = np.zeros(n + 3)
    a = np.zeros(n + 3)
    out = [u]
    for k in range(1, steps + 1):
        Kc = Kg0 + contact(x_start + veh.speed * dt * k)
        lu = splu((Kc + a0 * Mg + a1 * Cg).tocsc())
        un = lu.solve(f + Mg @ (a0 * u + a2 * v + a) + Cg @ (a1 * u + v))
        an = a0 * (un - u) - a2 * v - a
        v = v + 0.5 * dt * (a + an)
        u, a = un, an
        out.append(u)
    return np.array(out)


def timed(f, repeat: int = 200) -> float:
    """Median seconds of one call of f over ``repeat`` calls (in 5 batches)."""
    batches = []
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(repeat):
            f()
        batches.append((time.perf_counter() - t0) / repeat)
    return statistics.median(batches)


def breakdown(case, x, n_steps: int) -> dict[str, float]:
    """Seconds per run of the parts of the current method's step, timed in isolation."""
    track = build_track(case.scenario(), case.track_design(x))
    dt = case.simulation["time_step"]
    a0, a1 = 4 / dt ** 2, 2 / dt
    M, C, K = track.M, track.C, track.K
    MC = sp.hstack([M, C]).tocsr()
    ab, kd = to_upper_banded(K + a0 * M + a1 * C)
    chol = np.asfortranarray(lapack.dpbtrf(ab, lower=0)[0])
    n = K.shape[0]
    pq = np.random.default_rng(0).random(2 * n)
    b = pq[:n].copy()
    rows = np.zeros((2, n))
    veh = build_vehicle(case.scenario().vehicle)
    x0, _, _, x1 = track.window
    elements = np.unique(np.searchsorted(track.node_x, x0 + veh.speed * dt * np.arange(n_steps + 1),
                                         side="right") - 1)
    mid = elements[len(elements) // 2]
    dofs = [track.rail_w[mid + 1], track.rail_th[mid + 1]]
    product = timed(lambda: MC @ pq) * n_steps
    solves = timed(lambda: (blas.dtbsv(kd, chol, b, trans=1), blas.dtbsv(kd, chol, b))) * n_steps
    entering = timed(lambda: forward_columns(chol, dofs, rows), 50) * len(elements)
    return {
        "sparse product [M C][p; q]": product,
        "two banded triangular solves": solves,
        "U^-T rows on entering an element": entering,
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", default="configs/reference.yaml")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--naive-steps", type=int, default=300)
    ap.add_argument("--flush", action="store_true",
                    help="also time the old method without its flush")
    ap.add_argument("--scaling", action="store_true",
                    help="time against track length and time step")
    args = ap.parse_args()
    case = load_case(args.case)
    old_case = case.with_simulation(**REFERENCE_SETTINGS)
    x = case.reference
    ev = evaluate(case, x)  # warm up imports and caches
    ev_old = evaluate_legacy(old_case, x)
    new_t, old_t = [], []
    for _ in range(args.repeat):   # alternate, so that the machine's load hits both alike
        t0 = time.perf_counter()
        evaluate_legacy(old_case, x)
        old_t.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        evaluate(case, x)
        new_t.append(time.perf_counter() - t0)
    fast, old = statistics.median(new_t), statistics.median(old_t)
    n_steps, n_dofs = ev.info["n_steps"], ev.info["n_dofs"]
    dt = case.simulation["time_step"]
    load1 = os.getloadavg()[0]

    print(f"case {args.case}, 1-min load average {load1:.2f} on {os.cpu_count()} cores")
    print(f"current: {n_dofs} track dofs + 3 vehicle dofs, {n_steps} steps of {dt * 1e3:g} ms")
    print(f"  evaluate: median {fast:.3f} s over {args.repeat} runs "
          f"(min {min(new_t):.3f}, max {max(new_t):.3f}), {fast / n_steps * 1e6:.0f} µs/step")
    print(f"before issue 11: {ev_old.info['n_dofs']} track dofs, {ev_old.info['n_steps']} steps of "
          f"{old_case.simulation['time_step'] * 1e3:g} ms")
    print(f"  evaluate: median {old:.3f} s over {args.repeat} runs "
          f"(min {min(old_t):.3f}, max {max(old_t):.3f}), "
          f"{old / ev_old.info['n_steps'] * 1e6:.0f} µs/step")
    print(f"ratio old/current: {old / fast:.2f}x")
    d = {k: ev.objectives[k] / ev_old.objectives[k] - 1 for k in ("F_max", "E_max")}
    print(f"objectives current vs before: F_max {d['F_max']:+.3%}, E_max {d['E_max']:+.3%}")

    parts = breakdown(case, x, n_steps)
    print(f"where the current {fast:.3f} s go (parts timed in isolation):")
    for name, t in parts.items():
        print(f"  {name:36s} {t:.3f} s ({t / fast:.0%})")
    rest = fast - sum(parts.values())
    print(f"  {'rest: Python loop, small products, setup':36s} {rest:.3f} s ({rest / fast:.0%})")

    if args.flush:
        saved = legacy_newmark.FLUSH_EVERY, legacy_newmark.FLUSH_BELOW
        flushed, unflushed = [], []
        for _ in range(args.repeat):
            for store, setting in ((flushed, saved), (unflushed, (10 ** 12, 0.0))):
                legacy_newmark.FLUSH_EVERY, legacy_newmark.FLUSH_BELOW = setting
                t0 = time.perf_counter()
                evaluate_legacy(old_case, x)
                store.append(time.perf_counter() - t0)
        legacy_newmark.FLUSH_EVERY, legacy_newmark.FLUSH_BELOW = saved
        print("old method with its flush of tiny values: "
              f"median {statistics.median(flushed):.3f} s, "
              f"without: {statistics.median(unflushed):.3f} s")

    if args.scaling:
        print("cost against track length (entry length; the rest as the case) and time step:")
        variants = [("entry_length", L) for L in (100.0, 200.0, 400.0)] + \
                   [("time_step", dt_) for dt_ in (2.5e-4, 5e-4, 1e-3)]
        for key, value in variants:
            c = copy.deepcopy(case)
            if key == "entry_length":
                c.data["track"]["layout"]["entry_length"] = value
            else:
                c = c.with_simulation(time_step=value)
            ev_v = evaluate(c, x)
            ts = []
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                evaluate(c, x)
                ts.append(time.perf_counter() - t0)
            t = statistics.median(ts)
            print(f"  {key} = {value:g}: {ev_v.info['n_dofs']} dofs, {ev_v.info['n_steps']} steps: "
                  f"median {t:.3f} s, {t / ev_v.info['n_steps'] * 1e6:.0f} µs/step, "
                  f"{t / ev_v.info['n_steps'] / ev_v.info['n_dofs'] * 1e9:.0f} ns/step/dof")

    if args.naive_steps:
        track = build_track(case.scenario(), case.track_design(x))
        veh = build_vehicle(case.scenario().vehicle)
        x0 = ev.info["x_start"]
        t0 = time.perf_counter()
        ref = naive_steps(track, veh, dt, x0, args.naive_steps)
        naive_per_step = (time.perf_counter() - t0) / args.naive_steps
        h = integrate(track, dt, veh.speed, x0, args.naive_steps, vehicle=veh)
        dz = np.max(np.abs(ref[:, -1] - h.vehicle_displacement[:, 2])) / np.max(np.abs(ref[:, -1]))
        naive = naive_per_step * n_steps
        print(f"straightforward (assemble + SuperLU every step): {naive:.1f} s "
              f"({naive_per_step * 1e3:.2f} ms/step over {args.naive_steps} steps, "
              f"scaled to {n_steps}), {naive / fast:.0f}x the current; "
              f"wheel displacements agree to {dz:.1e} (relative)")


if __name__ == "__main__":
    main()
