"""Robust objectives: statistics of an objective over a design's realisations of the track.

A design of a case with ``uncertainty:`` is simulated on the track as drawn (its objectives
keep their plain names: ``F_max``) and on each of the case's R realisations, the same ones
for every design (common random numbers). Realisation r's value of an objective is kept as
``F_max#r`` (r from 0). The robust objectives are named after the statistic:

* ``mean(F_max)``: the mean over the realisations;
* ``q90(F_max)``: the 90 % quantile (any whole percentage 1-99; linear interpolation between
  the order statistics, numpy's default), the value the design stays below on nine tracks
  out of ten;
* ``p_worse(F_max)``: the probability that the design does *not* beat the reference design
  on the same realisation (its value is not lower: ties count as not better), the fraction
  of the realisations; the probability of beating the reference design is 1 - p_worse. The
  reference design scores 1.

Any objective a case returns may be wrapped, a condition's too (``q90(F_max@fast)``). With
every realisation equal to the drawing (a coefficient of variation of 0), mean and quantiles
equal the plain objective exactly.
"""

from __future__ import annotations

import difflib
import math
import re

import numpy as np

# what a statistic's name looks like: mean(F_max), q90(E_max@fast), p_worse(F_max)
_NAME = re.compile(r"^(mean|q([1-9][0-9]?)|p_worse)\((.+)\)$")
STATISTIC_DOC = {  # {doc}: what the objective means
    "mean": "mean over the realisations of the track of {doc}",
    "quantile": "{level:g} % quantile over the realisations of the track of {doc}",
    "p_worse": "probability that {doc} is not below the reference design's, on a realisation "
               "of the track",
}
DEFAULT_QUANTILE = 0.9


def parse(name: str) -> tuple[str, str, float | None] | None:
    """``(kind, objective, level)`` of a statistic's name, else None.

    kind is ``mean``, ``quantile`` (level in (0, 1)) or ``p_worse``; e.g.
    ``parse("q90(F_max)") == ("quantile", "F_max", 0.9)``."""
    m = _NAME.match(str(name))
    if m is None:
        return None
    if m.group(2) is not None:
        return "quantile", m.group(3), int(m.group(2)) / 100.0
    return m.group(1), m.group(3), None


def is_statistic(name: str) -> bool:
    return parse(name) is not None


def describe(name: str, objective_doc: str) -> str:
    """What a statistic means, given what its objective means: ``90 % quantile over the
    realisations of the track of <objective_doc>``."""
    kind, _, level = parse(name)
    return STATISTIC_DOC[kind].format(doc=objective_doc, level=(level or 0) * 100)


def is_probability(name: str) -> bool:
    """Whether a name is a probability (``p_worse(F_max)``): shown against the reference
    design's value, not as a relative change (the reference design's p_worse is always 1)."""
    parsed = parse(name)
    return parsed is not None and parsed[0] == "p_worse"


def objective_of(name: str) -> str:
    """The objective a name measures: ``F_max`` for ``q90(F_max)`` or ``F_max#3``; the name
    itself otherwise."""
    parsed = parse(name)
    if parsed is not None:
        return parsed[1]
    return str(name).split("#")[0]


def realisation_key(objective: str, r: int) -> str:
    """``F_max#3``: realisation 3's value of an objective."""
    return f"{objective}#{int(r)}"


def is_realisation_key(name: str) -> bool:
    return "#" in str(name)


def quantile_name(objective: str, level: float) -> str:
    return f"q{int(round(level * 100))}({objective})"


def values(objectives: dict, objective: str, n: int) -> np.ndarray:
    """The n realisations' values of ``objective`` (NaN where missing)."""
    return np.array([float(objectives.get(realisation_key(objective, r), math.nan))
                     for r in range(n)], dtype=float)


def mean(v) -> float:
    """The mean, exact when every value is the same (v0 + the mean of the differences)."""
    v = np.asarray(v, dtype=float)
    v0 = float(v[0])
    return v0 + math.fsum(float(d) for d in v - v0) / v.size


def quantile(v, level: float) -> float:
    return float(np.quantile(np.asarray(v, dtype=float), level))


def p_worse(v, reference) -> float:
    """The fraction of realisations in which ``v`` is not below the reference design's."""
    v, ref = np.asarray(v, dtype=float), np.asarray(reference, dtype=float)
    return float(np.count_nonzero(~(v < ref))) / v.size


# Resamples of the paired bootstrap (the study's choices were judged with 2000): against
# 100000, the ends of its nine paper intervals moved by at most 6 % of their width, none
# across 0. A fixed generator makes the same tracks give the same interval.
RESAMPLES = 2000
CONFIDENCE = 0.95


