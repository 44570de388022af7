"""The tree is ruff clean: lint and import order, with the rules in pyproject.toml [tool.ruff].

CI installs '.[test]' (which brings ruff) and runs pytest, so this test is the CI lint step.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_check_finds_nothing():
    result = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "lccopt", "tests", "benchmarks"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    exit_code, report = result.returncode, result.stdout + result.stderr
    assert exit_code == 0, f"ruff check found problems:\n{report}"


# The command layer: lccopt/cli.py (options, messages, exit codes), lccopt/commands/ (one
# module per command) and python -m lccopt. The library below it raises lccopt.errors and
# returns what it did.
COMMAND_LAYER = ("lccopt/cli.py", "lccopt/commands/", "lccopt/__main__.py")


def _imports(source: str, package: tuple[str, ...]) -> set[str]:
    """Every module a module of PACKAGE imports, at its top or inside a function, as absolute
    names (relative imports resolved)."""
    import ast

    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = list(package[:len(package) - node.level + 1]) if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            names.add(module)
            names.update(f"{module}.{a.name}" for a in node.names)
    return names


def _command_line_imports(source: str, package: tuple[str, ...]) -> list[str]:
    return sorted(name for name in _imports(source, package)
                  if name.split(".")[0] in ("typer", "click")
                  or name.startswith(("lccopt.cli", "lccopt.commands")))


def test_only_the_command_layer_knows_the_command_line():
    """Nothing under lccopt/ but the command layer imports typer or click (a library function
    never raises typer.Exit nor prints through typer), and nothing below it imports it back."""
    below, found = [], []
    for path in sorted((ROOT / "lccopt").rglob("*.py")):
        rel = path.relative_to(ROOT)
        if rel.as_posix().startswith(COMMAND_LAYER):
            continue
        below.append(rel)
        package = rel.parts[:-1]
        found += [f"{rel} imports {name}" for name in
                  _command_line_imports(path.read_text(encoding="utf-8"), package)]
    assert len(below) > 50, below            # the scan saw the library
    assert not found, "\n".join(found)


def test_the_import_scan_sees_lazy_and_relative_imports():
    """The scan above catches typer imported inside a function, click's exceptions, and the
    command layer reached through a relative import; a plain library import passes."""
    source = ("from ..errors import UsageError\n"
              "def stop():\n    import typer\n    raise typer.Exit(130)\n"
              "def fail():\n    from click.exceptions import Abort\n"
              "    from ..commands.run import run_optimise\n")
    assert _command_line_imports(source, ("lccopt", "engine")) == [
        "click.exceptions", "click.exceptions.Abort", "lccopt.commands.run",
        "lccopt.commands.run.run_optimise", "typer"]
    assert _command_line_imports("from ..errors import UsageError\n",
                                 ("lccopt", "engine")) == []


# Size limits: a module does one job, which fits in 500 lines; a function does one step, which
# fits in 120 (from its ``def`` line, decorators left out, to its last line, docstring
# included; a nested function counts in its own right and in the function around it).
MODULE_LINES, FUNCTION_LINES = 500, 120


def _package_modules():
    for path in sorted((ROOT / "lccopt").rglob("*.py")):
        yield path.relative_to(ROOT).as_posix(), path.read_text(encoding="utf-8")


def _long_functions(text: str) -> list[str]:
    """``name:first line (N lines)`` for every function of ``text`` over FUNCTION_LINES."""
    import ast

    return [f"{node.name}:{node.lineno} ({node.end_lineno - node.lineno + 1} lines)"
            for node in ast.walk(ast.parse(text))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > FUNCTION_LINES]


def test_modules_stay_under_the_size_limit():
    over = [f"{rel} ({len(text.splitlines())} lines)" for rel, text in _package_modules()
            if len(text.splitlines()) > MODULE_LINES]
    assert over == [], f"modules over {MODULE_LINES} lines: split them by their jobs"


def test_functions_stay_under_the_size_limit():
    over = [f"{rel}:{where}" for rel, text in _package_modules()
            for where in _long_functions(text)]
    assert over == [], f"functions over {FUNCTION_LINES} lines: split them into their steps"


def test_the_function_check_counts_every_line_of_a_function():
    """121 lines (def to last line) is over the limit, 120 is not, in a class or nested too."""
    def function(name, lines, indent=""):
        body = [f"{indent}    x = {i}" for i in range(lines - 2)]
        return "\n".join([f"{indent}def {name}():", f'{indent}    """doc."""', *body]) + "\n"

    assert _long_functions(function("fits", 120)) == []
    assert _long_functions(function("over", 121)) == ["over:1 (121 lines)"]
    inner = "class C:\n" + function("method", 121, indent="    ")
    assert _long_functions(inner) == ["method:2 (121 lines)"]
    nested = "def outer():\n" + function("inner", 120, indent="    ")
    assert _long_functions(nested) == ["outer:1 (121 lines)"]


def _import_graph(sources: dict[str, str]) -> dict[str, set[str]]:
    """Module -> the modules of ``sources`` it imports (at its top or inside a function);
    ``sources`` maps dotted module names (a package by its own name) to their text."""
    graph = {}
    for module, text in sources.items():
        is_package = module in {m.rpartition(".")[0] for m in sources}
        package = tuple(module.split(".")) if is_package else tuple(module.split(".")[:-1])
        found = set()
        for name in _imports(text, package):
            while name and name not in sources:
                name = name.rpartition(".")[0]
            if name and name != module:
                found.add(name)
        graph[module] = found
    # ``from . import sub`` names the package and its submodule: the submodule is the import
    return {m: {n for n in found if not any(o.startswith(n + ".") for o in found)}
            for m, found in graph.items()}


def _import_circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The groups of modules that import each other, directly or round a circle."""
    reach = {m: set() for m in graph}
    for start in graph:
        todo = list(graph[start])
        while todo:
            m = todo.pop()
            if m not in reach[start]:
                reach[start].add(m)
                todo.extend(graph.get(m, ()))
    circles = {tuple(sorted({m} | {n for n in reach[m] if m in reach[n]}))
               for m in graph if m in reach[m]}
    return sorted(list(c) for c in circles)


