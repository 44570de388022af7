"""The run directory: creation, lock, case copy, journal table, state snapshot, results.h5.

    runs/<name>/
      run.json          what the run is: case file path, sha256 of the resolved case, versions
      case.yaml         the resolved case (extends and defaults applied) the run uses
      journal.jsonl     the commit log (see journal.py); the truth everything else is rebuilt from
      state.json        optimiser state snapshot + the journal seq it reflects (a cache: resume
                        replays the journal events after it)
      evals/NNNNNN.h5   one immutable file per evaluation (time histories), NNNNNN = id
      results.h5        table of all evaluations, rebuilt atomically from the journal
      lock              fcntl lock: one process drives a run at a time

Every file but the journal is written to a temporary name, fsynced and renamed.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import errno
import fcntl
import hashlib
import json
import math
import os
import platform
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..atomic import atomic_path, atomic_write_bytes, fsync_dir, normal_mode
from ..safeio import UnsafeFile, check_owned_dir, is_regular_file, kind_of, open_owned, read_owned

RESULTS_FORMAT = "lccopt-results"
RESULTS_VERSION = 1
RUN_FORMAT = "lccopt-run"
RUN_VERSION = 1
MAX_META_BYTES = 1_000_000  # run.json is a few hundred bytes
OBJECTIVE_NAMES = ("F_rms", "F_max", "E_rms", "E_max")   # the paper's: always a column


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


def eval_name(i: int) -> str:
    return f"evals/{i:06d}.h5"


# ------------------------------------------------------------------------------ directory

class RunDir:
    def __init__(self, path: Path):
        self.path = Path(path)
        self._lock_fh = None

    journal_path = property(lambda self: self.path / "journal.jsonl")
    state_path = property(lambda self: self.path / "state.json")
    results_path = property(lambda self: self.path / "results.h5")
    meta_path = property(lambda self: self.path / "run.json")
    case_path = property(lambda self: self.path / "case.yaml")
    evals_path = property(lambda self: self.path / "evals")

    @classmethod
    def create(cls, path: Path, case, problem, evaluator: str) -> "RunDir":
        """Create the directory atomically (build under a temporary name, then rename)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.creating-"))
        normal_mode(tmp, directory=True)
        try:
            (tmp / "evals").mkdir()
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
            if getattr(case, "realisations", 0):
                from ..config.uncertainty import record

                # the realisations of the track every design meets: a resume checks that it
                # draws the same ones
                meta["realisations"] = record(case)
            (tmp / "case.yaml").write_text(resolved, encoding="utf-8")
            (tmp / "case.source.yaml").write_text(case.text, encoding="utf-8")
            (tmp / "run.json").write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
            (tmp / "lock").touch()
            with open(tmp / "journal.jsonl", "wb") as fh:
                line = {"seq": 0, "event": "run", "time": now_iso(),
                        "case_sha256": meta["case_sha256"],
                        "budget": problem.budget, "objectives": list(problem.objectives),
                        "seed": problem.seed, "versions": meta["versions"],
                        # what the surrogate fits (Problem.surrogate: the objectives, the
                        # sleeper energies or the value) and the optimiser's settings: a
                        # resume rebuilds the optimiser from these (replay.restore)
                        "surrogate": problem.surrogate,
                        "optimiser": problem.optimiser_settings().to_dict()}
                if "realisations" in meta:
                    line["realisations"] = meta["realisations"]
                fh.write((json.dumps(line, separators=(",", ":")) + "\n").encode())
                fh.flush()
                os.fsync(fh.fileno())
            for f in tmp.iterdir():
                if f.is_file():
                    with open(f, "rb") as fh:
                        os.fsync(fh.fileno())
            fsync_dir(tmp)
            os.rename(tmp, path)
        except OSError as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            if exc.errno in (errno.EEXIST, errno.ENOTEMPTY):
                raise RunError(f"{path} already exists (another run was started at the same "
                               f"time?)") from None
            raise
        fsync_dir(path.parent)
        return cls(path)

    @classmethod
    def open(cls, path: Path) -> "RunDir":
        path = Path(path)
        if not path.is_dir():
            raise RunError(f"{path}: no such run directory")
        if not all(os.path.lexists(path / name) for name in ("run.json", "journal.jsonl")):
            raise RunError(f"{path}: not an lccopt run directory (no run.json or journal.jsonl)")
        rd = cls(path)
        rd.check_entries()
        return rd

    OWNED_FILES = ("run.json", "journal.jsonl", "lock", "state.json", "results.h5", "case.yaml",
                   "case.source.yaml")

    def check_entries(self) -> None:
        """Every file and folder lccopt keeps in the run is what lccopt made: a regular file
        (a real folder for evals/), never a link or a special file planted there (RunError)."""
        for name in self.OWNED_FILES:
            p = self.path / name
            if os.path.lexists(p) and not is_regular_file(p):
                raise RunError(f"{p}: {kind_of(os.lstat(p).st_mode)}, where lccopt keeps a file "
                               f"of its own; lccopt never reads or writes through it: remove it")
        if os.path.lexists(self.evals_path):
            try:
                check_owned_dir(self.evals_path)
            except UnsafeFile as exc:
                raise RunError(f"{exc}") from None
            for entry in os.scandir(self.evals_path):
                if not entry.is_file(follow_symlinks=False):
                    kind = kind_of(entry.stat(follow_symlinks=False).st_mode)
                    raise RunError(f"{entry.path}: {kind} among the run's evaluation files; "
                                   f"lccopt never reads or writes through it: remove it")

    def evals_dir(self) -> Path:
        """evals/, made again if it was deleted under the run; never a link (UnsafeFile)."""
        try:
            self.evals_path.mkdir()
        except FileExistsError:
            pass
        check_owned_dir(self.evals_path)
        return self.evals_path

    def meta(self) -> dict:
        try:
            meta = json.loads(read_owned(self.meta_path, MAX_META_BYTES).decode("utf-8"))
        except (OSError, ValueError) as exc:
            raise RunError(f"{self.meta_path}: unreadable ({exc})") from None
        if not isinstance(meta, dict) or meta.get("format") != RUN_FORMAT:
            raise RunError(f"{self.meta_path}: not an lccopt run description")
        return meta

    def locked_by_other(self) -> bool:
        """True while another process holds the run's lock (flock: immune to PID reuse)."""
        try:
            fh = open_owned(self.path / "lock", "rb")
        except FileNotFoundError:
            return False
        except OSError as exc:
            raise RunError(f"{exc}") from None
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            return True
        finally:
            fh.close()  # closing drops a lock we got
        return False

    def write_meta(self, meta: dict) -> None:
        atomic_write_bytes(self.meta_path, (json.dumps(meta, indent=2) + "\n").encode())

    # -- lock -------------------------------------------------------------------------------
    def lock(self) -> None:
        try:
            fh = open_owned(self.path / "lock", "a+")
        except UnsafeFile as exc:
            raise RunError(f"{exc}") from None
        except OSError as exc:
            raise RunError(f"{self.path / 'lock'}: cannot open the run's lock file "
                           f"({exc.strerror or exc}); lccopt needs to write in the run "
                           f"directory") from None
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.seek(0)
            holder = fh.read().strip()
            fh.close()
            raise RunError(f"{self.path} is in use by another lccopt process"
                           f"{' (' + holder + ')' if holder else ''}; wait for it to finish or "
                           f"stop it first")
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()} on {platform.node()} since {now_iso()}\n")
        fh.flush()
        self._lock_fh = fh

    def unlock(self) -> None:
        if self._lock_fh is not None:
            with contextlib.suppress(OSError):
                self._lock_fh.seek(0)
                self._lock_fh.truncate()
            fcntl.flock(self._lock_fh.fileno(), fcntl.LOCK_UN)
            self._lock_fh.close()
            self._lock_fh = None

    # -- snapshot -----------------------------------------------------------------------------
    def save_state(self, seq: int, state: dict, mark: str) -> None:
        """The optimiser's state after journal line ``seq`` (``mark``: that line's line_mark)."""
        data = json.dumps({"seq": seq, "mark": mark, "strategy": state}, allow_nan=False,
                          separators=(",", ":"))
        atomic_write_bytes(self.state_path, data.encode())

    def write_case(self, resolved: str) -> None:
        atomic_write_bytes(self.case_path, resolved.encode("utf-8"))

    def load_state(self) -> dict | None:
        """The optimiser snapshot, or None if there is none or it is not usable (it is a
        cache: resume then replays the whole journal)."""
        try:
            d = json.loads(read_owned(self.state_path).decode("utf-8"))
            whole = isinstance(d, dict) and isinstance(d.get("seq"), int) and "strategy" in d
            return d if whole else None
        except (OSError, ValueError):
            return None

    def clean(self, pending: set[str]) -> list[str]:
        """Remove temporary files and the unfinished files of pending evaluations; return them.

        Only files lccopt itself would write again, and only regular files directly in the run
        directory or in its own evals/ (never through a link): an evaluation file the journal
        does not account for is never removed (it may be the only copy of a result)."""
        gone = []
        for d in (self.path, self.evals_path):
            if d == self.evals_path:
                if not os.path.lexists(d):
                    continue
                check_owned_dir(d)
            for f in d.iterdir():
                rel = f.relative_to(self.path).as_posix()
                if is_regular_file(f) and (f.name.endswith(".tmp") or rel in pending):
                    f.unlink()
                    gone.append(rel)
        return gone


