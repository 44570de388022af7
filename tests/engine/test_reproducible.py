"""Reproducible runs (issue 9): the same case, seed, lccopt version and worker count give the
same evaluations in the same order, whatever order the workers finish in, resumed or not.
(Interrupted-and-resumed runs against uninterrupted ones, with two workers: the kill -9 and
Ctrl-C tests in test_cli.py, SIGTERM/SIGHUP and disk full in test_faults.py.)"""

from __future__ import annotations

import json

import pytest

from lccopt.config import load_case
from lccopt.engine.journal import JournalError, read_journal
from lccopt.engine.rundir import RunDir
from lccopt.engine.runner import optimise, restore, resume
from lccopt.optim.strategy import GENERATION
from lccopt.problem import Problem

from .conftest import FAKE, REAL, assert_same_evaluations, cli_run, read_table, write_case


def _events(run):
    return read_journal(run / "journal.jsonl")[0]


def _asked(run):
    return [(e["id"], e["x"], e["phase"], e["restart"]) for e in _events(run) if e["event"] == "asked"]


def _state(strategy) -> str:
    return json.dumps(strategy.state_dict(), sort_keys=True)


def test_the_same_case_twice_with_the_real_simulator_and_two_workers_gives_identical_tables(tmp_path):
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


@pytest.mark.parametrize("workers", [2, 3])
def test_results_arriving_out_of_order_do_not_change_the_run(tmp_path, monkeypatch, workers):
    # evaluation times between 0.1x and 1.9x of 40 ms, a fixed function of x: the workers
    # finish in an order that differs from the ids (checked below) and from run to run
    monkeypatch.setenv("LCCOPT_FAKE_DELAY", "0.04")
    monkeypatch.setenv("LCCOPT_FAKE_SPREAD", "0.9")
    case = write_case(tmp_path, "ooo", budget=24, initial=6, seed=3)
    runs = [optimise(case, workers=workers, runs=tmp_path / f"r{k}", evaluator=FAKE, progress=False)
            for k in range(2)]
    for run in runs[1:]:
        assert_same_evaluations(read_table(runs[0]), read_table(run))
        assert _asked(runs[0]) == _asked(run)
    arrived = [e["id"] for run in runs for e in _events(run) if e["event"] in ("evaluated", "failed")]
    assert arrived != sorted(arrived), "the test needs results that arrive out of order"


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


def test_a_journal_without_schedule_lines_is_replayed_in_its_own_order(tmp_path):
    """Journals of lccopt before the schedule rule told results in the order of their lines."""
    case = write_case(tmp_path, "old", budget=10, initial=4, seed=5)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    pb = Problem.from_case(load_case(case))
    events = _events(run)
    now, _ = restore(pb, events, None)
    old = [e for e in events if e["event"] != "schedule"]
    old = [{**e, "seq": i} for i, e in enumerate(old)]
    before, _ = restore(pb, old, None)
    assert _state(before) == _state(now)


def _older_run(monkeypatch, case, runs, old_generation, old_composite=None, keys=(), written=None):
    """A run as an older lccopt made it: proposed by optimiser ``old_generation`` (and the
    scalar surrogate if old_composite=False), with the journal keys it did not write removed from the
    first line (and those it wrote otherwise, ``written``, set), and no state.json (a resume rebuilds the optimiser from the journal alone)."""
    real_strategy = Problem.strategy
    monkeypatch.setattr(Problem, "strategy", lambda self, budget=None, composite=None, generation=None:
                        real_strategy(self, budget, composite if old_composite is None else old_composite,
                                      generation=old_generation))
    run = optimise(case, workers=1, runs=runs, evaluator=FAKE, progress=False)
    monkeypatch.setattr(Problem, "strategy", real_strategy)
    lines = (run / "journal.jsonl").read_text().splitlines()
    first = json.loads(lines[0])
    for k in keys:
        first.pop(k)
    first.update(written or {})
    (run / "journal.jsonl").write_text("\n".join([json.dumps(first, separators=(",", ":"))] + lines[1:]) + "\n")
    (run / "state.json").unlink(missing_ok=True)
    return run


def _replays_and_carries_on(pb, case, old, budget: int, more: int = 4):
    """The older run's journal replays (no JournalError: the optimiser proposes what it
    proposed) to the end, and a resume with ``more`` evaluations of budget carries it on.
    Returns the replayed optimiser."""
    replayed, table = restore(pb, _events(old), None)
    assert replayed.done and table.n_done == budget
    case.write_text(case.read_text().replace(f"budget: {budget}", f"budget: {budget + more}"))
    resume(old, workers=1, allow_changed_case=True, evaluator=FAKE, progress=False)
    assert len(read_table(old)["id"]) == budget + more
    return replayed


def test_a_multi_objective_run_of_before_the_composite_surrogate_resumes_with_its_own(tmp_path, monkeypatch):
    """The journal's first line names the surrogate; a run of an older lccopt (no such key)
    was proposed by the scalar surrogate and is replayed and carried on with it."""
    case = write_case(tmp_path, "older", budget=12, initial=4, seed=3)
    pb = Problem.from_case(load_case(case))
    assert pb.multi
    new = optimise(case, workers=1, runs=tmp_path / "new", evaluator=FAKE, progress=False)
    assert _events(new)[0]["surrogate"] == "composite"
    # the older lccopt: the scalar surrogate, and no key in the journal
    old = _older_run(monkeypatch, case, tmp_path / "old", 1, old_composite=False,
                     keys=("surrogate", "candidates", "optimiser"))
    assert _asked(old) != _asked(new), "the two surrogates should propose differently here"
    # replayed, and carried on with more budget, it stays the scalar surrogate
    _replays_and_carries_on(pb, case, old, 12)


