"""The main job: ``lccopt optimise CASE`` and ``lccopt resume RUN``: checks of the case, the
run directory and the options, then the run's loop (``loop.Engine``). A resume rebuilds the
optimiser from the journal (``replay``) and re-runs the evaluations asked without a result.
"""

from __future__ import annotations

import os
from pathlib import Path

from .. import machine
from ..config import SAFE_NAME, Case, load_case
from ..errors import CaseError, UsageError, signals_deferred
from ..problem import Problem
from .dask_executor import DaskExecutor
from .events import ASKED, RUN
from .executors import ExecutorError, LocalPool, default_workers
from .journal import Journal, JournalError, read_journal, repair
from .loop import Engine
from .progress import Progress, fmt
from .replay import restore
from .results import write_results
from .run import Recorder, Run, eval_name
from .rundir import JOURNAL, RunDir, RunError, sha256_text, versions
from .upgrade import evaluator_name
from .worker import choose_evaluator


def _usage_error(message: str) -> Exception:
    return UsageError(message)


def make_executor(case, evaluator, workers: int | None, scheduler, timeout: float):
    """The worker pool of a run: a Dask scheduler's workers with ``scheduler`` (an address),
    else ``workers`` local processes (default: the cores)."""
    if scheduler is not None:
        return DaskExecutor(case, evaluator, scheduler, timeout)
    return LocalPool(case, evaluator, workers or default_workers(), timeout)

# ------------------------------------------------------------------------------ public API

def optimise(case, workers: int | None = None, scheduler=None, runs: Path = Path("runs"),
             force: bool = False, *, evaluator=None, progress: bool = True, stream=None) -> Path:
    """Start a run of CASE in ``runs/<case name>/``; return the run directory.

    Raises CaseError (bad case), UsageError (bad options, run exists or is locked),
    RunInterrupted after an interruption (the run is saved and resumable).
    """
    case_obj = case if isinstance(case, Case) else load_case(case)
    problem = Problem.from_case(case_obj)
    _check_options(workers, scheduler)
    evaluator = choose_evaluator(evaluator)
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
    executor = _start_executor(case_obj, evaluator, workers, scheduler, problem,
                               Progress(0, stream, progress).log)
    try:
        # a stopping signal waits for the old run's removal and the new one's creation: never
        # half a run directory (which --force would then refuse to replace)
        with signals_deferred():
            # looked at again: the workers took seconds to start, and meanwhile another
            # optimise may have made the run, or a link may have been put in its place
            _clear_the_way(run_path, Path(runs), force, case_obj)
            rd = RunDir.create(run_path, case_obj, problem,
                               evaluator if isinstance(evaluator, str) else repr(evaluator))
            rd.lock()
    except BaseException as exc:
        executor.close()
        if isinstance(exc, RunError):
            raise _usage_error(str(exc)) from None
        raise
    try:
        journal, events, _ = Journal.open(rd.at(JOURNAL), rd.journal_handle())
        strategy, table = restore(problem, events, None)
        engine = Engine(rd, case_obj, problem, journal, table, strategy, executor,
                        Progress(problem.budget, stream, progress))
        engine.run()
    except (ExecutorError, JournalError) as exc:
        raise _usage_error(str(exc)) from None
    finally:
        executor.close()
        rd.close()
    return rd.path


