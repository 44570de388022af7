"""The errors a user can act on (exit 2), shared by every layer below the CLI.

Kept apart from ``cli.py`` so that the config layer, the engine, the report and the simulate
command can raise them without importing the command line (which imports them).
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import signal
import sys


class CaseError(ValueError):
    """A case file problem, already formatted as ``file:line: key.path: message``; exit 2.

    Its text is one printable line whatever the case file holds: control and format
    characters (a key or a value may carry terminal escape sequences, newlines or
    bidirectional overrides) are shown as escapes."""

    def __str__(self) -> str:
        return printable(super().__str__())


def printable(text: str) -> str:
    """``text`` with every control or format character (category C*, line and paragraph
    separators) replaced by its Python escape, so that it prints as the one line it is."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() or c == " " else repr(c)[1:-1] for c in text)


def printable_lines(text: str) -> str:
    """``text`` as the lines it has: :func:`printable` between its newlines. What lccopt
    prints of a run's stored strings (a case file's path, variable names, failure reasons,
    from run.json, the journal, results.h5) can never move the cursor, clear the screen,
    retitle the terminal or forge a line of its own."""
    if text.isprintable():
        return text
    return "\n".join(printable(line) for line in text.split("\n"))


# The signals that end lccopt in an orderly way: Ctrl-C, what Slurm, systemd, `timeout` and a
# closed terminal send (SIGTERM, SIGHUP), and the other signals whose default is to end a
# process that a scheduler or a limit may send (Slurm's --signal=USR1, a CPU time limit's
# SIGXCPU). Each stops a command with exit 130, and a run saved; the workers ignore them (they
# reach the whole process group). SIGKILL and SIGQUIT end the process at once: a run's journal
# keeps everything committed, as after a crash.
STOP_SIGNALS = tuple(getattr(signal, name) for name in
                     ("SIGINT", "SIGTERM", "SIGHUP", "SIGUSR1", "SIGUSR2", "SIGALRM", "SIGXCPU")
                     if hasattr(signal, name))


class Interrupted(KeyboardInterrupt):
    """A stopping signal outside a run's loop (which handles its own): exit 130."""

    last: int | None = None   # the last signal raised as Interrupted (the command line's note)

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signum)
        self.signum = signum

    @property
    def name(self) -> str:
        try:
            return signal.Signals(self.signum).name
        except ValueError:
            return f"signal {self.signum}"


class RunInterrupted(Interrupted):
    """A run (``lccopt.optimise``, ``lccopt.resume``) stopped before its end by a stopping
    signal: Ctrl-C (the evaluations running finish first; a second Ctrl-C stops them too),
    SIGTERM, SIGHUP and the others of ``STOP_SIGNALS`` (at once). Nothing is lost: every
    evaluation committed is in the run directory ``path`` and the ones in flight stay pending;
    ``lccopt.resume(path)`` carries the run on to the table an uninterrupted run makes, with
    no budget spent twice. The command line says so and exits 130.

    A ``KeyboardInterrupt`` (as Ctrl-C in any Python program), so that ``except Exception``
    does not swallow it. ``signum``: the first stopping signal (None when the run stopped
    for another reason, e.g. its output pipe closed); ``done`` and ``budget``: the
    evaluations saved and the run's budget."""

    def __init__(self, path, done: int, budget: int, signum: int | None = None):
        super().__init__(signal.SIGINT if signum is None else signum)
        self.signum = signum
        self.path, self.done, self.budget = path, done, budget

    def __str__(self) -> str:
        how = f" by {self.name}" if self.signum is not None else ""
        return (f"run {self.path} interrupted{how}: {self.done}/{self.budget} evaluations saved; "
                f"carry on with lccopt.resume({str(self.path)!r})")


_swallowed: list[BaseException] = []   # interruptions raised where they could not propagate
_files_in_place = False   # the command's files are in place: nothing is left to stop


def _raise_interrupted(signum, frame):
    Interrupted.last = signum
    if _files_in_place:
        return   # too late to stop anything: the command ends as it would have
    raise Interrupted(signum)


