"""Units a case file may write a quantity in, converted to SI when the case is read.

A number with no unit is in the key's SI unit (the schema's ``unit``). A quantity may also be
written as text, a number and a unit: ``speed: 140 km/h``, ``stiffness: 1120 MN/m``,
``carbody_mass: 56.4 t``. The validated case, and so the resolved copy a run keeps and
fingerprints, holds the SI number only.

The units accepted are those people use for each quantity (and make mistakes with): a
speed in km/h or mph, a stiffness in kN/m or MN/m, a mass in t. Spaces, ``*`` and ``·``
inside a unit are ignored (``kN s/m`` = ``kNs/m``) and ``²``, ``³``, ``⁴`` read as ``^2``,
``^3``, ``^4``. Unit names are case-sensitive (``MN/m`` is not ``mN/m``).
"""

from __future__ import annotations

import difflib
import re

# SI unit of a quantity (the schema's `unit`) -> {accepted unit: factor to SI}
UNITS: dict[str, dict[str, float]] = {
    "m/s": {"m/s": 1.0, "km/h": 1 / 3.6, "mph": 0.44704},
    "m": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "km": 1e3},
    "kg": {"kg": 1.0, "t": 1e3},
    "N": {"N": 1.0, "kN": 1e3, "MN": 1e6},
    "N/m": {"N/m": 1.0, "kN/m": 1e3, "MN/m": 1e6, "kN/mm": 1e6, "GN/m": 1e9},
    "N s/m": {"N s/m": 1.0, "kN s/m": 1e3, "MN s/m": 1e6},
    # per metre of rail or of slab: the paper writes 54 MN/m/m
    "N/m^2": {"N/m^2": 1.0, "kN/m^2": 1e3, "MN/m^2": 1e6, "kN/m/m": 1e3, "MN/m/m": 1e6},
    "N s/m^2": {"N s/m^2": 1.0, "kN s/m^2": 1e3, "kN s/m/m": 1e3},
    "Pa": {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "GPa": 1e9, "N/mm^2": 1e6},
    "kg/m^3": {"kg/m^3": 1.0, "t/m^3": 1e3},
    "m^2": {"m^2": 1.0, "cm^2": 1e-4, "mm^2": 1e-6},
    "m^4": {"m^4": 1.0, "cm^4": 1e-8, "mm^4": 1e-12},
    "s": {"s": 1.0, "ms": 1e-3},
    "m/s^2": {"m/s^2": 1.0},
    "kg m^2": {"kg m^2": 1.0, "t m^2": 1e3},
    "m/N^(2/3)": {"m/N^(2/3)": 1.0},
    # a settlement prediction's horizon and traffic
    "year": {"year": 1.0, "years": 1.0},
    "1/year": {"1/year": 1.0, "/year": 1.0, "1/day": 365.0, "/day": 365.0},
}

_QUANTITY = re.compile(
    r"\s*([-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?)\s*(.*?)\s*")
_SUPERSCRIPTS = str.maketrans({"²": "^2", "³": "^3", "⁴": "^4"})


class UnitError(ValueError):
    """A quantity whose unit is not one of its key's (the message says which are)."""


def normal(unit: str) -> str:
    """The form units are compared in: no spaces, ``*`` or ``·``; superscripts as ``^n``."""
    return re.sub(r"[\s*·⋅]", "", unit.translate(_SUPERSCRIPTS))


def accepted(si: str) -> dict[str, float]:
    """{unit: factor to SI} of the quantities whose SI unit is ``si`` (empty: no unit)."""
    return UNITS.get(si, {})


def split(text: str) -> tuple[float, str] | None:
    """``"140 km/h"`` -> ``(140.0, "km/h")``; None if the text does not start with a number."""
    m = _QUANTITY.fullmatch(text)
    if m is None or not any(c.isdigit() for c in m.group(1)):
        return None
    return float(m.group(1).replace("_", "")), m.group(2)


def to_si(number: float, unit: str, si: str) -> float:
    """``number`` in ``unit`` as a value in the SI unit ``si`` (raises UnitError)."""
    units = accepted(si)
    factors = {normal(u): f for u, f in units.items()}
    key = normal(unit)
    if key in factors:
        return number * factors[key]
    if not units:
        raise UnitError(f"takes a plain number{f' in {si}' if si not in ('-', '') else ''}, "
                        f"got the unit '{unit}'")
    close = [u for u in units if normal(u).lower() == key.lower()] or [
        {normal(u): u for u in units}[k]
        for k in difflib.get_close_matches(key, list(factors), n=1, cutoff=0.6)]
    hint = f" (did you mean '{close[0]}'?)" if close else ""
    raise UnitError(f"unknown unit '{unit}'{hint}; it takes {', '.join(units)}")


def from_si(value: float, unit: str, si: str) -> float:
    """An SI value in another accepted ``unit`` of its quantity (for messages)."""
    return value / accepted(si).get(unit, 1.0)


def other_units(si: str) -> list[str]:
    """The accepted units of a quantity other than its SI unit."""
    return [u for u in accepted(si) if u != si]