def _clear_the_way(run_path: Path, runs: Path, force: bool, case_obj) -> None:
    """Make sure nothing is at ``run_path`` before the run is made there: without ``force``
    anything there is refused; with it, only the lccopt run directory found there (never
    through a link) is removed, once no process drives it (RunError otherwise)."""
    from ..folder import Folder
    from ..safeio import UnsafeFile

    try:
        folder = Folder.open(runs)
    except FileNotFoundError:
        return    # made with the run
    except OSError as exc:
        raise RunError(str(exc)) from None
    with folder:
        st = folder.lstat(run_path.name)
        if st is None:
            return
        if not force:
            raise RunError(f"{run_path} already exists (made while this lccopt started: another "
                           f"optimise of the same case?): carry it on with 'lccopt resume "
                           f"{run_path}', or start again with 'lccopt optimise {case_obj.path} "
                           f"--force'")
        try:
            sub = folder.sub(run_path.name)
        except (UnsafeFile, OSError):
            raise RunError(f"{run_path} is not a run directory inside {runs} any more; --force "
                           f"only replaces lccopt run directories: move or remove it yourself"
                           ) from None
        old = RunDir(run_path, sub)
        try:
            try:
                meta = old.meta()
            except RunError:
                meta = None
            if not isinstance(meta, dict):
                raise RunError(f"{run_path} is not an lccopt run directory (no readable run.json "
                               f"of lccopt); --force only replaces run directories: move or "
                               f"remove it yourself")
            old.lock()  # refuse to delete a run another process is driving
            st = folder.lstat(run_path.name)
            if st is None or (st.st_dev, st.st_ino) != sub.identity:
                raise RunError(f"{run_path} was moved or replaced meanwhile; nothing removed")
            folder.remove_tree(run_path.name)
        finally:
            old.close()


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


def _start_executor(case, evaluator, workers, scheduler, problem, log=None):
    try:
        executor = make_executor(case, evaluator, workers, scheduler, problem.timeout)
    except ExecutorError as exc:
        raise _usage_error(str(exc)) from None
    try:
        executor.start(log)
    except BaseException as exc:  # an interruption too: no worker or connection left behind
        executor.close()
        if isinstance(exc, ExecutorError):
            raise _usage_error(str(exc)) from None
        raise
    return executor


def resume(run, workers: int | None = None, scheduler=None, case=None,
           allow_changed_case: bool = False, budget: int | None = None, *, evaluator=None,
           progress: bool = True, stream=None, repair_journal: bool = False) -> Path:
    """Carry on the run in directory RUN; see the module docstring. ``repair_journal``: a
    journal damaged by something other than lccopt is cut back to the lines before the damage
    (the whole file kept beside it as journal.damaged-N.jsonl) and the run carries on."""
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
        try:
            events, _, _ = read_journal(rd.at(JOURNAL))
        except JournalError as exc:
            events = exc.events
            if not (events and events[0].get("event") == RUN):
                raise
            # e.g. two processes appended at once (an lccopt that did not lock the run, or a
            # copy of the run driven beside it): the lines before the damage are one
            # process's, whole and in order; carry on from them only when asked to
            if not repair_journal:
                raise JournalError(
                    f"{exc.args[0].split(';')[0]}; the journal was changed by something other "
                    f"than lccopt: carry on from the {exc.line - 1} lines before it with "
                    f"'lccopt resume {rd.path} --repair-journal' (the whole journal is kept "
                    f"beside it; what the lines after it recorded is simulated again)") from None
            kept = repair(rd.at(JOURNAL), rd.journal_handle(), exc)
            out.log(f"{exc.args[0].split(';')[0]}: carrying on from the {exc.line - 1} lines "
                    f"before it (the evaluations after it run again); the whole journal is kept "
                    f"as {rd.path / kept}")
        if not events or events[0].get("event") != RUN:
            n = (len([n for n in rd.evals(create=False).names() if n.endswith(".h5")])
                 if rd.folder.exists("evals") else 0)
            raise RunError(f"{rd.journal_path} is empty or does not start with the run's first "
                           f"line: this run cannot be carried on safely ({n} evaluation file(s) "
                           f"kept as they are); restore the journal, or start a new run under "
                           f"another name")
        _check_budget(budget, sum(ev.get("event") == ASKED for ev in events))
        journal, events, torn = Journal.open(rd.at(JOURNAL), rd.journal_handle())
        if torn:
            out.log("dropped a torn last line of the journal (the run was killed while writing "
                    "it)")
        case_obj = _resume_case(rd, meta, case, allow_changed_case, out, budget)
        _check_realisations(events[0].get("realisations"), case_obj)
        problem = Problem.from_case(case_obj)
        if events and events[0].get("objectives") not in (None, list(problem.objectives)):
            raise _usage_error(f"the case's objectives {list(problem.objectives)} differ from the "
                               f"run's {events[0]['objectives']}; start a new run instead")
        asked = sum(ev.get("event") == ASKED for ev in events)
        if problem.budget < asked:
            raise _usage_error(f"the case's budget of {problem.budget} is below the {asked} "
                               f"evaluations the run has already asked for; give a budget of at "
                               f"least {asked}")
        # a case the run did not record: another file, or a budget the journal does not hold
        # (the budget in force is the journal's: a replay must find it there)
        if (meta.get("case_sha256") != sha256_text(case_obj.resolved)
                or _journal_budget(events) not in (None, problem.budget)):
            extra = ({"worst": list(problem.worst), "rho": problem.rho}
                     if problem.multi and problem.worst else {})
            with signals_deferred():  # the journal's line and the run's copy of the case together
                events.append(Recorder(journal).case_changed(
                    sha256_text(case_obj.resolved), problem.budget, str(case_obj.path), **extra))
                rd.write_case(case_obj.resolved)
                meta.update(case_sha256=sha256_text(case_obj.resolved),
                            case_file=str(Path(case_obj.path).resolve()),
                            overrides=list(getattr(case_obj, "overrides", ())))
                if budget is not None:   # a later resume loads the case with it again
                    meta["budget"] = int(budget)
                rd.write_meta(meta)
        strategy, table = restore(problem, events, rd.load_state())
        # never the evaluator run.json names: a run directory from elsewhere must not choose
        # code to run; the testing hook ($LCCOPT_EVALUATOR) or the simulator
        evaluator = choose_evaluator(evaluator)
        started = evaluator_name(meta.get("evaluator"))
        if isinstance(evaluator, str) and isinstance(started, str) and started != evaluator:
            out.log(f"the run was started with evaluator {meta['evaluator'][:60]!r}; carrying on "
                    f"with {evaluator!r}")
        removed = rd.clean(pending={eval_name(i) for i in table.pending_ids()})
        if removed:
            out.log(f"removed {len(removed)} temporary or unfinished file(s): "
                    f"{', '.join(removed[:5])}{' ...' if len(removed) > 5 else ''}")
        lost = _lost_files(rd, table)
        if strategy.done and not table.pending_ids() and not lost:
            if not table.finished:
                Recorder(journal, table).finished()
            write_results(rd.at("results.h5"), table, case=case_obj, problem=problem, meta=meta)
            best = table.best()
            out.log(f"{rd.path} is finished: {table.n_done} evaluations ({table.n_failed} failed); "
                    "nothing to do")
            if best:
                out.log(f"best #{best['id']} value {fmt(best['value'])}")
            return rd.path
        note = machine.resume_note(events[0].get("versions"), versions())
        if note:
            out.log(note)
        executor = _start_executor(case_obj, evaluator, workers, scheduler, problem, out.log)
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
        rd.close()
    return rd.path


