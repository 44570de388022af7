"""Measured rail profiles: rows of (position m, dip m) from a CSV file or written in the case.

A case names a CSV file (``simulation.irregularity: profile.csv``) or gives the rows itself
(``irregularity: {points: ...}``). Either way the validated case holds the rows, as text in a
canonical form, never the file's name alone (that stays as ``source``): the run directory's
copy of the case (``Case.resolved``) then holds every input the simulations depend on, so an
edited file changes the run's fingerprint, and the copy loads without the file.

Rows: one per line, ``position, dip``, increasing positions; blank lines and lines starting
with ``#`` are skipped. Limits, and why:

* at most ``MAX_PROFILE_POINTS`` rows per profile (1 km at 1 cm spacing; the simulation
  interpolates between rows, and the wheel moves about 1-2 cm per step), and
  ``MAX_CASE_PROFILE_POINTS`` over all profiles of a case (case and conditions): each row
  costs about 50 bytes in the run's copy of the case, which every command reads;
* finite numbers, and ``|dip| <= MAX_DIP`` (0.05 m): track maintenance limits of the
  longitudinal level are a few tens of millimetres, so a larger dip is a unit mistake (mm for
  m) or a derailment, not an irregularity; the linearised wheel-rail contact of the model
  (about 0.1 mm of static contact deflection) is far out of its range long before;
* the profile must cover part of the modelled track (checked with the case: rows outside
  [0, track length] would give a smooth rail without a word).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

MAX_PROFILE_POINTS = 100_000
MAX_CASE_PROFILE_POINTS = 200_000
MAX_PROFILE_LINES = 2 * MAX_PROFILE_POINTS       # rows, comments and blank lines together
MAX_ROW_BYTES = 64    # a row in the run's copy: two floats as repr, ", ", indentation, newline
MAX_PROFILE_BYTES = MAX_PROFILE_LINES * 40       # a CSV file of profile rows and comments
MAX_DIP = 0.05        # [m]


class ProfileText(str):
    """The rows of a profile in canonical text (``repr`` of each float: they read back
    bit for bit); YAML writes it as a literal block, one row per line."""


class ProfileError(ValueError):
    """A problem on line ``line`` (1-based) of a profile's rows."""

    def __init__(self, line: int, message: str):
        super().__init__(message)
        self.line = line


def _number(field: str, line: int, what: str) -> float:
    try:
        value = float(field)
    except ValueError:
        raise ProfileError(line, f"{what} {field.strip()[:40]!r} is not a number") from None
    if not np.isfinite(value):
        raise ProfileError(line, f"{what} {field.strip()} is not a finite number")
    return value


def parse_rows(text: str) -> np.ndarray:
    """The (N, 2) rows of a profile's text; raises :class:`ProfileError` on the first bad line."""
    if text.count("\n") > MAX_PROFILE_LINES:
        raise ProfileError(1, f"{text.count(chr(10)):,} lines; a profile has at most "
                              f"{MAX_PROFILE_POINTS:,} rows (and as many comments or blank lines)")
    rows = []
    for i, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = line.split(",")
        if len(fields) != 2:
            raise ProfileError(i, f"expected two numbers 'position, dip' (m), got {line[:60]!r}")
        x, dip = _number(fields[0], i, "position"), _number(fields[1], i, "dip")
        if abs(dip) > MAX_DIP:
            raise ProfileError(i, f"a dip of {dip:g} m: at most {MAX_DIP:g} m either way (a dip "
                                  f"is in metres, downward positive)")
        if rows and not x > rows[-1][0]:
            raise ProfileError(i, f"position {x:g} m does not increase (the row before: "
                                  f"{rows[-1][0]:g} m)")
        rows.append((x, dip))
        if len(rows) > MAX_PROFILE_POINTS:
            raise ProfileError(i, f"more than {MAX_PROFILE_POINTS:,} rows")
    if len(rows) < 2:
        raise ProfileError(max(1, len(text.splitlines())),
                           f"{len(rows)} row(s); a profile needs at least two "
                           f"('position, dip' in m, one per line)")
    return np.array(rows, dtype=float)


def pairs_rows(value: list) -> np.ndarray:
    """Rows given as a YAML list of [position, dip] pairs; raises :class:`ProfileError` with
    the 1-based index of the bad pair as its line."""
    text = []
    for i, pair in enumerate(value, 1):
        if (not isinstance(pair, list) or len(pair) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in pair)):
            raise ProfileError(i, f"expected a pair [position, dip] of numbers, got {pair!r:.60}")
        text.append(f"{float(pair[0])!r}, {float(pair[1])!r}")
    return parse_rows("\n".join(text))


def rows_text(rows: np.ndarray) -> ProfileText:
    """Canonical text of rows: ``repr`` of each float (shortest text that reads back the same
    float), so that reading the text gives the same rows bit for bit."""
    return ProfileText("".join(f"{x!r}, {r!r}\n" for x, r in np.asarray(rows, float).tolist()))


@lru_cache(maxsize=64)   # a case holds at most MAX_CASE_PROFILE_POINTS rows in all
def profile_array(text: str) -> np.ndarray:
    """The (N, 2) rows of a canonical text (read once per process and text)."""
    rows = parse_rows(text)
    rows.setflags(write=False)
    return rows


def cover_problem(rows: np.ndarray, track_length: float) -> str | None:
    """Why the profile misses the modelled track [0, track_length] m, or None."""
    lo, hi = float(rows[0, 0]), float(rows[-1, 0])
    if hi <= 0.0 or lo >= track_length:
        return (f"the profile covers [{lo:g}, {hi:g}] m, outside the modelled track [0, "
                f"{track_length:g}] m (positions are in metres from the start of the entry track)")
    return None
