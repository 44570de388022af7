"""The experiments of benchmarks/optimiser/variants.py plug into the strategy through its extension
points (a candidate generator, a restart policy), do what they say, keep the strategy's
exact resume, and run from benchmarks/optimiser/optimiser.py --variant."""

import csv
import os
import subprocess
import sys

import numpy as np
import pytest

from benchmarks.optimiser import variants
from benchmarks.support import problems
from lccopt.optim.settings import Settings
from lccopt.optim.strategy import Strategy
from tests.optim.helpers import OFF_SWITCH_SPACE, ShortPhases, off_switch, run_serial, xs

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _run(variant, p, budget=80, seed=1, **kw):
    s = Strategy(p.space, budget=budget, n_initial=10, seed=seed,
                 **variants.strategy_kwargs(variant), **kw)
    return run_serial(s, p)


def test_uniform_candidates_compete_at_one_weight():
    p = problems.paper_size("levy")
    s = _run("uniform", p)
    assert "random" in {r["phase"] for r in s.history}
    assert xs(s) != xs(_run("default", p))


def test_integer_bound_jumps_put_moved_integers_on_bounds():
    gen = variants.IntBoundJumps(Settings.default(), q=0.2)
    s = Strategy(OFF_SWITCH_SPACE, budget=60, n_initial=10, seed=0, candidates=gen)
    for pr in s.ask(10):
        s.tell(pr.id, off_switch(pr.x))
    best = s.best[0]
    ctx = s._prepare()
    seen = []
    s.candidates = lambda req: seen.append(gen(req)) or seen[-1]
    s._select(ctx)
    X = seen[0][0][0]
    on_bound = np.isin(X[:, 2], [0.0, 100.0]) & (X[:, 2] != best[2])
    assert 0.1 < on_bound.mean() < 0.35  # about q of the rows whose integer moved
    ends = [run_serial(Strategy(OFF_SWITCH_SPACE, budget=60, n_initial=10, seed=k,
                                candidates=variants.IntBoundJumps(Settings.default())),
                       off_switch).best[0][2] for k in range(3)]
    assert ends == [0.0] * 3  # the "off" switch behind the wall, within the first phases


def test_alternate_restarts_go_on_from_the_best_point_on_odd_restarts():
    class Short(ShortPhases, variants.AlternateRestarts):
        pass

    p = problems.paper_size("ackley")
    # with restart_from "fresh" the default policy never goes on from the best point itself
    s = run_serial(Strategy(p.space, budget=120, n_initial=10, seed=5, restarts=Short(),
                            restart_from="fresh"), p)
    designs = {r: sum(q["phase"] == "initial" for q in s.history if q["restart"] == r)
               for r in range(1, s.restart + 1)}
    assert len(designs) >= 3
    assert all(designs[r] == (0 if r % 2 == 1 else 10) for r in designs), designs


@pytest.mark.slow
def test_a_variant_run_resumes_exactly_with_its_extension_passed_again():
    p = problems.paper_size("rastrigin")
    for variant in variants.VARIANTS:
        kw = variants.strategy_kwargs(variant)
        s = Strategy(p.space, budget=70, n_initial=10, seed=4, **kw)
        for pr in s.ask(30):
            s.tell(pr.id, p(pr.x))
        t = Strategy.from_state(s.state_dict(), **variants.strategy_kwargs(variant))
        assert xs(run_serial(s, p)) == xs(run_serial(t, p)), variant


def test_optimiser_benchmark_runs_a_variant_and_records_its_name(tmp_path):
    out = tmp_path / "v.csv"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, "-m", "benchmarks.optimiser.optimiser",
                        "--quick", "--problems", "gear", "--methods", "lccopt", "--seeds", "0-1",
                        "--variant", "uniform", "--out", str(out)],
                       capture_output=True, text=True, timeout=120, env=env, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(open(out)))
    assert len(rows) == 2 and {row["settings"] for row in rows} == {"uniform"}
