"""Output folders: where ``lccopt report`` and ``lccopt simulate`` write their files.

A command's files are written whole or not at all: they are built in a staging folder (a new
folder of lccopt's, named ``.lccopt-*.tmp``, held open and locked while it is built), and only
when every file is complete are they moved into place, each by one rename:

* **a folder the user names** (``--out DIR``, ``simulate``'s default ``runs/<case>-simulate``):
  made if missing; the files already there are refused unless ``--force`` (``names``: every
  file and sub-folder the command may write, checked before anything is computed); with
  ``--force`` a file, or a link, in the way is replaced, never written through; a sub-folder
  of the same name is filled the same way (a link in its place is replaced by a real folder).
  The staging folder is built inside DIR, so nothing is written outside it.
* **a folder lccopt owns whole** (a run's ``report/``): built beside it in the run directory and
  swapped with it at once (``renameat2(RENAME_EXCHANGE)``; two renames where the file system
  cannot), so the old report stays whole until the new one replaces it whole.

One command at a time per folder: the folder the files are moved into is locked (flock) for
the whole command; a second one is refused with one line. A staging folder that a killed
command left (kill -9: nothing else can leave one) is removed by the next command that writes
there. Everything is done relative to folders held open (``folder.Folder``): moving DIR or
putting a link in its place meanwhile never redirects a write.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import stat
from pathlib import Path

from .errors import UsageError, committing
from .folder import Folder
from .safeio import UnsafeFile, kind_of, named

STAGING = ".lccopt-"        # .lccopt-<command>-XXXXXXXX.tmp
_RENAME_NOREPLACE, _RENAME_EXCHANGE = 1, 2


class Place:
    """A file to write in a staging folder: ``folder``/``name``, shown as ``shown`` (where it
    will be once published). Has a path's ``name``, ``stem`` and ``suffix``."""

    def __init__(self, folder: Folder, name: str, shown: Path):
        self.folder, self.name, self.shown = folder, name, Path(shown)
        self.stem, self.suffix = Path(name).stem, Path(name).suffix

    def write_bytes(self, data: bytes) -> "Place":
        self.folder.write(self.name, data)
        return self

    def read_bytes(self) -> bytes:
        return self.folder.read(self.name)

    def __str__(self) -> str:
        return str(self.shown)

    def __repr__(self) -> str:
        return f"Place({str(self.shown)!r})"


class Staged:
    """A staging folder (or a sub-folder of one): ``staged / name`` is the :class:`Place` of a
    file in it, ``staged.sub(name)`` a sub-folder."""

    def __init__(self, folder: Folder, shown: Path):
        self.folder, self.shown = folder, Path(shown)
        self.lines: list[str] = []   # what the command says of its files once they are in place

    def __truediv__(self, name: str) -> Place:
        return Place(self.folder, name, self.shown / name)

    def sub(self, name: str) -> "Staged":
        return Staged(self.folder.sub(name, create=True), self.shown / name)

    @property
    def name(self) -> str:
        return self.shown.name

    def __str__(self) -> str:
        return str(self.shown)


