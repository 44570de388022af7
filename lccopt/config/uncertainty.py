"""The ``uncertainty:`` section of a case: its checks, what it costs, and its realisations.

A case with this section describes how the built track departs from its drawing, sleeper by
sleeper (docs/robust.md): each listed quantity is a random field over the ballast sleepers
(:mod:`lccopt.uncertainty.fields`). ``draw`` turns the section and the run's seed into the
case's realisations, one :class:`lccopt.vti.specs.TrackVariation` each, once per loaded case
(the driver's draw is the one its workers receive: they never draw again). Every design is
simulated on the track as drawn and on each realisation, the same ones for every design
(common random numbers), so designs are compared on the same tracks and a resumed run meets
the same ones.

Values belong to sleepers counted outwards from the ERS on each side (the entry sleeper next
to the slab is number 0 whatever the design's spans), placed for the correlation at the
standard spacing from the slab edges: a design that moves its sleepers keeps their values.

Each quantity draws from a random stream of its own (seed, quantity, realisation), so a case
with more realisations or another quantity keeps the realisations it had.
"""

from __future__ import annotations

import hashlib

import numpy as np

from ..terminal import WIDTH
from ..uncertainty import fields
from ..uncertainty import statistics as stats
from ..vti.response import REPORTED_ONLY, SETTLEMENT_OBJECTIVES
from ..vti.specs import TrackVariation
from .checks import MAX_DESIGN_STEP_DOFS, simulation_size
from .schema_uncertainty import MAX_REALISATIONS

# the quantities of the section, in the order check prints them
QUANTITIES = ("support_stiffness", "support_damping", "pad_stiffness", "settlement_coefficient",
              "initial_void")
# one random stream per quantity (never renumbered: a run's realisations depend on them)
_STREAMS = {"support_stiffness": 1, "support_damping": 2, "pad_stiffness": 3,
            "initial_void": 4, "void_gap": 5, "settlement_coefficient": 6}
# Work of one design's simulations in all, its realisations included: ten times what one
# design of a deterministic case may take (MAX_DESIGN_STEP_DOFS, about 35 minutes), about six
# hours of one core. The realisations run as tasks of their own, so workers share them.
MAX_ROBUST_DESIGN_WORK = 10 * MAX_DESIGN_STEP_DOFS
# a uniform factor mean * (1 + sqrt(3) cov (2u - 1)) stays above 0.13 mean
MAX_UNIFORM_COV = 0.5


def seed_of(data: dict) -> int:
    """The seed the realisations are drawn from: ``uncertainty.seed``, else the optimisation's
    seed, else 0."""
    unc = data.get("uncertainty") or {}
    if unc.get("seed") is not None:
        return int(unc["seed"])
    return int((data.get("optimisation") or {}).get("seed") or 0)


def sleeper_slots(data: dict) -> tuple[np.ndarray, np.ndarray]:
    """Positions [m] of the entry and exit sleepers a realisation gives values to, each side
    from the slab outwards, at the standard spacing from the slab edges: as many entry
    sleepers as any design can have (its spans, then the standard spacing to the track's
    start), every exit sleeper (``lccopt.vti.track``'s layout)."""
    track = data["track"]
    lay = track["layout"]
    d = lay["sleeper_spacing"]
    x_a = lay["entry_length"]
    x_b = x_a + float(sum(track["ers"]["slab_lengths"]))
    total = x_b + lay["exit_length"]
    n_entry = int(data["design"]["sleeper_spans"]["count"]) + int(x_a / d + 1e-9)
    entry = x_a - d * np.arange(1, n_entry + 1)
    e = lay["exit_first_span"]
    exit_ = x_b + e + d * np.arange(int((total - x_b - e) / d + 1e-9) + 1)
    return entry, exit_[exit_ < total - 1e-9]


