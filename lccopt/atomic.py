"""Atomic, durable file writes: a temporary file in the same directory, fsync, rename, fsync
of the directory. A file that exists under its final name is therefore complete, whatever
kill -9 or a power cut interrupted. With ``durable=False`` (a run's evaluation files, one
per evaluation: two fsyncs each would bound a run's throughput by the disk's fsync rate) the
fsyncs are left out: the file is still complete whatever kill -9 interrupted, but a power cut
can leave it damaged, which ``lccopt resume`` detects and simulates again."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path


def fsync_dir(directory) -> None:
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def normal_mode(path, directory: bool = False) -> None:
    """mkstemp/mkdtemp create 0600/0700: give the permissions open()/mkdir() would."""
    os.chmod(path, (0o777 if directory else 0o666) & ~_umask())


@contextlib.contextmanager
def atomic_path(path, durable: bool = True):
    """Yield a temporary path next to ``path``; on success it is fsynced (``durable``) and
    renamed to ``path``; on failure it is removed."""
    path = Path(path)
    # a link in the way is replaced, never followed (rename does not follow it); a folder or a
    # special file is refused with its own name (rename would otherwise name the temporary file)
    if os.path.lexists(path) and not os.path.islink(path) and not os.path.isfile(path):
        from .safeio import UnsafeFile, kind_of

        raise UnsafeFile(path, f"{kind_of(os.lstat(path).st_mode)} where lccopt writes a file "
                               f"of its own: remove it")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    os.close(fd)
    normal_mode(tmp)
    try:
        yield tmp
        if durable:
            with open(tmp, "rb") as fh:
                os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    if durable:
        fsync_dir(path.parent)


def atomic_write_bytes(path, data: bytes) -> None:
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(data)


def atomic_write_text(path, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))
