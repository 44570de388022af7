"""The case-file reference, generated from the schema: every key with its unit, the units it
may be written in, its default, range, whether it is required, and what it is.

    python -m lccopt.config.reference > docs/case-reference.md

tests/config/test_case_reference.py fails when docs/case-reference.md and the schema differ.
"""

from __future__ import annotations

import sys
from dataclasses import replace

from . import kinds, units
from .schema import DEFAULT_FORCE_ZONE_END, SCHEMA

INTRO = """\
# Case-file reference

Generated from `lccopt/config/schema.py` by `python -m lccopt.config.reference >
docs/case-reference.md` (a test fails when the two differ): do not edit by hand.

A case file is YAML. `extends: other.yaml` starts from another case (relative to this file)
and changes only the keys it writes; sections merge key by key. `lccopt check`, `simulate`
and `optimise` take `--set KEY.PATH=VALUE` (e.g. `--set vehicle.speed="160 km/h"`), applied as
if a file extending the case had written it and recorded in the run's resolved case.

**Units.** A bare number is in the key's SI unit (the *unit* column). A quantity may also be
written with one of its *accepted units*, as text: `speed: 140 km/h`, `stiffness: 1120 MN/m`,
`carbody_mass: 56.4 t`. It is converted to SI when the case is read: the resolved case that a
run keeps and fingerprints holds SI numbers. A bare number outside a key's range that another
of its units would bring inside it is refused with the fix (`speed: 140` is 140 m/s = 504
km/h: "did you mean `speed: 140 km/h`?").

**Required** keys must be written (in the case or the file it extends); *no* keys take their
default when absent. The `optimisation` section is needed by `lccopt optimise` only.
"""


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _num(v: float) -> str:
    return f"{v:g}"


def _range(kind) -> str:
    """``> 0, <= 250 km/h (why)``; ``one of a, b``; ``-``."""
    if isinstance(kind, kinds.StrList):
        return "some of " + ", ".join(kind.choices)
    if isinstance(kind, kinds.Str) and kind.choices:
        return "one of " + ", ".join(kind.choices)
    if not isinstance(kind, (kinds.Num, kinds.NumList)):
        return "-"
    shown = kind.shown or kind.unit
    parts = [f"{rel} {_num(units.from_si(b, shown, kind.unit))}"
             for rel, b in ((">", kind.gt), (">=", kind.ge), ("<=", kind.le)) if b is not None]
    if isinstance(kind, kinds.Num) and kind.integer:
        parts.insert(0, "whole number")
    if isinstance(kind, kinds.NumList):
        n = (f"{kind.length} values" if kind.length else
             f"{kind.min_length}-{kind.max_length} values")
        parts.insert(0, n)
    text = ", ".join(parts) + (f" {shown}" if parts and shown != "-" and not
                               (isinstance(kind, kinds.Num) and kind.integer) else "")
    return (text or "-") + (f" ({kind.why})" if kind.why else "")


_DEFAULTS = {  # defaults that a rule or another key gives
    "evaluation.force_zone_end": "{{at: {at}, offset: {offset:g}}}".format(
        **DEFAULT_FORCE_ZONE_END),
    "simulation.irregularity": "none (a smooth rail)",
    "conditions[].speed": "the vehicle's",
    "conditions[].irregularity": "simulation.irregularity",
}


def _default(kind, path: str) -> str:
    if getattr(kind, "required", True):
        return "-"
    if path in _DEFAULTS:
        return _DEFAULTS[path]
    default = getattr(kind, "default", None)
    if default is None:
        if isinstance(kind, kinds.Section) and not kind.none_if_absent:
            return "its keys' defaults"
        return "see description" if "Default" in getattr(kind, "doc", "") else "(none)"
    if isinstance(kind, kinds.Num) and kind.unit != "-":
        return f"{_num(default)} {kind.unit}"
    return str(default) if default != "" else '""'


def _row(path: str, kind, note: str = "") -> str:
    unit = getattr(kind, "unit", "-")
    accepted = ", ".join(units.accepted(unit)) if unit in units.UNITS else "-"
    required = "yes" if getattr(kind, "required", True) else "no"
    doc = (getattr(kind, "doc", "") or "") + note
    return (f"| `{path}` | {_cell(unit)} | {_cell(accepted)} | {_cell(_default(kind, path))} | "
            f"{_cell(_range(kind))} | {required} | {_cell(doc)} |")


def _rows(kind, path: str) -> list[str]:
    """The table rows of a key and, for a section, of every key inside it."""
    if isinstance(kind, kinds.Section):
        out = [_row(path, kind)] if path and kind.doc else []
        for key, sub in kind.fields.items():
            out += _rows(sub, f"{path}.{key}" if path else key)
        return out
    if isinstance(kind, kinds.Named) and isinstance(kind.item, kinds.NumOrSection):
        return _rows(replace(kind.item, doc=f"{kind.doc}: {kind.item.doc}", required=False),
                     f"{path}.<name>")
    if isinstance(kind, kinds.Named) and not isinstance(kind.item, kinds.Section):   # name->value
        return [_row(f"{path}.<name>", replace(kind.item, doc=f"{kind.doc}: {kind.item.doc}",
                                                required=False))]
    if isinstance(kind, kinds.Named):
        return [_row(f"{path}.<name>", kind)] + [
            r for k, s in kind.item.fields.items() for r in _rows(s, f"{path}.<name>.{k}")]
    if isinstance(kind, kinds.Items):
        return [_row(f"{path}[]", kind)] + _rows(kind.item, f"{path}[]")
    if isinstance(kind, kinds.NumOrSection):
        out = [_row(path, replace(kind.number, doc=f"{kind.doc}. A number: "
                                                   f"{kind.number.doc}", required=False))]
        out += [f"| *{path} as a section:* | | | | | | |"]
        return out + [r for k, s in kind.section.fields.items()
                      for r in _rows(s, f"{path}.{k}")]
    if isinstance(kind, kinds.TextOrSection):
        out = [_row(path, kind, " Text: a file name, or none.")]
        for key, sub in kind.sections.items():
            out += [f"| *{path} as {key}:* | | | | | | |"]
            out += _rows(sub, path)
        return out
    if isinstance(kind, (kinds.Num, kinds.NumList, kinds.Str, kinds.StrList, kinds.Rows)):
        return [_row(path, kind)]
    raise TypeError(kind)


HEAD = ("| key | unit | accepted units | default | range | required | description |\n"
        "|---|---|---|---|---|---|---|")


def render() -> str:
    """The whole reference as Markdown."""
    parts = [INTRO, "## Top level\n", HEAD]
    parts += [_row(k, s) for k, s in SCHEMA.fields.items()
              if not isinstance(s, (kinds.Section, kinds.Named, kinds.Items))]
    for key, kind in SCHEMA.fields.items():
        if not isinstance(kind, (kinds.Section, kinds.Named, kinds.Items)):
            continue
        doc = getattr(kind, "doc", "")
        parts += ["", f"## {key}\n", *([doc[0].upper() + doc[1:] + ".\n"] if doc else []), HEAD]
        parts += _rows(kind, key) if not isinstance(kind, kinds.Section) else [
            r for k, s in kind.fields.items() for r in _rows(s, f"{key}.{k}")]
    parts += ["", "## Units\n", "| SI unit | accepted units |", "|---|---|"]
    parts += [f"| {si} | {', '.join(u)} |" for si, u in units.UNITS.items()]
    return "\n".join(parts) + "\n"


if __name__ == "__main__":
    sys.stdout.write(render())
