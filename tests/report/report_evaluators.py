"""Evaluators for the report tests (pointed at by LCCOPT_EVALUATOR).

``fail_window``: the real simulator, except that the calls numbered FROM..TO-1 (0-based, in
the order the workers start them; counted in the file ``count`` of
``LCCOPT_REPORT_FAULT_DIR``) raise. With one worker and the optimiser's default
``max_failed_row`` (max(d, 5) = 8 failures in a row), a window of 8 calls just after the
initial design forces a restart: a run with failed evaluations and a restart, cheaply.
"""

from __future__ import annotations

import fcntl
import os


def _next_call() -> int:
    path = os.path.join(os.environ["LCCOPT_REPORT_FAULT_DIR"], "count")
    with open(path, "a+") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
        fh.seek(0)
        n = int(fh.read().strip() or 0)
        fh.seek(0)
        fh.truncate()
        fh.write(str(n + 1))
    return n


def fail_window(case, x):
    from lccopt.problem import evaluate

    lo, hi = (int(v) for v in os.environ.get("LCCOPT_REPORT_FAIL_CALLS", "5-13").split("-"))
    n = _next_call()
    if lo <= n < hi:
        raise RuntimeError("injected failure")
    return evaluate(case, x)
