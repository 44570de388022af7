"""``lccopt report RUN``: figures and a summary of a run, after the paper's Figs. 6-11, Tables 5-7.

Writes into ``RUN/report/``:

    search-history.png     value of every evaluation by number, phase, failures, best so far,
                           restarts (Figs. 6, 7, 10)
    objective-space.png    all evaluations in (F_max, E_max) (the run's two first objectives for
                           a multi-objective run), Pareto front, reference design, reference
                           point, chosen compromise (Fig. 9); drawn for single-objective runs too
    best-vs-reference.png  change of every objective and design variable, best vs reference
                           (Tables 5-7 as a picture; the numbers are in the summary)
    contact-force.png      contact force against wheel position, best and reference (ERS and
                           evaluation zone marked)
    sleeper-energy.png     energy dissipated under each zone sleeper, best and reference (Fig. 11)
    track-layout.png       drawing of the entry side next to the interface, best and reference
    sensitivity.png        each design variable against the value over all evaluations
    report.md / report.html  the summary (HTML self-contained: figures embedded as base64)
    summary.json           the key numbers, machine-readable

Read-only on the run: results.h5 is opened read-only and read at once (the engine replaces it
atomically); when the journal has committed more evaluations than results.h5 shows (a running
or killed run), the evaluation table is rebuilt from the journal instead. Only the evaluation
files of the best and the reference design are read; missing ones (failed evaluations, files of
a fake evaluator without histories) leave a note instead of a figure.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import json
import math
import os
import platform
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .atomic import atomic_write_text

FORMATS = ("md", "html", "both")
OBJECTIVE_NAMES = ("F_rms", "F_max", "E_rms", "E_max")
OBJECTIVE_DOC = {
    "F_rms": "rms of the wheel-rail contact force in the force zone",
    "F_max": "range (max - min) of the wheel-rail contact force in the force zone",
    "E_rms": "rms of the energy dissipated under the zone sleepers",
    "E_max": "range (max - min) of the energy dissipated under the zone sleepers",
}
PHASE_STYLE = {  # phase -> (label, marker, colour)
    "initial": ("initial design (Latin hypercube)", "^", "0.35"),
    "adaptive": ("adaptive candidates (DYCORS)", "o", "tab:blue"),
    "random": ("random candidates", "s", "tab:purple"),
    "local": ("local search of the surrogate", "D", "tab:cyan"),
}
REF_COLOR, BEST_COLOR, FAIL_COLOR, FRONT_COLOR = "tab:orange", "tab:blue", "tab:red", "tab:green"
DPI = 110

FIGURES = ("search-history", "objective-space", "best-vs-reference", "contact-force", "sleeper-energy",
           "track-layout", "sensitivity")


def _usage(message: str) -> Exception:
    from .cli import UsageError

    return UsageError(message)


# ================================================================================ reading

@dataclass
class VarInfo:
    name: str
    group: str
    integer: bool
    lower: float
    upper: float
    reference: float
    label: str       # what it is, in words
    unit: str        # display unit
    scale: float     # display value = SI value * scale


@dataclass
class RunData:
    path: Path
    name: str
    objectives: list[str]
    scalarisation: str
    budget: int
    names: list[str]
    variables: list[VarInfo]
    ids: np.ndarray
    x: np.ndarray
    obj: dict                      # objective name -> array over evaluations
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
    case: object = None            # lccopt.case.Case when the run's case could be loaded
    case_note: str = ""
    notes: list[str] = field(default_factory=list)
    created: str = ""
    updated: str = ""
    sessions_wall: float = math.nan

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

    def ref_index(self) -> int | None:
        """The reference design's evaluation (always proposal 0), or one with the same x."""
        hit = np.flatnonzero(self.ids == 0)
        if len(hit) and np.allclose(self.x[hit[0]], self.ref_x):
            return int(hit[0])
        same = np.flatnonzero(np.all(np.isclose(self.x, self.ref_x[None, :]), axis=1))
        return int(same[0]) if len(same) else None


def _s(v) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


def _var_info(name: str, group: str, integer: bool, lo: float, hi: float, ref: float, count: int,
              index: int) -> VarInfo:
    """Display label and unit of a design variable (from its group, or its name's stem)."""
    if not group:
        group = {"x_r": "railpad_stiffness", "x_n": "strengthened_sleepers", "x_s": "sleeper_spans",
                 "x_l": "type_ii_strip"}.get(name[:3].rstrip("0123456789"), "")
    if group == "railpad_stiffness":
        k = count - index  # x_rN nearest the interface = sleeper 1
        return VarInfo(name, group, integer, lo, hi, ref, f"railpad stiffness, sleeper {k} from the interface",
                       "MN/m", 1e-6)
    if group == "strengthened_sleepers":
        return VarInfo(name, group, integer, lo, hi, ref, "strengthened sleepers next to the interface",
                       "sleepers", 1.0)
    if group == "sleeper_spans":
        k = count - index
        what = ("slab edge to sleeper 1" if k == 1 else f"sleeper {k - 1} to sleeper {k}")
        return VarInfo(name, group, integer, lo, hi, ref, f"span {what}", "× 0.1 m", 1.0)
    if group == "type_ii_strip":
        return VarInfo(name, group, integer, lo, hi, ref, "Type II strip from the entry slab edge",
                       "× 0.1 m", 1.0)
    return VarInfo(name, group, integer, lo, hi, ref, name, "", 1.0)


def _load_case(run: Path, resolved_text: str | None):
    """The run's case (resolved copy), or (None, why)."""
    from .case import CaseError, load_case

    candidates = []
    if (run / "case.yaml").is_file():
        candidates.append(run / "case.yaml")
    why = "no case.yaml in the run directory"
    for p in candidates:
        try:
            return load_case(p), ""
        except CaseError as exc:
            why = str(exc)
    if resolved_text:
        # e.g. an irregularity file relative to the original case: load without it
        import yaml

        try:
            data = yaml.safe_load(resolved_text)
            if isinstance(data, dict) and isinstance(data.get("simulation"), dict):
                data["simulation"].pop("irregularity", None)
            with tempfile.TemporaryDirectory() as d:
                p = Path(d) / "case.yaml"
                p.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
                return load_case(p), ""
        except Exception as exc:  # noqa: BLE001 - a report without the case is still a report
            why = f"{why}; {exc}"
    return None, why


def _lock_state(run: Path) -> str:
    """'running' if the lock file names a live process on this host, else 'stopped'.

    Passive: reads the file the engine writes its pid into; never takes the lock."""
    try:
        text = (run / "lock").read_text(encoding="utf-8").strip()
    except OSError:
        return "stopped"
    parts = text.split()
    if len(parts) >= 4 and parts[0] == "pid" and parts[2] == "on":
        if parts[3] != platform.node():
            return "running"  # another host: cannot check, believe the file
        try:
            os.kill(int(parts[1]), 0)
            return "running"
        except (ValueError, ProcessLookupError):
            return "stopped"
        except PermissionError:
            return "running"
    return "stopped"