def _check_realisations(recorded, case) -> None:
    """The case draws the realisations of the track the run recorded (the same seed and
    section drawn by another numpy could differ: the run's designs would then not share
    their tracks)."""
    if not isinstance(recorded, dict) or not getattr(case, "realisations", 0):
        return
    from ..config.uncertainty import record

    now = record(case)
    if now["fingerprint"] != recorded.get("fingerprint"):
        raise _usage_error(f"the realisations of the track drawn now (fingerprint "
                           f"{now['fingerprint']}) are not those the run recorded "
                           f"({str(recorded.get('fingerprint'))[:16]}): the same seed gives "
                           f"other tracks here (another numpy?); carry the run on where it "
                           f"started, or start a new run")


def _check_budget(budget: int | None, asked: int) -> None:
    """``--budget``, named as the user typed it: within a case's bounds for a budget, and not
    below what the run has asked for already."""
    if budget is None:
        return
    from ..config.schema import SCHEMA

    rule = SCHEMA.fields["optimisation"].fields["budget"]
    if budget < rule.ge or budget > rule.le:
        raise _usage_error(f"--budget {budget}: a budget is {rule.ge:g} to {rule.le:g} "
                           f"evaluations")
    if budget < asked:
        raise _usage_error(f"--budget {budget} is below the {asked} evaluations the run has "
                           f"already asked for; give at least {asked}")


