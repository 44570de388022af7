"""The ask/tell strategy: proposals, budget, duplicates, failures, state and resume."""

import json

import numpy as np
import pytest

from benchmarks.support import problems
from lccopt.optim import context
from lccopt.optim.candidates import perturb
from lccopt.optim.sampling import latin_hypercube, to_space
from lccopt.optim.settings import WEIGHTS, Settings
from lccopt.optim.space import DesignSpace
from lccopt.optim.strategy import PHASES, Proposal, Strategy
from tests.optim.helpers import ShortPhases, fingerprint, run_serial

REFERENCE = [600.0, 600.0, 600.0, 0.0, 6.0, 6.0, 4.0, 0.0]  # like the paper's reference design


# -- basic behaviour -------------------------------------------------------------------------------
def test_given_point_first_then_lhs_then_adaptive():
    p = problems.paper_size("levy", given=[REFERENCE])
    s = Strategy(p.space, budget=40, n_initial=20, seed=0)
    first = s.ask(1)[0]
    assert isinstance(first, Proposal)
    assert first.id == 0 and first.phase == "initial" and first.restart == 0
    assert first.x.tolist() == REFERENCE
    s.tell(first.id, p(first.x))
    run_serial(s, p)
    h = s.history
    assert [r["id"] for r in h] == list(range(40))
    assert [r["phase"] for r in h[:20]] == ["initial"] * 20
    assert all(r["phase"] in PHASES[1:] for r in h[20:])
    X = np.array([r["x"] for r in h])
    assert np.all(X >= p.space.lb) and np.all(X <= p.space.ub)
    assert np.all(X[:, 3:] == np.rint(X[:, 3:]))
    assert len(np.unique(X, axis=0)) == 40
    assert s.n_asked == s.n_told == 40 and s.done and s.pending == []
    assert s.ask(3) == []
    x, v = s.best
    assert v == min(r["value"] for r in h)


def test_budget_counts_failures_and_ask_stops():
    sp = problems.paper_size("ackley").space
    s = Strategy(sp, budget=5, n_initial=3, seed=1)
    props = s.ask(10)
    assert len(props) == 5 and s.n_asked == 5 and s.ask(1) == []
    assert s.pending == [0, 1, 2, 3, 4]
    s.tell_failed(props[3].id, "solver diverged")
    s.tell(props[1].x, 1.0)  # by x
    s.tell(props[0], float("nan"))  # by Proposal; non-finite counts as failed
    assert not s.done
    s.tell(2, 3.0)
    s.tell(4, 0.5)
    assert s.done and s.n_told == 5
    h = s.history
    assert [r["status"] for r in h] == ["failed", "ok", "ok", "failed", "ok"]
    assert h[3]["reason"] == "solver diverged" and "non-finite" in h[0]["reason"]
    assert s.best[1] == 0.5
    with pytest.raises(ValueError, match="already told"):
        s.tell(2, 1.0)
    with pytest.raises(KeyError):
        s.tell(np.zeros(8), 1.0)


def test_the_candidates_are_dycors_steps_and_the_local_search():
    """No uniform points while steps near the best point find unused points ("random" is the
    fill-in of a nearly exhausted neighbourhood: test_integer_space_exhausted)."""
    p = problems.paper_size("rastrigin")
    s = run_serial(Strategy(p.space, budget=120, seed=3), p)
    assert {r["phase"] for r in s.history} == set(PHASES) - {"random"}


# -- beats random search and Latin hypercube -------------------------------------------------------
@pytest.mark.parametrize("name", ["ackley8", "levy8", "rastrigin8", "gear", "nvs09"])
@pytest.mark.slow
def test_beats_random_and_lhs(name):
    p = problems.get(name)
    budget, seeds = 70, range(3)
    ours = [run_serial(Strategy(p.space, budget=budget, seed=s), p).best[1] - p.f_opt
            for s in seeds]
    rand, lhs = [], []
    for s in seeds:
        rng = np.random.default_rng(100 + s)
        sp = p.space
        lo = np.where(sp.int_mask, sp.lb - 0.5, sp.lb)
        hi = np.where(sp.int_mask, sp.ub + 0.5, sp.ub)
        rand.append(p(sp.snap(lo + rng.random((budget, sp.dim)) * (hi - lo))).min() - p.f_opt)
        lhs.append(p(latin_hypercube(sp, budget, rng)).min() - p.f_opt)
    assert np.mean(ours) < np.mean(rand)
    assert np.mean(ours) < np.mean(lhs)


