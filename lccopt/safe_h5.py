"""HDF5 files lccopt owns, read safely.

Every HDF5 file lccopt reads is checked: when opened, that every link stays in the file (no
soft or external link, except results.h5's own links to its evaluation files, which lccopt
never follows); before a dataset is read (:func:`h5_read`) or copied, that it has no external
storage, is not virtual, uses no compression filter HDF5 lacks and is not too large to read.
Each of these would make HDF5 open other files by name, behind lccopt's back (a FIFO there
hangs the reader), or load code, or exhaust the memory. A refusal is a ``safeio.UnsafeFile``.
"""

from __future__ import annotations

import contextlib
import errno
import re

from .folder import owned_entry
from .safeio import UnsafeFile

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

    with owned_entry(src) as (folder, name):
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
