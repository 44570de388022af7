"""The driving process's own clock: monotonic time without the time it was stopped.

A driver stopped by SIGSTOP or Ctrl-Z (SIGTSTP to the terminal's process group), or frozen
by a debugger or a cgroup freezer, does not run its loop; whatever the designs in flight did
meanwhile, that pause is the driver's, not theirs. Timeouts are measured on :func:`now`,
which leaves it out: when the process is continued (SIGCONT, handled while a run's loop is
installed) the time since the driver was last seen running is added to the pause.

The driver is "seen" at every call of :func:`now` (the loop calls it at least every 0.2 s),
so a pause is counted from at most one loop turn before the stop: a design in flight may get
that much more than its timeout, never less.
"""

from __future__ import annotations

import signal
import time

_paused = 0.0                 # seconds this process was stopped, in all
_seen = time.monotonic()      # the last moment it was seen running


def now() -> float:
    """Monotonic seconds, less the time this process was stopped."""
    global _seen
    _seen = time.monotonic()
    return _seen - _paused


def paused() -> float:
    """Seconds this process was stopped so far (as far as SIGCONT told)."""
    return _paused


def continued(signum=None, frame=None) -> None:
    """SIGCONT: the process ran again; the time since it was last seen was a pause."""
    global _paused, _seen
    t = time.monotonic()
    _paused += max(0.0, t - _seen)
    _seen = t


def install():
    """Handle SIGCONT (main thread only); return the handler it replaced, or None."""
    import threading

    if threading.current_thread() is not threading.main_thread() or not hasattr(signal,
                                                                                 "SIGCONT"):
        return None
    now()
    return signal.signal(signal.SIGCONT, continued)
