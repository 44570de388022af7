"""Opening files safely: the inputs a user names, and the files of a run directory.

Two kinds of files, two rules:

* **Inputs** (a case file, a file it ``extends``, an irregularity CSV): the user's own files,
  read through links if need be, but only if they are regular files (a FIFO would hang the
  reader, ``/dev/zero`` would fill the memory) and only up to a size limit, checked while
  reading, never after.
* **Owned files** (everything inside a run directory): lccopt made them, so a symbolic link
  there is not lccopt's and is never followed, neither to read nor to write; a run's
  sub-directory must be a real directory. Every open is non-blocking, so a FIFO planted in a
  run directory is refused instead of hanging the process.

Every refusal is an :class:`UnsafeFile` (an ``OSError`` with the file name and the reason),
which the command line prints as one line with exit 2.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from pathlib import Path

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


def _open(path, flags: int, follow: bool, mode: int = 0o666, blocking: bool = True) -> int:
    """os.open that never blocks on a FIFO and refuses anything but a regular file (left
    non-blocking unless ``blocking``)."""
    flags |= os.O_NONBLOCK | os.O_CLOEXEC | (0 if follow else os.O_NOFOLLOW)
    try:
        fd = os.open(path, flags, mode)
    except OSError as exc:
        if exc.errno == errno.ELOOP and not follow:
            raise UnsafeFile(path, "a symbolic link inside the run directory; lccopt never follows "
                                   "a link it did not make (remove it)", errno.ELOOP) from None
        if exc.errno == errno.ENXIO:  # O_WRONLY|O_NONBLOCK on a FIFO nobody reads
            raise UnsafeFile(path, "a FIFO (named pipe), not a regular file", errno.ENXIO) from None
        raise
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise UnsafeFile(path, f"{kind_of(st.st_mode)}, not a regular file")
        # regular files ignore O_NONBLOCK, but clear it: the descriptor may be handed on
        if blocking:
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd


def _read_limited(fd: int, path, limit: int | None) -> bytes:
    chunks, size = [], 0
    with os.fdopen(fd, "rb", closefd=True) as fh:
        while True:
            want = 1 << 20 if limit is None else min(1 << 20, limit + 1 - size)
            chunk = fh.read(want)
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
    return _read_limited(_open(path, os.O_RDONLY, follow=True, blocking=False), path, limit)


def read_owned(path, limit: int | None = None) -> bytes:
    """The bytes of a file inside a run directory; never through a link, never a FIFO."""
    return _read_limited(_open(path, os.O_RDONLY, follow=False), path, limit)


def open_owned(path, mode: str = "rb"):
    """A file object on a file inside a run directory: ``rb``, ``ab`` (created if missing) or
    ``a+`` (text, created if missing). Never through a link; only regular files."""
    flags = {"rb": os.O_RDONLY, "ab": os.O_WRONLY | os.O_APPEND | os.O_CREAT,
             "a+": os.O_RDWR | os.O_APPEND | os.O_CREAT}[mode]
    fd = _open(path, flags, follow=False)
    if mode != "rb" and os.fstat(fd).st_nlink > 1:   # a hard link is a link too
        os.close(fd)
        raise UnsafeFile(path, "has other hard links; lccopt never writes to a file that is also "
                               "elsewhere (copy it instead)", errno.EMLINK)
    return os.fdopen(fd, mode)


def check_owned_dir(path) -> None:
    """Raise :class:`UnsafeFile` unless ``path`` is a real directory (not a link to one)."""
    st = os.lstat(path)
    if stat.S_ISLNK(st.st_mode):
        raise UnsafeFile(path, "a symbolic link where the run keeps a directory; lccopt never "
                               "writes through a link it did not make (remove it)", errno.ELOOP)
    if not stat.S_ISDIR(st.st_mode):
        raise UnsafeFile(path, f"{kind_of(st.st_mode)} where the run keeps a directory",
                         errno.ENOTDIR)


def is_regular_file(path) -> bool:
    """True for a regular file that is not a link (lstat: nothing is opened)."""
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


@contextlib.contextmanager
def h5_open_owned(path):
    """``with h5_open_owned(p) as f``: an h5py File (read-only) on an HDF5 file inside a run
    directory, through a checked descriptor: never a link, never a FIFO (which would hang
    HDF5's own open)."""
    import h5py

    with open_owned(Path(path), "rb") as fh, h5py.File(fh, "r") as f:
        yield f
