"""Run engine in-process: run directory, results.h5, faults, resume rules (fast stand-in
evaluator)."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from lccopt.cli import UsageError
from lccopt.config import design_items, load_case
from lccopt.engine.journal import Journal, JournalError, line_mark, read_journal
from lccopt.engine.replay import restore
from lccopt.engine.rundir import RunDir
from lccopt.engine.runner import optimise, resume
from lccopt.errors import CaseError
from lccopt.optim.settings import Settings
from lccopt.problem import Problem
from lccopt.store import read_evaluation

from .conftest import FAKE, FAULTY, REFERENCE, read_table, write_case

# seconds a test: whole runs of the engine
pytestmark = pytest.mark.slow


def test_run_directory_and_results_layout(tmp_path, capsys):
    case = write_case(tmp_path, "moo", budget=10, initial=4)
    run = optimise(case, workers=2, runs=tmp_path / "runs", evaluator=FAKE)
    assert run == tmp_path / "runs" / "moo"
    for name in ("run.json", "case.yaml", "journal.jsonl", "state.json", "results.h5", "lock",
                 "evals"):
        assert (run / name).exists(), name
    events, _, torn = read_journal(run / "journal.jsonl")
    assert not torn and events[0]["event"] == "run" and events[-1]["event"] == "finished"
    meta = json.loads((run / "run.json").read_text())
    c = load_case(case)
    # the copy stands on its own
    assert load_case(run / "case.yaml", resolved=True).resolved == c.resolved

    t = read_table(run)
    assert list(t["id"]) == list(range(10)) and set(t["status"]) == {"ok"}
    assert t["x"].shape == (10, 8)
    np.testing.assert_array_equal(t["x"][0], c.reference)  # the reference design goes first
    assert t["phase"][0] == "initial"
    with h5py.File(run / "results.h5", "r") as f:
        assert f.attrs["format"] == "lccopt-results" and bool(f.attrs["finished"])
        assert f.attrs["scalarisation"] == "asf"
        assert list(f.attrs["objectives"]) == ["F_max", "E_max"]
        assert f["case/resolved"][()].decode() == c.resolved
        assert f["case"].attrs["sha256"] == meta["case_sha256"]
        assert set(f["versions"].attrs) >= {"lccopt", "numpy", "scipy", "h5py", "python"}
        ref = {k: f["reference/objectives"].attrs[k] for k in f["reference/objectives"].attrs}
        point = f["reference/point"][()]
        np.testing.assert_allclose(point, [0.8 * ref["F_max"], 0.8 * ref["E_max"]])
        best = int(f["best"].attrs["id"])
        assert f["best"].attrs["value"] == np.min(t["value"])
        assert t["pareto"].dtype == bool and t["pareto"][list(t["id"]).index(best)]
    # The scalar value is the ASF of Eq. (7) of the stored objectives.
    pb = Problem.from_case(c)
    for i in range(10):
        obj = {"F_max": t["F_max"][i], "E_max": t["E_max"][i]}
        assert t["value"][i] == pytest.approx(pb.value(obj, point), rel=1e-12)
    with h5py.File(run / "results.h5", "r") as f:  # external links to the histories
        np.testing.assert_array_equal(f["evals/000003/design"][()], t["x"][3])
        assert "contact_force" in f["evals/000000/histories"]   # the reference's time histories
        # and the best's (histories: best)
        assert "contact_force" in f[f"evals/{best:06d}/histories"]
    for i, name in enumerate(t["file"]):
        x, ev = read_evaluation(run / name)
        np.testing.assert_array_equal(x, t["x"][i])
        assert ev.objectives["F_max"] == t["F_max"][i]
    out = capsys.readouterr()
    assert "done: 10 evaluations" in out.out and "[10/10]" in out.err
    # the best design's lines fit an 80-column terminal and still hold every variable
    lines = out.out.splitlines()
    i = next(i for i, line in enumerate(lines) if line.startswith("  x: "))
    design = [line for line in lines[i:] if line.startswith("  x: ") or line.startswith("     ")]
    assert len(design) >= 2 and all(len(line) <= 80 for line in design)
    assert " ".join(s.strip() for s in design)[3:] == ", ".join(
        design_items(c, t["x"][list(t["id"]).index(best)]))

    # Resuming a finished run says so and does nothing.
    resume(run, workers=1, evaluator=FAKE)
    assert "is finished" in capsys.readouterr().err
    assert len(read_journal(run / "journal.jsonl")[0]) == len(events)


def test_single_objective_value_is_the_objective(tmp_path):
    case = write_case(tmp_path, "single", objectives=("E_max",), budget=8, initial=4)
    run = optimise(case, workers=2, runs=tmp_path, evaluator=FAKE, progress=False)
    t = read_table(run)
    np.testing.assert_array_equal(t["value"], t["E_max"])
    with h5py.File(run / "results.h5", "r") as f:
        assert f.attrs["scalarisation"] == "single" and "point" not in f["reference"]


def test_faulty_simulations_are_recorded_and_the_run_completes(tmp_path, monkeypatch):
    faults = tmp_path / "markers"
    faults.mkdir()
    monkeypatch.setenv("LCCOPT_TEST_FAULTS", "raise,nan,exit,hang")
    monkeypatch.setenv("LCCOPT_TEST_FAULT_DIR", str(faults))
    case = write_case(tmp_path, "faults", budget=12, initial=6, timeout=3.0)
    run = optimise(case, workers=2, runs=tmp_path, evaluator=FAULTY, progress=False)
    t = read_table(run)
    assert len(t["id"]) == 12
    assert sorted(p.name for p in faults.iterdir()) == ["exit", "hang", "nan", "raise"]
    failed = {r for r, s in zip(t["reason"], t["status"]) if s == "failed"}
    assert len(failed) == 4, failed
    assert any(r.startswith("RuntimeError: injected simulation error") for r in failed)
    assert any(r.startswith("non-finite objectives: F_max=nan") for r in failed)
    assert any(r.startswith("worker process died (exit code 7)") for r in failed)
    assert any(r.startswith("timed out after 3 s") for r in failed)
    assert np.all(np.isnan(t["value"][t["status"] == "failed"]))
    assert np.all(np.isfinite(t["value"][t["status"] == "ok"]))
    for name in t["file"]:
        if name:
            read_evaluation(run / name)


def test_snapshot_plus_replay_equals_full_replay(tmp_path):
    case = write_case(tmp_path, "replay", budget=14, initial=5)
    run = optimise(case, workers=2, runs=tmp_path, evaluator=FAKE, progress=False)
    pb = Problem.from_case(load_case(case))
    events, _, _ = read_journal(run / "journal.jsonl")
    full, _ = restore(pb, events, None)
    snap = RunDir(run).load_state()
    from_snapshot, _ = restore(pb, events, snap)
    assert from_snapshot.state_dict() == full.state_dict()
    # And from a snapshot taken at any earlier point: state after k events, then replay the rest.
    for k in (3, 10, 20, len(events) - 3):
        part, _ = restore(pb, events[:k], None)
        mid = {"seq": k - 1, "mark": line_mark(events[k - 1]), "strategy": part.state_dict()}
        again, _ = restore(pb, events, mid)
        assert again.state_dict() == full.state_dict()


def test_replay_detects_a_journal_the_optimiser_does_not_reproduce(tmp_path):
    case = write_case(tmp_path, "tamper", budget=8, initial=4)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    events, _, _ = read_journal(run / "journal.jsonl")
    asked = next(e for e in events if e["event"] == "asked" and e["id"] == 2)
    asked["x"][0] += 1.0
    with pytest.raises(JournalError, match="optimiser proposes"):
        restore(Problem.from_case(load_case(case)), events, None)


def test_torn_journal_tail_is_dropped(tmp_path):
    path = tmp_path / "journal.jsonl"
    j, events, torn = Journal.open(path)
    assert events == [] and not torn
    j.append("asked", id=0, x=[1.0], phase="initial", restart=0)
    j.append("evaluated", id=0, value=2.0, objectives={"F_max": 2.0})
    j.close()
    with open(path, "ab") as fh:
        fh.write(b'{"seq":2,"event":"ask')
    events, length, torn = read_journal(path)
    assert torn and len(events) == 2
    j, events, torn = Journal.open(path)
    assert torn and path.stat().st_size == length
    j.append("asked", id=1, x=[2.0], phase="initial", restart=0)
    j.append("failed", id=1, reason="x")
    j.close()
    assert [e["seq"] for e in read_journal(path)[0]] == [0, 1, 2, 3]
    # A damaged line that is not the last one is an error, never silently dropped.
    lines = path.read_bytes().split(b"\n")
    lines[1] = b"garbage"
    path.write_bytes(b"\n".join(lines))
    with pytest.raises(JournalError, match="line 2 is damaged"):
        read_journal(path)


def test_resume_rules(tmp_path, capsys):
    case = write_case(tmp_path, "rules", budget=8, initial=4)
    runs = tmp_path / "runs"
    run = optimise(case, workers=1, runs=runs, evaluator=FAKE, progress=False)
    with pytest.raises(UsageError, match="already exists.*lccopt resume"):
        optimise(case, workers=1, runs=runs, evaluator=FAKE)
    with pytest.raises(UsageError, match="no such run directory"):
        resume(tmp_path / "nope")
    with pytest.raises(UsageError, match="--workers must be at least 1"):
        resume(run, workers=0)

    # A second process on the same run is refused while the lock is held.
    holder = RunDir(run)
    holder.lock()
    try:
        with pytest.raises(UsageError, match="in use by another lccopt process"):
            resume(run, evaluator=FAKE)
        with pytest.raises(UsageError, match="in use by another lccopt process"):
            optimise(case, workers=1, runs=runs, force=True, evaluator=FAKE)
    finally:
        holder.unlock()

    # A changed case is refused unless allowed; a larger budget then carries the run on.
    case.write_text(case.read_text().replace("budget: 8", "budget: 11"))
    with pytest.raises(UsageError, match="changed since the run started.*--allow-changed-case"):
        resume(run, evaluator=FAKE)
    resume(run, workers=1, allow_changed_case=True, evaluator=FAKE, progress=False)
    assert len(read_table(run)["id"]) == 11
    case.write_text(case.read_text() + "design:\n  strengthened_sleepers:\n    bounds: [0, 19]\n")
    with pytest.raises(UsageError, match="design.strengthened_sleepers.bounds changed"):
        resume(run, allow_changed_case=True, evaluator=FAKE)

    # --force starts again.
    case2 = write_case(tmp_path, "rules", budget=6, initial=4)
    optimise(case2, workers=1, runs=runs, force=True, evaluator=FAKE, progress=False)
    assert len(read_table(run)["id"]) == 6


def test_case_without_optimisation_section(tmp_path):
    path = tmp_path / "noopt.yaml"
    path.write_text(f"extends: {REFERENCE}\nname: noopt\n")
    with pytest.raises(CaseError, match=r"noopt.yaml:1: optimisation: missing section"):
        optimise(path, runs=tmp_path, evaluator=FAKE)


def test_reference_point_must_be_below_worst(tmp_path):
    case = write_case(tmp_path, "worst", budget=6, initial=3, worst=(1.0, 5.0))
    with pytest.raises(CaseError, match="worst = 1 must exceed the reference point"):
        optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)


def test_multi_objective_runs_use_the_composite_surrogate_and_replay_it(tmp_path):
    """The engine tells each result with its objective vector and sets the ASF as the aggregate;
    the replay of the journal does the same (from the journal's objectives and reference line),
    so without the objectives the replay no longer reproduces the run."""
    from lccopt.engine.replay import Replay
    from lccopt.optim.scalarise import ASF

    case = write_case(tmp_path, "composite", budget=16, initial=5)
    run = optimise(case, workers=2, runs=tmp_path, evaluator=FAKE, progress=False)
    pb = Problem.from_case(load_case(case))
    events, _, _ = read_journal(run / "journal.jsonl")
    strategy, table = restore(pb, events, None)
    assert strategy.settings.composite is True
    ref = next(e for e in events if e["event"] == "reference")
    assert strategy.aggregate == ASF(ref["point"], pb.worst, pb.rho)
    for r in strategy.history:
        if r["status"] == "ok":
            assert r["outputs"] == [table.rows[r["id"]]["objectives"][k] for k in pb.objectives]
    # the same journal told without the objectives: scalar surrogate, other proposals
    blind = pb.strategy(budget=events[0].get("budget", pb.budget))
    rep = Replay(blind, True)
    with pytest.raises(JournalError, match="optimiser proposes"):
        for ev in events:
            rep(ev)
    # the scalar surrogate stays available
    assert pb.strategy(settings=Settings.default()).settings.composite is False
    single = write_case(tmp_path, "single-c", objectives=("F_max",), budget=8, initial=4)
    assert Problem.from_case(load_case(single)).surrogate == "scalar"
    assert Problem.from_case(load_case(single)).strategy().settings.composite is False


def test_e_max_alone_fits_the_sleepers_energies_and_replays_them(tmp_path):
    """E_max alone: the evaluated lines carry the sleepers' energies, the optimiser is told
    them and scores by their max - min; a replay needs them (without: other proposals), and a
    journal that names the scalar surrogate (a run of lccopt before) is carried on with it."""
    from lccopt.engine.replay import Replay
    from lccopt.problem import sleeper_energy_spread

    case = write_case(tmp_path, "energies", objectives=("E_max",), budget=16, initial=5)
    run = optimise(case, workers=2, runs=tmp_path, evaluator=FAKE, progress=False)
    pb = Problem.from_case(load_case(case))
    events, _, _ = read_journal(run / "journal.jsonl")
    assert events[0]["surrogate"] == "sleeper-energies"
    evaluated = [e for e in events if e["event"] == "evaluated"]
    assert len(evaluated) == 16
    for e in evaluated:
        assert len(e["parts"]) == 5
        spread = max(e["parts"]) - min(e["parts"])
        assert spread == pytest.approx(e["objectives"]["E_max"], rel=1e-12)
    strategy, table = restore(pb, events, None)
    assert strategy.settings.composite is True
    assert strategy.aggregate is sleeper_energy_spread
    told = {e["id"]: e["parts"] for e in evaluated}
    for r in strategy.history:
        assert r["status"] == "ok" and r["outputs"] == told[r["id"]]
    stripped = [{k: v for k, v in e.items() if k != "parts"} for e in events]
    with pytest.raises(JournalError, match="optimiser proposes"):
        restore(pb, stripped, None)
    old = [{**events[0], "surrogate": "scalar", "optimiser": 12}]
    assert restore(pb, old, None)[0].settings.composite is False
    # a snapshot restores the aggregate too (it is not part of the state)
    snap = {"seq": events[-1]["seq"], "strategy": strategy.state_dict()}
    again, _ = restore(pb, events, snap)
    assert again.aggregate is sleeper_energy_spread
    assert Replay(again, False, pb).outputs(evaluated[0]) == evaluated[0]["parts"]


def test_changed_worst_values_are_journalled_and_replayed(tmp_path):
    case = write_case(tmp_path, "worst", budget=12, initial=5)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    case.write_text(case.read_text().replace("budget: 12", "budget: 18").replace(
        "worst: [60000.0, 5.0]", "worst: [30000.0, 4.0]"))
    resume(run, workers=2, allow_changed_case=True, evaluator=FAKE, progress=False)
    events, _, _ = read_journal(run / "journal.jsonl")
    changed = next(e for e in events if e["event"] == "case_changed")
    assert changed["worst"] == [30000.0, 4.0] and changed["rho"] == 0.05
    pb = Problem.from_case(load_case(case))
    full, _ = restore(pb, events, None)  # raises if a proposal is not reproduced
    assert full.aggregate.worst == [30000.0, 4.0] and full.n_told == 18
