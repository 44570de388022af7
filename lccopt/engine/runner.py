"""The main job: ``lccopt optimise CASE`` and ``lccopt resume RUN``.

One process (this one) runs the ask/tell loop and is the only writer of the journal,
the state snapshot and results.h5. Workers evaluate designs (and, in the local pool,
write their own immutable ``evals/NNNNNN.h5`` before reporting back).

Commit protocol, per evaluation ``i``:

1. ``asked`` line (id, x, phase, restart) after ``strategy.ask`` returned the proposal;
2. the worker writes ``evals/00000i.h5`` (tmp + rename: complete whatever kill -9 interrupts;
   not fsynced, one file per evaluation being more than a disk's fsync rate allows at
   scale: a file a power cut damaged is found by the resume, which simulates it again);
3. ``evaluated`` (objectives, scalar value, wall time, worker, file) or ``failed`` (reason)
   line when the outcome arrives; ``strategy.tell`` (value and objective vector, which the
   composite surrogate of a multi-objective run fits) / ``tell_failed`` when its turn comes:
   results are told in id order, result ``i`` once proposal ``i + k`` is made (k = workers;
   ``schedule.py``), so proposal ``n`` sees exactly results ``0 .. n-k-1`` whatever the timing;
4. every few seconds: ``state.json`` (strategy state + the journal seq it reflects) and
   ``results.h5`` (rebuilt from the journal), both atomic.

Journal lines are handed to the operating system before the evaluations they start (they
survive kill -9) and fsynced together at least every ``SYNC_EVERY`` seconds and before a
snapshot (a power cut loses at most the last second: those evaluations run again).

The optimiser calls are a fixed function of the journal lines (``Replay``: each ``asked`` or
``exhausted`` line is an ask, a result is told as the schedule rule allows after each line,
with the lag of the session's ``schedule`` line), so the optimiser state after any committed
line is the snapshot plus a replay of the lines after it (``ask`` must give back the logged
point, which is checked). Resume re-runs the ``asked`` ids without a result. With the same
worker count the sequence of calls, and so the run, is the same as without the interruption,
and the same from one run to the next.

For two or more objectives the reference design (always proposal 0) runs alone first: its
objectives fix the ASF reference point (``reference`` line) before any value is computed.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import typer

from .. import machine
from ..config import SAFE_NAME, Case, design_items, load_case
from ..errors import CaseError, EnvironmentFault, UsageError, describe_os_error, environment_errno
from ..problem import Problem
from ..terminal import PipeGuard, wrap_items
from .executors import ExecutorError, make_executor
from .journal import Journal, JournalError, line_mark, read_journal
from .progress import Progress, fmt, hms, objective_text, objective_value, reference_objectives
from .rundir import (
    RunDir,
    RunError,
    Table,
    eval_name,
    now_iso,
    sha256_text,
    versions,
    write_results,
)
from .schedule import batch_size, may_ask, release
from .worker import RENAMED_EVALUATORS, Outcome, Task, evaluator_spec

RESULTS_EVERY = 10.0  # [s] results.h5 is rebuilt at most this often while running (and at the end)
SNAPSHOT_EVERY = 5.0  # [s] state.json likewise; resume replays the journal lines after it
SYNC_EVERY = 1.0      # [s] the journal is fsynced at least this often (a power cut loses less)


def _usage_error(message: str) -> Exception:
    return UsageError(message)


def _fault(exc: BaseException, rd: RunDir) -> EnvironmentFault:
    return EnvironmentFault(f"{describe_os_error(exc)}; the run stopped with nothing lost "
                            f"(evaluations in flight stay pending): fix the cause, then "
                            f"'lccopt resume {rd.path}'")


# ------------------------------------------------------------------------------ public API

def optimise(case, workers: int | None = None, scheduler=None, runs: Path = Path("runs"),
             force: bool = False, *, evaluator=None, progress: bool = True, stream=None) -> Path:
    """Start a run of CASE in ``runs/<case name>/``; return the run directory.

    Raises CaseError (bad case), UsageError (bad options, run exists or is locked),
    typer.Exit(130) after an interruption (the run is saved and resumable).
    """
    case_obj = case if isinstance(case, Case) else load_case(case)
    problem = Problem.from_case(case_obj)
    _check_options(workers, scheduler)
    spec = evaluator_spec(evaluator)
    run_path = Path(runs) / case_obj.name
    if not SAFE_NAME.fullmatch(case_obj.name):  # load_case checks it too: never '.', '..' or a path
        raise _usage_error(f"case name {case_obj.name!r} cannot name a run directory")
    _check_runs_folder(Path(runs))
    if os.path.lexists(run_path) and not run_path.is_dir():
        raise _usage_error(f"{run_path} is {_kind(run_path)}, not a run directory: move it, or "
                           f"give the case another name")
    if run_path.exists() or run_path.is_symlink():
        if not force:
            raise _usage_error(f"{run_path} already exists: carry it on with "
                               f"'lccopt resume {run_path}', or start again with "
                               f"'lccopt optimise {case_obj.path} --force'")
        _check_replaceable(run_path, Path(runs))
    executor = _start_executor(case_obj, spec, workers, scheduler, problem,
                               Progress(0, stream, progress).log)
    try:
        if run_path.exists():
            old = RunDir(run_path)
            if (run_path / "lock").exists():
                old.lock()  # refuse to delete a run another process is driving
            shutil.rmtree(run_path)
            old.unlock()
        rd = RunDir.create(run_path, case_obj, problem,
                           spec if isinstance(spec, str) else repr(spec))
        rd.lock()
    except BaseException as exc:
        executor.close()
        if isinstance(exc, RunError):
            raise _usage_error(str(exc)) from None
        raise
    try:
        journal, events, _ = Journal.open(rd.journal_path)
        strategy, table = restore(problem, events, None)
        engine = Engine(rd, case_obj, problem, journal, table, strategy, executor,
                        Progress(problem.budget, stream, progress))
        engine.run()
    except (ExecutorError, JournalError) as exc:
        raise _usage_error(str(exc)) from None
    finally:
        executor.close()
        rd.unlock()
    return rd.path


def _kind(path: Path) -> str:
    from ..safeio import kind_of

    try:
        if path.is_symlink() and not path.exists():
            return "a symbolic link that leads nowhere (a loop or a missing target)"
        return "a regular file" if path.is_file() else kind_of(os.lstat(path).st_mode)
    except OSError as exc:  # e.g. a symbolic link loop
        return f"unusable ({exc.strerror or exc})"


def _check_runs_folder(runs: Path) -> None:
    """--runs must be a folder (or one that can be made): never a file, a device or a loop."""
    if not os.path.lexists(runs):
        return
    try:
        if runs.is_dir():
            return
    except OSError:
        pass
    raise _usage_error(f"--runs {runs} is {_kind(runs)}, not a folder for run directories")


def _check_replaceable(run_path: Path, runs: Path) -> None:
    """``--force`` removes only an lccopt run directory that sits directly inside ``--runs``."""
    from .rundir import RUN_FORMAT

    if (run_path.is_symlink() or not run_path.is_dir()
            or run_path.resolve().parent != runs.resolve()):
        raise _usage_error(f"{run_path} is not a run directory inside {runs}; --force only "
                           f"replaces lccopt run directories: move or remove it yourself")
    try:
        meta = RunDir(run_path).meta()
    except RunError:
        meta = None
    if not isinstance(meta, dict) or meta.get("format") != RUN_FORMAT:
        raise _usage_error(f"{run_path} is not an lccopt run directory (no readable run.json of "
                           f"lccopt); --force only replaces run directories: move or remove it "
                           f"yourself")


def _start_executor(case, spec, workers, scheduler, problem, log=None):
    try:
        executor = make_executor(case, spec, workers, scheduler, problem.timeout)
        executor.start(log)
    except ExecutorError as exc:
        raise _usage_error(str(exc)) from None
    return executor


def resume(run, workers: int | None = None, scheduler=None, case=None,
           allow_changed_case: bool = False, budget: int | None = None, *, evaluator=None,
           progress: bool = True, stream=None) -> Path:
    """Carry on the run in directory RUN; see the module docstring."""
    _check_options(workers, scheduler)
    out = Progress(0, stream, progress)
    try:
        rd = RunDir.open(Path(run))
        rd.lock()
    except RunError as exc:
        raise _usage_error(str(exc)) from None
    try:
        meta = rd.meta()
        if not isinstance(meta, dict):
            raise RunError(f"{rd.meta_path}: not an lccopt run description")
        events, _, _ = read_journal(rd.journal_path)
        if not events or events[0].get("event") != "run":
            n = len(list(rd.evals_path.glob("*.h5"))) if rd.evals_path.is_dir() else 0
            raise RunError(f"{rd.journal_path} is empty or does not start with the run's first "
                           f"line: this run cannot be carried on safely ({n} evaluation file(s) "
                           f"kept as they are); restore the journal, or start a new run under "
                           f"another name")
        journal, events, torn = Journal.open(rd.journal_path)
        if torn:
            out.log("dropped a torn last line of the journal (the run was killed while writing "
                    "it)")
        case_obj = _resume_case(rd, meta, case, allow_changed_case, out, budget)
        problem = Problem.from_case(case_obj)
        if events and events[0].get("objectives") not in (None, list(problem.objectives)):
            raise _usage_error(f"the case's objectives {list(problem.objectives)} differ from the "
                               f"run's {events[0]['objectives']}; start a new run instead")
        asked = sum(ev.get("event") == "asked" for ev in events)
        if problem.budget < asked:
            raise _usage_error(f"the case's budget of {problem.budget} is below the {asked} "
                               f"evaluations the run has already asked for; give a budget of at "
                               f"least {asked}")
        if meta.get("case_sha256") != sha256_text(case_obj.resolved):
            extra = ({"worst": list(problem.worst), "rho": problem.rho}
                     if problem.multi and problem.worst else {})
            ev = journal.append("case_changed", time=now_iso(),
                                case_sha256=sha256_text(case_obj.resolved),
                                budget=problem.budget, case_file=str(case_obj.path), **extra)
            events.append(ev)
            rd.write_case(case_obj.resolved)
            meta.update(case_sha256=sha256_text(case_obj.resolved),
                        case_file=str(Path(case_obj.path).resolve()),
                        overrides=list(getattr(case_obj, "overrides", ())))
            rd.write_meta(meta)
        strategy, table = restore(problem, events, rd.load_state())
        # never the evaluator run.json names: a run directory from elsewhere must not choose
        # code to run; the testing hook ($LCCOPT_EVALUATOR) or the simulator
        spec = evaluator_spec(evaluator)
        started = RENAMED_EVALUATORS.get(meta.get("evaluator"), meta.get("evaluator"))
        if isinstance(spec, str) and isinstance(started, str) and started != spec:
            out.log(f"the run was started with evaluator {meta['evaluator'][:60]!r}; carrying on "
                    f"with {spec!r}")
        removed = rd.clean(pending={eval_name(i) for i in table.pending_ids()})
        if removed:
            out.log(f"removed {len(removed)} temporary or unfinished file(s): "
                    f"{', '.join(removed[:5])}{' ...' if len(removed) > 5 else ''}")
        lost = _lost_files(rd, table)
        if strategy.done and not table.pending_ids() and not lost:
            if not table.finished:
                table.apply(journal.append("finished", time=now_iso(), evaluations=table.n_done))
            write_results(rd.results_path, table, case=case_obj, problem=problem, meta=meta)
            best = table.best()
            out.log(f"{rd.path} is finished: {table.n_done} evaluations ({table.n_failed} failed); "
                    "nothing to do")
            if best:
                out.log(f"best #{best['id']} value {fmt(best['value'])}")
            return rd.path
        note = machine.resume_note(events[0].get("versions"), versions())
        if note:
            out.log(note)
        executor = _start_executor(case_obj, spec, workers, scheduler, problem, out.log)
        try:
            engine = Engine(rd, case_obj, problem, journal, table, strategy, executor,
                            Progress(problem.budget, stream, progress))
            engine.restore_files(lost, out)
            engine.run()
        finally:
            executor.close()
    except (ExecutorError, JournalError, RunError) as exc:
        raise _usage_error(str(exc)) from None
    finally:
        rd.unlock()
    return rd.path


def _lost_files(rd: RunDir, table: Table) -> list[int]:
    """Ids of evaluations whose file the journal names but which is missing, unreadable or not
    theirs (another evaluation's file copied over it): each is simulated again."""
    from ..store import evaluation_problem

    return [i for i, r in sorted(table.rows.items()) if r["status"] == "ok" and r["file"]
            and evaluation_problem(rd.path / r["file"], i, r["x"]) is not None]


def _check_options(workers, scheduler) -> None:
    if workers is not None and workers < 1:
        raise _usage_error(f"--workers must be at least 1, got {workers}")
    if workers is not None:
        from .executors import max_local_workers

        most, why = max_local_workers()
        if workers > most:
            shown = str(workers) if len(str(workers)) <= 12 else f"{str(workers)[:8]}..."
            raise _usage_error(f"--workers {shown}: at most {most} local workers fit here ({why}); "
                               f"use fewer, or --scheduler")
    if workers is not None and scheduler is not None:
        raise _usage_error("--workers and --scheduler exclude each other (the Dask cluster decides "
                           "how many evaluations run at once)")


def _resume_case(rd: RunDir, meta: dict, case, allow_changed: bool, out: Progress,
                 budget: int | None = None) -> Case:
    """The case to carry on with: the original file with the run's --set overrides (must
    resolve as the run's case did) or the run's copy; ``budget``: a new budget on top."""
    if case is None:
        original = Path(meta.get("case_file", ""))
        if meta.get("case_file") and original.is_file():
            case = original
        else:
            out.log(f"the case file {original} is gone; using the run's copy {rd.case_path}")
            case = rd.case_path
    overrides = [o for o in meta.get("overrides") or [] if isinstance(o, str)]
    case_obj = case if isinstance(case, Case) else load_case(case, overrides)
    if budget is not None and sha256_text(case_obj.resolved) == meta.get("case_sha256"):
        # the same case with another budget: the one change --budget asks for
        case_obj = load_case(case_obj.path, [*overrides, f"optimisation.budget={int(budget)}"])
        allow_changed = True
    if sha256_text(case_obj.resolved) != meta.get("case_sha256"):
        if not allow_changed:
            raise _usage_error(
                f"the case file {case_obj.path} or a file it reads (extends, irregularity) "
                f"changed since the run started (the resolved case differs from {rd.case_path}); "
                f"restore it, resume with --case {rd.case_path} (the run's copy), or with "
                f"--allow-changed-case to use the changed case")
        old_case = load_case(rd.case_path)
        old, new = Problem.from_case(old_case), Problem.from_case(case_obj)
        if not old.same_space(new):
            raise _usage_error(f"the changed case {case_obj.path} has other design variables, "
                               f"bounds, scales, reference design or objectives; start a new run "
                               f"instead")
        refused = [k for k in changed_keys(old_case.data, case_obj.data)
                   if k not in HONOURED_CHANGES]
        if refused:
            raise _usage_error(f"{case_obj.path}: {refused[0]} changed since the run started; only "
                               f"budget, timeout, asf.worst and asf.rho may: start a new run")
        out.log(f"carrying on to a budget of {budget} (--budget)" if budget is not None else
                f"the case file {case_obj.path} changed since the run started: carrying on with it "
                f"(--allow-changed-case)")
    return case_obj


# What a run can carry on with when its case changed: how far it goes and how long an
# evaluation may take, and the ASF's worst values and rho (journalled, so a replay scores the
# later evaluations as the run did). Anything else (the seed, the initial design, the track,
# the simulation) would make the run's evaluations disagree with its case.
HONOURED_CHANGES = ("optimisation.budget", "optimisation.timeout", "optimisation.asf.worst",
                    "optimisation.asf.rho", "description")


def changed_keys(old, new, path: str = "") -> list[str]:
    """Dotted key paths whose values differ between two resolved cases."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in list(old) + [k for k in new if k not in old]:
            out += changed_keys(old.get(k), new.get(k), f"{path}.{k}" if path else k)
        return out
    return [] if old == new else [path]


# ------------------------------------------------------------------------------ restore

def restore(problem: Problem, events: list[dict], snapshot: dict | None):
    """Optimiser and table after the journal's events (snapshot + replay of the rest).

    The optimiser is built with the settings the run recorded (``recorded_settings``). The
    snapshot is a cache: one made with other settings, or that does not replay (stale,
    foreign, from another version), is dropped and the whole journal replayed."""
    seq = snapshot.get("seq") if isinstance(snapshot, dict) else None
    if (isinstance(seq, int) and 0 <= seq < len(events)
            and snapshot.get("mark") == line_mark(events[seq])):
        try:
            strategy, table = _restore(problem, events, snapshot)
            if _agrees(strategy, table):
                return strategy, table
        except JournalError:
            pass
    return _restore(problem, events, None)


def _agrees(strategy, table: Table) -> bool:
    """The optimiser restored from a snapshot holds exactly the journal's proposals, and the
    results it was told are the journal's (a snapshot that claims a line it does not reflect
    would otherwise carry on from another state)."""
    history = strategy.history
    if len(history) != len(table.rows):
        return False
    for rec in history:
        row = table.rows.get(rec["id"])
        if row is None or not np.array_equal(np.asarray(row["x"], dtype=float), rec["x"]):
            return False
        if rec["status"] != "pending" and (rec["status"] != row["status"] or (
                row["status"] == "ok" and rec["value"] != row["value"])):
            return False
    return True


def _restore(problem: Problem, events: list[dict], snapshot: dict | None):
    from ..optim.strategy import Strategy

    table = Table(list(problem.names), list(problem.objectives))
    for ev in events:
        try:
            table.apply(ev)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            seq = ev.get("seq")
            line = seq + 1 if isinstance(seq, int) else "?"
            raise JournalError(f"journal line {line} is not a valid event "
                               f"({type(exc).__name__}: {exc}); the journal was changed by "
                               f"something other than lccopt") from None
    first = events[0] if events else {}
    settings = recorded_settings(problem, first) if events else problem.optimiser_settings()
    strategy, start = None, 0
    if snapshot is not None and 0 <= snapshot["seq"] < len(events):
        try:
            strategy = Strategy.from_state(snapshot["strategy"])
            start = int(snapshot["seq"]) + 1
        except Exception:  # noqa: BLE001 - a stale or foreign snapshot: replay everything
            strategy = None
        if strategy is not None and strategy.settings != settings:
            strategy = None
    if strategy is None:
        strategy = problem.strategy(budget=first.get("budget", problem.budget), settings=settings)
        start = 0
    elif not problem.multi:  # not part of the state (for E_max alone: sleeper_energy_spread)
        strategy.set_aggregate(problem.aggregate(None))
    replayer = Replay(strategy, problem.multi, problem)
    for ev in events[:start]:  # what the snapshot already reflects: results held back, the lag
        replayer.note(ev)
    for ev in events[start:]:
        replayer(ev)
    return strategy, table


# A first line with "optimiser": 12 (a number instead of the settings) was written by the last
# lccopt that did not record its settings; today's defaults make the proposals of its runs.
_UNRECORDED_DEFAULTS = 12


def recorded_settings(problem: Problem, first: dict):
    """The optimiser settings of the run whose journal's first line is ``first``.

    The line records them (``"optimiser"``: the settings' dict); a line that says
    ``"optimiser": 12`` instead means today's default settings for the recorded surrogate.
    Any other run (another number, no settings, or settings this lccopt does not have)
    raises JournalError naming the lccopt version that made it."""
    from ..optim.settings import Settings

    rec = first.get("optimiser")
    if isinstance(rec, dict):
        try:
            return Settings.from_dict(rec)
        except ValueError as exc:
            raise JournalError(f"{_made_by(first)} with optimiser settings this lccopt does not "
                               f"have ({exc}): resume it with that version") from None
    if type(rec) is int and rec == _UNRECORDED_DEFAULTS:
        return Settings.default(composite=first.get("surrogate", "scalar") != "scalar")
    what = ("no optimiser settings" if rec is None
            else f"\"optimiser\": {rec!r} instead of its settings")
    raise JournalError(f"{_made_by(first)} (its journal names {what}), whose proposals this "
                       f"lccopt does not make: resume it with that version")


def _made_by(first: dict) -> str:
    versions = first.get("versions")
    version = versions.get("lccopt") if isinstance(versions, dict) else None
    if not (isinstance(version, str) and re.fullmatch(r"[\w.+-]{1,30}", version)):
        version = None   # a crafted journal shows nothing of its own on the terminal
    when = str(first.get("time", ""))[:10]
    if not re.fullmatch(r"\d{4}-\d{2}-\d{2}", when):
        when = ""
    return (f"this run was made by lccopt {version or '(version unknown)'}"
            + (f" on {when}" if when else ""))


class Replay:
    """Makes the optimiser calls that the engine made for each journal line (see schedule.py:
    results are told in id order, each once the proposal ``lag`` ids later has been made;
    the lag is the one of the session's ``schedule`` line).

    With the problem given, results are told with their objective vectors, and the optimiser's
    aggregate (the ASF, for a composite surrogate) is set as the engine set it: from the
    ``reference`` line (point, worst, rho) and from any ``case_changed`` line that records
    other worst values or rho."""

    def __init__(self, strategy, multi: bool, problem=None):
        self.strategy, self.multi, self.problem = strategy, multi, problem
        self.lag: int | None = None  # until the first schedule line
        self.results: dict[int, tuple] = {}
        self.asf: dict | None = None  # point, worst, rho of the aggregate in force

    def outputs(self, ev: dict):
        if self.problem is None:
            return None
        return self.problem.outputs(ev.get("objectives") or {}, ev.get("parts"))

    def note(self, ev: dict) -> None:
        kind = ev["event"]
        if kind == "evaluated":
            self.results[ev["id"]] = ("ok", ev["value"], self.outputs(ev))
        elif kind == "failed":
            self.results[ev["id"]] = ("failed", ev.get("reason", ""))
        elif kind == "schedule":
            self.lag = int(ev["lag"])
            self.strategy.set_batch(int(ev.get("batch", 1)))
        elif kind == "reference" and self.problem is not None:
            self.asf = {"point": ev["point"], "worst": ev.get("worst"), "rho": ev.get("rho")}
            self._set_aggregate()
        elif kind == "case_changed" and self.asf is not None and ("worst" in ev or "rho" in ev):
            self.asf.update({k: ev[k] for k in ("worst", "rho") if k in ev})
            self._set_aggregate()

    def _set_aggregate(self) -> None:
        a = self.asf
        self.strategy.set_aggregate(self.problem.aggregate(a["point"], a["worst"], a["rho"]))

    def __call__(self, ev: dict) -> None:
        kind = ev["event"]
        if self.lag is None and kind in ("asked", "exhausted", "evaluated", "failed"):
            raise JournalError(f"journal line {ev['seq'] + 1}: {kind} before the journal's "
                               f"first schedule line; the journal was changed by something "
                               f"other than lccopt")
        if kind in ("asked", "exhausted", "case_changed"):
            replay(self.strategy, ev)
        self.note(ev)
        if self.lag is not None:
            release(self.strategy, self.lag, self.multi, self.results.get)


def replay(strategy, ev: dict) -> None:
    """The optimiser call of an ``asked``, ``exhausted`` or ``case_changed`` line; an asked
    point the optimiser does not propose raises JournalError."""
    kind = ev["event"]
    if kind == "asked":
        props = strategy.ask(1)
        if (not props or props[0].id != ev["id"]
                or not np.array_equal(props[0].x, np.asarray(ev["x"], float))):
            got = f"#{props[0].id} {props[0].x.tolist()}" if props else "nothing"
            raise JournalError(f"journal line {ev['seq'] + 1}: the optimiser proposes {got}, the "
                               f"journal says #{ev['id']} {ev['x']}; was lccopt changed since the "
                               f"run started?")
    elif kind == "exhausted":
        props = strategy.ask(1)
        if props or not strategy.exhausted:
            got = props[0].id if props else "?"
            raise JournalError(f"journal line {ev['seq'] + 1}: the optimiser proposes #{got}, the "
                               f"journal says the design space was exhausted; was lccopt changed "
                               f"since the run started?")
    elif kind == "case_changed":
        strategy.budget = int(ev["budget"])


# ------------------------------------------------------------------------------ the loop

class Engine:
    def __init__(self, rd: RunDir, case: Case, problem: Problem, journal: Journal, table: Table,
                 strategy, executor, progress: Progress):
        self.rd, self.case, self.problem = rd, case, problem
        self.journal, self.table, self.strategy = journal, table, strategy
        self.progress = progress
        self.meta = rd.meta()
        if case.conditions:  # one task per (design, condition)
            from .conditions import ConditionPool

            executor = ConditionPool(executor, case, problem, rd.path)
        self.executor = executor
        self.strategy.budget = problem.budget
        self.ref_point = (table.reference or {}).get("point")
        if self.ref_point is not None:  # as the replay of the journal set it (restore)
            self.problem = problem = problem.with_reference(table.reference["objectives"])
            self.strategy.set_aggregate(problem.aggregate(self.ref_point))
        self._ahead: int | None = None   # id asked ahead, waiting for a free worker
        # proposal n sees exactly the results 0 .. n-lag-1 (schedule.py); lag = the workers
        self.lag = max(1, int(executor.slots))
        # proposals per surrogate fit (schedule.py)
        self.batch = batch_size(self.lag, getattr(case, "proposals_per_fit", 1))
        self.strategy.set_batch(self.batch)
        self.stop = False
        self.abort = False
        self._stop_logged = False
        self._saved_seq = table.seq
        self._results_at = 0.0
        self._snapshot_at = time.monotonic()
        self._synced_at = time.monotonic()
        self.t_optimiser = 0.0     # time in ask/tell
        self.t_bookkeeping = 0.0   # journal, snapshots, results.h5, files written here
        self.t_held = 0.0          # worker-seconds idle because a proposal waited for a late result
        self._held = False         # the last ask waited for a result (schedule.py)
        self._old_handlers: dict = {}
        self._restore: list[int] = []          # ids whose lost evals/ file is simulated again
        self._restoring: set[int] = set()
        self.histories = getattr(case, "histories", "best")
        self._histories_done: set[int] = set()  # designs whose histories were made at the end

    # -- signals ---------------------------------------------------------------------------------
    def _on_signal(self, signum, frame) -> None:
        if signum == signal.SIGINT and not self.stop:
            self.stop = True
        else:
            self.stop = self.abort = True

    def _install_signals(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return
        # SIGTERM/SIGHUP (Slurm, systemd, timeout, a closed terminal) stop at once like a second
        # Ctrl-C; the workers ignore them, so an evaluation is never reported as killed by them
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            self._old_handlers[sig] = signal.signal(sig, self._on_signal)

    def _restore_signals(self) -> None:
        for sig, h in self._old_handlers.items():
            signal.signal(sig, h)
        self._old_handlers.clear()

    def restore_files(self, ids: list[int], out: Progress) -> None:
        """Simulate again the evaluations whose file was deleted or damaged (no budget spent)."""
        if ids:
            out.log(f"{len(ids)} evaluation file(s) lost or damaged, simulating them again: "
                    f"{', '.join('#' + str(i) for i in ids[:6])}{' ...' if len(ids) > 6 else ''}")
        self._restore = list(ids)

    # -- main -----------------------------------------------------------------------------------
    def run(self) -> None:
        try:
            self._run()
        except (OSError, RuntimeError) as exc:  # h5py reports a full disk as either
            if environment_errno(exc) is None:
                raise
            raise _fault(exc, self.rd) from None

    def _run(self) -> None:
        p, pb = self.progress, self.problem
        if pb.multi and 0 in self.table.rows and self.table.rows[0]["status"] == "failed" \
                and self.table.reference is None:
            raise self._reference_failed(self.table.rows[0]["reason"])
        self._install_signals()
        t_start = time.monotonic()
        n_start = self.table.n_done
        try:
            what = ", ".join(pb.objectives) + (" (ASF, Eq. 7)" if pb.multi else "")
            # two lines, so that an 80-column terminal does not wrap them
            p.log(f"run {self.rd.path} (case '{self.case.name}'): {pb.dim} variables, "
                  f"budget {pb.budget}, {self.table.n_done} done")
            p.log(f"minimising {what}; {self.executor.description}")
            p.start(self.table, len(self.case.conditions) or 1)
            if self.table.lag != self.lag or self.table.batch != self.batch:
                self.table.apply(self.journal.append("schedule", lag=self.lag, batch=self.batch,
                                                     time=now_iso()))
            self._release()
            requeue = self.table.pending_ids()
            if requeue:
                p.log(f"running again {len(requeue)} evaluation(s) that were in flight: "
                      f"{', '.join('#' + str(i) for i in requeue)}")
            while True:
                # | head went away: stop as SIGPIPE would
                if PipeGuard.closed_pipe and not self.abort:
                    self.stop = self.abort = True
                if self.stop:
                    self._held = False
                submitted = 0 if self.stop else self._fill(requeue)
                if time.monotonic() - self._snapshot_at > SNAPSHOT_EVERY:
                    self._snapshot()
                if self.executor.running == 0:
                    if (not self.stop and self.strategy.done and not self._restore
                            and self._best_lacks_histories()):
                        continue  # its histories are simulated again (no budget), then it ends
                    if self.stop or (self.strategy.done and not self._restore):
                        break
                    if submitted == 0 and self.executor.free() > 0:
                        break  # nothing left to propose and nothing in flight
                idle = self.executor.free() if self._held and self.executor.running else 0
                t_wait = time.monotonic()
                for o in self.executor.wait(0.2):
                    self._record(o)
                self.journal.flush()  # the results' lines survive a kill -9 from here on
                if self.case.conditions:   # the designs' conditions, not a re-simulation's
                    p.parts(self.table, self.executor.parts_done(set(self.table.pending_ids())))
                if idle:
                    self.t_held += idle * (time.monotonic() - t_wait)
                if self.stop and not self._stop_logged:
                    self._stop_logged = True
                    n = self.executor.running
                    msg = "interrupted: no new evaluations"
                    if not self.abort and n:
                        msg += (f"; waiting for the {n} running to finish (Ctrl-C again to stop "
                                f"them now)")
                    p.log(msg)
                if self.abort:
                    n = self.executor.running
                    if n:
                        p.log(f"stopping {n} running evaluation(s); they run again on resume")
                    self.executor.kill_running()
                    break
                if time.monotonic() - self._results_at > RESULTS_EVERY:
                    self._write_results()
        finally:
            self.executor.close()
            self._restore_signals()
            p.close()
            wall = time.monotonic() - t_start
            try:
                self._snapshot()
                self.table.apply(self.journal.append(
                    "session", time=now_iso(), wall_time=wall,
                    evaluations=self.table.n_done - n_start,
                    optimiser_time=self.t_optimiser, bookkeeping_time=self.t_bookkeeping,
                    held_time=self.t_held, workers=self.lag,
                    executor=self.executor.description, versions=versions()))
                if self.strategy.done and not self.table.pending_ids() and not self.table.finished:
                    self.table.apply(self.journal.append("finished", time=now_iso(),
                                                         evaluations=self.table.n_done))
                self._write_results()
            finally:
                self.journal.close()
        if not self.table.finished:
            p.log(f"saved {self.table.n_done}/{pb.budget} evaluations in {self.rd.path}; carry on "
                  f"with:")
            p.log(f"    lccopt resume {self.rd.path}")
            raise typer.Exit(130)
        self._summary(wall)

    def _best_lacks_histories(self) -> bool:
        """With ``histories: best``, queue the best design again when its file has no time
        histories (once all results are in); True if it was queued."""
        best = self.table.best()
        if self.histories != "best" or best is None or best["id"] in self._histories_done \
                or self.table.pending_ids():
            return False
        self._histories_done.add(best["id"])
        from ..store import has_time_histories

        if has_time_histories(self.rd.path / eval_name(best["id"])):
            return False
        self._restore.append(best["id"])
        return True

    def _fill(self, requeue: list[int]) -> int:
        """Give every free worker a point; then, with all workers busy, propose the next point
        already, so that the next worker to finish gets it at once (the ask, or a whole
        block of proposals, runs while the evaluations do). A proposal waits for the results
        it must see (``_ask``); a free worker then idles until the late one arrives. Points
        asked but not yet running are pending in the journal: a resume runs them first, in
        order, and only then asks again, as the run would have. The asked lines are written
        (handed to the OS: they survive kill -9) before their evaluations start."""
        self._held = False
        rows = []
        free = self.executor.free()
        while len(rows) < free:
            if self._restore:
                i = self._restore.pop(0)
                self._restoring.add(i)
                rows.append(self.table.rows[i])
            elif requeue:
                rows.append(self.table.rows[requeue.pop(0)])
            elif self._ahead is not None:
                rows.append(self.table.rows[self._ahead])
                self._ahead = None
            else:
                row = self._ask()
                if row is None:
                    break
                rows.append(row)
        t0 = time.perf_counter()
        self.journal.flush()
        if time.monotonic() - self._synced_at > SYNC_EVERY:
            self.journal.sync()
            self._synced_at = time.monotonic()
        self.t_bookkeeping += time.perf_counter() - t0
        for row in rows:
            self._submit(row)
        if self.executor.free() == 0 and not requeue and self._ahead is None:
            row = self._ask()
            if row is not None:
                self._ahead = row["id"]
        return len(rows)

    def _ask(self) -> dict | None:
        """One proposal from the optimiser, committed to the journal; None if there is none now."""
        if self.problem.multi and self.ref_point is None and self.strategy.n_asked >= 1:
            return None  # the reference design runs alone: it fixes the reference point
        if self.strategy.done:
            return None
        if not may_ask(self.strategy, self.lag, self.problem.multi):
            self._held = True
            return None  # waits for the results it must see (in id order, whatever the timing)
        t0 = time.perf_counter()
        exhausted = self.strategy.exhausted
        props = self.strategy.ask(1)
        t1 = time.perf_counter()
        self.t_optimiser += t1 - t0
        if not props:
            if self.strategy.exhausted and not exhausted:  # replayed as a call that gives nothing
                self.table.apply(self.journal.append("exhausted", n_asked=self.strategy.n_asked))
            self.t_bookkeeping += time.perf_counter() - t1
            self._release()  # no more proposals: every result may be told
            return None
        pr = props[0]
        ev = self.journal.append("asked", sync=False, id=int(pr.id), x=[float(v) for v in pr.x],
                                 phase=pr.phase, restart=int(pr.restart))
        self.table.apply(ev)
        self.t_bookkeeping += time.perf_counter() - t1
        self._release()
        return self.table.rows[pr.id]

    def _result(self, i: int):
        r = self.table.rows.get(i)
        if r is None or r["status"] == "pending":
            return None
        if r["status"] != "ok":
            return ("failed", r["reason"])
        return ("ok", r["value"], self.problem.outputs(r["objectives"], r.get("parts")))

    def _release(self) -> None:
        """Tell the optimiser the results it may see now (in id order; see schedule.py)."""
        t0 = time.perf_counter()
        release(self.strategy, self.lag, self.problem.multi, self._result)
        self.t_optimiser += time.perf_counter() - t0

    def _submit(self, row: dict) -> None:
        # the evaluation file's path: a local worker writes it, a Dask worker if it sees the
        # run directory (executors.py), else the outcome brings the evaluation to write here
        out = str(self.rd.evals_dir() / Path(eval_name(row["id"])).name)
        # time histories: every design's, or the reference design's and, at the end, the best's
        # (simulated again then: a few MB per design saved; docs/runs.md, "Disk use")
        keep = self.histories == "all" or (
            self.histories == "best" and (row["id"] == 0 or row["id"] in self._restoring))
        self.executor.submit(Task(row["id"], list(row["x"]), row["phase"], row["restart"], out,
                                  histories=keep))

    def _record(self, o: Outcome) -> None:
        if o.fault is not None:  # the machine refused a write: stop, the evaluation stays pending
            raise EnvironmentFault(f"{o.fault}; the run stopped with nothing lost (evaluations in "
                                   f"flight stay pending): fix the cause, then "
                                   f"'lccopt resume {self.rd.path}'")
        if o.id in self._restoring:
            self._restored(o)
            return
        row = self.table.rows.get(o.id)
        if row is None or row["status"] != "pending":
            return
        if (self.stop and o.error is not None
                and o.error.startswith("worker process died (killed by")):
            return  # stopped along with lccopt by a signal: pending, runs again on resume
        t0 = time.perf_counter()
        pb, j = self.problem, self.journal
        error = o.error
        objectives = o.objectives
        if error is None:
            error = pb.finite(objectives)
        file = ""
        if objectives is not None:
            if o.file_written:
                file = eval_name(o.id)
            elif o.evaluation is not None:
                from ..store import write_evaluation

                attrs = {"id": o.id, "phase": row["phase"], "restart": row["restart"],
                         "worker": o.worker, "wall_time": o.wall_time, **o.machine}
                write_evaluation(self.rd.path / eval_name(o.id), o.evaluation, row["x"],
                                 self.case.names, attrs=attrs, durable=False)
                file = eval_name(o.id)
        common = dict(id=o.id, objectives=objectives or {}, wall_time=o.wall_time, worker=o.worker,
                      file=file,
                      at=round(time.time(), 3))  # when it was committed: `lccopt status` rates
        if error is None:
            if o.id == 0 and self.table.reference is None:
                self.problem = pb = pb.with_reference(objectives)  # worst: the case's or default
                point = pb.reference_point(objectives)  # CaseError if worst <= reference point
                self.table.apply(j.append("reference", sync=False, id=0, x=row["x"],
                                          objectives=objectives, point=point,
                                          worst=list(pb.worst) if pb.worst else None, rho=pb.rho,
                                          improvement=pb.improvement))
                self.ref_point = point
                self.strategy.set_aggregate(pb.aggregate(point))
            value = pb.value(objectives, self.ref_point)
            if pb.surrogate == "sleeper-energies" and o.parts is not None:
                common["parts"] = o.parts  # what the composite surrogate fits (and a replay tells)
            self.table.apply(j.append("evaluated", sync=False, value=value, **common))
        else:
            self.table.apply(j.append("failed", sync=False, reason=error, **common))
        self.t_bookkeeping += time.perf_counter() - t0
        self._release()  # told when its turn comes, not when it arrives (schedule.py)
        self.progress.update(self.table, last=row)
        if error is not None and pb.multi and o.id == 0 and self.table.reference is None:
            raise self._reference_failed(error)

    def _restored(self, o: Outcome) -> None:
        self._restoring.discard(o.id)
        row = self.table.rows[o.id]
        if o.error is None and o.evaluation is not None:
            from ..store import write_evaluation

            write_evaluation(self.rd.path / eval_name(o.id), o.evaluation, row["x"],
                             self.case.names,
                             attrs={"id": o.id, "phase": row["phase"], "restart": row["restart"],
                                    "worker": o.worker, "wall_time": o.wall_time, **o.machine})
        if o.error is not None:
            self.progress.log(f"could not simulate #{o.id} again ({o.error}); its file stays "
                              f"missing")
            return
        same = all(abs(o.objectives[k] - v) <= 1e-9 * max(1.0, abs(v))
                   for k, v in row["objectives"].items() if k in o.objectives)
        why = "histories" if o.id in self._histories_done else "lost"
        self.table.apply(self.journal.append("restored", id=o.id, file=eval_name(o.id), same=same,
                                             why=why))
        if not same:
            self.progress.log(f"#{o.id} simulated again gives other objectives than the journal's "
                              f"(another machine or library version?); the journal's values are "
                              f"kept")

    def _reference_failed(self, reason: str) -> CaseError:
        return CaseError(f"{self.case.path}: the reference design (evaluation #0) failed: "
                         f"{reason}; a multi-objective case needs its objectives for the ASF "
                         f"reference point")

    def _snapshot(self) -> None:
        if self.table.seq == self._saved_seq:
            return
        t0 = time.perf_counter()
        self.journal.sync()  # a snapshot never reflects a line that is not on disk
        self.rd.save_state(self.table.seq, self.strategy.state_dict(),
                           line_mark(self.table.last_event))
        self._saved_seq = self.table.seq
        self._snapshot_at = time.monotonic()
        self.t_bookkeeping += time.perf_counter() - t0

    def _write_results(self) -> None:
        t0 = time.perf_counter()
        write_results(self.rd.results_path, self.table, case=self.case, problem=self.problem,
                      meta=self.meta)
        self._results_at = time.monotonic()
        self.t_bookkeeping += time.perf_counter() - t0

    def _summary(self, wall: float) -> None:
        t, pb = self.table, self.problem
        lines = [f"done: {t.n_done} evaluations ({t.n_failed} failed) in {self.rd.path}",
                 f"  this session {hms(wall)} wall, optimiser {self.t_optimiser:.1f} s, "
                 f"bookkeeping {self.t_bookkeeping:.1f} s"]
        best = t.best()
        ref = reference_objectives(t) or {}
        if best is not None:
            lines.append(f"best #{best['id']} ({best['phase']}, restart {best['restart']}): value "
                         f"{fmt(best['value'])}")
            lines += wrap_items(design_items(self.case, best["x"]), "  x: ")
            for k in pb.objectives:
                v, r = best["objectives"].get(k), ref.get(k)
                rel = (f" ({(v - r) / r:+.1%} vs reference design {objective_value(k, r)})"
                       if r else "")
                lines.append(f"  {objective_text(k, v)}{rel}")
        lines.append(f"results: {self.rd.results_path}")
        sys.stdout.write("\n".join(lines) + "\n")
        sys.stdout.flush()
