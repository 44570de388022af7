"""Restarts: fresh designs, phases from the run's best point, bound probes, subspace phases."""

import json

import numpy as np
import pytest

from benchmarks.support import problems
from lccopt.optim import selection as selection_module
from lccopt.optim.settings import SIGMA_INIT, fail_tol
from lccopt.optim.strategy import Strategy
from tests.optim.helpers import (
    OFF_SWITCH_SPACE,
    ShortPhases,
    as_outputs,
    fingerprint,
    off_switch,
    off_switch_elsewhere,
    off_switch_poor_subspace,
    phases,
    run_delayed,
    run_serial,
    xs,
)

# seconds a test: whole optimisations through their restarts
pytestmark = pytest.mark.slow


def _watch_phases(s, f, workers=1, outputs=False):
    """Run s; per phase: (its Phase, the run's best record id and value when it began)."""
    seen = {}

    def watch(s):
        if s.phase.index not in seen:
            ok = [r for r in s.history[: s.phase.start] if r["status"] == "ok"]
            best = min(ok, key=lambda r: (r["value"], r["id"])) if ok else None
            seen[s.phase.index] = (s.phase, best)

    run_delayed(s, f, workers=workers, watch=watch, outputs=outputs)
    return seen


def _late(s, start: int) -> bool:
    h = s.history
    r = h[start]["restart"]
    lengths = [sum(rec["restart"] == q for rec in h[:start]) for q in range(r)]
    return s.budget - start < sum(lengths) / len(lengths)


def test_a_late_restart_goes_on_from_the_run_best_point_with_a_scalar_surrogate(tmp_path):
    """restart_from "endgame": a restart starts a fresh design unless the budget left is
    shorter than the run's phases so far were on average; then it goes on from the run's best
    point: the first such restart asks the best point's bound probes (its design), the later
    ones have no design, the step size reset. With "fresh" every restart has its design."""
    p = problems.paper_size("ackley")
    kw = dict(budget=140, n_initial=10, seed=5)
    s = Strategy(p.space, restarts=ShortPhases(), **kw)
    seen = _watch_phases(s, p)
    kinds = set()
    for i, (ph, best) in seen.items():
        if i == 0:
            continue
        late = _late(s, ph.start)
        kinds.add(late)
        if not late:
            assert (ph.n_design, ph.anchor) == (10, None)
        elif ph.frozen is None:
            assert ph.anchor == best["id"] and ph.n_design in (0, len(
                [r for r in s.history if r["restart"] == i and r["phase"] == "initial"]))
    assert kinds == {True, False}
    assert any(ph.n_design > 0 and ph.anchor is not None for ph, _ in seen.values())  # probes
    # inside a restart from the best point without a design: centred on the run's best,
    # sigma reset, success counted against the best value; saved and resumed there
    i, (ph, best) = next((i, (ph, best)) for i, (ph, best) in seen.items()
                         if ph.n_design == 0 and ph.anchor is not None and ph.frozen is None)
    t = Strategy(p.space, restarts=ShortPhases(), **kw)
    while t.n_asked < ph.start + 1:
        for pr in t.ask(1):
            if pr.id < ph.start:
                t.tell(pr.id, p(pr.x))
    assert t.restart == i and t.sigma == SIGMA_INIT and t.phase.anchor == best["id"]
    assert np.array_equal(t._prepare().best, best["x"]) and t._fbest_phase == best["value"]
    d = json.loads(json.dumps(t.state_dict()))
    t.tell(ph.start, p(t.history[ph.start]["x"]))
    resumed = Strategy.from_state(d, restarts=ShortPhases())
    resumed.tell(ph.start, p(resumed.history[ph.start]["x"]))
    assert fingerprint(run_serial(t, p)) == fingerprint(run_serial(resumed, p)) == fingerprint(s)
    fresh = Strategy(p.space, restarts=ShortPhases(), restart_from="fresh", **kw)
    seen = _watch_phases(fresh, p)
    assert len(seen) >= 3 and all(ph.n_design == 10 and ph.anchor is None
                                  for i, (ph, _) in seen.items() if i)


def test_a_scalar_surrogate_fits_every_point_after_a_restart():
    """restart_keeps_points: after a fresh restart the surrogate is fitted to every evaluated
    point, while the perturbations centre on the new phase's best point; without it, to the
    phase's own points."""
    p = problems.paper_size("ackley")
    seen = {}
    for keep in (True, False):
        s = Strategy(p.space, budget=90, n_initial=10, seed=5, restarts=ShortPhases(),
                     restart_keeps_points=keep)
        while s.restart == 0 or s._queue:  # into the second phase's surrogate proposals
            for pr in s.ask(1):
                s.tell(pr.id, p(pr.x))
        assert s.phase.anchor is None
        ctx = s._prepare()
        ok = [r for r in s.history if r["status"] == "ok"]
        own = [r for r in ok if r["restart"] == s.restart]
        seen[keep] = len(ctx.surrogate.X)
        assert seen[keep] == (len(ok) if keep else len(own))
        assert np.array_equal(ctx.best, min(own, key=lambda r: (r["value"], r["id"]))["x"])
    assert seen[True] > seen[False]


