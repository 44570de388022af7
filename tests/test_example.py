"""`lccopt example`: the bundled cases as a user without a clone gets them, written into a
folder of theirs and run from there (subprocesses, real files, an 80-column terminal)."""

from __future__ import annotations

import fnmatch
import os
import tomllib

import pytest

from lccopt.config import load_case
from tests.conftest import CONFIGS, ROOT

BUNDLED = sorted(p.relative_to(CONFIGS).as_posix() for p in CONFIGS.rglob("*") if p.is_file())


def test_the_package_carries_every_file_of_configs_and_nothing_else():
    """One copy of each case: configs/ is what the package ships (lccopt/examples links to it
    in a checkout; a wheel holds the files); every file there matches the package data."""
    from lccopt.config.bundled import bundled_root

    link = ROOT / "lccopt" / "examples"
    assert link.is_symlink() and os.readlink(link) == "../configs"
    patterns = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["lccopt"]
    for rel in BUNDLED:
        assert any(fnmatch.fnmatch(f"examples/{rel}", p) for p in patterns), rel
    root = bundled_root()   # the installed package's (editable: configs/ itself)
    shipped = sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())
    assert shipped == BUNDLED
    for rel in BUNDLED:
        assert (root / rel).read_bytes() == (CONFIGS / rel).read_bytes(), rel


def test_list_names_every_bundled_case_with_its_description(run_cli, tmp_path):
    r = run_cli("example", "--list")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert all(len(line) <= 80 for line in lines), [line for line in lines if len(line) > 80]
    names = [line.split()[0] for line in lines if line.startswith("  ") and line[2] != " "]
    assert sorted(names) == sorted(rel[:-5] for rel in BUNDLED), names
    assert names[0] == "reference"
    assert "Quick look at the main job" in r.stdout
    assert run_cli("example").stdout == r.stdout        # no name: the list


def test_quickstart_is_written_with_what_it_extends_and_resolves_as_the_bundled_one(run_cli,
                                                                                   tmp_path):
    r = run_cli("example", "quickstart", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    written = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*.yaml"))
    assert written == ["moo.yaml", "quickstart.yaml", "reference.yaml"]   # its extends chain
    for name in written:
        assert (tmp_path / name).read_bytes() == (CONFIGS / name).read_bytes()
    assert "quickstart.yaml: written" in r.stdout
    assert "lccopt optimise quickstart.yaml" in r.stdout
    assert all(len(line) <= 80 for line in r.stdout.splitlines())
    check = run_cli("check", "quickstart.yaml", cwd=tmp_path)
    assert check.returncode == 0, check.stderr
    assert check.stdout.splitlines()[1:] == run_cli(
        "check", CONFIGS / "quickstart.yaml").stdout.splitlines()[1:]
    again = run_cli("example", "quickstart", cwd=tmp_path)     # the same files: nothing to do
    assert again.returncode == 0 and "already there, unchanged" in again.stdout


def test_every_bundled_case_written_out_resolves_exactly_as_in_configs(run_cli, tmp_path):
    """--all into a folder: the vehicles/ files and the cases that extend them (settlement)
    keep their relative places, so each resolves to the very case configs/ holds."""
    r = run_cli("example", "--all", "--out", "mine", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "mine"
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == BUNDLED
    for rel in BUNDLED:
        assert load_case(out / rel).resolved == load_case(CONFIGS / rel).resolved, rel


def test_settlement_brings_its_vehicle_and_the_reference(run_cli, tmp_path):
    r = run_cli("example", "settlement", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "vehicles" / "virm-bogie.yaml").is_file()
    assert (tmp_path / "reference.yaml").is_file()
    assert run_cli("check", "settlement.yaml", cwd=tmp_path).returncode == 0
    r = run_cli("example", "virm-half-car", cwd=tmp_path)    # a vehicle by its short name
    assert r.returncode == 0 and "vehicles/virm-half-car.yaml: written" in r.stdout, r.stdout
    assert "lccopt simulate vehicles/virm-half-car.yaml" in r.stdout   # it has no objectives


def test_a_file_of_the_users_is_never_overwritten_without_force(run_cli, tmp_path):
    mine = "# my own reference crossing\n"
    (tmp_path / "reference.yaml").write_text(mine)
    r = run_cli("example", "moo", cwd=tmp_path)
    assert r.returncode == 2
    err = r.stderr.strip()
    assert "\n" not in err and "reference.yaml exists and differs" in err and "--force" in err
    assert (tmp_path / "reference.yaml").read_text() == mine
    assert not (tmp_path / "moo.yaml").exists()              # all or nothing
    r = run_cli("example", "moo", "--force", cwd=tmp_path)
    assert r.returncode == 0 and "reference.yaml: replaced" in r.stdout, r.stdout
    assert (tmp_path / "reference.yaml").read_bytes() == (CONFIGS / "reference.yaml").read_bytes()


def test_never_written_through_a_link_lccopt_did_not_make(run_cli, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    work = tmp_path / "work"
    work.mkdir()
    (work / "vehicles").symlink_to(elsewhere)
    r = run_cli("example", "settlement", "--force", cwd=work)
    assert r.returncode == 2 and "symbolic link" in r.stderr, r.stderr
    assert not list(elsewhere.iterdir()) and not (work / "settlement.yaml").exists()
    (work / "moo.yaml").symlink_to(elsewhere / "target.yaml")
    r = run_cli("example", "moo", "--force", cwd=work)
    assert r.returncode == 2 and not (elsewhere / "target.yaml").exists()


@pytest.mark.parametrize("name, hint", [("quikstart", "did you mean quickstart"),
                                        ("nothing-like-it", "lccopt example --list")])
def test_an_unknown_name_gets_one_line(run_cli, tmp_path, name, hint):
    r = run_cli("example", name, cwd=tmp_path)
    assert r.returncode == 2 and hint in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not list(tmp_path.iterdir())


def test_a_missing_case_file_with_a_bundled_name_says_how_to_get_it(run_cli, tmp_path):
    """The README's and the docs' `configs/...` paths from a folder without a clone."""
    r = run_cli("optimise", "configs/quickstart.yaml", cwd=tmp_path)
    assert r.returncode == 2
    assert "lccopt example quickstart --out configs writes the bundled case" in r.stderr, r.stderr
    (tmp_path / "mine.yaml").write_text("extends: configs/vehicles/virm-bogie.yaml\nname: m\n")
    r = run_cli("check", "mine.yaml", cwd=tmp_path)
    assert r.returncode == 2 and "mine.yaml:1: extends:" in r.stderr
    assert "lccopt example vehicles/virm-bogie --out configs" in r.stderr, r.stderr
    r = run_cli("check", "not-bundled.yaml", cwd=tmp_path)
    assert r.returncode == 2 and "lccopt example" not in r.stderr
