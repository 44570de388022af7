"""A run directory read for the report: evaluations, reference, case, histories; number formats."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..config.variables import Variable
from ..config.variables import named as named_variables
from ..uncertainty.statistics import is_probability
from ..vti.response import improvement_sign  # noqa: F401 (re-exported)
from ..vti.response import objective_display as obj_display
from .evaluations import (
    load_run_case,
    read_results,
    results_match,
    table_from_journal,
)

FORMATS = ("md", "html", "both")
# Okabe & Ito's colour-blind-safe palette (Color Universal Design, 2008): every pair stays
# distinguishable under the common colour-vision deficiencies.
OKABE_ITO = {"orange": "#E69F00", "sky": "#56B4E9", "green": "#009E73", "yellow": "#F0E442",
             "blue": "#0072B2", "vermillion": "#D55E00", "purple": "#CC79A7", "grey": "#999999"}
PHASE_STYLE = {  # phase -> (label, marker, colour)
    "initial": ("initial design (Latin hypercube)", "^", "0.35"),
    "adaptive": ("adaptive candidates (DYCORS)", "o", OKABE_ITO["blue"]),
    "random": ("random candidates", "s", OKABE_ITO["purple"]),
    "local": ("local search of the surrogate", "D", OKABE_ITO["sky"]),
}
REF_COLOR, BEST_COLOR, FAIL_COLOR, FRONT_COLOR = (OKABE_ITO["orange"], OKABE_ITO["blue"],
                                                  OKABE_ITO["vermillion"], OKABE_ITO["green"])
ZONE_COLOR, TYPE_II_COLOR = OKABE_ITO["yellow"], OKABE_ITO["purple"]


def colour_name(colour: str) -> str:
    """The palette's name of a colour ('yellow' for ZONE_COLOR): captions say what the figure
    draws, from the one place the figure takes it."""
    return {v: k for k, v in OKABE_ITO.items()}[colour]
DPI = 110

FIGURES = ("search-history", "objective-space", "best-vs-reference", "conditions", "contact-force",
           "sleeper-energy", "track-layout", "sensitivity", "settlement-history",
           "settlement-profile", "robust-spread")


def _usage(message: str) -> Exception:
    from ..errors import UsageError

    return UsageError(message)


# ================================================================================ reading

@dataclass
class RunData:
    path: Path
    rd: object                     # the run directory (engine.rundir.RunDir), held open
    name: str
    objectives: list[str]
    scalarisation: str
    budget: int
    names: list[str]
    variables: list[Variable]     # their words, units and bounds (lccopt.config.variables)
    ids: np.ndarray
    x: np.ndarray
    obj: dict                      # objective name -> array over evaluations (table order)
    value: np.ndarray
    status: np.ndarray
    reason: np.ndarray
    phase: np.ndarray
    restart: np.ndarray
    file: np.ndarray
    wall_time: np.ndarray
    pareto: np.ndarray
    ref_x: np.ndarray
    ref_objectives: dict
    ref_point: np.ndarray | None
    worst: np.ndarray | None
    rho: float | None
    improvement: float | None
    n_pending: int
    finished: bool
    state: str                     # finished | running | interrupted
    source: str                    # results.h5 | journal.jsonl
    case: object = None            # lccopt.config.Case when the run's case could be loaded
    case_note: str = ""
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)   # also said on the screen
    created: str = ""
    updated: str = ""
    sessions_wall: float = math.nan
    conditions: list[str] = field(default_factory=list)   # traffic conditions, in case order
    cond_obj: dict = field(default_factory=dict)   # condition -> objective name -> array
    # realisations of the track (a case with uncertainty:): count, objective -> (n, count)
    # array of each evaluation's values on each, and the run's record (seed, fingerprint)
    realisations: int = 0
    real_obj: dict = field(default_factory=dict)
    real_record: dict = field(default_factory=dict)
    run_mark: str = ""             # the run's identity (its first journal line's mark)

    @property
    def n(self) -> int:
        return len(self.ids)

    @property
    def ok(self) -> np.ndarray:
        return self.status == "ok"

    @property
    def multi(self) -> bool:
        return len(self.objectives) > 1

    def best_index(self) -> int | None:
        ok = np.flatnonzero(self.ok & np.isfinite(self.value))
        if not len(ok):
            return None
        return int(ok[np.lexsort((self.ids[ok], self.value[ok]))[0]])

    def setting_condition(self, objective: str, index: int | None) -> str | None:
        """The traffic condition whose value of ``objective`` is the largest for evaluation
        ``index``: the one that sets a worst case (None without conditions)."""
        first = self.cond_obj.get(self.conditions[0], {}) if self.conditions else {}
        if index is None or objective not in first:
            return None
        values = [float(self.cond_obj[c][objective][index]) for c in self.conditions]
        if not np.isfinite(values).any():
            return None
        return self.conditions[int(np.nanargmax(values))]

    def ref_index(self) -> int | None:
        """The reference design's evaluation (always proposal 0), or one with the same x."""
        hit = np.flatnonzero(self.ids == 0)
        if len(hit) and np.allclose(self.x[hit[0]], self.ref_x):
            return int(hit[0])
        same = np.flatnonzero(np.all(np.isclose(self.x, self.ref_x[None, :]), axis=1))
        return int(same[0]) if len(same) else None