# -- duplicates and exhaustion ---------------------------------------------------------------------
def int_space():
    return DesignSpace(["a", "b", "c"], [0, 0, 0], [4, 4, 4], [True] * 3)  # 125 points


def bowl(x):
    return float(np.sum((np.asarray(x) - [1, 3, 2]) ** 2))


def test_no_duplicates_on_integer_problem():
    s = run_serial(Strategy(int_space(), budget=100, n_initial=10, seed=0), bowl)
    X = np.array([r["x"] for r in s.history])
    assert len(X) == 100 and len(np.unique(X, axis=0)) == 100
    assert s.best[1] == 0.0


def test_integer_space_exhausted():
    s = Strategy(int_space(), budget=200, n_initial=10, seed=2)
    props = []
    while True:
        got = s.ask(4)
        if not got:
            break
        props += got
        for p in got:
            s.tell(p.id, bowl(p.x))
    X = np.array([p.x for p in props])
    assert len(X) == 125 and len(np.unique(X, axis=0)) == 125
    assert s.exhausted and s.done
    assert "random" in {p.phase for p in props}  # the last unused points: uniform and grid


# -- failures --------------------------------------------------------------------------------------
def test_failed_points_not_reproposed_and_surrogate_survives():
    p = problems.paper_size("levy")
    s = Strategy(p.space, budget=90, seed=4)
    n_failed = 0
    while not s.done:
        for pr in s.ask(2):
            # The "simulator" crashes on a third of the railpad range and at random.
            if pr.x[0] > 850 or pr.id % 7 == 3:
                s.tell_failed(pr.id, "crash")
                n_failed += 1
            else:
                s.tell(pr.id, p(pr.x))
    h = s.history
    X = np.array([r["x"] for r in h])
    assert len(np.unique(X, axis=0)) == len(X) == 90
    assert n_failed == sum(r["status"] == "failed" for r in h) > 10
    x, v = s.best
    assert np.isfinite(v) and x[0] <= 850
    # still better than the best of the initial design
    assert v < min(r["value"] for r in h[:20] if r["status"] == "ok")


def test_repeated_failures_force_restart():
    p = problems.paper_size("ackley")
    s = Strategy(p.space, budget=60, n_initial=10, seed=0)  # a phase ends after 8 in a row
    while not s.done:
        for pr in s.ask(1):
            if pr.phase == "initial" and pr.restart == 0:
                s.tell(pr.id, p(pr.x))
            else:
                s.tell_failed(pr.id, "always fails")
    assert s.restart >= 1
    h = s.history
    assert {r["phase"] for r in h if r["restart"] == 1} >= {"initial"}


# -- state and resume ------------------------------------------------------------------------------
def drive(s, fun, steps, workers, pending, save_every=None, tmp_path=None, restarts=None):
    """Deterministic asynchronous engine: keep `workers` busy, finish them out of order.

    `pending` (list of ids, oldest first) is the engine's own state, passed across resumes.
    With save_every, the strategy is saved, dropped and reloaded every that many steps.
    """
    for step in range(steps):
        if s.done:
            break
        pending += [p.id for p in s.ask(workers - len(pending))]
        if not pending:
            break
        i = pending.pop((s.n_told * 5 + 2) % len(pending))  # out of order
        x = s.history[i]["x"]
        if i % 11 == 5:
            s.tell_failed(i, "crashed")
        else:
            s.tell(x if i % 2 else i, fun(x))
        if save_every and step % save_every == save_every - 1:
            path = tmp_path / "state.json"
            s.save(path)
            s = Strategy.load(path) if restarts is None else Strategy.from_state(
                json.loads(path.read_text()), restarts=restarts())
    return s, pending


