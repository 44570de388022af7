"""Older runs' spellings read as today's (lccopt.engine.upgrade)."""

from lccopt.engine.upgrade import evaluator_name, settings_unrecorded
from lccopt.engine.worker import DEFAULT_EVALUATOR


def test_the_simulator_under_its_old_name_is_todays_simulator():
    assert evaluator_name("lccopt.vti.simulate:evaluate") == DEFAULT_EVALUATOR
    assert evaluator_name("tests.engine.fakesim:evaluate") == "tests.engine.fakesim:evaluate"
    assert evaluator_name(None) is None


def test_only_the_number_12_means_the_default_settings():
    assert settings_unrecorded(12)
    for other in (11, 13, 12.0, "12", True, None, {"surrogate": "scalar"}):
        assert not settings_unrecorded(other)