def _journal_budget(events: list[dict]) -> int | None:
    """The budget in force after the journal's lines (None: not recorded, or lines lccopt
    cannot use, which the replay then reports)."""
    try:
        return Run.of(events).budget
    except (KeyError, TypeError, ValueError, IndexError):
        return None


def _lost_files(rd: RunDir, table: Run) -> list[int]:
    """Ids of evaluations whose file the journal names but which is missing, unreadable or not
    theirs (another evaluation's file copied over it): each is simulated again."""
    from ..store import evaluation_problem

    return [i for i, r in sorted(table.rows.items()) if r["status"] == "ok" and r["file"]
            and evaluation_problem(rd.at(r["file"]), i, r["x"], table.head_mark) is not None]


def _run_case(rd: RunDir, overrides=(), budget: int | None = None) -> Case:
    """The run's own copy of its case (case.yaml), read through the run directory held open."""
    from ..config.reading import MAX_CASE_FILE_BYTES, case_text
    from ..errors import CaseError

    try:
        data = rd.folder.read("case.yaml", MAX_CASE_FILE_BYTES)
    except OSError as exc:
        raise CaseError(f"{rd.case_path}: cannot read the run's copy of its case "
                        f"({exc.strerror or exc})") from None
    return load_case(rd.case_path, overrides, text=case_text(data, rd.case_path), budget=budget)


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
    """The case to carry on with: the original file with the run's --set overrides and the
    budget an earlier ``--budget`` gave (must resolve as the run's case did) or the run's
    copy; ``budget``: a new budget on top."""
    if case is None:
        original = Path(meta.get("case_file", ""))
        if meta.get("case_file") and original.is_file():
            case = original
        else:
            out.log(f"the case file {original} is gone; using the run's copy {rd.case_path}")
            case = rd.case_path
    overrides = [o for o in meta.get("overrides") or [] if isinstance(o, str)]
    given = meta.get("budget") if type(meta.get("budget")) is int else None
    run_copy = not isinstance(case, Case) and Path(case) == rd.case_path
    if isinstance(case, Case):
        case_obj = case
    elif run_copy:
        case_obj = _run_case(rd, overrides, given)
    else:
        case_obj = load_case(case, overrides, budget=given)
    if budget is not None and sha256_text(case_obj.resolved) == meta.get("case_sha256"):
        # the same case with another budget: the one change --budget asks for
        try:
            case_obj = load_case(case_obj.path, overrides, text=case_obj.text,
                                 resolved=run_copy, budget=budget)
        except CaseError as exc:   # named as the user typed it (the case locates it at --set)
            text = str(exc)
            prefix = "--set: optimisation.budget: "
            if text.startswith(prefix):
                raise _usage_error(f"--budget {budget}: {text[len(prefix):]}") from None
            raise
        allow_changed = True
    if sha256_text(case_obj.resolved) != meta.get("case_sha256"):
        old_case = _run_case(rd)
        old, new = Problem.from_case(old_case), Problem.from_case(case_obj)
        refused = [k for k in changed_keys(old_case.data, case_obj.data)
                   if k not in HONOURED_CHANGES]
        if not old.same_space(new) and not refused:
            refused = ["the design variables"]
        if refused:
            # no flag carries a run on with another track, design space or model: say what
            # does work
            more = f" (and {len(refused) - 1} more key(s))" if len(refused) > 1 else ""
            raise _usage_error(
                f"{case_obj.path}: {refused[0]}{more} changed since the run started; a run "
                f"carries on only with the case it started with (budget, timeout, asf.worst and "
                f"asf.rho may change). To run the changed case, give it a new name (name: in "
                f"the file, or --set name=NEW) or replace this run with 'lccopt optimise "
                f"{case_obj.path} --force'; to carry this run on, restore the file or resume "
                f"with --case {rd.case_path} (the run's copy)")
        if not allow_changed:
            raise _usage_error(
                f"the case file {case_obj.path} or a file it reads (extends, irregularity) "
                f"changed since the run started (the resolved case differs from {rd.case_path}) "
                f"in what a run may change (budget, timeout, asf.worst, asf.rho): resume with "
                f"--allow-changed-case to use it, or with --case {rd.case_path} (the run's copy)")
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

