"""Settlement laws (lccopt/degradation/laws.py) against their definitions."""

import numpy as np
import pytest

from lccopt.degradation.laws import (
    LI_SELIG,
    LoadHistory,
    LogarithmicLaw,
    SleeperLaw,
    SubgradeLaw,
    VarandasLaw,
    harmonic,
)


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
    # a load history's (rows, sleepers) counts, a few small among large: as one by one
    counts = np.array([[0.0, 3.5, 1e6], [19.99, 20.0, 7.0], [1e-3, 4e4, 0.0]])
    one_by_one = np.array([[float(harmonic(c, beta)) for c in row] for row in counts])
    assert np.array_equal(harmonic(counts, beta), one_by_one)
    assert float(harmonic(5.0, beta)) == pytest.approx(np.sum(np.arange(1, 6) ** -beta), rel=1e-12)


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
    law = LogarithmicLaw(first_cycle=0.2e-3, log_rate=0.3)
    assert law.constant(50e3, 1.0) == pytest.approx(0.2e-3, rel=1e-12)
    assert law.constant(50e3, 1e6) == pytest.approx(0.2e-3 * (1 + 0.3 * np.log(1e6)), rel=1e-12)
    # a constant load in blocks: the closed form
    s = law.start(1)
    for n in (10, 90, 900, 9000):
        s = law.add(s, [[40e3]], [n])
    assert law.settlement(s)[0] == pytest.approx(float(law.constant(40e3, 1e4)), rel=1e-10)
    # a heavier block after a lighter one settles more than the light one alone
    light = law.add(law.start(1), [[30e3]], [1e5])
    assert law.add(light, [[60e3]], [1e5])[0] > law.add(light, [[30e3]], [1e5])[0]
    # a sleeper over a void (no load) does not settle
    assert law.add(light, [[0.0]], [1e6])[0] == light[0]
    with pytest.raises(ValueError):
        LogarithmicLaw(first_cycle=0.0, log_rate=0.3)


def random_history(law, n, rng):
    state = law.start(n)
    for _ in range(30):
        state = law.add(state, rng.uniform(30e3, 50e3, (1, n)), [rng.uniform(1, 1e4)])
    return state


@pytest.mark.parametrize("law", [
    VarandasLaw(), LogarithmicLaw(first_cycle=0.2e-3, log_rate=0.3),
    SubgradeLaw.of_soil("CH", 100e3, np.full(5, 0.375), 0.5, 2.0),
    SleeperLaw(VarandasLaw(), np.linspace(0.8, 1.0, 5), np.linspace(0.9, 1.2, 5),
               SubgradeLaw.of_soil("CL", 150e3, np.full(5, 0.375), 0.5, 2.0), np.full(5, 1e-4))],
    ids=["varandas", "logarithmic", "li-selig", "sleeper"])
def test_sensitivity_is_the_derivative_by_each_row(law):
    """What the implicit block update differentiates: d settlement / d peak of each new row,
    against central differences, also where two rows tie (they rise together)."""
    rng = np.random.default_rng(0)
    state = random_history(law, 5, rng)
    peaks = rng.uniform(25e3, 60e3, (3, 5))
    cycles = np.array([100.0, 100.0, 50.0])
    s, d = law.sensitivity(state, peaks, cycles)
    np.testing.assert_allclose(s, law.settlement(law.add(state, peaks, cycles)), rtol=1e-12)
    h = 0.5
    for r in range(3):
        up, down = peaks.copy(), peaks.copy()
        up[r] += h
        down[r] -= h
        fd = (law.settlement(law.add(state, up, cycles))
              - law.settlement(law.add(state, down, cycles))) / (2 * h)
        np.testing.assert_allclose(d[r], fd, rtol=1e-4, atol=1e-6 * np.abs(fd).max())
    peaks[1] = peaks[0]
    s, d = law.sensitivity(state, peaks, cycles)
    up, down = peaks.copy(), peaks.copy()
    up[:2] += h
    down[:2] -= h
    fd = (law.settlement(law.add(state, up, cycles))
          - law.settlement(law.add(state, down, cycles))) / (2 * h)
    np.testing.assert_allclose(d[0] + d[1], fd, rtol=1e-4, atol=1e-6 * np.abs(fd).max())


