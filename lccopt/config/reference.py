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


def _range(spec) -> str:
    """``> 0, <= 250 km/h (why)``; ``one of a, b``; ``-``."""
    if isinstance(spec, kinds.StrList):
        return "some of " + ", ".join(spec.choices)
    if isinstance(spec, kinds.Str) and spec.choices:
        return "one of " + ", ".join(spec.choices)
    if not isinstance(spec, (kinds.Num, kinds.NumList)):
        return "-"
    shown = spec.shown or spec.unit
    parts = [f"{rel} {_num(units.from_si(b, shown, spec.unit))}"
             for rel, b in ((">", spec.gt), (">=", spec.ge), ("<=", spec.le)) if b is not None]
    if isinstance(spec, kinds.Num) and spec.integer:
        parts.insert(0, "whole number")
    if isinstance(spec, kinds.NumList):
        n = (f"{spec.length} values" if spec.length else
             f"{spec.min_length}-{spec.max_length} values")
        parts.insert(0, n)
    text = ", ".join(parts) + (f" {shown}" if parts and shown != "-" and not
                               (isinstance(spec, kinds.Num) and spec.integer) else "")
    return (text or "-") + (f" ({spec.why})" if spec.why else "")


_DEFAULTS = {  # defaults that a rule or another key gives
    "evaluation.force_zone_end": "{{at: {at}, offset: {offset:g}}}".format(
        **DEFAULT_FORCE_ZONE_END),
    "simulation.irregularity": "none (a smooth rail)",
    "conditions[].speed": "the vehicle's",
    "conditions[].irregularity": "simulation.irregularity",
}


def _default(spec, path: str) -> str:
    if getattr(spec, "required", True):
        return "-"
    if path in _DEFAULTS:
        return _DEFAULTS[path]
    default = getattr(spec, "default", None)
    if default is None:
        if isinstance(spec, kinds.Section) and not spec.none_if_absent:
            return "its keys' defaults"
        return "see description" if "Default" in getattr(spec, "doc", "") else "(none)"
    if isinstance(spec, kinds.Num) and spec.unit != "-":
        return f"{_num(default)} {spec.unit}"
    return str(default) if default != "" else '""'


def _row(path: str, spec, note: str = "") -> str:
    unit = getattr(spec, "unit", "-")
    accepted = ", ".join(units.accepted(unit)) if unit in units.UNITS else "-"
    required = "yes" if getattr(spec, "required", True) else "no"
    doc = (getattr(spec, "doc", "") or "") + note
    return (f"| `{path}` | {_cell(unit)} | {_cell(accepted)} | {_cell(_default(spec, path))} | "
            f"{_cell(_range(spec))} | {required} | {_cell(doc)} |")


def _rows(spec, path: str) -> list[str]:
    """The table rows of a key and, for a section, of every key inside it."""
    if isinstance(spec, kinds.Section):
        out = [_row(path, spec)] if path and spec.doc else []
        for key, sub in spec.fields.items():
            out += _rows(sub, f"{path}.{key}" if path else key)
        return out
    if isinstance(spec, kinds.Named) and isinstance(spec.item, kinds.NumOrSection):
        return _rows(replace(spec.item, doc=f"{spec.doc}: {spec.item.doc}", required=False),
                     f"{path}.<name>")
    if isinstance(spec, kinds.Named) and not isinstance(spec.item, kinds.Section):   # name->value
        return [_row(f"{path}.<name>", replace(spec.item, doc=f"{spec.doc}: {spec.item.doc}",
                                                required=False))]
    if isinstance(spec, kinds.Named):
        return [_row(f"{path}.<name>", spec)] + [
            r for k, s in spec.item.fields.items() for r in _rows(s, f"{path}.<name>.{k}")]
    if isinstance(spec, kinds.Items):
        return [_row(f"{path}[]", spec)] + _rows(spec.item, f"{path}[]")
    if isinstance(spec, kinds.NumOrSection):
        out = [_row(path, replace(spec.number, doc=f"{spec.doc}. A number: "
                                                   f"{spec.number.doc}", required=False))]
        out += [f"| *{path} as a section:* | | | | | | |"]
        return out + [r for k, s in spec.section.fields.items()
                      for r in _rows(s, f"{path}.{k}")]
    if isinstance(spec, kinds.TextOrSection):
        out = [_row(path, spec, " Text: a file name, or none.")]
        for key, sub in spec.sections.items():
            out += [f"| *{path} as {key}:* | | | | | | |"]
            out += _rows(sub, path)
        return out
    if isinstance(spec, (kinds.Num, kinds.NumList, kinds.Str, kinds.StrList, kinds.Rows)):
        return [_row(path, spec)]
    raise TypeError(spec)


HEAD = ("| key | unit | accepted units | default | range | required | description |\n"
        "|---|---|---|---|---|---|---|")


def render() -> str:
    """The whole reference as Markdown."""
    parts = [INTRO, "## Top level\n", HEAD]
    parts += [_row(k, s) for k, s in SCHEMA.fields.items()
              if not isinstance(s, (kinds.Section, kinds.Named, kinds.Items))]
    for key, spec in SCHEMA.fields.items():
        if not isinstance(spec, (kinds.Section, kinds.Named, kinds.Items)):
            continue
        doc = getattr(spec, "doc", "")
        parts += ["", f"## {key}\n", *([doc[0].upper() + doc[1:] + ".\n"] if doc else []), HEAD]
        parts += _rows(spec, key) if not isinstance(spec, kinds.Section) else [
            r for k, s in spec.fields.items() for r in _rows(s, f"{key}.{k}")]
    parts += ["", "## Units\n", "| SI unit | accepted units |", "|---|---|"]
    parts += [f"| {si} | {', '.join(u)} |" for si, u in units.UNITS.items()]
    return "\n".join(parts) + "\n"


if __name__ == "__main__":
    sys.stdout.write(render())
