"""What the files of runs made by older lccopt versions say differently, read as today's.

The core reads today's run files only; the places that read a run's recorded files (resume,
its journal's first line and run.json) turn an older spelling into today's with these. A run
whose files say something no older version wrote is not upgraded here: the reader refuses it.
"""

from __future__ import annotations

from .worker import DEFAULT_EVALUATOR

# A journal's first line with "optimiser": 12 (a number instead of the settings) was written
# by the last lccopt that did not record its settings; today's defaults with the settings
# added since at their value before (ADDED_SETTINGS) make the proposals of its runs.
UNRECORDED_DEFAULTS = 12

# optimiser settings added after runs recorded theirs, at the value that makes the proposals
# of a run that does not name them (switches: every variable searched as one range;
# shaped_steps: every DYCORS step a coordinate step)
ADDED_SETTINGS = {"switches": False, "shaped_steps": False}

# the simulator under the name older runs recorded in run.json
RENAMED_EVALUATORS = {"lccopt.vti.simulate:evaluate": DEFAULT_EVALUATOR}


def settings_unrecorded(recorded) -> bool:
    """Whether a first line's ``"optimiser"`` value means today's default settings."""
    return type(recorded) is int and recorded == UNRECORDED_DEFAULTS


def recorded_settings_dict(recorded: dict) -> dict:
    """A journal's recorded settings with the settings added since at their earlier value."""
    return {**ADDED_SETTINGS, **recorded}


def evaluator_name(recorded):
    """Today's name of the evaluator a run.json records (anything else as it is)."""
    return RENAMED_EVALUATORS.get(recorded, recorded)
