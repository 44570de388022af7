"""Speed and plausibility of the settlement prediction (figures: benchmarks/RESULTS-settlement.md).

    python benchmarks/settlement.py speed        # one run: linear vs 0, 3, 10 voided sleepers
    python benchmarks/settlement.py designs      # reference vs the paper's MOO design, 10 years

Run one process at a time (2 cores shared). OPENBLAS_NUM_THREADS=1 as in the tests.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys
import time

import numpy as np

from lccopt.case import load_case
from lccopt.degradation.iteration import Condition, predict_settlement
from lccopt.degradation.laws import LogarithmicLaw, VarandasLaw
from lccopt.degradation.loading import entry_zone, vti_condition
from lccopt.vti.newmark import integrate
from lccopt.vti.track import build_track
from lccopt.vti.vehicle import Vehicle

# One bogie side of the VIRM (configs/traffic.yaml's values): two wheels, no fixed point, so a
# settled track does not change its static wheel loads (the paper's 3-dof vehicle rests half
# of its bogie on an unmodelled wheelset that stays where it is: docs/settlement.md).
BOGIE = dict(type="bogie", wheelbase=2.5, bogie_pitch_inertia=1400.0)
MOO = [214e6, 155e6, 50e6, 5, 6, 7, 3, 0]          # Table 7


def setup(x=None, vehicle="bogie"):
    case = load_case("configs/reference.yaml")
    if vehicle == "bogie":
        case.data["vehicle"].update(BOGIE)
    x = case.reference.copy() if x is None else np.asarray(x, float)
    tr = build_track(case, x)
    veh = Vehicle.from_case(case)
    dt = case.simulation["time_step"]
    x_start, _, _, x_end = tr.window
    n = int(np.ceil(abs(x_end - x_start) / (veh.speed * dt)))
    return case, tr, veh, dt, x_start, n


def timed(fn, repeat=5):
    t = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        t.append(time.perf_counter() - t0)
    return float(np.median(t)), out


def speed():
    for vehicle in ("three-dof", "bogie"):
        case, tr, veh, dt, x0, n = setup(vehicle=vehicle)
        zone = entry_zone(tr, 20)
        lin, _ = timed(lambda: integrate(tr, dt, veh.speed, x0, n, vehicle=veh))
        print(f"{vehicle}: {n} steps, {tr.n_dofs} dofs, {len(zone.supports.dof)} unilateral sleepers")
        print(f"  linear model                  {lin * 1e3:7.1f} ms")
        for voided in (0, 3, 10):
            s = np.zeros(20)
            s[:voided] = np.linspace(2e-3, 0.5e-3, voided)     # hanging next to the interface
            sup = zone.supports.with_gaps(zone.gaps(s))
            t, h = timed(lambda: integrate(tr, dt, veh.speed, x0, n, vehicle=veh, supports=sup))
            print(f"  {voided:2d} voided sleepers           {t * 1e3:7.1f} ms  ({t / lin:4.2f}x)  "
                  f"switches {h.info['switches']}, most passes {h.info['iterations']}, "
                  f"unsettled steps {h.info['unsettled']}")


def designs(tolerance=0.2e-3, years=10.0, per_year=1.0e6):
    print(f"bogie side of the VIRM, {per_year:.0e} passes (2 axles each) a year, {years:g} years, "
          f"tolerance {tolerance * 1e3:g} mm")
    for law in (VarandasLaw(), LogarithmicLaw()):
        for name, x in (("reference", None), ("MOO (Table 7)", MOO)):
            case, tr, veh, dt, x0, n = setup(x)
            zone = entry_zone(tr, 20)
            cond = Condition("virm-bogie", per_year,
                             vti_condition(tr, veh, dt=dt, speed=veh.speed, x_start=x0, n_steps=n))
            t0 = time.perf_counter()
            r = predict_settlement(tr, zone, [cond], horizon_years=years, law=law,
                                   tolerance=tolerance)
            wall = time.perf_counter() - t0
            o = r.objectives(limit_measure="differential_settlement", limit=3e-3)
            print(f"  {law.name:11s} {name:14s} {wall:5.1f} s, {r.n_simulations} simulations, "
                  f"blocks {r.info['blocks']}, axle passes {r.axle_passes[-1]:.2e}")
            print("     " + ", ".join(f"{k} {v * 1e3:.2f} mm" if k not in ("force_growth", "passes_to_limit")
                                      else f"{k} {v:.3g}" for k, v in o.items()))
            print("     settlement [mm] by sleeper from the interface: "
                  + " ".join(f"{v:.1f}" for v in r.settlement[-1] * 1e3))
            print("     void [mm]: " + " ".join(f"{v:.1f}" for v in r.void[-1] * 1e3))


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "speed"
    {"speed": speed, "designs": designs}[what]()
