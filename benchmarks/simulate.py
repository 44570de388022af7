"""Time one reference evaluation at the default settings, on one core.

Prints the median wall time of ``evaluate(case, reference)`` over several runs, and the time of
the straightforward approach (assemble the coupled vehicle-track matrix with the contact at the
wheel's position and factorise it with SuperLU every step), measured over a slice of the same
run and scaled to the full number of steps, with the ratio. The two are checked to agree.

    python benchmarks/simulate.py [--repeat 7] [--naive-steps 300]
"""

from __future__ import annotations

import os

for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")   # one core: set before numpy loads BLAS

import argparse
import statistics
import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from lccopt.case import load_case
from lccopt.vti.newmark import contact_vector, integrate
from lccopt.vti.simulate import evaluate
from lccopt.vti.track import build_track
from lccopt.vti.vehicle import Vehicle


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


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", default="configs/reference.yaml")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--naive-steps", type=int, default=300)
    args = ap.parse_args()
    case = load_case(args.case)
    x = case.reference
    evaluate(case, x)  # warm up imports and caches
    times = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        ev = evaluate(case, x)
        times.append(time.perf_counter() - t0)
    fast = statistics.median(times)
    n_steps, n_dofs = ev.info["n_steps"], ev.info["n_dofs"]

    # the same without flushing tiny far-field values (denormals reach the banded solves)
    from lccopt.vti import newmark

    saved = newmark.FLUSH_EVERY, newmark.FLUSH_BELOW
    newmark.FLUSH_EVERY, newmark.FLUSH_BELOW = 10 ** 12, 0.0
    unflushed = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        evaluate(case, x)
        unflushed.append(time.perf_counter() - t0)
    newmark.FLUSH_EVERY, newmark.FLUSH_BELOW = saved
    no_flush = statistics.median(unflushed)

    track = build_track(case, x)
    veh = Vehicle.from_case(case)
    dt = case.simulation["time_step"]
    x0 = ev.info["x_start"]
    t0 = time.perf_counter()
    ref = naive_steps(track, veh, dt, x0, args.naive_steps)
    naive_per_step = (time.perf_counter() - t0) / args.naive_steps
    h = integrate(track, dt, veh.speed, x0, args.naive_steps, vehicle=veh)
    dz = np.max(np.abs(ref[:, -1] - h.vehicle_displacement[:, 2])) / np.max(np.abs(ref[:, -1]))
    naive = naive_per_step * n_steps

    print(f"case {args.case}: {n_dofs} track dofs + 3 vehicle dofs, {n_steps} steps of {dt * 1e3:g} ms")
    print(f"lccopt evaluate (factorise once, rank-one contact):  median {fast:.3f} s over {args.repeat} runs "
          f"(min {min(times):.3f}, max {max(times):.3f}), {fast / n_steps * 1e6:.0f} µs/step")
    print(f"straightforward (assemble + SuperLU every step):       {naive:.1f} s "
          f"({naive_per_step * 1e3:.2f} ms/step over {args.naive_steps} steps, scaled to {n_steps})")
    print(f"without flushing denormals:                          median {no_flush:.3f} s "
          f"({no_flush / fast:.2f}x)")
    print(f"speed-up: {naive / fast:.0f}x; wheel displacements agree to {dz:.1e} (relative)")


if __name__ == "__main__":
    main()
