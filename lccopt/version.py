"""The version of lccopt that a run records (run.json, the journal, results.h5)."""

__version__ = "0.1.0"
