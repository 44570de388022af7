"""The errors a user can act on (exit 2), shared by every layer below the CLI.

Kept apart from ``cli.py`` so that the config layer, the engine, the report and the simulate
command can raise them without importing the command line (which imports them).
"""

from __future__ import annotations

import errno
import os
import re


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
