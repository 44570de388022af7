"""Reading case files: YAML with the line of every key, and ``extends``.

Every problem is a :class:`~lccopt.errors.CaseError` of one line, ``FILE:LINE: KEY.PATH:
what is wrong``. The reader is a safe YAML loader hardened against what a case file never
needs: anchors and aliases (an alias bomb expands exponentially), merge keys, tags, deep
nesting.
"""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path
from typing import Any

import yaml

from ..errors import CaseError
from ..safeio import UnsafeFile, read_input
from .profiles import MAX_CASE_PROFILE_POINTS, MAX_ROW_BYTES

MAX_CASE_BYTES = 1_000_000  # a case file is a few kB; anything near this is not one
# what a case file may take with its rail profiles inline (a run's resolved copy holds them)
MAX_CASE_FILE_BYTES = MAX_CASE_BYTES + MAX_CASE_PROFILE_POINTS * MAX_ROW_BYTES
# YAML besides profile rows over a whole extends chain: 1 MB of dense YAML takes the reader
# ~3 s and ~110 MB (measured), so a chain may not multiply it
MAX_CHAIN_STRUCTURE_BYTES = 2 * MAX_CASE_BYTES
MAX_DEPTH = 20              # sections nest 4 deep; deeper is an attack on the recursive reader


class _Loader(yaml.SafeLoader):
    """SafeLoader that reads ``1120e6`` as a float (PyYAML's YAML 1.1 rules make it a string),
    refuses anchors/aliases (an alias bomb expands exponentially) and deep nesting."""

    _depth = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent) or getattr(self.peek_event(), "anchor", None):
            raise yaml.composer.ComposerError(
                None, None, "anchors and aliases (&name, *name) are not allowed in case files; "
                "use 'extends: other.yaml' to share values", self.peek_event().start_mark)
        self._depth += 1
        if self._depth > MAX_DEPTH:
            raise yaml.composer.ComposerError(None, None,
                                              f"nested more than {MAX_DEPTH} levels deep",
                                              self.peek_event().start_mark)
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


_PLAIN_TAGS = ("tag:yaml.org,2002:map", "tag:yaml.org,2002:seq")


def dotted(path: tuple) -> str:
    """``("track", "ers", "slab_lengths", 0)`` -> ``track.ers.slab_lengths[0]``."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


def locate(lines: dict, at: tuple, file: str) -> str:
    """``file:line`` of key path ``at``, else of the nearest enclosing key, else ``file:1``."""
    where, line = at, lines.get(at)
    while line is None and where:
        where = where[:-1]
        line = lines.get(where)
    return line or f"{file}:1"


def _build(node: yaml.Node, loader: _Loader, path: tuple, lines: dict, file: str) -> Any:
    """Turn a composed YAML node into plain Python objects, remembering each key's line."""
    lines[path] = f"{file}:{node.start_mark.line + 1}"
    top = dotted(path) or "<top>"
    # scalars go through the constructor, which knows only the plain tags
    if node.tag not in _PLAIN_TAGS and not isinstance(node, yaml.ScalarNode):
        raise CaseError(f"{file}:{node.start_mark.line + 1}: {top}: "
                        f"YAML tags ({node.tag}) are not allowed in case files")
    if isinstance(node, yaml.MappingNode):
        out: dict = {}
        for key_node, value_node in node.value:
            at = f"{file}:{key_node.start_mark.line + 1}"
            if key_node.tag == "tag:yaml.org,2002:merge":
                raise CaseError(f"{at}: {top}: merge keys (<<) are not allowed in case files; "
                                f"use 'extends:'")
            key = loader.construct_object(key_node)
            if not isinstance(key, str):
                raise CaseError(f"{at}: {top}: keys must be strings, got {key!r}")
            if key in out:
                raise CaseError(f"{at}: {dotted(path + (key,))}: duplicate key")
            out[key] = _build(value_node, loader, path + (key,), lines, file)
            lines[path + (key,)] = at
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_build(v, loader, path + (i,), lines, file) for i, v in enumerate(node.value)]
    return loader.construct_object(node, deep=True)


def read_yaml(text: str, file: str) -> tuple[dict, dict]:
    """Parse the YAML text of a case file; return (data, {key path: "file:line"})."""
    if "\x00" in text:
        line = text.count("\n", 0, text.index("\x00")) + 1
        raise CaseError(f"{file}:{line}: <file>: binary data (NUL byte); a case file is YAML text")
    lines: dict = {}
    loader = None
    try:
        loader = _Loader(text)   # its reader refuses control characters already
        node = loader.get_single_node()
        if node is None:
            raise CaseError(f"{file}:1: <top>: the file is empty")
        data = _build(node, _Loader(""), (), lines, file)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else 1
        raise CaseError(f"{file}:{line}: <yaml>: {exc.problem or exc}") from None
    except yaml.YAMLError as exc:  # e.g. the reader's "special characters are not allowed"
        position = getattr(exc, "position", None)
        at = text.count("\n", 0, position) + 1 if isinstance(position, int) else 1
        raise CaseError(f"{file}:{at}: <yaml>: {str(exc).splitlines()[0]}") from None
    except RecursionError:
        raise CaseError(f"{file}:1: <yaml>: nested too deeply") from None
    finally:
        if loader is not None:
            loader.dispose()
    if not isinstance(data, dict):
        raise CaseError(f"{file}:1: <top>: a case file is a mapping of sections")
    return data, lines


def _merge(base: dict, over: dict) -> dict:
    """Deep-merge two raw case mappings: sections merge key by key, anything else is replaced."""
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(base[k], v) if isinstance(v, dict) and isinstance(base.get(k), dict) else v
    return out


