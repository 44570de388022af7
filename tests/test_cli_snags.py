"""Command-line snags a new user met, as they meet them: a --set split by the shell, a run
named by its case's name, the README's own virtual environment in git status."""

from __future__ import annotations

import shutil
import subprocess

import pytest

from lccopt.engine.runner import optimise
from tests.conftest import REFERENCE, ROOT
from tests.engine.conftest import FAKE, write_case


@pytest.mark.parametrize("args, hint", [
    (["--set", "optimisation.budget", "30"],
     "--set takes KEY=VALUE as one word: --set optimisation.budget=30"),
    (["--set", "vehicle.speed=120", "km/h"],
     "a --set value with a space must be quoted: --set 'vehicle.speed=120 km/h'"),
    (["--set", "vehicle.speed", "120 km/h"],
     "--set takes KEY=VALUE as one word, quoted if it holds a space: "
     "--set 'vehicle.speed=120 km/h'"),
])
def test_a_set_split_in_two_says_how_to_write_it(run_cli, tmp_path, args, hint):
    r = run_cli("check", REFERENCE, *args, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "unexpected extra argument" in r.stderr and hint in r.stderr, r.stderr
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("command", ["optimise", "simulate"])
def test_optimise_and_simulate_give_the_same_hint_and_start_nothing(run_cli, tmp_path, command):
    r = run_cli(command, REFERENCE, "--set", "vehicle.speed=120", "km/h", cwd=tmp_path)
    assert r.returncode == 2 and "--set 'vehicle.speed=120 km/h'" in r.stderr, r.stderr
    assert not list(tmp_path.iterdir())


def test_a_plain_extra_argument_gets_no_set_hint(run_cli, tmp_path):
    r = run_cli("check", REFERENCE, "extra", cwd=tmp_path)
    assert r.returncode == 2 and "--set" not in r.stderr, r.stderr


@pytest.mark.slow
def test_status_report_and_resume_take_the_runs_name(run_cli, tmp_path):
    """`lccopt status quickstart` means runs/quickstart, the folder `optimise` made here."""
    optimise(write_case(tmp_path, "named", objectives=("F_max",), budget=5, initial=4),
             workers=1, runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    r = run_cli("status", "named", cwd=tmp_path)
    assert r.returncode == 0 and r.stdout.startswith("runs/named: finished, 5/5"), r.stdout
    r = run_cli("report", "named", "--format", "md", cwd=tmp_path)
    assert r.returncode == 0 and (tmp_path / "runs" / "named" / "report" / "report.md").is_file()
    r = run_cli("resume", "named", cwd=tmp_path, env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0 and "nothing to do" in r.stderr, r.stderr
    r = run_cli("status", "unnamed", cwd=tmp_path)
    assert r.returncode == 2
    assert r.stderr.strip() == "lccopt: error: unnamed: no such run directory, nor runs/unnamed"
    (tmp_path / "named").mkdir()           # a folder of that name here wins: it is what was said
    r = run_cli("status", "named", cwd=tmp_path)
    assert r.returncode == 2 and "not an lccopt run" in r.stderr, r.stderr


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_the_readmes_virtual_environment_is_ignored_by_git():
    probe = subprocess.run(["git", "check-ignore", "-q", ".venv/bin/python"], cwd=ROOT)
    if probe.returncode == 128:
        pytest.skip("not a git checkout")
    assert probe.returncode == 0


@pytest.mark.slow
def test_resume_after_a_track_edit_says_what_works_and_that_works(run_cli, tmp_path):
    case = write_case(tmp_path, "edit", objectives=("F_max",), budget=5, initial=4)
    env = {"LCCOPT_EVALUATOR": FAKE}
    assert run_cli("optimise", case, "--workers", "1", cwd=tmp_path, env=env).returncode == 0
    case.write_text(case.read_text() + "track:\n  support: {stiffness: 22.5 MN/m}\n")
    for extra in ([], ["--allow-changed-case"]):
        r = run_cli("resume", "edit", *extra, cwd=tmp_path, env=env)
        assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
        line = r.stderr
        assert "track.support.stiffness changed since the run started" in line, line
        assert "--allow-changed-case" not in line                   # it would refuse too
        assert "--set name=NEW" in line and f"lccopt optimise {case} --force" in line, line
    # what it says works: a new name, or --force
    r = run_cli("optimise", case, "--set", "name=edit-soft", "--workers", "1", cwd=tmp_path,
                env=env)
    assert r.returncode == 0 and (tmp_path / "runs" / "edit-soft" / "results.h5").is_file()
    r = run_cli("optimise", case, "--force", "--workers", "1", cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr
