"""Benchmarks and studies of lccopt: run from the repository root as `python -m
benchmarks.SUBJECT.SCRIPT` (see benchmarks/README.md). Not part of the lccopt wheel."""
