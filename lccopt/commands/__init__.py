"""The command layer: one module per ``lccopt`` command, between the options ``lccopt.cli``
parsed and the library.

The library (config, engine, report, ...) raises its own errors (``lccopt.errors``) and
returns what it did; these modules say it (``typer.echo``) and map what a command line must
(an interrupted run's exit code). ``lccopt.cli`` maps the errors to one-line messages and
exit codes. Only ``lccopt.cli`` and this package import typer (tests/test_lint.py).
"""
