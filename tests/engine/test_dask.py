"""The Dask executor on a local cluster gives the same evaluations as the local process pool."""

from __future__ import annotations

import io
import os
import signal

import pytest

from lccopt.engine.runner import optimise
from lccopt.store import read_evaluation

from .conftest import (
    FAKE,
    FAULTY,
    assert_same_evaluations,
    optimise_on_local_dask,
    read_table,
    write_case,
)

# seconds a test: Dask schedulers and workers
pytestmark = pytest.mark.slow


def test_dask_local_cluster_same_evaluations_as_process_pool(tmp_path):
    pytest.importorskip("distributed")
    case = write_case(tmp_path, "dk", budget=10, initial=5, seed=3)
    local = read_table(optimise(case, workers=1, runs=tmp_path / "local", evaluator=FAKE,
                                progress=False))
    run = optimise_on_local_dask(case, tmp_path / "dask", FAKE)
    dask = read_table(run)
    assert_same_evaluations(local, dask)
    assert all(w.startswith("tcp://") for w in dask["worker"])
    for name in dask["file"]:  # written by the workers, which see the run directory here
        read_evaluation(run / name)
    assert not list((run / "evals").glob("*.tmp")), "the probe file is removed at the end"


def test_dask_runs_the_real_simulator_like_the_process_pool(tmp_path):
    """The real simulator on Dask workers (case pickled to them, files written by the parent)
    gives the pool's objectives. The initial design only: its points do not depend on values,
    and the last bits of a simulation may differ between processes (see the README)."""
    import numpy as np

    from .conftest import REAL

    pytest.importorskip("distributed")
    case = write_case(tmp_path, "dr", budget=4, initial=4, seed=5)
    local = read_table(optimise(case, workers=1, runs=tmp_path / "local", evaluator=REAL,
                                progress=False))
    run = optimise_on_local_dask(case, tmp_path / "dask", REAL)
    dask = read_table(run)
    assert list(dask["status"]) == ["ok"] * 4
    np.testing.assert_array_equal(local["x"], dask["x"])
    for k in ("F_rms", "F_max", "E_rms", "E_max", "value"):
        np.testing.assert_allclose(dask[k], local[k], rtol=1e-9, err_msg=k)
    for i, name in zip(dask["id"], dask["file"]):   # time histories: the reference's and the best's
        x, ev = read_evaluation(run / name)
        keeps = i == 0 or i == dask["id"][np.argmin(dask["value"])]
        assert ("contact_force" in ev.histories) == keeps and "sleeper_energy" in ev.histories
        if keeps:
            assert len(ev.histories["contact_force"]) > 100


def test_a_dask_worker_writes_the_file_only_where_it_sees_the_run_directory(tmp_path):
    """dask_task as a worker runs it: with the run's probe file there (same content) it
    writes the evaluation file and returns no evaluation; with a probe it cannot read, or of
    other content (another machine's directory of the same name), it writes nothing and
    returns the evaluation for the lccopt process to write."""
    from lccopt.config import load_case
    from lccopt.engine import dask_task
    from lccopt.engine.worker import Task
    from lccopt.problem import Problem

    case = load_case(write_case(tmp_path, "probe", budget=4, initial=4, seed=1))
    evals = tmp_path / "evals"
    evals.mkdir()
    _, probe = dask_task.write_probe(evals)
    assert probe[0].endswith(".tmp") and open(probe[0]).read() == probe[1]
    x = list(Problem.from_case(case).reference)
    here = dask_task.dask_task(case, Task(0, x, out_path=str(evals / "000000.h5")), FAKE, probe)
    assert here.error is None and here.file_written and here.evaluation is None
    assert read_evaluation(evals / "000000.h5")[1].objectives == here.objectives
    for other in [(probe[0], "0" * 32), (str(tmp_path / "nowhere.tmp"), probe[1])]:
        away = dask_task.dask_task(case, Task(1, x, out_path=str(evals / "000001.h5")), FAKE, other)
        assert away.error is None and not away.file_written and away.evaluation is not None
        assert not (evals / "000001.h5").exists()


