"""A case's rail profiles as it names them: each CSV file read (relative to the case file)
into the case, and the rows of all of them counted against the case's limit."""

from __future__ import annotations

from pathlib import Path

from ..errors import CaseError
from .profiles import (
    MAX_CASE_PROFILE_POINTS,
    MAX_PROFILE_BYTES,
    ProfileError,
    parse_rows,
    rows_text,
)
from .reading import check_file_name, dotted, locate, read_input_bytes, shown


def profile_rows(value, path: Path, lines: dict, err, at: tuple):
    """The irregularity as the case keeps it: a CSV file named is read (relative to the case
    file) into ``{source: name, points: rows}``; anything else as it is."""
    if not isinstance(value, str) or value == "none":
        return value
    if not value.strip():
        raise err(at, "an empty file name (none: a smooth rail)")
    where = locate(lines, at, str(path))
    check_file_name(value, where, dotted(at))
    csv = path.parent / value

    def fail(problem: str) -> CaseError:
        return err(at, f"{shown(str(csv))}: {problem}")

    data = read_input_bytes(csv, MAX_PROFILE_BYTES, fail)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise fail(f"line {line}: not UTF-8 text (byte {exc.start})") from None
    try:
        rows = parse_rows(text)
    except ProfileError as exc:
        raise fail(f"line {exc.line}: {exc}") from None
    return {"source": value, "points": rows_text(rows)}


class RowCount:
    """The rows of a case's profiles, counted as they are read: at most
    MAX_CASE_PROFILE_POINTS in all (case and conditions), refused at the one that passes it."""

    def __init__(self, err):
        self.err, self.total = err, 0

    def add(self, value, at: tuple):
        if isinstance(value, dict) and "points" in value:
            self.total += value["points"].count("\n")
            if self.total > MAX_CASE_PROFILE_POINTS:
                raise self.err(at, f"the case's rail profiles hold more than "
                                   f"{MAX_CASE_PROFILE_POINTS:,} rows in all")
        return value
