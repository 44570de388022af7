"""``lccopt simulate``: one design, its objectives on screen, histories in HDF5, PNG plots
(drawn by ``lccopt.report.simulation``; a case with ``degradation:`` predicts the design's
settlement and draws it with ``lccopt.report.settlement``).

The simulation is the workers' (``lccopt.problem.evaluate``, or the stand-in that
``LCCOPT_EVALUATOR`` names, as for ``optimise``). Objectives that are not finite numbers are
never shown as a result: the command stops with one line and writes nothing.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
import typer

from .. import machine
from ..config import design_items, load_case, parse_design
from ..config.describe import condition_lines, vehicle_line, zone_line
from ..outdir import Output
from ..store import write_evaluation
from ..terminal import WIDTH, wrap_items, wrap_message
from ..uncertainty import statistics as stats
from ..vti.response import (
    OBJECTIVE_DOC,
    PAPER_OBJECTIVES,
    SETTLEMENT_OBJECTIVES,
    Evaluation,
    objective_display,
)


def _echo_setting(case, case_path: Path, x) -> None:
    """The case and the design simulated, its traffic conditions (or its one vehicle) and the
    force evaluation zone, in lines that fit an 80-column terminal."""
    typer.echo(f"case '{case.name}' ({case_path})")
    typer.echo("\n".join(wrap_items(design_items(case, x), "  design ")))
    if case.traffic:
        typer.echo("\n".join(line[2:] for line in condition_lines(case)))
    else:
        typer.echo(f"vehicle: {vehicle_line(case.vehicle)}")
    typer.echo(zone_line(case))


def run_simulate(case_path: Path, design: str | None, out: Path | None, plots: bool,
                 force: bool = False, overrides=(), against: str | None = None) -> Evaluation:
    from ..errors import UsageError

    case = load_case(case_path, overrides)
    try:
        x = case.reference if design is None else parse_design(design, case)
    except ValueError as exc:
        raise UsageError(f"--design: {exc}") from None
    other = None
    if against is not None:
        if not case.realisations:
            raise UsageError(f"--against compares two designs on the realisations of the "
                             f"track; {case_path} has no uncertainty: section (or 0 "
                             f"realisations), and on one track the difference is just "
                             f"that of two simulations")
        try:
            other = parse_design(against, case)
        except ValueError as exc:
            raise UsageError(f"--against: {exc}") from None
    named = out is not None
    out = Path(out or Path("runs") / f"{case.name}-simulate")
    files, folders = _outputs(case, plots)
    evaluate = _simulator()
    # the folder checked, locked and a staging folder made before the simulation; the files
    # are moved into place only once all are written (lccopt.outdir)
    with Output.into(out, files, folders, force, "simulate", named) as output:
        if case.realisations:
            ev = _simulate_realisations(case, case_path, x, output.root, plots, evaluate,
                                        other)
        elif case.degradation is not None:
            ev = _simulate_settlement(case, case_path, x, output.root, plots, evaluate)
        elif case.conditions:
            ev = _simulate_conditions(case, case_path, x, output.root, plots, evaluate)
        else:
            ev = _simulate_one(case, case_path, x, output.root, plots, evaluate)
    for line in output.lines:
        typer.echo(line)
    return ev


def _outputs(case, plots: bool) -> tuple[list[str], list[str]]:
    """(files, folders) ``simulate`` may write into its output folder."""
    from ..report.simulation import FILES

    files, folders = ["simulation.h5"], []
    if plots:
        files += FILES
        if case.realisations:
            files += ["robust-spread.png"]
        elif case.degradation is not None:
            files += ["settlement-history.png", "settlement-profile.png"]
        elif case.conditions:
            files = ["simulation.h5"]
            folders = [c.name for c in case.conditions]
    return files, folders


def _simulate_one(case, case_path: Path, x, out, plots: bool, evaluate) -> Evaluation:
    t0 = time.perf_counter()
    ev = evaluate(case, x)
    wall = time.perf_counter() - t0
    _check_finite(ev.objectives, case, x)
    info = ev.info
    _echo_setting(case, case_path, x)
    typer.echo(f"Hertz spring linearised at P = {info['hertz_load'] / 1e3:.1f} kN: "
               f"k_w = {info['contact_stiffness'] / 1e9:.3f} GN/m")
    edge = info.get("interface_entry", 0.0)   # positions from the entry slab edge, as plotted
    typer.echo(f"{info['n_dofs']} track dofs, {info['n_steps']} steps of "
               f"{info['time_step'] * 1e3:g} ms, {wall:.2f} s")
    typer.echo(f"wheel from {info['x_start'] - edge:.1f} m to {info['x_end'] - edge:.1f} m "
               f"from the entry slab edge")
    for k, v in ev.objectives.items():
        scale, unit = objective_display(k)
        typer.echo(f"  {k:<6} = {v * scale:10.5g} {unit:<2}  {OBJECTIVE_DOC.get(k, '')}")
    if info["contact_loss_steps"]:
        typer.echo(wrap_message(
            f"WARNING: contact lost (force <= 0) in {info['contact_loss_steps']} steps, first "
            f"at {info['contact_loss_first_position']:.2f} m; the linear contact spring "
            f"pulled the wheel"), err=True)
    _write(out, ev, x, case)
    if plots:
        from ..report.simulation import simulation_figures

        _said(out, simulation_figures(ev, case.name, out))
    return ev


def _write(out, ev, x, case) -> None:
    """simulation.h5 of one evaluation into the staged folder ``out``."""
    p = out / "simulation.h5"
    write_evaluation((p.folder, p.name), ev, x, case.names,
                     {"case": case.resolved, **machine.describe()})
    _said(out, [p], "histories")


def _said(out, paths, what: str = "plot") -> None:
    """Lines printed once the files are in place (``output.lines``)."""
    out.lines.extend(f"{what}: {p}" for p in paths)


def _simulate_conditions(case, case_path: Path, x, out: Path, plots: bool, evaluate) -> Evaluation:
    """A case with traffic conditions: one simulation per condition, their objectives and the
    combination the optimiser would minimise; one file with every condition."""
    from ..problem import combine_conditions
    from ..store import write_condition_evaluations

    names = [c.name for c in case.conditions]
    _echo_setting(case, case_path, x)
    keys = list(PAPER_OBJECTIVES)
    label = {"worst": "worst case", "mean": "weighted mean",
             "each": "worst case"}[case.condition_mode]
    # as wide as the longest name, as far as 80 columns allow (the values take the rest)
    width = min(max(len("condition"), len(label), *map(len, names)) + 1,
                WIDTH - 12 * len(keys) - 7)
    head = "".join(f"{k + ' [' + objective_display(k)[1] + ']':>12}" for k in keys)
    typer.echo(f"{'condition':<{width}}{head}{'time':>7}")
    evs = []
    for i, c in enumerate(case.conditions):
        t0 = time.perf_counter()
        ev = evaluate(case.condition_case(i), x)
        _check_finite(ev.objectives, case, x, c.name)
        evs.append(ev)
        vals = "".join(f"{ev.objectives[k] * objective_display(k)[0]:12.5g}" for k in keys)
        typer.echo(f"{c.name[:width - 1]:<{width}}{vals}{time.perf_counter() - t0:6.2f}s")
        if ev.info.get("contact_loss_steps"):
            typer.echo(f"WARNING: {c.name}: contact lost (force <= 0) in "
                       f"{ev.info['contact_loss_steps']} steps", err=True)
    weights = [c.weight for c in case.conditions]
    combined = combine_conditions([e.objectives for e in evs], names, weights,
                                  case.condition_mode)
    vals = "".join(f"{combined[k] * objective_display(k)[0]:12.5g}" for k in keys)
    typer.echo(f"{label:<{width}}{vals}")
    p = out / "simulation.h5"
    write_condition_evaluations((p.folder, p.name), evs, x, case.names, names,
                                weights, combined,
                                {"case": case.resolved, **machine.describe()})
    _said(out, [p], "histories")
    if plots:
        from ..report.simulation import simulation_figures

        drawn = [simulation_figures(ev, case.name, out.sub(c.name))
                 for c, ev in zip(case.conditions, evs)]
        # one line for them all: three plots a condition would fill the terminal
        folder = Path(str(drawn[0][0])).parent.parent / "<condition>"
        out.lines.extend(wrap_items([Path(str(p)).name for p in drawn[0]], "plots: "))
        out.lines.append(f"  of each condition, in {folder}/")
    return Evaluation(combined, evs[0].histories, evs[0].info)


def _simulate_settlement(case, case_path: Path, x, out: Path, plots: bool, evaluate) -> Evaluation:
    """A case with degradation: the paper's objectives on the new track and the settlement
    prediction of the design; its histories and, with plots, the settlement figures."""
    from ..config.describe import degradation_lines

    _echo_setting(case, case_path, x)
    typer.echo("\n".join(line[2:] for line in degradation_lines(case)))
    t0 = time.perf_counter()
    ev = evaluate(case, x)
    wall = time.perf_counter() - t0
    _check_finite(ev.objectives, case, x)
    info, o = ev.info, ev.objectives
    typer.echo("the paper's objectives on the new track"
               + (f" ({case.condition_mode} over the conditions):" if len(case.traffic) > 1
                  else ":"))
    for k in PAPER_OBJECTIVES:
        scale, unit = objective_display(k)
        typer.echo(f"  {k:<6} = {o[k] * scale:10.5g} {unit:<2}  {OBJECTIVE_DOC[k]}")
    horizon = info.get("settlement_horizon_years", math.nan)
    typer.echo(f"settlement after {horizon:g} year{'' if horizon == 1 else 's'}: "
               f"{info.get('settlement_simulations', '?')} simulations, "
               f"{info.get('settlement_blocks', '?')} blocks, {wall:.1f} s")
    typer.echo("  (the law's values, not a forecast: not calibrated to a measured crossing)")
    if info.get("settlement_tamping"):
        typer.echo("  (tamped: each measure is its worst over the horizon, not at the horizon)")
    _echo_objectives(o, [k for k in (*SETTLEMENT_OBJECTIVES, "years_to_limit") if k in o])
    if not info.get("settlement_limit_reached", True):
        typer.echo(f"  (the limit, {info['settlement_limit_measure']} "
                   f"{info['settlement_limit_value'] * 1e3:g} mm, is not reached within the "
                   f"horizon)")
    if info.get("settlement_tamping"):
        years = ev.histories["settlement_years"][ev.histories["settlement_tamped"].astype(bool)]
        typer.echo(f"  tamped {len(years)} time(s)"
                   + (": after " + ", ".join(f"{y:.3g}" for y in years) + " years"
                      if len(years) else ""))
    if info.get("settlement_budget_bound"):
        deg = case.degradation
        typer.echo(wrap_message(
            f"note: the prediction used all {deg['max_simulations']} simulations it may "
            f"(degradation.max_simulations) and spread them wider than the "
            f"{deg['tolerance'] / 1e3:g} kN tolerance asks (a tamped track needs some after "
            f"every tamping): its measures carry that error. Measured on configs/settlement"
            f".yaml's reference design: 30, 60 and 120 simulations give the same 8 tampings "
            f"and measures within 3 % (benchmarks/RESULTS-settlement.md, 'Numerics'); "
            f"a larger max_simulations checks a case of your own"), err=True)
    h = ev.histories
    if "settlement_sleepers" in h:
        s, v = h["settlement_sleepers"][-1] * 1e3, h["settlement_void"][-1] * 1e3
        typer.echo("settlement and void [mm] at the horizon, from the sleeper next to the slab:")
        typer.echo("\n".join(wrap_items([f"{a:.2f}" for a in s], "  settlement ")))
        typer.echo("\n".join(wrap_items([f"{a:.2f}" for a in v], "  void       ")))
    _write(out, ev, x, case)
    if plots:
        from ..report.settlement import (
            Design,
            fig_settlement_history,
            fig_settlement_profile,
            limit_of,
        )
        from ..report.simulation import simulation_figures

        paths = simulation_figures(ev, case.name, out)
        design = Design("design", h, info)
        title = (f"Settlement of '{case.name}' under its traffic (the law's values, not a "
                 f"forecast)")
        paths.append(fig_settlement_history([design], out, title, limit_of(info)))
        paths.append(fig_settlement_profile([design], out, title))
        _said(out, paths)
    return ev


def _simulate_realisations(case, case_path: Path, x, out: Path, plots: bool,
                           evaluate, other=None) -> Evaluation:
    """A case with uncertainty: the design on the track as drawn and on each realisation
    (each under every traffic condition, combined as the optimiser would), one line per
    track, the statistics over the realisations, one file with every track and the spread
    figure. ``other``: a second design on the same tracks, its statistics and each
    statistic's difference with its interval (kept in the file under ``against``)."""
    from ..config.uncertainty import uncertainty_lines
    from ..engine.executors import local_processes
    from ..fanout import call_in_processes
    from ..problem import Problem
    from ..report.data import BEST_COLOR
    from ..report.robust import NOMINAL_COLOR, fig_spread, spread_of
    from ..store import write_condition_evaluations

    problem = Problem.from_case(case) if _optimisable(case) else None
    keys = _spread_keys(case)
    _echo_setting(case, case_path, x)
    typer.echo("\n".join(line[2:] for line in uncertainty_lines(case, budget=False)))
    conditions = list(range(len(case.conditions))) or [-1]
    tracks = [-1, *range(case.realisations)]
    designs = [x] if other is None else [x, other]
    # the tracks side by side, one process per core (each its own process; the same numbers)
    tasks = [(evaluate, case, d, r, conditions) for d in designs for r in tracks]
    processes = local_processes(len(tasks))
    head = "".join(f"{k[:13]:>14}" for k in keys)
    units = "".join(f"{'[' + (objective_display(k)[1] or '-') + ']':>14}" for k in keys)
    typer.echo(f"{'track':<16}{head}{'time':>7}")
    typer.echo(f"{'':<16}{units}")
    typer.echo(f"simulating {len(tracks)} tracks"
               + (" for each of the two designs" if other is not None else "")
               + f" in {processes} process{'es' if processes > 1 else ''}...", err=True)
    simulated = call_in_processes(_track, tasks, processes)
    this = _on_tracks(case, x, tracks, simulated[:len(tracks)], keys, echo=True)
    levels = sorted({stats.parse(k)[2] for k in (problem.objectives if problem else ())
                     if stats.parse(k) and stats.parse(k)[0] == "quantile"}) or [0.9]
    n = case.realisations
    _echo_statistics(this.objectives, keys, levels, n)
    if other is not None:
        that = _on_tracks(case, other, tracks, simulated[len(tracks):], keys, echo=False)
        typer.echo("\n".join(wrap_items(design_items(case, other), "the other design ")))
        _echo_statistics(that.objectives, keys, levels, n)
        _echo_differences(this.objectives, that.objectives, keys, levels, n)
    p = out / "simulation.h5"
    write_condition_evaluations((p.folder, p.name), this.drawn, x, case.names,
                                [c.name for c in case.conditions],
                                [c.weight for c in case.conditions], this.objectives,
                                {"case": case.resolved, **machine.describe()},
                                realisations=this.realisations,
                                against=None if other is None else (other, that.objectives))
    _said(out, [p], "histories")
    if plots:
        from ..report.simulation import simulation_figures

        label = ("the reference design" if np.array_equal(x, case.reference)
                 else "this design")
        spreads = [spread_of(label, this.objectives, n, BEST_COLOR)]
        title = f"'{case.name}': the design on {n} realisations of the track"
        if other is not None:     # compared with the other: it stands first
            spreads.insert(0, spread_of("the other design", that.objectives, n,
                                        NOMINAL_COLOR))
            title = f"'{case.name}': two designs on the same {n} realisations of the track"
        paths = [fig_spread(spreads, keys, out, title, first="the other design")]
        paths += simulation_figures(this.drawn[0], case.name, out)
        _said(out, paths)
    return Evaluation(this.objectives, this.drawn[0].histories, this.drawn[0].info)


