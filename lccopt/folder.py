"""A directory lccopt owns, held open: a run directory, its evals/, a report or simulation
output folder.

Owned files are opened relative to a :class:`Folder`, a directory held open (``openat``):
once a run directory is open, renaming it or putting a link in its place never redirects a
read or a write, because its path is never looked up again. What is in it goes by the rules
of owned files (``safeio``): never through a link, never blocking on a FIFO, only regular
files, never writing to a file with other hard links. A file is written whole or not at all
(``atomic``).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import secrets
import stat
import weakref
from pathlib import Path

from .atomic import write_in
from .safeio import UnsafeFile, kind_of, named, open_regular, read_limited

_DIR_FLAGS = os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC | os.O_NONBLOCK


def _close_quietly(fd: int) -> None:
    with contextlib.suppress(OSError):
        os.close(fd)



class Folder:
    """A directory held open; files in it are opened, written, renamed and removed relative to
    its descriptor (``dir_fd=``), never by looking its path up again. ``path`` is for messages.
    """

    def __init__(self, fd: int, path):
        self.fd = fd
        self.path = Path(path)
        self._closer = weakref.finalize(self, _close_quietly, fd)

    # -- opening ----------------------------------------------------------------------------
    @classmethod
    def open(cls, path, create: bool = False, follow: bool = True) -> "Folder":
        """The directory at ``path`` (made, with its parents, if ``create``). ``follow``: the
        user named it, so links on the way are theirs; else the last component must be a real
        directory, not a link to one."""
        path = Path(path)
        if create:
            try:
                os.makedirs(path, exist_ok=True)
            except FileExistsError:
                pass  # a file or a dangling link: said by the open below
        try:
            fd = os.open(path, _DIR_FLAGS | (0 if follow else os.O_NOFOLLOW))
        except OSError as exc:
            raise _dir_error(exc, path) from None
        return cls(fd, path)

    def sub(self, name: str, create: bool = False) -> "Folder":
        """The sub-directory ``name`` (made if ``create`` and missing); never a link."""
        if create:
            try:
                os.mkdir(name, 0o777, dir_fd=self.fd)
            except FileExistsError:
                pass
            except OSError as exc:
                raise named(exc, self.path / name) from None
        try:
            fd = os.open(name, _DIR_FLAGS | os.O_NOFOLLOW, dir_fd=self.fd)
        except OSError as exc:
            raise _dir_error(exc, self.path / name, self.lstat(name)) from None
        return Folder(fd, self.path / name)

    def close(self) -> None:
        self._closer()

    def __enter__(self) -> "Folder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Folder({str(self.path)!r}, fd={self.fd})"

    # -- entries ----------------------------------------------------------------------------
    @property
    def identity(self) -> tuple[int, int]:
        st = os.fstat(self.fd)
        return st.st_dev, st.st_ino

    def lstat(self, name: str):
        """The entry ``name`` as it is (a link is not followed), or None if there is none."""
        try:
            return os.stat(name, dir_fd=self.fd, follow_symlinks=False)
        except FileNotFoundError:
            return None

    def exists(self, name: str) -> bool:
        return self.lstat(name) is not None

    def is_file(self, name: str) -> bool:
        """True for a regular file that is not a link."""
        st = self.lstat(name)
        return st is not None and stat.S_ISREG(st.st_mode)

    def names(self) -> list[str]:
        return sorted(os.listdir(self.fd))

    def display(self, name: str) -> Path:
        """The path of entry ``name`` as the user knows it (for messages only)."""
        return self.path / name

    def still_at(self, path) -> bool:
        """Whether ``path`` still leads to this directory (it was not moved or replaced)."""
        try:
            st = os.stat(path)
        except OSError:
            return False
        return (st.st_dev, st.st_ino) == self.identity

    # -- files ------------------------------------------------------------------------------
    def open_fd(self, name: str, flags: int, mode: int = 0o666, blocking: bool = True) -> int:
        """os.open relative to the folder: never through a link, never blocking on a FIFO,
        only a regular file (left non-blocking unless ``blocking``)."""
        return open_regular(name, flags, follow=False, mode=mode, blocking=blocking, dir_fd=self.fd,
                     shown=self.display(name))

    def read(self, name: str, limit: int | None = None) -> bytes:
        return read_limited(self.open_fd(name, os.O_RDONLY), self.display(name), limit)

    def open_file(self, name: str, mode: str = "rb"):
        """A file object: ``rb``, ``ab`` (created if missing) or ``a+`` (text, created if
        missing). Never through a link; only regular files; never writing to a file that has
        other hard links."""
        flags = {"rb": os.O_RDONLY, "ab": os.O_WRONLY | os.O_APPEND | os.O_CREAT,
                 "a+": os.O_RDWR | os.O_APPEND | os.O_CREAT}[mode]
        fd = self.open_fd(name, flags)
        if mode != "rb" and os.fstat(fd).st_nlink > 1:   # a hard link is a link too
            os.close(fd)
            raise UnsafeFile(self.display(name), "has other hard links; lccopt never writes to "
                             "a file that is also elsewhere (copy it instead)", errno.EMLINK)
        return os.fdopen(fd, mode)

    def write(self, name: str, data: bytes, durable: bool = True) -> Path:
        """Write ``name`` whole or not at all (``atomic.write_in``); return its display path."""
        write_in(self, name, data, durable)
        return self.display(name)

    def unlink(self, name: str, missing_ok: bool = True) -> None:
        try:
            os.unlink(name, dir_fd=self.fd)
        except FileNotFoundError:
            if not missing_ok:
                raise
        except OSError as exc:
            raise named(exc, self.display(name)) from None

    def rename(self, src: str, dst: str, into: "Folder | None" = None) -> None:
        """Rename entry ``src`` to ``dst`` (in ``into``, default this folder); an entry
        ``dst`` is replaced, never followed."""
        target = into or self
        try:
            os.rename(src, dst, src_dir_fd=self.fd, dst_dir_fd=target.fd)
        except OSError as exc:
            raise named(exc, target.display(dst)) from None

    def make_temp_dir(self, prefix: str, suffix: str = ".tmp") -> str:
        """A new sub-directory named ``prefix`` + random + ``suffix``; return its name."""
        while True:
            name = f"{prefix}{secrets.token_hex(4)}{suffix}"
            try:
                os.mkdir(name, 0o777, dir_fd=self.fd)
                return name
            except FileExistsError:
                continue
            except OSError as exc:
                raise named(exc, self.display(name)) from None

    def remove_tree(self, name: str) -> None:
        """Remove the sub-directory ``name`` and all in it (never following a link in it)."""
        import shutil

        st = self.lstat(name)
        if st is None:
            return
        if not stat.S_ISDIR(st.st_mode):
            self.unlink(name)
            return
        shutil.rmtree(name, dir_fd=self.fd)

    def fsync(self) -> None:
        os.fsync(self.fd)

    def try_lock(self, shared: bool = False) -> bool:
        """flock this directory (exclusive unless ``shared``) without waiting; True if got.
        Held until the folder is closed."""
        try:
            fcntl.flock(self.fd, (fcntl.LOCK_SH if shared else fcntl.LOCK_EX) | fcntl.LOCK_NB)
        except OSError:
            return False
        return True

    def unlock(self) -> None:
        with contextlib.suppress(OSError):
            fcntl.flock(self.fd, fcntl.LOCK_UN)


def _dir_error(exc: OSError, path, st=None) -> OSError:
    if exc.errno == errno.ELOOP:
        return UnsafeFile(path, "a symbolic link where lccopt keeps a directory; lccopt never "
                                "writes through a link it did not make (remove it)", errno.ELOOP)
    if exc.errno == errno.ENOTDIR:
        try:
            st = st or os.lstat(path)
            what = kind_of(st.st_mode) if not stat.S_ISREG(st.st_mode) else "a regular file"
        except OSError:
            what = "not a directory"
        return UnsafeFile(path, f"{what} where lccopt keeps a directory", errno.ENOTDIR)
    return named(exc, path)


# -- an owned file named by its path (its folder opened for the one access) ---------------------

@contextlib.contextmanager
def owned_entry(src):
    """(folder, name) of ``src``: a ``(Folder, name)`` pair, or a path (its parent opened)."""
    if isinstance(src, tuple):
        yield src
        return
    path = Path(src)
    with Folder.open(path.parent) as folder:
        yield folder, path.name


def read_owned(src, limit: int | None = None) -> bytes:
    """The bytes of an owned file (a path or ``(Folder, name)``); never through a link, never a
    FIFO."""
    with owned_entry(src) as (folder, name):
        return folder.read(name, limit)


def open_owned(src, mode: str = "rb"):
    """A file object on an owned file (see :meth:`Folder.open_file`)."""
    with owned_entry(src) as (folder, name):
        return folder.open_file(name, mode)


def write_owned(dest, data: bytes, durable: bool = True) -> Path:
    """Write an owned file (a path, its folder opened for the one write, or ``(Folder, name)``)
    whole or not at all (fsynced if ``durable``); return its path (for messages)."""
    with owned_entry(dest) as (folder, name):
        return folder.write(name, data, durable)