# ------------------------------------------------------------------------------ table

class Table:
    """All evaluations as the journal describes them (rebuilt by replaying its events)."""

    def __init__(self, names: list[str], objectives: list[str]):
        self.names = list(names)
        self.objectives = list(objectives)
        self.rows: dict[int, dict] = {}
        self.reference: dict | None = None   # objectives, point, worst, ...
        self.finished = False
        self.seq = -1
        self.last_event: dict | None = None
        self.lag: int | None = None          # the schedule's lag (workers) of the last session
        self.batch = 1                       # and its block size (schedule.batch_size)

    def apply(self, ev: dict) -> None:
        self.seq = ev["seq"]
        self.last_event = ev
        kind = ev["event"]
        if kind == "asked":
            self.rows[ev["id"]] = {
                "id": ev["id"], "x": list(ev["x"]), "phase": ev["phase"], "restart": ev["restart"],
                "status": "pending", "reason": "", "objectives": {}, "value": math.nan,
                "wall_time": math.nan, "worker": "", "file": "",
            }
        elif kind in ("evaluated", "failed"):
            r = self.rows[ev["id"]]
            r["status"] = "ok" if kind == "evaluated" else "failed"
            r["objectives"] = dict(ev.get("objectives") or {})
            r["value"] = ev.get("value", math.nan) if kind == "evaluated" else math.nan
            r["reason"] = ev.get("reason", "")
            r["wall_time"] = ev.get("wall_time", math.nan)
            r["worker"] = ev.get("worker", "")
            r["file"] = ev.get("file", "")
            if r["file"] not in ("", eval_name(ev["id"])):  # never a path out of the run
                raise ValueError(f"evaluation #{ev['id']} names the file {r['file'][:80]!r}")
            if "parts" in ev:  # the sleepers' energies (composite surrogate of E_max)
                r["parts"] = ev["parts"]
        elif kind == "reference":
            self.reference = {k: v for k, v in ev.items() if k not in ("seq", "event")}
        elif kind == "finished":
            self.finished = True
        elif kind == "schedule":
            self.lag = int(ev["lag"])
            self.batch = int(ev.get("batch", 1))
        elif kind == "case_changed":  # e.g. a larger budget: a finished run carries on
            self.finished = False

    # -- views ----------------------------------------------------------------------------------
    def done_rows(self) -> list[dict]:
        return [self.rows[i] for i in sorted(self.rows) if self.rows[i]["status"] != "pending"]

    def pending_ids(self) -> list[int]:
        return sorted(i for i, r in self.rows.items() if r["status"] == "pending")

    @property
    def n_done(self) -> int:
        return sum(r["status"] != "pending" for r in self.rows.values())

    @property
    def n_failed(self) -> int:
        return sum(r["status"] == "failed" for r in self.rows.values())

    def best(self) -> dict | None:
        ok = [r for r in self.rows.values() if r["status"] == "ok"]
        return min(ok, key=lambda r: (r["value"], r["id"])) if ok else None

    def files(self) -> set[str]:
        return {r["file"] for r in self.rows.values() if r["file"]}