def test_a_run_of_before_dycors_only_candidates_resumes_with_its_uniform_candidates(tmp_path, monkeypatch):
    """Since issue 9 the candidates are DYCORS perturbations only (the journal's first line says
    so); a run of an older lccopt (no such key) also drew uniform candidates, and is replayed
    and carried on with them."""
    case = write_case(tmp_path, "older1", objectives=("F_max",), budget=14, initial=4, seed=2)
    pb = Problem.from_case(load_case(case))
    new = optimise(case, workers=1, runs=tmp_path / "new", evaluator=FAKE, progress=False)
    assert _events(new)[0]["candidates"] == "dycors"
    old = _older_run(monkeypatch, case, tmp_path / "old", 1, keys=("candidates", "optimiser"))
    assert any(p == "random" for _, _, p, _ in _asked(old)), "the old run drew uniform candidates"
    assert not any(p == "random" for _, _, p, _ in _asked(new))
    replayed = _replays_and_carries_on(pb, case, old, 14)
    assert replayed.settings["n_uniform"] > 0


def test_a_run_of_optimiser_generation_2_resumes_with_its_own_steps(tmp_path, monkeypatch):
    """Generation 3 changed the DYCORS steps (pySOT-like truncated normal steps, a perturbation
    probability over the whole run) and the defaults of capping and the local search; a run
    of generation 2 (journal: "candidates": "dycors", no "optimiser" key) is replayed and
    carried on with generation 2's settings."""
    case = write_case(tmp_path, "gen2", objectives=("F_max",), budget=30, initial=6, seed=4)
    pb = Problem.from_case(load_case(case))
    new = optimise(case, workers=1, runs=tmp_path / "new", evaluator=FAKE, progress=False)
    assert _events(new)[0]["optimiser"] == GENERATION
    old = _older_run(monkeypatch, case, tmp_path / "old", 2, keys=("optimiser",))
    assert _asked(old) != _asked(new), "the two generations should propose differently here"
    replayed = _replays_and_carries_on(pb, case, old, 30)
    assert replayed.settings["perturbation"] == "reflect"


def test_a_multi_objective_run_of_optimiser_generation_3_resumes_with_its_local_search(tmp_path, monkeypatch):
    """Generation 4 lets the local search compete at every weight with a composite surrogate;
    a multi-objective run of generation 3 (journal: "optimiser": 3) is replayed and carried on
    with its local search at the greedy weight only."""
    case = write_case(tmp_path, "gen3", budget=30, initial=6, seed=4)
    pb = Problem.from_case(load_case(case))
    new = optimise(case, workers=1, runs=tmp_path / "new", evaluator=FAKE, progress=False)
    assert _events(new)[0]["optimiser"] == GENERATION
    old = _older_run(monkeypatch, case, tmp_path / "old", 3, written={"optimiser": 3})
    assert _asked(old) != _asked(new), "the two generations should propose differently here"
    replayed = _replays_and_carries_on(pb, case, old, 30)
    assert replayed.settings["local_weights"] == [0.95]


def test_an_e_max_run_of_optimiser_generation_5_resumes_with_its_capped_sleeper_energies(tmp_path, monkeypatch):
    """Generation 6 fits E_max's sleeper energies as told (their max - min is not increasing in
    each energy, so median capping would hide the high ones); an E_max run of generation 5
    (journal: "optimiser": 5) is replayed and carried on with the energies median-capped."""
    case = write_case(tmp_path, "gen5", objectives=("E_max",), budget=30, initial=6, seed=4)
    pb = Problem.from_case(load_case(case))
    assert pb.surrogate == "sleeper-energies"
    new = optimise(case, workers=1, runs=tmp_path / "new", evaluator=FAKE, progress=False)
    assert _events(new)[0]["optimiser"] == GENERATION
    old = _older_run(monkeypatch, case, tmp_path / "old", 5, written={"optimiser": 5})
    assert _asked(old) != _asked(new), "the two generations should propose differently here"
    replayed = _replays_and_carries_on(pb, case, old, 30)
    assert replayed.settings["composite_capping"] is True


@pytest.mark.parametrize("value", [99, 0, "3", None])
def test_a_journal_of_an_unknown_optimiser_generation_is_refused(tmp_path, value):
    case = write_case(tmp_path, "future", objectives=("F_max",), budget=6, initial=4, seed=1)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    lines = (run / "journal.jsonl").read_text().splitlines()
    first = {**json.loads(lines[0]), "optimiser": value}
    (run / "journal.jsonl").write_text("\n".join([json.dumps(first)] + lines[1:]) + "\n")
    (run / "state.json").unlink()
    with pytest.raises(JournalError, match="optimiser generation"):
        restore(Problem.from_case(load_case(case)), _events(run), None)
    r = cli_run("resume", run, env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 2 and "optimiser generation" in r.stderr and "Traceback" not in r.stderr
