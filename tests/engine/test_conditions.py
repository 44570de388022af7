"""Traffic conditions (issue 10): the case's conditions list, how objectives combine over
conditions, one task per (design, condition) and a resume that keeps finished conditions."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from lccopt import machine
from lccopt.config import load_case
from lccopt.engine.runner import optimise
from lccopt.errors import CaseError
from lccopt.problem import Problem
from lccopt.store import read_conditions, read_evaluation
from tests.engine import fakesim
from tests.engine.conftest import FAKE, cli, cli_run, optimise_on_local_dask, read_table, write_case

V140 = 38.88888888888889


def conditions_case(tmp_path: Path, conditions: str, *, mode="worst", name="tc", budget=10,
                    objectives=("F_max", "E_max"), worst=(60000.0, 5.0), extra_opt="") -> Path:
    path = write_case(tmp_path, name=name, budget=budget, initial=5, objectives=objectives,
                      worst=worst, extra="conditions:\n" + conditions)
    text = path.read_text().replace("optimisation:\n",
                                    f"optimisation:\n  conditions: {mode}\n{extra_opt}", 1)
    path.write_text(text)
    return path


THREE = """\
  - {name: v140, speed: 38.88888888888889}
  - {name: v80, speed: 22.22222222222222, weight: 2}
  - {name: v160, speed: 44.44444444444444, direction: leave}
