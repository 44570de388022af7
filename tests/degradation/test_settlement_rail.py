"""The rail's measures (lccopt/degradation/rail.py) on levels whose answers are known: the D1
band passes 3-25 m wavelengths whole and stops the others; the step and the angle of a ramp
down off the slab."""

import numpy as np
import pytest

from lccopt.degradation.rail import SAMPLE, RailGrid, d1_level


def grid(x_a=100.0, x_b=112.0, far=88.0):
    x = 40.0 + SAMPLE * np.arange(int(110.0 / SAMPLE) + 1)
    shown = np.flatnonzero((x >= far - 3) & (x <= x_b))
    return RailGrid(x, x_a, (far, x_b), shown, (far - 3.0, x_a + 3.0))


@pytest.mark.parametrize("wavelength, gain", [(1.0, 0.0), (5.0, 1.0), (12.0, 1.0), (20.0, 1.0),
                                              (120.0, 0.0)])
def test_d1_band_passes_3_to_25_m(wavelength, gain):
    g = grid()
    level = 1e-3 * np.sin(2 * np.pi * g.x / wavelength)
    out = d1_level(level)
    mid = (g.x > 80) & (g.x < 110)            # away from the ends
    amp = np.sqrt(2) * np.std(out[mid])
    assert amp == pytest.approx(gain * 1e-3, abs=0.12e-3)


def test_step_and_angle_of_a_ramp_off_the_slab():
    """The approach 4 mm below the slab, reached over a 2 m ramp: step 4 mm, angle 2 mm/m;
    a level uniform over everything measures nothing."""
    g = grid()
    level = np.interp(g.x, [0.0, 98.0, 100.0, 200.0], [4e-3, 4e-3, 0.0, 0.0])
    m = g.measures(level)
    assert m["rail_step"] == pytest.approx(4e-3)
    assert m["rail_angle"] == pytest.approx(2e-3, rel=1e-6)
    assert m["level_d1_max"] > 1e-3                     # the ramp is in the D1 band
    flat = g.measures(np.full(g.x.shape, 5e-3))
    assert flat["rail_step"] == 0.0 and flat["rail_angle"] == 0.0
    assert flat["level_d1_max"] < 1e-6 and flat["level_d1_std"] < 1e-6
