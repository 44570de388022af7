"""A stand-in simulator (LCCOPT_EVALUATOR=tests.profile_evaluator:evaluate) whose result shows
the rail profile it was given: the analytic objectives of tests/engine/fakesim.py, with
E_rms = 1 + 1000 x the deepest dip of the case's profile [m] (1 on a smooth rail), so that a
run's table tells which profile every evaluation saw."""

from __future__ import annotations

import numpy as np

from tests.engine import fakesim


def evaluate(case, x):
    ev = fakesim.evaluate(case, x)
    profile = case.irregularity
    ev.objectives["E_rms"] = 1.0 + 1000.0 * (0.0 if profile is None
                                             else float(np.abs(profile[:, 1]).max()))
    return ev
