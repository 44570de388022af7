"""Replays a golden journal (tests/data/golden/NAME) in a process of its own, started with the
pinned floating-point environment (conftest.pinned_numerics_env): the stopped run's journal,
then the stored rest of the run, each ``asked`` line checked against what the optimiser
proposes, from the journal alone and from a snapshot of the optimiser's state at the cut.

    python -m tests.engine.golden_check NAME        # exit 0 when both agree to the last bit
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from lccopt.config import load_case
from lccopt.engine.journal import line_mark
from lccopt.engine.replay import restore
from lccopt.problem import Problem

GOLDEN = Path(__file__).resolve().parents[1] / "data" / "golden"


def lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def check(name: str) -> None:
    prefix = lines(GOLDEN / name / "journal.jsonl")
    events = prefix + lines(GOLDEN / name / "continuation.jsonl")
    copy = GOLDEN / name / "case.yaml"     # the run's own copy: its lengths in 0.1 m elements
    pb = Problem.from_case(load_case(copy, text=copy.read_text(encoding="utf-8")))
    stopped, _ = restore(pb, prefix, None)
    snapshot = {"seq": len(prefix) - 1, "mark": line_mark(prefix[-1]),
                "strategy": json.loads(json.dumps(stopped.state_dict()))}
    resumed, table = restore(pb, events, snapshot)     # raises if a proposal is not reproduced
    replayed, _ = restore(pb, events, None)
    assert resumed.done and table.n_done == pb.budget, (table.n_done, pb.budget)
    state = lambda s: json.dumps(s.state_dict(), sort_keys=True)  # noqa: E731
    assert state(resumed) == state(replayed)


if __name__ == "__main__":
    check(sys.argv[1])