def load_run(path: Path) -> RunData:
    """Read a run directory (finished, running or interrupted); UsageError if it is not one."""

    from .engine.journal import JournalError, read_journal

    run = Path(path)
    if not run.exists():
        raise _usage(f"{run}: no such run directory")
    if not run.is_dir():
        raise _usage(f"{run}: not a directory (expected a run directory such as runs/<case name>)")
    has_results = (run / "results.h5").is_file()
    has_journal = (run / "journal.jsonl").is_file()
    if not has_results and not has_journal:
        raise _usage(f"{run}: not an lccopt run directory (no results.h5 or journal.jsonl)")

    res = None
    res_error = ""
    if has_results:
        try:
            res = _read_results(run / "results.h5")
        except (OSError, KeyError, ValueError) as exc:
            res_error = f"{run / 'results.h5'} is unreadable ({exc})"
    events: list[dict] = []
    if has_journal:
        try:
            events, _, _ = read_journal(run / "journal.jsonl")
        except (JournalError, OSError) as exc:
            if res is None:
                raise _usage(f"{run}: cannot read the run: {res_error or 'no results.h5'}; {exc}") from None
    if res is None and not events:
        raise _usage(f"{run}: cannot read the run: {res_error or 'no results.h5 and an empty journal'}")

    journal_seq = events[-1]["seq"] if events else -1
    notes = []
    if res is not None and (not events or res["journal_seq"] >= journal_seq):
        d, source = res, "results.h5"
    else:
        try:
            d = _from_journal(run, events, res)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            if res is None:
                raise _usage(f"{run}: cannot read the run: {res_error or 'no results.h5'}; "
                             f"journal.jsonl: {type(exc).__name__}: {exc}") from None
            d, source = res, "results.h5"
        else:
            source = "journal.jsonl"
            if res is not None:
                notes.append(f"results.h5 lags the journal (it is rebuilt every few seconds while a run goes, "
                             f"and a killed run may not have rebuilt it); the table was read from the journal's "
                             f"committed lines: {len(d['ids'])} evaluations, results.h5 had {len(res['ids'])}")
            elif res_error:
                notes.append(res_error + "; the table was rebuilt from journal.jsonl")
    if len(d["ids"]) == 0:
        raise _usage(f"{run}: nothing to report yet: no evaluation has finished")

    case, case_note = _load_case(run, d.get("resolved"))
    names = list(d["names"])
    variables = []
    if case is not None and case.names == names:
        counts = {}
        for v in case.variables:
            counts[v.group] = counts.get(v.group, 0) + 1
        seen: dict = {}
        for v in case.variables:
            i = seen.get(v.group, 0)
            seen[v.group] = i + 1
            variables.append(_var_info(v.name, v.group, v.integer, v.lower, v.upper, v.reference,
                                       counts[v.group], i))
    else:
        if case is not None:
            case_note = "the run's case.yaml has other design variables than results.h5"
            case = None
        stems = [n.rstrip("0123456789") for n in names]
        for i, n in enumerate(names):
            same = [j for j, s in enumerate(stems) if s == stems[i]]
            variables.append(_var_info(n, "", False, math.nan, math.nan, float(d["ref_x"][i]), len(same),
                                       same.index(i)))

    lock = _lock_state(run)
    state = "finished" if d["finished"] else ("running" if lock == "running" else "interrupted")
    sessions = [ev.get("wall_time", 0.0) for ev in events if ev.get("event") == "session"]
    created = d.get("created") or (events[0].get("time", "") if events else "")
    return RunData(
        path=run, name=d["name"] or run.name, objectives=list(d["objectives"]),
        scalarisation=d["scalarisation"], budget=int(d["budget"]), names=names, variables=variables,
        ids=d["ids"], x=d["x"], obj=d["obj"], value=d["value"], status=d["status"], reason=d["reason"],
        phase=d["phase"], restart=d["restart"], file=d["file"], wall_time=d["wall_time"],
        pareto=d["pareto"], ref_x=d["ref_x"], ref_objectives=d["ref_objectives"], ref_point=d["ref_point"],
        worst=d["worst"], rho=d["rho"], improvement=d["improvement"], n_pending=int(d["n_pending"]),
        finished=bool(d["finished"]), state=state, source=source, case=case, case_note=case_note,
        notes=notes, created=created, updated=d.get("updated", ""),
        sessions_wall=float(sum(sessions)) if sessions else math.nan)


def _read_results(path: Path) -> dict:
    """Everything the report needs from results.h5, read at once into memory."""
    import h5py

    with h5py.File(path, "r") as f:
        a = f.attrs
        e = f["evaluations"]
        ids = e["id"][()].astype(int)
        n = len(ids)
        names = [_s(v) for v in e["x"].attrs.get("names", e.attrs.get("names", []))]
        strs = {k: np.array([_s(v) for v in e[k][()]], dtype=object) if n else np.array([], dtype=object)
                for k in ("status", "reason", "phase", "file")}
        ref = f["reference"]
        objectives = [_s(v) for v in a["objectives"]]
        worst = np.asarray(a.get("worst", []), dtype=float)
        return {
            "name": _s(a.get("case_name", "")), "objectives": objectives,
            "scalarisation": _s(a.get("scalarisation", "single")), "budget": int(a.get("budget", n)),
            "names": names, "ids": ids, "x": e["x"][()].reshape(n, len(names)),
            "obj": {k: e[k][()].astype(float) for k in OBJECTIVE_NAMES if k in e},
            "value": e["value"][()].astype(float), **strs,
            "restart": e["restart"][()].astype(int), "wall_time": e["wall_time"][()].astype(float),
            "pareto": e["pareto"][()].astype(bool) if "pareto" in e else np.zeros(n, bool),
            "ref_x": ref["x"][()].astype(float),
            "ref_objectives": {k: float(v) for k, v in ref["objectives"].attrs.items()} if "objectives" in ref else {},
            "ref_point": ref["point"][()].astype(float) if "point" in ref else None,
            "worst": worst if worst.size else None, "rho": float(a.get("rho", math.nan)),
            "improvement": float(a.get("improvement", math.nan)),
            "n_pending": int(a.get("n_pending", 0)), "finished": bool(a.get("finished", False)),
            "journal_seq": int(a.get("journal_seq", -1)), "created": _s(a.get("created", "")),
            "updated": _s(a.get("updated", "")),
            "resolved": _s(f["case/resolved"][()]) if "case/resolved" in f else None,
        }


def _from_journal(run: Path, events: list[dict], res: dict | None) -> dict:
    """The same table as results.h5, rebuilt from the committed journal lines."""
    from .engine.rundir import Table
    from .optim.scalarise import pareto_mask

    head = events[0] if events and events[0].get("event") == "run" else {}
    objectives = list(head.get("objectives") or (res or {}).get("objectives") or ["F_max"])
    budget = int(head.get("budget") or (res or {}).get("budget") or 0)
    for ev in events:
        if ev.get("event") == "case_changed" and ev.get("budget"):
            budget = int(ev["budget"])
    asked = next((ev for ev in events if ev.get("event") == "asked"), None)
    d = len(asked["x"]) if asked else len((res or {}).get("names", []))
    names = list((res or {}).get("names") or [])
    if len(names) != d:
        names = _names_from_case_yaml(run) or [f"x{i + 1}" for i in range(d)]
    table = Table(names, objectives)
    for ev in events:
        table.apply(ev)
    rows = table.done_rows()
    n = len(rows)
    obj = {k: np.array([float(r["objectives"].get(k, math.nan)) for r in rows], dtype=float)
           for k in OBJECTIVE_NAMES}
    status = np.array([r["status"] for r in rows], dtype=object)
    F = np.column_stack([obj[k] for k in objectives]) if n else np.zeros((0, len(objectives)))
    F = F.copy()
    F[status != "ok"] = math.nan
    ref = table.reference or {}
    ref_x = np.asarray(ref.get("x") or (res or {}).get("ref_x") if (ref.get("x") or res) else
                       (rows[0]["x"] if rows and rows[0]["id"] == 0 else [math.nan] * d), dtype=float)
    worst = ref.get("worst") or ((res or {}).get("worst"))
    return {
        "name": (res or {}).get("name") or _case_name(run), "objectives": objectives,
        "scalarisation": "asf" if len(objectives) > 1 else "single", "budget": budget, "names": names,
        "ids": np.array([r["id"] for r in rows], dtype=int),
        "x": np.array([r["x"] for r in rows], dtype=float).reshape(n, d), "obj": obj,
        "value": np.array([r["value"] for r in rows], dtype=float), "status": status,
        "reason": np.array([str(r["reason"]) for r in rows], dtype=object),
        "phase": np.array([r["phase"] for r in rows], dtype=object),
        "restart": np.array([r["restart"] for r in rows], dtype=int),
        "file": np.array([r["file"] for r in rows], dtype=object),
        "wall_time": np.array([r["wall_time"] for r in rows], dtype=float),
        "pareto": pareto_mask(F) if n else np.zeros(0, bool),
        "ref_x": ref_x, "ref_objectives": dict(ref.get("objectives") or {}),
        "ref_point": np.asarray(ref["point"], float) if ref.get("point") is not None else None,
        "worst": np.asarray(worst, float) if worst is not None else None,
        "rho": float(ref.get("rho", math.nan) or math.nan), "improvement": float(ref.get("improvement", math.nan)
                                                                                   or math.nan),
        "n_pending": len(table.pending_ids()), "finished": table.finished,
        "created": head.get("time", ""), "updated": events[-1].get("time", "") if events else "",
        "resolved": (res or {}).get("resolved"),
    }


def _names_from_case_yaml(run: Path) -> list[str] | None:
    from .case import CaseError, load_case

    try:
        return load_case(run / "case.yaml").names
    except (CaseError, OSError):
        return None


def _case_name(run: Path) -> str:
    try:
        return json.loads((run / "run.json").read_text(encoding="utf-8")).get("name", run.name)
    except (OSError, ValueError):
        return run.name


def read_history(run: RunData, index: int | None) -> tuple[dict | None, dict, str]:
    """(histories, info, note) of evaluation ``index`` from its file; histories None if unreadable."""
    from .store import read_evaluation

    if index is None:
        return None, {}, "no evaluation"
    f = run.file[index]
    if not f:
        return None, {}, f"evaluation #{run.ids[index]} has no histories file"
    p = run.path / f
    if not p.is_file():
        return None, {}, f"{f} is missing"
    try:
        _, ev = read_evaluation(p)
    except Exception as exc:  # noqa: BLE001 - a damaged file is a note, not a crash
        return None, {}, f"{f} is unreadable ({type(exc).__name__}: {exc})"
    return ev.histories, ev.info, ""


# ================================================================================ formatting

def obj_unit(k: str) -> str:
    return "N" if k.startswith("F") else "J"


def obj_display(k: str) -> tuple[float, str]:
    """(scale, unit) to show objective k in plots: forces in kN, energies in J."""
    return (1e-3, "kN") if k.startswith("F") else (1.0, "J")


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
    return f"{(new - old) / abs(old) * 100:+.1f} %"


