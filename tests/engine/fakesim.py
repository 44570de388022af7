"""Test evaluators for the run engine (pointed at by LCCOPT_EVALUATOR or the ``evaluator``
argument): a cheap analytic stand-in for the simulator, and faulty variants.

``evaluate``: deterministic smooth objectives of x, the vehicle speed and, on a realisation of
the track, its support stiffness next to the slab (+ small time histories; with
``LCCOPT_FAKE_LOG`` set, one line per simulation appended to it); sleeps
``LCCOPT_FAKE_DELAY`` seconds (default 0) to look like a simulation; with
``LCCOPT_FAKE_SPREAD`` = s (0 <= s < 1) the delay varies between (1-s) and (1+s) times that
from point to point (a fixed function of x), so that results come back out of order.
With ``LCCOPT_FAKE_ZERO`` = an objective's name, that objective is 0 at the reference design.
With ``LCCOPT_FAKE_STALL`` = n (and ``LCCOPT_FAKE_LOG``), a simulation of a vehicle leaving
the crossing hangs once the log holds n lines: a run then stays, until killed, with designs
whose other conditions have finished (a kill between conditions without a timing race).

``faulty``: like ``evaluate`` for the reference design; otherwise fires each fault listed
in ``LCCOPT_TEST_FAULTS`` (comma-separated: raise, nan, exit, hang: for
``LCCOPT_TEST_HANG`` seconds if set, else for ever) exactly once, claimed
through marker files in ``LCCOPT_TEST_FAULT_DIR`` (so each fault happens once whatever the
worker), then behaves like ``evaluate``.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from lccopt.vti.response import Evaluation


def _objectives(case, x) -> dict:
    x = np.asarray(x, dtype=float)
    u = (x - case.lower) / np.where(case.upper > case.lower, case.upper - case.lower, 1.0)
    a = np.array([0.3, 0.2, 0.1, 0.25, 0.5, 0.5, 0.25, 0.0])[: len(u)]
    b = np.array([0.9, 0.8, 0.7, 0.1, 0.6, 0.4, 0.2, 0.3])[: len(u)]
    f = 5000.0 + 12000.0 * np.sum((u - a) ** 2) + 300 * np.sin(7 * u).sum()
    e = 0.1 + 0.5 * np.sum((u - b) ** 2) + 0.01 * np.cos(5 * u).sum()
    # a traffic condition's speed scales the objectives (exactly 1 at the reference speed)
    s = case.vehicle["speed"] / 38.88888888888889
    f, e = f * s, e * s * s
    # a realisation of the track (uncertainty:) scales them by its zone's mean support factor
    variation = getattr(case, "variation", None)
    if variation is not None and variation.support_stiffness is not None:
        k = float(np.mean(variation.support_stiffness[0][:20]))
        f, e = f * k, e / k
    return {"F_rms": 49000.0 + 0.1 * f, "F_max": float(f), "E_rms": 1.5 + e, "E_max": float(e)}


def _stall(case) -> None:
    n, log = os.environ.get("LCCOPT_FAKE_STALL"), os.environ.get("LCCOPT_FAKE_LOG")
    if n and log and case.simulation.get("direction") == "leave":
        if os.path.exists(log) and len(Path(log).read_text().splitlines()) >= int(n):
            while True:
                time.sleep(1)


def evaluate(case, x) -> Evaluation:
    _stall(case)
    delay = float(os.environ.get("LCCOPT_FAKE_DELAY", "0") or 0)
    if delay:
        spread = float(os.environ.get("LCCOPT_FAKE_SPREAD", "0") or 0)
        u = (np.sin(1e3 * np.sum(np.asarray(x, float) * np.arange(1, len(x) + 1))) + 1.0) / 2.0
        time.sleep(delay * (1.0 + spread * (2.0 * u - 1.0)))
    x = case.check_design(x)
    obj = _objectives(case, x)
    zero = os.environ.get("LCCOPT_FAKE_ZERO")   # an objective 0 at the reference design
    if zero and np.array_equal(x, case.reference):
        obj[zero] = 0.0
    log = os.environ.get("LCCOPT_FAKE_LOG")
    if log:  # one line per finished simulation (tests count what a resume runs again)
        with open(log, "a") as fh:
            fh.write(f"{case.vehicle['speed']:.6f} {' '.join(f'{v:g}' for v in x)}\n")
    t = np.linspace(0.0, 0.1, 200)
    force = 87000.0 + obj["F_max"] * np.sin(60 * t)
    return Evaluation(obj, {"time": t, "contact_force": force,
                            "sleeper_energy": np.linspace(0.0, obj["E_max"], 5)},
                      {"static_load": 87000.0, "fake": True})


def _claim(kind: str) -> bool:
    d = os.environ["LCCOPT_TEST_FAULT_DIR"]
    try:
        fd = os.open(os.path.join(d, kind), os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return False
    os.close(fd)
    return True


def faulty(case, x) -> Evaluation:
    if not np.array_equal(np.asarray(x, float), case.reference):
        for kind in [k for k in os.environ.get("LCCOPT_TEST_FAULTS", "").split(",") if k]:
            if _claim(kind):
                if kind == "raise":
                    raise RuntimeError("injected simulation error")
                if kind == "nan":
                    ev = evaluate(case, x)
                    ev.objectives = {k: float("nan") for k in ev.objectives}
                    return ev
                if kind == "exit":
                    os._exit(7)
                if kind == "hang":   # for LCCOPT_TEST_HANG seconds if set, else for ever
                    end = time.monotonic() + float(os.environ.get("LCCOPT_TEST_HANG", "inf"))
                    while time.monotonic() < end:
                        time.sleep(min(1.0, max(0.0, end - time.monotonic())))
    return evaluate(case, x)


def settled(case, x) -> Evaluation:
    """``evaluate`` with a settlement prediction's objectives too (smooth functions of the same
    x): a stand-in for a case with ``degradation:``, whose long objective names
    (differential_settlement, maintenance_rate) are what a terminal line must hold."""
    ev = evaluate(case, x)
    f, e = ev.objectives["F_max"], ev.objectives["E_max"]
    ev.objectives.update({"differential_settlement": 1e-3 * (1.0 + f / 5000.0),
                          "max_settlement": 2e-3 * (1.0 + e), "max_void": 5e-4 * (1.0 + e),
                          "level_std": 2e-4 * (1.0 + e), "force_growth": 0.01 * e,
                          "maintenance_rate": 0.1 * (1.0 + f / 5000.0),
                          "years_to_limit": 10.0 / (1.0 + f / 5000.0)})
    return ev
