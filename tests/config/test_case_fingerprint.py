"""Every input a run depends on is in its fingerprint: the resolved case (the run's case.yaml,
whose sha256 resume checks) holds the rows of every rail profile, not the CSV's name. An
edited profile is a changed case; the run's own copy of the case needs no file outside it."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.engine.journal import read_journal
from tests.engine.conftest import cli, cli_run, read_table, write_case

EVALUATOR = "tests.profile_evaluator:evaluate"
ORIGINAL = "98,0\n98.5,0.0001\n99,0\n"
EDITED = "98,0\n98.5,0.0002\n99,0\n"


def _n_done(run: Path) -> int:
    if not (run / "journal.jsonl").exists():
        return 0
    events, _, _ = read_journal(run / "journal.jsonl")
    return sum(e["event"] in ("evaluated", "failed") for e in events)


def _wait_for(cond, what: str, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while not cond():
        if time.monotonic() - t0 > timeout:
            raise AssertionError(f"gave up waiting for {what}")
        time.sleep(0.05)


@pytest.mark.slow
def test_an_edited_profile_is_a_changed_case_and_the_run_keeps_its_own(tmp_path):
    (tmp_path / "profile.csv").write_text(ORIGINAL)
    case = write_case(tmp_path, "irr", budget=30, initial=5,
                      extra="  irregularity: profile.csv\n")
    runs, run = tmp_path / "runs", tmp_path / "runs" / "irr"
    env = {"LCCOPT_EVALUATOR": EVALUATOR, "LCCOPT_FAKE_DELAY": "0.1"}
    p = cli("optimise", case, "--workers", "1", "--runs", runs, env=env, start_new_session=True)
    _wait_for(lambda: _n_done(run) >= 4, "4 evaluations")
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    n_before = len(read_table(run)["id"])
    assert n_before < 30

    # the run's copy holds the rows, not the file's name
    copy = (run / "case.yaml").read_text()
    assert "source: profile.csv" in copy and "98.5, 0.0001\n" in copy

    (tmp_path / "profile.csv").write_text(EDITED)
    refused = cli_run("resume", run, "--workers", "1", env=env)
    assert refused.returncode == 2, refused.stderr
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "changed since the run started" in lines[0], refused.stderr
    assert str(case) in lines[0] and f"--case {run / 'case.yaml'}" in lines[0]
    assert len(read_table(run)["id"]) == n_before           # nothing was simulated

    # the run's own case.yaml stands alone: no CSV anywhere, and it resumes on the profile the
    # run started with
    (tmp_path / "profile.csv").unlink()
    done = cli_run("resume", run, "--workers", "1", "--case", run / "case.yaml", env=env)
    assert done.returncode == 0, done.stderr
    table = read_table(run)
    assert len(table["id"]) == 30 and set(table["status"]) == {"ok"}
    assert np.all(table["E_rms"] == 1.0 + 1000.0 * 0.0001)   # every evaluation, before and after


def test_every_condition_profile_is_held_and_the_copy_reads_back_the_same(tmp_path):
    """The case's and each condition's profile are in the resolved case as rows that read
    back bit for bit (repr of each float), so the copy's fingerprint is its own."""
    rows = np.array([[90.0, 0.0], [95.1, 1.23456789012345e-4], [100.3, -2.0e-5]])
    np.savetxt(tmp_path / "a.csv", rows, delimiter=",", fmt="%.17g")
    (tmp_path / "b.csv").write_text("# measured\n96, 0\n\n97, 0.0004\n98, 0\n")
    case = write_case(tmp_path, "cond", extra="  irregularity: a.csv\n" + (
        "conditions:\n  - {name: own, irregularity: b.csv}\n  - {name: inherited}\n"
        "  - {name: smooth, irregularity: none}\n"))
    c = load_case(case)
    assert np.array_equal(c.irregularity, rows)
    assert np.array_equal(c.conditions[0].irregularity, [[96, 0], [97, 0.0004], [98, 0]])
    assert np.array_equal(c.conditions[1].irregularity, rows)
    assert c.conditions[2].irregularity is None
    copy = tmp_path / "copy"
    copy.mkdir()
    (copy / "case.yaml").write_text(c.resolved)              # no CSV in that directory
    again = load_case(copy / "case.yaml", resolved=True)
    assert again.resolved == c.resolved
    for i in range(3):
        a, b = c.conditions[i].irregularity, again.conditions[i].irregularity
        assert (a is None and b is None) or np.array_equal(a, b)


@pytest.mark.slow
def test_a_run_copy_with_a_long_profile_exceeds_the_case_limit_and_still_loads(tmp_path):
    """A case file is at most 1 MB besides its profiles' rows: the run's copy of a case with a
    25 000-row profile (1.2 MB) loads, and reads back the same rows."""
    x = np.linspace(0.0, 134.0, 25_000)
    rows = np.c_[x, 1e-3 * np.sin(7.1 * x)]
    np.savetxt(tmp_path / "long.csv", rows, delimiter=",", fmt="%.17g")
    c = load_case(write_case(tmp_path, "long", extra="  irregularity: long.csv\n"))
    copy = tmp_path / "copy"
    copy.mkdir()
    (copy / "case.yaml").write_text(c.resolved)
    assert (copy / "case.yaml").stat().st_size > 1_000_000
    again = load_case(copy / "case.yaml", resolved=True)
    assert np.array_equal(again.irregularity, rows) and again.resolved == c.resolved
