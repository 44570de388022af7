"""Whether a run's ranking holds under the settlement law's uncertainty: the best design and the
reference re-predicted under the law's variants, and what that says in words."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..vti.response import SETTLEMENT_OBJECTIVES

CHECK_FILE = "law-variants.json"


def law_check(run, bi: int, ri: int | None, out: Path, echo=None) -> dict | None:
    """The best design and the reference re-predicted under the law's uncertainty (the eight
    variants of :func:`lccopt.degradation.variants.law_variants`): in how many the best design
    beats the reference on the run's settlement objectives.

    The predictions (16; a few seconds to minutes each) run side by side in processes of
    their own, one per core (:func:`lccopt.fanout.call_in_processes`), and are kept in
    ``out/law-variants.json`` under a key of the case, both designs and the version, read
    again by a later report.

    Parameters
    ----------
    run
        the run (its case loaded).
    bi, ri
        the best and the reference design's rows.
    out
        the report's folder.
    echo
        ``echo(text, err=False)``, how to say that the predictions run (default
        :func:`lccopt.terminal.echo`).

    Returns
    -------
    dict or None
        ``keys`` (the objectives compared), ``variants`` (label, best's and reference's
        objectives), ``beats`` (variants in which the best design is better in every key),
        ``verdict``; None when there is nothing to check (no settlement prediction, no
        reference, the best is the reference).
    """
    import hashlib
    import json

    from ..degradation.variants import law_variants
    from ..engine.executors import local_processes
    from ..fanout import call_in_processes
    from ..folder import read_owned
    from ..version import code_fingerprint

    case = run.case
    if case is None or case.degradation is None or ri is None or bi == ri:
        return None
    keys = [k for k in run.objectives if k in SETTLEMENT_OBJECTIVES] or ["level_d1_max"]
    spec = case.degradation_spec()
    variants = law_variants(spec)
    xb, xr = (np.asarray(run.x[i], float) for i in (bi, ri))
    key = hashlib.sha256(json.dumps([case.resolved, xb.tolist(), xr.tolist(), code_fingerprint(),
                                     [v[0] for v in variants]]).encode()).hexdigest()
    place = out / CHECK_FILE            # staged: written whole with the rest of the report
    path = place.shown                  # where the last report of this folder kept it
    try:
        kept = json.loads(read_owned(path, 10_000_000))
        if kept.get("key") == key:
            place.write_bytes((json.dumps(kept, indent=1) + "\n").encode())
            return _verdict(kept, keys)
    except (OSError, ValueError):       # none kept, or not a regular file of its own
        pass
    from ..terminal import echo as default_echo
    from ..terminal import wrap_message

    say = echo or default_echo
    calls = [(v, case.track_design(x)) for _, v in variants for x in (xb, xr)]
    processes = local_processes(len(calls))
    # a prediction costs about what a design cost the run: say how long to expect
    each = float(np.nanmedian(run.wall_time)) if np.isfinite(run.wall_time).any() else math.nan
    rounds = -(-len(calls) // processes)
    expect = (f", about {_duration(each * rounds)} at the run's {each:.0f} s a design"
              if math.isfinite(each) and each * rounds >= 60 else "")
    say(wrap_message(f"predicting the best and the reference design under {len(variants)} "
                     f"variants of the law ({len(calls)} predictions in {processes} process"
                     f"{'es' if processes > 1 else ''}{expect}, kept in {path})..."), err=True)
    predicted = iter(call_in_processes(_objectives, calls, processes))
    rows = [{"label": label, "best": next(predicted), "reference": next(predicted)}
            for label, _ in variants]
    kept = {"key": key, "variants": rows,
            "nominal": {"best": {k: float(run.obj[k][bi]) for k in keys if k in run.obj},
                        "reference": {k: float(run.obj[k][ri]) for k in keys if k in run.obj}}}
    place.write_bytes((json.dumps(kept, indent=1) + "\n").encode())
    return _verdict(kept, keys)


def _duration(seconds: float) -> str:
    """``4 min``, ``1.5 h``."""
    return f"{seconds / 60:.0f} min" if seconds < 5400 else f"{seconds / 3600:.1f} h"


def _objectives(spec, design) -> dict:
    """One design's settlement objectives under one variant of the law (a process's call)."""
    from ..degradation.assessment import predict, settlement_objectives

    o = settlement_objectives(predict(spec, design), spec.limit)
    return {k: float(o[k]) for k in o}


def _verdict(kept: dict, keys: list[str]) -> dict:
    """How often the best beats the reference: in every key (at least as good in all, better
    in one), and per key."""
    rows = kept["variants"]

    def better(r, k):
        return r["best"][k] < r["reference"][k]

    def beats(r):
        return (all(r["best"][k] <= r["reference"][k] for k in keys)
                and any(better(r, k) for k in keys))
    n = len(rows)
    wins = sum(beats(r) for r in rows)
    return {"keys": keys, "variants": rows, "nominal": kept.get("nominal", {}), "n": n,
            "beats": wins, "per_key": {k: sum(better(r, k) for r in rows) for k in keys},
            "within_uncertainty": wins <= n // 2}


def check_sentences(check: dict) -> list[str]:
    """The report's sentences on the law check."""
    n, wins, keys = check["n"], check["beats"], check["keys"]
    per = ", ".join(f"{k} in {v}" for k, v in check["per_key"].items())
    first = (f"Re-predicted under {n} variants of the law (each of its parameters 30 % lower "
             f"and higher, the other reading of the load history, the other law matched to "
             f"this one), the best design beats the reference design in "
             f"{' and '.join(keys)} in {wins} of {n} (each objective alone: {per}).")
    if check["within_uncertainty"]:
        return [first, "Not in most of them: the best design's gain is **within the model's "
                       "uncertainty**; the law cannot tell the two designs apart."]
    return [first, "In most of them: the ranking holds under the law's uncertainty (the "
                   "millimetres themselves remain the law's values, not a forecast)."]
