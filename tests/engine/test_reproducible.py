"""Reproducible runs: the same case, seed, lccopt version and worker count give the
same evaluations in the same order, whatever order the workers finish in, resumed or not.
(Interrupted-and-resumed runs against uninterrupted ones, with two workers: the kill -9 and
Ctrl-C tests in test_cli.py, SIGTERM/SIGHUP and disk full in test_faults.py.) The journal
records the optimiser's settings and a resume uses them; runs of an optimiser this lccopt does
not have are refused; golden journals of an earlier lccopt resume to their stored continuation
bit for bit (tests/data/golden)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from lccopt.config import load_case
from lccopt.engine.journal import JournalError, read_journal
from lccopt.engine.replay import recorded_settings, restore
from lccopt.engine.rundir import RunDir
from lccopt.engine.runner import optimise, resume
from lccopt.optim.settings import Settings
from lccopt.problem import Problem

from .conftest import (
    FAKE,
    REAL,
    REPO,
    assert_same_evaluations,
    cli_run,
    pinned_numerics_env,
    read_table,
    write_case,
)

# seconds a test: whole runs compared bit for bit
pytestmark = pytest.mark.slow


def _events(run):
    return read_journal(run / "journal.jsonl")[0]


def _asked(run):
    return [(e["id"], e["x"], e["phase"], e["restart"]) for e in _events(run)
            if e["event"] == "asked"]


def _state(strategy) -> str:
    return json.dumps(strategy.state_dict(), sort_keys=True)


def test_the_same_case_twice_with_the_real_simulator_and_two_workers_gives_identical_tables(
        tmp_path):
    """`lccopt optimise` as a user runs it, twice: identical results.h5 tables (ids, x, objectives,
    value, status, reason, phase, restart, file) and the same proposals in the same order."""
    case = write_case(tmp_path, "twice", budget=18, initial=5, seed=6, worst=(20000.0, 3.0))
    env = {"LCCOPT_EVALUATOR": REAL}
    runs = []
    for k in range(2):
        r = cli_run("optimise", case, "--workers", "2", "--runs", tmp_path / f"runs{k}", env=env)
        assert r.returncode == 0, r.stderr
        runs.append(tmp_path / f"runs{k}" / "twice")
    a, b = (read_table(run) for run in runs)
    assert list(a["id"]) == list(range(18))
    assert {"adaptive", "local", "random"} & set(a["phase"]), "the surrogate phase was reached"
    assert_same_evaluations(a, b)
    assert _asked(runs[0]) == _asked(runs[1])
    assert [e["lag"] for e in _events(runs[0]) if e["event"] == "schedule"] == [2]


@pytest.mark.parametrize("workers", [2, 3, 6])
def test_results_arriving_out_of_order_do_not_change_the_run(tmp_path, monkeypatch, workers):
    """With 2 workers one proposal per fit; with 3 and 6 workers and proposals_per_fit of 3
    and 6, blocks of 3 and 6 (one fit each)."""
    # evaluation times between 0.1x and 1.9x of 40 ms, a fixed function of x: the workers
    # finish in an order that differs from the ids (checked below) and from run to run
    monkeypatch.setenv("LCCOPT_FAKE_DELAY", "0.04")
    monkeypatch.setenv("LCCOPT_FAKE_SPREAD", "0.9")
    per_fit = 1 if workers == 2 else workers
    case = write_case(tmp_path, "ooo", budget=24, initial=6, seed=3, per_fit=per_fit)
    runs = [optimise(case, workers=workers, runs=tmp_path / f"r{k}", evaluator=FAKE, progress=False)
            for k in range(2)]
    for run in runs[1:]:
        assert_same_evaluations(read_table(runs[0]), read_table(run))
        assert _asked(runs[0]) == _asked(run)
    arrived = [e["id"] for run in runs for e in _events(run)
               if e["event"] in ("evaluated", "failed")]
    assert arrived != sorted(arrived), "the test needs results that arrive out of order"
    schedule = [e for e in _events(runs[0]) if e["event"] == "schedule"]
    assert [(e["lag"], e["batch"]) for e in schedule] == [(workers, per_fit)]


def test_a_resume_with_another_worker_count_is_replayed_exactly(tmp_path):
    """The lag (worker count) of each session is journalled, so the optimiser rebuilt from the
    journal alone is the one the engine had, across sessions with different worker counts."""
    case = write_case(tmp_path, "lag", budget=8, initial=4, seed=2)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    case.write_text(case.read_text().replace("budget: 8", "budget: 16"))
    resume(run, workers=3, allow_changed_case=True, evaluator=FAKE, progress=False)
    events = _events(run)
    assert [e["lag"] for e in events if e["event"] == "schedule"] == [1, 3]
    pb = Problem.from_case(load_case(case))
    full, table = restore(pb, events, None)
    assert full.done and table.n_done == 16
    snap = RunDir(run).load_state()
    assert _state(full) == json.dumps(snap["strategy"], sort_keys=True)


def _first_line_changed(run, **changes):
    """The run's journal with its first line changed (None: key removed), no state.json."""
    lines = (run / "journal.jsonl").read_text().splitlines()
    first = json.loads(lines[0])
    for k, v in changes.items():
        if v is None:
            first.pop(k, None)
        else:
            first[k] = v
    (run / "journal.jsonl").write_text("\n".join([json.dumps(first)] + lines[1:]) + "\n")
    (run / "state.json").unlink(missing_ok=True)


