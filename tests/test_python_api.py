"""The Python entry points a notebook uses: lccopt.load_case, simulate, optimise, resume."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

import lccopt
from tests.conftest import write_case


def test_importing_lccopt_loads_no_numerics():
    # the command line sets the BLAS thread count before numpy loads: the package must not load it
    code = "import sys, lccopt; print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_simulate_a_case_file_and_a_design(tmp_path):
    case = lccopt.load_case(write_case(tmp_path, "api"))
    ref = lccopt.simulate(case)
    assert set(ref.objectives) == {"F_rms", "F_max", "E_rms", "E_max"}
    assert all(np.isfinite(v) and v > 0 for v in ref.objectives.values())
    other = case.to_user()                           # the reference design, MN/m and m
    other[:3] = 200.0                                # softer pads, MN/m
    assert lccopt.simulate(case, other).objectives != ref.objectives
    again = lccopt.simulate(tmp_path / "api.yaml")   # a path works too
    assert again.objectives == ref.objectives


def test_simulate_a_traffic_case_gives_each_condition(tmp_path):
    conditions = "conditions:\n  - {name: slow, speed: 22.0}\n  - {name: fast, speed: 40.0}\n"
    out = lccopt.simulate(write_case(tmp_path, "apitr", extra=conditions))
    assert list(out) == ["slow", "fast"]
    assert out["fast"].objectives["F_max"] != out["slow"].objectives["F_max"]


def test_simulate_a_realisation_of_the_track(tmp_path):
    """A case with uncertainty: the drawing by default, any realisation by its number (the
    tracks a run evaluates every design on, as part_case gives them to the workers)."""
    import pytest

    from lccopt.problem import evaluate

    spread = ("uncertainty:\n  realisations: 3\n  seed: 4\n"
              "  support_stiffness: {cov: 0.3, correlation_length: 0}\n")
    case = lccopt.load_case(write_case(tmp_path, "apirob", extra=spread))
    drawn = lccopt.simulate(case).objectives
    assert drawn == lccopt.simulate(lccopt.load_case(write_case(tmp_path, "plain"))).objectives
    second = lccopt.simulate(case, realisation=2).objectives
    assert second == evaluate(case.part_case(-1, 2), case.reference).objectives
    assert second["F_max"] != drawn["F_max"]
    assert lccopt.simulate(case, realisation=1).objectives["F_max"] != second["F_max"]
    for bad, kind, text in ((3, ValueError, "realisation 3: the case has realisations 0-2"),
                            (-1, ValueError, "realisations 0-2"),
                            (1.0, TypeError, "realisation must be a whole number"),
                            (True, TypeError, "realisation must be a whole number")):
        with pytest.raises(kind, match=text):
            lccopt.simulate(case, realisation=bad)
    with pytest.raises(ValueError, match="no uncertainty: section"):
        lccopt.simulate(tmp_path / "plain.yaml", realisation=0)


def test_optimise_and_resume_from_python(tmp_path, monkeypatch):
    monkeypatch.setenv("LCCOPT_EVALUATOR", "tests.engine.fakesim:evaluate")
    case = write_case(tmp_path, "apiopt", budget=6, initial=4)
    run = lccopt.optimise(case, workers=1, runs=tmp_path / "runs", progress=False)
    assert (run / "results.h5").is_file()
    assert lccopt.resume(run, progress=False) == run     # finished: nothing to do


def test_every_argument_of_a_wrong_type_or_value_is_named(tmp_path):
    """A float worker count is not rounded, a text is not compared with a number, a dict is
    not taken for a path: TypeError or ValueError naming the argument, before anything runs."""
    import pytest

    case = write_case(tmp_path, "args", budget=6, initial=4)
    runs = tmp_path / "runs"
    wrong = [(dict(workers=2.5), TypeError, "workers must be a whole number"),
             (dict(workers="2"), TypeError, "workers must be a whole number"),
             (dict(workers=True), TypeError, "workers must be a whole number"),
             (dict(workers=0), ValueError, "workers must be at least 1"),
             (dict(runs=3), TypeError, "runs must be"),
             (dict(force="no"), TypeError, "force must be True or False"),
             (dict(progress=None), TypeError, "progress must be True or False"),
             (dict(scheduler=8786), TypeError, "scheduler must be a Dask scheduler address")]
    for kwargs, kind, text in wrong:
        with pytest.raises(kind, match=text):
            lccopt.optimise(case, **{"runs": runs, "progress": False, **kwargs})
    assert not runs.exists()
    for bad in ({"name": "x"}, 3, None):
        with pytest.raises(TypeError, match="case must be a case file"):
            lccopt.optimise(bad, runs=runs)
    with pytest.raises(TypeError, match="path must be a case file"):
        lccopt.load_case({"name": "x"})
    with pytest.raises(ValueError, match="budget must be at least 2, not -5"):
        lccopt.resume(runs / "args", budget=-5)
    with pytest.raises(TypeError, match="budget must be a whole number"):
        lccopt.resume(runs / "args", budget=3.0)
    with pytest.raises(TypeError, match="run must be a run directory"):
        lccopt.resume(None)
    with pytest.raises(TypeError, match="design must be a sequence of numbers, one per design"):
        lccopt.simulate(case, "abc")
    with pytest.raises(ValueError, match="design: a design vector has 8 values"):
        lccopt.simulate(case, [1.0, 2.0])


_STOPPED_RUN = """
import json, os, signal, sys, threading, time
import lccopt