def test_bound_probes_in_a_phase_from_the_best_point_reach_an_off_switch_behind_a_wall(
        monkeypatch):
    """From the basin near n = 70 steps of sigma never cross the wall; once the run goes on
    from its best point, the probes put n on 0 and the run ends there. Probes are candidates
    only in phases that go on from a point."""
    probed_in = []
    real = selection_module.bound_probes
    for seed in range(3):
        s = Strategy(OFF_SWITCH_SPACE, budget=80, n_initial=10, seed=seed)
        monkeypatch.setattr(selection_module, "bound_probes",
                            lambda *a, s=s: probed_in.append(s.phase.anchor) or real(*a))
        run_serial(s, off_switch)
        first = [r for r in s.history if r["restart"] == 0 and r["status"] == "ok"]
        assert min(first, key=lambda r: r["value"])["x"][2] > 15  # the first phase: stuck
        assert s.best[0][2] == 0.0
    assert probed_in and None not in probed_in


def test_a_strategy_saved_while_probing_bounds_proposes_the_same_after_restoring():
    s = Strategy(OFF_SWITCH_SPACE, budget=80, n_initial=10, seed=1)
    while s.phase.anchor is None or s.n_told < s.n_asked:  # into a phase from the best point
        for p in s.ask(1):
            s.tell(p.id, off_switch(p.x))
    copy = Strategy.from_state(json.loads(json.dumps(s.state_dict())))
    runs = []
    for t in (s, copy):
        out = []
        while not t.done:
            for p in t.ask(1):
                t.tell(p.id, off_switch(p.x))
                out.append(p.x.tolist())
        runs.append(out)
    assert runs[0] == runs[1] and len(runs[0]) > 5
    assert s.best[0][2] == 0.0


def test_a_failed_probe_leads_a_subspace_phase_that_holds_its_integer_on_the_bound():
    """Where the run first goes on from its best point, the probes come first; when all are
    told and none improved on the run's best, half the budget left goes to a phase from the
    best probe with its integer held on that bound; it ends at n = 0's own optimum, which no
    step from the basin near n = 70 reaches."""
    for seed in range(3):
        s = Strategy(OFF_SWITCH_SPACE, budget=100, n_initial=10, seed=seed)
        seen = []

        def watch(s):
            if s.phase.frozen is not None and not seen:
                probes = [r for r in s.history if r["restart"] == s.restart - 1]
                seen.append((s.phase, len(s.history) - 1, probes))
            if s.phase.frozen is not None:  # the held integer never moves
                assert all(r["x"][2] == 0.0 for r in s.history if r["restart"] == s.restart)

        run_delayed(s, off_switch_elsewhere, watch=watch)
        (ph, start, probes), = seen
        # the probes, then one step while the last is in flight
        assert [r["phase"] for r in probes[-2:]] == ["initial", "adaptive"]
        probes = [r for r in probes if r["phase"] == "initial"]
        assert all(r["status"] == "ok" for r in probes) and len(probes) == 2
        best_probe = min(probes, key=lambda r: r["value"])
        assert ph.frozen == 2 and ph.anchor == best_probe["id"] and best_probe["x"][2] == 0.0
        assert ph.end == start + (100 - start) // 2
        before = [r for r in s.history[:start] if r["status"] == "ok"]
        assert min(before, key=lambda r: r["value"])["x"][2] == 70.0
        assert s.best[0][2] == 0.0 and s.best[1] < 1e-3


def test_a_subspace_trial_ends_a_poor_subspace_early_and_lets_a_good_one_run():
    """A subspace phase that has not improved on the run's best (by the step rule's tolerance)
    after fail_tol(d) proposals ends there, once those are told (2 in flight: one more
    proposal), and the run goes on from its best point; one that has runs to its end."""
    trial = fail_tol(3)
    for seed in range(3):
        s = Strategy(OFF_SWITCH_SPACE, budget=100, n_initial=10, seed=seed)
        seen = _watch_phases(s, off_switch_poor_subspace, workers=2)
        (r_sub, (ph, _)), = [(r, v) for r, v in seen.items() if v[0].frozen is not None]
        start, n = phases(s)[r_sub]
        end, bar = ph.trial
        assert ph.frozen == 2 and end == start + trial and n == trial + 1
        run_best = min(r["value"] for r in s.history[:start] if r["status"] == "ok")
        assert bar == pytest.approx(run_best - 1e-3 * abs(run_best))
        assert all(r["value"] >= bar for r in s.history[start:start + n])
        after, best_before = seen[r_sub + 1]   # back to the run's best point
        assert after.frozen is None and after.n_design == 0 and after.anchor == best_before["id"]
        assert s.best[0][2] == 70.0 and s.best[1] < 0.11
        good = Strategy(OFF_SWITCH_SPACE, budget=100, n_initial=10, seed=seed)
        seen = _watch_phases(good, off_switch_elsewhere, workers=2)
        (r_sub, (ph, _)), = [(r, v) for r, v in seen.items() if v[0].frozen is not None]
        start, n = phases(good)[r_sub]
        assert n == ph.end - start > trial + 1 and good.best[0][2] == 0.0


