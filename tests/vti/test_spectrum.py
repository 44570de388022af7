"""Irregularities: a sinusoid excites the contact force at v/λ with the closed-form amplitude of
a mass on a spring; the spectrum generator is deterministic, has the spectrum's PSD in its
band and nothing outside it (lccopt/vti/irregularity.py)."""

import numpy as np
import pytest

from lccopt.vti.irregularity import generate, psd
from lccopt.vti.newmark import integrate
from lccopt.vti.specs import VehicleSpec
from lccopt.vti.track import WinklerBeam
from lccopt.vti.vehicle import Vehicle, build_vehicle

EI = 210e9 * 2.337e-5
M_RAIL = 7800 * 6.977e-3
M_W = 1819.0
G, P = 5.13e-8, 100e3


def wheel_on_spring(kind):
    """The wheelset hung from its bogie by a 1 N/m spring (no damping, no gravity): on its own,
    a mass m_w on the Hertz spring k_w (k_s1/k_w = 3e-10)."""
    if kind == "three-dof":
        return Vehicle(np.array([7047.25, 943.0, M_W]), 1.0, 0.0, 1.0, 0.0, 20.0, 0.0, G, P,
                       "quarter-car")
    return build_vehicle(VehicleSpec(type="bogie", carbody_mass=7047.25, bogie_mass=943.0,
                                     wheelset_mass=M_W, primary_stiffness=1.0,
                                     primary_damping=0.0, secondary_stiffness=1.0,
                                     secondary_damping=0.0, wheelbase=2.5,
                                     bogie_pitch_inertia=1400.0, speed=20.0, gravity=0.0,
                                     hertz_constant=G, hertz_load=P))


@pytest.mark.parametrize("kind", ["three-dof", "bogie"])
def test_sinusoidal_irregularity_drives_the_force_at_v_over_lambda_with_the_closed_form_amplitude(
    kind,
):
    """Setting where the closed form applies: a rigid rail (Winkler foundation 1e15 N/m²: point
    stiffness 2e13 N/m, 5000x the Hertz spring) and the wheel as a free mass on the Hertz
    spring k_w. A dip r = r0 sin(2π x/λ) passed at v drives m z'' + k_w (z - r) = 0 at
    ω = 2π v/λ; the steady contact force k_w (z - r) has the amplitude

        F = k_w r0 m ω² / |k_w - m ω²|.

    The run starts from rest, so the free wheel mode (137 Hz) rings on top, undamped; the
    forced part is measured with a Hann window over a whole number of forcing periods, which
    leaves the 137 Hz part out to < 1e-5. Tolerance 1e-3, from the error budget: Newmark's
    frequency error (ωΔt)²/12 = 5e-5 amplifies to ~1.2e-4 in F, the rail compliance
    k_w/k_rail ~ 2e-4, linear interpolation of the profile sampled at λ/100 ~ 2e-4."""
    veh = wheel_on_spring(kind)
    v, lam, r0 = 20.0, 0.5, 1e-4
    omega = 2 * np.pi * v / lam                       # 40 Hz
    kw = veh.contact_stiffness
    closed = kw * r0 * M_W * omega ** 2 / abs(kw - M_W * omega ** 2)
    beam = WinklerBeam.build(20.0, 0.1, EI, M_RAIL, 1e15)
    xs = np.arange(0.0, 20.0 + 1e-9, lam / 100)
    rs = r0 * np.sin(2 * np.pi * xs / lam)
    def r_of(p):
        return float(np.interp(p, xs, rs))

    dt, periods = 1e-4, 20
    steps = int(round(periods * 2 * np.pi / omega / dt))          # 5000 steps, 10 m
    h = integrate(beam, dt, v, 6.0, steps, vehicle=veh, irregularity=r_of)
    t = h.time[:-1]
    w = np.hanning(len(t) + 1)[:-1]                               # periodic Hann window
    for i in range(veh.n_wheels):
        f = h.wheel_force[:-1, i] - h.wheel_force[0, i]
        forced = 2 * abs(np.sum(w * f * np.exp(-1j * omega * t))) / np.sum(w)
        assert forced == pytest.approx(closed, rel=1e-3)
        # the forcing frequency is the force's dominant one below the free wheel mode (137 Hz)
        freqs = np.fft.rfftfreq(len(t), dt)
        spec = np.abs(np.fft.rfft(w * f))
        low = freqs < 100.0
        assert freqs[low][np.argmax(spec[low])] == pytest.approx(v / lam)
    assert closed > 0.05 * kw * r0                    # a real dynamic force, not a tiny one