def test_a_larger_base_under_the_same_force_settles_less_by_the_laws_exponent():
    """The ballast law is fed the pressure: a sleeper with a 1.25x larger base carries the same
    force at 1/1.25 of the pressure, and settles 1.25^-(α+1) as much (Varandas: the load
    enters as F^(α+1)); a standard sleeper keeps the force-fed law's numbers."""
    ballast = VarandasLaw()
    law = SleeperLaw(ballast, pressure_scale=np.array([1.0, 1 / 1.25]),
                     ballast_factor=np.ones(2))
    state = law.add(law.start(2), [[45e3, 45e3]], [3e5])
    s = law.settlement(state)
    assert s[0] == pytest.approx(float(ballast.constant(45e3, 3e5)), rel=1e-12)
    assert s[1] / s[0] == pytest.approx(1.25 ** -(ballast.alpha + 1), rel=1e-12)
    # the logarithmic law by its own exponent m
    log = LogarithmicLaw(first_cycle=0.2e-3, log_rate=0.3)
    law = SleeperLaw(log, np.array([1.0, 1 / 1.25]), np.ones(2))
    s = law.settlement(law.add(law.start(2), [[45e3, 45e3]], [3e5]))
    assert s[1] / s[0] == pytest.approx(1.25 ** -log.exponent, rel=1e-9)


def test_li_selig_subgrade_is_the_strain_of_its_sublayers():
    """S = Σ_layers h (a/100) (σ_d/σ_s)^m N^b, σ_d the 2:1 spread of the force over a square of
    the bearing area; a weaker soil, a deeper or thinner layer settle as the law says."""
    a, b, m = LI_SELIG["CL"]
    area, depth, thick, strength, force, n = 0.375, 0.5, 2.0, 150e3, 45e3, 1e6
    law = SubgradeLaw.of_soil("CL", strength, [area], depth, thick)
    z = np.linspace(depth, depth + thick, 200001)
    sigma = force / (np.sqrt(area) + z) ** 2
    expected = np.trapezoid(a / 100 * (sigma / strength) ** m * n ** b, z)
    assert float(law.constant(force, n)[0]) == pytest.approx(expected, rel=1e-3)
    # half the strength: 2^m times the settlement
    weak = SubgradeLaw.of_soil("CL", strength / 2, [area], depth, thick)
    assert weak.constant(force, n)[0] / law.constant(force, n)[0] == pytest.approx(2 ** m)
    # constant load in blocks is the closed form; rows in any order are the same (order-free
    # strain hardening of a power law in N)
    s = law.start(1)
    for k in (10, 90, 900, 9000):
        s = law.add(s, [[force]], [k])
    assert law.settlement(s)[0] == pytest.approx(float(law.constant(force, 1e4)[0]), rel=1e-10)
    one = law.add(law.add(law.start(1), [[30e3]], [1e4]), [[60e3]], [1e3])
    other = law.add(law.add(law.start(1), [[60e3]], [1e3]), [[30e3]], [1e4])
    assert law.settlement(one)[0] == pytest.approx(law.settlement(other)[0], rel=1e-12)
    # a larger base spreads the force: less stress, less settlement
    wide = SubgradeLaw.of_soil("CL", strength, [1.25 * area], depth, thick)
    assert wide.constant(force, n)[0] < law.constant(force, n)[0]


def test_tamping_restarts_the_ballast_and_keeps_the_subgrade():
    """Tamped sleepers are lifted to the level asked and their ballast settles anew (fast at
    first: the law's first cycles); the others and every subgrade keep their history."""
    sub = SubgradeLaw.of_soil("CL", 150e3, np.full(3, 0.375), 0.5, 2.0)
    law = SleeperLaw(VarandasLaw(), np.ones(3), np.ones(3), sub)
    state = law.add(law.start(3), np.full((1, 3), 45e3), [1e6])
    before = law.parts(state)
    tamped = law.tamp(state, [True, True, False], np.zeros(3))
    after = law.parts(tamped)
    s = law.settlement(tamped)
    assert s[:2] == pytest.approx([0.0, 0.0], abs=1e-15)
    assert s[2] == law.settlement(state)[2]
    np.testing.assert_array_equal(after["subgrade"], before["subgrade"])
    # the next 10^4 cycles: the tamped ballast settles as new ballast, the untamped one slowly
    more = law.add(tamped, np.full((1, 3), 45e3), [1e4])
    gain = law.settlement(more) - law.settlement(tamped)
    new = float(VarandasLaw().constant(45e3, 1e4))
    assert gain[0] - (law.parts(more)["subgrade"][0] - after["subgrade"][0]) == \
        pytest.approx(new, rel=1e-9)
    assert gain[0] > 5 * gain[2]
