"""A settlement case through the command line as a user runs it: check, simulate, optimise,
status, report, and a run killed with kill -9 and resumed, which ends as the uninterrupted
run ends. A coarse, short case (1 ms steps, 0.1 m elements, 2 x 10^5 axle passes, 8 settling
sleepers, at most 4 simulations): a few seconds a design."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.degradation.variants import law_variants
from lccopt.engine.journal import read_journal
from lccopt.report.law_variants import _objectives
from tests.conftest import CONFIGS, lccopt_command

# seconds a test: settlement runs through the command line
pytestmark = pytest.mark.slow

BOGIE = (CONFIGS / "vehicles" / "virm-bogie.yaml").as_posix()
SETTLEMENT = ("level_d1_max", "level_d1_std", "rail_step", "rail_angle",
              "differential_settlement", "max_settlement", "max_void", "level_std",
              "force_growth", "maintenance_rate", "interventions", "years_to_limit")


def write_settlement_case(directory: Path, name: str = "s", budget: int = 8) -> Path:
    p = Path(directory) / f"{name}.yaml"
    p.write_text(f"""extends: {BOGIE}
name: {name}
simulation: {{time_step: 1.0e-3, element_length: 0.1, far_element_length: 0.6, run_in: 2.0,
             run_out: 1.0}}
degradation:
  passages_per_year: 5.0e5
  horizon_axle_passes: 2.0e5
  settling_sleepers: 8
  tolerance: 4 kN
  max_simulations: 4
  limit: {{measure: level_d1_max, value: 1 mm}}
  tamping: {{unreachable_sleepers: 2, min_interval: 0.05}}
optimisation:
  objectives: [level_d1_max, interventions]
  budget: {budget}
  initial_points: 5
  seed: 2
  timeout: 120
""", encoding="utf-8")
    return p


def cli(*args, cwd, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(lccopt_command() + [str(a) for a in args], cwd=cwd, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "MPLBACKEND": "Agg"}, **kw)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One finished run of the settlement case: two workers, then its report."""
    base = tmp_path_factory.mktemp("settlement")
    case = write_settlement_case(base)
    r = cli("optimise", case, "--workers", 2, cwd=base)
    assert r.returncode == 0, r.stderr[-3000:]
    rep = cli("report", base / "runs" / "s", cwd=base)
    assert rep.returncode == 0, rep.stderr[-3000:]
    return base, case, r, rep


