"""The run directory: creation, lock, case copy, state snapshot (the journal's lines:
journal.py and run.py; results.h5: results.py).

    runs/<name>/
      run.json          what the run is: case file path, sha256 of the resolved case, versions
      case.yaml         the resolved case (extends and defaults applied) the run uses
      journal.jsonl     the commit log (see journal.py); the truth everything else is rebuilt from
      state.json        optimiser state snapshot + the journal seq it reflects (a cache: resume
                        replays the journal events after it)
      evals/NNNNNN.h5   one immutable file per evaluation (time histories), NNNNNN = id
      results.h5        table of all evaluations, rebuilt atomically from the journal
      lock              who drives the run (pid, host, since)

One process drives a run: it holds an advisory lock (flock) on the journal, on the descriptor
it appends with, and on ``lock``; a second driver is refused whatever happened to the lock file,
and the driver checks now and then that both are still the run's files.

The directory is held open (``folder.Folder``) from the moment it is opened or made: every file
is read, written and renamed relative to it, so moving the run directory or putting a link in
its place while a command works on it never redirects a read or a write. Every file but the
journal is written to a temporary name (fsynced) and renamed.
"""

from __future__ import annotations

import datetime as _dt
import errno
import fcntl
import hashlib
import json
import os
import platform
import stat
import time
from pathlib import Path

import numpy as np

from ..folder import Folder
from ..safeio import UnsafeFile, kind_of
from .events import RUN
from .journal import encode

RUN_FORMAT = "lccopt-run"
RUN_VERSION = 1
MAX_META_BYTES = 1_000_000  # run.json is a few hundred bytes
JOURNAL = "journal.jsonl"
LOCK = "lock"
CREATING = ".creating-"     # .<name>.creating-XXXXXXXX: a run directory being made
# what a run directory being made holds: a stale one with anything else is not removed
CREATED = {"evals", "case.yaml", "case.source.yaml", "run.json", LOCK, JOURNAL}
LOCK_RETRY = 1.0            # [s] a reader's shared peek at the lock may delay taking it


class RunError(Exception):
    """A run directory problem the user can fix (exists, locked, not a run, ...)."""