def test_a_real_scheduler_with_eight_worker_processes_runs_an_optimisation(tmp_path):
    """As on a cluster: `dask scheduler` and `dask worker ADDRESS --nworkers 8 --nthreads 1`
    as processes of their own, then `lccopt optimise CASE --scheduler ADDRESS` as a user runs
    it. Eight workers (proposals_per_fit 8) give a lag and a block of eight, every worker
    takes part, and the run's evaluations are those of the local pool with eight workers (the
    same schedule)."""
    import json
    import os
    import subprocess
    import sys
    import time

    import numpy as np

    distributed = pytest.importorskip("distributed")
    from lccopt.engine.journal import read_journal

    from .conftest import REPO, cli_run

    env = {**os.environ, "PYTHONPATH": str(REPO), "LCCOPT_FAKE_DELAY": "0.05"}
    sfile = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                               "--port", "0", "--no-dashboard", "--scheduler-file", str(sfile)],
                              env=env, cwd=tmp_path, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        deadline = time.monotonic() + 60
        while not sfile.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(0.2)  # written whole
        address = json.loads(sfile.read_text())["address"]
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                       "--nworkers", "8", "--nthreads", "1", "--no-dashboard",
                                       "--memory-limit", "0"], env=env, cwd=tmp_path,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        with distributed.Client(address, timeout="20s") as client:
            client.wait_for_workers(8, timeout=90)  # the lag is the worker threads at the start
        case = write_case(tmp_path, "cluster", budget=32, initial=8, seed=9, per_fit=8)
        r = cli_run("optimise", case, "--scheduler", address, "--runs", tmp_path / "dask",
                    env={"LCCOPT_EVALUATOR": FAKE, "LCCOPT_FAKE_DELAY": "0.05"}, timeout=120)
        assert r.returncode == 0, r.stderr
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    run = tmp_path / "dask" / "cluster"
    table = read_table(run)
    assert list(table["id"]) == list(range(32)) and set(table["status"]) == {"ok"}
    assert len(set(table["worker"])) == 8 and all(w.startswith("tcp://") for w in table["worker"])
    events = read_journal(run / "journal.jsonl")[0]
    assert [(e["lag"], e["batch"]) for e in events if e["event"] == "schedule"] == [(8, 8)]
    assert "8 worker threads" in next(e for e in events if e["event"] == "session")["executor"]
    for name in table["file"]:
        read_evaluation(run / name)
    local = read_table(optimise(case, workers=8, runs=tmp_path / "local", evaluator=FAKE,
                                progress=False))
    assert_same_evaluations(local, table)
    assert np.isfinite(table["value"]).all()


# ------------------------------------------------------------------------ a cluster that dies

