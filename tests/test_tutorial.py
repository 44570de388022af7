"""docs/tutorial.md, followed literally: its case files written as given, each of its
commands run in order in an empty folder (the bundled cases written out by its first
command, as a user without a clone gets them). A command must
exit 0 (or the code its block announces), and the output lines the tutorial quotes whole
must be there (lines with numbers that differ from machine to machine are not quoted
whole: those after a `...`)."""

from __future__ import annotations

import re
import shlex

import pytest

from tests.conftest import ROOT

# seconds a test: the whole tutorial: simulations, optimisations, reports
pytestmark = pytest.mark.slow

TUTORIAL = ROOT / "docs" / "tutorial.md"
BLOCK = re.compile(r"(?:<!-- (file|exit): ([^ ]+) -->\n)?```(\w+)\n(.*?)```", re.S)


def steps() -> list[tuple]:
    """('file', name, text) and ('run', command, exit code, quoted output lines), in order."""
    out = []
    for kind, value, lang, body in BLOCK.findall(TUTORIAL.read_text(encoding="utf-8")):
        if kind == "file":
            out.append(("file", value, body))
        elif lang == "console":
            code = int(value) if kind == "exit" else 0
            command, quoted, exact = None, [], True
            for line in body.splitlines():
                if line.startswith("$ "):
                    if command:
                        out.append(("run", command, code, quoted))
                    command, quoted, exact = line[2:], [], True
                elif line.strip() == "...":
                    exact = False
                elif exact:
                    quoted.append(line)
            if command:
                out.append(("run", command, code, quoted))
    return out


def test_the_tutorial_has_what_it_promises():
    kinds = [s[0] for s in steps()]
    commands = [s[1] for s in steps() if s[0] == "run"]
    assert kinds.count("file") >= 4 and len(commands) >= 10
    for verb in ("check", "simulate", "optimise", "status", "resume", "report"):
        assert any(c.startswith(f"lccopt {verb} ") for c in commands), verb


def test_the_tutorial_runs_as_written(tmp_path, run_cli):
    for step in steps():     # in an empty folder: the tutorial writes its configs/ first
        if step[0] == "file":
            (tmp_path / step[1]).write_text(step[2], encoding="utf-8")
            continue
        _, command, code, quoted = step
        args = shlex.split(command)
        assert args[0] == "lccopt", command
        r = run_cli(*args[1:], cwd=tmp_path, env={"COLUMNS": "80"})
        assert r.returncode == code, (command, r.stdout[-2000:], r.stderr[-2000:])
        shown = (r.stdout + r.stderr).splitlines()
        for line in quoted:
            assert line in shown, (command, line, shown[:40])
    assert (tmp_path / "runs" / "my-crossing" / "report" / "report.html").is_file()
    assert (tmp_path / "soft-pads" / "simulation.h5").is_file()
    assert (tmp_path / "virm" / "contact_force.png").is_file()
