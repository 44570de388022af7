"""Vertical rail irregularity: random profiles from standard spectra.

A profile r(x) is a dip (downward positive) against the position along the track (the
simulation takes it as an (N, 2) array, :class:`lccopt.vti.specs.Scenario`), the same for
every design and both directions: a random one is generated over the fixed track coordinates
[0, track length] (never over a design's mesh) from the seed alone, so that designs are
compared on the same track.

Spectra: one-sided PSD S(Ω) of the vertical profile in m²/(rad/m), Ω = 2π/λ the spatial
angular frequency [rad/m], so that the variance of the profile over a band is ∫ S(Ω) dΩ.

* ``erri-low``, ``erri-high``: ORE/ERRI B176 (ERRI B176/DT 290, 1993; also in Eurocode-based
  and German high-speed practice), the spectrum used for European track:
      S(Ω) = A_v Ω_c² / ((Ω² + Ω_r²)(Ω² + Ω_c²)),
  Ω_c = 0.8246 rad/m, Ω_r = 0.0206 rad/m, A_v = 4.032e-7 m·rad (low level, good track) or
  1.080e-6 m·rad (high level, poor track).
* ``fra-4``, ``fra-5``, ``fra-6``: US FRA track classes 4-6 (Hamid & Yang 1981, as tabulated in
  Garg & Dukkipati, Dynamics of Railway Vehicle Systems, 1984):
      S(Ω) = k A_v Ω_c² / (Ω² (Ω² + Ω_c²))   [cm²/(rad/m)],
  k = 0.25, Ω_c = 0.8245 rad/m, A_v = 0.5376 (class 4), 0.2095 (class 5), 0.0339 (class 6)
  cm²·rad/m; converted to m² here (x 1e-4). The constants were not re-checked against the
  primary FRA report in this work; the published formula is valid for wavelengths of roughly
  1.5-300 m.

Conventions differ between authors (one- or two-sided, per Ω or per cycle/m); the one used
here is stated above, and ``amplitude_scale`` scales the profile (the PSD by its square).

Generation (the spectral representation, e.g. Shinozuka): with the track length L as the
period, Ω_m = 2π m / L for the m whose wavelength L/m lies in [λ_min, λ_max],

    r(x) = Σ_m a_m cos(Ω_m x) + b_m sin(Ω_m x),   a_m, b_m ~ N(0, S(Ω_m) ΔΩ), ΔΩ = 2π / L,

drawn from ``numpy.random.default_rng(seed)`` and summed by an inverse FFT on a grid of
λ_min / 20: a Gaussian process with the spectrum's PSD in the band and nothing outside it.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

SPECTRA = ("erri-low", "erri-high", "fra-4", "fra-5", "fra-6")
_ERRI = {"erri-low": 4.032e-7, "erri-high": 1.080e-6}
_FRA = {"fra-4": 0.5376, "fra-5": 0.2095, "fra-6": 0.0339}
POINTS_PER_SHORTEST_WAVE = 20       # profile grid: linear interpolation error <= 1.2 % of r
ELEMENTS_PER_SHORTEST_WAVE = 4      # the rail mesh under the wheel must follow the shortest wave
STEPS_PER_SHORTEST_WAVE = 5         # as many time steps per period as for the contact mode


def psd(spectrum: str, omega) -> np.ndarray:
    """One-sided PSD [m²/(rad/m)] of ``spectrum`` at spatial angular frequencies omega [rad/m]."""
    w2 = np.asarray(omega, dtype=float) ** 2
    if spectrum in _ERRI:
        wc, wr = 0.8246, 0.0206
        return _ERRI[spectrum] * wc ** 2 / ((w2 + wr ** 2) * (w2 + wc ** 2))
    if spectrum in _FRA:
        wc = 0.8245
        return 1e-4 * 0.25 * _FRA[spectrum] * wc ** 2 / (w2 * (w2 + wc ** 2))
    raise ValueError(f"unknown spectrum {spectrum!r} (expected one of {', '.join(SPECTRA)})")


def band_bins(length: float, wavelengths) -> np.ndarray:
    """Harmonics m (wavelength length/m) of a profile of period ``length`` inside the band."""
    lo, hi = float(wavelengths[0]), float(wavelengths[1])
    m_lo = int(np.ceil(length / hi - 1e-9))
    m_hi = int(np.floor(length / lo + 1e-9))
    return np.arange(max(m_lo, 1), m_hi + 1)


def generate(spectrum: str, seed: int, wavelengths, length: float,
             amplitude_scale: float = 1.0) -> np.ndarray:
    """Profile (positions, dips) of shape (N, 2) over [0, length], deterministic from the seed."""
    return _generate(spectrum, int(seed), float(wavelengths[0]), float(wavelengths[1]),
                     float(length), float(amplitude_scale)).copy()


@lru_cache(maxsize=16)
def _generate(spectrum, seed, lo, hi, length, scale) -> np.ndarray:
    m = band_bins(length, (lo, hi))
    d_omega = 2 * np.pi / length
    sigma = np.sqrt(psd(spectrum, m * d_omega) * d_omega) * scale
    rng = np.random.default_rng(seed)
    a, b = rng.standard_normal((2, len(m))) * sigma
    n = 2 * max(int(np.ceil(length / lo * POINTS_PER_SHORTEST_WAVE / 2)), int(m[-1]) + 1)
    coefficients = np.zeros(n // 2 + 1, dtype=complex)
    coefficients[m] = 0.5 * n * (a - 1j * b)
    r = np.fft.irfft(coefficients, n)
    x = np.arange(n + 1) * (length / n)
    out = np.column_stack([x, np.append(r, r[0])])
    out.setflags(write=False)
    return out