def var_value(v: VarInfo, value: float) -> str:
    if not np.isfinite(value):
        return "–"
    if v.group in ("sleeper_spans", "type_ii_strip"):
        return f"{value:g} ({value * 0.1:.1f} m)"
    if v.integer or v.group == "strengthened_sleepers":
        return f"{value:g}"
    return f"{value * v.scale:.4g}"


def var_axis_label(v: VarInfo) -> str:
    if v.group in ("sleeper_spans", "type_ii_strip"):
        return f"{v.name} [elements of 0.1 m]"
    return f"{v.name} [{v.unit}]" if v.unit else v.name


def value_label(run: RunData) -> tuple[float, str]:
    """(scale, axis label) of the value the optimiser minimised."""
    if run.multi:
        return 1.0, f"ASF value (Eq. 7) of {', '.join(run.objectives)} [-]"
    k = run.objectives[0]
    s, u = obj_display(k)
    return s, f"{k} [{u}]"


# ================================================================================ figures

def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 9, "axes.titlesize": 10, "legend.fontsize": 8,
                         "axes.grid": True, "grid.alpha": 0.3, "figure.dpi": DPI})
    return plt


def _save(fig, path: Path) -> Path:
    fig.savefig(path, dpi=DPI)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path


def _history_panel(ax, run: RunData, vals: np.ndarray, ylo: float, yhi: float, arrows: bool = True) -> list:
    """One panel of the search history; returns the legend handles."""
    import matplotlib.transforms as mtransforms
    from matplotlib.lines import Line2D

    ok = run.ok & np.isfinite(vals)
    ref_i = run.ref_index()
    clipped = ok & (vals > yhi)
    unit = "" if run.multi else " " + obj_display(run.objectives[0])[1]
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    handles = []
    for ph, (label, marker, color) in PHASE_STYLE.items():
        m = ok & (run.phase == ph) & ~clipped
        if ref_i is not None:
            m[ref_i] = False
        if m.any():
            ax.scatter(run.ids[m], vals[m], marker=marker, s=18, color=color, alpha=0.8, lw=0, zorder=3)
        n_ph = int((ok & (run.phase == ph)).sum())
        if n_ph:
            handles.append(Line2D([], [], ls="", marker=marker, color=color, label=f"{label} ({n_ph})"))
    other = ok & ~np.isin(run.phase, list(PHASE_STYLE)) & ~clipped
    if other.any():
        ax.scatter(run.ids[other], vals[other], marker="o", s=18, color="0.6", zorder=3)
        handles.append(Line2D([], [], ls="", marker="o", color="0.6", label=f"other ({other.sum()})"))
    if ref_i is not None and ok[ref_i] and not clipped[ref_i]:
        ax.scatter([run.ids[ref_i]], [vals[ref_i]], marker="D", s=60, color=REF_COLOR, edgecolor="k", zorder=5)
    if ref_i is not None and ok[ref_i]:
        handles.append(Line2D([], [], ls="", marker="D", color=REF_COLOR, markeredgecolor="k",
                              label=f"reference design (#{run.ids[ref_i]})"))
    tr = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    if clipped.any() and arrows:
        ax.scatter(run.ids[clipped], np.full(clipped.sum(), 0.985), marker="$\u2191$", s=40, color="0.45",
                   transform=tr, clip_on=False, zorder=4)
        handles.append(Line2D([], [], ls="", marker="$\u2191$", markersize=8, color="0.45",
                              label=f"above the plotted range ({clipped.sum()})"))
    failed = run.status == "failed"
    if failed.any():
        ax.scatter(run.ids[failed], np.full(failed.sum(), 0.03), marker="x", s=40, color=FAIL_COLOR,
                   transform=tr, zorder=6, clip_on=False)
        handles.append(Line2D([], [], ls="", marker="x", color=FAIL_COLOR,
                              label=f"failed evaluation ({failed.sum()}), no value"))
    order = np.argsort(run.ids)
    v = np.where(ok, vals, np.inf)[order]
    best = np.minimum.accumulate(v)
    has = np.isfinite(best)
    if has.any():
        xs = np.append(run.ids[order][has], run.ids.max() + 0.5)
        ax.step(xs, np.append(best[has], best[has][-1]), where="post", color=FRONT_COLOR, lw=2.2, zorder=4)
        handles.append(Line2D([], [], color=FRONT_COLOR, lw=2.2, label="best so far"))
    bi = run.best_index()
    if bi is not None:
        ax.scatter([run.ids[bi]], [vals[bi]], marker="*", s=180, color=BEST_COLOR, edgecolor="k", zorder=7)
        handles.append(Line2D([], [], ls="", marker="*", markersize=12, color=BEST_COLOR, markeredgecolor="k",
                              label=f"best: #{run.ids[bi]}, {fnum(vals[bi], 4)}{unit}"))
    starts = [int(run.ids[run.restart == r].min()) for r in np.unique(run.restart) if r > 0]
    for k, i0 in enumerate(starts):
        ax.axvline(i0 - 0.5, color="k", ls="--", lw=1.0, zorder=2)
        ax.text(i0 - 0.5, 0.88, f" restart {k + 1}", transform=ax.get_xaxis_transform(), va="top",
                ha="left", fontsize=8, bbox=dict(facecolor="white", edgecolor="none", alpha=0.7, pad=1))
    if starts:
        handles.append(Line2D([], [], color="k", ls="--", lw=1.0, label="restart (fresh design)"))
    if run.multi and run.ref_point is not None and ylo < 0 < yhi:
        ax.axhline(0.0, color="0.3", lw=0.8, ls=":")
        handles.append(Line2D([], [], color="0.3", ls=":", lw=0.8, label="0: the reference point f^r"))
    ax.set_ylim(ylo, yhi)
    ax.set_xlim(-1, max(int(run.ids.max()) + 1, run.budget))
    return handles


def fig_search_history(run: RunData, out: Path) -> Path:
    """All evaluations (top) and, when it adds detail, a zoom on the best-so-far line (bottom)."""
    plt = _plt()
    s, ylabel = value_label(run)
    vals = run.value * s
    ok = run.ok & np.isfinite(vals)
    if ok.any():
        v_ok = vals[ok]
        lo, hi = float(v_ok.min()), float(np.percentile(v_ok, 95) if ok.sum() > 10 else v_ok.max())
        pad = 0.06 * (hi - lo if hi > lo else (abs(hi) or 1.0))
        ylo, yhi = lo - 2 * pad, hi + 2.5 * pad  # room below the data for the failure marks
    else:
        ylo, yhi = 0.0, 1.0
    zoom = None
    if ok.sum() > 3:
        order = np.argsort(run.ids)
        bsf = np.minimum.accumulate(np.where(ok, vals, np.inf)[order])
        later = np.flatnonzero(run.phase[order] != "initial")  # first candidate after the initial design
        n0 = max(0, int(later[0]) - 1) if len(later) else len(bsf) - 1
        top, bottom = float(bsf[n0]), float(bsf[-1])
        if np.isfinite(top) and top > bottom and (top - bottom) < 0.35 * (yhi - ylo):
            pz = 0.12 * (top - bottom)
            zoom = (bottom - 2 * pz, top + 2.5 * pz)
    if zoom is None:
        fig, ax = plt.subplots(figsize=(10, 4.6))
        axes = [ax]
    else:
        fig, axes = plt.subplots(2, 1, figsize=(10, 7.2), sharex=True, gridspec_kw={"height_ratios": [1.25, 1]})
    handles = _history_panel(axes[0], run, vals, ylo, yhi)
    axes[0].set_title(f"Search history of '{run.name}': {run.n} of {run.budget} evaluations ({run.state})")
    axes[0].set_ylabel(ylabel)
    if zoom is not None:
        _history_panel(axes[1], run, vals, *zoom, arrows=False)
        axes[1].set_ylabel(ylabel)
        axes[1].set_title("zoom on the best so far (after the initial design)", fontsize=9)
    axes[-1].set_xlabel("evaluation number")
    axes[0].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0, frameon=False)
    fig.tight_layout()
    return _save(fig, out / "search-history.png")


