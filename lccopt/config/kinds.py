"""The language the case schema is written in: one small class per kind of value.

``lccopt.config.schema`` declares every key of a case file with these (its doc, unit, bounds
and default); ``lccopt.config.validate`` checks a raw mapping against them, and
``lccopt.config.reference`` writes the case-file reference (docs/case-reference.md) from them.

Common fields: ``doc`` (one line for the reference and messages), ``required``, ``default``
(the value an absent key takes) and ``keep_absent``: an absent key stays absent in the
validated case, so that its resolved copy (what a run keeps and fingerprints) reads as it did
before the key existed; code reads such a key with ``.get`` and its documented default.
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass, field
from typing import Any


@dataclass(frozen=True, kw_only=True)
class _Key:
    """What every kind has (keyword-only, after the kind's own fields)."""
    default: Any = None
    required: bool = True
    keep_absent: bool = False


@dataclass(frozen=True)
class _Quantity(_Key):
    """A number or a list of numbers in SI ``unit`` (``-``: none), each within optional bounds
    (``gt``: strictly greater). ``shown``: the unit messages and the reference show it in
    (``km/h`` for a speed); ``why``: the reason for the bounds, said when a value falls
    outside them."""
    doc: str
    unit: str = "-"
    _: KW_ONLY
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    shown: str | None = None
    why: str = ""


@dataclass(frozen=True)
class Num(_Quantity):
    """A number (``integer``: a whole one)."""
    integer: bool = False


@dataclass(frozen=True)
class Str(_Key):
    """Text, one of ``choices`` when given."""
    doc: str
    choices: tuple | None = None


@dataclass(frozen=True)
class NumList(_Quantity):
    """A list of numbers (``length`` fixed when given)."""
    length: int | None = None
    min_length: int = 1
    max_length: int = 50


@dataclass(frozen=True)
class Section(_Key):
    """A mapping of fixed keys, each with its own kind (``fields``). An absent optional
    section whose keys are all optional is built from their defaults, unless
    ``none_if_absent`` (then it is None: ``optimisation:`` of a case that only simulates)."""
    fields: dict
    doc: str = ""
    none_if_absent: bool = False


@dataclass(frozen=True)
class _Collection(_Key):
    """Several values of one kind (``item``), at most ``max_items``."""
    item: Any
    doc: str = ""
    max_items: int = 50
    required: bool = field(default=False, kw_only=True)


class Named(_Collection):
    """A mapping of user-chosen names (``SAFE_NAME``) to values of one kind (``vehicles:``)."""


class Items(_Collection):
    """A list of values of one kind (``conditions:``)."""


@dataclass(frozen=True)
class TextOrSection(_Key):
    """Text (e.g. a file name) or a mapping, checked against the one of ``sections``
    (``{key: Section}``) whose key it holds."""
    doc: str
    sections: dict


@dataclass(frozen=True)
class NumOrSection(_Key):
    """A number (checked against ``number``) or a mapping checked against ``section``."""
    doc: str
    number: Num
    section: Section


@dataclass(frozen=True)
class Rows(_Key):
    """The rows of a rail profile: text, one ``position, dip`` per line, or a list of
    [position, dip] pairs (lccopt.config.profiles); checked and kept as canonical text."""
    doc: str


@dataclass(frozen=True)
class StrList(_Key):
    """A list of distinct names from ``choices`` (one name alone is a list of one)."""
    doc: str
    choices: tuple