def _lock_state(rd) -> str:
    """'running' while a process holds the run's flock, else 'stopped' (a PID in the file
    could have been reused by another program; the kernel's lock cannot lie)."""
    from ..engine.rundir import RunError

    try:
        return "running" if rd.locked_by_other() else "stopped"
    except RunError as exc:
        raise _usage(str(exc)) from None


def open_run(path: Path):
    """The run directory at ``path``, held open and checked as every command checks it
    (``RunDir.open``: no link or special file where the run keeps its own); UsageError if it is
    not one."""
    from ..engine.rundir import RunDir, RunError

    run = Path(path)
    if not run.exists():
        raise _usage(f"{run}: no such run directory")
    if not run.is_dir():
        raise _usage(f"{run}: not a directory (expected a run directory such as runs/<case name>)")
    rd = RunDir(run)
    try:
        folder = rd.folder
        if not folder.exists("results.h5") and not folder.exists("journal.jsonl"):
            raise RunError(f"{run}: not an lccopt run directory (no results.h5 or journal.jsonl)")
        rd.check_entries()
    except RunError as exc:
        rd.close()
        raise _usage(str(exc)) from None
    return rd


def load_run(path: Path) -> RunData:
    """Read a run directory (finished, running or interrupted); UsageError if it is not one."""

    from ..engine.journal import JournalError, line_mark, read_journal
    from ..engine.run import Run

    rd = open_run(path)
    run, folder = rd.path, rd.folder
    has_results = folder.exists("results.h5")
    has_journal = folder.exists("journal.jsonl")

    res = None
    res_error = ""
    if has_results:
        try:
            res = read_results((folder, "results.h5"))
        except (OSError, KeyError, ValueError, TypeError, MemoryError) as exc:
            res_error = f"{run / 'results.h5'} is unreadable ({type(exc).__name__}: {exc})"
    events: list[dict] = []
    journal_error = ""
    if has_journal:
        try:
            events, _, _ = read_journal((folder, "journal.jsonl"))
        except (JournalError, OSError) as exc:
            events = getattr(exc, "events", [])   # the lines before the damage
            if res is None and not events:
                raise _usage(f"{run}: cannot "
                             f"read the run: {res_error or 'no results.h5'}; {exc}") from None
            journal_error = (f"{exc}; the table is results.h5's, which may lag the run"
                             if res is not None else f"{exc}; the table holds the lines before it")
    if res is None and not events:
        raise _usage(f"{run}: cannot read the run: "
                     f"{res_error or 'no results.h5 and an empty journal'}")
    journal, why = None, None   # the run as its journal's committed lines describe it
    try:
        journal = Run.of(events)
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        why = exc

    journal_seq = events[-1]["seq"] if events else -1
    notes = [journal_error] if journal_error else []
    foreign = res is not None and events and not results_match(res, events, line_mark,
                                                                 bool(journal_error))
    if foreign:
        notes.append("results.h5 is not this run's (its identity does not match the journal's "
                     "lines: another run's file, or another state of this one); the table was "
                     "rebuilt from the journal")
        res = None
    if res is not None and (not events or journal_error or res["journal_seq"] >= journal_seq):
        d, source = res, "results.h5"
    else:
        try:
            if journal is None:
                raise why
            d = table_from_journal(rd, journal, res)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            if res is None:
                raise _usage(f"{run}: cannot read the run: {res_error or 'no results.h5'}; "
                             f"journal.jsonl: {type(exc).__name__}: {exc}") from None
            d, source = res, "results.h5"
        else:
            source = "journal.jsonl"
            if res is not None:
                notes.append("results.h5 lags the journal (it is rebuilt every few seconds while a "
                             "run goes, and a killed run may not have rebuilt it); the table was "
                             f"read from the journal's committed lines: {len(d['ids'])} "
                             f"evaluations, results.h5 had {len(res['ids'])}")
            elif res_error:
                notes.append(res_error + "; the table was rebuilt from journal.jsonl")
    if len(d["ids"]) == 0:
        raise _usage(f"{run}: nothing to report yet: no evaluation has finished")

    case, case_note = load_run_case(rd, d.get("resolved"))
    names = list(d["names"])
    if case is not None and case.names == names:
        variables = list(case.variables)
    else:
        if case is not None:
            case_note = "the run's case.yaml has other design variables than results.h5"
            case = None
        variables = named_variables(names, d["ref_x"])

    lock = _lock_state(rd)
    state = "finished" if d["finished"] else ("running" if lock == "running" else "interrupted")
    sessions = journal.session_walls if journal is not None else []
    created = d.get("created") or (events[0].get("time", "") if events else "")
    return RunData(
        path=run, rd=rd, name=d["name"] or run.name, objectives=list(d["objectives"]),
        scalarisation=d["scalarisation"], budget=int(d["budget"]), names=names, variables=variables,
        ids=d["ids"], x=d["x"], obj=d["obj"], value=d["value"], status=d["status"],
        reason=d["reason"],
        phase=d["phase"], restart=d["restart"], file=d["file"], wall_time=d["wall_time"],
        pareto=d["pareto"], ref_x=d["ref_x"], ref_objectives=d["ref_objectives"],
        ref_point=d["ref_point"],
        worst=d["worst"], rho=d["rho"], improvement=d["improvement"], n_pending=int(d["n_pending"]),
        finished=bool(d["finished"]), state=state, source=source, case=case, case_note=case_note,
        notes=notes, warnings=[journal_error] if journal_error else [], created=created,
        updated=d.get("updated", ""),
        sessions_wall=float(sum(sessions)) if sessions else math.nan,
        conditions=list(d.get("conditions", [])), cond_obj=d.get("cond_obj", {}),
        realisations=int(d.get("realisations", 0)), real_obj=d.get("real_obj", {}),
        real_record=d.get("real_record") or (events[0].get("realisations") if events else {})
        or {},
        run_mark=line_mark(events[0]) if events else d.get("run_mark", ""))