def fig_objective_space(run: RunData, out: Path) -> tuple[Path, str]:
    """(path, note). Multi-objective: the run's first two objectives; else F_max vs E_max.

    Left: all evaluations (logarithmic axes when they span a wide range); right: a zoom on the
    Pareto front, the reference design and the reference point."""
    plt = _plt()
    from matplotlib.ticker import FuncFormatter, LogLocator

    if run.multi:
        kx, ky = run.objectives[0], run.objectives[1]
        front = run.pareto.copy()
        note = ""
        if len(run.objectives) > 2:
            note = (f"The run has {len(run.objectives)} objectives; the figure shows the first two, the "
                    f"Pareto front is over all of them.")
    else:
        from .optim.scalarise import pareto_mask

        kx, ky = "F_max", "E_max"
        F = np.column_stack([run.obj[kx], run.obj[ky]])
        F[~run.ok] = math.nan
        front = pareto_mask(F)
        note = (f"This run minimised {run.objectives[0]} alone; the objective-space figure shows all evaluations "
                f"in (F_max, E_max) anyway, with the evaluations that no other beats in both (not the run's goal).")
    sx, ux = obj_display(kx)
    sy, uy = obj_display(ky)
    X, Y = run.obj[kx] * sx, run.obj[ky] * sy
    ok = run.ok & np.isfinite(X) & np.isfinite(Y)
    fm = ok & front
    rx, ry = run.ref_objectives.get(kx, math.nan) * sx, run.ref_objectives.get(ky, math.nan) * sy
    target = None
    if run.multi and run.ref_point is not None:
        target = (run.ref_point[0] * sx, run.ref_point[1] * sy)
    bi = run.best_index()
    px = list(X[fm]) + [v for v in (rx, target[0] if target else math.nan) if np.isfinite(v)]
    py = list(Y[fm]) + [v for v in (ry, target[1] if target else math.nan) if np.isfinite(v)]
    if bi is not None:
        px.append(X[bi])
        py.append(Y[bi])
    box = None
    if len(set(zip(np.round(px, 12), np.round(py, 12)))) >= 2 and ok.sum() >= 2:
        x0, x1, y0, y1 = min(px), max(px), min(py), max(py)
        dx, dy = (x1 - x0) or abs(x1) * 0.1 or 1.0, (y1 - y0) or abs(y1) * 0.1 or 1.0
        box = (x0 - 0.1 * dx, x1 + 0.1 * dx, y0 - 0.1 * dy, y1 + 0.1 * dy)
        fx, fy = np.ptp(X[ok]) or 1.0, np.ptp(Y[ok]) or 1.0
        if (box[1] - box[0]) > 0.5 * fx and (box[3] - box[2]) > 0.5 * fy:
            box = None  # the zoom would show about what the full view shows
    fig, axes = plt.subplots(1, 2 if box else 1, figsize=(11 if box else 7.5, 5.4), squeeze=False)
    axes = axes[0]

    def draw(ax, labels: bool):
        L = (lambda t: t) if labels else (lambda t: None)  # noqa: E731
        ax.scatter(X[ok & ~front], Y[ok & ~front], s=16, color="0.6", alpha=0.7, lw=0,
                   label=L(f"evaluations ({(ok & ~front).sum()})"))
        if fm.any():
            o = np.argsort(X[fm])
            ax.plot(X[fm][o], Y[fm][o], color=FRONT_COLOR, lw=1.0, drawstyle="steps-post", zorder=3)
            ax.scatter(X[fm], Y[fm], s=34, color=FRONT_COLOR, edgecolor="k", lw=0.5, zorder=4,
                       label=L(f"Pareto front of all evaluations ({fm.sum()})" if run.multi
                               else f"non-dominated in ({kx}, {ky}) ({fm.sum()})"))
        if np.isfinite(rx) and np.isfinite(ry):
            ax.scatter([rx], [ry], marker="D", s=70, color=REF_COLOR, edgecolor="k", zorder=5,
                       label=L(f"reference design ({fnum(rx, 4)} {ux}, {fnum(ry, 4)} {uy})"))
        if target is not None:
            imp = f"{run.improvement:.0%} better than the reference design" \
                if run.improvement is not None and np.isfinite(run.improvement) else "target"
            ax.scatter([target[0]], [target[1]], marker="P", s=90, color="tab:red", edgecolor="k", zorder=5,
                       label=L(f"reference point f^r ({imp})"))
            ax.axvline(target[0], color="tab:red", lw=0.7, ls=":", zorder=1)
            ax.axhline(target[1], color="tab:red", lw=0.7, ls=":", zorder=1)
        if bi is not None:
            lab = "chosen compromise (best ASF value)" if run.multi else f"best {run.objectives[0]}"
            ax.scatter([X[bi]], [Y[bi]], marker="*", s=260, color=BEST_COLOR, edgecolor="k", zorder=6,
                       label=L(f"{lab}: #{run.ids[bi]} ({fnum(X[bi], 4)} {ux}, {fnum(Y[bi], 4)} {uy})"))
        ax.set(xlabel=f"{kx} [{ux}]", ylabel=f"{ky} [{uy}]")

    a0 = axes[0]
    draw(a0, True)
    a0.set_title("all evaluations")
    for vals, axis in ((X[ok], a0.xaxis), (Y[ok], a0.yaxis)):
        if len(vals) and np.all(vals > 0) and vals.max() > 4 * vals.min():
            (a0.set_xscale if axis is a0.xaxis else a0.set_yscale)("log")
            axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 3.0, 5.0)))
            axis.set_minor_locator(LogLocator(subs=np.arange(1, 10)))
            axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            axis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    if box:
        a1 = axes[1]
        draw(a1, False)
        a1.set_title("zoom: Pareto front, reference design" + (", reference point" if target else ""))
        a1.set_xlim(box[0], box[1])
        a1.set_ylim(box[2], box[3])
    fig.suptitle(f"Objective space of '{run.name}'" + ("" if run.multi else
                                                        f" (the run minimised {run.objectives[0]} alone)"))
    fig.legend(*a0.get_legend_handles_labels(), loc="lower center", ncol=2 if box else 1, frameon=False)
    fig.tight_layout(rect=(0, 0.15 if box else 0.22, 1, 1))
    return _save(fig, out / "objective-space.png"), note


def fig_best_vs_reference(run: RunData, bi: int, ri: int | None, out: Path) -> Path:
    """Relative change of every objective (left) and the design vector (right), best vs reference."""
    plt = _plt()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9.5, 3.8), gridspec_kw={"width_ratios": [1, 1.5]})
    names = [k for k in OBJECTIVE_NAMES if k in run.obj]
    ch = []
    for k in names:
        r = run.ref_objectives.get(k, run.obj[k][ri] if ri is not None else math.nan)
        b = run.obj[k][bi]
        ch.append((b - r) / abs(r) * 100 if np.isfinite(b) and np.isfinite(r) and r else math.nan)
    ch = np.array(ch)
    colors = [("tab:green" if c < 0 else "tab:red") for c in np.nan_to_num(ch)]
    y = np.arange(len(names))
    a1.barh(y, np.nan_to_num(ch), color=colors)
    a1.set_yticks(y, names)
    for t in a1.get_yticklabels():
        if t.get_text() in run.objectives:
            t.set_fontweight("bold")
    a1.invert_yaxis()
    a1.axvline(0, color="k", lw=0.8)
    lim = max(5.0, float(np.nanmax(np.abs(ch))) * 1.35) if np.isfinite(ch).any() else 5.0
    a1.set_xlim(-lim, lim)
    for yi, c in zip(y, ch):
        if np.isfinite(c):
            a1.text(0, yi, f" {c:+.1f} % ", va="center", ha="right" if c >= 0 else "left", fontsize=8)
    a1.set(xlabel="change vs reference design [%]", title="objectives (bold: the run's; negative = better)")
    a1.grid(axis="y", visible=False)
    # design vector, as a fraction of each variable's range
    xb, xr = run.x[bi], run.ref_x
    lo = np.array([v.lower for v in run.variables])
    hi = np.array([v.upper for v in run.variables])
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        lo, hi = np.nanmin(run.x, axis=0), np.nanmax(run.x, axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    ub, ur = (xb - lo) / span, (xr - lo) / span
    yy = np.arange(len(run.names))
    a2.hlines(yy, 0, 1, color="0.85", lw=6)
    a2.scatter(ur, yy, marker="D", s=40, color=REF_COLOR, edgecolor="k", zorder=3, label="reference design")
    a2.scatter(ub, yy, marker="*", s=120, color=BEST_COLOR, edgecolor="k", zorder=4, label=f"best (#{run.ids[bi]})")
    for yi, v in enumerate(run.variables):
        a2.text(1.03, yi, f"{var_value(v, xr[yi])} → {var_value(v, xb[yi])}"
                + (f" {v.unit}" if v.unit and v.group not in ("sleeper_spans", "type_ii_strip") else ""),
                va="center", fontsize=7.5, transform=a2.get_yaxis_transform())
    a2.set_yticks(yy, run.names)
    a2.invert_yaxis()
    a2.set_xlim(-0.05, 1.05)
    a2.set_xticks([0, 0.5, 1], ["lower bound", "middle", "upper bound"])
    a2.set(title="design variables within their bounds")
    a2.grid(axis="y", visible=False)
    a2.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)
    fig.tight_layout()
    fig.subplots_adjust(right=0.8)
    return _save(fig, out / "best-vs-reference.png")


def _zone_marks(ax, info: dict, xmax: float, label: bool = True):
    x_a, x_b = info.get("interface_entry"), info.get("interface_exit")
    if x_a is not None and x_b is not None:
        ax.axvspan(x_a, min(x_b, xmax), color="0.88", zorder=0, label="ERS (level crossing)" if label else None)
        ax.axvline(x_a, color="0.3", lw=0.9, zorder=1)
    if "zone_start" in info and "zone_end" in info:
        ax.axvspan(info["zone_start"], info["zone_end"], color="tab:orange", alpha=0.10, zorder=0,
                   label="force evaluation zone" if label else None)


