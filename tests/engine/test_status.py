"""`lccopt status RUN`: where a run stands, safe to call while the run goes."""

from __future__ import annotations

import signal
import time

from lccopt.engine.journal import read_journal
from lccopt.engine.runner import optimise

from .conftest import FAKE, cli, cli_run, write_case

ENV = {"LCCOPT_EVALUATOR": FAKE}


def _n_done(run) -> int:
    try:
        events = read_journal(run / "journal.jsonl")[0]
        return sum(e["event"] in ("evaluated", "failed") for e in events)
    except Exception:  # noqa: BLE001 - not there yet
        return 0


def test_status_of_a_running_a_stopped_and_a_finished_run(tmp_path):
    case = write_case(tmp_path, "s", budget=30, initial=4, seed=2)
    p = cli("optimise", case, "--workers", "2", "--runs", tmp_path / "runs",
            env={**ENV, "LCCOPT_FAKE_DELAY": "0.3"}, start_new_session=True)
    run = tmp_path / "runs" / "s"
    t0 = time.monotonic()
    while _n_done(run) < 6:
        assert time.monotonic() - t0 < 120
        time.sleep(0.05)
    r = cli_run("status", run)
    assert r.returncode == 0, r.stderr
    first = r.stdout.splitlines()[0]
    assert "running" in first and "/30 evaluations" in first, r.stdout
    assert "best #" in r.stdout and "kN" in r.stdout and "MN/m" in r.stdout
    assert "left" in r.stdout and "s of simulation per evaluation" in r.stdout
    assert all(len(line) <= 80 for line in r.stdout.splitlines()[1:]), r.stdout  # [0]: the path
    p.send_signal(signal.SIGINT)
    p.communicate(timeout=120)
    r = cli_run("status", run)
    assert r.returncode == 0 and "stopped" in r.stdout.splitlines()[0], r.stdout
    assert f"lccopt resume {run}" in r.stdout
    done = optimise(write_case(tmp_path, "f", budget=8, initial=4), workers=1,
                    runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    r = cli_run("status", done)
    assert r.returncode == 0 and r.stdout.startswith(f"{done}: finished, 8/8 evaluations"), r.stdout
    r = cli_run("status", tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("lccopt: error: ")
    assert "not an lccopt run" in r.stderr
