"""benchmarks/ is a package run from the repository root (`python -m benchmarks.SUBJECT.SCRIPT`):
every `benchmarks.*` import names a module that exists, no script patches sys.path, each script
runs only under its `__main__` guard (so importing one, as the tests and its neighbours do, runs
nothing), and benchmarks/README.md lists every script. Static: nothing is imported or run."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"
# Modules other modules import and that are no command of their own.
LIBRARIES = {"support/problems.py", "support/legacy_newmark.py", "support/runs_table.py",
             "optimiser/variants.py", "scale/standin.py"}


def _modules():
    return sorted(p for p in BENCH.rglob("*.py")
                  if p.name != "__init__.py" and "results" not in p.relative_to(BENCH).parts)


def _exists(dotted: str) -> bool:
    path = ROOT.joinpath(*dotted.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def test_scripts_live_in_subject_folders_with_packages_on_the_way():
    assert (BENCH / "__init__.py").is_file()
    assert not [p.name for p in BENCH.glob("*.py") if p.name != "__init__.py"]
    for p in _modules():
        assert (p.parent / "__init__.py").is_file(), p


def test_imports_resolve_without_sys_path_patches():
    for p in _modules():
        text = p.read_text(encoding="utf-8")
        assert "sys.path" not in text, f"{p.relative_to(ROOT)} patches sys.path"
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                if node.module.split(".")[0] != "benchmarks":
                    continue
                assert _exists(node.module), f"{p.relative_to(ROOT)}: {node.module}"
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == "benchmarks":
                        assert _exists(alias.name), f"{p.relative_to(ROOT)}: {alias.name}"


def test_scripts_run_only_as_main_and_are_listed_in_the_readme():
    readme = (BENCH / "README.md").read_text(encoding="utf-8")
    for p in _modules():
        rel = p.relative_to(BENCH).as_posix()
        module = "benchmarks." + rel[:-3].replace("/", ".")
        if rel in LIBRARIES:
            continue
        assert 'if __name__ == "__main__":' in p.read_text(encoding="utf-8"), rel
        assert f"python -m {module}" in readme, f"benchmarks/README.md lacks {module}"
