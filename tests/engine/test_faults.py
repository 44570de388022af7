"""Faults around a run, as a user meets them: every one stops with one line, loses nothing
already computed, spends no budget, and a resume ends where an uninterrupted run ends."""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import time
from pathlib import Path

import pytest

from lccopt.engine.runner import optimise

from .conftest import (
    FAKE,
    REFERENCE,
    assert_same_evaluations,
    cli,
    cli_run,
    journal_events,
    n_done,
    read_table,
    wait_for,
    write_case,
)

# seconds a test: runs killed, starved and resumed, in subprocesses
pytestmark = pytest.mark.slow

ENV = {"LCCOPT_EVALUATOR": FAKE}





def _uninterrupted(tmp_path: Path, case: Path, workers: int = 1) -> dict:
    return read_table(optimise(case, workers=workers, runs=tmp_path / "uninterrupted",
                               evaluator=FAKE, progress=False))


def _one_error_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert lines and lines[-1].startswith("lccopt: error: "), stderr
    assert "Traceback" not in stderr, stderr
    return lines[-1]


# ------------------------------------------------------------------------ --force and names

@pytest.mark.parametrize("name", [".", "..", "../x", "", ".hidden", "a/b", "x" * 65])
def test_a_case_name_must_be_one_safe_path_component(tmp_path, name):
    case = tmp_path / "n.yaml"
    case.write_text(f'extends: {REFERENCE}\nname: "{name}"\n', encoding="utf-8")
    r = cli_run("check", case)
    assert r.returncode == 2 and f"{case}:2: name: " in _one_error_line(r.stderr)


def test_force_replaces_only_an_lccopt_run_directory_inside_runs(tmp_path):
    case = write_case(tmp_path, "t", budget=3, initial=3)
    runs = tmp_path / "runs"
    # a folder of the user's that happens to carry the case's name
    (runs / "t").mkdir(parents=True)
    (runs / "t" / "thesis.tex").write_text("precious")
    r = cli_run("optimise", case, "--runs", runs, "--force", env=ENV)
    assert r.returncode == 2 and "not an lccopt run directory" in _one_error_line(r.stderr)
    assert (runs / "t" / "thesis.tex").read_text() == "precious"

    # a symlink named like the run, pointing elsewhere: neither it nor its target is removed
    (runs / "t" / "thesis.tex").unlink()
    (runs / "t").rmdir()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep").write_text("x")
    (runs / "t").symlink_to(elsewhere)
    r = cli_run("optimise", case, "--runs", runs, "--force", env=ENV)
    assert r.returncode == 2 and "not a run directory inside" in _one_error_line(r.stderr)
    assert (elsewhere / "keep").exists() and (runs / "t").is_symlink()

    # a real run is replaced
    (runs / "t").unlink()
    assert cli_run("optimise", case, "--runs", runs, "--workers", "1", env=ENV).returncode == 0
    (runs / "other-run.txt").write_text("x")
    r = cli_run("optimise", case, "--runs", runs, "--workers", "1", "--force", env=ENV)
    assert r.returncode == 0, r.stderr
    assert (runs / "other-run.txt").exists() and len(read_table(runs / "t")["id"]) == 3


# ------------------------------------------------------------------------ signals

@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_a_stop_signal_to_the_process_group_leaves_the_running_evaluation_pending(tmp_path, sig):
    """What Slurm, systemd and `timeout` do: the whole group gets SIGTERM at once."""
    case = write_case(tmp_path, "st", budget=10, initial=4, seed=3)
    reference = _uninterrupted(tmp_path, case, workers=2)
    run = tmp_path / "runs" / "st"
    # two workers and evaluation times that vary from point to point: results arrive out of order
    p = cli("optimise", case, "--workers", "2", "--runs", tmp_path / "runs",
            env={**ENV, "LCCOPT_FAKE_DELAY": "0.4", "LCCOPT_FAKE_SPREAD": "0.8"},
            start_new_session=True)
    wait_for(lambda: run.exists() and n_done(run) >= 2)
    time.sleep(0.2)  # mid-evaluation
    os.killpg(p.pid, sig)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "Traceback" not in err
    assert not [e for e in journal_events(run) if e["event"] == "failed"]
    assert cli_run("resume", run, "--workers", "2", env=ENV).returncode == 0
    assert_same_evaluations(reference, read_table(run))


