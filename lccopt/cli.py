"""The ``lccopt`` command line: options parsed here, each command run by its module in
``lccopt.commands``; the library's errors mapped to one-line messages and exit codes (``main``).

Exit codes: 0 done, 1 internal error, 2 bad usage, case file, run directory or environment
(disk full, read-only), 130 interrupted (any stopping signal), 141 output pipe closed.
"""

from __future__ import annotations

import enum
import os
import sys
from pathlib import Path
from typing import List, Optional

from .errors import STOP_SIGNALS


def _exit_at_once(signum, frame) -> None:
    """A stopping signal while the command line loads: nothing is open yet, so exit 130 with
    its one line at once (``main`` then makes these signals raise, to clean up)."""
    import signal

    try:
        os.write(2, f"lccopt: interrupted by {signal.Signals(signum).name}\n".encode())
    except OSError:
        pass
    os._exit(130)


if Path(sys.argv[0]).name in ("lccopt", "__main__.py"):
    # the command itself (not a program importing this module): SIGTERM, SIGHUP, ... end it
    # with exit 130 from here on, its first ~0.05 s of interpreter start-up aside
    import signal

    for _sig in STOP_SIGNALS:
        signal.signal(_sig, _exit_at_once)

# One BLAS thread in the lccopt process, set before numpy loads OpenBLAS: the engine's
# optimiser runs while the worker simulations use the cores, and multi-threaded BLAS then
# spins against them (measured: ask/tell 2.5x slower, parallel efficiency 0.94 -> 0.87).
# The simulations' banded solves are sequential anyway. An explicit setting wins. The imports
# below it may load numpy, so they follow it (noqa: E402).
from .fanout import SINGLE_THREAD_ENV  # noqa: E402 (no numpy: it names the settings)

for _var, _value in SINGLE_THREAD_ENV.items():
    os.environ.setdefault(_var, _value)

import typer  # noqa: E402

from .errors import (  # noqa: E402
    CaseError,
    Interrupted,
    UsageError,
    describe_os_error,
    printable,
    stop_on_signals,
    swallowed_interruption,
)
from .terminal import PipeGuard, guard_streams, wrap_message  # noqa: E402

EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_INTERRUPTED, EXIT_PIPE = 0, 1, 2, 130, 141

_APP_HELP = (
    "Optimise railway level crossings and their transition zones.\n\n"
    "Objectives (paper Sec. 2.2.2), over the evaluation zone next to the interface: "
    "F_rms and F_max, the rms and the max - min of the wheel-rail contact force (kN); "
    "E_rms and E_max, the rms and the max - min over the zone sleepers of the energy "
    "dissipated in the ballast under each (J)."
)
_RUN_HELP = "run directory, e.g. runs/moo (or moo: runs/moo)"
_WORKERS_HELP = "local worker processes (default: number of cores)"
_SCHEDULER_HELP = "Dask scheduler address, e.g. tcp://host:8786"

app = typer.Typer(no_args_is_help=True, pretty_exceptions_enable=False, rich_markup_mode=None,
                  help=_APP_HELP)


class Format(str, enum.Enum):
    md = "md"
    html = "html"
    both = "both"


def _version(value: bool) -> None:
    if value:
        from .version import version_text

        typer.echo(f"lccopt {version_text()}")
        raise typer.Exit()


@app.callback()
def _main_options(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                                help="print the version and the fingerprint of "
                                                     "the code, and exit")) -> None:
    """Optimise railway level crossings and their transition zones."""


_SET_HELP = ("set a case key as if the case file said so, e.g. --set vehicle.speed='160 km/h' "
             "(repeatable; recorded in the resolved case)")


def _set_option():
    return typer.Option(None, "--set", metavar="KEY.PATH=VALUE", help=_SET_HELP)


@app.command()
def check(case: Path = typer.Argument(..., help="case file (YAML)"),
          set_: Optional[List[str]] = _set_option()) -> None:
    """Validate a case file without simulating."""
    from .commands.check import run_check

    run_check(case, set_ or ())