@pytest.mark.parametrize("objectives,surrogate", [(("F_max",), "scalar"),
                                                  (("E_max",), "sleeper-energies"),
                                                  (("F_max", "E_max"), "composite")])
def test_the_journal_records_the_resolved_optimiser_settings(tmp_path, objectives, surrogate):
    """Every setting with its value, the surrogate's defaults ("auto" is never written)."""
    case = write_case(tmp_path, "rec", objectives=objectives, budget=6, initial=4, seed=1)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    first = _events(run)[0]
    assert first["surrogate"] == surrogate
    expected = Settings.default(composite=surrogate != "scalar").to_dict()
    assert first["optimiser"] == expected and set(expected) == {
        "composite", "perturbation", "probability_schedule", "local_weights",
        "restart_keeps_points", "restart_from", "subspace_start", "switches", "shaped_steps"}
    assert "auto" not in first["optimiser"].values()


def test_a_resume_uses_the_settings_the_run_recorded(tmp_path, monkeypatch):
    """A run recorded with settings other than today's defaults (as a later lccopt with other
    defaults would leave them) is replayed and carried on with its own."""
    case = write_case(tmp_path, "own", objectives=("F_max",), budget=30, initial=6, seed=4)
    other = Settings.default().replace(perturbation="reflect", probability_schedule="restart")
    monkeypatch.setattr(Problem, "optimiser_settings", lambda self: other)
    run = optimise(case, workers=1, runs=tmp_path / "other", evaluator=FAKE, progress=False)
    monkeypatch.undo()
    new = optimise(case, workers=1, runs=tmp_path / "new", evaluator=FAKE, progress=False)
    assert _asked(run) != _asked(new), "the two settings should propose differently here"
    assert _events(run)[0]["optimiser"] == other.to_dict()
    (run / "state.json").unlink()
    pb = Problem.from_case(load_case(case))
    replayed, table = restore(pb, _events(run), None)
    assert replayed.settings == other and replayed.done and table.n_done == 30
    case.write_text(case.read_text().replace("budget: 30", "budget: 34"))
    resume(run, workers=1, allow_changed_case=True, evaluator=FAKE, progress=False)
    assert len(read_table(run)["id"]) == 34
    # a snapshot of the optimiser made with other settings is not used: the journal is
    snap = RunDir(new).load_state()
    strategy, _ = restore(pb, _events(run), snap)
    assert strategy.settings == other


