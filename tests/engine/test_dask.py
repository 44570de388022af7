"""The Dask executor on a local cluster gives the same evaluations as the local process pool."""

from __future__ import annotations

import pytest

from lccopt.engine.runner import optimise
from lccopt.store import read_evaluation

from .conftest import FAKE, assert_same_evaluations, optimise_on_local_dask, read_table, write_case


def test_dask_local_cluster_same_evaluations_as_process_pool(tmp_path):
    pytest.importorskip("distributed")
    case = write_case(tmp_path, "dk", budget=10, initial=5, seed=3)
    local = read_table(optimise(case, workers=1, runs=tmp_path / "local", evaluator=FAKE, progress=False))
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
    local = read_table(optimise(case, workers=1, runs=tmp_path / "local", evaluator=REAL, progress=False))
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
    from lccopt.engine import executors
    from lccopt.engine.worker import Task
    from lccopt.problem import Problem

    case = load_case(write_case(tmp_path, "probe", budget=4, initial=4, seed=1))
    evals = tmp_path / "evals"
    evals.mkdir()
    probe = executors._write_probe(evals)
    assert probe[0].endswith(".tmp") and open(probe[0]).read() == probe[1]
    x = list(Problem.from_case(case).reference)
    here = executors.dask_task(case, Task(0, x, out_path=str(evals / "000000.h5")), FAKE, probe)
    assert here.error is None and here.file_written and here.evaluation is None
    assert read_evaluation(evals / "000000.h5")[1].objectives == here.objectives
    for other in [(probe[0], "0" * 32), (str(tmp_path / "nowhere.tmp"), probe[1])]:
        away = executors.dask_task(case, Task(1, x, out_path=str(evals / "000001.h5")), FAKE, other)
        assert away.error is None and not away.file_written and away.evaluation is not None
        assert not (evals / "000001.h5").exists()
