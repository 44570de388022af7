"""A test evaluator (``tests.engine.forkless:evaluate``) whose local worker process cannot
fork after its first ``LCCOPT_FORKS`` evaluations (default 3), as on a machine with no memory
or process slots left: importing it in the worker makes ``os.fork`` fail from then on."""

from __future__ import annotations

import errno
import os

from .fakesim import evaluate  # noqa: F401 - the evaluator itself

_fork = os.fork
_left = int(os.environ.get("LCCOPT_FORKS", "3"))


def _limited_fork() -> int:
    global _left
    if _left <= 0:
        raise OSError(errno.EAGAIN, os.strerror(errno.EAGAIN))
    _left -= 1
    return _fork()


os.fork = _limited_fork