def draw(data: dict) -> tuple[TrackVariation, ...]:
    """The case's realisations (none without an ``uncertainty:`` section).

    Parameters
    ----------
    data
        a validated case (``check_uncertainty`` passed).

    Returns
    -------
    tuple of lccopt.vti.specs.TrackVariation
        one per realisation, in order.
    """
    unc = data.get("uncertainty")
    if not unc:
        return ()
    seed = seed_of(data)
    entry, exit_ = sleeper_slots(data)
    x = np.concatenate([entry, exit_])
    n = entry.size

    def split(values):
        v = np.asarray(values, dtype=float)
        return v[:n].copy(), v[n:].copy()

    def field(stream: str, r: int, correlation: float) -> np.ndarray:
        return fields.gaussian_field(x, correlation, fields.generator(seed, _STREAMS[stream], r))

    out = []
    for r in range(int(unc["realisations"])):
        values = {}
        stiffness_z = None
        q = unc.get("support_stiffness")
        if q is not None:
            stiffness_z = field("support_stiffness", r, q["correlation_length"])
            values["support_stiffness"] = split(
                fields.factors(stiffness_z, q["distribution"], 1.0, q["cov"]))
        q = unc.get("support_damping")
        if q is not None:
            z = (stiffness_z if stiffness_z is not None and q["field"] == "stiffness"
                 else field("support_damping", r, q["correlation_length"]))
            values["support_damping"] = split(fields.factors(z, q["distribution"], 1.0, q["cov"]))
        q = unc.get("pad_stiffness")
        if q is not None:
            z = field("pad_stiffness", r, q["correlation_length"])
            values["pad_stiffness"] = split(
                fields.factors(z, q["distribution"], q["mean"], q["cov"]))
        q = unc.get("settlement_coefficient")
        if q is not None:
            z = field("settlement_coefficient", r, q["correlation_length"])
            values["settlement"] = split(fields.factors(z, q["distribution"], 1.0, q["cov"]))
        q = unc.get("initial_void")
        if q is not None:
            hang = fields.hanging(field("initial_void", r, q["correlation_length"]),
                                  q["probability"])
            gap = fields.factors(field("void_gap", r, q["correlation_length"]), "lognormal",
                                 q["gap"], q["cov"])
            values["void"] = split(np.where(hang, gap, 0.0))
        out.append(TrackVariation(**values))
    return tuple(out)


def fingerprint(variations) -> str:
    """A short hash of the realisations' values: the same case and seed give the same one on
    any machine, and a run records it (a resume checks it)."""
    h = hashlib.sha256()
    for v in variations:
        for name in ("support_stiffness", "support_damping", "pad_stiffness", "void",
                     "settlement"):
            pair = getattr(v, name)
            h.update(name.encode())
            if pair is not None:
                for a in pair:
                    h.update(np.ascontiguousarray(a, dtype="<f8").tobytes())
    return h.hexdigest()[:16]


def record(case) -> dict:
    """What a run records of its realisations: their count, seed and fingerprint."""
    return {"count": case.realisations, "seed": seed_of(case.data),
            "fingerprint": fingerprint(case.variations)}


def check_uncertainty(data: dict, conditions: tuple, err) -> None:
    """Check the ``uncertainty:`` section and the robust objectives that need it.

    Parameters
    ----------
    data
        the validated case.
    conditions
        its traffic conditions (empty for a case without ``conditions:``).
    err
        ``err(key_path, message)`` -> the case error to raise, naming the file and line.

    Raises
    ------
    CaseError
        (from ``err``) the first problem found: a robust objective without the section, or of
        an objective that is reported only or needs ``degradation:``; a uniform spread that
        would make a factor negative; a settlement coefficient without a settlement
        prediction; a design whose realisations cost more than ``MAX_ROBUST_DESIGN_WORK``.
    """
    unc = data.get("uncertainty")
    objectives = (data.get("optimisation") or {}).get("objectives") or []
    at = ("optimisation", "objectives")
    for k in objectives:
        if not stats.is_statistic(k):
            continue
        base = stats.objective_of(k)
        if unc is None:
            raise err(at, f"{k} is a statistic over realisations of the track: it needs an "
                          f"uncertainty: section (docs/robust.md)")
        if base in REPORTED_ONLY:
            raise err(at, f"{base} is reported, not minimised: use maintenance_rate in {k}")
        if base in SETTLEMENT_OBJECTIVES and data.get("degradation") is None:
            raise err(at, f"{k}: {base} is an objective of a settlement prediction: it needs "
                          f"a degradation: section (docs/settlement.md)")
    if unc is None:
        return
    for name in QUANTITIES:
        q = unc.get(name)
        if q and q.get("distribution") == "uniform" and q["cov"] > MAX_UNIFORM_COV:
            raise err(("uncertainty", name, "cov"),
                      f"{q['cov']:g} is too wide for a uniform factor (at most "
                      f"{MAX_UNIFORM_COV:g}: a factor must stay positive); use lognormal")
    if not any(unc.get(name) for name in QUANTITIES):
        raise err(("uncertainty",), f"no quantity varies: list some of {', '.join(QUANTITIES)} "
                                    f"({{}} takes a quantity's defaults)")
    if unc.get("settlement_coefficient") is not None and data.get("degradation") is None:
        raise err(("uncertainty", "settlement_coefficient"),
                  "varies the settlement law of a settlement prediction: it needs a "
                  "degradation: section (docs/settlement.md)")
    per_design = design_work(data, conditions)
    n = int(unc["realisations"])
    if (n + 1) * per_design > MAX_ROBUST_DESIGN_WORK:
        raise err(("uncertainty", "realisations"),
                  f"{n} realisations and the track as drawn take {(n + 1) * per_design:.2g} "
                  f"steps x track dofs per design; at most {MAX_ROBUST_DESIGN_WORK:.0e} (about "
                  f"6 hours of one core per design): at most "
                  f"{most_realisations(data, conditions)} realisations here")