def objective_columns(rows: list[dict], objectives) -> list[str]:
    """The objective columns of results.h5's /evaluations.

    The paper's four, then the case's objectives, then every other objective an evaluation
    returned (e.g. a settlement prediction's, a robust statistic), in the order first met; a
    condition's own values (``F_max@name``) go to /conditions and a realisation's
    (``F_max#r``) to /realisations instead.

    Parameters
    ----------
    rows
        the table's finished rows (each with an ``objectives`` dict).
    objectives
        the case's objectives.

    Returns
    -------
    list of str
    """
    out = list(OBJECTIVE_NAMES)
    for k in [*objectives, *(k for r in rows for k in r["objectives"])]:
        if k not in out and (k in objectives or ("@" not in k and "#" not in k)):
            out.append(k)
    return out


def write_results(path: Path, table: Table, *, case, problem, meta: dict) -> None:
    """Write results.h5 (layout in docs/runs.md, 'results.h5') to tmp, fsync, rename."""
    import h5py

    from ..vti.response import objective_unit

    path = Path(path)
    rows = table.done_rows()
    n, d = len(rows), len(table.names)
    sdt = h5py.string_dtype()
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        a = f.attrs
        a["format"], a["format_version"] = RESULTS_FORMAT, RESULTS_VERSION
        a["case_name"] = case.name
        a["objectives"] = list(problem.objectives)
        a["scalarisation"] = problem.scalarisation
        a["rho"], a["improvement"] = problem.rho, problem.improvement
        a["worst"] = np.array(problem.worst if problem.worst else [], dtype=float)
        a["budget"], a["seed"] = problem.budget, problem.seed
        a["initial_points"] = problem.initial_points
        a["n_evaluations"], a["n_failed"] = n, table.n_failed
        a["n_pending"] = len(table.pending_ids())
        a["finished"] = bool(table.finished)
        a["journal_seq"] = table.seq
        a["created"], a["updated"] = meta.get("created", ""), now_iso()

        g = f.create_group("case")
        g.create_dataset("text", data=case.text, dtype=sdt)
        g.create_dataset("resolved", data=case.resolved, dtype=sdt)
        g.attrs["sha256"] = sha256_text(case.resolved)
        g.attrs["file"] = meta.get("case_file", "")

        g = f.create_group("versions")
        for k, v in versions().items():
            g.attrs[k] = v
        g.attrs["run_started_with"] = json.dumps(meta.get("versions", {}))

        g = f.create_group("reference")
        ds = g.create_dataset("x", data=np.array(problem.reference, dtype=float))
        ds.attrs["names"] = list(table.names)
        ref = table.reference or {}
        og = g.create_group("objectives")
        for k, v in (ref.get("objectives") or {}).items():
            og.attrs[k] = v
        if ref.get("point") is not None:
            g.create_dataset("point", data=np.array(ref["point"], dtype=float))
        if problem.worst:
            g.create_dataset("worst", data=np.array(problem.worst, dtype=float))

        e = f.create_group("evaluations")
        e.attrs["names"] = list(table.names)
        e.create_dataset("id", data=np.array([r["id"] for r in rows], dtype=np.int64))
        x = e.create_dataset("x", data=np.array([r["x"] for r in rows], dtype=float).reshape(n, d))
        x.attrs["names"] = list(table.names)
        columns = objective_columns(rows, problem.objectives)
        a["objective_columns"] = columns
        for k in columns:
            col = e.create_dataset(k, data=np.array([float(r["objectives"].get(k, math.nan))
                                                     for r in rows], dtype=float))
            col.attrs["unit"] = objective_unit(k)
        if problem.conditions:  # every condition's objectives
            a["conditions"] = list(problem.conditions)
            a["condition_weights"] = np.array(problem.weights, dtype=float)
            a["condition_mode"] = problem.condition_mode
            cg = f.create_group("conditions")  # rows as in /evaluations
            for c, w in zip(problem.conditions, problem.weights):
                g_c = cg.create_group(c)
                g_c.attrs["weight"] = w
                for k in OBJECTIVE_NAMES:
                    col = g_c.create_dataset(k, data=np.array(
                        [float(r["objectives"].get(f"{k}@{c}", math.nan)) for r in rows],
                        dtype=float))
                    col.attrs["unit"] = objective_unit(k)
        if getattr(problem, "realisations", 0):  # every realisation's objectives: (n, R) each
            _write_realisations(f, rows, problem, case, meta)
        e.create_dataset("value", data=np.array([r["value"] for r in rows], dtype=float))
        for k in ("status", "reason", "phase", "worker", "file"):
            e.create_dataset(k, data=[str(r[k]) for r in rows], dtype=sdt)
        e.create_dataset("restart", data=np.array([r["restart"] for r in rows], dtype=np.int64))
        wt = e.create_dataset("wall_time",
                              data=np.array([r["wall_time"] for r in rows], dtype=float))
        wt.attrs["unit"] = "s"
        F = np.array([[float(r["objectives"].get(k, math.nan)) for k in problem.objectives]
                      for r in rows], dtype=float).reshape(n, len(problem.objectives))
        ok = np.array([r["status"] == "ok" for r in rows], dtype=bool)
        if n:
            from ..optim.scalarise import pareto_mask

            F[~ok] = math.nan
            e.create_dataset("pareto", data=pareto_mask(F))
        else:
            e.create_dataset("pareto", data=np.zeros(0, dtype=bool))

        links = f.create_group("evals")  # external links: f["evals/000012/histories/contact_force"]
        for r in rows:
            if r["file"]:
                links[f"{r['id']:06d}"] = h5py.ExternalLink(r["file"], "/")

        g = f.create_group("best")
        best = table.best()
        if best is not None:
            g.attrs["id"], g.attrs["value"] = best["id"], best["value"]
            ds = g.create_dataset("x", data=np.array(best["x"], dtype=float))
            ds.attrs["names"] = list(table.names)
            for k, v in best["objectives"].items():
                g.attrs[k] = v


def _write_realisations(f, rows: list[dict], problem, case, meta: dict) -> None:
    """/realisations: the run's realisations of the track (count, seed, fingerprint) and, for
    each objective recorded per realisation, an (evaluations, realisations) table in the rows
    of /evaluations."""
    from ..uncertainty.statistics import is_realisation_key, objective_of
    from ..vti.response import objective_unit

    n = int(problem.realisations)
    g = f.create_group("realisations")
    g.attrs["count"] = n
    g.attrs["seed"] = int(meta.get("realisations", {}).get("seed", -1))
    g.attrs["fingerprint"] = str(meta.get("realisations", {}).get("fingerprint", ""))
    names = []
    for r in rows:
        for k in r["objectives"]:
            base = objective_of(k)
            if is_realisation_key(k) and base not in names:
                names.append(base)
    for base in names:
        ds = g.create_dataset(base, data=np.array(
            [[float(r["objectives"].get(f"{base}#{j}", math.nan)) for j in range(n)]
             for r in rows], dtype=float).reshape(len(rows), n))
        ds.attrs["unit"] = objective_unit(base)