class Output:
    """The files of one command, staged and then published (see the module docstring); a
    context manager: published on success, dropped on any error or interruption."""

    def __init__(self, target: Folder, staging_name: str, staging: Folder, shown: Path,
                 force: bool, whole: str | None, holder: Folder, made: bool = False):
        self.target = target            # where the files go (the user's DIR, or the run folder)
        self.staging_name = staging_name
        self.staging = staging
        self.shown = Path(shown)        # the folder the user reads the files in
        self.force = force
        self.whole = whole              # name of the folder lccopt owns whole in target, or None
        self._holder = holder           # the locked folder
        self._made = made               # the command made the user's folder
        self._published = False
        # files being built are named where they will be (a full disk names report.md, not
        # a staging folder the user never sees)
        staging.path = self.shown
        self.root = Staged(staging, self.shown)

    @property
    def lines(self) -> list[str]:
        return self.root.lines

    # -- making ---------------------------------------------------------------------------------
    @classmethod
    def into(cls, out: Path, files, folders, force: bool, command: str,
             named: bool = True) -> "Output":
        """Files for a folder the user names (``--out``; not ``named``: the command's default
        folder, which must not be a link): ``files`` and ``folders``, the names the command
        may write there (refused if there, unless ``force``)."""
        out = Path(out)
        made = not os.path.lexists(out)
        try:
            target = Folder.open(out, create=True, follow=named)
        except UnsafeFile as exc:
            if named:
                raise UsageError(f"--out {out}: {exc.strerror}") from None
            raise UsageError(f"{out}: {exc.strerror}, and lccopt never writes through a "
                             f"link it did not make (remove it, or name a folder with "
                             f"--out)") from None
        except FileExistsError:
            raise UsageError(f"--out {out} is a file, not a folder") from None
        except OSError as exc:
            raise UsageError(f"cannot create {out}: {exc.strerror or exc}") from None
        try:
            _lock(target, out)
            _clean_staging(target)
            if not force:
                taken = [n for n in (*files, *folders) if target.exists(n)]
                if taken:
                    raise UsageError(f"{out} already holds {taken[0]}"
                                     f"{' and more' if len(taken) > 1 else ''}: choose another "
                                     f"--out, or add --force to replace them")
            for n in files:   # a folder or a special file in a file's place: said before work
                st = target.lstat(n)
                if st is not None and not (stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode)):
                    raise UsageError(f"{out / n} is {kind_of(st.st_mode)}, where lccopt {command} "
                                     f"writes a file: remove it")
            name, staging = _new_staging(target, command)
        except BaseException:
            target.close()
            raise
        return cls(target, name, staging, out, force, None, target, made)

    @classmethod
    def own(cls, parent: Folder, name: str, shown: Path, command: str) -> "Output":
        """Files of the folder ``name`` that lccopt owns whole inside ``parent`` (held open)."""
        st = parent.lstat(name)
        if st is not None and not stat.S_ISDIR(st.st_mode):
            why = ("a symbolic link where lccopt keeps a directory; lccopt never writes through a "
                   "link it did not make (remove it)" if stat.S_ISLNK(st.st_mode)
                   else f"{kind_of(st.st_mode)} where lccopt keeps a directory")
            raise UsageError(f"{shown}: {why}")
        _lock(parent, shown, whole=True)
        try:
            _clean_staging(parent)
            tmp, staging = _new_staging(parent, command)
        except BaseException:
            parent.unlock()
            raise
        return cls(parent, tmp, staging, shown, True, name, parent)

    # -- finishing ------------------------------------------------------------------------------
    def __enter__(self) -> "Output":
        return self

    def __exit__(self, kind, exc, tb) -> None:
        try:
            if kind is None:
                with committing():
                    self.publish()
        finally:
            self.close()

    def publish(self) -> None:
        """Move the staged files into place (see the module docstring)."""
        try:
            if self.whole is not None:
                self._swap()
            else:
                _merge(self.staging, self.target, self.force, self.shown)
            self._published = True
        except OSError as exc:
            raise named(exc, getattr(exc, "filename", None) or self.shown) from None

    def close(self) -> None:
        """Drop whatever is still staged and release the folders."""
        with contextlib.suppress(OSError):
            self.target.remove_tree(self.staging_name)
        self.staging.close()
        if self._holder is self.target and self.whole is None:
            empty = not self.target.names()
            self.target.close()
            if self._made and empty and not self._published:
                with contextlib.suppress(OSError):   # the folder this command made, left empty
                    os.rmdir(self.shown)
        else:
            self._holder.unlock()

    def _swap(self) -> None:
        name, tmp = self.whole, self.staging_name
        if not self.target.exists(name):
            _rename(self.target, tmp, self.target, name, _RENAME_NOREPLACE)
            return
        try:
            _rename(self.target, tmp, self.target, name, _RENAME_EXCHANGE)
        except _Unsupported:
            old = self.target.make_temp_dir(f"{STAGING}old-")
            self.target.rename(name, old)   # replaces the empty folder just made
            self.target.rename(tmp, name)
            self.target.remove_tree(old)
            return
        self.target.remove_tree(tmp)   # the old folder, now under the staging name


