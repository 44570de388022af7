"""The schedule rule (lccopt/engine/schedule.py) without processes: an event-driven stand-in
for the engine with k workers and random evaluation times. Whatever the times, the optimiser
gets the same calls in the same order, proposal n (the first of a block, with blocks of
q = batch_size(k, k) = k points) sees exactly the results 0..n-k-1, and a replay of the journal the
stand-in writes rebuilds the optimiser exactly."""

from __future__ import annotations

import heapq
import json
import random

import numpy as np
import pytest

from benchmarks.support import problems
from lccopt.engine.replay import Replay
from lccopt.engine.schedule import batch_size, may_ask, release
from lccopt.optim.space import DesignSpace
from lccopt.optim.strategy import Strategy


class Recording(Strategy):
    """A Strategy that logs its calls: ('ask', id, told ids at that moment) / ('tell', id)."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self.calls = []

    def ask(self, k=1):
        told = tuple(r["id"] for r in self.records if r["status"] != "pending")
        fresh = self.n_ahead == 0  # this call computes a block (or one point)
        out = super().ask(k)
        for p in out:
            self.calls.append(("ask", p.id, told, fresh))
        return out

    def tell(self, x_or_id, value, outputs=None):
        self.calls.append(("tell", int(x_or_id)))
        super().tell(x_or_id, value, outputs)

    def tell_failed(self, x_or_id, reason=""):
        self.calls.append(("fail", int(x_or_id)))
        super().tell_failed(x_or_id, reason)


def engine(strategy, fun, k, multi, timing_seed):
    """What Engine._fill/_ask/_record do, with simulated time; returns the journal events."""
    rng = random.Random(timing_seed)
    journal, results = [], {}
    running: list[tuple[float, int]] = []
    ahead, now = None, 0.0

    def log(event, **kw):
        journal.append({"seq": len(journal), "event": event, **kw})

    def ask():
        if strategy.done or not may_ask(strategy, k, multi):
            return None
        was = strategy.exhausted
        props = strategy.ask(1)
        if not props:
            if strategy.exhausted and not was:
                log("exhausted", n_asked=strategy.n_asked)
            release(strategy, k, multi, results.get)
            return None
        p = props[0]
        log("asked", id=p.id, x=[float(v) for v in p.x], phase=p.phase, restart=p.restart)
        release(strategy, k, multi, results.get)
        return p

    q = batch_size(k, k)
    strategy.set_batch(q)
    log("schedule", lag=k, batch=q)
    while True:
        while len(running) < k:
            if ahead is not None:
                p, ahead = ahead, None
            else:
                p = ask()
                if p is None:
                    break
            heapq.heappush(running, (now + rng.uniform(0.05, 2.0), p.id, p.x))
        if len(running) == k and ahead is None:
            ahead = ask()
        if not running:
            break
        now, i, x = heapq.heappop(running)
        v = fun(x)
        if i % 7 == 3 or not np.isfinite(v):
            results[i] = ("failed", "injected")
            log("failed", id=i, reason="injected")
        else:
            results[i] = ("ok", float(v))
            log("evaluated", id=i, value=float(v))
        release(strategy, k, multi, results.get)
    return journal


def told_before_each_ask(calls, k, multi):
    """Each call that computes proposals (a block's first) sees exactly results 0..n-k-1;
    the other points of a block are handed out whatever has been told since."""
    blocks = 0
    for c in calls:
        if c[0] == "ask" and c[3]:
            n, told = c[1], set(c[2])
            want = set(range(max(0, n - k)))
            if multi and n >= 1:
                want.add(0)
            assert told == want, (n, sorted(told), sorted(want))
            blocks += 1
    return blocks


@pytest.mark.parametrize("k,multi", [(1, False), (2, False), (2, True), (3, True), (4, False),
                                     (5, True)])
@pytest.mark.slow
def test_same_calls_whatever_the_timing(k, multi):
    p = problems.paper_size("levy")
    runs = []
    for timing in range(4):
        s = Recording(p.space, budget=45, n_initial=8, seed=7)
        journal = engine(s, p, k, multi, timing)
        assert s.done and s.n_told == 45 and not s.pending
        blocks = told_before_each_ask(s.calls, k, multi)
        q = batch_size(k, k)
        assert blocks < 45 if q > 1 else blocks == 45  # blocks of q: fewer fits than points
        # what the proposals depend on: each block's call with the results it saw, the tells
        # (in id order) and the points; a point handed out of a block may come before or
        # after a tell, as the workers finish
        blocks_seen = [c for c in s.calls if c[0] == "ask" and c[3]]
        tells = [c for c in s.calls if c[0] != "ask"]
        points = [e["x"] for e in journal if e["event"] == "asked"]
        runs.append((blocks_seen, tells, points, json.dumps(s.state_dict(), sort_keys=True)))
        # the journal's arrival order differs from run to run; its replay is exact
        r = Strategy(p.space, budget=45, n_initial=8, seed=7)
        rep = Replay(r, multi)
        for ev in journal:
            rep(ev)
        assert json.dumps(r.state_dict(), sort_keys=True) == runs[-1][-1]
    assert all(run == runs[0] for run in runs[1:])


def test_an_exhausted_integer_space_is_replayed_exactly():
    space = DesignSpace(["a", "b"], [0, 0], [3, 2], [True, True])  # 12 points, budget 20

    def fun(x):
        return float((x[0] - 2) ** 2 + (x[1] - 1) ** 2)

    states = set()
    for timing in range(3):
        s = Strategy(space, budget=20, n_initial=4, seed=3)
        journal = engine(s, fun, 2, False, timing)
        assert s.exhausted and s.n_asked == 12 and not s.pending
        assert [e["event"] for e in journal].count("exhausted") == 1
        states.add(json.dumps(s.state_dict(), sort_keys=True))
        # replayed from scratch and from a snapshot taken at every line
        for cut in range(0, len(journal) + 1, 3):
            part = Strategy(space, budget=20, n_initial=4, seed=3)
            rep = Replay(part, False)
            for ev in journal[:cut]:
                rep(ev)
            again = Strategy.from_state(json.loads(json.dumps(part.state_dict())))
            rep2 = Replay(again, False)
            for ev in journal[:cut]:
                rep2.note(ev)
            for ev in journal[cut:]:
                rep2(ev)
            assert json.dumps(again.state_dict(), sort_keys=True) == states.copy().pop()
    assert len(states) == 1