def test_a_journal_that_says_optimiser_12_resumes_with_the_default_settings():
    """Journals of the last lccopt before recorded settings say "optimiser": 12 (its
    optimiser generation), whose proposals today's defaults make with the settings added since
    at their earlier value (the golden journals check them bit for bit)."""
    for name, composite in (("scalar-F_max", False), ("composite-asf", True)):
        prefix = _lines(GOLDEN / name / "journal.jsonl")
        assert prefix[0]["optimiser"] == 12
        pb = Problem.from_case(load_case(GOLDEN / name / "case.yaml", resolved=True))
        assert recorded_settings(pb, prefix[0]) == Settings.default(
            composite=composite).replace(switches=False, shaped_steps=False)


def test_recorded_settings_without_a_later_setting_take_its_earlier_value():
    """A run that recorded its settings before `switches` existed searched the strip as one
    range: it resumes so; today's runs record the setting and resume with it."""
    pb = Problem.from_case(load_case(GOLDEN / "scalar-F_max" / "case.yaml", resolved=True))
    older = Settings.default().to_dict()
    del older["switches"]
    assert recorded_settings(pb, {"optimiser": older}).switches is False
    today = Settings.default().to_dict()
    assert recorded_settings(pb, {"optimiser": today}) == Settings.default()
    assert Settings.default().switches and Settings.default(composite=True).switches


def test_recorded_settings_without_shaped_steps_take_coordinate_steps():
    """A run that recorded its settings before `shaped_steps` existed drew every DYCORS step
    as a coordinate step: it resumes so, scalar or composite."""
    pb = Problem.from_case(load_case(GOLDEN / "scalar-F_max" / "case.yaml", resolved=True))
    for composite in (False, True):
        older = Settings.default(composite=composite).to_dict()
        del older["shaped_steps"]
        assert recorded_settings(pb, {"optimiser": older}) == Settings.default(
            composite=composite).replace(shaped_steps=False)
    assert Settings.default().shaped_steps and not Settings.default(composite=True).shaped_steps


@pytest.mark.parametrize("changes,what", [
    ({"optimiser": 11}, "\"optimiser\": 11 instead of its settings"),
    ({"optimiser": 3}, "\"optimiser\": 3 instead of its settings"),
    ({"optimiser": None, "candidates": "dycors"}, "no optimiser settings"),
    ({"optimiser": None}, "no optimiser settings"),
    ({"optimiser": "12"}, "\"optimiser\": '12' instead of its settings"),
    ({"optimiser": {**Settings.default().to_dict(), "restart_from": "alternate"}},
     "optimiser setting restart_from = 'alternate'"),
    ({"optimiser": {**Settings.default().to_dict(), "tail": "quadratic"}},
     "unknown optimiser setting 'tail'")])