@pytest.mark.parametrize("workers", [1, 3])
def test_resume_half_way_is_bit_identical(tmp_path, workers):
    p = problems.paper_size("rastrigin", given=[REFERENCE])
    def make():
        return Strategy(p.space, budget=70, n_initial=15, seed=11)

    straight, pend_a = drive(make(), p, 200, workers, [])
    half, pend_b = drive(make(), p, 35, workers, [])
    half.save(tmp_path / "s.json")
    resumed, pend_b = drive(Strategy.load(tmp_path / "s.json"), p, 165, workers, pend_b)
    assert straight.done and resumed.done
    assert fingerprint(straight) == fingerprint(resumed)
    for a, b in zip(straight.history, resumed.history):
        assert a["x"].tobytes() == b["x"].tobytes()
        assert (a["phase"], a["restart"], a["status"], a["value"]) == \
               (b["phase"], b["restart"], b["status"], b["value"])


@pytest.mark.slow
def test_resume_at_every_step_across_restarts(tmp_path):
    """Saved, dropped and restored after every step through fresh restarts, restarts from the
    run's best point, bound probes and a subspace phase (short phases: many restarts)."""
    p = problems.paper_size("ackley")
    kw = dict(budget=120, n_initial=10, seed=5)
    straight, _ = drive(Strategy(p.space, restarts=ShortPhases(), **kw), p, 400, 2, [])
    assert straight.restart >= 4
    assert {r["restart"] for r in straight.history if r["phase"] == "initial"} != set(
        range(straight.restart + 1)), "a restart from the run's best point"
    resumed, _ = drive(Strategy(p.space, restarts=ShortPhases(), **kw), p, 400, 2, [],
                       save_every=1, tmp_path=tmp_path, restarts=ShortPhases)
    assert fingerprint(straight) == fingerprint(resumed)


def test_state_is_plain_json_and_exact():
    p = problems.paper_size("levy")
    s = Strategy(p.space, budget=30, seed=2)
    for pr in s.ask(25):
        s.tell(pr.id, p(pr.x) / 3.0)  # values that need all 17 digits
    d = json.loads(json.dumps(s.state_dict()))
    t = Strategy.from_state(d)
    assert fingerprint(t) == fingerprint(s)
    a, b = s.ask(3), t.ask(3)
    assert [x.x.tobytes() for x in a] == [x.x.tobytes() for x in b]
    assert [x.phase for x in a] == [x.phase for x in b]


def test_save_is_atomic_and_leaves_no_temp(tmp_path):
    sp = problems.gear().space
    s = Strategy(sp, budget=10, n_initial=4, seed=0)
    s.save(tmp_path / "st.json")
    s.ask(2)
    s.save(tmp_path / "st.json")
    assert [f.name for f in tmp_path.iterdir()] == ["st.json"]
    assert Strategy.load(tmp_path / "st.json").n_asked == 2


@pytest.mark.parametrize("name", ["ackley8", "gear"])
def test_is_taken_matches_pairwise_comparison(name):
    """The grouped duplicate check equals the all-pairs definition (ints equal, cont within tol)."""
    from scipy.spatial.distance import cdist

    p = problems.get(name)
    s = Strategy(p.space, budget=200, seed=3)
    while s.n_told < 60:
        for pr in s.ask(1):
            s.tell(pr.id, p(pr.x))
    ctx = s._prepare()
    rng = np.random.default_rng(0)
    near = ctx.taken[rng.integers(len(ctx.taken), size=40)].copy()
    cont, ints = ctx.cont, ctx.int
    if cont.any():
        near[:20, cont] += 1e-9  # within tol: taken
        near[20:, cont] += 50.0  # outside tol: free unless the integers match another point
    near[:, ints] = np.where(near[:, ints] == 0, -0.0, near[:, ints])  # -0.0 equals 0.0
    steps = perturb(p.space, rng, ctx.best, 300, s.sigma, 0.5, p.space.ub > p.space.lb, "truncnorm")
    C = np.vstack([near, steps, to_space(p.space, rng.random((50, p.space.dim)))])
    same = cdist(C[:, ints], ctx.taken[:, ints], "chebyshev") == 0
    if cont.any():
        Cu, Tu = (p.space.to_unit(A)[:, cont] for A in (C, ctx.taken))
        same &= cdist(Cu, Tu) < ctx.tol
    assert np.array_equal(ctx.is_taken(C), same.any(axis=1))
    assert ctx.is_taken(C[:20]).all()


