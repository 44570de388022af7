"""Atomic, durable file writes: a temporary file in the same directory, fsync, rename, fsync
of the directory. A file that exists under its final name is therefore complete, whatever
kill -9 or a power cut interrupted. With ``durable=False`` (a run's evaluation files, one
per evaluation: two fsyncs each would bound a run's throughput by the disk's fsync rate) the
fsyncs are left out: the file is still complete whatever kill -9 interrupted, but a power cut
can leave it damaged, which ``lccopt resume`` detects and simulates again.

Everything is done relative to a held directory (``folder.Folder``, whose ``write`` this is;
``folder.write_owned`` for a file named by its path): the temporary file is created there
(``O_EXCL``, never through a link) and renamed there. A failure (a full disk, a read-only or
immutable file) names the file being written, never the temporary one, which is removed.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import stat

from .safeio import UnsafeFile, kind_of, named


def write_in(folder, name: str, data: bytes, durable: bool = True) -> None:
    """Write ``data`` as ``name`` in ``folder`` (a ``folder.Folder``), whole or not at all (see
    the module docstring).

    A link in the way is replaced, never followed (rename does not follow it); a folder or a
    special file there is refused with its own name."""
    st = folder.lstat(name)
    if st is not None and not (stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode)):
        raise UnsafeFile(folder.display(name), f"{kind_of(st.st_mode)} where lccopt writes a "
                                               f"file of its own: remove it")
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
    while True:
        tmp = f"{name}.{secrets.token_hex(4)}.tmp"
        try:
            fd = os.open(tmp, flags, 0o666, dir_fd=folder.fd)
            break
        except FileExistsError:
            continue
        except OSError as exc:
            raise named(exc, folder.display(name)) from None
    try:
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
            if durable:
                os.fsync(fd)
        finally:
            os.close(fd)
        os.rename(tmp, name, src_dir_fd=folder.fd, dst_dir_fd=folder.fd)
        if durable:
            folder.fsync()
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp, dir_fd=folder.fd)
        if isinstance(exc, OSError):
            raise named(exc, folder.display(name)) from None
        raise

