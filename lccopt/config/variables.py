"""Design variables: one object per variable, built from the case file's ``design:`` groups.

A :class:`Variable` knows its name, bounds, kind (integer or continuous), scale (linear or
log), the unit people write and read it in, the internal unit the simulator, the optimiser and
the run's journal hold it in, and the conversion both ways. The four groups of the design
section are described once, in :data:`GROUPS` (scikit-optimize's ``Space`` of ``Dimension``
objects is the model): everything that splits a design vector into its groups, shows a value
or reads one a person wrote asks them.

Internal units are those of the simulator: pad stiffness in N/m, spans and the Type II strip
counted in 0.1 m rail elements (whole numbers, so that every design puts sleepers on nodes),
counts as they are. People write and read pads in MN/m and lengths in m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..vti.specs import ELEMENT_UNIT
from .units import UnitError, accepted, to_si
from .units import split as split_quantity


@dataclass(frozen=True)
class Group:
    """One key of the ``design:`` section: its variables' name stem, units and words."""
    key: str           # the design section's key
    stem: str          # variables are stem1..stemN (a group with count:), else stem
    internal: str      # the unit the simulator, optimiser and journal hold a value in
    unit: str          # the unit people write and read a value in
    scale: float       # a value in `unit` = the internal value x scale
    what: str          # the variable in words (the report's tables)
    counted: bool      # count: variables in the group (else one)
    integer: bool      # kind integer (else continuous)
    first: str = ""    # the words of variable 1 where they differ
    absent_at_zero: bool = False   # 0 leaves the component out (no Type II strip)

    @property
    def length(self) -> bool:
        """A length counted internally in 0.1 m elements (spans, the strip)."""
        return self.internal == "elements"

    def label(self, k: int) -> str:
        """The words of the group's variable k, counted from the interface (1: nearest)."""
        return self.first if k == 1 and self.first else self.what.format(k=k, k_1=k - 1)


GROUPS = (
    Group("railpad_stiffness", "x_r", "N/m", "MN/m", 1e-6,
          "railpad stiffness, sleeper {k} from the interface", True, False),
    Group("strengthened_sleepers", "x_n", "-", "", 1.0,
          "strengthened sleepers next to the interface", False, True),
    Group("sleeper_spans", "x_s", "elements", "m", ELEMENT_UNIT,
          "span sleeper {k_1} to sleeper {k}", True, True, "span slab edge to sleeper 1"),
    Group("type_ii_strip", "x_l", "elements", "m", ELEMENT_UNIT,
          "Type II strip from the entry slab edge", False, True, absent_at_zero=True),
)
GROUP = {g.key: g for g in GROUPS}
_UNKNOWN = Group("", "", "-", "", 1.0, "", False, False)   # a name no group's stem gives
_BY_STEM = {g.stem: g for g in GROUPS}


