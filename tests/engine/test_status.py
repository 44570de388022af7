"""`lccopt status RUN`: where a run stands, safe to call while the run goes."""

from __future__ import annotations

import re
import signal
import time

import pytest

from lccopt.engine.journal import read_journal
from lccopt.engine.runner import optimise

from .conftest import FAKE, cli, cli_run, write_case

# seconds a test: status read while runs go
pytestmark = pytest.mark.slow

ENV = {"LCCOPT_EVALUATOR": FAKE}


def _n_done(run) -> int:
    try:
        events = read_journal(run / "journal.jsonl")[0]
        return sum(e["event"] in ("evaluated", "failed") for e in events)
    except Exception:  # noqa: BLE001 - not there yet
        return 0


def test_status_of_a_running_a_stopped_and_a_finished_run(tmp_path):
    case = write_case(tmp_path, "s", budget=60, initial=4, seed=2)
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
    assert "running" in first and "/60 evaluations" in first, r.stdout
    assert "best #" in r.stdout and "kN" in r.stdout and "MN/m" in r.stdout
    assert "left" in r.stdout and "s of simulation per evaluation" in r.stdout
    assert all(len(line) <= 80 for line in r.stdout.splitlines()[1:]), r.stdout  # [0]: the path
    # two workers: never more than two designs in flight (the one asked ahead waits), read
    # as a user types it, by the run's name from the folder that holds runs/
    seen = []
    for _ in range(5):
        first = cli_run("status", "s", cwd=tmp_path).stdout.splitlines()[0]
        assert first.startswith("runs/s: "), first
        seen += [int(n) for n in re.findall(r"(\d+) in flight", first)]
    assert all(n <= 2 for n in seen), seen
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


def test_status_counts_in_flight_no_more_designs_than_workers(tmp_path):
    """The loop asks one design ahead of the free workers: with 2 workers and 3 designs asked,
    status says 2 in flight and 1 proposed (never '3 in flight')."""
    import json

    from lccopt.engine.rundir import RunDir

    run = optimise(write_case(tmp_path, "w", objectives=("F_max",), budget=6, initial=4),
                   workers=2, runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    events = read_journal(run / "journal.jsonl")[0]
    keep = [e for e in events if e["event"] in ("run", "schedule")]
    keep += [e for e in events if e["event"] == "asked"][:3]
    assert [e["lag"] for e in keep if e["event"] == "schedule"] == [2]
    lines = [json.dumps({**e, "seq": i}) for i, e in enumerate(keep)]
    (run / "journal.jsonl").write_text("\n".join(lines) + "\n")
    holder = RunDir(run)
    holder.lock()          # the run is going (as far as status can tell)
    try:
        r = cli_run("status", run)
    finally:
        holder.unlock()
    first = r.stdout.splitlines()[0]
    assert first.endswith("running, 0/6 evaluations, 2 in flight and 1 proposed"), first
