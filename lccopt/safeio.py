"""Opening files safely: the inputs a user names, and the files lccopt keeps (a run directory,
a report or simulation output folder).

Two kinds of files, two rules:

* **Inputs** (a case file, a file it ``extends``, an irregularity CSV): the user's own files,
  read through links if need be, but only if they are regular files (a FIFO would hang the
  reader, ``/dev/zero`` would fill the memory) and only up to a size limit, checked while
  reading, never after.
* **Owned files** (everything inside a run directory or an output folder): lccopt made them,
  so a symbolic link there is not lccopt's and is never followed, neither to read nor to
  write; a sub-directory must be a real directory. Every open is non-blocking, so a FIFO
  planted there is refused instead of hanging the process. A file with other hard links is
  read like any other (it is the same file), but never written in place.

Owned files are opened relative to a :class:`Folder`, a directory held open (``openat``):
once a run directory is open, renaming it or putting a link in its place never redirects a
read or a write, because its path is never looked up again.

HDF5 files lccopt reads are checked: when opened, that every link stays in the file (no soft or
external link, except results.h5's own links to its evaluation files, which lccopt never
follows); before a dataset is read (:func:`h5_read`) or copied, that it has no external
storage, is not virtual, uses no compression filter HDF5 lacks and is not too large to read.
Each of these would make HDF5 open other files by name, behind lccopt's back (a FIFO there
hangs the reader), or load code, or exhaust the memory.

Every refusal is an :class:`UnsafeFile` (an ``OSError`` with the file name and the reason),
which the command line prints as one line with exit 2.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import re
import secrets
import stat
import weakref
from pathlib import Path

_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISDIR, "a directory"), (stat.S_ISLNK, "a symbolic link"))
_DIR_FLAGS = os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC | os.O_NONBLOCK


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


def _close_quietly(fd: int) -> None:
    with contextlib.suppress(OSError):
        os.close(fd)


# ------------------------------------------------------------------------------ folders

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
        return _open(name, flags, follow=False, mode=mode, blocking=blocking, dir_fd=self.fd,
                     shown=self.display(name))

    def read(self, name: str, limit: int | None = None) -> bytes:
        return _read_limited(self.open_fd(name, os.O_RDONLY), self.display(name), limit)

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
        from .atomic import write_in

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


def _open(path, flags: int, follow: bool, mode: int = 0o666, blocking: bool = True,
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


def _read_limited(fd: int, path, limit: int | None) -> bytes:
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
    return _read_limited(_open(path, os.O_RDONLY, follow=True, blocking=False), path, limit)


# -- an owned file named by its path (its folder opened for the one access) ---------------------

@contextlib.contextmanager
def _place(src):
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
    with _place(src) as (folder, name):
        return folder.read(name, limit)


def open_owned(src, mode: str = "rb"):
    """A file object on an owned file (see :meth:`Folder.open_file`)."""
    with _place(src) as (folder, name):
        return folder.open_file(name, mode)


# ------------------------------------------------------------------------------ HDF5

MAX_H5_OBJECTS = 100_000        # links in one file: lccopt's largest (traffic) hold ~500
MAX_DATASET_BYTES = 1 << 30     # one dataset read whole: lccopt's largest are a few MB
# compression filters HDF5 has built in (or h5py registers): never a plugin loaded from disk
SAFE_FILTERS = {1: "deflate", 2: "shuffle", 3: "fletcher32", 4: "szip", 5: "nbit",
                6: "scaleoffset", 32000: "lzf"}
EVALS_LINK = re.compile(r"evals/\d{6}")   # results.h5's links to its evaluation files


@contextlib.contextmanager
def h5_open_owned(src, evals_links: bool = False):
    """``with h5_open_owned(src) as f``: an h5py File (read-only) on an owned HDF5 file (a path
    or ``(Folder, name)``), through a checked descriptor (never a link, never a FIFO, which
    would hang HDF5's own open), whose links are all within the file (:func:`check_links`;
    ``evals_links``: results.h5's links to its evaluation files are allowed, never followed).
    Read its datasets with :func:`h5_read`, which checks each before reading it."""
    import h5py

    with _place(src) as (folder, name):
        shown = folder.display(name)
        with folder.open_file(name, "rb") as fh:
            try:
                f = h5py.File(fh, "r")
            except OSError as exc:
                raise UnsafeFile(shown, f"not a readable HDF5 file ({_h5_reason(exc)})",
                                 errno.EIO) from None
            key = f.id.fileno
            _H5_NAMES[key] = shown
            try:
                with f:
                    check_links(f, shown, evals_links)
                    yield f
            finally:
                _H5_NAMES.pop(key, None)


_H5_NAMES: dict = {}   # HDF5 file number -> the file's path, for messages


def _h5_reason(exc: BaseException) -> str:
    return str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__


def _text(name) -> str:
    return name.decode("utf-8", "replace") if isinstance(name, bytes) else str(name)


def _refuse(shown, why: str) -> UnsafeFile:
    return UnsafeFile(shown, f"holds {why}; lccopt reads only HDF5 files that keep their data in "
                             f"themselves (is this lccopt's file?)")


def check_links(f, shown, evals_links: bool = False) -> None:
    """Refuse (UnsafeFile) an HDF5 file with a soft, external or user-defined link (a reader
    would follow it to another file or object, by name), or more than MAX_H5_OBJECTS links."""
    from h5py import h5l

    count = 0

    def link(name, info):
        nonlocal count
        count += 1
        if count > MAX_H5_OBJECTS:
            return f"more than {MAX_H5_OBJECTS:,} objects"
        if info.type == h5l.TYPE_HARD:
            return None
        text = _text(name)
        if info.type == h5l.TYPE_EXTERNAL:
            if evals_links and EVALS_LINK.fullmatch(text):
                return None
            return f"a link to another file at /{text[:80]}"
        return f"a {'soft' if info.type == h5l.TYPE_SOFT else 'user-defined'} link at /{text[:80]}"

    try:
        why = f.id.links.visit(link, info=True)
    except (KeyError, ValueError, RuntimeError, OSError) as exc:
        raise UnsafeFile(shown, f"not a readable HDF5 file ({_h5_reason(exc)})",
                         errno.EIO) from None
    if why:
        raise _refuse(shown, why)


def dataset_problem(dsid) -> str | None:
    """Why the dataset (a low-level h5py DatasetID) must not be read: its data in other files
    (external storage, a virtual dataset), a filter HDF5 would load from disk, or too large;
    None if it may."""
    from h5py import h5d

    dcpl = dsid.get_create_plist()
    if dcpl.get_layout() == h5d.VIRTUAL:
        return "a virtual dataset (its data are in other files)"
    if dcpl.get_external_count():
        return "a dataset stored in external files"
    for i in range(dcpl.get_nfilters()):
        code = dcpl.get_filter(i)[0]
        if code not in SAFE_FILTERS:
            return f"a dataset with compression filter {code}, which HDF5 does not have built in"
    space = dsid.get_space()
    n = 1
    for s in space.shape if space.get_simple_extent_type() == 1 else ():
        n *= int(s)
    if n * max(1, dsid.get_type().get_size()) > MAX_DATASET_BYTES:
        return f"a dataset of {n:,} values, too large to read"
    return None


def h5_read(ds):
    """The whole of dataset ``ds`` (of a file opened by :func:`h5_open_owned`), after checking
    it (:func:`dataset_problem`)."""
    why = dataset_problem(ds.id)
    if why:
        raise _refuse(_H5_NAMES.get(ds.id.fileno, ds.file.filename), f"{why} at {ds.name[:80]}")
    return ds[()]


def check_datasets(f) -> None:
    """Every dataset of ``f`` checked (:func:`dataset_problem`): before HDF5 copies them whole."""
    from h5py import h5d, h5o

    def visit(name, info):
        if info.type == h5o.TYPE_DATASET:
            why = dataset_problem(h5d.open(f.id, name))
            return f"{why} at /{_text(name)[:80]}" if why else None
        return None

    why = h5o.visit(f.id, visit, info=True)
    if why:
        raise _refuse(_H5_NAMES.get(f.id.fileno, f.filename), why)
