"""The version of lccopt that a run records (run.json, the journal, results.h5), and a
fingerprint of its code: the version number changes at releases only, while a run resumed by
another checkout or install evaluates its later designs with that code's model."""

from __future__ import annotations

import functools
import hashlib
import re
from pathlib import Path

__version__ = "0.1.0"


@functools.cache  # the code does not change under a running process (what it imported)
def code_fingerprint() -> str:
    """16 hex digits of a sha256 over every Python file of the package (path and bytes): two
    installs with the same fingerprint run the same code, whatever the version number says."""
    root = Path(__file__).resolve().parent
    files = sorted(p for p in root.rglob("*.py") if "__pycache__" not in p.parts)
    if not files:   # imported from an archive or compiled files only: nothing to tell apart
        return "unknown"
    digest = hashlib.sha256()
    for path in files:
        rel = path.relative_to(root).as_posix()
        digest.update(rel.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def version_text() -> str:
    """``0.1.0 (code 3f2a9c1b0e4d5a6f)``: what ``lccopt --version`` prints and runs name."""
    return f"{__version__} (code {code_fingerprint()})"


def recorded_code(versions) -> str | None:
    """The code fingerprint a run's ``versions`` record names, or None (none recorded, or
    not a fingerprint: a journal is a file anyone may edit, and nothing of its own reaches
    the terminal)."""
    code = versions.get("lccopt_code") if isinstance(versions, dict) else None
    return code if isinstance(code, str) and re.fullmatch(r"[0-9a-f]{16}", code) else None
