"""``--set KEY.PATH=VALUE``: values given on the command line, applied to a case as if a file
that extends it had written them.

The value is YAML (``--set vehicle.speed="160 km/h"``, ``--set track.ers.slab_lengths=[9.0]``,
``--set 'evaluation.force_zone_end={at: exit_interface, offset: -1.5}'``); a mapping merges
into the section it names, as ``extends`` merges a case into its base. Key paths are dotted,
list items by index (``conditions[0].speed`` or ``conditions.0.speed``). The case is then
validated with the same messages as a file, located at ``--set`` instead of ``file:line``,
and the run's resolved case records the values.
"""

from __future__ import annotations

import re
from typing import Any

from ..errors import CaseError
from .reading import _merge, dotted, read_yaml

WHERE = "--set"
_STEP = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[[0-9]+\])*)")


def parse_path(text: str) -> tuple:
    """``conditions[0].speed`` (or ``conditions.0.speed``) -> ``("conditions", 0, "speed")``."""
    out: list = []
    for part in text.split("."):
        if part.isdigit() and out:
            out.append(int(part))
            continue
        m = _STEP.fullmatch(part)
        if m is None:
            raise CaseError(f"{WHERE}: {text}: not a key path (keys joined by '.', list "
                            f"items as [0])")
        out.append(m.group(1))
        out += [int(i) for i in re.findall(r"\[([0-9]+)\]", m.group(2))]
    return tuple(out)


def parse(item: str) -> tuple[tuple, Any]:
    """``KEY.PATH=VALUE`` -> (key path, value read as YAML)."""
    key, eq, text = item.partition("=")
    if not eq or not key.strip():
        raise CaseError(f"{WHERE}: expected KEY.PATH=VALUE (e.g. vehicle.speed=\"160 km/h\"), "
                        f"got {item[:60]!r}")
    path = parse_path(key.strip())
    if path[0] == "extends":
        raise CaseError(f"{WHERE}: extends: name the base case in a file, not with --set")
    if _ANCHOR.search(text):  # the reader's own words would point at a case file
        quoted = f"--set '{key.strip()}=" + '"' + text[:20] + "\"'"
        raise CaseError(f"{WHERE}: {dotted(path)}: cannot read the value {text[:40]!r}: anchors "
                        f"and aliases (&name, *name) are not allowed; quote the value to mean "
                        f"the text ({quoted})")
    try:
        data, _ = read_yaml(f"value: {text}" if text.strip() else "value: null", WHERE)
    except CaseError as exc:
        # what the reader says after its own location ("--set:1: <yaml>: ")
        problem = _LOCATION.sub("", str(exc), count=1)
        raise CaseError(f"{WHERE}: {dotted(path)}: cannot read the value {text[:40]!r}: "
                        f"{problem}") from None
    return path, data["value"]


_LOCATION = re.compile(re.escape(WHERE) + r":\d+: \S+: ")
# a YAML anchor or alias where a value starts: at its beginning, or after [ { , or ': '
_ANCHOR = re.compile(r"(?:^|[\[{,]|:\s)\s*[&*][^\s,\]}]")


def _mark(value: Any, path: tuple, lines: dict, where: str = WHERE) -> None:
    """Every key path of ``value`` set at ``path`` is located at ``where``."""
    lines[path] = where
    if isinstance(value, dict):
        for k, v in value.items():
            _mark(v, path + (k,), lines, where)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _mark(v, path + (i,), lines, where)


def apply(raw: dict, lines: dict, items) -> dict:
    """The raw case with the ``--set`` items applied in order (``lines`` updated to locate
    them at --set). Raises CaseError for an item that cannot be applied."""
    for item in items:
        path, value = parse(item)
        raw = put(raw, lines, path, value, item)
    return raw


def put(raw: dict, lines: dict, path: tuple, value: Any, item: str = "",
        where: str = WHERE) -> dict:
    """The raw case with ``value`` at key ``path``, a value given on the command line (a --set
    item, or an option's typed value such as ``--budget``): located at ``where``, the
    option that gave it."""
    raw = _set(raw, path, value, item or dotted(path))
    for k in range(1, len(path)):  # sections the item made (nosuch.key=3 makes nosuch)
        lines.setdefault(path[:k], where)
    _mark(value, path, lines, where)
    return raw


def _set(node: Any, path: tuple, value: Any, item: str, above: tuple = ()) -> Any:
    """A copy of ``node`` (at key path ``above``) with ``value`` at ``path`` below it
    (mappings merge, as ``extends`` does)."""
    if not path:
        return _merge(node, value) if isinstance(node, dict) and isinstance(value, dict) \
            else value
    head, rest = path[0], path[1:]
    if isinstance(head, int):
        if not isinstance(node, list) or head >= len(node):
            size = len(node) if isinstance(node, list) else 0
            raise CaseError(f"{WHERE}: {item.partition('=')[0]}: no item [{head}] "
                            f"(the list holds {size})")
        out = list(node)
        out[head] = _set(node[head], rest, value, item, above + (head,))
        return out
    if node is None:
        node = {}
    if not isinstance(node, dict):
        raise CaseError(f"{WHERE}: {item.partition('=')[0]}: {dotted(above)} is a value, "
                        f"not a section")
    out = dict(node)
    out[head] = _set(node.get(head), rest, value, item, above + (head,))
    return out
