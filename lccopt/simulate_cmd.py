"""``lccopt simulate``: one design, its objectives on screen, histories in HDF5, PNG plots."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import typer

from . import machine
from .config import design_items, load_case, parse_design
from .store import write_evaluation
from .terminal import wrap_items
from .vti.response import OBJECTIVE_DOC, Evaluation, objective_display


def _echo_design(case, case_path: Path, x) -> None:
    """The case and the design simulated, in lines that fit an 80-column terminal."""
    typer.echo(f"case '{case.name}' ({case_path})")
    typer.echo("\n".join(wrap_items(design_items(case, x), "  design ")))


def run_simulate(case_path: Path, design: str | None, out: Path | None, plots: bool,
                 force: bool = False) -> Evaluation:
    from .errors import UsageError

    case = load_case(case_path)
    try:
        x = case.reference if design is None else parse_design(design, case)
    except ValueError as exc:
        raise UsageError(f"--design: {exc}") from None
    out = out or Path("runs") / f"{case.name}-simulate"
    if (out / "simulation.h5").exists() and not force:
        raise UsageError(f"{out} already holds a simulation: choose another --out, or add --force "
                         f"to replace it")
    out.mkdir(parents=True, exist_ok=True)

    from .problem import evaluate

    if case.conditions:
        return _simulate_conditions(case, case_path, x, out, plots, evaluate)
    t0 = time.perf_counter()
    ev = evaluate(case, x)
    wall = time.perf_counter() - t0
    info = ev.info
    _echo_design(case, case_path, x)
    typer.echo(f"static wheel load {info['static_wheel_load'] / 1e3:.2f} kN (on a rigid rail)")
    typer.echo(f"Hertz spring linearised at P = {info['hertz_load'] / 1e3:.1f} kN: "
               f"k_w = {info['contact_stiffness'] / 1e9:.3f} GN/m")
    typer.echo(f"{info['n_dofs']} track dofs, {info['n_steps']} steps of {info['time_step'] * 1e3:g} ms, "
               f"wheel from {info['x_start']:.1f} m to {info['x_end']:.1f} m, {wall:.2f} s")
    for k, v in ev.objectives.items():
        scale, unit = objective_display(k)
        typer.echo(f"  {k:<6} = {v * scale:10.5g} {unit:<2}  {OBJECTIVE_DOC[k]}")
    if info["contact_loss_steps"]:
        typer.echo(f"WARNING: contact lost (force <= 0) in {info['contact_loss_steps']} steps, first at "
                   f"{info['contact_loss_first_position']:.2f} m; the linear contact spring pulled the wheel",
                   err=True)
    h5 = write_evaluation(out / "simulation.h5", ev, x, case.names,
                          {"case": case.resolved, **machine.describe()})
    typer.echo(f"histories: {h5}")
    if plots:
        for p in plot_evaluation(ev, case, out):
            typer.echo(f"plot: {p}")
    return ev


def _simulate_conditions(case, case_path: Path, x, out: Path, plots: bool, evaluate) -> Evaluation:
    """A case with traffic conditions: one simulation per condition, their objectives and the
    combination the optimiser would minimise; one file with every condition."""
    from .problem import combine_conditions
    from .store import write_condition_evaluations

    names = [c.name for c in case.conditions]
    _echo_design(case, case_path, x)
    keys = list(OBJECTIVE_DOC)
    head = "".join(f"{k + ' [' + objective_display(k)[1] + ']':>12}" for k in keys)
    typer.echo(f"{'condition':<22}{head}{'time':>7}")
    evs = []
    for i, c in enumerate(case.conditions):
        t0 = time.perf_counter()
        ev = evaluate(case.condition_case(i), x)
        evs.append(ev)
        vals = "".join(f"{v * objective_display(k)[0]:12.5g}" for k, v in ev.objectives.items())
        typer.echo(f"{c.name[:21]:<22}{vals}{time.perf_counter() - t0:6.2f}s")
        if ev.info.get("contact_loss_steps"):
            typer.echo(f"WARNING: {c.name}: contact lost (force <= 0) in {ev.info['contact_loss_steps']} "
                       f"steps", err=True)
    combined = combine_conditions([e.objectives for e in evs], names, [c.weight for c in case.conditions],
                                  case.condition_mode)
    label = {"worst": "worst case", "mean": "weighted mean", "each": "worst case"}[case.condition_mode]
    vals = "".join(f"{combined[k] * objective_display(k)[0]:12.5g}" for k in keys)
    typer.echo(f"{label:<22}{vals}")
    h5 = write_condition_evaluations(out / "simulation.h5", evs, x, case.names, names,
                                     [c.weight for c in case.conditions], combined,
                                     {"case": case.resolved, **machine.describe()})
    typer.echo(f"histories: {h5}")
    if plots:
        for c, ev in zip(case.conditions, evs):
            (out / c.name).mkdir(exist_ok=True)
            for p in plot_evaluation(ev, case.condition_case(names.index(c.name)), out / c.name):
                typer.echo(f"plot: {p}")
    return Evaluation(combined, evs[0].histories, evs[0].info)


def plot_evaluation(ev: Evaluation, case, out: Path) -> list[Path]:
    """Contact force along the track, energy per zone sleeper, wheel and rail displacement."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    from .report.data import OKABE_ITO, TYPE_II_COLOR, ZONE_COLOR
    from .report.figures import range_bracket, sleeper_ticks, speed_text

    h, info = ev.histories, ev.info
    x = h["wheel_position"]
    x_a, x_b = info["interface_entry"], info["interface_exit"]
    speed = speed_text(info, case)
    paths = []

    def mark(ax):
        ax.axvspan(x_a, min(x_b, x.max()), color="0.85", label="ERS (level crossing)")
        ax.axvspan(info["zone_start"], info["zone_end"], color=ZONE_COLOR, alpha=0.18,
                   label="force evaluation zone")
        if info["type_ii_end"] > x_a:
            ax.axvspan(x_a, info["type_ii_end"], color=TYPE_II_COLOR, alpha=0.2, label="Type II strip")

    fig, ax = plt.subplots(figsize=(9, 4.6))
    mark(ax)
    f = h["contact_force"] / 1e3
    fw = h.get("contact_force_wheels")
    if fw is not None and fw.ndim == 2 and fw.shape[1] > 1:  # trailing wheels, each at its position
        xw, inw = h["wheel_positions"], h["in_force_zone_wheels"].astype(bool)
        for j in range(1, fw.shape[1]):
            ax.plot(xw[:, j], fw[:, j] / 1e3, lw=0.6, color=OKABE_ITO["sky"], alpha=0.7,
                    label="trailing wheels" if j == 1 else None)
        lo, hi = float(fw[inw].min()) / 1e3, float(fw[inw].max()) / 1e3   # F_max: all wheels
    else:
        zone = (x >= info["zone_start"]) & (x <= info["zone_end"])
        lo, hi = float(f[zone].min()), float(f[zone].max())
    ax.plot(x, f, lw=0.9, color=OKABE_ITO["blue"], label="contact force (leading wheel)"
            if fw is not None and fw.ndim == 2 and fw.shape[1] > 1 else "contact force")
    ax.hlines([lo, hi], info["zone_start"], info["zone_end"], color=OKABE_ITO["blue"], lw=0.7, ls="--")
    range_bracket(ax, 0, lo, hi, OKABE_ITO["blue"], "F_max")
    ax.axhline(info["static_wheel_load"] / 1e3, color="k", ls=":", lw=0.8, label="static wheel load")
    sleeper_ticks(ax, h["entry_sleeper_position"], "0.3", 0, "sleepers")
    ax.set(xlabel="wheel position along the track [m]", ylabel="wheel-rail contact force [kN]",
           title=f"case {case.name}" + (f" at {speed}" if speed else "")
                 + f": F_max = {ev.objectives['F_max'] / 1e3:.2f} kN (max - min in the zone), "
                 f"F_rms = {ev.objectives['F_rms'] / 1e3:.2f} kN", xlim=(x.min(), x.max()))
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 0.96, 1))
    paths.append(out / "contact_force.png")
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(9, 4.4))
    e = h["sleeper_energy"]
    n = np.arange(1, len(e) + 1)
    strengthened = h["sleeper_strengthened"] > 0
    # strengthened sleepers differ in colour and hatching, so the two read apart without colour
    ax.bar(n[~strengthened], e[~strengthened], color=OKABE_ITO["sky"], edgecolor="k", lw=0.5)
    ax.bar(n[strengthened], e[strengthened], color=OKABE_ITO["vermillion"], edgecolor="k", lw=0.5, hatch="///")
    ax.hlines([e.min(), e.max()], 0.3, len(e) + 0.7, color="k", lw=0.7, ls="--")
    range_bracket(ax, 0, float(e.min()), float(e.max()), "k", "E_max")
    ax.set(xlabel="sleeper number (1 = next to the interface)", ylabel="energy dissipated in support [J]",
           title=f"E_max = {ev.objectives['E_max']:.4f} J (max - min), E_rms = {ev.objectives['E_rms']:.4f} J",
           xticks=n, xlim=(0.3, len(e) + 0.7))
    ax.legend(handles=[Patch(facecolor=OKABE_ITO["vermillion"], edgecolor="k", hatch="///",
                             label="strengthened sleeper"),
                       Patch(facecolor=OKABE_ITO["sky"], edgecolor="k", label="standard sleeper")],
              loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 0.96, 1))
    paths.append(out / "sleeper_energy.png")
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(9, 4.4))
    mark(ax)
    ax.plot(x, h["wheel_displacement"] * 1e3, lw=0.9, color=OKABE_ITO["blue"], label="wheel")
    ax.plot(x, h["rail_displacement"] * 1e3, lw=0.9, color=OKABE_ITO["vermillion"], label="rail under the wheel")
    ax.invert_yaxis()
    ax.set(xlabel="wheel position along the track [m]", ylabel="displacement, downward [mm]",
           title="wheel and rail displacement" + (f" at {speed}" if speed else ""))
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=5, fontsize=8, frameon=False)
    fig.tight_layout()
    paths.append(out / "displacement.png")
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)
    return paths
