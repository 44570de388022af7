"""`lccopt optimise` / `lccopt resume` as subprocesses: kill -9, Ctrl-C, exit codes, messages."""

from __future__ import annotations

import json
import os
import random
import signal
import time
from pathlib import Path

import h5py
import pytest

from lccopt.engine.journal import read_journal
from lccopt.engine.runner import optimise
from lccopt.store import read_evaluation

from .conftest import (
    FAKE,
    REAL,
    REFERENCE,
    assert_same_evaluations,
    cli,
    cli_run,
    n_done,
    read_table,
    wait_for,
    write_case,
)

# seconds a test: runs killed and resumed through the command line
pytestmark = pytest.mark.slow


def _children(pid: int) -> list[int]:
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(d.name))
    return out


def _alive(pid: int) -> bool:
    try:
        stat = (Path("/proc") / str(pid) / "stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"




def _check_consistent(run: Path) -> None:
    """Whatever the moment of the kill: journal readable, every file opens, no id twice."""
    events, _, _ = read_journal(run / "journal.jsonl")
    done = [e["id"] for e in events if e["event"] in ("evaluated", "failed")]
    assert len(done) == len(set(done)), "an evaluation was committed twice"
    asked = [e["id"] for e in events if e["event"] == "asked"]
    assert asked == list(range(len(asked))), "ids asked out of order or twice"
    if (run / "results.h5").exists():
        with h5py.File(run / "results.h5", "r") as f:
            assert set(f["evaluations/id"][()]) <= set(done)
    for e in events:
        if e["event"] == "evaluated":
            read_evaluation(run / e["file"])
    if (run / "state.json").exists():
        assert json.loads((run / "state.json").read_text())["seq"] < len(events)


def test_kill_9_at_random_moments_then_resume_equals_an_uninterrupted_run(tmp_path):
    """Real simulator (coarse settings), real case file and HDF5, two workers, fixed seed: the
    results reach the optimiser in id order whatever the timing, so the tables are equal."""
    case = write_case(tmp_path, "k9", budget=20, initial=6, seed=4, worst=(20000.0, 3.0))
    reference = read_table(optimise(case, workers=2, runs=tmp_path / "uninterrupted",
                                    evaluator=REAL, progress=False))
    assert (reference["status"] == "ok").all(), set(reference["reason"])
    runs = tmp_path / "runs"
    run = runs / "k9"
    env = {"LCCOPT_EVALUATOR": REAL}
    rng = random.Random(20240611)
    kills = 0
    for _ in range(5):
        args = ["resume", run, "--workers", "2"] if run.exists() else \
            ["optimise", case, "--workers", "2", "--runs", runs]
        p = cli(*args, env=env)
        # A random moment once the run is under way, counted in evaluations so that the kill
        # lands mid-run on a fast machine as on a slow one, then a random fraction of one more.
        wait_for(lambda: (run / "journal.jsonl").exists() or p.poll() is not None,
                  what="the run to start")
        target = n_done(run) + rng.randint(1, 3)
        wait_for(lambda: n_done(run) >= target or p.poll() is not None,
                  what="evaluations to finish")
        time.sleep(rng.uniform(0.0, 0.15))
        workers = _children(p.pid)
        if p.poll() is None:
            p.kill()  # SIGKILL to the lccopt process only: its workers must die with it
            kills += 1
        p.communicate()
        wait_for(lambda: not any(_alive(w) for w in workers), 30, "orphaned workers to exit")
        if run.exists():
            _check_consistent(run)
    assert kills >= 3
    done = cli_run("resume", run, "--workers", "2", env=env)
    assert done.returncode == 0, done.stderr
    final = read_table(run)
    assert_same_evaluations(reference, final)
    events, _, _ = read_journal(run / "journal.jsonl")
    finished = sorted(e["id"] for e in events if e["event"] in ("evaluated", "failed"))
    assert finished == list(range(20))
    assert sorted(p.name for p in (run / "evals").iterdir()) == [f"{i:06d}.h5" for i in range(20)]


def test_kill_9_mid_block_then_resume_equals_an_uninterrupted_run(tmp_path):
    """Four workers, proposals_per_fit 4: proposals come in blocks of four (one fit each),
    handed out as workers free up; a kill -9 lands between a block's computation and its last
    point's start (its points not yet handed out are nowhere but in the lost process), and the
    resumed run still equals the uninterrupted one."""
    env = {"LCCOPT_EVALUATOR": FAKE, "LCCOPT_FAKE_DELAY": "0.05", "LCCOPT_FAKE_SPREAD": "0.9"}
    case = write_case(tmp_path, "k9b", budget=36, initial=6, seed=5, per_fit=4)
    first = cli_run("optimise", case, "--workers", "4", "--runs", tmp_path / "uninterrupted",
                    env=env)
    assert first.returncode == 0, first.stderr
    reference = read_table(tmp_path / "uninterrupted" / "k9b")
    runs = tmp_path / "runs"
    run = runs / "k9b"
    rng = random.Random(20261205)
    kills = 0
    for _ in range(4):
        args = ["resume", run, "--workers", "4"] if run.exists() else \
            ["optimise", case, "--workers", "4", "--runs", runs]
        p = cli(*args, env=env)
        wait_for(lambda: (run / "journal.jsonl").exists() or p.poll() is not None,
                  what="the run to start")
        target = n_done(run) + rng.randint(2, 6)
        wait_for(lambda: n_done(run) >= target or p.poll() is not None,
                  what="evaluations to finish")
        time.sleep(rng.uniform(0.0, 0.05))
        workers = _children(p.pid)
        if p.poll() is None:
            p.kill()
            kills += 1
        p.communicate()
        wait_for(lambda: not any(_alive(w) for w in workers), 30, "orphaned workers to exit")
        _check_consistent(run)
    assert kills >= 3
    done = cli_run("resume", run, "--workers", "4", env=env)
    assert done.returncode == 0, done.stderr
    assert_same_evaluations(reference, read_table(run))
    events, _, _ = read_journal(run / "journal.jsonl")
    assert [(e["lag"], e["batch"]) for e in events if e["event"] == "schedule"] == [(4, 4)]


def test_ctrl_c_saves_exits_130_and_resumes_to_the_same_run(tmp_path):
    case = write_case(tmp_path, "cc", budget=12, initial=5, seed=2)
    # two workers, evaluation times varying from point to point: results arrive out of order
    env = {"LCCOPT_EVALUATOR": FAKE, "LCCOPT_FAKE_DELAY": "0.3", "LCCOPT_FAKE_SPREAD": "0.8"}
    reference = read_table(optimise(case, workers=2, runs=tmp_path / "uninterrupted",
                                    evaluator=FAKE, progress=False))
    runs = tmp_path / "runs"
    run = runs / "cc"
    # Ctrl-C in a terminal signals the whole process group, workers included.
    p = cli("optimise", case, "--workers", "2", "--runs", runs, env=env, start_new_session=True)
    wait_for(lambda: run.exists() and n_done(run) >= 3, what="3 evaluations")
    os.killpg(p.pid, signal.SIGINT)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert f"lccopt resume {run}" in err and "no new evaluations" in err
    t = read_table(run)
    # the running one finished, not failed
    assert 3 <= len(t["id"]) < 12 and set(t["status"]) == {"ok"}

    # Second Ctrl-C stops the running evaluation; it runs again on resume.
    p = cli("resume", run, "--workers", "2", env=env, start_new_session=True)
    n0 = len(t["id"])
    wait_for(lambda: n_done(run) >= n0 + 2, what="2 more evaluations")
    os.killpg(p.pid, signal.SIGINT)
    time.sleep(0.05)
    os.killpg(p.pid, signal.SIGINT)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert set(read_table(run)["status"]) == {"ok"}

    done = cli_run("resume", run, "--workers", "2", env=env)
    assert done.returncode == 0, done.stderr
    assert_same_evaluations(reference, read_table(run))
    again = cli_run("resume", run, env=env)
    assert again.returncode == 0 and "is finished" in again.stderr


def test_bad_case_and_bad_runs_give_one_line_messages_and_exit_2(tmp_path):
    noopt = tmp_path / "noopt.yaml"
    noopt.write_text(f"extends: {REFERENCE}\nname: noopt\n")
    r = cli_run("optimise", noopt, "--runs", tmp_path / "runs")
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [
        f"lccopt: error: {noopt}:1: optimisation: missing section (objectives, budget, "
        f"initial_points, ...); 'lccopt optimise' needs it"]

    bad = write_case(tmp_path, "bad", budget=3, initial=5)
    r = cli_run("optimise", bad, "--runs", tmp_path / "runs")
    assert r.returncode == 2
    assert "initial_points: 5 initial points exceed the budget of 3" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1

    r = cli_run("resume", tmp_path / "runs" / "nothing")
    missing = tmp_path / "runs" / "nothing"
    assert r.returncode == 2
    assert r.stderr.strip() == f"lccopt: error: {missing}: no such run directory"

    case = write_case(tmp_path, "chg", budget=4, initial=3)
    r = cli_run("optimise", case, "--workers", "1", "--runs", tmp_path / "runs",
                env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0, r.stderr
    case.write_text(case.read_text().replace("seed: 1", "seed: 2"))
    r = cli_run("resume", tmp_path / "runs" / "chg", env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "optimisation.seed changed since the run started" in lines[0]
    # no flag carries a run on with another seed: the message says what does work
    assert "--allow-changed-case" not in lines[0]
    assert "new name" in lines[0] and f"lccopt optimise {case} --force" in lines[0], lines[0]
    copy = tmp_path / "runs" / "chg" / "case.yaml"
    assert f"--case {copy}" in lines[0]
    r = cli_run("resume", tmp_path / "runs" / "chg", "--case", copy, env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0, r.stderr  # the run's copy, as the message says
    # a changed scale changes what the optimiser proposes: never carried on with
    case.write_text(case.read_text().replace("seed: 2", "seed: 1")
                    + "design:\n  railpad_stiffness:\n    scale: linear\n")
    r = cli_run("resume", tmp_path / "runs" / "chg", "--allow-changed-case",
                env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 2 and "design.railpad_stiffness.scale changed" in r.stderr
    assert "new name" in r.stderr and "--force" in r.stderr

    r = cli_run("optimise", case, "--runs", tmp_path / "runs", env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 2 and "already exists" in r.stderr

    r = cli_run("optimise", case, "--workers", "0", "--runs", tmp_path / "runs2")
    assert r.returncode == 2 and "--workers must be at least 1" in r.stderr

    r = cli_run("optimise", case, "--runs", tmp_path / "runs3",
                env={"LCCOPT_EVALUATOR": "nosuchmodule:f"})
    assert r.returncode == 2 and "cannot load the evaluator 'nosuchmodule:f'" in r.stderr


@pytest.mark.parametrize("seed, unchanged", [(9, True), (2, False)])
def test_the_summary_says_unchanged_when_the_best_is_the_reference(tmp_path, seed, unchanged):
    """Two evaluations: the reference design and one more, which beats it or not (seed 9 of
    the stand-in: not); an equal value reads "unchanged", never "+0.0%"."""
    case = write_case(tmp_path, "u", objectives=("F_max",), budget=2, initial=2, seed=seed)
    r = cli_run("optimise", case, "--workers", "1", "--runs", tmp_path / "runs",
                env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0, r.stderr
    line = next(ln for ln in r.stdout.splitlines() if ln.startswith("  F_max "))
    assert ("(unchanged: the reference design's)" in line) == unchanged, line
    assert "+0.0%" not in line
