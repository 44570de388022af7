"""Runs of a case with uncertainty: every design on the same realisations of the track, as
tasks of the worker pool (with traffic conditions: one task per condition and track), robust
objectives, and runs that repeat and resume exactly."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import h5py
import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.engine.runner import optimise
from lccopt.problem import Problem
from lccopt.report.data import fnum
from lccopt.store import read_conditions, read_realisations
from lccopt.uncertainty import statistics as stats
from tests.engine import fakesim
from tests.engine.conftest import (
    FAKE,
    REAL,
    assert_same_evaluations,
    cli,
    cli_run,
    n_done,
    optimise_on_local_dask,
    read_table,
    wait_for,
    write_case,
)

# whole runs with worker processes (the statistics' and units' tests below are quick)
SECTION = """uncertainty:
  realisations: 4
  support_stiffness: {correlation_length: 3 m}
  support_damping: {}
"""


def robust_case(tmp_path: Path, *, name="rb", objectives=("q90(F_max)", "mean(E_max)"),
                budget=10, section=SECTION, extra="") -> Path:
    return write_case(tmp_path, name=name, objectives=objectives, budget=budget, initial=5,
                      worst=(60000.0, 5.0), extra=section + extra)


def realisation_table(run: Path) -> dict:
    with h5py.File(run / "results.h5") as f:
        g = f["realisations"]
        return {"attrs": dict(g.attrs), **{k: g[k][()] for k in g}}


@pytest.mark.slow
def test_same_seed_same_realisations_and_same_table_another_seed_other_tracks(tmp_path):
    path = robust_case(tmp_path)
    a = optimise(path, workers=2, runs=tmp_path / "a", evaluator=FAKE, progress=False)
    b = optimise(path, workers=2, runs=tmp_path / "b", evaluator=FAKE, progress=False)
    ta, tb = read_table(a), read_table(b)
    assert_same_evaluations(ta, tb, ("id", "x", "F_max", "E_max", "q90(F_max)", "mean(E_max)",
                                     "value", "status"))
    ra, rb = realisation_table(a), realisation_table(b)
    assert ra["attrs"]["count"] == 4 and ra["attrs"]["fingerprint"] == rb["attrs"]["fingerprint"]
    np.testing.assert_array_equal(ra["F_max"], rb["F_max"])
    assert ra["F_max"].shape == (10, 4)
    # the statistics are those of the realisations in the table, the plain objective the drawing's
    case = load_case(path)
    for i, x in enumerate(ta["x"]):
        assert ta["q90(F_max)"][i] == np.quantile(ra["F_max"][i], 0.9)
        assert ta["F_max"][i] == fakesim.evaluate(case, x).objectives["F_max"]
        for r in range(4):
            assert ra["F_max"][i, r] == fakesim.evaluate(case.part_case(-1, r), x).objectives[
                "F_max"]
    # every design met the same tracks: the realisations' spread is the same factor for all
    ratio = ra["F_max"] / ta["F_max"][:, None]
    np.testing.assert_allclose(ratio, np.broadcast_to(ratio[0], ratio.shape), rtol=1e-12)
    assert np.ptp(ratio[0]) > 0.01
    other = path.read_text().replace("uncertainty:\n", "uncertainty:\n  seed: 99\n")
    (tmp_path / "other.yaml").write_text(other.replace("name: rb", "name: other"))
    c = optimise(tmp_path / "other.yaml", workers=2, runs=tmp_path / "c", evaluator=FAKE,
                 progress=False)
    rc = realisation_table(c)
    assert rc["attrs"]["fingerprint"] != ra["attrs"]["fingerprint"]
    assert not np.allclose(rc["F_max"][0], ra["F_max"][0])
    files = sorted(p.name for p in (a / "evals").iterdir())
    assert files == [f"{i:06d}.h5" for i in range(10)]            # parts merged and removed
    evs = read_realisations(a / "evals" / "000003.h5")
    assert [e.objectives["F_max"] for e in evs] == list(ra["F_max"][3])
    assert "sleeper_energy" in evs[0].histories and "contact_force" not in evs[0].histories


@pytest.mark.slow
def test_kill_9_mid_design_keeps_the_finished_tracks_and_resumes_to_the_same_end(tmp_path):
    path = robust_case(tmp_path, budget=10)
    env = {"LCCOPT_EVALUATOR": FAKE, "LCCOPT_FAKE_DELAY": "0.05",
           "LCCOPT_FAKE_LOG": str(tmp_path / "log")}
    runs = tmp_path / "runs"
    p = cli("optimise", path, "--workers", "2", "--runs", runs, env=env, start_new_session=True)
    evals = runs / "rb" / "evals"
    wait_for(lambda: n_done(runs / "rb") >= 4 and any(evals.glob("*.r0*.h5")), 120,
             "four designs and a realisation's part on disk")
    os.killpg(p.pid, signal.SIGKILL)
    p.communicate(timeout=30)
    kept = sorted(q.name for q in evals.glob("*.r*.h5"))
    r = cli_run("resume", runs / "rb", env=env)
    assert r.returncode == 0, r.stderr
    simulated = len((tmp_path / "log").read_text().splitlines())
    # every task once (5 per design), plus at most the ones in flight at the kill (one per
    # worker) and the best design's tracks again for its time histories (histories: best)
    assert 10 * 5 <= simulated <= 10 * 5 + 2 + 5, (simulated, kept)
    again = optimise(path, workers=2, runs=tmp_path / "again", evaluator=FAKE, progress=False)
    a, b = read_table(runs / "rb"), read_table(again)
    assert_same_evaluations(a, b, ("id", "x", "F_max", "q90(F_max)", "mean(E_max)", "value"))
    np.testing.assert_array_equal(realisation_table(runs / "rb")["E_max"],
                                  realisation_table(again)["E_max"])


@pytest.mark.slow
def test_a_resume_refuses_realisations_other_than_the_runs(tmp_path):
    path = robust_case(tmp_path, budget=6)
    run = optimise(path, workers=1, runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    journal = (run / "journal.jsonl").read_text().splitlines()
    first = journal[0].replace('"fingerprint":"', '"fingerprint":"00')
    (run / "journal.jsonl").write_text("\n".join([first, *journal[1:]]) + "\n")
    r = cli_run("resume", run, "--budget", "8", env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 2
    assert "realisations of the track drawn now" in r.stderr and "not those the run recorded" \
        in r.stderr


@pytest.mark.slow
def test_p_worse_waits_for_the_reference_design_and_counts_the_tracks_it_loses(tmp_path):
    path = robust_case(tmp_path, objectives=("p_worse(F_max)",), budget=8)
    run = optimise(path, workers=2, runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    t, rt = read_table(run), realisation_table(run)
    assert t["p_worse(F_max)"][0] == 1.0                 # the reference never beats itself
    for i in range(len(t["id"])):
        lost = np.count_nonzero(~(rt["F_max"][i] < rt["F_max"][0])) / 4
        assert t["p_worse(F_max)"][i] == lost == t["value"][i]
    assert min(t["value"]) < 1.0
    # shown against the reference design's 1, not as a relative change (-75 %)
    r = cli_run("resume", run, "--budget", "9", env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0, r.stderr
    t = read_table(run)
    best = f"{min(t['value']):.3g}"
    assert f"p_worse(F_max) {best} (reference design 1)" in r.stdout + r.stderr
    r = cli_run("report", run, "--out", tmp_path / "rep")
    assert r.returncode == 0, r.stderr
    assert f"p_worse(F_max) {best} against 1" in r.stdout and "p_worse(F_max) -" not in r.stdout
    table = (tmp_path / "rep" / "report.md").read_text()
    change = f"{min(t['value']) - 1:+.3g}"
    assert f"| **p_worse(F_max)** | - | 1.0000 | {fnum(min(t['value']))} | {change} |" in table
    assert f"p_worse(F_max) falls from 1.000 to {fnum(min(t['value']), 4)} ({change})" in table
    assert "Minimise **p_worse(F_max)**: probability that max - min of the contact forces in " \
        "the force zone is not below the reference design's, on a realisation of the track [-]." \
        in table


@pytest.mark.slow
def test_conditions_on_each_track_run_as_tasks_and_combine_per_track(tmp_path):
    conds = ("conditions:\n  - {name: v140, speed: 38.88888888888889}\n"
             "  - {name: v160, speed: 44.44444444444444, direction: leave}\n")
    path = robust_case(tmp_path, extra=conds, budget=6,
                       objectives=("q90(F_max)", "q90(E_max)"))
    log = tmp_path / "log"
    os.environ["LCCOPT_FAKE_LOG"] = str(log)
    try:
        run = optimise(path, workers=2, runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    finally:
        del os.environ["LCCOPT_FAKE_LOG"]
    assert len(log.read_text().splitlines()) >= 6 * 2 * 5     # a task per condition and track
    case = load_case(path)
    t, rt = read_table(run), realisation_table(run)
    for i, x in enumerate(t["x"]):
        for r in range(4):
            per = [fakesim.evaluate(case.part_case(c, r), x).objectives for c in (0, 1)]
            assert rt["F_max"][i, r] == max(o["F_max"] for o in per)   # worst over conditions
        assert t["q90(E_max)"][i] == np.quantile(rt["E_max"][i], 0.9)
    assert list(read_conditions(run / "evals" / "000002.h5")) == ["v140", "v160"]
    assert len(read_realisations(run / "evals" / "000002.h5")) == 4


def test_each_condition_gets_its_own_robust_objective(tmp_path):
    conds = ("conditions:\n  - {name: a, speed: 30.0}\n  - {name: b, speed: 40.0}\n")
    path = robust_case(tmp_path, extra=conds, objectives=("q90(F_max)",))
    path.write_text(path.read_text().replace("optimisation:\n",
                                             "optimisation:\n  conditions: each\n", 1)
                    .replace("    worst: [60000.0, 5.0]\n", "").replace("  asf:\n", ""))
    p = Problem.from_case(load_case(path))
    assert p.objectives == ("q90(F_max@a)", "q90(F_max@b)")
    assert p.statistics[:2] == ("q90(F_max@a)", "q90(F_max@b)")
    tracks = [{"F_max": 2.0, "F_max@a": 1.0, "F_max@b": 2.0}]
    assert p.realisation_objectives(tracks) == {"F_max#0": 2.0, "F_max@a#0": 1.0,
                                                "F_max@b#0": 2.0}


@pytest.mark.slow
def test_no_spread_gives_exactly_the_deterministic_objectives(tmp_path):
    """With a coefficient of variation of 0 every realisation is the drawing: the robust run's
    statistics equal the deterministic run's objectives bit for bit, so it proposes the same
    designs."""
    flat = ("uncertainty:\n  realisations: 2\n  support_stiffness: {cov: 0}\n"
            "  pad_stiffness: {cov: 0}\n")
    robust = robust_case(tmp_path, name="flat", objectives=("q90(F_max)", "mean(E_max)"),
                         section=flat, budget=5)
    plain = write_case(tmp_path, name="plain", objectives=("F_max", "E_max"), budget=5,
                       initial=5)
    a = read_table(optimise(robust, workers=2, runs=tmp_path / "r", evaluator=REAL,
                            progress=False))
    b = read_table(optimise(plain, workers=2, runs=tmp_path / "p", evaluator=REAL,
                            progress=False))
    np.testing.assert_array_equal(a["x"], b["x"])
    np.testing.assert_array_equal(a["q90(F_max)"], b["F_max"])
    np.testing.assert_array_equal(a["mean(E_max)"], b["E_max"])
    np.testing.assert_array_equal(a["value"], b["value"])


@pytest.mark.parametrize("name", ["q90(F_max)", "mean(E_max@a)", "p_worse(F_max)"])
def test_a_statistic_has_its_objectives_unit(name):
    from lccopt.vti.response import objective_unit

    expected = {"q90(F_max)": "N", "mean(E_max@a)": "J", "p_worse(F_max)": "-"}[name]
    assert objective_unit(name) == expected
    assert stats.is_statistic(name)


@pytest.mark.slow
def test_robust_runs_print_their_tasks_per_design(tmp_path):
    path = robust_case(tmp_path, budget=5)
    r = cli_run("optimise", path, "--workers", "2", "--runs", tmp_path / "runs",
                env={"LCCOPT_EVALUATOR": FAKE})
    assert r.returncode == 0, r.stderr
    assert "4 realisations and the drawn track per design" in r.stderr
    line = next(ln for ln in r.stdout.splitlines() if "beats the reference design" in ln)
    assert "on the same tracks: F_max on" in line and "of 4 realisations" in line


@pytest.mark.slow
def test_realisations_on_dask_give_the_process_pools_evaluations_and_files(tmp_path):
    pytest.importorskip("distributed")
    path = robust_case(tmp_path, budget=6)
    local = optimise(path, workers=2, runs=tmp_path / "local", evaluator=FAKE, progress=False)
    run = optimise_on_local_dask(path, tmp_path / "dask", FAKE, n_workers=2)
    a, b = read_table(local), read_table(run)
    assert_same_evaluations(a, b, ("id", "x", "F_max", "q90(F_max)", "mean(E_max)", "value"))
    np.testing.assert_array_equal(realisation_table(local)["F_max"],
                                  realisation_table(run)["F_max"])
    evs = read_realisations(run / b["file"][0])     # written by the parent from the evaluations
    assert [e.objectives["F_max"] for e in evs] == list(realisation_table(run)["F_max"][0])


def test_a_best_design_that_is_the_reference_is_not_said_to_beat_it_nowhere(tmp_path):
    """The session's last lines: 'beats the reference design on the same tracks: F_max on
    5 of 8' for a better design; nothing of the kind when the best is the reference (it
    read 'F_max on 0 of 3 realisations', as if the run had found a worse design)."""
    from types import SimpleNamespace

    from lccopt.engine.progress import summary_lines

    case = load_case(robust_case(tmp_path))
    problem = Problem.from_case(case)
    ref = {"q90(F_max)": 2.0, "mean(E_max)": 1.0,
           **{stats.realisation_key(k, r): 1.0 + r for k in ("F_max", "E_max") for r in range(4)}}
    better = {k: v * 0.9 for k, v in ref.items()}
    rd = SimpleNamespace(path=tmp_path, results_path=tmp_path / "results.h5")
    for best_id, objectives, said in ((0, ref, False), (7, better, True)):
        best = {"id": best_id, "phase": "local", "restart": 0, "value": 0.1,
                "x": case.reference, "objectives": objectives}
        table = SimpleNamespace(n_done=8, n_failed=0, best=lambda b=best: b,
                                reference={"objectives": ref}, rows={})
        text = "\n".join(summary_lines(rd, table, case, problem, 1.0, 0.1, 0.1))
        assert ("beats the reference design on the same tracks" in text) == said, text
        if said:
            assert "F_max on 4 of 4 realisations" in text, text