class _OnTracks(NamedTuple):
    """One design on the drawn track and each realisation."""
    objectives: dict        # the drawn track's, and each realisation's as ``F_max#r``
    drawn: list             # the drawn track's evaluation under each condition
    realisations: list      # (combined objectives, first condition's evaluation) of each


def _on_tracks(case, x, tracks, simulated, keys, echo: bool) -> _OnTracks:
    """A design's simulations on ``tracks`` (-1 the drawing) gathered, checked finite and,
    with ``echo``, printed one line per track."""
    names = [c.name for c in case.conditions]
    weights = [c.weight for c in case.conditions]
    drawn, realisations = [], []
    for r, (evs, seconds) in zip(tracks, simulated):
        for i, ev in enumerate(evs):     # one per condition (one for a case without)
            where = (f"{names[i]}, " if names else "") + (f"realisation {r}" if r >= 0 else
                                                         "the drawn track")
            _check_finite(ev.objectives, case, x, where)
        combined = (combine_tracks(evs, names, weights, case.condition_mode) if names
                    else dict(evs[0].objectives))
        if echo:
            label = "as drawn" if r < 0 else f"realisation {r}"
            vals = "".join(f"{combined[k] * objective_display(k)[0]:14.5g}" for k in keys)
            typer.echo(f"{label:<16}{vals}{seconds:6.2f}s")
        if r < 0:
            drawn, on_drawing = evs, combined
        else:
            realisations.append((combined, evs[0]))
    realised = {stats.realisation_key(k, r): v for r, (o, _) in enumerate(realisations)
                for k, v in o.items() if "@" not in k}
    return _OnTracks({**on_drawing, **realised}, drawn, realisations)