def test_check_and_simulate_say_what_the_prediction_does(tmp_path):
    case = write_settlement_case(tmp_path)
    r = cli("check", case, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "horizon 0.2 years = 200,000 axle passes; 8 settling sleepers" in r.stdout
    r = cli("simulate", case, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert all(len(line) <= 80 for line in out.splitlines()[1:]), out
    for k in SETTLEMENT:
        assert f"\n  {k} " in out, k
    assert "settlement after 0.2 years" in out and " mm " in out
    assert "(the law's values, not a forecast: not calibrated to a measured crossing)" in out
    assert re.search(r"\n  tamped [1-9]\d* time\(s\): after 0\.05", out), out
    # 4 simulations for a tamped track: budget-bound, and said so in lines that fit
    note = " ".join(r.stderr.split("note: ")[1].split())
    assert note.startswith("the prediction used all 4 simulations it may "
                           "(degradation.max_simulations) and spread them wider than the 4 kN "
                           "tolerance asks"), r.stderr
    assert all(len(line) <= 80 for line in r.stderr.splitlines()), r.stderr
    sim = tmp_path / "runs" / "s-simulate"
    for png in ("contact_force", "sleeper_energy", "displacement", "settlement-history",
                "settlement-profile"):
        assert (sim / f"{png}.png").stat().st_size > 10_000, png
    with h5py.File(sim / "simulation.h5", "r") as f:
        d = f["objectives"].attrs["differential_settlement"]
        s = f["histories/settlement_sleepers"][()]
        assert f["objectives"].attrs["differential_settlement_unit"] == "m"
        assert s.shape[1] == 8 and d == pytest.approx(np.ptp(s[-1]))
        assert f["histories/settlement_axle_passes"][-1] == pytest.approx(2.0e5)


def test_results_h5_carries_every_objective_with_its_unit(run):
    base, _, r, _ = run
    path = base / "runs" / "s"
    events = read_journal(path / "journal.jsonl")[0]
    done = {e["id"]: e["objectives"] for e in events if e["event"] == "evaluated"}
    assert len(done) == 8
    with h5py.File(path / "results.h5", "r") as f:
        columns = list(f.attrs["objective_columns"].astype(str)) if hasattr(
            f.attrs["objective_columns"], "astype") else list(f.attrs["objective_columns"])
        # the paper's four, the case's objectives, then the others as they came
        assert columns == ["F_rms", "F_max", "E_rms", "E_max", "level_d1_max", "interventions",
                           *(k for k in SETTLEMENT if k not in ("level_d1_max",
                                                                 "interventions"))]
        e = f["evaluations"]
        ids = e["id"][()]
        for k in columns:
            np.testing.assert_array_equal(e[k][()], [done[i][k] for i in ids], err_msg=k)
        assert e["max_void"].attrs["unit"] == "m" and e["F_max"].attrs["unit"] == "N"
        assert e["maintenance_rate"].attrs["unit"] == "1/year"
        assert e["level_d1_max"].attrs["unit"] == "m" and e["rail_step"].attrs["unit"] == "m"
        assert e["rail_angle"].attrs["unit"] == "m/m"
        assert e["interventions"].attrs["unit"] == "-"
        assert list(f.attrs["objectives"]) == ["level_d1_max", "interventions"]
        assert np.all(e["interventions"][()] >= 1)        # every design tamped
    assert "level_d1_max" in r.stdout and " mm " in r.stdout


def test_every_design_keeps_its_settlement_histories(run):
    """optimisation.histories: best keeps the time histories of the reference and the best
    design only, but every design's settlement histories (a few tens of kB)."""
    base = run[0]
    files = sorted((base / "runs" / "s" / "evals").glob("*.h5"))
    assert len(files) == 8
    with_time = []
    for p in files:
        with h5py.File(p, "r") as f:
            h = f["histories"]
            assert "settlement_sleepers" in h and "settlement_void" in h, p.name
            if "contact_force" in h:
                with_time.append(p.name)
    best = json.loads((base / "runs" / "s" / "report" / "summary.json").read_text())["best"]["id"]
    assert set(with_time) == {"000000.h5", f"{best:06d}.h5"}


def test_status_and_report_speak_settlement(run):
    base = run[0]
    r = cli("status", base / "runs" / "s", cwd=base)
    assert r.returncode == 0, r.stderr
    assert "finished, 8/8 evaluations" in r.stdout and "level_d1_max" in r.stdout
    rep = base / "runs" / "s" / "report"
    for png in ("settlement-history", "settlement-profile", "objective-space",
                "best-vs-reference", "contact-force"):
        assert (rep / f"{png}.png").stat().st_size > 10_000, png
    md = (rep / "report.md").read_text()
    assert "## Settlement over the horizon" in md
    assert "**maintenance_rate**: 1 / years_to_limit" in md
    assert "the limit: level_d1_max reaching 1 mm" in md
    assert "| **level_d1_max** | mm |" in md
    assert "The track is tamped whenever the limit is reached" in md
    assert re.search(r"tamped \d+ times over the horizon, each when level_d1_max reached "
                     r"[\d.]+ mm \(after ", md), md
    # a tamped track's state measures are said to be its worst over the horizon
    assert "each measure of it is its worst over the horizon" in md
    assert "over the approach and the ERS at its worst over the horizon" in md
    assert "the law's values, not a forecast" in md
    # the traffic in the words check uses, not a condition's name and a rate
    assert ("of the traffic (500,000 bogie passages a year (2 axles each), axle load 174 kN; "
            "1 million axle passes, about 17.8 million gross tonnes a year)") in md, md
    # the best design re-predicted under the law's uncertainty, said and tabled
    assert "### Rankings and the law's uncertainty" in md
    assert re.search(r"the best design beats the reference design in level_d1_max and "
                     r"interventions in \d of 8", md), md
    assert ("within the model's uncertainty" in md) == s_within(rep)
    # the first report said what it runs, and how long to expect when a minute or more
    said = " ".join(run[3].stderr.split())
    assert "predicting the best and the reference design under 8 variants of the law (16 " \
           "predictions in" in said, said
    with h5py.File(base / "runs" / "s" / "results.h5") as f:
        walls = f["evaluations/wall_time"][()]
    procs = int(said.split("predictions in ")[1].split()[0])
    assert ("at the run's" in said) == (np.median(walls) * -(-16 // procs) >= 60), said
    t0 = time.monotonic()                     # a second report reads the kept predictions
    again = cli("report", base / "runs" / "s", cwd=base)
    assert again.returncode == 0 and "predicting the best" not in again.stderr, again.stderr
    assert time.monotonic() - t0 < 60
    for label in ("alpha -30 %", "1 - beta +30 %", "gamma +30 %", "passage reading",
                  "logarithmic law (matched)"):
        assert f"| {label} |" in md, label
    s = json.loads((rep / "summary.json").read_text())
    assert set(SETTLEMENT) <= set(s["best"]["objectives"])
    assert s["figures"]["settlement-profile"] == "settlement-profile.png"


def test_the_law_check_in_processes_is_what_one_process_predicts(run):
    """The report's 16 predictions run side by side in processes of their own: the first
    variant's, for the reference design, is what this process predicts, bit for bit."""
    base, case_path, _, _ = run
    kept = json.loads((base / "runs" / "s" / "report" / "law-variants.json").read_text())
    case = load_case(case_path)
    label, variant = law_variants(case.degradation_spec())[0]
    with h5py.File(base / "runs" / "s" / "results.h5", "r") as f:
        e = f["evaluations"]
        x = e["x"][()][list(e["id"][()]).index(0)]     # #0, the reference design
    assert kept["variants"][0]["label"] == label
    assert kept["variants"][0]["reference"] == _objectives(variant, case.track_design(x))


def s_within(rep: Path) -> bool:
    """Whether summary.json's law check says "within the model's uncertainty" (checked to
    be: the best beats the reference in at most half of the 8 variants)."""
    check = json.loads((rep / "summary.json").read_text())["law_check"]
    assert check["n"] == 8 and 0 <= check["beats"] <= 8
    assert check["within_uncertainty"] == (check["beats"] <= 4)
    return check["within_uncertainty"]


def _n_done(run: Path) -> int:
    try:
        return sum(e["event"] in ("evaluated", "failed")
                   for e in read_journal(run / "journal.jsonl")[0])
    except Exception:  # noqa: BLE001 - being written
        return 0


def _table(run: Path) -> dict:
    with h5py.File(run / "results.h5", "r") as f:
        e = f["evaluations"]
        return {k: e[k][()] for k in ("id", "x", "value", "differential_settlement", "F_max",
                                      "max_void", "years_to_limit", "level_d1_max",
                                      "interventions", "rail_step")}


def test_a_settlement_run_killed_mid_run_resumes_to_the_uninterrupted_end(tmp_path, run):
    base = run[0]
    reference = _table(base / "runs" / "s")
    case = write_settlement_case(tmp_path)
    path = tmp_path / "runs" / "s"
    p = subprocess.Popen(lccopt_command() + ["optimise", str(case), "--workers", "2"],
                         cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         start_new_session=True, env={**os.environ, "MPLBACKEND": "Agg"})
    t0 = time.monotonic()
    while _n_done(path) < 3 and p.poll() is None:
        assert time.monotonic() - t0 < 300, "the run did not get going"
        time.sleep(0.05)
    assert p.poll() is None, "finished before it could be killed"
    os.kill(p.pid, signal.SIGKILL)             # the lccopt process only: workers die with it
    p.communicate(timeout=60)
    assert _n_done(path) < 8
    r = cli("resume", path, "--workers", 2, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    got = _table(path)
    for k, v in reference.items():
        np.testing.assert_array_equal(got[k], v, err_msg=k)


def test_the_papers_three_dof_vehicle_is_refused_in_one_line(tmp_path):
    """The paper's vehicle under a settlement prediction: exit 2, one line naming the file,
    the line and the key to change, and what to use instead; nothing is written."""
    case = tmp_path / "d3.yaml"
    case.write_text(f"extends: {(CONFIGS / 'reference.yaml').as_posix()}\nname: d3\n"
                    "degradation: {passages_per_year: 5.0e5}\n", encoding="utf-8")
    for command in ("check", "optimise"):
        r = cli(command, case, cwd=tmp_path)
        assert r.returncode == 2, r.stderr
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
        assert re.search(r"reference\.yaml:\d+: vehicle\.type: the paper's three-dof vehicle "
                         r"cannot carry a settlement prediction", lines[0]), lines[0]
        assert "use type: bogie or half-car" in lines[0]
    assert not (tmp_path / "runs").exists()


def test_a_settlement_objective_alone_is_what_the_run_minimises(tmp_path):
    """max_void alone: a single-objective run whose value column is each design's largest
    void, and whose best design is the one with the smallest. Untamped (half the cost)."""
    case = write_settlement_case(tmp_path, name="v", budget=6)
    text = case.read_text().replace("[level_d1_max, interventions]", "[max_void]")
    text = text.replace("  tamping: {unreachable_sleepers: 2, min_interval: 0.05}\n", "")
    assert "tamping" not in text
    case.write_text(text.replace("initial_points: 5", "initial_points: 4"), encoding="utf-8")
    r = cli("optimise", case, "--workers", 1, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    with h5py.File(tmp_path / "runs" / "v" / "results.h5", "r") as f:
        e = f["evaluations"]
        void, value = e["max_void"][()], e["value"][()]
        assert list(f.attrs["objectives"]) == ["max_void"] and len(void) == 6
        np.testing.assert_array_equal(value, void)
        assert np.all(void > 0) and np.ptp(void) > 1e-5     # the designs differ
    r = cli("status", tmp_path / "runs" / "v", cwd=tmp_path)
    assert r.returncode == 0 and "max_void" in r.stdout, r.stdout + r.stderr


def test_settlement_history_keeps_its_labels_clear_of_the_legend_and_the_limit(run, monkeypatch,
                                                                               tmp_path):
    """The time marks (1 day, 1 week, ...) are labelled on an axis of their own above the lower
    panel, and its legend sits below it: no label runs into the legend, the curves or the
    limit line (measured on the drawn figure, in pixels)."""
    from lccopt.report import settlement, write_report
    from lccopt.report.law_variants import CHECK_FILE

    figs = {}

    def keep(fig, path):
        fig.canvas.draw()
        figs[path.stem] = fig     # a staged file of the report (lccopt.outdir.Place)
        return path

    monkeypatch.setattr(settlement, "_save", keep)
    # the law check's predictions as the run's report kept them: read back, not predicted anew
    (tmp_path / "rep").mkdir()
    kept = run[0] / "runs" / "s" / "report" / CHECK_FILE
    (tmp_path / "rep" / CHECK_FILE).write_bytes(kept.read_bytes())
    said = []
    write_report(run[0] / "runs" / "s", "md", tmp_path / "rep", True,
                 echo=lambda text, err=False: said.append(text))
    assert not any("predicting" in text for text in said), said
    fig = figs["settlement-history"]
    lower = [ax for ax in fig.axes if ax.get_ylabel() == "[mm]"][0]
    assert not lower.texts                     # nothing written inside the panel
    inside = lower.get_window_extent()
    labels = [t for ax in fig.axes if ax is not lower and ax.bbox.bounds == lower.bbox.bounds
              for t in ax.get_xticklabels() if t.get_text()]
    labels += [t for child in lower.child_axes for t in child.get_xticklabels() if t.get_text()]
    texts = [t.get_text() for t in labels]
    assert {"1 day", "1 week", "1 month"} <= set(texts), texts
    boxes = [t.get_window_extent() for t in labels]
    assert all(b.y0 >= inside.y1 - 1 for b in boxes), "a time label inside the panel"
    legend = lower.get_legend().get_window_extent()
    assert legend.y1 <= inside.y0, "the legend overlaps the panel"
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:]), texts


@pytest.mark.parametrize("body, line, key", [
    ("degradation: {trains_per_day: 30}\n", 3, "degradation.trains_per_day"),
    ("degradation: {trains_per_day: 30, vehicles_per_train: 4,\n"
     "              tamping: {unreachable_sleepers: 25}}\n", 4,
     "degradation.tamping.unreachable_sleepers"),
    ("degradation: {trains_per_day: 30, vehicles_per_train: 4,\n"
     "              tamping: {min_interval: 0 year}}\n", 4, "degradation.tamping.min_interval"),
    ("degradation: {trains_per_day: 30, vehicles_per_train: 4, subgrade: {depth: 0}}\n", 3,
     "degradation.subgrade.depth"),
    ("degradation: {trains_per_day: 30, vehicles_per_train: 4}\n"
     "track: {sleeper: {bearing_area: 0 m^2}}\n", 4, "track.sleeper.bearing_area"),
])
def test_bad_traffic_tamping_and_subgrade_are_one_line_exit_2(tmp_path, body, line, key):
    """What a user gets wrong most (a train without its length, a tamping that reaches no
    sleeper or comes at no interval, a subgrade at no depth, a sleeper on no area): exit 2,
    one line naming the file, line and key."""
    case = tmp_path / "bad.yaml"
    case.write_text(f"extends: {BOGIE}\nname: bad\n{body}", encoding="utf-8")
    r = cli("check", case, cwd=tmp_path)
    assert r.returncode == 2, r.stdout + r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert re.search(rf"{re.escape(str(case))}:{line}: {re.escape(key)}: ", lines[0]), lines[0]
