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
    for name in dask["file"]:  # written by the parent from the returned evaluation
        read_evaluation(run / name)


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
