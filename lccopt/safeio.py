"""Opening files safely: the rules every file lccopt reads or writes goes by, and the inputs a
user names.

Two kinds of files, two rules:

* **Inputs** (a case file, a file it ``extends``, an irregularity CSV): the user's own files,
  read through links if need be, but only if they are regular files (a FIFO would hang the
  reader, ``/dev/zero`` would fill the memory) and only up to a size limit, checked while
  reading, never after (:func:`read_input`).
* **Owned files** (everything inside a run directory or an output folder): lccopt made them,
  so a symbolic link there is not lccopt's and is never followed, neither to read nor to
  write; a sub-directory must be a real directory. Every open is non-blocking, so a FIFO
  planted there is refused instead of hanging the process. A file with other hard links is
  read like any other (it is the same file), but never written in place. They are opened
  relative to a directory held open (``folder.Folder``); their HDF5 files are read through
  ``safe_h5``.

Every refusal is an :class:`UnsafeFile` (an ``OSError`` with the file name and the reason),
which the command line prints as one line with exit 2.
"""

from __future__ import annotations

import errno
import os
import stat

_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISDIR, "a directory"), (stat.S_ISLNK, "a symbolic link"))


class UnsafeFile(OSError):
    """A file lccopt refuses to read or write (not a regular file, a link, too large)."""

    def __init__(self, path, reason: str, code: int = errno.EINVAL):
        super().__init__(code, reason, str(path))

    def __str__(self) -> str:
        return f"{self.filename}: {self.strerror}"


def kind_of(mode: int) -> str:
    """What a file of this ``st_mode`` is, in words (for messages)."""
    for test, words in _KINDS:
        if test(mode):
            return words
    return "not a regular file"


def named(exc: OSError, path) -> OSError:
    """``exc`` naming ``path`` (the file the user knows: never a temporary name)."""
    if isinstance(exc, UnsafeFile):
        return exc
    out = OSError(exc.errno, exc.strerror or str(exc), str(path))
    out.__cause__ = exc.__cause__
    return out



def open_regular(path, flags: int, follow: bool, mode: int = 0o666, blocking: bool = True,
          dir_fd: int | None = None, shown=None) -> int:
    """os.open that never blocks on a FIFO and refuses anything but a regular file (left
    non-blocking unless ``blocking``)."""
    shown = path if shown is None else shown
    flags |= os.O_NONBLOCK | os.O_CLOEXEC | (0 if follow else os.O_NOFOLLOW)
    try:
        fd = os.open(path, flags, mode, dir_fd=dir_fd)
    except OSError as exc:
        if exc.errno == errno.ELOOP and not follow:
            raise UnsafeFile(shown, "a symbolic link where lccopt keeps a file of its own; "
                                    "lccopt never follows a link it did not make (remove it)",
                             errno.ELOOP) from None
        if exc.errno == errno.ENXIO:  # O_WRONLY|O_NONBLOCK on a FIFO nobody reads
            raise UnsafeFile(shown, "a FIFO (named pipe), not a regular file",
                             errno.ENXIO) from None
        if exc.errno == errno.EISDIR:
            raise UnsafeFile(shown, "a directory where lccopt keeps a file of its own",
                             errno.EISDIR) from None
        raise named(exc, shown) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise UnsafeFile(shown, f"{kind_of(st.st_mode)}, not a regular file")
        # regular files ignore O_NONBLOCK, but clear it: the descriptor may be handed on
        if blocking:
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd


def read_limited(fd: int, path, limit: int | None) -> bytes:
    chunks, size = [], 0
    with os.fdopen(fd, "rb", closefd=True) as fh:
        while True:
            want = 1 << 20 if limit is None else min(1 << 20, limit + 1 - size)
            try:
                chunk = fh.read(want)
            except OSError as exc:
                raise named(exc, path) from None
            if chunk is None:   # a kernel file that waits for data (e.g. /proc/kmsg)
                raise UnsafeFile(path, "reading it would wait for more data (a kernel or device "
                                       "file, not a regular file's content)", errno.EAGAIN)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
            if limit is not None and size > limit:
                raise UnsafeFile(path, f"larger than {limit:,} bytes (is this the right file?)",
                                 errno.EFBIG)
    return b"".join(chunks)


def read_input(path, limit: int) -> bytes:
    """The bytes of an input file the user named (links followed), at most ``limit`` bytes.

    Raises
    ------
    UnsafeFile
        not a regular file, or larger than ``limit``.
    OSError
        the file cannot be opened (missing, no permission, ...).
    """
    # left non-blocking: a regular file reads the same, a kernel file that would wait
    # (a /proc file looks regular) is refused instead of hanging
    return read_limited(open_regular(path, os.O_RDONLY, follow=True, blocking=False), path, limit)