class _Unsupported(Exception):
    """renameat2 with this flag is not available here (libc or file system)."""


_renameat2 = None


def _rename(src: Folder, a: str, dst: Folder, b: str, flags: int) -> None:
    """renameat2(src/a, dst/b, flags); _Unsupported where the system cannot do it (then
    RENAME_NOREPLACE is done as a check and a rename)."""
    global _renameat2
    if _renameat2 is None:
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            fn = libc.renameat2
            fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                           ctypes.c_uint]
            _renameat2 = fn
        except (AttributeError, OSError):
            _renameat2 = False
    if _renameat2:
        if _renameat2(src.fd, os.fsencode(a), dst.fd, os.fsencode(b), flags) == 0:
            return
        code = ctypes.get_errno()
        if code not in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
            raise OSError(code, os.strerror(code), str(dst.display(b)))
    if flags == _RENAME_EXCHANGE:
        raise _Unsupported()
    if dst.exists(b):
        raise OSError(errno.EEXIST, os.strerror(errno.EEXIST), str(dst.display(b)))
    src.rename(a, b, into=dst)


def _merge(src: Folder, dst: Folder, force: bool, shown: Path) -> None:
    """Move every entry of ``src`` into ``dst``: a file replaces one (or a link) there only with
    ``force``; a folder goes in whole, or is merged into a real folder of the same name."""
    for name in src.names():
        st = src.lstat(name)
        there = dst.lstat(name)
        if stat.S_ISDIR(st.st_mode):
            if there is not None and stat.S_ISDIR(there.st_mode):
                with src.sub(name) as s, dst.sub(name) as d:
                    _merge(s, d, force, shown / name)
                continue
            if there is not None:
                if not force:
                    raise _taken(shown / name)
                dst.unlink(name)   # a link or a file where a folder goes: replaced, not followed
            _rename(src, name, dst, name, _RENAME_NOREPLACE)
        elif force:
            if there is not None and stat.S_ISDIR(there.st_mode):
                raise UnsafeFile(shown / name, "a directory where lccopt writes a file: remove it",
                                 errno.EISDIR)
            src.rename(name, name, into=dst)   # replaces a file or a link, never follows it
        else:
            try:
                _rename(src, name, dst, name, _RENAME_NOREPLACE)
            except OSError as exc:
                if exc.errno == errno.EEXIST:
                    raise _taken(shown / name) from None
                raise


def _taken(path: Path) -> UsageError:
    return UsageError(f"{path} appeared while lccopt wrote its files there; nothing replaced: "
                      f"choose another --out, or add --force to replace it")


def _new_staging(folder: Folder, command: str) -> tuple[str, Folder]:
    """A staging folder for ``command``'s files made and locked inside ``folder``: its name
    and the folder."""
    name = folder.make_temp_dir(f"{STAGING}{command}-")
    staging = folder.sub(name)
    staging.try_lock()
    return name, staging


def _lock(folder: Folder, shown: Path, whole: bool = False) -> None:
    if not folder.try_lock():
        where = f"{shown}" if not whole else f"{shown}'s folder"
        raise UsageError(f"another lccopt command is writing into {where}; wait for it to finish "
                         f"(one at a time per folder)")


def _clean_staging(folder: Folder) -> list[str]:
    """Remove staging folders a killed command left in ``folder`` (real folders named
    ``.lccopt-*.tmp`` that no live command holds); return their names."""
    gone = []
    for name in folder.names():
        if not (name.startswith(STAGING) and name.endswith(".tmp")):
            continue
        try:
            with folder.sub(name) as left:
                if not left.try_lock():
                    continue   # a command at work
                folder.remove_tree(name)
                gone.append(name)
        except OSError:
            continue
    return gone