class _Cluster:
    """`dask scheduler` on 127.0.0.1 at a free port and `dask worker --nworkers 2 --nthreads 1`,
    as processes of their own (what a cluster's operator starts, and kills)."""

    def __init__(self, env: dict, cwd):
        import socket

        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = s.getsockname()[1]
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.env, self.cwd = env, cwd
        self.scheduler = self.workers = None

    def _popen(self, module: str, *args):
        import subprocess
        import sys

        return subprocess.Popen([sys.executable, "-m", module, *args], env=self.env, cwd=self.cwd,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def start(self) -> "_Cluster":
        import importlib

        import distributed

        self.scheduler = self._popen("distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                     "--port", str(self.port), "--no-dashboard")
        self.workers = self._popen("distributed.cli.dask_worker", self.address, "--nworkers", "2",
                                   "--nthreads", "1", "--no-dashboard", "--memory-limit", "0")
        with distributed.Client(self.address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
            # a worker's first evaluation imports lccopt (about a second): done before a test's
            # short timeouts start
            for module in ("tests.engine.fakesim", "lccopt.engine.dask_task", "lccopt.store"):
                client.run(importlib.import_module, module)
        return self

    def running(self) -> "_Cluster":
        """Started again if a test left it stopped or frozen."""
        if self.scheduler is not None and self.scheduler.poll() is None:
            os.kill(self.scheduler.pid, signal.SIGCONT)
        if any(p is None or p.poll() is not None for p in (self.scheduler, self.workers)):
            self.stop()
            self.start()
        return self

    def kill_scheduler(self, sig=None) -> None:
        """kill -9 (or ``sig``: SIGTERM is the scheduler's orderly close)."""
        if sig is None:
            self.scheduler.kill()
        else:
            self.scheduler.send_signal(sig)
        self.scheduler.wait()

    def stop(self) -> None:
        import subprocess

        for p in (self.workers, self.scheduler):
            if p is not None and p.poll() is None:
                p.terminate()
                try:
                    p.wait(30)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """One cluster for the tests that stop, kill and freeze it (a start costs seconds); its
    workers' evaluator ``FAULTY`` hangs once, for 6 s."""
    pytest.importorskip("distributed")
    from .conftest import REPO

    where = tmp_path_factory.mktemp("cluster")
    (where / "faults").mkdir()
    env = {**os.environ, "PYTHONPATH": str(REPO), "LCCOPT_EVALUATOR": FAKE,
           "LCCOPT_FAKE_DELAY": "0.3", "LCCOPT_TEST_FAULTS": "hang",
           "LCCOPT_TEST_FAULT_DIR": str(where / "faults"), "LCCOPT_TEST_HANG": "6"}
    c = _Cluster(env, where)
    c.faults = where / "faults"
    try:
        yield c.start()
    finally:
        c.running()
        c.stop()


def test_a_scheduler_killed_mid_run_is_an_environment_fault_never_a_failed_design(
        tmp_path, monkeypatch, cluster):
    """The Dask scheduler stopped (SIGTERM) or killed (kill -9) while evaluations run: nothing
    in flight fails and no budget is spent. Brought back (scheduler and workers restarted after
    a SIGTERM), the run carries on by
    itself; never back, the run stops with exit 2 and one line after its wait, and a resume on
    a new cluster ends it. Both tables are the uninterrupted run's (the local pool with as
    many workers)."""
    import threading
    import time

    from lccopt.engine import dask_executor
    from lccopt.errors import UsageError

    from .conftest import cli, cli_run, journal_events, n_done, wait_for

    case = write_case(tmp_path, "lost", budget=12, initial=4, seed=6)
    reference = read_table(optimise(case, workers=2, runs=tmp_path / "local", evaluator=FAKE,
                                    progress=False))
    cluster.running()
    try:
        # brought back: the run waits, saying so, and carries on
        p = cli("optimise", case, "--scheduler", cluster.address, "--runs", tmp_path / "back",
                env={"LCCOPT_EVALUATOR": FAKE})
        run = tmp_path / "back" / "lost"
        wait_for(lambda: n_done(run) >= 4)
        cluster.kill_scheduler(signal.SIGTERM)
        cluster.stop()
        time.sleep(1.0)
        cluster.start()
        out, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
        assert "lost the connection to the Dask scheduler" in err and "FAILED" not in err, err
        assert "Traceback" not in err and " ERROR " not in err, err
        assert_same_evaluations(reference, read_table(run))

        # never back: exit 2 after the wait (shortened here), nothing failed, then a resume
        monkeypatch.setattr(dask_executor, "RECONNECT_TIMEOUT", 3.0)
        gone = tmp_path / "gone" / "lost"
        monkeypatch.setenv("LCCOPT_FAKE_DELAY", "0.3")

        def kill_when_going():
            wait_for(lambda: n_done(gone) >= 4)
            cluster.kill_scheduler()

        killer = threading.Thread(target=kill_when_going, daemon=True)
        killer.start()
        with pytest.raises(UsageError, match="did not come back within 3 s; the run stopped "
                                             "with nothing lost"):
            optimise(case, scheduler=cluster.address, runs=tmp_path / "gone", evaluator=FAKE,
                     progress=False)
        killer.join(60)
        assert not [e for e in journal_events(gone) if e["event"] == "failed"]
        cluster.stop()
        cluster.start()
        r = cli_run("resume", gone, "--scheduler", cluster.address,
                    env={"LCCOPT_EVALUATOR": FAKE}, timeout=300)
        assert r.returncode == 0, r.stderr
        assert_same_evaluations(reference, read_table(gone))
    finally:
        cluster.running()


def test_a_scheduler_frozen_longer_than_the_timeout_times_out_no_design(tmp_path, monkeypatch,
                                                                        cluster):
    """SIGSTOP to the Dask scheduler for 1.75 times the evaluations' timeout while they run (its
    workers go on; nothing they do is reported): no design is recorded as timed out and the
    table is the uninterrupted run's. Frozen for less than PROBE_TIMEOUT the run waits; longer
    (shortened here), the scheduler is taken for lost and the designs in flight run again once
    it answers."""
    import threading
    import time

    from lccopt.engine import dask_executor

    from .conftest import cli, journal_events, n_done, wait_for

    case = write_case(tmp_path, "frozen", budget=8, initial=4, seed=5, timeout=2.0)
    reference = read_table(optimise(case, workers=2, runs=tmp_path / "local", evaluator=FAKE,
                                    progress=False))
    cluster.running()

    def freeze(run, seconds, p=None):
        wait_for(lambda: n_done(run) >= 2 or (p is not None and p.poll() is not None))
        time.sleep(0.1)              # evaluations in flight
        os.kill(cluster.scheduler.pid, signal.SIGSTOP)
        time.sleep(seconds)
        os.kill(cluster.scheduler.pid, signal.SIGCONT)

    try:
        p = cli("optimise", case, "--scheduler", cluster.address, "--runs", tmp_path / "a",
                env={"LCCOPT_EVALUATOR": FAKE, "LCCOPT_FAKE_DELAY": "0.3"})
        run = tmp_path / "a" / "frozen"
        freeze(run, 3.5, p)
        out, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
        assert "FAILED" not in err and "timed out" not in err, err
        assert not [e for e in journal_events(run) if e["event"] == "failed"]
        assert_same_evaluations(reference, read_table(run))

        monkeypatch.setattr(dask_executor, "PROBE_TIMEOUT", 3.5)
        monkeypatch.setenv("LCCOPT_FAKE_DELAY", "0.3")
        run = tmp_path / "b" / "frozen"
        stopper = threading.Thread(target=freeze, args=(run, 4.5), daemon=True)
        stopper.start()
        said = io.StringIO()
        optimise(case, scheduler=cluster.address, runs=tmp_path / "b", evaluator=FAKE,
                 progress=False, stream=said)
        stopper.join(30)
        said = said.getvalue()
        assert "has not answered for 3.5 s" in said and "is back" in said, said
        assert not [e for e in journal_events(run) if e["event"] == "failed"]
        assert_same_evaluations(reference, read_table(run))

        # while the scheduler answers, a design that hangs is still timed out (once)
        table = read_table(optimise(case, scheduler=cluster.address, runs=tmp_path / "c",
                                    evaluator=FAULTY, progress=False))
        failed = [r for r, s in zip(table["reason"], table["status"]) if s == "failed"]
        assert failed == ["timed out after 2 s (Dask task cancelled)"], failed
        assert len(table["id"]) == 8 and (cluster.faults / "hang").exists()
    finally:
        cluster.running()


def test_scheduler_addresses_lccopt_cannot_use_are_one_line_with_no_finaliser_later(tmp_path):
    """TLS without certificates in Dask's configuration, UCX without its package, a host that
    does not resolve: exit 2 with one line, and no Client.__del__ traceback (20 s) after it."""
    import time

    pytest.importorskip("distributed")
    from .conftest import cli_run

    case = write_case(tmp_path, "addr", budget=6, initial=4)
    host = "a" * 60 + "." + "b" * 60 + ".example.invalid"
    for address, text in (("tls://127.0.0.1:8786", "needs the client's certificates"),
                          ("ucx://127.0.0.1:8786", "ucx:// transport cannot be used here"),
                          (f"tcp://{host}:8786", "cannot connect to the Dask scheduler")):
        t0 = time.monotonic()
        r = cli_run("optimise", case, "--scheduler", address, "--runs", tmp_path / "runs",
                    env={"LCCOPT_EVALUATOR": FAKE}, timeout=120)
        assert time.monotonic() - t0 < 19, address
        assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and text in lines[0], r.stderr
    assert not (tmp_path / "runs").exists()
