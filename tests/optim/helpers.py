"""Shared pieces of the optimiser's tests: drivers, test functions, a short-phase policy."""

from __future__ import annotations

import json

import numpy as np

from lccopt.optim.restarts import RestartPolicy
from lccopt.optim.space import DesignSpace


def run_serial(strategy, fun):
    """Ask one point, tell its value, until done."""
    while not strategy.done:
        props = strategy.ask(1)
        if not props:
            break
        for p in props:
            strategy.tell(p.id, fun(p.x))
    return strategy


def run_delayed(s, f, workers=2, watch=None, outputs=False):
    """Run with ``workers`` evaluations in flight, told oldest first (as the engine does);
    ``outputs``: f gives the outputs of a composite surrogate, their sum the value."""
    pending = []
    while not s.done:
        pending += s.ask(workers - len(pending))
        if watch:
            watch(s)
        p = pending.pop(0)
        if outputs:
            F = f(p.x)
            s.tell(p.id, float(F.sum()), F)
        else:
            s.tell(p.id, f(p.x))
    return s


def fingerprint(s) -> str:
    return json.dumps(s.state_dict(), sort_keys=True)


def xs(s) -> list:
    return [r["x"].tobytes() for r in s.history]


class ShortPhases(RestartPolicy):
    """The default restart policy, but a phase without an end of its own also ends
    ``length`` proposals after its design: many restarts in a short run (an experiment
    plugged in as benchmarks/optimiser/variants.py plugs its own)."""

    def __init__(self, length: int = 15):
        super().__init__()
        self.length = length

    def phase_over(self, s) -> bool:
        ph = s.phase
        return super().phase_over(s) or (
            ph.end is None and s.n_asked - ph.start - ph.n_design >= self.length)


def phase_starts(s) -> list[tuple]:
    """Per restart of a finished run: (index, first id, its design size, the record it went
    on from, whether the budget left was shorter than the mean of the phases before it)."""
    h = s.history
    out = []
    for r in range(1, s.restart + 1):
        recs = [rec for rec in h if rec["restart"] == r]
        first = recs[0]["id"]
        lengths = [sum(rec["restart"] == q for rec in h[:first]) for q in range(r)]
        design = sum(rec["phase"] == "initial" for rec in recs)
        out.append((r, first, design, s.budget - first < sum(lengths) / len(lengths)))
    return out


# -- an integer whose bound is best behind a wall (the paper's strip length x_l = 0) -----------
OFF_SWITCH_SPACE = DesignSpace(["x", "y", "n"], [0.0, 0.0, 0], [1.0, 1.0, 100],
                               [False, False, True])


def off_switch(x):
    """A bowl in x, y plus an integer n whose value 0 ("off": no strip, no strengthened
    sleepers) is best, its small values worst (a wall) and a second basin near n = 70."""
    n = x[2]
    wall = 0.0 if n == 0 else (3.0 if n <= 15 else 1.0 + (n - 70) ** 2 / 2000)
    return (x[0] - 0.6) ** 2 + (x[1] - 0.3) ** 2 + wall


def off_switch_elsewhere(x):
    """An "off" switch (n = 0) whose optimum lies elsewhere in x, y: the run's best point with
    n on 0 is worse than the basin near n = 70, so a bound probe fails, yet n = 0 is best."""
    if x[2] == 0:
        return (x[0] - 0.2) ** 2 + (x[1] - 0.8) ** 2
    wall = 3.0 if x[2] <= 15 else 0.1 + (x[2] - 70) ** 2 / 500
    return (x[0] - 0.7) ** 2 + (x[1] - 0.3) ** 2 + wall


def off_switch_poor_subspace(x):
    """As off_switch_elsewhere, but n = 0's own optimum (0.5) is worse than the run's basin."""
    return off_switch_elsewhere(x) + (0.5 if x[2] == 0 else 0.0)


def as_outputs(f):
    """f as two outputs of a composite surrogate (their sum is f): f - g and a smooth g."""
    def outputs(x):
        g = (x[1] - 0.3) ** 2
        return np.array([f(x) - g, g])
    return outputs


def phases(s) -> dict:
    """Per restart: [its first id, its proposals]."""
    out = {}
    for r in s.history:
        out.setdefault(r["restart"], [r["id"], 0])[1] += 1
    return out