# ------------------------------------------------------------------------ disk full

def _small_filesystem(path: Path, size_kb: int):
    """Mount a tmpfs of size_kb at path (needs root); None where the machine does not allow it."""
    path.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kb}k", "tmpfs", str(path)],
                       capture_output=True)
    return path if r.returncode == 0 else None


def test_disk_full_stops_with_one_line_exit_2_and_the_run_resumes_to_the_same_end(tmp_path):
    case = write_case(tmp_path, "full", budget=12, initial=5, seed=4)
    reference = _uninterrupted(tmp_path, case)
    small = _small_filesystem(tmp_path / "small", 1024)
    try:
        if small is not None:  # a real full disk: fill the filesystem up to ~60 kB
            runs = small / "runs"
            filler = small / "filler"
            with open(filler, "wb") as fh:
                try:
                    fh.write(b"\0" * (1024 * 1024 - 60 * 1024))
                except OSError:
                    pass
            r = cli_run("optimise", case, "--workers", "1", "--runs", runs, env=ENV)
            filler.unlink()
        else:  # no mount here: the kernel refuses writes past a file-size limit instead (EFBIG)
            runs = tmp_path / "runs"
            limit = lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (12 * 1024, 12 * 1024))  # noqa: E731
            p = cli("optimise", case, "--workers", "1", "--runs", runs, env=ENV, preexec_fn=limit)
            out, err = p.communicate(timeout=120)
            r = subprocess.CompletedProcess(p.args, p.returncode, out, err)
        assert r.returncode == 2, r.stderr
        line = _one_error_line(r.stderr)
        assert "No space left on device" in line or "File too large" in line
        assert "lccopt resume" in line
        run = runs / "full"
        assert not [e for e in journal_events(run) if e["event"] == "failed"]
        assert n_done(run) < 12
        done = cli_run("resume", run, "--workers", "1", env=ENV)
        assert done.returncode == 0, done.stderr
        assert_same_evaluations(reference, read_table(run))
    finally:
        if small is not None:
            subprocess.run(["umount", str(small)], capture_output=True)


# ------------------------------------------------------------------------ files deleted under a run

def test_deleted_evaluation_files_are_simulated_again_without_spending_budget(tmp_path):
    case = write_case(tmp_path, "del", budget=8, initial=4, seed=5)
    runs = tmp_path / "runs"
    assert cli_run("optimise", case, "--workers", "1", "--runs", runs, env=ENV).returncode == 0
    run = runs / "del"
    before = read_table(run)
    import shutil

    shutil.rmtree(run / "evals")
    r = cli_run("resume", run, "--workers", "1", env=ENV)
    assert r.returncode == 0, r.stderr
    assert "8 evaluation file(s) lost or damaged" in r.stderr
    assert_same_evaluations(before, read_table(run))
    assert sorted(p.name for p in (run / "evals").iterdir()) == [f"{i:06d}.h5" for i in range(8)]
    assert not [e for e in journal_events(run) if e["event"] == "failed"]

    (run / "evals" / "000003.h5").write_bytes(b"garbage")  # a damaged file
    r = cli_run("resume", run, "--workers", "1", env=ENV)
    assert r.returncode == 0 and "#3" in r.stderr
    import h5py

    with h5py.File(run / "evals" / "000003.h5", "r") as f:
        assert f["info"].attrs["id"] == 3


def test_an_emptied_journal_is_refused_and_nothing_is_deleted(tmp_path):
    case = write_case(tmp_path, "ej", budget=4, initial=4)
    runs = tmp_path / "runs"
    assert cli_run("optimise", case, "--workers", "1", "--runs", runs, env=ENV).returncode == 0
    run = runs / "ej"
    (run / "journal.jsonl").write_bytes(b"")
    r = cli_run("resume", run, env=ENV)
    assert r.returncode == 2 and "journal.jsonl is empty" in _one_error_line(r.stderr)
    assert len(list((run / "evals").glob("*.h5"))) == 4


# ------------------------------------------------------------------------ damaged run directories

