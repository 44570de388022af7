"""Settlement laws (lccopt/degradation/laws.py) against their definitions."""

import numpy as np
import pytest

from lccopt.degradation.laws import LoadHistory, LogarithmicLaw, VarandasLaw, harmonic


@pytest.mark.parametrize("beta", [0.5, 0.82, 0.95])
def test_harmonic_number_matches_the_sum(beta):
    n = np.arange(1, 3001)
    exact = np.cumsum(n ** -beta)
    got = harmonic(n.astype(float), beta)
    assert np.max(np.abs(got - exact) / exact) < 1e-12
    assert harmonic(0.0, beta) == 0.0
    # increasing between the integers too (real cycle counts of a block)
    x = np.linspace(0.0, 50.0, 2001)
    assert np.all(np.diff(harmonic(x, beta)) > 0)


def brute_force_varandas(law, peaks):
    """Σ_n γ/M ∫_0^{F_n} F^α (h_n(F)+1)^-β dF, cycle by cycle, h_n(F) counting earlier cycles
    whose peak reached F; the integral by fine quadrature."""
    a, b = law.alpha, law.beta
    grid = np.linspace(0.0, max(peaks), 20001)
    M = law.f0 ** (a + 1) / (a + 1) * np.sum(np.arange(1, int(law.n0) + 1) ** -b)
    count = np.zeros_like(grid)
    total = 0.0
    for f in peaks:
        integrand = np.where(grid <= f, grid ** a * (count + 1) ** -b, 0.0)
        total += np.trapezoid(integrand, grid)
        count += grid <= f
    return law.gamma / M * total


def test_varandas_histogram_form_is_the_cycle_by_cycle_law():
    law = VarandasLaw(n0=2000)                         # a small N0 keeps the brute force short
    rng = np.random.default_rng(3)
    peaks = rng.choice([30e3, 45e3, 60e3], size=300)
    expected = brute_force_varandas(law, peaks)
    h = LoadHistory.empty(1)
    for f in peaks:
        h = h.add([f], 1)
    assert law.settlement(h)[0] == pytest.approx(expected, rel=2e-4)
    # grouped by level, in any order: the same (the law depends on the histogram only)
    grouped = LoadHistory.empty(1)
    for f in (60e3, 30e3, 45e3):
        grouped = grouped.add([f], np.sum(peaks == f))
    assert law.settlement(grouped)[0] == pytest.approx(law.settlement(h)[0], rel=1e-12)


def test_varandas_reference_test_and_constant_load():
    law = VarandasLaw()
    h = LoadHistory.empty(3).add([50e3, 25e3, 0.0], 1e6)
    s = law.settlement(h)
    assert s[0] == pytest.approx(10e-3, rel=1e-12)      # γ after N0 cycles of F0
    assert s[1] == pytest.approx(10e-3 * 0.5 ** 1.6, rel=1e-12)
    assert s[2] == 0.0
    # about N^0.18 in the long run
    assert law.constant(50e3, 1e7) / law.constant(50e3, 1e6) == pytest.approx(10 ** 0.18, rel=0.05)
    # a smaller γ (a stiffer ballast) settles less under the same loads
    assert VarandasLaw(gamma=5e-3).settlement(h)[0] < s[0]


def test_logarithmic_law_constant_load_and_strain_hardening():
    law = LogarithmicLaw()
    assert law.constant(50e3, 1e6) == pytest.approx(VarandasLaw().constant(50e3, 1e6), rel=1e-12)
    # a constant load in blocks: the closed form
    h = LoadHistory.empty(1)
    for n in (10, 90, 900, 9000):
        h = h.add([40e3], n)
    assert law.settlement(h)[0] == pytest.approx(float(law.constant(40e3, 1e4)), rel=1e-10)
    # a heavier block after a lighter one settles more than the light one alone
    light = LoadHistory.empty(1).add([30e3], 1e5)
    assert law.settlement(light.add([60e3], 1e5))[0] > law.settlement(light.add([30e3], 1e5))[0]
    # a sleeper over a void (no load) does not settle
    assert law.settlement(light.add([0.0], 1e6))[0] == law.settlement(light)[0]