@dataclass(frozen=True)
class Variable:
    """One scalar design variable; bounds and reference in its internal unit."""
    name: str          # e.g. x_r1
    group: str         # its design section key (GROUP)
    integer: bool
    lower: float
    upper: float
    reference: float
    log: bool = False  # searched on a log scale (design.<group>.scale: log)
    label: str = ""    # in words (the report's tables)

    @property
    def kind(self) -> Group:
        return GROUP.get(self.group, _UNKNOWN)

    @property
    def switch(self) -> bool:
        """Whether the optimiser searches the variable as an on/off choice with a value behind
        it: its group's 0 leaves the component out and its range runs from 0
        (``lccopt.optim.space``, ``switch``)."""
        return self.kind.absent_at_zero and self.lower == 0 < self.upper

    @property
    def internal_unit(self) -> str:
        """``N/m``, ``-`` or ``elements`` (0.1 m)."""
        return self.kind.internal

    @property
    def unit(self) -> str:
        """The unit people read the variable in (the report's tables: a count of sleepers)."""
        return self.kind.unit or "sleepers"

    @property
    def scale(self) -> float:
        """A value in ``unit`` = the internal value x scale."""
        return self.kind.scale

    @property
    def display(self) -> tuple[str, float]:
        """(unit, scale) of the command line: pads in MN/m, spans and the strip in m, counts
        as they are (no unit)."""
        return self.kind.unit, self.kind.scale

    def to_user(self, value: float) -> float:
        """An internal value in the user's unit."""
        return float(value) * self.scale

    def show(self, value: float) -> str:
        """``x_r1=214 MN/m``, ``x_s3=0.3 m``: an internal value in the units people use."""
        unit = self.kind.unit
        return f"{self.name}={self.to_user(value):.6g}" + (f" {unit}" if unit else "")

    def from_user(self, value: float) -> float:
        """A value in the user's unit (MN/m, m, a count) as the internal value, checked
        against the bounds (ValueError naming the variable; a value that reads as the old
        internal unit says so)."""
        value = float(value)
        return self._checked(value / self.scale if np.isfinite(value) else np.nan, value)

    def _checked(self, q: float, value: float) -> float:
        """Internal value q (``value`` in the user's unit, for messages) rounded to whole
        elements and checked against the bounds."""
        unit = self.kind.unit
        u = f" {unit}" if unit else ""
        if self.kind.length and np.isfinite(q):
            if abs(q - round(q)) > 1e-6:
                raise ValueError(f"{self.name} = {value:g}{u} is not a multiple of "
                                 f"{self.scale:g}{u}{self._old_hint(value)}")
            q = float(round(q))
        tol = 1e-9 * max(abs(self.lower), abs(self.upper), 1.0)
        if not np.isfinite(q) or not self.lower - tol <= q <= self.upper + tol:
            raise ValueError(f"{self.name} = {value:g}{u} is outside "
                             f"[{self.to_user(self.lower):g}, {self.to_user(self.upper):g}]{u}"
                             f"{self._old_hint(value)}")
        if self.integer and q != round(q):
            raise ValueError(f"{self.name} = {value:g}{u} must be a whole number")
        return min(max(q, self.lower), self.upper)

    def from_quantity(self, text: str) -> float:
        """A value written as a quantity, a number in SI (N/m, m; a count as it is) or a
        number with its unit (``540 MN/m``, ``0.3 m``), as the checked internal value
        (ValueError)."""
        si = {"N/m": "N/m", "elements": "m"}.get(self.internal_unit, "-")
        quantity = split_quantity(text)
        if quantity is None:
            raise ValueError(f"expected a number or a number with its unit, got {text!r}")
        number, unit = quantity
        value = to_si(number, unit, si) if unit else number     # UnitError is a ValueError
        user = value / accepted(si).get(self.kind.unit, 1.0)
        # a pad's SI value is its internal one, kept to the last digit (not via MN/m and back)
        return self._checked(value if self.internal_unit == si else user / self.scale, user)

    def _old_hint(self, value: float) -> str:
        """`` (if that is in N/m, write 214 MN/m)`` when the value, read in the internal unit,
        lies within the bounds: a design written as lccopt took it before (pads in N/m,
        lengths in 0.1 m elements)."""
        if self.scale == 1.0 or not np.isfinite(value) or not self.lower <= value <= self.upper:
            return ""
        what = "counts 0.1 m elements" if self.kind.length else f"is in {self.internal_unit}"
        return f" (if that {what}, write {self.to_user(value):g} {self.kind.unit})"


def variables(design: dict, where) -> tuple[Variable, ...]:
    """The design variables of a checked ``design:`` section, in GROUPS order.

    ``where(key, field)`` names the place of a group's field (``file:line: key.path``) for a
    message; a group's bounds and reference are in internal units."""
    from ..errors import CaseError

    out = []
    for g in GROUPS:
        section = design[g.key]
        lo, hi = section["bounds"]
        if lo > hi:
            raise CaseError(f"{where(g.key, 'bounds')}: lower bound {lo:g} is above upper bound "
                            f"{hi:g}")
        if "scale" in section and section["scale"] is None:
            del section["scale"]  # absent stays absent: the resolved case does not grow a key
        if g.integer and (lo != round(lo) or hi != round(hi)):
            raise CaseError(f"{where(g.key, 'bounds')}: an integer variable needs whole-number "
                            f"bounds, got [{lo:g}, {hi:g}]{_elements(g, lo, hi)}")
        log = section.get("scale") == "log"
        if log and not lo > 0:
            raise CaseError(f"{where(g.key, 'scale')}: a log scale needs positive bounds, "
                            f"got [{lo:g}, {hi:g}]")
        refs = section["reference"] if g.counted else [section["reference"]]
        if g.counted and len(refs) != section["count"]:
            raise CaseError(f"{where(g.key, 'reference')}: expected {section['count']} values "
                            f"(count), got {len(refs)}")
        for i, r in enumerate(refs):
            name = f"{g.stem}{i + 1}" if g.counted else g.stem
            if g.integer and r != round(r):
                raise CaseError(f"{where(g.key, 'reference')}: {name} = {r:g} must be a whole "
                                f"number{_elements(g, r)}")
            if not lo <= r <= hi:
                raise CaseError(f"{where(g.key, 'reference')}: reference {name} = "
                                f"{r * g.scale:g}{' ' + g.unit if g.unit else ''} is outside "
                                f"the bounds [{lo * g.scale:g}, {hi * g.scale:g}]"
                                f"{' ' + g.unit if g.unit else ''}")
            k = len(refs) - i       # x_rN, x_sM: the nearest the interface is sleeper 1
            out.append(Variable(name, g.key, g.integer, float(lo), float(hi), float(r), log,
                                g.label(k)))
    return tuple(out)


