"""A strategy's whole state as plain JSON types, and back (``Strategy.state_dict``).

Everything a proposal depends on is written: the space, budget, initial design size, seed,
settings, the random generator's state, every record (with told outputs), the queued design,
the points of the last block not handed out yet, the phase and its step counters, and the
restart policy's state. The caches (fitted RBFs' distance matrices), the aggregate and the
block size are not: they are set again by whoever restores
(``Strategy.set_aggregate``). A state of another format or version raises ValueError; the
run engine then rebuilds the strategy from the run's journal instead.
"""

from __future__ import annotations

import json

import numpy as np

from .restarts import Phase
from .settings import Settings
from .space import DesignSpace

STATE_FORMAT = "lccopt.optim.strategy"
STATE_VERSION = 2


def state_dict(s) -> dict:
    """The state of strategy ``s`` (floats round-trip exactly through json)."""
    return {
        "format": STATE_FORMAT,
        "version": STATE_VERSION,
        "space": s.space.to_dict(),
        "budget": s.budget,
        "n_initial": s.n_initial,
        "seed": s.seed,
        "settings": s.settings.to_dict(),
        "rng": s.rng.bit_generator.state,
        "records": [{**r, "x": [float(v) for v in r["x"]]} for r in s.records],
        "queue": [[float(v) for v in x] for x in s._queue],
        "exhausted": s.exhausted,
        # a block's points not handed out yet (absent in states of one-point asks)
        **({"ahead": [{**r, "x": [float(v) for v in r["x"]]} for r in s._ahead],
            "ahead_exhausted": s._ahead_exhausted} if s._ahead or s._ahead_exhausted else {}),
        "phase": s.phase.to_dict(),
        "steps": {"sigma": s.sigma, "n_fail": s._n_fail, "n_succ": s._n_succ,
                  "failed_row": s.failed_row, "n_adaptive": s._n_adaptive,
                  "w_index": s._w_index, "fbest": s._fbest_phase},
        "restarts": s.restarts.state_dict(),
    }


def from_state(cls, d: dict, candidates=None, restarts=None):
    """A strategy of class ``cls`` in the state ``d``."""
    if not isinstance(d, dict) or d.get("format") != STATE_FORMAT:
        raise ValueError("not an lccopt strategy state")
    if d.get("version") != STATE_VERSION:
        raise ValueError(f"unsupported strategy state version {d.get('version')}")
    s = cls.__new__(cls)
    s._setup(DesignSpace.from_dict(d["space"]), int(d["budget"]), int(d["n_initial"]),
             d["seed"], Settings.from_dict(d["settings"]), candidates, restarts)
    bg = getattr(np.random, d["rng"]["bit_generator"])()
    bg.state = d["rng"]
    s.rng = np.random.Generator(bg)
    s.records = [{**r, "x": np.array(r["x"], dtype=float)} for r in d["records"]]
    s._queue = [np.array(x, dtype=float) for x in d["queue"]]
    s.exhausted = bool(d["exhausted"])
    s._ahead = [{**r, "x": np.array(r["x"], dtype=float)} for r in d.get("ahead", [])]
    s._ahead_exhausted = bool(d.get("ahead_exhausted", False))
    s.phase = Phase.from_dict(d["phase"])
    st = d["steps"]
    s.sigma = float(st["sigma"])
    s._n_fail, s._n_succ = int(st["n_fail"]), int(st["n_succ"])
    s.failed_row = int(st["failed_row"])
    s._n_adaptive, s._w_index = int(st["n_adaptive"]), int(st["w_index"])
    s._fbest_phase = None if st["fbest"] is None else float(st["fbest"])
    s.restarts.load_state_dict(d["restarts"])
    return s


def save(s, path) -> None:
    """Atomic write: temporary file in the same directory, fsync, rename."""
    from ..folder import write_owned

    write_owned(path, json.dumps(state_dict(s), allow_nan=False).encode("utf-8"))


def load(cls, path):
    """The strategy (of class ``cls``) saved at ``path``."""
    with open(path, encoding="utf-8") as fh:
        return from_state(cls, json.load(fh))
