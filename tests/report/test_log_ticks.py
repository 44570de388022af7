"""Labelled ticks on the objective-space figure's logarithmic axes: a Pareto front that lies
within one decade (e.g. 0.3-1.8 kN) still gets readable numbers."""

import numpy as np
import pytest

from lccopt.report.plotting import log_ticks


@pytest.mark.parametrize("lo, hi", [(0.3, 1.8), (2.6, 13.0), (0.05, 40.0), (1.0, 4.5), (1e3, 9e4)])
def test_every_wide_range_gets_at_least_four_labels_inside_it(lo, hi):
    ticks = np.array(log_ticks(lo, hi))
    inside = ticks[(ticks >= lo) & (ticks <= hi)]
    assert len(inside) >= 4, ticks
    assert np.all(np.diff(ticks) > 0)
    mantissa = ticks / 10.0 ** np.floor(np.log10(ticks) + 1e-9)
    assert np.allclose(mantissa, np.round(mantissa))   # round numbers only: 1, 2, 3, 5, ...


def test_wide_ranges_thin_out_to_one_two_five():
    assert log_ticks(0.01, 100.0) == [0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0,
                                      20.0, 50.0, 100.0]