def test_a_run_of_an_optimiser_this_lccopt_does_not_have_is_refused_in_one_line(tmp_path, changes,
                                                                                 what):
    """A run of an earlier optimiser generation, or recorded with settings this lccopt does not
    have: one line naming the lccopt version (and date) that made it, exit status 2."""
    case = write_case(tmp_path, "older", objectives=("F_max",), budget=6, initial=4, seed=1)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    case.write_text(case.read_text().replace("budget: 6", "budget: 8"))
    _first_line_changed(run, **changes)
    with pytest.raises(JournalError, match=r"made by lccopt 0\.1\.0 \(code [0-9a-f]{16}\) on 20"):
        restore(Problem.from_case(load_case(case)), _events(run), None)
    r = cli_run("resume", run, "--allow-changed-case", env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 2 and "Traceback" not in r.stderr
    lines = [ln for ln in r.stderr.splitlines() if "made by" in ln]
    assert len(lines) == 1 and what in lines[0] and "resume it with that version" in lines[0]
    assert len(read_table(run)["id"]) == 6


# -- golden journals (tests/data/golden: runs written by lccopt, see the README there) ----------
GOLDEN = Path(__file__).resolve().parents[1] / "data" / "golden"
GOLDEN_RUNS = sorted(p.name for p in GOLDEN.iterdir() if (p / "continuation.jsonl").is_file())


def _lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def _proposals(events) -> list:
    return [(e["id"], e["x"], e["phase"], e["restart"]) for e in events if e["event"] == "asked"]


def test_the_golden_journals_cover_restarts_and_a_subspace_phase():
    """What the golden runs pin: each surrogate, a restart in each continuation, and the
    scalar run's bound probes, subspace phase (an integer held on a bound) and its trial."""
    assert set(GOLDEN_RUNS) == {"composite-asf", "scalar-F_max", "sleeper-energies"}
    for name in GOLDEN_RUNS:
        first = _lines(GOLDEN / name / "journal.jsonl")[0]
        rest = _proposals(_lines(GOLDEN / name / "continuation.jsonl"))
        assert {r for *_, r in rest} - {0}, f"{name}: no restart in the continuation"
        assert first["surrogate"] == {"composite-asf": "composite", "scalar-F_max": "scalar",
                                      "sleeper-energies": "sleeper-energies"}[name]
    rest = _proposals(_lines(GOLDEN / "scalar-F_max" / "continuation.jsonl"))
    by_restart = {}
    for i, x, phase, r in rest:
        by_restart.setdefault(r, []).append((x, phase))
    probes = [x for x, phase in by_restart[1] if phase == "initial"]
    assert len(probes) >= 2  # the run's best point with one integer on a bound, each
    held = [j for j in range(8) if len({x[j] for x, _ in by_restart[2]}) == 1]
    assert held and all(by_restart[2][0][0][j] in (0.0, 3.0, 7.0, 20.0, 120.0) for j in held)


@pytest.mark.parametrize("name", GOLDEN_RUNS)
def test_a_golden_journal_resumes_to_its_stored_continuation_bit_for_bit(name):
    """The stopped run's journal, replayed, then carried on through the stored rest of the
    run, from the journal alone and from a snapshot at the cut (tests/engine/golden_check.py),
    in a process whose floating point is pinned as the golden runs' was."""
    env = {**os.environ, "PYTHONPATH": str(REPO), **pinned_numerics_env()}
    r = subprocess.run([sys.executable, "-m", "tests.engine.golden_check", name], env=env, cwd=REPO,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]


@pytest.mark.parametrize("name", GOLDEN_RUNS)
def test_lccopt_resume_of_a_golden_run_writes_its_stored_continuation(tmp_path, name):
    """`lccopt resume` of the stopped run (no state.json, no evaluation files: they are
    simulated again) with the stand-in evaluator proposes the stored continuation and gets
    the same values."""
    run = tmp_path / name
    (run / "evals").mkdir(parents=True)
    for f in ("case.yaml", "run.json", "journal.jsonl"):
        shutil.copy(GOLDEN / name / f, run / f)
    prefix = _lines(GOLDEN / name / "journal.jsonl")
    workers = [e["lag"] for e in prefix if e["event"] == "schedule"][-1]
    # --allow-changed-case: the run's copy of the case, resolved again by a later config
    # layer, may read differently while meaning the same (the optimiser is what is pinned)
    r = cli_run("resume", run, "--workers", str(workers), "--allow-changed-case",
                env={"LCCOPT_EVALUATOR": FAKE, **pinned_numerics_env()})
    assert r.returncode == 0, r.stderr
    want = prefix + _lines(GOLDEN / name / "continuation.jsonl")
    got = _events(run)
    assert _proposals(got) == _proposals(want)
    def values(evs):
        return sorted((e["id"], e["value"]) for e in evs if e["event"] == "evaluated")

    assert values(got) == values(want)
