"""The law's uncertainty (lccopt/degradation/variants.py) and the report's verdict on it
(lccopt/report/settlement.py)."""

import numpy as np
import pytest

from lccopt.degradation.inputs import DegradationSpec, LawSpec
from lccopt.degradation.laws import LogarithmicLaw, VarandasLaw
from lccopt.degradation.variants import law_variants, other_law
from lccopt.report.law_variants import _verdict, check_sentences

VARANDAS = LawSpec("varandas", (("alpha", 0.6), ("beta", 0.82), ("gamma", 10e-3),
                                ("f0", 50e3), ("n0", 1e6)))


def test_the_other_law_matches_at_the_first_cycle_and_at_n0():
    log = other_law(VARANDAS)
    v, g = VarandasLaw(**dict(VARANDAS.parameters)), LogarithmicLaw(**dict(log.parameters))
    for n in (1.0, 1e6):
        assert float(g.constant(50e3, n)) == pytest.approx(float(v.constant(50e3, n)), rel=1e-9)
    # the same load exponent; a different form between (the point of the variant)
    assert float(g.constant(25e3, 1e6)) / float(g.constant(50e3, 1e6)) == pytest.approx(
        0.5 ** 1.6)
    assert abs(float(g.constant(50e3, 1e3)) / float(v.constant(50e3, 1e3)) - 1) > 0.05
    back = dict(other_law(log).parameters)
    for k, val in VARANDAS.parameters:
        assert back[k] == pytest.approx(val, rel=1e-6)


def test_eight_variants_each_change_one_thing():
    spec = DegradationSpec(traffic=(), horizon_years=10.0, law=VARANDAS)
    out = law_variants(spec)
    assert len(out) == 8
    base = dict(VARANDAS.parameters)
    for label, v in out[:6]:
        p = dict(v.law.parameters)
        changed = [k for k in p if not np.isclose(p[k], base[k])]
        assert len(changed) == 1 and v.reading == "axle", label
    p = dict(out[1][1].law.parameters)                   # 1 - beta 30 % lower
    assert 1 - p["beta"] == pytest.approx(0.7 * 0.18)
    assert out[6][1].reading == "passage" and out[6][1].law == VARANDAS
    assert out[7][1].law.name == "logarithmic"


def rows(wins: int, n: int = 8):
    return [{"label": str(i), "best": {"a": 1.0, "b": 1.0},
             "reference": {"a": 2.0 if i < wins else 0.5, "b": 1.0}} for i in range(n)]


@pytest.mark.parametrize("wins, within", [(8, False), (5, False), (4, True), (0, True)])
def test_within_the_models_uncertainty_when_not_most(wins, within):
    check = _verdict({"variants": rows(wins)}, ["a", "b"])
    assert check["beats"] == wins and check["within_uncertainty"] == within
    text = " ".join(check_sentences(check))
    assert f"in {wins} of 8" in text
    assert ("within the model's uncertainty" in text) == within
