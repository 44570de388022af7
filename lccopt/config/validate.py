"""Validating a raw case mapping against its schema (``lccopt.config.kinds`` classes).

:func:`check` turns the raw mapping into typed values (floats in SI units, ints, lists) or
raises a :class:`~lccopt.errors.CaseError` of one line naming the file, the line and the key
(``--set`` instead of ``file:line`` for a value given on the command line). Quantities may be
written with a unit (``lccopt.config.units``); a bare number out of its bounds that one of the
key's other units would bring within them gets a hint ("did you mean `speed: 140 km/h`?").
"""

from __future__ import annotations

import difflib
import re
from typing import Any

import numpy as np

from ..errors import CaseError
from . import kinds, units
from .profiles import ProfileError, ProfileText, pairs_rows, parse_rows, rows_text
from .reading import dotted, locate

MAX_MAGNITUDE = 1e13        # no quantity of a case comes near it (Young's modulus of steel: 2.1e11)
# A name is one path component of the run directory: never ".", "..", empty or hidden.
SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
_FLOAT_RE = re.compile(
    r"""^[-+]?(?:[0-9][0-9_]*)?(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)?$""", re.X
)


def check(value: Any, kind: Any, path: tuple, lines: dict, file: str,
          root: Any = None) -> Any:
    """Validate one value against its kind; return the typed value. ``root``: the kind of
    the whole file (default ``kind``), where an unknown key is looked for elsewhere."""
    root = kind if root is None else root

    def fail(msg: str, at: tuple = path) -> CaseError:
        return CaseError(f"{locate(lines, at, file)}: {dotted(at) or '<top>'}: {msg}")

    def sub(v: Any, s: Any, key) -> Any:
        return check(v, s, path + (key,), lines, file, root)

    if isinstance(kind, kinds.Section):
        return _section(value, kind, sub, fail, lambda k: lines.get(path + (k,), file + ":1"),
                        path, root)
    if isinstance(kind, (kinds.Named, kinds.Items)):
        return _collection(value, kind, sub, fail, path)
    if isinstance(kind, kinds.TextOrSection):
        if isinstance(value, dict):
            keys = [k for k in kind.sections if k in value]
            if len(keys) != 1:
                raise fail(f"expected a mapping with one of the keys "
                           f"{' or '.join(repr(k) for k in kind.sections)}")
            return check(value, kind.sections[keys[0]], path, lines, file, root)
        if not isinstance(value, str):
            raise fail(f"expected a file name or a mapping, got {value!r:.60}")
        return value
    if isinstance(kind, kinds.NumOrSection):
        if isinstance(value, dict):
            return check(value, kind.section, path, lines, file, root)
        return check(value, kind.number, path, lines, file, root)
    if isinstance(kind, kinds.Rows):
        return _rows(value, fail)
    if isinstance(kind, kinds.Num):
        return _number(value, kind, fail, _key_name(path))
    if isinstance(kind, kinds.Str):
        if value is None and not kind.required:
            return None
        if not isinstance(value, str):
            raise fail(f"expected text, got {value!r}")
        if kind.choices and value not in kind.choices:
            raise fail(f"must be one of {', '.join(kind.choices)}, got '{value}'"
                       + _did_you_mean(value, kind.choices))
        return value
    if isinstance(kind, kinds.NumList):
        return _numbers(value, kind, fail, path)
    if isinstance(kind, kinds.StrList):
        return _names(value, kind, fail)
    raise TypeError(kind)


def _key_name(path: tuple) -> str:
    """The last key of a path (the one a user writes): ``speed``, ``bounds``."""
    named = [p for p in path if isinstance(p, str)]
    return named[-1] if named else ""