def erri(omega, a_v):   # ORE/ERRI B176 vertical profile, written out independently of the module
    return a_v * 0.8246 ** 2 / ((omega ** 2 + 0.0206 ** 2) * (omega ** 2 + 0.8246 ** 2))


def harmonics(profile, length):
    """Fourier coefficients (a_m, b_m) of a profile sampled over one period [0, length]."""
    r = profile[:-1, 1]
    n = len(r)
    X = np.fft.rfft(r)
    return 2 * X.real / n, -2 * X.imag / n


def test_spectrum_profile_is_deterministic_for_a_seed_and_differs_between_seeds():
    a = generate("erri-low", 7, [1.0, 50.0], 134.0)
    b = generate("erri-low", 7, [1.0, 50.0], 134.0)
    c = generate("erri-low", 8, [1.0, 50.0], 134.0)
    assert np.array_equal(a, b)
    assert a[0, 0] == 0.0 and a[-1, 0] == pytest.approx(134.0)
    assert abs(np.corrcoef(a[:, 1], c[:, 1])[0, 1]) < 0.5
    assert np.std(a[:, 1]) > 1e-4                     # millimetres, as a real track


@pytest.mark.parametrize("name,a_v", [("erri-low", 4.032e-7), ("erri-high", 1.080e-6)])
def test_spectrum_profile_has_the_spectrum_psd_in_its_band_and_nothing_outside(name, a_v):
    """The periodogram of the generated profile at its harmonics Ω_m = 2π m/L: in the band
    each (a_m² + b_m²)/(2ΔΩ) estimates S(Ω_m) with an exponential(1) scatter, so the mean of
    their ratio to the formula over n harmonics x seeds is 1 ± 1/sqrt(n); allowed: 4/sqrt(n) in
    each third of the band (log-spaced). Outside the band the coefficients vanish."""
    length, band = 134.0, (0.5, 40.0)
    d_omega = 2 * np.pi / length
    m = np.arange(1, 600)
    omega = m * d_omega
    wl = length / m
    inside = (wl >= band[0]) & (wl <= band[1])
    assert np.allclose(psd(name, omega), erri(omega, a_v), rtol=1e-12)
    ratios = []
    for seed in range(30):
        p = generate(name, seed, band, length)
        a, b = harmonics(p, length)
        a, b = a[1:600], b[1:600]
        est = (a ** 2 + b ** 2) / (2 * d_omega)
        assert np.max(np.abs(est[~inside])) < 1e-20 * np.max(est[inside]) + 1e-30
        ratios.append(est[inside] / erri(omega[inside], a_v))
        # no zero-frequency content either
        assert abs(np.mean(p[:-1, 1])) < 1e-12 * np.std(p[:, 1])
    ratios = np.array(ratios)                         # seeds x harmonics in the band
    edges = np.geomspace(band[0], band[1], 4)
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (wl[inside] >= lo) & (wl[inside] <= hi)
        r = ratios[:, sel]
        assert r.mean() == pytest.approx(1.0, abs=4 / np.sqrt(r.size)), (lo, hi)
    # and the variance of the profile is the integral of S over the band: a sum of exponential
    # terms S_m ΔΩ E_m, whose scatter sqrt(Σ (S_m ΔΩ)²) the few longest waves dominate
    var = np.mean([np.var(generate(name, s, band, length)[:-1, 1]) for s in range(30)])
    terms = erri(omega[inside], a_v) * d_omega
    assert var == pytest.approx(terms.sum(), abs=4 * np.sqrt(np.sum(terms ** 2) / 30))


def test_fra_spectra_follow_their_formula_and_order():
    """FRA classes: S = k A_v Ω_c²/(Ω²(Ω² + Ω_c²)) with k = 0.25, Ω_c = 0.8245 rad/m, in cm²
    per rad/m; a better class is smoother at every wavelength."""
    omega = np.geomspace(0.02, 6.0, 50)
    for name, a_v in (("fra-4", 0.5376), ("fra-5", 0.2095), ("fra-6", 0.0339)):
        s = 1e-4 * 0.25 * a_v * 0.8245 ** 2 / (omega ** 2 * (omega ** 2 + 0.8245 ** 2))
        assert np.allclose(psd(name, omega), s, rtol=1e-12)
    assert np.all(psd("fra-4", omega) > psd("fra-5", omega))
    assert np.all(psd("fra-5", omega) > psd("fra-6", omega))


def test_spectrum_generation_is_cheap():
    import time

    generate("erri-high", 0, [1.0, 50.0], 134.0)      # warm up the FFT
    t0 = time.perf_counter()
    generate("fra-5", 12345, [0.2, 100.0], 134.0)
    assert time.perf_counter() - t0 < 0.05