@pytest.mark.slow
def test_duplicate_radius_lets_a_sharp_minimum_be_refined(monkeypatch):
    """The duplicate radius (settings.DIST_TOL, 1e-4 of the unit box): Schoen's function is
    -1000 + ~1e5 r^2 near its optimum, so a radius ten times larger stops the refinement
    0.03-0.04 above f* in 200 evaluations; 1e-4 lets it get within 1e-5."""
    p = problems.get("schoen6_int")
    for seed in (0, 1):
        now = run_serial(Strategy(p.space, budget=200, seed=seed), p)
        assert now.best[1] - p.f_opt < 1e-3, (seed, now.best[1])
    with monkeypatch.context() as m:
        m.setattr(context, "DIST_TOL", 1e-3)
        for seed in (0, 1):
            wide = run_serial(Strategy(p.space, budget=200, seed=seed), p)
            assert wide.best[1] - p.f_opt > 1e-2, (seed, wide.best[1])


def test_settings_are_the_surrogate_defaults_and_changes_are_checked():
    space = problems.paper_size("ackley").space
    assert Strategy(space).settings == Settings.default()
    assert Strategy(space, composite=True).settings == Settings.default(composite=True)
    s = Strategy(space, composite=True, restart_from="endgame")
    assert s.settings == Settings.default(composite=True).replace(restart_from="endgame")
    assert Strategy(space, settings=s.settings.to_dict()).settings == s.settings
    with pytest.raises(TypeError, match="unknown optimiser settings"):
        Strategy(space, n_uniform=80)
    with pytest.raises(ValueError, match="restart_from = 'alternate'"):
        Strategy(space, restart_from="alternate")


def test_one_ask_fits_once_for_several_points_and_spreads_them():
    """ask(k) proposes k distinct points from one surrogate fit and one scored candidate set,
    each pick joining the distance criterion before the next (pySOT's batch mode)."""
    from scipy.spatial.distance import cdist

    from lccopt.optim.context import CandidatePool

    p = problems.paper_size("levy")
    a = Strategy(p.space, budget=60, seed=8)
    for pr in a.ask(30):
        a.tell(pr.id, p(pr.x))
    fits, pools = [], []
    real_fit, real_pool = a._fit, a._pool
    a._fit = lambda *args: fits.append(1) or real_fit(*args)
    a._pool = lambda ctx: pools.append(real_pool(ctx)) or pools[-1]
    snapshot = json.loads(fingerprint(a))
    batch = a.ask(8)
    assert len(fits) == 1 and len(pools) == 1
    X = np.array([q.x for q in batch])
    sp = p.space
    assert len(np.unique(X, axis=0)) == 8 and np.all((X >= sp.lb) & (X <= sp.ub))
    assert np.array_equal(X[:, sp.int_mask], np.rint(X[:, sp.int_mask]))
    # picked from one set: the pool's maximin picks at weight 0 are the brute-force ones
    b = Strategy.from_state(snapshot)
    ctx = b._prepare()
    C, src = b._free_candidates(ctx, max(WEIGHTS))
    np.testing.assert_array_equal(C, pools[0].C)
    pool = CandidatePool(b.space, ctx, C, src)
    used = list(ctx.near_u)
    for _ in range(5):
        i = pool.best(0.0)
        far = cdist(pool.Cu, np.array(used)).min(axis=1)
        assert far[i] == far[pool.free].max()
        pool.add(pool.C[i])
        used.append(pool.Cu[i])
        assert not pool.free[i]
    # a block is state: what it computed beyond k comes out of the next asks, after a restore
    c = Strategy.from_state(snapshot)
    c.set_batch(8)
    first = c.ask(1)
    rest = Strategy.from_state(json.loads(fingerprint(c))).ask(7)
    assert c.n_ahead == 7
    assert [q.x.tobytes() for q in first + rest] == [q.x.tobytes() for q in batch]