def sha256_text(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def versions() -> dict:
    import h5py
    import scipy

    from .. import machine
    from ..version import __version__

    return {"lccopt": __version__, "numpy": np.__version__, "scipy": scipy.__version__,
            "h5py": h5py.__version__, "python": platform.python_version(), **machine.describe()}


def now_iso() -> str:
    return _dt.datetime.now(_dt.timezone.utc).astimezone().isoformat(timespec="seconds")


def _flock(fh, exclusive: bool, wait: float = 0.0) -> bool:
    """flock without blocking, retried for ``wait`` seconds (a reader's momentary shared lock
    must not refuse a driver); True if got."""
    deadline = time.monotonic() + wait
    while True:
        try:
            fcntl.flock(fh.fileno(), (fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
                        | fcntl.LOCK_NB)
            return True
        except OSError as exc:
            if exc.errno not in (errno.EAGAIN, errno.EACCES) or time.monotonic() >= deadline:
                return False
        time.sleep(0.02)


def _say_holder(fh) -> None:
    """Who drives the run, in its lock file (for people: the flock is what counts, so a full
    disk that refuses these few bytes does not matter)."""
    try:
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()} on {platform.node()} since {now_iso()}\n")
        fh.flush()
    except OSError:
        pass


# ------------------------------------------------------------------------------ directory

class RunDir:
    """A run directory. ``path`` names it in messages; every access goes through ``folder``,
    the directory held open (opened at the first access, following the path the user gave)."""

    def __init__(self, path: Path, folder: Folder | None = None):
        self.path = Path(path)
        self._folder = folder
        self._evals: Folder | None = None
        self._lock_fh = None
        self._journal_fh = None

    journal_path = property(lambda self: self.path / JOURNAL)
    state_path = property(lambda self: self.path / "state.json")
    results_path = property(lambda self: self.path / "results.h5")
    meta_path = property(lambda self: self.path / "run.json")
    case_path = property(lambda self: self.path / "case.yaml")
    evals_path = property(lambda self: self.path / "evals")

    @property
    def folder(self) -> Folder:
        if self._folder is None:
            try:
                self._folder = Folder.open(self.path)
            except FileNotFoundError:
                raise RunError(f"{self.path}: no such run directory") from None
            except UnsafeFile as exc:
                raise RunError(str(exc)) from None
            except OSError as exc:
                raise RunError(f"{self.path}: cannot open the run directory "
                               f"({exc.strerror or exc})") from None
        return self._folder

    def at(self, name: str) -> tuple[Folder, str]:
        """(folder, name) of the run's file ``name`` (``evals/NNNNNN.h5`` too): where lccopt
        reads or writes it."""
        if name.startswith("evals/"):
            return self.evals(), name[len("evals/"):]
        return self.folder, name

    def close(self) -> None:
        self.unlock()
        for f in (self._evals, self._folder):
            if f is not None:
                f.close()

    @classmethod
    def create(cls, path: Path, case, problem, evaluator: str) -> "RunDir":
        """Create the directory atomically (build it under a temporary name inside the runs
        folder, then rename it); a creation a kill -9 left behind is removed first."""
        path = Path(path)
        name = path.name
        try:
            runs = Folder.open(path.parent, create=True)
        except OSError as exc:
            raise RunError(f"{path.parent}: cannot make the folder for run directories "
                           f"({exc.strerror or exc})") from None
        with runs:
            clean_creations(runs, name)
            tmp = runs.make_temp_dir(f".{name}{CREATING}", suffix="")
            try:
                made = runs.sub(tmp)
                made.try_lock()   # a creation in progress: never taken for a stale one
                _fill_new_run(made, case, problem, evaluator)
                made.fsync()
                runs.rename(tmp, name)
                made.unlock()
            except BaseException as exc:
                try:
                    runs.remove_tree(tmp)
                except OSError:
                    pass
                if isinstance(exc, OSError) and exc.errno in (errno.EEXIST, errno.ENOTEMPTY,
                                                            errno.ENOTDIR):
                    raise RunError(f"{path} already exists (another run was started at the same "
                                   f"time?)") from None
                raise
            runs.fsync()
        made.path = path
        return cls(path, made)

    @classmethod
    def open(cls, path: Path) -> "RunDir":
        path = Path(path)
        rd = cls(path)
        folder = rd.folder
        if not all(folder.exists(name) for name in ("run.json", JOURNAL)):
            raise RunError(f"{path}: not an lccopt run directory (no run.json or journal.jsonl)")
        rd.check_entries()
        return rd

    OWNED_FILES = ("run.json", JOURNAL, LOCK, "state.json", "results.h5", "case.yaml",
                   "case.source.yaml")

    def check_entries(self) -> None:
        """Every file and folder lccopt keeps in the run is what lccopt made: a regular file
        (a real folder for evals/), never a link or a special file planted there (RunError).
        Every command that opens a run (resume, status, report) checks it the same way."""
        for name in self.OWNED_FILES:
            st = self.folder.lstat(name)
            if st is not None and not stat.S_ISREG(st.st_mode):
                raise RunError(f"{self.path / name}: {kind_of(st.st_mode)}, where lccopt keeps a "
                               f"file of its own; lccopt never reads or writes through it: "
                               f"remove it")
        if self.folder.exists("evals"):
            try:
                evals = self.evals(create=False)
            except UnsafeFile as exc:
                raise RunError(f"{exc}") from None
            with os.scandir(evals.fd) as entries:
                for entry in entries:
                    if not entry.is_file(follow_symlinks=False):
                        kind = kind_of(entry.stat(follow_symlinks=False).st_mode)
                        raise RunError(f"{evals.display(entry.name)}: {kind} among the run's "
                                       f"evaluation files; lccopt never reads or writes through "
                                       f"it: remove it")

    def evals(self, create: bool = True) -> Folder:
        """evals/, held open; made again if it was deleted under the run (``create``); never a
        link (UnsafeFile)."""
        st = self.folder.lstat("evals")
        if self._evals is not None and st is not None and \
                (st.st_dev, st.st_ino) == self._evals.identity:
            return self._evals
        if self._evals is not None:
            self._evals.close()
            self._evals = None
        self._evals = self.folder.sub("evals", create=create)
        return self._evals

    def meta(self) -> dict:
        try:
            meta = json.loads(self.folder.read("run.json", MAX_META_BYTES).decode("utf-8"))
        except (OSError, ValueError) as exc:
            raise RunError(f"{self.meta_path}: unreadable ({exc})") from None
        if not isinstance(meta, dict) or meta.get("format") != RUN_FORMAT:
            raise RunError(f"{self.meta_path}: not an lccopt run description")
        return meta

    def read_text(self, name: str, limit: int | None = None) -> str:
        """A file of the run as text (OSError, UnicodeDecodeError)."""
        return self.folder.read(name, limit).decode("utf-8")

    # -- lock -------------------------------------------------------------------------------
    def locked_by_other(self) -> bool:
        """True while another process drives the run (flock on its journal or its lock file:
        immune to PID reuse, to a deleted lock file and to a crashed holder)."""
        for name in (JOURNAL, LOCK):
            try:
                fh = self.folder.open_file(name, "rb")
            except FileNotFoundError:
                continue
            except OSError as exc:
                raise RunError(f"{exc}") from None
            try:
                if not _flock(fh, exclusive=False):
                    return True
            finally:
                fh.close()  # closing drops a lock we got
        return False

    def lock(self) -> None:
        """Become the run's one driver: flock the lock file and the journal (on the descriptor
        the journal is appended with: ``journal_handle``); RunError if another process holds
        either."""
        try:
            fh = self.folder.open_file(LOCK, "a+")
        except UnsafeFile as exc:
            raise RunError(f"{exc}") from None
        except OSError as exc:
            raise RunError(f"{self.path / LOCK}: cannot open the run's lock file "
                           f"({exc.strerror or exc}); lccopt needs to write in the run "
                           f"directory") from None
        journal = None
        try:
            if not _flock(fh, exclusive=True, wait=LOCK_RETRY):
                raise self._in_use(fh)
            try:
                journal = self.folder.open_fd(JOURNAL, os.O_WRONLY | os.O_APPEND)
                journal = os.fdopen(journal, "ab")
            except FileNotFoundError:
                journal = None   # no journal: RunDir.open or resume says so
            except UnsafeFile as exc:
                raise RunError(f"{exc}") from None
            if journal is not None:
                if os.fstat(journal.fileno()).st_nlink > 1:
                    raise RunError(f"{self.journal_path}: has other hard links; lccopt never "
                                   f"writes to a file that is also elsewhere (copy it instead)")
                if not _flock(journal, exclusive=True, wait=LOCK_RETRY):
                    raise self._in_use(fh)
        except BaseException:
            fh.close()
            if journal is not None:
                journal.close()
            raise
        _say_holder(fh)
        self._lock_fh, self._journal_fh = fh, journal

    def _in_use(self, fh) -> RunError:
        try:
            fh.seek(0)
            holder = fh.read(200).strip()
        except (OSError, ValueError):
            holder = ""
        holder = holder if holder.isprintable() else ""
        return RunError(f"{self.path} is in use by another lccopt process"
                        f"{' (' + holder + ')' if holder else ''}; wait for it to finish or "
                        f"stop it first")

    def journal_handle(self):
        """The journal's file object, locked by :meth:`lock` (None before)."""
        return self._journal_fh

    def check_lock(self) -> str | None:
        """While driving: why this process may no longer be the run's one driver (its journal
        was replaced or removed), else None. A lock file that was removed or replaced is made
        and locked again."""
        if self._journal_fh is not None:
            mine = os.fstat(self._journal_fh.fileno())
            st = self.folder.lstat(JOURNAL)
            if st is None or (st.st_dev, st.st_ino) != (mine.st_dev, mine.st_ino):
                return (f"{self.journal_path} was {'removed' if st is None else 'replaced'} while "
                        f"the run went (this process's journal is no longer the run's)")
        if self._lock_fh is not None:
            mine = os.fstat(self._lock_fh.fileno())
            st = self.folder.lstat(LOCK)
            if st is None or (st.st_dev, st.st_ino) != (mine.st_dev, mine.st_ino):
                try:
                    fh = self.folder.open_file(LOCK, "a+")
                except OSError:
                    return None   # the journal's lock still keeps a second driver out
                if _flock(fh, exclusive=True):
                    _say_holder(fh)
                    self._lock_fh.close()
                    self._lock_fh = fh
                else:
                    fh.close()
        return None

    def unlock(self) -> None:
        if self._lock_fh is not None:
            try:
                self._lock_fh.seek(0)
                self._lock_fh.truncate()
            except (OSError, ValueError):
                pass
            self._lock_fh.close()   # closing drops the flock
            self._lock_fh = None
        if self._journal_fh is not None:
            if not self._journal_fh.closed:
                try:
                    self._journal_fh.close()
                except OSError:
                    pass
            self._journal_fh = None

    # -- files -------------------------------------------------------------------------------
    def write_meta(self, meta: dict) -> None:
        self.folder.write("run.json", (json.dumps(meta, indent=2) + "\n").encode())

    def save_state(self, seq: int, state: dict, mark: str) -> None:
        """The optimiser's state after journal line ``seq`` (``mark``: that line's line_mark)."""
        data = json.dumps({"seq": seq, "mark": mark, "strategy": state}, allow_nan=False,
                          separators=(",", ":"))
        self.folder.write("state.json", data.encode())

    def write_case(self, resolved: str) -> None:
        self.folder.write("case.yaml", resolved.encode("utf-8"))

    def load_state(self) -> dict | None:
        """The optimiser snapshot, or None if there is none or it is not usable (it is a
        cache: resume then replays the whole journal)."""
        try:
            d = json.loads(self.folder.read("state.json").decode("utf-8"))
            whole = isinstance(d, dict) and isinstance(d.get("seq"), int) and "strategy" in d
            return d if whole else None
        except (OSError, ValueError, RunError):
            return None

    def clean(self, pending: set[str]) -> list[str]:
        """Remove temporary files and the unfinished files of pending evaluations; return them.

        Only files lccopt itself would write again, and only regular files directly in the run
        directory or in its own evals/ (never through a link): an evaluation file the journal
        does not account for is never removed (it may be the only copy of a result)."""
        gone = []
        places = [(self.folder, "")]
        if self.folder.exists("evals"):
            places.append((self.evals(create=False), "evals/"))
        for folder, prefix in places:
            for name in folder.names():
                if folder.is_file(name) and (name.endswith(".tmp") or prefix + name in pending):
                    folder.unlink(name)
                    gone.append(prefix + name)
        return gone


def _fill_new_run(made: Folder, case, problem, evaluator: str) -> None:
    """The files of a new run directory (being made under a temporary name)."""
    made.sub("evals", create=True).close()
    resolved = case.resolved
    meta = {
        "format": RUN_FORMAT, "version": RUN_VERSION, "name": case.name,
        "case_file": str(Path(case.path).resolve()), "case_sha256": sha256_text(resolved),
        "created": now_iso(), "versions": versions(), "evaluator": evaluator,
        # how each design variable is shown (name, unit, factor from SI): status reads it
        "variables": [[v.name, *v.display] for v in case.variables],
        # the --set items the case was loaded with: resume loads it the same way
        "overrides": list(getattr(case, "overrides", ())),
    }
    if getattr(case, "budget_option", None) is not None:   # --budget: resume loads it again
        meta["budget"] = int(case.budget_option)
    if getattr(case, "realisations", 0):
        from ..config.uncertainty import record

        # the realisations of the track every design meets: a resume checks that it draws the
        # same ones
        meta["realisations"] = record(case)
    made.write("case.yaml", resolved.encode("utf-8"))
    made.write("case.source.yaml", case.text.encode("utf-8"))
    made.write("run.json", (json.dumps(meta, indent=2) + "\n").encode("utf-8"))
    made.write(LOCK, b"")
    line = {"seq": 0, "event": RUN, "time": now_iso(), "case_sha256": meta["case_sha256"],
            "budget": problem.budget, "objectives": list(problem.objectives),
            "seed": problem.seed, "versions": meta["versions"],
            # what the surrogate fits (Problem.surrogate: the objectives, the sleeper energies
            # or the value) and the optimiser's settings: a resume rebuilds the optimiser from
            # these (replay.restore)
            "surrogate": problem.surrogate,
            "optimiser": problem.optimiser_settings().to_dict()}
    if "realisations" in meta:
        line["realisations"] = meta["realisations"]
    made.write(JOURNAL, encode(line))


def clean_creations(runs: Folder, name: str) -> list[str]:
    """Remove the run directories named ``name`` that a killed ``optimise`` left half made
    (``.<name>.creating-*``): only real folders that no live process holds (a creation holds a
    flock on its folder), that hold nothing but what a new run holds, and that are not empty or
    older than a minute (an empty one may be one being made this instant); return them."""
    gone = []
    for entry in runs.names():
        if not entry.startswith(f".{name}{CREATING}"):
            continue
        try:
            with runs.sub(entry) as made:
                if not made.try_lock():
                    continue
                inside = set(made.names())
                fresh = time.time() - os.fstat(made.fd).st_mtime < 60
                if not inside <= CREATED or (not inside and fresh):
                    continue
                runs.remove_tree(entry)
                gone.append(entry)
        except OSError:
            continue
    return gone