def paired_difference(v, other, level: float | None,
                      confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    """(difference, low, high): the difference of a statistic (the quantile at ``level``, the
    mean for None) between two designs' values on the same realisations, ``v``'s minus
    ``other``'s, and its percentile-bootstrap interval at ``confidence``, the realisations
    resampled in pairs so that what the tracks share cancels (Efron & Tibshirani, "An
    introduction to the bootstrap", 1993, ch. 13). An interval wholly below 0 says ``v``'s
    design is clearly the lower on such tracks; the chance that it says so of two designs
    equally good is about (1 - confidence) / 2 with 16 values, more with fewer
    (benchmarks/robust/interval_calibration.py)."""
    a, b = np.asarray(v, dtype=float), np.asarray(other, dtype=float)
    if a.shape != b.shape or a.ndim != 1 or not a.size:
        raise ValueError("two designs' values on the same realisations are needed")

    def stat(x):
        return x.mean(axis=-1) if level is None else np.quantile(x, level, axis=-1)

    picks = np.random.default_rng(0).integers(0, a.size, (RESAMPLES, a.size))
    d = stat(a[picks]) - stat(b[picks])
    low, high = np.quantile(d, [(1 - confidence) / 2, (1 + confidence) / 2])
    return float(stat(a) - stat(b)), float(low), float(high)


def statistic(name: str, objectives: dict, n: int, reference: dict | None = None) -> float:
    """The value of the statistic ``name`` for a design's objectives (with its realisations'
    ``F_max#r``); ``reference``: the reference design's objectives (p_worse needs them:
    NaN without)."""
    kind, objective, level = parse(name)
    v = values(objectives, objective, n)
    if kind == "mean":
        return mean(v)
    if kind == "quantile":
        return quantile(v, level)
    if reference is None:
        return math.nan
    return p_worse(v, values(reference, objective, n))


def recorded(objectives) -> list[str]:
    """The statistics a run records for every design: the case's own first, then each
    objective the case names (bare or in a statistic) with its mean and its quantiles (those
    the case names, else 90 %). p_worse only where the case minimises it: it needs the
    reference design's result, which a design may otherwise finish before (the report
    computes it from the realisations)."""
    named = [k for k in objectives if is_statistic(k)]
    levels = sorted({parse(k)[2] for k in named if parse(k)[0] == "quantile"})
    levels = levels or [DEFAULT_QUANTILE]
    out = list(named)
    for k in objectives:
        base = objective_of(k)
        for s in [f"mean({base})", *(quantile_name(base, q) for q in levels)]:
            if s not in out:
                out.append(s)
    return out


def at_condition(name: str, condition: str) -> str:
    """``F_max@fast`` for ``F_max``, ``q90(F_max@fast)`` for ``q90(F_max)``: a case's
    objective for one traffic condition (conditions: each)."""
    parsed = parse(name)
    if parsed is None:
        return f"{name}@{condition}"
    return f"{name[:name.index('(')]}({parsed[1]}@{condition})"


class ObjectiveNames(tuple):
    """Objective names a case may list: each of these, alone or inside a statistic
    (``q90(F_max)``). Iterating gives the plain names (messages, the case reference)."""

    def __contains__(self, name) -> bool:
        if tuple.__contains__(self, name):
            return True
        parsed = parse(name) if isinstance(name, str) else None
        return parsed is not None and tuple.__contains__(self, parsed[1])

    def unknown(self, name: str) -> str:
        """What a message about the unknown ``name`` adds: the statistics' forms, and for a
        name shaped like one (``p_beat(F_max)``) the closest statistic."""
        text = "; or one of them in mean(...), q1(...) to q99(...) or p_worse(...)"
        m = re.match(r"^\s*([A-Za-z0-9_]+)\s*\((.*)\)\s*$", str(name))
        if m is None:
            close = difflib.get_close_matches(str(name), list(self), n=1, cutoff=0.6)
            return text + (f" (did you mean '{close[0]}'?)" if close else "")
        inner = m.group(2).strip()
        if not tuple.__contains__(self, inner):
            close = difflib.get_close_matches(inner, list(self), n=1, cutoff=0.6)
            if not close:
                return text
            inner = close[0]
        head = m.group(1)
        if not re.fullmatch(r"mean|q[1-9][0-9]?|p_worse", head):
            close = difflib.get_close_matches(head, ["mean", "q90", "p_worse"], n=1, cutoff=0.3)
            head = close[0] if close else "q90"
        return f"{text} (did you mean '{head}({inner})'?)"