def _finished_run(tmp_path: Path, name: str) -> Path:
    case = write_case(tmp_path, name, budget=4, initial=4)
    r = cli_run("optimise", case, "--workers", "1", "--runs", tmp_path / "runs", env=ENV)
    assert r.returncode == 0
    return tmp_path / "runs" / name


def test_damaged_run_files_give_one_line_and_exit_2(tmp_path):
    run = _finished_run(tmp_path, "dm")
    meta = (run / "run.json").read_bytes()
    (run / "run.json").write_bytes(b"\x00garbage{")
    r = cli_run("resume", run, env=ENV)
    assert r.returncode == 2 and "run.json" in _one_error_line(r.stderr)
    (run / "run.json").write_bytes(meta)

    journal = (run / "journal.jsonl").read_bytes()
    lines = journal.splitlines(keepends=True)
    for bad in ({"seq": 1}, {"seq": 1, "event": "evaluated", "id": 999}):
        (run / "journal.jsonl").write_bytes(lines[0] + (json.dumps(bad) + "\n").encode()
                                            + b"".join(lines[2:]))
        r = cli_run("resume", run, env=ENV)
        assert r.returncode == 2 and "journal" in _one_error_line(r.stderr)
    (run / "journal.jsonl").write_bytes(journal)

    (run / "case.yaml").write_bytes("name: caf\xe9\n".encode("latin-1"))
    (run / "run.json").write_bytes(meta.replace(b'"case_file"', b'"case_file_gone"'))
    r = cli_run("resume", run, env=ENV)
    assert r.returncode == 2 and "not UTF-8" in _one_error_line(r.stderr)
    (run / "run.json").write_bytes(meta)

    (run / "lock").unlink()
    (run / "lock").mkdir()
    r = cli_run("resume", run, env=ENV)
    assert r.returncode == 2 and "lock" in _one_error_line(r.stderr)


def test_a_read_only_run_directory_gives_one_line_and_exit_2(tmp_path):
    """Resume of a finished and of an unfinished run, and optimise into a read-only --runs."""
    small = _small_filesystem(tmp_path / "ro", 4096) if os.geteuid() == 0 else None
    base = small or tmp_path
    case_done = write_case(tmp_path, "rodone", budget=3, initial=3)
    case_open = write_case(tmp_path, "roopen", budget=12, initial=4)
    runs = base / "runs"
    assert cli_run("optimise", case_done, "--workers", "1", "--runs", runs, env=ENV).returncode == 0
    p = cli("optimise", case_open, "--workers", "1", "--runs", runs,
            env={**ENV, "LCCOPT_FAKE_DELAY": "0.3"}, start_new_session=True)
    wait_for(lambda: (runs / "roopen").exists() and n_done(runs / "roopen") >= 1)
    os.killpg(p.pid, signal.SIGTERM)
    assert p.wait(60) == 130
    try:
        if small is not None:  # root ignores permissions: make the filesystem itself read-only
            assert subprocess.run(["mount", "-o", "remount,ro", str(small)]).returncode == 0
        else:
            for d in [runs, *runs.rglob("*")]:
                d.chmod(d.stat().st_mode & ~0o222)
        new = write_case(tmp_path, "ronew", budget=3, initial=3)
        for args in (("resume", runs / "rodone"), ("resume", runs / "roopen"),
                     ("optimise", new, "--runs", runs)):
            r = cli_run(*args, "--workers", "1", env=ENV)
            assert r.returncode == 2, (args, r.stderr)
            _one_error_line(r.stderr)
    finally:
        if small is not None:
            subprocess.run(["umount", str(small)], capture_output=True)
        else:
            for d in [runs, *runs.rglob("*")]:
                d.chmod(d.stat().st_mode | 0o200)


def test_a_closed_stderr_does_not_turn_into_a_traceback(tmp_path):
    r = subprocess.run(f"{cli_cmd()} resume {tmp_path}/nothing 2>&1 | head -c 0", shell=True,
                       capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert r.stdout == "" and r.stderr == ""


def cli_cmd() -> str:
    import shlex
    import sys

    main = "import sys; from lccopt.cli import main; sys.exit(main())"
    return f"{shlex.quote(sys.executable)} -c '{main}'"


from .conftest import REPO  # noqa: E402
