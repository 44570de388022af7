"""Test problems with known optima, for the optimiser's tests and benchmark.

``paper_size(name)``: a classic function on the box of the paper's case (Table 4: three
continuous railpad stiffnesses in [50, 1200], x_n in 0..20, three spans in 3..7,
x_l in 0..120; 8 variables, 5 integer). The box is mapped affinely onto the function's
usual domain, shifted so that the optimum sits at a fixed, off-centre, integer-feasible
point (an optimum in the middle of the box would flatter any method that samples there).

``gear`` and ``nvs09``: all-integer problems from MINLPLib as used by RBFOpt.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .space import DesignSpace


@dataclass
class Problem:
    name: str
    space: DesignSpace
    fun: Callable[[np.ndarray], np.ndarray]  # (n, d) -> (n,)
    f_opt: float
    x_opt: np.ndarray

    def __call__(self, x) -> float | np.ndarray:
        x = np.asarray(x, dtype=float)
        return float(self.fun(x[None, :])[0]) if x.ndim == 1 else self.fun(x)


# -- classic functions, vectorised over rows ---------------------------------------------
def ackley(z):
    d = z.shape[1]
    return (-20.0 * np.exp(-0.2 * np.sqrt((z ** 2).sum(1) / d))
            - np.exp(np.cos(2 * np.pi * z).sum(1) / d) + 20.0 + np.e)


def rastrigin(z):
    return 10.0 * z.shape[1] + (z ** 2 - 10.0 * np.cos(2 * np.pi * z)).sum(1)


def levy(z):
    w = 1.0 + (z - 1.0) / 4.0
    a = np.sin(np.pi * w[:, 0]) ** 2
    mid = ((w[:, :-1] - 1) ** 2 * (1 + 10 * np.sin(np.pi * w[:, :-1] + 1) ** 2)).sum(1)
    last = (w[:, -1] - 1) ** 2 * (1 + np.sin(2 * np.pi * w[:, -1]) ** 2)
    return a + mid + last


def rosenbrock(z):
    return (100.0 * (z[:, 1:] - z[:, :-1] ** 2) ** 2 + (1 - z[:, :-1]) ** 2).sum(1)


def styblinski_tang(z):
    return 0.5 * (z ** 4 - 16 * z ** 2 + 5 * z).sum(1)


def zakharov(z):
    i = np.arange(1, z.shape[1] + 1)
    s = (0.5 * i * z).sum(1)
    return (z ** 2).sum(1) + s ** 2 + s ** 4


_ST_ARGMIN = -2.903534027771178  # root of 4z^3 - 32z + 5 = 0 nearest -2.9

# name: (function, domain width, argmin per coordinate, minimum per coordinate count)
_CLASSIC = {
    "ackley": (ackley, 65.536, 0.0),
    "rastrigin": (rastrigin, 10.24, 0.0),
    "levy": (levy, 20.0, 1.0),
    "rosenbrock": (rosenbrock, 15.0, 1.0),
    "styblinski_tang": (styblinski_tang, 10.0, _ST_ARGMIN),
    "zakharov": (zakharov, 15.0, 0.0),
}
PAPER_SIZE = tuple(_CLASSIC)

_PAPER_NAMES = ["x_r1", "x_r2", "x_r3", "x_n", "x_s1", "x_s2", "x_s3", "x_l"]
_PAPER_LB = np.array([50.0, 50.0, 50.0, 0.0, 3.0, 3.0, 3.0, 0.0])
_PAPER_UB = np.array([1200.0, 1200.0, 1200.0, 20.0, 7.0, 7.0, 7.0, 120.0])
_PAPER_INT = [False, False, False, True, True, True, True, True]
# Optimum location: continuous part arbitrary, integer part on the grid, off-centre.
_PAPER_XOPT = np.array([407.5, 878.0, 717.0, 13.0, 4.0, 6.0, 5.0, 37.0])


def paper_size(name: str, given: list | None = None) -> Problem:
    """``name`` (one of PAPER_SIZE) on the paper's 8-variable, 5-integer box."""
    g, width, zstar = _CLASSIC[name]
    space = DesignSpace(names=_PAPER_NAMES, lower=_PAPER_LB, upper=_PAPER_UB,
                        integer=_PAPER_INT, given=given or [])
    u_opt = (_PAPER_XOPT - _PAPER_LB) / (_PAPER_UB - _PAPER_LB)

    def fun(X):
        u = (np.atleast_2d(X) - _PAPER_LB) / (_PAPER_UB - _PAPER_LB)
        return g(zstar + (u - u_opt) * width)

    f_opt = float(g(np.full((1, 8), zstar))[0])
    return Problem(f"{name}8", space, fun, f_opt, _PAPER_XOPT.copy())


def gear() -> Problem:
    """Gear train design: 4 integers in 12..60; f = (1/6.931 - x1 x2 / (x3 x4))^2."""
    space = DesignSpace(names=["x1", "x2", "x3", "x4"], lower=[12] * 4, upper=[60] * 4,
                        integer=[True] * 4)

    def fun(X):
        X = np.atleast_2d(X)
        return (1.0 / 6.931 - X[:, 0] * X[:, 1] / (X[:, 2] * X[:, 3])) ** 2

    x_opt = np.array([19.0, 16.0, 43.0, 49.0])
    return Problem("gear", space, fun, float(fun(x_opt)[0]), x_opt)


def nvs09() -> Problem:
    """MINLPLib nvs09: 10 integers in 3..9; optimum -43.1343 at all 9."""
    space = DesignSpace(names=[f"x{i}" for i in range(10)], lower=[3] * 10, upper=[9] * 10,
                        integer=[True] * 10)

    def fun(X):
        X = np.atleast_2d(X)
        return (np.log(X - 2) ** 2 + np.log(10 - X) ** 2).sum(1) - np.prod(X, axis=1) ** 0.2

    x_opt = np.full(10, 9.0)
    return Problem("nvs09", space, fun, float(fun(x_opt)[0]), x_opt)


def get(name: str) -> Problem:
    if name in _CLASSIC:
        return paper_size(name)
    if name.endswith("8") and name[:-1] in _CLASSIC:
        return paper_size(name[:-1])
    if name == "gear":
        return gear()
    if name == "nvs09":
        return nvs09()
    raise KeyError(f"unknown problem {name!r}")