def _echo_statistics(objectives: dict, keys, levels, n: int) -> None:
    """The mean, the quantiles, the lowest and the highest value over the realisations."""
    rows = [("mean", lambda v: stats.mean(v))]
    rows += [(f"{q:.0%} quantile", lambda v, q=q: stats.quantile(v, q)) for q in levels]
    rows += [("lowest", np.min), ("highest", np.max)]
    for label, fn in rows:
        vals = "".join(f"{fn(stats.values(objectives, k, n)) * objective_display(k)[0]:14.5g}"
                       for k in keys)
        typer.echo(f"{label:<16}{vals}")


# Below this many realisations the paired bootstrap's interval is too narrow (measured on
# synthetic pairs, benchmarks/robust/interval_calibration.py: a false "clearly lower" in 12 %
# of comparisons with 3, 5 % with 8, 3 % with 12, 2.7 % with 16; docs/robust.md).
FEW_FOR_AN_INTERVAL = 12


def _echo_differences(this: dict, that: dict, keys, levels, n: int) -> None:
    """Each statistic of the design minus the other's, on the same realisations, with its
    paired-bootstrap interval and what the interval says."""
    typer.echo(wrap_message(
        f"this design minus the other on the same {n} realisations, with a "
        f"{stats.CONFIDENCE:.0%} interval (paired bootstrap over the realisations):"))
    for k in keys:
        scale, unit = objective_display(k)
        typer.echo(f"{k} [{unit or '-'}]")
        a, b = stats.values(this, k, n), stats.values(that, k, n)
        for label, level in [("mean", None), *((f"{q:.0%} quantile", q) for q in levels)]:
            d, low, high = stats.paired_difference(a, b, level)
            verdict = ("clearly lower" if high < 0 else "clearly higher" if low > 0
                       else "not clearly different")
            interval = f"{low * scale:+.3g} to {high * scale:+.3g}"
            typer.echo(f"  {label:<14}{d * scale:+10.4g}  {interval:<22} {verdict}")
    if n < FEW_FOR_AN_INTERVAL:
        typer.echo(wrap_message(
            f"note: {n} realisations make these intervals too narrow: of two equal designs "
            f"one is called clearly lower in about 5% of comparisons with 8 realisations "
            f"and 12% with 3, against the 2.5% a 95% interval promises (16 or more: "
            f"--set uncertainty.realisations=16; docs/robust.md)"), err=True)