# -- log scales ------------------------------------------------------------------------------------
def _ratio_problem(log: bool):
    """Optimum at 2e-3, 0.5 and 30 of [1e-3, 1e3]: a bowl in ln x, plus an integer."""
    a = np.array([2e-3, 0.5, 30.0])
    space = DesignSpace(["p", "q", "r", "n"], [1e-3] * 3 + [0], [1e3] * 3 + [10],
                        [False] * 3 + [True], log=[log] * 3 + [False])
    return space, lambda x: float(np.sum(np.log(x[:3] / a) ** 2) + (x[3] - 3) ** 2)


@pytest.mark.slow
def test_a_log_scale_steps_in_ratios_and_finds_an_optimum_a_linear_scale_misses():
    for log in (True, False):
        best = []
        for seed in range(3):
            space, f = _ratio_problem(log)
            s = run_serial(Strategy(space, budget=60, n_initial=10, seed=seed), f)
            X = np.array([r["x"] for r in s.history])
            assert np.all(X >= space.lb) and np.all(X <= space.ub)
            best.append(s.best[1])
            if log:  # the initial design spreads over the decades: some points below 0.1
                assert np.sum(X[:10, 0] < 0.1) >= 3
        if log:
            assert max(best) < 1e-6
        else:  # in the unit box of x the optima at 2e-3 and 0.5 are within 5e-4 of the bound
            assert min(best) > 0.1


def test_a_log_scale_state_is_exact_and_resumes_bit_for_bit():
    space, f = _ratio_problem(True)
    s = Strategy(space, budget=40, n_initial=10, seed=3)
    for pr in s.ask(25):
        s.tell(pr.id, f(pr.x))
    t = Strategy.from_state(json.loads(json.dumps(s.state_dict())))
    assert t.space.log == [True, True, True, False]
    a, b = s.ask(3), t.ask(3)
    assert [x.x.tobytes() for x in a] == [x.x.tobytes() for x in b]




# -- an on/off switch searched as such -------------------------------------------------------------
@pytest.mark.parametrize("composite", [False, True])
def test_a_switch_reaches_an_off_optimum_behind_a_wall_that_one_range_misses(composite):
    """off_switch_elsewhere: n = 0 ("no strip") holds the optimum (0 at x, y = 0.2, 0.8), small
    n are a wall and a basin near n = 70 is the wide one. Searched as one range, n = 0 is one
    value of 121 and 30 evaluations find it in at most 2 of 10 seeds; searched as a switch
    (off half the search range) in all 10, with either surrogate."""
    from tests.optim.helpers import as_outputs, off_switch_elsewhere

    def run(switch: bool, seed: int):
        space = DesignSpace(["x", "y", "n"], [0.0, 0.0, 0], [1.0, 1.0, 120], [False, False, True],
                            switch=[False, False, switch])
        s = Strategy(space, budget=30, n_initial=8, seed=seed, composite=composite)
        outputs = as_outputs(off_switch_elsewhere)
        if composite:
            s.set_aggregate(lambda F: F.sum(axis=1))
        while not s.done:
            for p in s.ask(1):
                s.tell(p.id, off_switch_elsewhere(p.x), outputs(p.x) if composite else None)
        x, v = s.best
        return x[2] == 0 and v < 0.01

    assert sum(run(True, seed) for seed in range(10)) == 10
    assert sum(run(False, seed) for seed in range(10)) <= 2


def test_settings_without_switches_search_one_range():
    space = DesignSpace(["x", "n"], [0.0, 0], [1.0, 120], [False, True], switch=[False, True])
    assert Strategy(space, budget=10, n_initial=4).space.switch == [False, True]
    plain = Strategy(space, budget=10, n_initial=4, switches=False)
    assert plain.space.switch == [False, False]
    assert plain.settings.switches is False