case, runs = sys.argv[1], sys.argv[2]
journal = os.path.join(runs, "apistop", "journal.jsonl")


def stop_after_two():
    while True:
        try:
            if open(journal).read().count('"evaluated"') >= 2:
                break
        except OSError:
            pass
        time.sleep(0.05)
    os.kill(os.getpid(), signal.SIGTERM)


threading.Thread(target=stop_after_two, daemon=True).start()
try:
    lccopt.optimise(case, workers=1, runs=runs, progress=False)
except Exception as exc:   # noqa: BLE001 - what a script's except Exception would catch
    print(json.dumps({"caught by except Exception": repr(exc)}))
except lccopt.RunInterrupted as exc:
    print(json.dumps({"class": f"{type(exc).__module__}.{type(exc).__name__}",
                      "keyboard": isinstance(exc, KeyboardInterrupt), "path": str(exc.path),
                      "done": exc.done, "budget": exc.budget, "signal": exc.name,
                      "text": str(exc),
                      "handler back": signal.getsignal(signal.SIGTERM) == signal.SIG_DFL}))
    sys.stdout.flush()
    print(lccopt.resume(exc.path, progress=False))
"""


def test_an_interrupted_optimise_raises_the_library_exception_and_resumes(tmp_path):
    """A run stopped by a signal from Python raises lccopt.RunInterrupted (a KeyboardInterrupt,
    never typer's Exit nor SystemExit), saying where the run is saved; the program's signal
    handler is back; lccopt.resume carries the run on to its budget."""
    import json

    from tests.conftest import subprocess_env
    from tests.engine.conftest import read_table

    case = write_case(tmp_path, "apistop", budget=8, initial=4, seed=4)
    runs = tmp_path / "runs"
    r = subprocess.run([sys.executable, "-c", _STOPPED_RUN, str(case), str(runs)],
                       capture_output=True, text=True, timeout=300,
                       env=subprocess_env(LCCOPT_EVALUATOR="tests.engine.fakesim:evaluate",
                                          LCCOPT_FAKE_DELAY="0.2"))
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()      # the stop, the resumed run's summary, its directory
    stopped, resumed = json.loads(lines[0]), lines[-1]
    run = runs / "apistop"
    assert stopped["class"] == "lccopt.errors.RunInterrupted" and stopped["keyboard"], stopped
    assert (stopped["path"], stopped["budget"], stopped["signal"]) == (str(run), 8, "SIGTERM")
    assert 2 <= stopped["done"] < 8 and stopped["handler back"], stopped
    assert stopped["text"] == (f"run {run} interrupted by SIGTERM: {stopped['done']}/8 "
                               f"evaluations saved; carry on with lccopt.resume('{run}')")
    assert resumed == str(run)
    t = read_table(run)
    assert len(t["id"]) == 8 and set(t["status"]) == {"ok"}