def most_realisations(data: dict, conditions: tuple) -> int:
    """The most realisations a design of this case may have: its simulations on them and on
    the drawing within ``MAX_ROBUST_DESIGN_WORK``, and no more than the section allows."""
    fit = int(MAX_ROBUST_DESIGN_WORK // design_work(data, conditions)) - 1
    return max(1, min(fit, MAX_REALISATIONS))


def design_work(data: dict, conditions: tuple) -> float:
    """Steps x track dofs of one design on one track (all its conditions; a settlement
    prediction at its most simulations)."""
    deg = data.get("degradation")
    sims = [c.data for c in conditions] or [data]
    extra = 1 + (deg["max_simulations"] if deg is not None else 0)
    return float(sum(s * d for s, d in (simulation_size(one) for one in sims))) * extra


def simulations_per_design(case) -> tuple[int, int]:
    """(tasks, simulations) of one design: the track as drawn and each realisation, times
    the conditions the engine splits a design into (a settlement prediction is one task of
    up to max_simulations + 1 simulations per condition)."""
    tracks = case.realisations + 1
    tasks = tracks * max(1, len(case.conditions))
    deg = case.degradation
    if deg is None:
        return tasks, tasks
    traffic = max(1, len(case.traffic))
    return tasks, tracks * traffic * (deg["max_simulations"] + 1)


def _field_text(q: dict, name: str, unc: dict) -> str:
    if name == "support_damping" and q["field"] == "stiffness" and unc.get("support_stiffness"):
        where = "support_stiffness's field"
    elif q["correlation_length"] > 0:
        where = f"correlation {q['correlation_length']:g} m"
    else:
        where = "independent"
    return where


def uncertainty_lines(case, *, cost: bool = True, budget: bool = True) -> list[str]:
    """The ``uncertainty:`` section as ``lccopt check`` prints it: the quantities, the seed,
    and the cost per design, the realisations the cost cap allows and the budget's cost.

    Parameters
    ----------
    case
        a loaded case with an ``uncertainty:`` section.
    cost
        False: the head line and the quantities only.
    budget
        False: without the budget's cost (a single design's command).

    Returns
    -------
    list of str
        lines of at most 80 columns, indented by two.
    """
    data = case.data
    unc = data["uncertainty"]
    n = case.realisations
    lines = [f"  uncertainty: {n} realisations of the track (seed {seed_of(data)}), the same "
             f"for every design:"]
    for name in QUANTITIES:
        q = unc.get(name)
        if q is None:
            continue
        if name == "initial_void":
            spread = f" (cov {q['cov']:g})" if q["cov"] else ""
            text = (f"{q['probability']:.0%} of the sleepers hang, gap {q['gap'] * 1e3:g} mm"
                    f"{spread}, {_field_text(q, name, unc)}")
        else:
            mean = f"mean {q['mean']:g}, " if q.get("mean", 1.0) != 1.0 else ""
            text = (f"{q['distribution']}, {mean}cov {q['cov']:g}, "
                    f"{_field_text(q, name, unc)}")
        lines.append(f"    {name}: {text}")
    if not cost:
        return lines
    tasks, sims = simulations_per_design(case)
    each = (f" x {len(case.conditions)} conditions" if case.conditions else "")
    designs = (case.optimisation or {}).get("budget") if budget else None
    head = f"    per design: {n + 1} tracks (the drawing and {n} realisations)"
    tail = f"{each} = {tasks} tasks" + (f", up to {sims:,} simulations" if sims != tasks else "")
    # the count on a line of its own where both would not fit an 80-column terminal
    if len(head + tail) <= WIDTH:
        lines.append(head + tail)
    else:
        lines += [head + ("" if each else ":"), "      " + tail.lstrip(" =")]
    most = most_realisations(data, case.traffic)
    lines.append(f"    at most {most} realisations: " + (
        "the section's limit" if most == MAX_REALISATIONS else
        "the cost cap, about 6 hours of one core a design"))
    if designs:
        lines.append(f"    budget {designs}: {designs * tasks:,} tasks" +
                     (f", up to {designs * sims:,} simulations" if sims != tasks else "") +
                     f" ({n + 1} x a deterministic run)")
    return lines