def read_with_base(path: Path, text: str, seen: frozenset = frozenset(),
                   budget: tuple[int, int] | None = None) -> tuple[dict, dict]:
    """Read a case file; ``extends: other.yaml`` (relative to it) starts from another case.

    ``budget``: (bytes, bytes besides profile rows) the files of the ``extends`` chain may
    still take together (each is limited as a case file, and the chain as one)."""
    size = len(text.encode("utf-8"))
    structure = size if size <= MAX_CASE_BYTES else structure_bytes(text)
    total, left = budget or (MAX_CASE_FILE_BYTES, MAX_CHAIN_STRUCTURE_BYTES)
    if structure > left:
        raise CaseError(f"{shown(str(path))}:1: <file>: the files of the extends chain hold "
                        f"more than {MAX_CHAIN_STRUCTURE_BYTES:,} bytes of YAML in all")
    budget = (total - size, left - structure)
    raw, lines = read_yaml(text, str(path))
    base_name = raw.pop("extends", None)
    if base_name is None:
        return raw, lines
    where = lines[("extends",)]
    if not isinstance(base_name, str):
        raise CaseError(f"{where}: extends: expected a file name, got {base_name!r}")
    check_file_name(base_name, where, "extends")
    try:
        base_path = (path.parent / base_name).resolve()
    except (OSError, RuntimeError) as exc:   # RuntimeError: a loop of symbolic links
        raise CaseError(f"{where}: extends: cannot read {shown(base_name)}: "
                        f"{getattr(exc, 'strerror', None) or exc}") from None
    if base_path in seen:
        raise CaseError(f"{where}: extends: {shown(base_name)} extends itself (a cycle)")

    def fail(problem: str) -> CaseError:
        return CaseError(f"{where}: extends: {shown(str(base_path))}: {problem}")

    base_text = read_case_text(base_path, max(0, budget[0]), fail)
    base_raw, base_lines = read_with_base(base_path, base_text, seen | {base_path}, budget)
    return _merge(base_raw, raw), {**base_lines, **lines}


def shown(name: str, most: int = 160) -> str:
    """A file name as a message shows it: control characters escaped, long names cut."""
    text = repr(name)[1:-1] if not name.isprintable() else name
    return text if len(text) <= most else text[:most - 3] + "..."


def check_file_name(name: str, where: str, key: str) -> None:
    """Refuse a file name with a control or format character (NUL, escape sequences that
    repaint the terminal, bidirectional overrides that show a name other than the real one)."""
    bad = next((c for c in name if unicodedata.category(c)[0] == "C" or c in "\u2028\u2029"),
               None)
    if bad is not None:
        raise CaseError(f"{where}: {key}: the file name '{shown(name)}' holds the control "
                        f"character U+{ord(bad):04X}; name the file with printable characters")


def read_input_bytes(path: Path, limit: int, fail) -> bytes:
    """The bytes of an input file, through :func:`lccopt.safeio.read_input` (regular files
    only, at most ``limit`` bytes, checked while reading); ``fail(problem)`` makes the
    CaseError that names the file and, where there is one, the key that named it."""
    try:
        return read_input(path, limit)
    except UnsafeFile as exc:
        raise fail(exc.strerror) from None
    except FileNotFoundError as exc:
        from .bundled import suggest_for_missing

        hint = suggest_for_missing(path)
        raise fail(f"cannot read: {exc.strerror or exc}" + (f"; {hint}" if hint else "")) from None
    except OSError as exc:
        raise fail(f"cannot read: {exc.strerror or exc}") from None
    except ValueError as exc:   # e.g. a NUL in a name built by a program
        raise fail(f"cannot read: {exc}") from None


def read_case_text(path: Path, limit: int = MAX_CASE_FILE_BYTES, fail=None) -> str:
    """The text of a case file (raises CaseError): UTF-8, at most ``MAX_CASE_BYTES`` besides
    its rail profiles written inline (``points: |`` blocks, see :func:`structure_bytes`)."""
    file = shown(str(path))
    if fail is None:
        def fail(problem: str) -> CaseError:
            where = f"{file}:1: <file>" if problem.startswith("larger than") else file
            return CaseError(f"{where}: {problem}")
    data = read_input_bytes(path, limit, fail)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise CaseError(f"{file}:{line}: <file>: not UTF-8 text (byte {exc.start}); "
                        f"save the case file as UTF-8") from None
    if len(data) > MAX_CASE_BYTES and structure_bytes(text) > MAX_CASE_BYTES:
        raise CaseError(f"{file}:1: <file>: {len(data):,} bytes; a case file is at most "
                        f"{MAX_CASE_BYTES:,} besides its inline rail profiles (is this the right "
                        f"file?)")
    return text


_POINTS_BLOCK = re.compile(r"[ -]*(points): *\|[-+0-9]*[ \t]*(?:#.*)?")


def structure_bytes(text: str) -> int:
    """Bytes of a case file's text outside its ``points: |`` literal blocks (the rows of rail
    profiles written inline, as the resolved copy of a run holds them): what the
    ``MAX_CASE_BYTES`` limit applies to. The YAML reader itself parses the whole text; this
    only decides whether it is worth parsing."""
    lines = text.split("\n")
    total, i = 0, 0
    while i < len(lines):
        m = _POINTS_BLOCK.fullmatch(lines[i])
        total += len(lines[i].encode("utf-8")) + 1
        i += 1
        if m:   # the block: blank lines and lines indented deeper than its key
            column = m.start(1)
            while i < len(lines) and (not lines[i].strip()
                                      or len(lines[i]) - len(lines[i].lstrip(" ")) > column):
                i += 1
    return total