"""


def test_conditions_are_read_with_their_vehicle_speed_direction_and_weight(tmp_path):
    case = load_case(conditions_case(tmp_path, THREE))
    assert [c.name for c in case.conditions] == ["v140", "v80", "v160"]
    assert [c.weight for c in case.conditions] == [1.0, 2.0, 1.0]
    one = case.condition_case(2)
    assert one.vehicle["speed"] == pytest.approx(44.44444444444444)
    assert one.simulation["direction"] == "leave"
    assert one.vehicle["wheelset_mass"] == case.vehicle["wheelset_mass"]


@pytest.mark.parametrize("conditions, key, words", [
    ("  - {name: a}\n  - {name: a}\n", "conditions[1].name", "names two conditions"),
    ("  - {name: a, vehicle: tram}\n", "conditions[0].vehicle", "no vehicle 'tram'"),
    ("  - {name: ../x}\n", "conditions[0].name", "letters, digits"),
    ("  - {name: a, direction: sideways}\n", "conditions[0].direction",
     "must be one of enter, leave"),
    ("  - {name: a, weight: 0}\n", "conditions[0].weight", "must be > 0"),
    ("  - {name: a, speed: 1000}\n", "conditions[0].speed", "must be <= 250 km/h"),
    ("  []\n", "conditions", "expected a list"),
])
def test_a_bad_condition_is_one_line_naming_file_line_and_key(tmp_path, conditions, key, words):
    path = conditions_case(tmp_path, conditions)
    with pytest.raises(CaseError) as e:
        load_case(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"{path}:"), msg
    assert f": {key}:" in msg and words in msg, msg


def test_each_mode_needs_a_worst_value_per_objective_or_per_objective_and_condition(tmp_path):
    path = conditions_case(tmp_path, THREE, mode="each", worst=(1.0, 2.0, 3.0))
    with pytest.raises(CaseError, match=r"optimisation\.asf\.worst: expected 2 values .* or 6"):
        load_case(path)
    p = Problem.from_case(load_case(conditions_case(tmp_path, THREE, mode="each")))
    assert p.objectives == ("F_max@v140", "F_max@v80", "F_max@v160",
                            "E_max@v140", "E_max@v80", "E_max@v160")
    assert p.worst == (60000.0,) * 3 + (5.0,) * 3


def test_worst_is_the_largest_and_mean_the_weighted_mean_over_conditions(tmp_path):
    case = load_case(conditions_case(tmp_path, THREE))
    x = case.reference
    per = [fakesim.evaluate(case.condition_case(i), x).objectives for i in range(3)]
    worst = Problem.from_case(case).combine(per)
    mean = Problem.from_case(load_case(conditions_case(tmp_path, THREE, mode="mean"))).combine(per)
    for k in ("F_rms", "F_max", "E_rms", "E_max"):
        v = np.array([o[k] for o in per])
        assert worst[k] == v.max() and len(set(v)) == 3          # the conditions differ
        assert mean[k] == pytest.approx((v[0] + 2 * v[1] + v[2]) / 4, rel=1e-15)
        for name, vi in zip(("v140", "v80", "v160"), v):
            assert worst[f"{k}@{name}"] == vi


@pytest.mark.slow
def test_two_identical_conditions_weigh_as_one_with_the_sum_of_their_weights(tmp_path):
    split = "  - {name: a, speed: 30.0, weight: 0.75}\n  - {name: b, speed: 30.0, weight: 1.5}\n" \
            "  - {name: c, speed: 40.0, weight: 1}\n"
    whole = "  - {name: ab, speed: 30.0, weight: 2.25}\n  - {name: c, speed: 40.0, weight: 1}\n"
    runs = []
    for i, conds in enumerate((split, whole)):
        path = conditions_case(tmp_path, conds, mode="mean", name=f"w{i}", budget=8)
        runs.append(optimise(path, workers=2, runs=tmp_path / "runs", evaluator=FAKE,
                             progress=False))
    a, b = read_table(runs[0]), read_table(runs[1])
    np.testing.assert_array_equal(a["x"], b["x"])   # the same objectives: the same proposals
    for k in ("F_max", "E_max", "value"):
        np.testing.assert_allclose(a[k], b[k], rtol=1e-14, atol=0, err_msg=k)


@pytest.mark.slow
def test_a_run_over_conditions_stores_every_condition_and_its_combination(tmp_path):
    path = conditions_case(tmp_path, THREE, budget=8)
    run = optimise(path, workers=2, runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    case = load_case(path)
    with h5py.File(run / "results.h5") as f:
        assert list(f.attrs["conditions"]) == ["v140", "v80", "v160"]
        assert f.attrs["condition_mode"] == "worst"
        x = f["evaluations/x"][()]
        cols = {c: {k: f[f"conditions/{c}/{k}"][()] for k in ("F_max", "E_max")}
                for c in ("v140", "v80", "v160")}
        fmax = f["evaluations/F_max"][()]
    for i, xi in enumerate(x):
        for j, c in enumerate(("v140", "v80", "v160")):
            direct = fakesim.evaluate(case.condition_case(j), xi).objectives
            assert cols[c]["F_max"][i] == direct["F_max"] and cols[c]["E_max"][i] == direct["E_max"]
        assert fmax[i] == max(cols[c]["F_max"][i] for c in cols)
    files = sorted(p.name for p in (run / "evals").iterdir())
    assert files == [f"{i:06d}.h5" for i in range(8)]            # parts merged and removed
    conds = read_conditions(run / "evals" / "000003.h5")
    assert list(conds) == ["v140", "v80", "v160"]
    assert conds["v80"].objectives["F_max"] == cols["v80"]["F_max"][3]
    # time histories are kept for the reference and the best design only (histories: best)
    best = int(np.argmin(read_table(run)["value"]))
    assert "sleeper_energy" in conds["v160"].histories
    assert ("contact_force" in conds["v160"].histories) == (best == 3)
    for i in (0, best):
        assert "contact_force" in read_conditions(run / "evals" / f"{i:06d}.h5")["v160"].histories
    _, ev = read_evaluation(run / "evals" / "000003.h5")   # the workers' machine, recorded
    assert {k: ev.info[k] for k in machine.describe()} == machine.describe()


@pytest.mark.slow
def test_kill_9_mid_design_keeps_the_finished_conditions_and_resumes_to_the_same_end(tmp_path):
    """A design's conditions run as separate tasks: a kill between them loses none that
    finished, and the resumed run ends exactly as an uninterrupted one."""
    path = conditions_case(tmp_path, THREE, budget=10)
    env = {"LCCOPT_EVALUATOR": FAKE, "LCCOPT_FAKE_DELAY": "0.05",
           "LCCOPT_FAKE_LOG": str(tmp_path / "log")}
    runs = tmp_path / "runs"
    # once 12 simulations are done, the 'leave' condition (v160) hangs: designs stay with
    # some conditions finished and one not, so the kill lands between them every time
    p = cli("optimise", path, "--workers", "2", "--runs", runs,
            env={**env, "LCCOPT_FAKE_STALL": "12"}, start_new_session=True)
    evals = runs / "tc" / "evals"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:   # wait until a design has some conditions but not all
        parts = sorted(evals.glob("*.c0*.h5")) if evals.is_dir() else []
        ids = {q.name[:6] for q in parts}
        if any(sum(q.name.startswith(i) for q in parts) in (1, 2) for i in ids) and \
                len(list(evals.glob("[0-9]" * 6 + ".h5"))) >= 2:
            break
        time.sleep(0.02)
    os.killpg(p.pid, signal.SIGKILL)
    p.communicate(timeout=30)
    kept = sorted(q.name for q in evals.glob("*.c0*.h5"))
    assert kept, "the kill did not land between a design's conditions"
    r = cli_run("resume", runs / "tc", env=env)
    assert r.returncode == 0, r.stderr
    simulated = len((tmp_path / "log").read_text().splitlines())
    # every simulation once, plus at most the ones in flight at the kill (one per worker), plus
    # the best design's conditions again at the end for its time histories (histories: best)
    assert 10 * 3 <= simulated <= 10 * 3 + 2 + 3, simulated
    ref = optimise(path, workers=2, runs=tmp_path / "again", evaluator=FAKE, progress=False)
    a, b = read_table(runs / "tc"), read_table(ref)
    for k in ("x", "F_max", "E_max", "value"):
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_simulate_runs_every_condition_and_prints_their_combination(tmp_path):
    path = conditions_case(tmp_path, THREE, mode="mean")
    r = cli_run("simulate", path, "--no-plots", "--out", tmp_path / "sim")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    rows = {ln.split()[0]: [float(v) for v in ln.split()[1:5]] for ln in lines
            if ln.split() and ln.split()[0] in ("v140", "v80", "v160")}
    mean = next(ln for ln in lines if ln.startswith("weighted mean"))
    fmax = np.array([rows[c][1] for c in ("v140", "v80", "v160")])
    assert float(mean.split()[3]) == pytest.approx((fmax[0] + 2 * fmax[1] + fmax[2]) / 4, rel=1e-4)
    assert max(len(ln) for ln in lines if not ln.startswith(("case ", "histories"))) <= 80
    conds = read_conditions(tmp_path / "sim" / "simulation.h5")
    assert list(conds) == ["v140", "v80", "v160"]
    assert conds["v80"].objectives["F_max"] / 1e3 == pytest.approx(rows["v80"][1], rel=1e-4)
    assert conds["v80"].info["speed"] == pytest.approx(22.22222222222222)


def test_simulate_prints_long_condition_names_whole_and_its_plots_in_one_line(tmp_path):
    """configs/traffic.yaml's names run to 24 characters: cut at 21 its two freight
    conditions read 'freight-100-enter-smo' and '...-rou'; three plot lines a condition were
    42 lines for its 14."""
    names = ("freight-100-enter-smooth", "freight-100-enter-rough")
    path = conditions_case(tmp_path, "".join(f"  - {{name: {n}, speed: 30.0}}\n" for n in names))
    r = cli_run("simulate", path, "--out", tmp_path / "sim")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert [ln.split()[0] for ln in lines if ln.startswith("freight-")] == list(names)
    assert max(len(ln) for ln in lines if not ln.startswith(("case ", "histories"))
               and str(tmp_path) not in ln) <= 80
    plots = [ln for ln in lines if "png" in ln]
    assert plots == ["plots: contact_force.png, sleeper_energy.png, displacement.png"], lines
    assert f"  of each condition, in {tmp_path / 'sim'}/<condition>/" in lines, lines
    for n in names:
        assert sorted(os.listdir(tmp_path / "sim" / n)) == [
            "contact_force.png", "displacement.png", "sleeper_energy.png"]


@pytest.mark.slow
def test_conditions_on_dask_give_the_process_pools_evaluations_and_files(tmp_path):
    pytest.importorskip("distributed")
    path = conditions_case(tmp_path, THREE, budget=8)
    local = read_table(optimise(path, workers=2, runs=tmp_path / "local", evaluator=FAKE,
                                progress=False))
    run = optimise_on_local_dask(path, tmp_path / "dask", FAKE, n_workers=2)
    dask = read_table(run)
    for k in ("x", "F_max", "E_max", "value"):
        np.testing.assert_array_equal(local[k], dask[k], err_msg=k)
    conds = read_conditions(run / dask["file"][0])   # written by the parent from the evaluations
    assert list(conds) == ["v140", "v80", "v160"] and "contact_force" in conds["v80"].histories
    _, ev = read_evaluation(run / dask["file"][2])        # the Dask workers' machine, recorded
    assert {k: ev.info[k] for k in machine.describe()} == machine.describe()
