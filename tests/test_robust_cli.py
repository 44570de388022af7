"""configs/robust.yaml as a user runs it: check, simulate (the reference design's spread),
optimise, status, resume to a larger budget, report (with fewer realisations and a coarser
simulation set on the command line, recorded in the run as any --set)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time

import h5py
import pytest

from lccopt.config import load_case
from lccopt.problem import evaluate
from lccopt.store import read_realisations
from tests.conftest import CONFIGS, lccopt_command, leaves_no_process, subprocess_env

pytestmark = pytest.mark.slow

CHEAP = ["--set", "uncertainty.realisations=3", "--set", "simulation.time_step=1.0e-3",
         "--set", "simulation.run_in=3.0", "--set", "simulation.run_out=1.0",
         "--set", "simulation.far_element_length=0.1"]


def test_check_prints_the_realisations_and_their_cost(run_cli):
    r = run_cli("check", CONFIGS / "robust.yaml")
    assert r.returncode == 0, r.stderr
    assert "uncertainty: 8 realisations of the track (seed 1)" in r.stdout
    assert "support_stiffness: lognormal, cov 0.25, correlation 3 m" in r.stdout
    assert "pad_stiffness: uniform, cov 0.1, independent" in r.stdout
    assert "budget 60: 540 tasks (9 x a deterministic run)" in r.stdout


def test_simulate_shows_the_reference_design_on_every_track(run_cli, tmp_path):
    r = run_cli("simulate", CONFIGS / "robust.yaml", "--out", tmp_path / "sim", *CHEAP)
    assert r.returncode == 0, r.stderr
    rows = {" ".join(line.split()[:2]): line for line in r.stdout.splitlines()}
    for label in ("as drawn", "realisation 0", "realisation 2", "90% quantile", "lowest"):
        assert any(k.startswith(label) for k in rows), (label, r.stdout)
    fmax = [float(rows[f"realisation {i}"].split()[2]) for i in range(3)]
    q90 = float(next(v for k, v in rows.items() if k.startswith("90%")).split()[2])
    assert min(fmax) <= q90 <= max(fmax) and len(set(fmax)) == 3
    assert (tmp_path / "sim" / "robust-spread.png").stat().st_size > 10_000
    evs = read_realisations(tmp_path / "sim" / "simulation.h5")
    assert [e.objectives["F_max"] / 1e3 for e in evs] == pytest.approx(fmax, rel=1e-4)
    # the tracks ran side by side in processes of their own: realisation 2, simulated in this
    # process, gives the same objectives bit for bit
    case = load_case(CONFIGS / "robust.yaml", [v for v in CHEAP if v != "--set"])
    here = evaluate(case.part_case(-1, 2), case.reference).objectives
    assert {k: evs[2].objectives[k] for k in here} == here


def test_simulate_against_a_second_design_on_the_same_tracks(run_cli, tmp_path):
    """--against: the other design's statistics are those it has simulated alone (the same
    tracks), each difference comes with its interval and verdict, the file keeps both, and
    a design against itself is 'not clearly different' by exactly 0."""
    design, other = "x_r1=300 MN/m, x_n=0", "x_r1=540 MN/m"
    r = run_cli("simulate", CONFIGS / "robust.yaml", "--out", tmp_path / "pair", "--no-plots",
                "--design", design, "--against", other, *CHEAP)
    assert r.returncode == 0, r.stderr
    alone = run_cli("simulate", CONFIGS / "robust.yaml", "--out", tmp_path / "alone",
                    "--no-plots", "--design", other, *CHEAP)
    assert alone.returncode == 0, alone.stderr
    text = r.stdout.split("the other design ", 1)[1].split("this design minus", 1)[0]
    stats_of = {line[:16].strip(): line[16:].split() for line in text.splitlines()}
    alone_of = {line[:16].strip(): line[16:].split() for line in alone.stdout.splitlines()}
    for row in ("mean", "90% quantile", "lowest", "highest"):
        assert stats_of[row] == alone_of[row], row
    lines = r.stdout.splitlines()
    at = lines.index("F_max [kN]")
    mean, q90 = lines[at + 1].split(), lines[at + 2].split()
    assert mean[0] == "mean" and q90[:2] == ["90%", "quantile"]
    assert " ".join(q90[-3:]).endswith(("clearly lower", "clearly higher", "not clearly "
                                        "different"))
    block = r.stdout.split("the other design ", 1)[1].split("histories: ")[0]
    assert max(len(line) for line in block.splitlines()) <= 80
    assert "note: 3 realisations make these intervals too narrow" in r.stderr
    again = run_cli("simulate", CONFIGS / "robust.yaml", "--out", tmp_path / "again",
                    "--no-plots", "--design", design, "--against", other, *CHEAP)
    assert again.stdout.split("the other design ", 1)[1].split("histories: ")[0] == block
    with h5py.File(tmp_path / "pair" / "simulation.h5") as f, \
            h5py.File(tmp_path / "alone" / "simulation.h5") as g:
        assert list(f["against/design"][()]) == list(g["design"][()])
        assert dict(f["against/objectives"].attrs) == dict(g["objectives"].attrs)
        assert list(f["design"][()]) != list(g["design"][()])
    r = run_cli("simulate", CONFIGS / "robust.yaml", "--out", tmp_path / "same",
                "--design", other, "--against", other, *CHEAP)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "same" / "robust-spread.png").stat().st_size > 10_000
    diffs = [line.split() for line in r.stdout.splitlines()
             if line.startswith("  mean ") or line.startswith("  90% quantile ")]
    assert diffs and all(d[-3:] == ["not", "clearly", "different"] for d in diffs)
    assert all(float(d[-7 if d[0] == "mean" else -6]) == 0.0 for d in diffs)


@pytest.mark.parametrize("case, args, expected", [
    ("reference.yaml", ["--against", "x_n=3"], "has no uncertainty: section"),
    ("robust.yaml", ["--against", "x_q=3"], "--against: "),
    ("robust.yaml", ["--against", "1,2"], "--against: "),
])
def test_simulate_against_refuses_in_one_line(run_cli, tmp_path, case, args, expected):
    r = run_cli("simulate", CONFIGS / case, "--out", tmp_path / "s", *args)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert expected in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (tmp_path / "s").exists()


def test_optimise_status_resume_and_report(run_cli, tmp_path):
    runs = tmp_path / "runs"
    r = run_cli("optimise", CONFIGS / "robust.yaml", "--runs", runs, "--workers", "2", *CHEAP,
                "--set", "optimisation.budget=6", "--set", "optimisation.initial_points=5")
    assert r.returncode == 0, r.stderr
    assert "3 realisations and the drawn track per design" in r.stderr
    run = runs / "robust"
    r = run_cli("status", run)
    assert r.returncode == 0 and "finished, 6/6 evaluations" in r.stdout, r.stdout
    assert "q90(F_max)" in r.stdout
    assert "tracks: 3 realisations (seed 1) and the drawn track per design" in r.stdout
    r = run_cli("resume", run, "--budget", "8")
    assert r.returncode == 0, r.stderr
    with h5py.File(run / "results.h5") as f:
        assert f["realisations/F_max"].shape == (8, 3)
        assert f["realisations"].attrs["count"] == 3
        assert list(f["evaluations/q90(F_max)"][()]) != list(f["evaluations/F_max"][()])
    r = run_cli("report", run)
    assert r.returncode == 0, r.stderr
    report = (run / "report" / "report.md").read_text()
    assert "## Over the realisations of the track" in report
    assert "beats the reference on" in report
    assert "--against \"<the nominal optimum>\"" in report
    # what varied, as check words it, without the cost lines
    assert "pad_stiffness: uniform, cov 0.1, independent. On each track" in report
    assert (run / "report" / "robust-spread.png").stat().st_size > 10_000
    summary = json.loads((run / "report" / "summary.json").read_text())
    assert "reference" in summary["realisations"]
    ref = summary["realisations"]["reference"]["F_max"]
    assert ref["tracks"] == 3 and ref["drawn"] > 0


def test_ctrl_c_while_the_tracks_run_side_by_side_leaves_nothing(tmp_path):
    """Ctrl-C to the process group (as a terminal sends it) while the tracks run in processes
    of their own: exit 130 with one line, no file in --out, no process left behind."""
    out, said = tmp_path / "sim", tmp_path / "stderr"
    with open(said, "w") as err:
        p = subprocess.Popen(lccopt_command() + ["simulate", str(CONFIGS / "robust.yaml"),
                                                 "--out", str(out), *CHEAP],
                             stdout=subprocess.DEVNULL, stderr=err, start_new_session=True,
                             env=subprocess_env(LCCOPT_EVALUATOR="tests.engine.fakesim:evaluate",
                                                LCCOPT_FAKE_DELAY="60"))
    with leaves_no_process(p.pid):
        t0 = time.monotonic()
        while "simulating 4 tracks in" not in said.read_text():
            assert p.poll() is None and time.monotonic() - t0 < 60, said.read_text()
            time.sleep(0.05)
        time.sleep(1.0)                              # the processes started, simulating
        os.killpg(p.pid, signal.SIGINT)
        p.wait(timeout=30)
        text = said.read_text()
        assert p.returncode == 130 and text.strip().endswith("lccopt: interrupted by SIGINT"), text
        assert "Traceback" not in text
        assert not out.exists() or os.listdir(out) == []