def _elements(g: Group, *values) -> str:
    """`` (it counts 0.1 m elements: [3, 7] for 0.3-0.7 m)`` for a length group."""
    if not g.length:
        return ""
    if len(values) == 1:
        return f" (0.1 m elements: {values[0] * 10:g} for {values[0]:g} m)"
    lo, hi = values
    return f" (it counts 0.1 m elements: [{lo * 10:g}, {hi * 10:g}] for {lo:g}-{hi:g} m)"


def named(names, reference) -> list[Variable]:
    """Variables known by their names only (a run whose case cannot be read): group, unit
    and words from the name's stem, bounds unknown (NaN)."""
    stems = [n.rstrip("0123456789") for n in names]
    out = []
    for i, (n, s) in enumerate(zip(names, stems)):
        g = _BY_STEM.get(s)
        same = [j for j, t in enumerate(stems) if t == s]
        label = g.label(len(same) - same.index(i)) if g else n
        out.append(Variable(n, g.key if g else "", bool(g and g.integer), np.nan, np.nan,
                            float(reference[i]), label=label))
    return out


def split(variables, x) -> dict[str, np.ndarray]:
    """A design vector as {group key: its values} (internal units)."""
    x = np.asarray(x, dtype=float)
    return {g.key: x[[i for i, v in enumerate(variables) if v.group == g.key]] for g in GROUPS}


def read_lengths(raw: dict, where, resolved: bool = False) -> None:
    """The lengths of the raw design section (the spans, the Type II strip's bounds and
    reference), written with their unit (``0.6 m``, ``60 cm``), replaced by the whole 0.1 m
    elements the case holds them in, before the schema checks them.

    ``where(path)`` names the place of a key path (``file:line: key.path``). A bare number
    other than 0 is refused with the value to write: it counted 0.1 m elements before (a
    whole number), or it was meant in m. A case lccopt resolved (``resolved``: a run's own
    copy) holds its lengths in elements, as bare numbers: they are read as they are."""
    design = raw.get("design") if isinstance(raw, dict) else None
    if not isinstance(design, dict):
        return
    for g in GROUPS:
        section = design.get(g.key)
        if not g.length or not isinstance(section, dict):
            continue
        for k in ("bounds", "reference"):
            value = section.get(k)
            items = value if isinstance(value, list) else [value]
            if value is None or any(_number(v) is None and _length(v) is None for v in items):
                continue                       # not numbers: the schema says what is wrong
            bare = [v for v in items if _number(v) is not None and _number(v) != 0]
            if bare and not resolved:
                raise _bare_length(where(("design", g.key, k)), k, value)
            out = [_element_count(v, where(("design", g.key, k))) for v in items]
            section[k] = out if isinstance(value, list) else out[0]


def _number(v) -> float | None:
    """A bare number (a YAML number, or text that is one), else None."""
    if isinstance(v, bool):
        return None
    if isinstance(v, (int, float)):
        return float(v)
    parts = split_quantity(v) if isinstance(v, str) else None
    return parts[0] if parts is not None and not parts[1] else None


def _length(v) -> tuple[float, str] | None:
    """(number, unit) of a quantity written with a unit, else None."""
    parts = split_quantity(v) if isinstance(v, str) else None
    return parts if parts is not None and parts[1] else None


def _element_count(v, where: str) -> float:
    """A length (or a resolved copy's bare element count) as whole 0.1 m elements."""
    from ..errors import CaseError

    number = _number(v)
    if number is not None:
        return number                          # 0, or a resolved copy's element count
    value, unit = _length(v)
    try:
        metres = to_si(value, unit, "m")
    except UnitError as exc:
        raise CaseError(f"{where}: {exc}") from None
    q = metres / ELEMENT_UNIT
    if abs(q - round(q)) > 1e-6:
        raise CaseError(f"{where}: {v} is not a multiple of {ELEMENT_UNIT:g} m (the rail's "
                        f"elements: every sleeper sits on a node)")
    return float(round(q))


def _bare_length(where: str, key: str, value):
    """The one-line refusal of a length written without its unit, with what to write: a
    whole number counted 0.1 m elements (lccopt's convention before), else it meant m."""
    from ..errors import CaseError

    items = value if isinstance(value, list) else [value]
    numbers = [_number(v) for v in items]
    whole = all(n is None or n == round(n) for n in numbers)
    shown = [v if n is None else f"{n * ELEMENT_UNIT if whole else n:g} m"
             for v, n in zip(items, numbers)]
    text = f"[{', '.join(shown)}]" if isinstance(value, list) else shown[0]
    was = ("a bare number counted 0.1 m elements before" if whole else "a bare number is not "
           "read as m here, so that an old count of 0.1 m elements is never misread")
    return CaseError(f"{where}: a length is written with its unit ({was}): did you mean "
                     f"`{key}: {text}`?")
