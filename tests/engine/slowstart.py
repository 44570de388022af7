"""A test evaluator (``tests.engine.slowstart:evaluate``) whose local worker takes
``LCCOPT_SLOW_START`` seconds (default 1) to start: importing it in the worker touches the file
``LCCOPT_SLOW_MARK`` (if set), then sleeps. The driver waits for its workers meanwhile, which
gives a test the window in which another process can change the runs folder."""

from __future__ import annotations

import os
import time

from .fakesim import evaluate  # noqa: F401 - the evaluator itself

if os.environ.get("LCCOPT_SLOW_MARK"):
    with open(os.environ["LCCOPT_SLOW_MARK"], "a", encoding="ascii") as _fh:
        _fh.write(f"{os.getpid()}\n")
time.sleep(float(os.environ.get("LCCOPT_SLOW_START", "1")))