def test_no_subspace_phase_when_a_probe_improves():
    """A probe better than the run's best joins the run: the next phase goes on from it, no
    integer is held."""
    s = Strategy(OFF_SWITCH_SPACE, budget=80, n_initial=10, seed=1)
    held = []
    run_delayed(s, off_switch, watch=lambda s: held.append(s.phase.frozen))
    assert s.restarts.subspace_tried and set(held) == {None} and s.best[0][2] == 0.0


def test_a_strategy_saved_in_a_subspace_phase_proposes_the_same_after_restoring():
    for where in ("probes", "subspace"):
        s = Strategy(OFF_SWITCH_SPACE, budget=100, n_initial=10, seed=0)
        pending = []
        while (s.restarts.subspace_probes if where == "probes" else s.phase.frozen) is None:
            pending += s.ask(2 - len(pending))
            p = pending.pop(0)
            s.tell(p.id, off_switch_elsewhere(p.x))
        t = Strategy.from_state(json.loads(json.dumps(s.state_dict())))
        runs = []
        for u in (s, t):
            todo, out = list(pending), []
            while not u.done:
                todo += u.ask(2 - len(todo))
                p = todo.pop(0)
                u.tell(p.id, off_switch_elsewhere(p.x))
                out.append(p.x.tolist())
            runs.append(out)
        assert runs[0] == runs[1] and len(runs[0]) > 20
        assert s.best[0][2] == 0.0


def _composite(seed, **settings):
    s = Strategy(OFF_SWITCH_SPACE, budget=150, n_initial=10, seed=seed, composite=True,
                 **settings)
    s.set_aggregate(lambda F: F.sum(axis=1))
    return s


def _phase_stalled(s, r):
    """Whether phase r improved on the best of the phases before it by the tolerance."""
    vals = [[q["value"] for q in s.history if q["restart"] == k and q["status"] == "ok"]
            for k in range(r + 1)]
    before = min(min(v) for v in vals[:-1] if v)
    return not (vals[-1] and min(vals[-1]) < before - 1e-3 * abs(before))


def test_a_composite_run_takes_the_subspace_step_after_a_phase_that_found_nothing_better():
    """A composite surrogate restarts fresh, so with subspace_start "endgame" the
    probe-and-subspace step never comes and its runs stay near n = 70; with its default
    "stalled" the first restart after a fresh phase that did not improve on the run's best
    asks the probes of the run's best point, and the subspace phase behind the failed n = 0
    probe ends at n = 0's own optimum."""
    for seed in range(3):
        old = _composite(seed, subspace_start="endgame")
        seen_old = _watch_phases(old, as_outputs(off_switch_elsewhere), 2, outputs=True)
        assert all(ph.anchor is None for ph, _ in seen_old.values())
        assert old.best[0][2] == 70.0 and old.best[1] > 0.09
        s = _composite(seed)
        seen = _watch_phases(s, as_outputs(off_switch_elsewhere), 2, outputs=True)
        (r_probes,) = [r for r, (ph, _) in seen.items()
                       if ph.anchor is not None and ph.frozen is None and ph.n_design > 0]
        assert r_probes >= 2 and _phase_stalled(s, r_probes - 1)
        assert not any(_phase_stalled(s, r) for r in range(1, r_probes - 1))
        ph, _ = seen[r_probes + 1]
        assert ph.frozen == 2 and s.history[ph.anchor]["x"][2] == 0.0 and ph.trial is not None
        assert s.best[0][2] == 0.0 and s.best[1] < old.best[1]


def test_a_composite_run_whose_subspace_fails_its_trial_goes_on_from_its_best_point():
    """After a failed trial a composite run, like a scalar one, goes on from the run's best
    point (no design; the surrogate fits the run's points), not with a fresh design."""
    for seed in range(3):
        s = _composite(seed)
        seen = _watch_phases(s, as_outputs(off_switch_poor_subspace), 2, outputs=True)
        (r_sub,) = [r for r, (ph, _) in seen.items() if ph.frozen is not None]
        start, n = phases(s)[r_sub]
        assert n == fail_tol(3) + 1  # one more in flight
        after, best_before = seen[r_sub + 1]
        assert after.frozen is None and after.n_design == 0
        assert after.anchor == best_before["id"] and s.best[0][2] == 70.0
        assert len(s._prepare().surrogate.rbfs[0].X) > len([
            r for r in s.history if r["restart"] == s.restart])  # the run's points


def test_a_restart_policy_plugs_in_and_its_state_is_saved():
    p = problems.paper_size("levy")
    a = run_serial(Strategy(p.space, budget=90, n_initial=10, seed=3, restarts=ShortPhases()), p)
    b = run_serial(Strategy(p.space, budget=90, n_initial=10, seed=3), p)
    assert a.restart > b.restart and xs(a) != xs(b)
    d = a.state_dict()
    assert d["restarts"] == {"subspace_tried": a.restarts.subspace_tried,
                             "subspace_probes": None}
