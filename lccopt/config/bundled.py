"""The bundled cases: the paper's case, its studies and the vehicles, shipped with the package.

They are the files of a checkout's ``configs/``; the package reaches them as
``lccopt/examples`` (a link to ``configs/`` in a checkout, the files themselves in a wheel), so
there is one copy of each. ``lccopt example`` writes them out (``lccopt.commands.example``); a
case file that is missing but has a bundled namesake is answered with the command that writes
it.
"""

from __future__ import annotations

import difflib
from importlib import resources
from pathlib import Path, PurePosixPath

import yaml

from ..errors import UsageError


def bundled_root() -> Path:
    """The folder of the bundled cases (``lccopt/examples``; in a checkout a link to
    ``configs/``)."""
    return Path(str(resources.files("lccopt") / "examples"))


def example_names() -> list[str]:
    """Every bundled case as ``lccopt example`` names it: ``reference``,
    ``vehicles/virm-bogie``, ... (the paper's reference case first, then by name)."""
    root = bundled_root()
    names = [p.relative_to(root).with_suffix("").as_posix() for p in root.rglob("*.yaml")]
    return sorted(names, key=lambda n: (n != "reference", "/" in n, n))


def _name_of(given: str) -> str:
    """``quickstart``, ``quickstart.yaml`` and ``configs/quickstart.yaml`` all name the
    bundled ``quickstart``."""
    name = PurePosixPath(given.replace("\\", "/"))
    if name.parts[:1] == ("configs",):
        name = PurePosixPath(*name.parts[1:])
    return str(name.with_suffix("") if name.suffix in (".yaml", ".yml") else name)


def resolve_name(given: str) -> str:
    """The bundled case a user means (UsageError naming the closest ones if none)."""
    names = example_names()
    name = _name_of(given)
    if name in names:
        return name
    by_stem = [n for n in names if n.split("/")[-1] == name]
    if len(by_stem) == 1:            # virm-bogie for vehicles/virm-bogie
        return by_stem[0]
    close = difflib.get_close_matches(name, names, n=3, cutoff=0.5)
    hint = f"did you mean {' or '.join(close)}? " if close else ""
    raise UsageError(f"no bundled case '{given}'; {hint}lccopt example --list shows them all")


def read_bundled(rel: str) -> dict:
    """The YAML of bundled file REL (``vehicles/virm-bogie.yaml``) as plain data."""
    data = yaml.safe_load((bundled_root() / rel).read_text(encoding="utf-8"))
    return data if isinstance(data, dict) else {}


def files_of(name: str) -> list[str]:
    """The bundled files case NAME needs, relative to the bundled folder: the case, then each
    file it ``extends`` in turn (all of them bundled)."""
    root = bundled_root().resolve()
    rel = PurePosixPath(f"{name}.yaml")
    out: list[str] = []
    while rel.as_posix() not in out:
        out.append(rel.as_posix())
        base = read_bundled(rel.as_posix()).get("extends")
        if not base:
            break
        rel = PurePosixPath((root / rel.parent / base).resolve().relative_to(root).as_posix())
    return out


def optimisable(name: str) -> bool:
    """Whether bundled case NAME (with what it extends) has objectives to optimise."""
    return any((read_bundled(rel).get("optimisation") or {}).get("objectives")
               for rel in files_of(name))


def suggest_for_missing(path) -> str:
    """For a case file that does not exist: the command that writes the bundled case of that
    name there (``configs/quickstart.yaml``: ``lccopt example quickstart --out configs``), or
    ''."""
    path = Path(path)
    if path.is_absolute() and path.is_relative_to(Path.cwd()):   # an extends, resolved
        path = path.relative_to(Path.cwd())
    posix = PurePosixPath(str(path).replace("\\", "/"))
    for name in example_names():
        parts = PurePosixPath(f"{name}.yaml").parts
        if posix.parts[-len(parts):] == parts:
            folder = PurePosixPath(*posix.parts[:-len(parts)]) if len(posix.parts) > len(parts) \
                else None
            return (f"lccopt example {name}" + (f" --out {folder}" if folder else "")
                    + " writes the bundled case of that name")
    return ""