def fig_contact_force(run: RunData, best: tuple, ref: tuple, bi: int, out: Path) -> Path | None:
    (hb, ib), (hr, ir) = best, ref
    have = [(h, i) for h, i in (best, ref) if h is not None and "wheel_position" in h and "contact_force" in h]
    if not have:
        return None
    plt = _plt()
    info = ib if hb is not None and "wheel_position" in hb else ir
    fig, ax = plt.subplots(figsize=(9, 4.8))
    xmax = max(float(np.max(h["wheel_position"])) for h, _ in have)
    _zone_marks(ax, info, xmax)
    if hr is not None and "contact_force" in hr and "wheel_position" in hr:
        ax.plot(hr["wheel_position"], hr["contact_force"] / 1e3, color=REF_COLOR, lw=1.1,
                label=f"reference design: F_max = {fnum(run.ref_objectives.get('F_max', math.nan) / 1e3, 4)} kN")
    if hb is not None and "contact_force" in hb and "wheel_position" in hb:
        ax.plot(hb["wheel_position"], hb["contact_force"] / 1e3, color=BEST_COLOR, lw=1.1,
                label=f"best #{run.ids[bi]}: F_max = {fnum(run.obj['F_max'][bi] / 1e3, 4)} kN")
    if "static_wheel_load" in info:
        ax.axhline(info["static_wheel_load"] / 1e3, color="k", ls=":", lw=0.8, label="static wheel load")
    if "interface_entry" in info:
        ax.text(info["interface_entry"], 0.98, " interface", transform=ax.get_xaxis_transform(), va="top",
                ha="left", fontsize=8)
    ax.set(xlabel="wheel position along the track [m]", ylabel="wheel-rail contact force [kN]",
           title="Contact force: best against reference design")
    x0 = min(float(np.min(h["wheel_position"])) for h, _ in have)
    if "zone_start" in info:  # the run-in from static equilibrium is not of interest
        x0 = max(x0, float(info["zone_start"]) - 2.0)
    ax.set_xlim(x0, xmax)
    shown = [h["contact_force"][h["wheel_position"] >= x0] / 1e3 for h, _ in have]
    lo, hi = min(float(v.min()) for v in shown), max(float(v.max()) for v in shown)
    ax.set_ylim(lo - 0.08 * (hi - lo or 1), hi + 0.15 * (hi - lo or 1))
    fig.legend(*ax.get_legend_handles_labels(), loc="lower center", ncol=3, frameon=False)
    fig.tight_layout(rect=(0, 0.13, 1, 1))
    return _save(fig, out / "contact-force.png")


