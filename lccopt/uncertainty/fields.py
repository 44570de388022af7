"""Random fields over the sleepers of a track.

A quantity that varies from sleeper to sleeper (support stiffness, pad stiffness, ...) is a
standard Gaussian field Z(x) along the track, sampled at the sleepers and turned into the
quantity by its marginal distribution:

* correlation: rho(r) = exp(-(pi/4) (r / l)^2), the Gaussian covariance model of ROSE's random
  fields (Deltares / TU Delft, ``rose/utils/random_field.py``, through gstools' ``Gaussian``,
  whose length scale l is the integral scale: the integral of rho over r >= 0 is l). l = 0:
  independent sleepers (Wu & Thompson, Acustica 86 (2000) 313-321, draw each support's
  stiffness on its own).
* lognormal factor: mean * exp(s Z - s^2 / 2), s^2 = ln(1 + cov^2): mean ``mean`` and
  coefficient of variation ``cov`` exactly (ROSE's ``log_normal`` transform);
* uniform factor: mean * (1 + sqrt(3) cov (2 Phi(Z) - 1)): the same mean and cov, bounded
  (a tolerance band), positive for cov < 1 / sqrt(3);
* hanging sleepers: where Z exceeds the (1 - p) quantile, so a fraction p of the sleepers
  hang and, with a correlation length, in groups (unevenly supported sleepers "often occur in
  a row": Lazarevic, Popovic & Micic, RAILCON 2016).

Z is built by smoothing white noise on a fine grid with a Gaussian kernel of width
a = l / sqrt(pi) (the convolution of two such kernels is rho) and dividing by the kernel's
norm at each point, so that every sample has variance exactly 1. It uses sums only (no
factorisation of an ill-conditioned covariance matrix, no eigenvectors whose signs a LAPACK
build may flip): the same seed gives the same field on any machine.

A coefficient of variation of 0 gives factors of exactly 1.0 (s = 0: exp(0) = 1), so the
track is bit for bit the drawing.
"""

from __future__ import annotations

import math

import numpy as np

DISTRIBUTIONS = ("lognormal", "uniform")
# kernel reach, in kernel widths: exp(-6^2 / 2) = 1.5e-8 of the centre weight is dropped
_REACH = 6.0
# grid points per kernel width: the discrete sums match the continuous covariance to ~1e-12
_PER_WIDTH = 4.0
# independent sleepers below this fraction of their closest spacing: rho = exp(-(pi/4) 8^2)
# = 1e-22 between neighbours there
_INDEPENDENT_BELOW = 1.0 / 8.0


def generator(seed: int, stream: int, realisation: int) -> np.random.Generator:
    """The random numbers of one quantity (``stream``) in one realisation: a stream of its
    own for each, so that adding realisations or quantities leaves the others as they were."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(
        [int(seed), int(stream), int(realisation)])))


def gaussian_field(positions, correlation_length: float, rng: np.random.Generator) -> np.ndarray:
    """A standard Gaussian field (mean 0, variance 1) at ``positions`` [m].

    Parameters
    ----------
    positions
        where the field is sampled (any order, distinct).
    correlation_length
        l [m] of rho(r) = exp(-(pi/4) (r/l)^2); 0 for independent samples.
    rng
        the random numbers (``generator``).

    Returns
    -------
    numpy.ndarray
        one value per position.
    """
    x = np.asarray(positions, dtype=float)
    if x.size == 0:
        return np.zeros(0)
    ell = float(correlation_length)
    gaps = np.diff(np.sort(x))
    closest = float(gaps.min()) if gaps.size else math.inf
    if ell <= _INDEPENDENT_BELOW * closest:
        return rng.standard_normal(x.size)
    a = ell / math.sqrt(math.pi)            # kernel width: exp(-u^2 / (2 a^2))
    h = a / _PER_WIDTH
    reach = int(math.ceil(_REACH * _PER_WIDTH))
    start = float(x.min()) - (reach + 1) * h
    n_grid = int(math.ceil((float(x.max()) - start) / h)) + reach + 2
    xi = rng.standard_normal(n_grid)
    first = np.floor((x - start) / h).astype(int) - reach          # grid index of each window
    idx = first[:, None] + np.arange(2 * reach + 2)[None, :]
    w = np.exp(-0.5 * ((x[:, None] - (start + idx * h)) / a) ** 2)
    return np.einsum("ij,ij->i", w, xi[idx]) / np.sqrt(np.einsum("ij,ij->i", w, w))


def factors(z, distribution: str, mean: float, cov: float) -> np.ndarray:
    """Positive factors with mean ``mean`` and coefficient of variation ``cov`` from a standard
    Gaussian field ``z`` (module docstring); exactly ``mean`` where cov = 0."""
    z = np.asarray(z, dtype=float)
    if distribution == "lognormal":
        s = math.sqrt(math.log1p(cov * cov))
        return mean * np.exp(s * z - 0.5 * s * s)
    if distribution == "uniform":
        # imported here: every command reads DISTRIBUTIONS through the case's schema, and
        # scipy.special would nearly double a `check`'s start
        from scipy.special import ndtr

        return mean * (1.0 + math.sqrt(3.0) * cov * (2.0 * ndtr(z) - 1.0))
    raise ValueError(f"unknown distribution {distribution!r} (expected one of "
                     f"{', '.join(DISTRIBUTIONS)})")


def hanging(z, probability: float) -> np.ndarray:
    """Which sleepers hang: where ``z`` exceeds its (1 - probability) quantile."""
    z = np.asarray(z, dtype=float)
    if probability <= 0.0:
        return np.zeros(z.shape, dtype=bool)
    if probability >= 1.0:
        return np.ones(z.shape, dtype=bool)
    from scipy.special import ndtri

    return z > ndtri(1.0 - probability)