def _did_you_mean(word: str, choices) -> str:
    """`` (did you mean 'speed'?)`` for the closest of ``choices``, else ''."""
    close = difflib.get_close_matches(str(word), list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def unknown_key(key: str, known, path: tuple, root: Any = None) -> str:
    """The message for an unknown key: the closest known key, else the keys if they are few,
    else where they are documented; and where the key is known in ``root`` (a key written in
    the wrong section: ``slab_lengths`` under track.layout), unless the few keys say it all."""
    close = (difflib.get_close_matches(str(key), list(known), n=1, cutoff=0.6)
             or _sharing_a_word(str(key), known))
    if len(known) <= 5 and not close:
        return f"unknown key (expected one of: {', '.join(known)})"
    homes = list(dict.fromkeys(dotted(h + (str(key),)) for h in key_homes(root, str(key))
                               if h != path))
    elsewhere = " or ".join(homes[:2]) + (" or ..." if len(homes) > 2 else "")
    if close:
        named = " or ".join(f"'{c}'" for c in close)
        return f"unknown key (did you mean {named}{' or ' + elsewhere if homes else ''}?)"
    where = dotted(tuple(p for p in path if isinstance(p, str))) or "the top level"
    also = f"; or did you mean {elsewhere}?" if homes else ""
    return f"unknown key (the keys of {where}: docs/case-reference.md{also})"


def _sharing_a_word(key: str, known) -> list[str]:
    """The known keys (two at most) that share a word with ``key``, a plural or a slip of
    a letter allowed (``voids`` -> ``initial_void``), for a key too unlike any whole key."""
    words = [w for w in key.lower().split("_") if len(w) >= 4]
    shared = {k: sum(bool(difflib.get_close_matches(w, k.split("_"), n=1, cutoff=0.8))
                     for w in words) for k in known}
    most = max(shared.values(), default=0)
    matches = [k for k, n in shared.items() if n == most]
    return matches if most and len(matches) <= 2 else []


def key_homes(kind: Any, key: str, path: tuple = ()) -> list[tuple]:
    """The paths of the sections of ``kind`` that hold ``key`` (a collection's entries as
    ``<name>`` or ``[0]``)."""
    if isinstance(kind, kinds.Section):
        return ([path] if key in kind.fields else []) + [
            h for k, f in kind.fields.items() for h in key_homes(f, key, path + (k,))]
    if isinstance(kind, (kinds.Named, kinds.Items)):
        return key_homes(kind.item, key, path + ("<name>" if isinstance(kind, kinds.Named)
                                                 else 0,))
    if isinstance(kind, kinds.TextOrSection):
        return [h for s in kind.sections.values() for h in key_homes(s, key, path)]
    if isinstance(kind, kinds.NumOrSection):
        return key_homes(kind.section, key, path)
    return []


def _section(value: Any, kind: kinds.Section, sub, fail, line_of, path: tuple,
             root: Any = None) -> dict:
    """A section: no unknown key, every required key, defaults for the others."""
    if not isinstance(value, dict):
        raise fail(f"expected a section (mapping), got {type(value).__name__}")
    for k in value:
        if k not in kind.fields:
            raise CaseError(f"{line_of(k)}: {dotted(path + (k,))}: "
                            f"{unknown_key(k, kind.fields, path, root)}")
    out = {}
    for key, field_kind in kind.fields.items():
        if value.get(key) is None:  # absent, or written as null
            if getattr(field_kind, "required", True):
                raise fail(f"missing key '{key}'")
            if getattr(field_kind, "keep_absent", False):
                continue
            optional_only = isinstance(field_kind, kinds.Section) \
                and not field_kind.none_if_absent and not any(
                getattr(f, "required", True) for f in field_kind.fields.values())
            out[key] = (sub({}, field_kind, key) if optional_only
                        else getattr(field_kind, "default", None))
            continue
        out[key] = sub(value[key], field_kind, key)
    return out


def _collection(value: Any, kind: kinds._Collection, sub, fail, path: tuple):
    """kinds.Named (a mapping of names) or kinds.Items (a list), each value of ``kind.item``."""
    if isinstance(kind, kinds.Named):
        if not isinstance(value, dict) or not value:
            raise fail("expected a mapping of names to sections")
    elif not isinstance(value, list) or not value:
        raise fail("expected a list")
    if len(value) > kind.max_items:
        raise fail(f"{len(value)} entries; at most {kind.max_items}")
    if isinstance(kind, kinds.Items):
        return [sub(v, kind.item, i) for i, v in enumerate(value)]
    for k in value:
        if not isinstance(k, str) or not SAFE_NAME.fullmatch(k):
            raise fail(f"{str(k)[:40]!r} is not a name (1-64 letters, digits, '.', '-' "
                       f"and '_')", path + (k,))
    return {k: sub(v, kind.item, k) for k, v in value.items()}


def _numbers(value: Any, kind: kinds.NumList, fail, path: tuple) -> list:
    if not isinstance(value, list):
        raise fail(f"expected a list of numbers, got {value!r:.60}")
    if kind.length is not None and len(value) != kind.length:
        raise fail(f"expected {kind.length} values, got {len(value)}")
    if len(value) < kind.min_length:
        raise fail(f"expected at least {kind.min_length} value(s)")
    if len(value) > kind.max_length:
        raise fail(f"{len(value)} values; at most {kind.max_length}")
    item = kinds.Num(kind.doc, kind.unit, gt=kind.gt, ge=kind.ge, le=kind.le, shown=kind.shown,
               why=kind.why)
    key = _key_name(path)
    return [_number(v, item, lambda m, i=i: fail(m, path + (i,)), key)
            for i, v in enumerate(value)]


def _names(value: Any, kind: kinds.StrList, fail) -> list:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not value:
        raise fail("expected a list of names")
    for v in value:
        if v not in kind.choices:
            more = getattr(kind.choices, "unknown", None)
            if more is not None:           # objectives: also a statistic of one
                raise fail(f"unknown name {v!r} (expected some of {', '.join(kind.choices)}"
                           f"{more(v)})")
            raise fail(f"unknown name {v!r} (expected some of {', '.join(kind.choices)})"
                       + _did_you_mean(v, kind.choices))
    if len(set(value)) != len(value):
        raise fail("a name is listed twice")
    return list(value)


def _rows(value: Any, fail) -> ProfileText:
    """A profile's rows (text or pairs), checked, as canonical text."""
    try:
        if isinstance(value, str):
            rows = parse_rows(value)
        elif isinstance(value, list):
            rows = pairs_rows(value)
        else:
            raise fail(f"expected rows 'position, dip' (text) or [position, dip] pairs, got "
                       f"{value!r:.60}")
    except ProfileError as exc:
        where = "line" if isinstance(value, str) else "pair"
        raise fail(f"{where} {exc.line}: {exc}") from None
    return rows_text(rows)


def _number(value: Any, kind: kinds.Num, fail, key: str = "") -> float | int:
    """A number checked against ``kind``: an int for an integer kind, else a float (in SI
    units: a quantity written with a unit is converted)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > MAX_MAGNITUDE:
        raise fail(f"{str(value)[:12]}... ({len(str(abs(value)))} digits) is not a plausible value")
    written_unit = None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        if isinstance(value, str) and _FLOAT_RE.match(value.strip()) and value.strip():
            value = float(value)  # e.g. "1_120e6"
        elif isinstance(value, str) and units.split(value) is not None:
            number, written_unit = units.split(value)
            try:
                value = units.to_si(number, written_unit, kind.unit)
            except units.UnitError as exc:
                raise fail(str(exc)) from None
        else:
            raise fail(f"expected a number, got {value!r:.60}")
    if not np.isfinite(value):
        raise fail(f"must be finite, got {value!r}")
    if abs(value) > MAX_MAGNITUDE:
        raise fail(f"{value:g} is not a plausible value (|value| <= {MAX_MAGNITUDE:g} in SI units)")
    if kind.integer:
        if float(value) != int(value):
            raise fail(f"must be a whole number, got {value!r}")
        value = int(value)
    else:
        value = float(value)
    problem = _bound_problem(value, kind)
    if problem:
        raise fail(_bound_message(value, kind, problem, written_unit, key))
    return value


def _bound_problem(value: float, kind: kinds.Num) -> tuple[str, float] | None:
    """The first bound ``value`` breaks, as (relation, bound), or None."""
    for rel, bound, ok in ((">", kind.gt, lambda v, b: v > b), (">=", kind.ge, lambda v, b: v >= b),
                           ("<=", kind.le, lambda v, b: v <= b)):
        if bound is not None and not ok(value, bound):
            return rel, bound
    return None


def _bound_message(value: float, kind: kinds.Num, problem: tuple[str, float], written: str | None,
                   key: str) -> str:
    """``must be <= 250 km/h (why), got 504 km/h``; for a bare number that another unit of
    the key brings within the bounds: ``140 m/s is 504 km/h, above 250 km/h (why): did you
    mean `speed: 140 km/h`?``."""
    rel, bound = problem
    shown = kind.shown or kind.unit
    def show(v: float) -> str:
        if shown == "-":
            return f"{v:g}"
        return f"{units.from_si(v, shown, kind.unit):.4g} {shown}"

    why = f" ({kind.why})" if kind.why else ""
    if written is None and kind.unit != "-":
        for unit in units.other_units(kind.unit):
            candidate = units.to_si(value, unit, kind.unit)
            if _bound_problem(candidate, kind) is None:
                said = f"{value:g} {kind.unit}"
                also = f" is {show(value)}," if shown != kind.unit else ""
                side = "above" if rel == "<=" else "below"
                return (f"{said}{also} {side} {show(bound)}{why}: did you mean "
                        f"`{key}: {value:g} {unit}`?")
    return f"must be {rel} {show(bound)}{why}, got {show(value)}"