def fig_sleeper_energy(run: RunData, best: tuple, ref: tuple, bi: int, out: Path) -> Path | None:
    """Energy per zone sleeper (profile, as the paper's Fig. 11); E_max = max - min shown as a band."""
    (hb, _), (hr, _) = best, ref
    eb = None if hb is None else hb.get("sleeper_energy")
    er = None if hr is None else hr.get("sleeper_energy")
    if eb is None and er is None:
        return None
    plt = _plt()
    from matplotlib.lines import Line2D

    n = max(len(e) for e in (eb, er) if e is not None)
    fig, ax = plt.subplots(figsize=(9, 4.6))
    handles = []
    for e, h, color, marker, lab in ((er, hr, REF_COLOR, "D", "reference design"),
                                     (eb, hb, BEST_COLOR, "o", f"best #{run.ids[bi]}")):
        if e is None:
            continue
        e = np.asarray(e, float)
        idx = np.arange(1, len(e) + 1)
        st = np.asarray(h.get("sleeper_strengthened", np.zeros(len(e))), dtype=bool)[:len(e)]
        ax.axhspan(e.min(), e.max(), color=color, alpha=0.10, lw=0)
        ax.plot(idx, e, color=color, lw=1.4, zorder=3)
        ax.scatter(idx[~st], e[~st], marker=marker, s=30, facecolor="white", edgecolor=color, lw=1.3, zorder=4)
        ax.scatter(idx[st], e[st], marker=marker, s=30, facecolor=color, edgecolor=color, lw=1.3, zorder=4)
        handles.append(Line2D([], [], color=color, marker=marker, markerfacecolor=color,
                              label=f"{lab}: E_max = {fnum(float(e.max() - e.min()), 4)} J (band: min to max), "
                                    f"E_rms = {fnum(float(np.sqrt(np.mean(e ** 2))), 4)} J"))
    handles += [Line2D([], [], ls="", marker="o", color="0.3", label="strengthened sleeper (filled)"),
                Line2D([], [], ls="", marker="o", markerfacecolor="white", color="0.3",
                       label="standard sleeper (open)")]
    ax.set(xlabel="sleeper number (1 = next to the interface)", ylabel="energy dissipated in the support [J]",
           title="Energy dissipated under each sleeper of the evaluation zone (cf. paper Fig. 11)",
           xlim=(0.5, n + 0.5))
    ax.set_xticks(np.arange(1, n + 1))
    fig.legend(handles=handles, loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    return _save(fig, out / "sleeper-energy.png")


def _layout_of(run: RunData, h: dict | None, info: dict, x: np.ndarray) -> dict | None:
    """Entry-side layout of a design: from its histories, else rebuilt from the case."""
    keys = ("entry_sleeper_position", "entry_pad_stiffness", "entry_strengthened")
    if h is not None and all(k in h for k in keys) and "interface_entry" in info:
        lay = {"x": np.asarray(h["entry_sleeper_position"], float), "k": np.asarray(h["entry_pad_stiffness"], float),
               "strong": np.asarray(h["entry_strengthened"], bool), "x_a": float(info["interface_entry"]),
               "x_b": float(info.get("interface_exit", math.nan)), "type_ii_end": float(info.get("type_ii_end",
                                                                                               info["interface_entry"]))}
    elif run.case is not None:
        try:
            from .vti.track import build_track

            t = build_track(run.case, np.asarray(x, float))
        except Exception:  # noqa: BLE001
            return None
        lay = {"x": t.entry_sleeper_x, "k": t.entry_pad_stiffness, "strong": np.asarray(t.entry_strengthened, bool),
               "x_a": t.interface[0], "x_b": t.interface[1], "type_ii_end": t.type_ii_end}
    else:
        return None
    slabs = None
    if run.case is not None:
        slabs = list(run.case.track["ers"]["slab_lengths"])
    lay["slabs"] = slabs
    return lay


def fig_track_layout(run: RunData, best: tuple, ref: tuple, bi: int, out: Path) -> Path | None:
    lays = [("reference design", _layout_of(run, ref[0], ref[1], run.ref_x)),
            (f"best design #{run.ids[bi]}", _layout_of(run, best[0], best[1], run.x[bi]))]
    lays = [(t, l) for t, l in lays if l is not None]
    if not lays:
        return None
    plt = _plt()
    import matplotlib.colors as mcolors
    from matplotlib.patches import Patch, Rectangle

    n_zone = None
    if run.case is not None:
        n_zone = int(run.case.evaluation["sleepers"])
    kmin = min(float(np.min(l["k"])) for _, l in lays)
    kmax = max(float(np.max(l["k"])) for _, l in lays)
    v_lo = [v for v in run.variables if v.group == "railpad_stiffness"]
    if v_lo and np.isfinite(v_lo[0].lower):
        kmin, kmax = min(kmin, v_lo[0].lower), max(kmax, v_lo[0].upper)
    norm = mcolors.LogNorm(vmin=kmin / 1e6, vmax=kmax / 1e6) if kmax > kmin else mcolors.Normalize(kmin / 1e6 - 1,
                                                                                                    kmax / 1e6 + 1)
    cmap = plt.get_cmap("viridis")
    # x: distance from the entry slab edge (negative: ballast track)
    n_show = n_zone or 20
    left = -max(float(l["x_a"] - l["x"][min(n_show, len(l["x"])) - 1]) for _, l in lays) - 0.8
    ers_len = min(float(l["x_b"] - l["x_a"]) for _, l in lays if np.isfinite(l["x_b"])) if \
        any(np.isfinite(l["x_b"]) for _, l in lays) else 12.0
    right = min(ers_len, max(3.0, max(l["type_ii_end"] - l["x_a"] for _, l in lays) + 1.0))
    fig, axes = plt.subplots(len(lays), 1, figsize=(10, 1.9 * len(lays) + 1.3), sharex=True, squeeze=False)
    for ax, (title, l) in zip(axes[:, 0], lays):
        xs = l["x"] - l["x_a"]
        ax.set_ylim(-1.25, 0.75)
        ax.set_xlim(left, right)
        ax.grid(False)
        ax.set_yticks([])
        for sp in ("left", "right", "top"):
            ax.spines[sp].set_visible(False)
        # slab(s)
        x0 = 0.0
        for k, L in enumerate(l["slabs"] or [ers_len]):
            ax.add_patch(Rectangle((x0, -0.9), L - 0.02, 0.55, facecolor="0.75", edgecolor="0.3", lw=0.8))
            x0 += L
        ax.axvline(0.0, color="k", lw=1.0, ls="-", ymin=0.05, ymax=0.95)
        # Type II strip
        t2 = l["type_ii_end"] - l["x_a"]
        if t2 > 0:
            ax.add_patch(Rectangle((0, -0.35), t2, 0.33, facecolor="tab:purple", alpha=0.6, edgecolor="none"))
        ax.add_patch(Rectangle((max(t2, 0), -0.35), max(right, ers_len) - max(t2, 0), 0.33, facecolor="0.55",
                               edgecolor="none"))
        # rail
        ax.plot([left, right], [0.0, 0.0], color="k", lw=3, solid_capstyle="butt")
        # sleepers with pads
        for i, (xi, k, st) in enumerate(zip(xs, l["k"], l["strong"])):
            if xi < left:
                break
            wdt = 0.30 if st else 0.22
            ax.add_patch(Rectangle((xi - wdt / 2, -0.75 if st else -0.65), wdt, 0.55 if st else 0.45,
                                   facecolor="tab:brown" if st else "burlywood", edgecolor="k", lw=0.5,
                                   hatch="///" if st else None))
            ax.add_patch(Rectangle((xi - 0.09, -0.2), 0.18, 0.17, facecolor=cmap(norm(k / 1e6)), edgecolor="k",
                                   lw=0.4))
            if n_zone is not None and i + 1 in (1, 5, 10, 15, 20) and i < n_zone:
                ax.text(xi, -1.05, str(i + 1), ha="center", va="center", fontsize=7, color="0.3")
        # spans next to the interface (the designed ones)
        n_sp = sum(v.group == "sleeper_spans" for v in run.variables) or 3
        pts = np.concatenate([[0.0], xs[:n_sp]])
        for a, b in zip(pts[:-1], pts[1:]):
            ax.annotate("", xy=(a, 0.28), xytext=(b, 0.28), arrowprops=dict(arrowstyle="<->", lw=0.7))
            ax.text(0.5 * (a + b), 0.36, f"{abs(a - b):.1f}", ha="center", va="bottom", fontsize=7)
        n_pad = sum(v.group == "railpad_stiffness" for v in run.variables)
        for xi, k in zip(xs[:n_pad], l["k"][:n_pad]):  # the designed pads, in MN/m
            ax.text(xi, 0.05, f"{k / 1e6:.0f}", ha="center", va="bottom", fontsize=6.5, color="0.15")
        ax.text(left, 0.62, title, fontsize=9, fontweight="bold", va="center")
        ax.text(0.05, 0.62, f"ERS →  {'Type II strip ' + format(t2, '.1f') + ' m' if t2 > 0 else 'no Type II strip'}",
                fontsize=8, va="center")
    axes[-1, 0].set_xlabel("distance from the entry slab edge [m] (vehicle runs left to right; "
                           "sleeper numbers below; above: designed pads in MN/m, spans in m)")
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.tight_layout(rect=(0, 0.09, 0.88, 1))
    cax = fig.add_axes((0.895, 0.2, 0.015, 0.7))
    cb = fig.colorbar(sm, cax=cax)
    cb.set_label("railpad stiffness [MN/m]")
    if isinstance(norm, mcolors.LogNorm):
        from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

        ticks = [t for t in (20, 50, 100, 200, 500, 1000, 2000) if norm.vmin <= t <= norm.vmax]
        cb.ax.yaxis.set_major_locator(FixedLocator(ticks))
        cb.ax.yaxis.set_minor_locator(NullLocator())
        cb.ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    handles = [Patch(facecolor="burlywood", edgecolor="k", label="standard sleeper"),
               Patch(facecolor="tab:brown", edgecolor="k", hatch="///", label="strengthened sleeper"),
               Patch(facecolor="0.55", label="standard rail strip (Type I)"),
               Patch(facecolor="tab:purple", alpha=0.6, label="Type II rail strip"),
               Patch(facecolor="0.75", edgecolor="0.3", label="concrete slab")]
    fig.legend(handles=handles, loc="lower center", ncol=5, frameon=False, bbox_to_anchor=(0.45, 0.0))
    return _save(fig, out / "track-layout.png")


def fig_sensitivity(run: RunData, out: Path) -> Path:
    plt = _plt()
    from matplotlib.lines import Line2D

    d = len(run.names)
    ncol = 4 if d > 4 else d
    nrow = int(math.ceil(d / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(2.6 * ncol + 0.6, 2.3 * nrow + 0.9), sharey=True, squeeze=False)
    s, ylabel = value_label(run)
    vals = run.value * s
    ok = run.ok & np.isfinite(vals)
    if ok.any():
        v_ok = vals[ok]
        lo, hi = float(v_ok.min()), float(np.percentile(v_ok, 95) if ok.sum() > 10 else v_ok.max())
        pad = 0.06 * (hi - lo if hi > lo else (abs(hi) or 1.0))
        ylo, yhi = lo - pad, hi + 2 * pad
    else:
        ylo, yhi = 0.0, 1.0
    bi, ri = run.best_index(), run.ref_index()
    failed = run.status == "failed"
    for j, ax in enumerate(axes.ravel()):
        if j >= d:
            ax.set_visible(False)
            continue
        v = run.variables[j]
        xs = run.x[:, j] * v.scale
        ax.scatter(xs[ok], np.minimum(vals[ok], yhi), s=9, color="0.45", alpha=0.6, lw=0)
        if ri is not None and ok[ri]:
            ax.scatter([xs[ri]], [min(vals[ri], yhi)], marker="D", s=40, color=REF_COLOR, edgecolor="k", zorder=4)
        if bi is not None:
            ax.scatter([xs[bi]], [vals[bi]], marker="*", s=110, color=BEST_COLOR, edgecolor="k", zorder=5)
        if failed.any():
            import matplotlib.transforms as mtransforms

            tr = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
            ax.scatter(xs[failed], np.full(failed.sum(), 0.97), marker="x", s=18, color=FAIL_COLOR, transform=tr,
                       clip_on=False, zorder=5)
        if np.isfinite(v.lower) and v.upper > v.lower:
            m = 0.04 * (v.upper - v.lower) * v.scale
            ax.set_xlim(v.lower * v.scale - m, v.upper * v.scale + m)
        ax.set_ylim(ylo, yhi)
        ax.set_xlabel(var_axis_label(v), fontsize=8)
        ax.set_title(v.label, fontsize=7.5)
        ax.tick_params(labelsize=7)
        if v.integer:
            from matplotlib.ticker import MaxNLocator

            ax.xaxis.set_major_locator(MaxNLocator(integer=True, nbins=6))
    for r in range(nrow):
        axes[r, 0].set_ylabel(ylabel if len(ylabel) < 28 else "value [-]", fontsize=8)
    handles = [Line2D([], [], ls="", marker="o", color="0.45", label="evaluation"),
               Line2D([], [], ls="", marker="D", color=REF_COLOR, markeredgecolor="k", label="reference design"),
               Line2D([], [], ls="", marker="*", markersize=10, color=BEST_COLOR, markeredgecolor="k", label="best")]
    if failed.any():
        handles.append(Line2D([], [], ls="", marker="x", color=FAIL_COLOR, label="failed (at the top)"))
    fig.suptitle(f"Each design variable against the {ylabel.split(' [')[0]} (values above the 95th percentile "
                 f"drawn at the top)", fontsize=9.5)
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), frameon=False)
    fig.tight_layout(rect=(0, 0.06, 1, 0.96))
    return _save(fig, out / "sensitivity.png")


# ================================================================================ summary

