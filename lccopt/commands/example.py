"""``lccopt example``: the bundled cases, listed and written out as files a user can run and
edit.

The bundled cases are the files of a checkout's ``configs/``; the package reaches them as
``lccopt/examples`` (a link to ``configs/`` in a checkout, the files themselves in a wheel), so
there is one copy of each. A case is written with the files it ``extends``, in the same
relative places (``settlement.yaml`` next to ``vehicles/virm-bogie.yaml``, which extends
``../reference.yaml``), byte for byte: the comments that give each value's source come along,
and the written case resolves exactly as the bundled one.

Writing follows the rules of every lccopt output: only into the folder named (``--out``,
default the current one), never through a link lccopt did not make, never over a file that
differs from the bundled one unless told (``--force``); the files are written whole or not
at all (``lccopt.outdir``).
"""

from __future__ import annotations

import errno
import os
import stat
import textwrap
from pathlib import Path

import typer

from ..config.bundled import (
    bundled_root,
    example_names,
    files_of,
    optimisable,
    read_bundled,
    resolve_name,
)
from ..errors import UsageError
from ..outdir import Output
from ..safeio import UnsafeFile, read_input
from ..terminal import WIDTH

# the name column of ``lccopt example --list``
_NAME_WIDTH = 24


def run_example(names: list[str], list_: bool, all_: bool, out: Path, force: bool) -> None:
    """List the bundled cases (``--list``, or nothing named), or write the ones named (or
    ``--all``) into ``out``, and say what was written."""
    if list_ or not (names or all_):
        typer.echo("\n".join(list_lines()))
        return
    if names and all_:
        raise UsageError("give case names or --all, not both")
    typer.echo("\n".join(write_examples(example_names() if all_ else names, out, force)))


def list_lines() -> list[str]:
    """``lccopt example --list``: each bundled case with its description, in 80 columns."""
    lines = ["bundled cases (lccopt example NAME writes NAME.yaml and the files it extends",
             "into the current folder, or into --out DIR):"]
    for name in example_names():
        text = " ".join(str(read_bundled(f"{name}.yaml").get("description") or "").split())
        body = textwrap.wrap(text or "(no description)", WIDTH - _NAME_WIDTH,
                             break_on_hyphens=False)
        head = f"  {name}"
        if len(head) >= _NAME_WIDTH:
            lines.append(head)
            head = ""
        lines.append(f"{head:<{_NAME_WIDTH}}{body[0]}")
        lines += [" " * _NAME_WIDTH + b for b in body[1:]]
    return lines


def _refuse_link(path: Path) -> None:
    """A folder or file on the way that is a symbolic link lccopt did not make: refused."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    if stat.S_ISLNK(st.st_mode):
        raise UsageError(f"{path} is a symbolic link; lccopt never writes through a link it did "
                         f"not make (remove it, or write elsewhere with --out)")


def write_examples(names: list[str], out: Path, force: bool = False) -> list[str]:
    """Write the bundled cases NAMES (with the files they extend) into folder OUT; return the
    lines ``lccopt example`` prints. Nothing is written if any file in the way differs from
    the bundled one and ``force`` is not given."""
    root = bundled_root()
    wanted = [resolve_name(n) for n in names]
    files: list[str] = []
    for name in wanted:
        files += [f for f in files_of(name) if f not in files]
    plan = []
    for rel in files:
        data = (root / rel).read_bytes()
        dest = out / rel
        for part in [*reversed(dest.relative_to(out).parents[:-1]), dest.relative_to(out)]:
            _refuse_link(out / part)
        try:
            same = read_input(dest, len(data)) == data
        except FileNotFoundError:
            same = None
        except UnsafeFile as exc:
            if exc.errno != errno.EFBIG:   # a directory, a FIFO, a device: not a case file
                raise UsageError(f"{dest}: {exc.strerror}") from None
            same = False                   # larger than the bundled file: another file
        if same is False and not force:
            raise UsageError(f"{dest} exists and differs from the bundled {rel}; keep yours and "
                             f"write elsewhere with --out DIR, or replace it with --force")
        plan.append((rel, dest, data, same))
    lines = []
    # written whole or not at all, relative to the folder held open, one command at a time
    # (lccopt.outdir); the checks above decided what may be replaced
    with Output.into(out, (), (), True, "example") as output:
        for rel, dest, data, same in plan:
            if same:
                lines.append(f"  {dest}: already there, unchanged")
                continue
            staged = output.root
            for part in Path(rel).parts[:-1]:
                staged = staged.sub(part)
            (staged / Path(rel).name).write_bytes(data)
            lines.append(f"  {dest}: {'replaced' if same is False else 'written'}")
    first = (out / f"{wanted[0]}.yaml").as_posix()
    if len(wanted) > 1:
        return [f"{len(wanted)} bundled cases and the files they extend, in {out}:", *lines,
                f"next: e.g. lccopt check {first}"]
    head = (f"bundled case '{wanted[0]}'" + (" and the files it extends" if len(files) > 1 else "")
            + f", in {out}:")
    verb = "optimise" if optimisable(wanted[0]) else "simulate"
    return [head, *lines, f"next: lccopt check {first}", f"      lccopt {verb} {first}"]