def _track(evaluate, case, x, r: int, conditions: list[int]) -> tuple[list, float]:
    """One track (realisation ``r``, -1 the drawing) under each condition: the evaluations
    and the seconds they took (a call in a process of its own)."""
    t0 = time.perf_counter()
    return [evaluate(case.part_case(c, r), x) for c in conditions], time.perf_counter() - t0


def combine_tracks(evs, names, weights, mode) -> dict:
    """One track's objectives from its conditions' evaluations, combined as the optimiser
    would (``Problem.combine``)."""
    from ..problem import combine_conditions

    return combine_conditions([e.objectives for e in evs], names, weights, mode)


def _optimisable(case) -> bool:
    opt = case.optimisation or {}
    return bool(opt.get("objectives")) and bool(opt.get("budget"))


def _spread_keys(case) -> list[str]:
    """The objectives a simulation of a case with uncertainty shows per track: those the
    case's objectives measure, then the paper's F_max and E_max (and a settlement measure),
    four at most."""
    from ..uncertainty import statistics as stats

    named = [stats.objective_of(k) for k in (case.optimisation or {}).get("objectives") or []]
    default = ["F_max", "E_max", "F_rms", "E_rms"]
    if case.degradation is not None:
        default = ["differential_settlement", "max_settlement", "F_max", "E_max"]
    return list(dict.fromkeys([*named, *default]))[:4]


def _echo_objectives(objectives: dict, keys) -> None:
    """One line per objective: name, value in engineering units, what it measures."""
    for k in keys:
        scale, unit = objective_display(k)
        typer.echo(f"  {k:<23} {objectives[k] * scale:9.4g} {unit:<6} {OBJECTIVE_DOC.get(k, '')}")


def _simulator():
    """The function that simulates ``(case, x)``: the workers' (lccopt.problem.evaluate) or
    the stand-in named by LCCOPT_EVALUATOR."""
    from ..engine.worker import choose_evaluator, load_evaluator

    return load_evaluator(choose_evaluator())


def _check_finite(objectives: dict, case, x, condition: str | None = None) -> None:
    """Stop (exit 2, one line, nothing written) when an objective is not a finite number."""
    from ..errors import UsageError

    bad = [f"{k} = {v!r}" for k, v in objectives.items()
           if not isinstance(v, (int, float)) or not math.isfinite(v)]
    if bad:
        under = f" under condition {condition}" if condition else ""
        raise UsageError(f"the simulation of {case.name}{under} (design "
                         f"{', '.join(design_items(case, x))}) gave non-finite objectives: "
                         f"{', '.join(bad)}; nothing written")