class Doc:
    """A tiny document model rendered to Markdown and to self-contained HTML."""

    def __init__(self):
        self.blocks: list[tuple] = []

    def h(self, level: int, text: str):
        self.blocks.append(("h", level, text))

    def p(self, text: str):
        self.blocks.append(("p", text))

    def ul(self, items: list[str]):
        self.blocks.append(("ul", items))

    def table(self, header: list[str], rows: list[list[str]], align: str | None = None):
        self.blocks.append(("table", header, rows, align or "l" + "r" * (len(header) - 1)))

    def fig(self, path: Path, caption: str):
        self.blocks.append(("fig", path, caption))

    def markdown(self) -> str:
        out = []
        for b in self.blocks:
            if b[0] == "h":
                out.append("#" * b[1] + " " + b[2])
            elif b[0] == "p":
                out.append(b[1])
            elif b[0] == "ul":
                out.append("\n".join(f"- {i}" for i in b[1]))
            elif b[0] == "table":
                _, head, rows, al = b
                esc = lambda s: str(s).replace("|", "\\|")  # noqa: E731
                lines = ["| " + " | ".join(esc(c) for c in head) + " |",
                         "|" + "|".join(":---" if a == "l" else "---:" for a in al) + "|"]
                lines += ["| " + " | ".join(esc(c) for c in r) + " |" for r in rows]
                out.append("\n".join(lines))
            elif b[0] == "fig":
                out.append(f"![{b[1].stem.replace('-', ' ')}]({b[1].name})\n\n*{b[2]}*")
        return "\n\n".join(out) + "\n"

    def html(self, title: str) -> str:
        def inline(s: str) -> str:
            # the Markdown subset used in the texts: `code` and **bold**
            t = html.escape(s)
            import re

            t = re.sub(r"`([^`]+)`", r"<code>\1</code>", t)
            t = re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", t)
            return t

        body = []
        for b in self.blocks:
            if b[0] == "h":
                body.append(f"<h{b[1]}>{inline(b[2])}</h{b[1]}>")
            elif b[0] == "p":
                body.append(f"<p>{inline(b[1])}</p>")
            elif b[0] == "ul":
                body.append("<ul>" + "".join(f"<li>{inline(i)}</li>" for i in b[1]) + "</ul>")
            elif b[0] == "table":
                _, head, rows, al = b
                cls = lambda a: ' class="r"' if a == "r" else ""  # noqa: E731
                t = ["<table><thead><tr>" + "".join(f"<th{cls(a)}>{inline(c)}</th>" for c, a in zip(head, al))
                     + "</tr></thead><tbody>"]
                t += ["<tr>" + "".join(f"<td{cls(a)}>{inline(c)}</td>" for c, a in zip(r, al)) + "</tr>"
                      for r in rows]
                body.append("".join(t) + "</tbody></table>")
            elif b[0] == "fig":
                data = base64.b64encode(b[1].read_bytes()).decode("ascii")
                body.append(f'<figure><img alt="{html.escape(b[1].name)}" src="data:image/png;base64,{data}">'
                            f"<figcaption>{inline(b[2])}</figcaption></figure>")
        style = ("body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;max-width:1100px;"
                 "margin:2em auto;padding:0 1em;color:#222;line-height:1.45}"
                 "table{border-collapse:collapse;margin:0.8em 0}th,td{border:1px solid #ccc;padding:3px 8px}"
                 "th{background:#f3f3f3}td.r,th.r{text-align:right}img{max-width:100%;height:auto}"
                 "figure{margin:1em 0}figcaption{color:#555;font-size:0.9em}code{background:#f3f3f3;padding:0 3px}")
        return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{html.escape(title)}"
                f"</title><style>{style}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")


def history_facts(best: tuple, ref: tuple) -> list[str]:
    """Sentences on the histories of the best and the reference design (for 'Why it is better')."""
    (hb, ib), (hr, ir) = best, ref
    out = []
    eb = None if hb is None else hb.get("sleeper_energy")
    er = None if hr is None else hr.get("sleeper_energy")
    if eb is not None and er is not None and len(eb) and len(er):
        eb, er = np.asarray(eb, float), np.asarray(er, float)
        out.append(f"Under sleeper 1, next to the interface, the ballast dissipates {fnum(eb[0], 4)} J instead of "
                   f"{fnum(er[0], 4)} J ({pct(eb[0], er[0])}); the most loaded zone sleeper is number "
                   f"{int(np.argmax(eb)) + 1} ({fnum(eb.max(), 4)} J) instead of number {int(np.argmax(er)) + 1} "
                   f"({fnum(er.max(), 4)} J), and the spread max - min (E_max) is {fnum(eb.max() - eb.min(), 4)} J "
                   f"instead of {fnum(er.max() - er.min(), 4)} J.")
    peaks = []
    for h, i in ((hb, ib), (hr, ir)):
        if h is None or "contact_force" not in h or "wheel_position" not in h or "interface_entry" not in i:
            return out
        x, f = np.asarray(h["wheel_position"]), np.asarray(h["contact_force"])
        m = (x >= i["interface_entry"] - 1.0) & (x <= i["interface_entry"] + 3.0)
        if not m.any():
            return out
        peaks.append((float(f[m].max()), float(x[m][np.argmax(f[m])] - i["interface_entry"])))
    (pb, xb), (pr, xr) = peaks
    out.append(f"Around the interface (1 m before to 3 m after it) the contact force peaks at {fnum(pb / 1e3, 4)} kN "
               f"{abs(xb):.2f} m {'after' if xb >= 0 else 'before'} the slab edge, against {fnum(pr / 1e3, 4)} kN "
               f"{abs(xr):.2f} m {'after' if xr >= 0 else 'before'} it for the reference design.")
    return out


def build_summary(run: RunData, figs: dict, notes: dict, facts: list[str] | None = None) -> tuple[Doc, dict]:
    doc = Doc()
    bi, ri = run.best_index(), run.ref_index()
    n_failed = int((run.status == "failed").sum())
    restarts = sorted(int(r) for r in np.unique(run.restart) if r > 0)
    state = {"finished": "finished",
             "running": f"still running ({run.n_pending} evaluation(s) in flight when this was read)",
             "interrupted": f"interrupted (carry on with `lccopt resume {run.path}`)"}[run.state]
    doc.h(1, f"Run '{run.name}'")
    doc.p(f"**{run.n} of {run.budget} evaluations**, {n_failed} failed, {len(restarts)} restart(s); the run is "
          f"{state}. Read from `{run.source}` on {_dt.datetime.now().astimezone().isoformat(timespec='seconds')}.")
    for note in run.notes:
        doc.p(f"Note: {note}")

    # --- what was searched
    doc.h(2, "What was searched")
    if run.multi:
        pt = ", ".join(f"{k} = {fnum(v)} {obj_unit(k)}" for k, v in zip(run.objectives, run.ref_point)) \
            if run.ref_point is not None else "not set yet"
        wst = ", ".join(f"{k} = {fnum(v)} {obj_unit(k)}" for k, v in zip(run.objectives, run.worst)) \
            if run.worst is not None else "–"
        doc.p(f"Minimise {', '.join(f'**{k}** ({OBJECTIVE_DOC.get(k, k)})' for k in run.objectives)} together, "
              f"scalarised by the augmented Chebyshev achievement function (paper Eq. 7, ρ = {run.rho:g}). "
              f"Reference point f^r ({run.improvement:.0%} better than the reference design): {pt}; "
              f"worst values: {wst}. The value is 0 on the reference point and negative beyond it.")
    else:
        k = run.objectives[0]
        doc.p(f"Minimise **{k}**: {OBJECTIVE_DOC.get(k, k)} [{obj_unit(k)}].")
    rows = []
    for v in run.variables:
        rng = f"{var_value(v, v.lower)} … {var_value(v, v.upper)}" if np.isfinite(v.lower) else "–"
        rows.append([f"`{v.name}`", v.label, v.unit or "–", rng, "integer" if v.integer else "continuous",
                     var_value(v, v.reference)])
    doc.table(["variable", "meaning", "unit", "bounds", "kind", "reference design"], rows, "llllll")
    if run.case is None and run.case_note:
        doc.p(f"Note: the run's case could not be loaded ({run.case_note}); bounds are not shown.")

    # --- how the search went
    doc.h(2, "How the search went")
    if "search-history" in figs:
        doc.fig(figs["search-history"], "Value of every evaluation by number, by phase; failed evaluations as red "
                "crosses at the bottom; the green line is the best value so far; dashed lines mark restarts "
                "(paper Figs. 6, 7, 10).")
    phase_counts = {ph: int((run.phase == ph).sum()) for ph in PHASE_STYLE if (run.phase == ph).any()}
    items = ["evaluations by phase: " + ", ".join(f"{PHASE_STYLE[p][0]} {c}" for p, c in phase_counts.items())]
    if bi is not None:
        items.append(f"best value {fnum(run.value[bi])} at evaluation #{run.ids[bi]} ({run.phase[bi]}, restart "
                     f"{run.restart[bi]}); the best value was within 1 % of it from evaluation "
                     f"#{_first_near_best(run)} on")
    if restarts:
        starts = [int(run.ids[run.restart == r].min()) for r in restarts]
        items.append("restarts (fresh initial design after the step size collapsed or evaluations kept failing) at "
                     + ", ".join(f"#{s}" for s in starts))
    if n_failed:
        reasons: dict = {}
        for r in run.reason[run.status == "failed"]:
            reasons[r or "no reason given"] = reasons.get(r or "no reason given", 0) + 1
        fids = [f"#{i}" for i in run.ids[run.status == "failed"]]
        items.append(f"{n_failed} failed evaluation(s) ({', '.join(fids[:12])}{' …' if len(fids) > 12 else ''}): "
                     + "; ".join(
            f"{c}× {r}" for r, c in sorted(reasons.items(), key=lambda t: -t[1])[:5]))
    wt = run.wall_time[np.isfinite(run.wall_time)]
    if len(wt):
        items.append(f"simulation wall time per evaluation: median {np.median(wt):.2f} s, max {wt.max():.2f} s"
                     + (f"; run sessions took {run.sessions_wall / 60:.1f} min" if np.isfinite(run.sessions_wall)
                        else ""))
    doc.ul(items)

    summary = {"run": str(run.path), "name": run.name, "state": run.state, "evaluations": run.n,
               "budget": run.budget, "failed": n_failed, "restarts": len(restarts), "objectives": run.objectives,
               "source": run.source, "figures": {k: p.name for k, p in figs.items()}, "notes": dict(notes)}
    if bi is None:
        doc.h(2, "Best design")
        doc.p("No evaluation has succeeded yet: there is no best design.")
        return doc, summary

    # --- best design vs reference
    doc.h(2, "Best design against the reference design")
    lab = "chosen compromise (lowest ASF value)" if run.multi else f"lowest {run.objectives[0]}"
    doc.p(f"The best design is evaluation **#{run.ids[bi]}**, the {lab}. Changes are relative to the "
          f"reference design (evaluation #0); negative is better for every objective (paper Tables 5-7).")
    rows = []
    for j, v in enumerate(run.variables):
        xr, xb = run.ref_x[j], run.x[bi, j]
        rows.append([f"`{v.name}`", v.label, v.unit or "–", var_value(v, xr), var_value(v, xb),
                     pct(xb, xr) if not v.integer else (f"{xb - xr:+g}" if xb != xr else "0")])
    doc.table(["variable", "meaning", "unit", "reference", f"best #{run.ids[bi]}", "change"], rows, "lllrrr")
    rows = []
    for k in OBJECTIVE_NAMES:
        if k not in run.obj:
            continue
        r = run.ref_objectives.get(k, run.obj[k][ri] if ri is not None else math.nan)
        b = float(run.obj[k][bi])
        tgt = ""
        if run.multi and run.ref_point is not None and k in run.objectives:
            t = run.ref_point[run.objectives.index(k)]
            tgt = f"{fnum(t)} ({'reached' if b <= t else 'not reached'})"
        rows.append([f"**{k}**" if k in run.objectives else k, obj_unit(k), fnum(r), fnum(b), pct(b, r)]
                    + ([tgt] if run.multi else []))
    doc.table(["objective", "unit", "reference", f"best #{run.ids[bi]}", "change"]
              + (["target f^r"] if run.multi else []), rows)
    doc.p(f"Value minimised: reference {fnum(run.value[ri]) if ri is not None else '–'}, best "
          f"{fnum(run.value[bi])}.")
    if "best-vs-reference" in figs:
        doc.fig(figs["best-vs-reference"], "Change of every objective (left) and where the design variables sit "
                "within their bounds (right), best against reference.")

    # --- why
    doc.h(2, "Why it is better")
    doc.p(_why_text(run, bi, ri, notes))
    for fact in facts or []:
        doc.p(fact)
    for key, cap in (("contact-force", "Wheel-rail contact force against wheel position, best and reference "
                                       "design; grey: ERS, orange: evaluation zone of the force objectives."),
                     ("sleeper-energy", "Energy dissipated in the ballast/subgrade under each sleeper of the "
                                        "evaluation zone, sleeper 1 next to the interface (paper Fig. 11)."),
                     ("track-layout", "The designed track next to the interface: sleepers (standard or "
                                      "strengthened), railpad stiffness by colour, spans next to the slab, "
                                      "the Type II strip and the slab edge; reference above, best below.")):
        if key in figs:
            doc.fig(figs[key], cap)
        elif key in notes:
            doc.p(f"No {key.replace('-', ' ')} figure: {notes[key]}.")

    # --- objective space and sensitivity
    doc.h(2, "Objective space")
    if "objective-space" in figs:
        doc.fig(figs["objective-space"], "All evaluations in objective space with the Pareto front, the reference "
                "design, the reference point and the chosen compromise (paper Fig. 9).")
    if notes.get("objective-space"):
        doc.p(notes["objective-space"])
    doc.h(2, "Sensitivity at a glance")
    if "sensitivity" in figs:
        doc.fig(figs["sensitivity"], "Each design variable against the value minimised, over all evaluations "
                "(one panel per variable; the star is the best design, the diamond the reference).")
    doc.h(2, "Files")
    doc.ul([f"results table: `{run.path / 'results.h5'}`; commit log: `{run.path / 'journal.jsonl'}`",
            f"histories of the best design: `{run.path / run.file[bi]}`" if run.file[bi] else
            "the best design has no histories file",
            f"histories of the reference design: `{run.path / run.file[ri]}`" if ri is not None and run.file[ri]
            else "the reference design has no histories file"])

    summary["best"] = {"id": int(run.ids[bi]), "value": float(run.value[bi]),
                       "x": {n: float(v) for n, v in zip(run.names, run.x[bi])},
                       "objectives": {k: float(run.obj[k][bi]) for k in run.obj},
                       "phase": str(run.phase[bi]), "restart": int(run.restart[bi])}
    summary["reference"] = {"id": int(run.ids[ri]) if ri is not None else None,
                            "x": {n: float(v) for n, v in zip(run.names, run.ref_x)},
                            "objectives": {k: float(v) for k, v in run.ref_objectives.items()}}
    summary["change_percent"] = {k: (float(run.obj[k][bi]) - r) / abs(r) * 100
                                 for k, r in run.ref_objectives.items() if k in run.obj and r}
    return doc, summary


