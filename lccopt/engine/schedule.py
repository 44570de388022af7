"""When the optimiser may see a result, and when it may propose: the rule that makes a run
reproducible whatever the timing of the workers.

With a lag ``k`` (the number of workers of the session):

* results are told to the optimiser in evaluation-id order, and result ``i`` only once
  proposal ``i + k`` has been made (or no proposal is left: budget reached, space exhausted);
* proposal ``n`` waits until results ``0 .. n-k-1`` have been told.

So proposal ``n`` is computed from exactly the results of evaluations ``0 .. n-k-1``, with
``n-k .. n-1`` pending, whatever order the workers finish in: a result that arrives early is
held back until its turn, and a proposal waits for a late one. The sequence of optimiser calls
(ask 0 .. k-1, then ask n / tell n-k alternately) is a function of the results alone, so the
same case, seed, lccopt version and worker count give the same evaluations in the same order,
interrupted and resumed or not. ``k`` running plus one proposed ahead is the most a run can use
anyway (the engine asks one point ahead while every worker is busy), so a worker waits only
when an evaluation takes longer than the ones started after it have taken together.

Blocks: with ``optimisation.proposals_per_fit`` above 1 the optimiser computes its proposals
in blocks of ``q`` points (``batch_size``: q = that setting, at most k), one surrogate fit
and one scored candidate set per block (``Strategy.set_batch``). A proposal that opens a
block obeys the rule above; the others of the block were computed with it and are handed
out at once, waiting for nothing. So block
``b`` starting at proposal ``n`` is computed from exactly the results ``0 .. n-k-1``, and
its last point sees nothing newer (a lag of up to ``k + q - 1``): the price of one fit per
``q`` points, measured in benchmarks/RESULTS-scale.md (worse designs at the same number of
evaluations, so 1 is the default). The block size is a function of the case and the worker
count alone, never of timing.

Multi-objective cases: the reference design (evaluation 0) fixes the ASF reference point, so
its result is told as soon as it is there, and proposals 1, 2, ... wait for it.

The lag and the block size are journalled (``schedule`` line, at the start of a session whose
worker count differs from the journal's), so that a replay of the journal makes the same
calls.
"""

from __future__ import annotations

from typing import Callable, Optional

# (status, value or reason[, outputs]): ("ok", value), ("ok", value, objective vector) or
# ("failed", reason); None if not there yet
Result = Optional[tuple]


def batch_size(lag: int, per_fit: int = 1) -> int:
    """Points per block: the case's ``optimisation.proposals_per_fit``, at most ``lag`` (the
    workers, designs in flight)."""
    return max(1, min(int(per_fit), int(lag)))


def asks_over(strategy) -> bool:
    """No further proposal will be made (so every result may be told)."""
    return strategy.n_asked >= strategy.budget or strategy.exhausted


def may_tell(strategy, i: int, lag: int, multi: bool) -> bool:
    return i + lag < strategy.n_asked or (multi and i == 0) or asks_over(strategy)


def may_ask(strategy, lag: int, multi: bool) -> bool:
    """All results 0 .. n-lag-1 told (and, multi-objective, the reference design's); a point
    of a block already computed waits for nothing."""
    n = strategy.n_asked
    pending = strategy.pending
    if not pending:
        return True
    first = pending[0]  # records are in id order
    if multi and n >= 1 and first == 0:
        return False
    return strategy.n_ahead > 0 or first >= n - lag


def release(strategy, lag: int, multi: bool, result: Callable[[int], Result]) -> list[int]:
    """Tell the optimiser, in id order, every held result it may see now; return their ids."""
    told = []
    while True:
        pending = strategy.pending
        if not pending:
            break
        i = pending[0]
        r = result(i)
        if r is None or not may_tell(strategy, i, lag, multi):
            break
        if r[0] == "ok":  # with the objectives, if given, for a composite surrogate
            strategy.tell(i, r[1], r[2] if len(r) > 2 else None)
        else:
            strategy.tell_failed(i, r[1])
        told.append(i)
    return told