@app.command()
def example(
    names: Optional[List[str]] = typer.Argument(
        None, metavar="[NAME]...", help="bundled case(s), e.g. quickstart, reference, "
                                        "vehicles/virm-bogie (lccopt example --list)"),
    list_: bool = typer.Option(False, "--list", help="list the bundled cases and exit"),
    all_: bool = typer.Option(False, "--all", help="write every bundled case"),
    out: Path = typer.Option(Path("."), "--out", help="folder to write into (default: the "
                             "current one)"),
    force: bool = typer.Option(False, "--force", help="replace files that differ from the "
                               "bundled ones"),
) -> None:
    """Write a bundled case (and the cases it extends) into the current folder, or list them."""
    from .commands.example import run_example

    run_example(names or [], list_, all_, out, force)


@app.command()
def simulate(
    case: Path = typer.Argument(..., help="case file (YAML)"),
    design: Optional[str] = typer.Option(
        None,
        help="design x in the case's order, comma-separated: "
             "pad stiffness x_r1..x_rN in MN/m, then x_n, the spans x_s1.. and "
             "the strip x_l in m (0.1 m steps); e.g. 214,155,50,5,0.6,0.7,0.3,0; "
             "or by name as status prints it: \"x_r1=214 MN/m, x_n=5\" (the others "
             "at the reference) (default: the case's reference design)"),
    against: Optional[str] = typer.Option(
        None,
        help="a case with uncertainty: a second design (in either form of --design), "
             "simulated on the same tracks; prints each statistic's difference with a 95 % "
             "interval and whether the design is clearly lower"),
    out: Optional[Path] = typer.Option(
        None, help="output directory (default: runs/<case name>-simulate)"),
    no_plots: bool = typer.Option(False, "--no-plots", help="skip the PNG plots"),
    force: bool = typer.Option(
        False, "--force", help="replace a simulation already in the output directory"),
    set_: Optional[List[str]] = _set_option(),
) -> None:
    """Simulate one design: print F_rms, F_max (kN), E_rms, E_max (J); write HDF5 and plots."""
    from .commands.simulate import run_simulate

    run_simulate(case, design, out, not no_plots, force, set_ or (), against)


@app.command()
def optimise(
    case: Path = typer.Argument(..., help="case file (YAML) with an optimisation section"),
    workers: Optional[int] = typer.Option(None, help=_WORKERS_HELP),
    scheduler: Optional[str] = typer.Option(None, help=_SCHEDULER_HELP),
    runs: Path = typer.Option(Path("runs"), help="directory that holds run directories"),
    force: bool = typer.Option(False, "--force", help="replace an existing lccopt run directory "
                               "of the same name inside --runs"),
    budget: Optional[int] = typer.Option(None, help="evaluations in all (default: the case's "
                                         "optimisation.budget)"),
    set_: Optional[List[str]] = _set_option(),
) -> None:
    """Run the surrogate optimisation of a case into runs/<case name>/."""
    from .commands.run import run_optimise

    run_optimise(case, set_, workers, scheduler, runs, force, budget)


def _run_dir(run: Path) -> Path:
    """RUN as given, or runs/RUN where RUN is a bare name (the case's name) with no folder of
    that name here: `lccopt status quickstart` reads runs/quickstart."""
    if os.path.lexists(run) or len(run.parts) != 1:
        return run
    if os.path.lexists(Path("runs") / run):
        return Path("runs") / run
    raise UsageError(f"{run}: no such run directory, nor {Path('runs') / run}")


@app.command()
def resume(
    run: Path = typer.Argument(..., help=_RUN_HELP),
    workers: Optional[int] = typer.Option(None, help=_WORKERS_HELP),
    scheduler: Optional[str] = typer.Option(None, help=_SCHEDULER_HELP),
    case: Optional[Path] = typer.Option(None, help="the case file to check against (default: the "
                                        "one the run was started from)"),
    allow_changed_case: bool = typer.Option(False, "--allow-changed-case",
                                            help="resume even if the case file changed (budget, "
                                                 "timeout and the ASF's worst and rho may)"),
    budget: Optional[int] = typer.Option(None, help="carry the run on to this many evaluations in "
                                         "all (a finished run too)"),
    repair_journal: bool = typer.Option(False, "--repair-journal",
                                        help="carry on from the lines before a damaged line of the "
                                             "journal (the whole journal is kept beside it)"),
) -> None:
    """Carry on an interrupted run where it stopped, or a finished one to a larger budget."""
    from .commands.run import run_resume

    run_resume(_run_dir(run), workers, scheduler, case, allow_changed_case, budget,
               repair_journal)