def _first_near_best(run: RunData) -> int:
    ok = run.ok & np.isfinite(run.value)
    order = np.argsort(run.ids)
    v = np.where(ok, run.value, np.inf)[order]
    bsf = np.minimum.accumulate(v)
    b = bsf[-1]
    tol = 0.01 * abs(b) if b != 0 else 1e-12
    return int(run.ids[order][np.flatnonzero(bsf <= b + tol)[0]])


def _why_text(run: RunData, bi: int, ri: int | None, notes: dict) -> str:
    parts = []
    for k in run.objectives:
        r, b = run.ref_objectives.get(k, math.nan), float(run.obj[k][bi])
        if np.isfinite(r) and r:
            s, u = obj_display(k)
            word = "falls" if b < r else "rises"
            parts.append(f"{k} {word} from {fnum(r * s, 4)} to {fnum(b * s, 4)} {u} ({pct(b, r)})")
    text = "Against the reference design, " + "; ".join(parts) + "." if parts else ""
    diffs = []
    for j, v in enumerate(run.variables):
        xr, xb = run.ref_x[j], run.x[bi, j]
        if not np.isclose(xr, xb):
            diffs.append(f"{v.label} {var_value(v, xr)} → {var_value(v, xb)}"
                         + (f" {v.unit}" if v.unit and v.group not in ("sleeper_spans", "type_ii_strip") else ""))
    if diffs:
        text += " The design differs in: " + "; ".join(diffs) + "."
    else:
        text += " The best design is the reference design."
    return text.strip()


def write_report(run: Path, format: str = "both") -> Path:
    """Write figures and the summary of run directory RUN into RUN/report/; return that directory."""
    import time

    t0 = time.perf_counter()
    fmt_ = str(format).lower()
    if fmt_ not in FORMATS:
        raise _usage(f"--format must be one of {', '.join(FORMATS)}, got {format!r}")
    data = load_run(Path(run))
    out = data.path / "report"
    try:
        out.mkdir(exist_ok=True)
    except OSError as exc:
        raise _usage(f"cannot create {out}: {exc.strerror or exc}") from None
    for name in FIGURES:  # figures of an earlier report that this one may not redraw
        p = out / f"{name}.png"
        if p.exists():
            p.unlink()

    figs: dict[str, Path] = {}
    notes: dict[str, str] = {}
    figs["search-history"] = fig_search_history(data, out)
    p, note = fig_objective_space(data, out)
    figs["objective-space"] = p
    if note:
        notes["objective-space"] = note
    bi, ri = data.best_index(), data.ref_index()
    if bi is not None:
        figs["best-vs-reference"] = fig_best_vs_reference(data, bi, ri, out)
        hb, ib, nb = read_history(data, bi)
        hr, ir, nr = read_history(data, ri) if ri is not None else (None, {}, "the reference design was not "
                                                                       "evaluated successfully")
        why = "; ".join(n for n in (nb and f"best: {nb}", nr and f"reference: {nr}") if n)
        for key, fn in (("contact-force", fig_contact_force), ("sleeper-energy", fig_sleeper_energy),
                        ("track-layout", fig_track_layout)):
            p = fn(data, (hb, ib), (hr, ir), bi, out)
            if p is not None:
                figs[key] = p
                if why and key != "track-layout":
                    notes[key] = why
            else:
                notes[key] = why or "the evaluation files hold no such histories (e.g. a test evaluator)"
        facts = history_facts((hb, ib), (hr, ir))
    else:
        facts = []
    figs["sensitivity"] = fig_sensitivity(data, out)

    doc, summary = build_summary(data, figs, notes, facts)
    wrote = []
    if fmt_ in ("md", "both"):
        atomic_write_text(out / "report.md", doc.markdown())
        wrote.append(out / "report.md")
    if fmt_ in ("html", "both"):
        atomic_write_text(out / "report.html", doc.html(f"lccopt report: {data.name}"))
        wrote.append(out / "report.html")
    summary["seconds"] = round(time.perf_counter() - t0, 2)
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2, allow_nan=True) + "\n")
    import typer

    bi_txt = (f"; best #{summary['best']['id']}: " + ", ".join(
        f"{k} {pct(summary['best']['objectives'][k], data.ref_objectives.get(k, math.nan))}"
        for k in data.objectives)) if "best" in summary else ""
    typer.echo(f"report of '{data.name}' ({data.n}/{data.budget} evaluations, {data.state}){bi_txt}")
    typer.echo(f"  {len(figs)} figures and {', '.join(p.name for p in wrote)} in {out} "
               f"({summary['seconds']:.1f} s)")
    return out