def test_no_module_imports_one_that_imports_it_back():
    """Data flows one way: no two modules of lccopt/ import each other, directly or round a
    circle, not even through an import inside a function."""
    sources = {}
    for rel, text in _package_modules():
        parts = rel[:-3].split("/")
        sources[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = text
    assert len(sources) > 50
    assert _import_circles(_import_graph(sources)) == []


def test_the_circle_check_sees_a_circle_through_a_lazy_import():
    sources = {"p": "", "p.a": "from .b import f\n",
               "p.b": "def f():\n    from . import c\n", "p.c": "from p.a import g\n",
               "p.d": "from . import a\n"}
    assert _import_circles(_import_graph(sources)) == [["p.a", "p.b", "p.c"]]
    del sources["p.c"]
    assert _import_circles(_import_graph(sources)) == []


def _package_map(sources: dict[str, str]) -> dict[str, set[str]]:
    """What each package of lccopt/ (or top-level module) imports of the others: the lines of
    docs/house.md's package map."""
    def unit(module):
        parts = module.split(".")
        return parts[1] if len(parts) > 1 else parts[0]

    out: dict[str, set[str]] = {}
    for module, found in _import_graph(sources).items():
        out.setdefault(unit(module), set()).update(unit(m) for m in found)
    return {u: found - {u} for u, found in out.items()}


def test_the_house_map_in_the_docs_is_the_code():
    """docs/house.md's package map (between its house-map markers) lists every package and
    top-level module of lccopt/ with what it imports, as the code does."""
    import re

    sources = {}
    for rel, text in _package_modules():
        parts = rel[:-3].split("/")
        sources[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = text
    doc = (ROOT / "docs" / "house.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- house-map -->\n```\n(.*?)```\n<!-- /house-map -->", doc, re.S)
    assert block, "docs/house.md has no package map between <!-- house-map --> markers"
    drawn = {}
    for line in block.group(1).splitlines():
        name, _, targets = line.partition("->")
        drawn[name.strip()] = {t.strip() for t in targets.split(",") if t.strip()}
    measured = _package_map(sources)
    differ = [f"{u}: drawn {sorted(drawn.get(u, ()))}, code {sorted(measured.get(u, ()))}"
              for u in sorted(set(drawn) | set(measured)) if drawn.get(u) != measured.get(u)]
    assert differ == [], "docs/house.md's package map is not the code:\n" + "\n".join(differ)
