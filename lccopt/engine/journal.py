"""The run journal: an append-only, fsynced JSON-lines file; each line is a commit point.

Lines may be appended without waiting for the disk (``append(..., sync=False)``), handed to
the operating system by ``flush()`` (then they survive kill -9 of the process) and made
durable together by ``sync()``: one fsync covers every line before it. Lines reach the file
in order, so the file always holds a prefix of the lines appended (a torn last line at
most). The engine flushes before it starts evaluations and syncs at least once a second:
one fsync per evaluation would bound a run by the disk's fsync rate.

Every line is one JSON object with ``seq`` (0, 1, 2, ... without gaps), ``event`` and the
event's fields. A line is committed once it and its newline are on disk (write + flush +
fsync). A process killed mid-write can leave a torn last line: :func:`read_journal` drops it
(and :meth:`Journal.open` truncates the file to the last whole line before appending).
A malformed line anywhere else means the file was damaged by something other than a crash
(say, two processes appending at once, which the run's lock prevents): it is reported, never
guessed around, and ``lccopt resume`` carries on from the lines before it after keeping the
whole file beside it (:func:`repair`).

The journal refuses a second writer: :meth:`Journal.open` holds an exclusive flock on the
descriptor it appends with (``RunDir.lock`` takes it first, for the whole command).
"""

from __future__ import annotations

import fcntl
import json
import os

from ..folder import Folder, open_owned, read_owned
from ..safeio import named
from .events import EventCheck


class JournalError(Exception):
    """The journal is damaged beyond a torn last line. ``events`` and ``length``: the lines
    before the damaged one and their length in bytes; ``line``: the damaged line (from 1)."""

    def __init__(self, message: str, events=(), length: int = 0, line: int = 0):
        super().__init__(message)
        self.events, self.length, self.line = list(events), length, line


def _shown(src) -> str:
    return str(src[0].display(src[1]) if isinstance(src, tuple) else src)


def read_journal(src) -> tuple[list[dict], int, bool]:
    """Return (events, length of the committed part in bytes, whether a torn tail was found)
    of the journal ``src`` (a path or ``(Folder, name)``)."""
    path = _shown(src)
    try:
        data = read_owned(src)
    except FileNotFoundError:
        return [], 0, False
    events: list[dict] = []
    pos = 0
    torn = False
    check = EventCheck()
    while pos < len(data):
        end = data.find(b"\n", pos)
        if end < 0:  # no newline: a torn last line
            torn = True
            break
        line = data[pos:end]
        try:
            ev = json.loads(line)
            if not isinstance(ev, dict) or ev.get("seq") != len(events):
                raise ValueError("bad sequence number")
        except ValueError as exc:
            if data.find(b"\n", end + 1) < 0 and not data[end + 1:].strip():
                torn = True  # the last line is garbage (e.g. zeros after a crash): drop it
                break
            raise JournalError(f"{path}: line {len(events) + 1} is damaged ({exc}); "
                               f"the journal was changed by something other than lccopt",
                               events, pos, len(events) + 1) from None
        try:  # whole JSON that lccopt could not use: damage, wherever it is (a crash tears)
            check(ev)
        except ValueError as exc:
            raise JournalError(f"{path}: line {len(events) + 1} is damaged ({exc}); "
                               f"the journal was changed by something other than lccopt",
                               events, pos, len(events) + 1) from None
        events.append(ev)
        pos = end + 1
    return events, pos, torn


def encode(ev: dict) -> bytes:
    """One journal line as written (its JSON, compact, and the newline)."""
    return (json.dumps(ev, allow_nan=True, separators=(",", ":")) + "\n").encode("utf-8")


def line_mark(ev: dict) -> str:
    """A fingerprint of one committed line (its JSON as written): what a snapshot records of the
    line it reflects, so that a snapshot of another run or another state is never trusted."""
    import hashlib

    return hashlib.sha256(encode(ev)[:-1]).hexdigest()[:32]


def lock_for_writing(fh, shown) -> None:
    """Take the journal's writer lock on ``fh`` (JournalError if another process holds it)."""
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        raise JournalError(f"{shown}: another lccopt process is appending to it; one process "
                           f"drives a run") from None


def repair(src, fh, error: JournalError) -> str:
    """Cut the journal ``src`` back to the lines before its damaged one (``error``), through
    ``fh`` (the locked writer's descriptor), after keeping the whole file beside it as
    ``journal.damaged-N.jsonl``; return that name."""
    folder, name = src if isinstance(src, tuple) else (None, str(src))
    if folder is None:
        from pathlib import Path

        folder, name = Folder.open(Path(name).parent), Path(name).name
    data = folder.read(name)
    n = 1
    while folder.exists(f"journal.damaged-{n}.jsonl"):
        n += 1
    kept = f"journal.damaged-{n}.jsonl"
    folder.write(kept, data)
    fh.truncate(error.length)
    fh.flush()
    os.fsync(fh.fileno())
    return kept


class Journal:
    """Appends events; ``seq`` continues from the committed lines."""

    def __init__(self, path, fh, next_seq: int):
        self.path = _shown(path)
        self._fh = fh
        self.next_seq = next_seq
        self.unsynced = False  # lines written since the last fsync

    @classmethod
    def open(cls, src, fh=None) -> tuple["Journal", list[dict], bool]:
        """Open for appending after dropping a torn tail; return (journal, events, torn).

        ``src``: a path or ``(Folder, name)``; ``fh``: the descriptor ``RunDir.lock`` opened and
        locked, else one is opened here and locked (JournalError if another process holds it)."""
        if fh is None:
            fh = open_owned(src, "ab")
            try:
                lock_for_writing(fh, _shown(src))
            except JournalError:
                fh.close()
                raise
        events, length, torn = read_journal(src)
        fh.seek(0, os.SEEK_END)
        if fh.tell() != length:
            try:
                fh.truncate(length)
                fh.flush()
                os.fsync(fh.fileno())
            except OSError as exc:
                raise named(exc, _shown(src)) from None
        fh.seek(length)
        return cls(src, fh, len(events)), events, torn

    def append(self, event: str, sync: bool = True, **fields) -> dict:
        """Write one event (``seq`` added) and return it; with ``sync`` also wait until it,
        and every line before it, is on disk."""
        ev = {"seq": self.next_seq, "event": event, **fields}
        try:
            self._fh.write(encode(ev))
        except OSError as exc:
            raise named(exc, self.path) from None
        self.next_seq += 1
        self.unsynced = True
        if sync:
            self.sync()
        return ev

    def flush(self) -> None:
        """Every line appended so far handed to the operating system (no fsync)."""
        try:
            self._fh.flush()
        except OSError as exc:   # a full disk names the journal, never a bare reason
            raise named(exc, self.path) from None

    def sync(self) -> None:
        """Every line appended so far on disk (one flush and fsync; nothing if already)."""
        if self.unsynced:
            try:
                self._fh.flush()
                os.fsync(self._fh.fileno())
            except OSError as exc:
                raise named(exc, self.path) from None
            self.unsynced = False

    def close(self) -> None:
        if not self._fh.closed:
            try:
                self.sync()
            finally:
                try:
                    self._fh.close()
                except OSError:   # its flush failed again: sync said why, naming the file
                    pass
