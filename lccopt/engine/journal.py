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
A malformed line anywhere else means the file was damaged by something other than a crash,
and is reported, never guessed around.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from ..safeio import open_owned, read_owned
from .events import EventCheck


class JournalError(Exception):
    """The journal is damaged beyond a torn last line."""


def read_journal(path: str | Path) -> tuple[list[dict], int, bool]:
    """Return (events, length of the committed part in bytes, whether a torn tail was found)."""
    path = Path(path)
    try:
        data = read_owned(path)
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
                               f"the journal was changed by something other than lccopt") from None
        try:  # whole JSON that lccopt could not use: damage, wherever it is (a crash tears)
            check(ev)
        except ValueError as exc:
            raise JournalError(f"{path}: line {len(events) + 1} is damaged ({exc}); "
                               f"the journal was changed by something other than lccopt") from None
        events.append(ev)
        pos = end + 1
    return events, pos, torn


def line_mark(ev: dict) -> str:
    """A fingerprint of one committed line (its JSON as written): what a snapshot records of the
    line it reflects, so that a snapshot of another run or another state is never trusted."""
    import hashlib

    line = json.dumps(ev, allow_nan=True, separators=(",", ":"))
    return hashlib.sha256(line.encode("utf-8")).hexdigest()[:32]


class Journal:
    """Appends events; ``seq`` continues from the committed lines."""

    def __init__(self, path: str | Path, fh, next_seq: int):
        self.path = Path(path)
        self._fh = fh
        self.next_seq = next_seq
        self.unsynced = False  # lines written since the last fsync

    @classmethod
    def open(cls, path: str | Path) -> tuple["Journal", list[dict], bool]:
        """Open for appending after dropping a torn tail; return (journal, events, torn)."""
        path = Path(path)
        events, length, torn = read_journal(path)
        fh = open_owned(path, "ab")
        if fh.tell() != length:
            fh.truncate(length)
            fh.flush()
            os.fsync(fh.fileno())
        fh.seek(length)
        return cls(path, fh, len(events)), events, torn

    def append(self, event: str, sync: bool = True, **fields) -> dict:
        """Write one event (``seq`` added) and return it; with ``sync`` also wait until it,
        and every line before it, is on disk."""
        ev = {"seq": self.next_seq, "event": event, **fields}
        line = json.dumps(ev, allow_nan=True, separators=(",", ":")) + "\n"
        self._fh.write(line.encode("utf-8"))
        self.next_seq += 1
        self.unsynced = True
        if sync:
            self.sync()
        return ev

    def flush(self) -> None:
        """Every line appended so far handed to the operating system (no fsync)."""
        self._fh.flush()

    def sync(self) -> None:
        """Every line appended so far on disk (one flush and fsync; nothing if already)."""
        if self.unsynced:
            self._fh.flush()
            os.fsync(self._fh.fileno())
            self.unsynced = False

    def close(self) -> None:
        if not self._fh.closed:
            try:
                self.sync()
            finally:
                self._fh.close()
