"""How a run's loop stops: the stopping signals it handles while it runs.

Ctrl-C (SIGINT) stops proposing and lets the running evaluations finish; a second Ctrl-C,
SIGTERM, SIGHUP (Slurm, systemd, timeout, a closed terminal) and the other stopping signals
stop them at once. Handlers are set in the main thread only, for the loop's duration, and
the program's own put back after it. The loop then saves the run and raises
:class:`lccopt.errors.RunInterrupted` (``signum``: the first signal).
"""

from __future__ import annotations

import signal
import threading

from ..errors import STOP_SIGNALS
from . import awake


class StopSignals:
    """``stop``: propose nothing more; ``abort``: stop the running evaluations too."""

    def __init__(self):
        self.stop = False
        self.abort = False
        self.signum: int | None = None   # the first stopping signal of the run
        self._old_handlers: dict = {}

    def _on_signal(self, signum, frame) -> None:
        if self.signum is None:
            self.signum = signum
        if signum == signal.SIGINT and not self.stop:
            self.stop = True
        else:
            self.stop = self.abort = True

    def install(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return
        # the workers ignore the stopping signals, so an evaluation is never reported as
        # killed by them
        for sig in STOP_SIGNALS:
            self._old_handlers[sig] = signal.signal(sig, self._on_signal)
        # SIGCONT after SIGSTOP or Ctrl-Z: the pause was this process's (awake.py)
        old = awake.install()
        if old is not None:
            self._old_handlers[signal.SIGCONT] = old

    def restore(self) -> None:
        for sig, h in self._old_handlers.items():
            signal.signal(sig, h)
        self._old_handlers.clear()