def _unraisable(info) -> None:
    """An interruption raised inside a finaliser (``__del__``, a weak reference's callback)
    cannot propagate: instead of a traceback, the command stops at its next commit (see
    :func:`committing`) or ends with exit 130 once done."""
    if isinstance(info.exc_value, KeyboardInterrupt):
        _swallowed.append(info.exc_value)
        return
    sys.__unraisablehook__(info)


def swallowed_interruption() -> BaseException | None:
    """The first interruption that a finaliser swallowed in this command, if any."""
    return _swallowed[0] if _swallowed else None


def stop_on_signals() -> None:
    """Make every stopping signal raise :class:`Interrupted` (as Ctrl-C raises
    KeyboardInterrupt), from the main thread of the command line only: the library leaves
    a program's signals alone (a run's loop sets and restores its own)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return
    global _files_in_place
    _files_in_place = False
    _swallowed.clear()
    sys.unraisablehook = _unraisable
    for sig in STOP_SIGNALS:
        try:
            signal.signal(sig, _raise_interrupted)
        except (OSError, ValueError):
            pass


@contextlib.contextmanager
def signals_deferred():
    """A step that must not be cut in two by a stopping signal (replacing or creating a run
    directory, a journal line and the file that goes with it): a signal that arrives meanwhile
    takes effect when the step is done, as it would have then. Handlers rather than a signal
    mask: a process signal may be delivered to any thread that does not block it (Dask's)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []
    old = {}
    for sig in STOP_SIGNALS:
        try:
            old[sig] = signal.signal(sig, lambda signum, frame: pending.append(signum))
        except (OSError, ValueError):
            pass
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)
        if pending:
            signal.raise_signal(pending[0])


class UsageError(Exception):
    """Bad input that is not a case-file problem (options, run directories); exit 2."""


class EnvironmentFault(UsageError):
    """The machine refused a write or a read (disk full, read-only, files deleted); exit 2.

    The run stops where it is: what was committed stays, what was in flight stays pending."""


# errno values that mean "the environment", never "this design failed"
_ENVIRONMENT_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM,
                       errno.EIO, errno.ENOENT, errno.ENOTDIR, errno.EFBIG, errno.EMFILE,
                       errno.ENFILE, errno.ESTALE}
_H5_ERRNO = re.compile(r"errno = (\d+)")            # HDF5 reports the C errno only in its text
_H5_FILE = re.compile(r"(?:filename|name) = '([^']*)'")


def environment_errno(exc: BaseException) -> int | None:
    """The errno of an environment fault behind ``exc`` (also inside h5py's messages), else None."""
    if not isinstance(exc, (OSError, RuntimeError)):
        return None
    code = getattr(exc, "errno", None)
    if code is None:
        m = _H5_ERRNO.search(str(exc))
        code = int(m.group(1)) if m else None
    return code if code in _ENVIRONMENT_ERRNOS else None


def describe_os_error(exc: BaseException) -> str:
    """One line: the file and the system's reason."""
    code = environment_errno(exc) or getattr(exc, "errno", None)
    first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    reason = getattr(exc, "strerror", None) or (os.strerror(code) if code else first)
    name = getattr(exc, "filename", None)
    if name is None:
        m = _H5_FILE.search(str(exc))
        name = m.group(1) if m else None
    return f"{name}: {reason}" if name else reason


@contextlib.contextmanager
def committing():
    """The step that moves a command's files into place (``lccopt.outdir``), so that an
    interruption either leaves nothing or comes too late to stop anything: one that a
    finaliser swallowed earlier stops the command before the step; a stopping signal during
    the step waits for its end; once the step is done the command's work is in place, and
    under the command line a stopping signal no longer stops it (it ends as it would have,
    exit 0). A program using the library keeps its own handlers: its Ctrl-C then arrives
    after the files are in place, as in any Python code."""
    global _files_in_place
    if _swallowed:
        raise _swallowed[0]
    with signals_deferred():
        yield
        _files_in_place = True