@app.command()
def status(run: Path = typer.Argument(..., help=_RUN_HELP)) -> None:
    """Where a run stands: state, evaluations, best so far, pace (safe while it runs)."""
    from .commands.status import run_status

    run_status(_run_dir(run))


@app.command()
def report(
    run: Path = typer.Argument(..., help=_RUN_HELP),
    format: Format = typer.Option(Format.both, "--format", help="summary format"),
    out: Optional[Path] = typer.Option(
        None, "--out", help="output directory (default: RUN/report)"),
    force: bool = typer.Option(False, "--force", help="replace a report already in --out"),
) -> None:
    """Write figures and a summary of a run into RUN/report/ (or --out)."""
    from .commands.report import run_report

    run_report(_run_dir(run), format.value, out, force)


def main(argv: list[str] | None = None) -> int:
    """Console entry point: map errors to exit codes and one-line messages."""
    try:
        stop_on_signals()
        guard_streams()
        usage_errors, aborts = _click_exception_types()
        code = _main(argv, usage_errors, aborts)
    except KeyboardInterrupt as exc:  # before or after the command's own handling
        code = _interrupted(exc)
    if code == EXIT_OK and swallowed_interruption() is not None:
        code = _interrupted(swallowed_interruption())
    # done: a signal from here on (the interpreter's shutdown, which restores the default
    # handlers of Python-level ones) must not turn the exit code into a kill's
    _ignore_stop_signals()
    if PipeGuard.closed_pipe:
        return EXIT_PIPE
    if code == EXIT_INTERRUPTED:
        _end_now(code)
    out = sys.stdout
    if code == EXIT_OK and isinstance(out, PipeGuard) and out.lost:
        # the command's work is done; what it had to say is not, and a script must know
        return _fail(f"lccopt: error: cannot write to {out.name}: {out.failed}", EXIT_USAGE)
    return code


def _main(argv, usage_errors, aborts) -> int:
    if not (sys.argv[1:] if argv is None else argv):
        argv = ["--help"]  # bare `lccopt`: its help, and success
    try:
        # non-standalone click returns the code of a typer.Exit instead of raising it
        code = app(args=argv, standalone_mode=False)
        if code == EXIT_INTERRUPTED and Interrupted.last is not None:
            # recent typer returns an interruption as a bare 130: say which signal it was
            return _interrupted(Interrupted(Interrupted.last))
        if isinstance(code, int) and code != EXIT_OK:
            return code
    except (CaseError, UsageError) as exc:
        return _fail(f"lccopt: error: {exc}", EXIT_USAGE)
    except typer.Exit as exc:
        return exc.exit_code
    except (KeyboardInterrupt, *aborts) as exc:
        return _interrupted(exc)
    except usage_errors as exc:  # usage errors: one line naming the command, exit 2
        return _fail(_usage_line(exc, sys.argv[1:] if argv is None else argv), EXIT_USAGE)
    except BrokenPipeError:  # the reader went away (| head): stop quietly, as SIGPIPE would
        _silence_stdio()
        return EXIT_PIPE
    except OSError as exc:  # the environment refused: read-only, missing, full, not a file ...
        return _fail(f"lccopt: error: {describe_os_error(exc)}", EXIT_USAGE)
    except Exception as exc:
        cause = _interruption_behind(exc)
        if cause is not None:
            # a signal raised where Python wraps what it raises (a class body's __set_name__,
            # a codec, an import hook): still the interruption, not an internal error
            return _interrupted(cause)
        import traceback

        try:
            traceback.print_exc()
        except OSError:
            pass
        return _fail(f"lccopt: internal error: {exc}", EXIT_INTERNAL)
    return EXIT_OK