def read_history(run: RunData, index: int | None, condition: str | None = None
                 ) -> tuple[dict | None, dict, str]:
    """(histories, info, note) of evaluation ``index`` from its file (under traffic condition
    ``condition``, if given); histories None if unreadable."""
    from ..store import evaluation_problem, read_conditions, read_evaluation

    if index is None:
        return None, {}, "no evaluation"
    f = run.file[index]
    if not f:
        return None, {}, f"evaluation #{run.ids[index]} has no histories file"
    if f != f"evals/{int(run.ids[index]):06d}.h5":   # a crafted table: never a path out of the run
        return None, {}, f"evaluation #{run.ids[index]} names the file {f[:60]!r}, not its own"
    from ..engine.rundir import RunError

    try:
        p = run.rd.at(f)
    except (OSError, RunError) as exc:
        return None, {}, f"{f} is unreadable ({exc})"
    problem = evaluation_problem(p, int(run.ids[index]), run.x[index], run.run_mark)
    if problem is not None:
        why = f"{f} is {problem}" if problem in ("missing", "incomplete") else f"{f} {problem}"
        return None, {}, why
    try:
        ev = read_conditions(p).get(condition) if condition else read_evaluation(p)[1]
    except Exception as exc:  # noqa: BLE001 - a damaged file is a note, not a crash
        return None, {}, f"{f} is unreadable ({type(exc).__name__}: {exc})"
    if ev is None:
        return None, {}, f"{f} holds no condition {condition}"
    return ev.histories, ev.info, ""


# ================================================================================ formatting

def objective_change(k: str, new: float, old: float) -> str:
    """Objective k's change from OLD (the reference design's) to NEW: relative, as ``pct``;
    a probability's difference instead (``-0.75``), since its reference is always 1 and a
    relative change of a probability would read as another probability."""
    if not is_probability(k):
        return pct(new, old)
    if not (np.isfinite(new) and np.isfinite(old)):
        return "–"
    return "0" if new == old else f"{new - old:+.3g}"


def fnum(v: float, sig: int = 5) -> str:
    if v is None or not np.isfinite(v):
        return "–"
    if v == 0:
        return "0"
    a = abs(v)
    if 1e-3 <= a < 1e6:
        digits = max(0, sig - 1 - int(math.floor(math.log10(a))))
        return f"{v:,.{digits}f}".replace(",", " ")
    return f"{v:.{sig - 1}e}"


def pct(new: float, old: float) -> str:
    if not (np.isfinite(new) and np.isfinite(old)) or old == 0:
        return "–"
    if new == old:
        return "0 %"
    text = f"{(new - old) / abs(old) * 100:+.1f}"
    return "0.0 %" if text in ("+0.0", "-0.0") else f"{text} %"    # rounded to nothing: unsigned


def var_value(v: Variable, value: float) -> str:
    if not np.isfinite(value):
        return "–"
    if v.kind.length:                 # counted in 0.1 m elements, shown in m
        return f"{value * v.scale:.1f}"
    if v.integer:
        return f"{value:g}"
    return f"{value * v.scale:.4g}"


def with_unit(name: str, unit: str) -> str:
    """``F_max [kN]``; a dimensionless value (a probability, a count) without brackets."""
    return f"{name} [{unit}]" if unit else name


def value_label(run: RunData) -> tuple[float, str]:
    """(scale, axis label) of the value the optimiser minimised."""
    if run.multi:
        return 1.0, f"ASF value (Eq. 7) of {', '.join(run.objectives)} [-]"
    k = run.objectives[0]
    s, u = obj_display(k)
    return s, with_unit(k, u)