def _interruption_behind(exc: BaseException) -> BaseException | None:
    """The interruption an exception was raised because of (its cause or context), if any."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def _click_exception_types() -> tuple[tuple, tuple]:
    """(usage error classes, abort classes) of the click typer runs on: recent typer vendors
    click (typer.TyperException is the base of its ClickException), older typer uses click."""
    usage, aborts = [], [typer.Abort]
    if hasattr(typer, "TyperException"):
        usage.append(typer.TyperException)
    try:
        import click

        usage.append(click.ClickException)
        aborts.append(click.exceptions.Abort)
    except ImportError:
        pass
    return tuple(usage), tuple(aborts)


def _usage_line(exc: Exception, argv=()) -> str:
    """click's usage error as one line: `lccopt report: error: ... (see lccopt report --help)`,
    with how to write --set where a --set value split into two words caused it."""
    ctx = getattr(exc, "ctx", None)
    command = "lccopt" + (f" {ctx.info_name}" if ctx is not None and ctx.parent is not None else "")
    message = exc.format_message() if hasattr(exc, "format_message") else str(exc)
    message = " ".join(message.replace("Value error, ", "").split())
    hint = _set_hint(list(argv)) if "unexpected extra argument" in message else ""
    return f"{command}: error: {message} (see {command} --help){hint}"


def _set_hint(argv: list[str]) -> str:
    """For a --set whose value the shell split in two (`--set optimisation.budget 30`,
    `--set vehicle.speed=120 km/h`): the one word it should have been."""
    for i, arg in enumerate(argv[:-2]):
        value, extra = argv[i + 1], argv[i + 2]
        if arg != "--set" or extra.startswith("-"):
            continue
        if "=" not in value:
            return (f"; --set takes KEY=VALUE as one word: --set {value}={extra}"
                    if " " not in extra else f"; --set takes KEY=VALUE as one word, quoted "
                                             f"if it holds a space: --set '{value}={extra}'")
        return (f"; a --set value with a space must be quoted: --set '{value} {extra}' "
                f"(or no space: --set {value}{extra})")
    return ""


def _fail(message: str, code: int) -> int:
    """Print the message to stderr (if anyone is still reading it) and return the exit code:
    one line for a log or a script, wrapped to the width of a terminal for a person."""
    message = printable(message)  # one line, whatever stored string it quotes
    try:
        if sys.stderr.isatty():
            message = wrap_message(message)
        typer.echo(message, err=True)
    except OSError:  # stderr closed or a broken pipe: the exit code still tells
        _silence_stdio()
    return code


def _interrupted(exc: BaseException) -> int:
    _ignore_stop_signals()  # a second signal must not break the message or the exit code
    how = f" by {exc.name}" if isinstance(exc, Interrupted) else ""
    return _fail(f"lccopt: interrupted{how}", EXIT_INTERRUPTED)


def _end_now(code: int) -> None:
    """End an interrupted command without the interpreter's finalisation: the signal may have
    cut an extension module's import or a C library's call in half, and tearing those modules
    down then crashed the process (SIGSEGV after the one line, measured under load). What was
    computed is on disk already (journal lines are synced, result files replaced whole); the
    exit handlers still run, so worker processes and pools are stopped."""
    import atexit

    try:
        atexit._run_exitfuncs()
    except BaseException:  # noqa: BLE001 - ending anyway
        pass
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)


def _ignore_stop_signals() -> None:
    import signal

    for sig in STOP_SIGNALS:
        try:
            signal.signal(sig, signal.SIG_IGN)
        except (OSError, ValueError):
            pass


def _silence_stdio() -> None:
    """Point stdout/stderr at /dev/null so that the interpreter's final flush cannot fail."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    for fd in (1, 2):
        try:
            os.dup2(devnull, fd)
        except OSError:
            pass


if __name__ == "__main__":  # python -m lccopt.cli: use the package's module, not a second copy
    from lccopt.cli import main as package_main

    sys.exit(package_main())
