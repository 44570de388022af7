"""Test functions with known optima, for the optimiser's tests and
benchmarks/optimiser/optimiser.py.

The scripts (run from the repository root as ``python -m benchmarks...``) and the tests import
it alike, as ``benchmarks.support.problems``.

``paper_size(name)``: a classic function on the box of the paper's case (Table 4: three
continuous railpad stiffnesses in [50, 1200], x_n in 0..20, three spans in 3..7,
x_l in 0..120; 8 variables, 5 integer). The box is mapped affinely onto the function's
usual domain, shifted so that the optimum sits at a fixed, off-centre, integer-feasible
point (an optimum in the middle of the box would flatter any method that samples there).

``gear`` and ``nvs09``: all-integer problems from MINLPLib as used by RBFOpt.

``BENCHMARK``: the broader set of benchmarks/optimiser/optimiser.py (issue 9): mixed-integer and
pure-integer, 4-12 variables, integer ranges of 3 to 100 values (121 on the paper's box),
in the categories of ``CATEGORIES``. Each problem documents its formula, source, optimum
value and optimal point; tests/test_benchmark_problems.py checks that the stated optimum is
attained at the stated point, that the point is a valid point of the space, and (where
that can be done exhaustively or per coordinate) that nothing in the space is better.

Mapped problems (``_mapped``): ``f(x) = g(z)`` with ``z = z* + (x - x*) * step`` per
variable, so that the classic function's minimiser ``z*`` sits at the integer-feasible,
off-centre point ``x*``; f* = g(z*). For integer variables ``step`` is the distance in z
between neighbouring integers, so the integer grid is a sub-lattice of the usual domain.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from lccopt.optim.space import DesignSpace


@dataclass
class TestFunction:
    """A function of a design space with its known minimum ``f_opt`` at ``x_opt``."""

    __test__ = False  # not a pytest test class
    name: str
    space: DesignSpace
    fun: Callable[[np.ndarray], np.ndarray]  # (n, d) -> (n,)
    f_opt: float
    x_opt: np.ndarray
    category: str = ""   # one of CATEGORIES (benchmark problems)
    source: str = ""     # formula and where it comes from

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


def paper_size(name: str, given: list | None = None) -> TestFunction:
    """``name`` (one of PAPER_SIZE) on the paper's 8-variable, 5-integer box."""
    g, width, zstar = _CLASSIC[name]
    space = DesignSpace(names=_PAPER_NAMES, lower=_PAPER_LB, upper=_PAPER_UB,
                        integer=_PAPER_INT, given=given or [])
    u_opt = (_PAPER_XOPT - _PAPER_LB) / (_PAPER_UB - _PAPER_LB)

    def fun(X):
        u = (np.atleast_2d(X) - _PAPER_LB) / (_PAPER_UB - _PAPER_LB)
        return g(zstar + (u - u_opt) * width)

    f_opt = float(g(np.full((1, 8), zstar))[0])
    cat = {"rosenbrock": "unimodal-illcond", "zakharov": "unimodal-illcond"}.get(name, "multimodal")
    return TestFunction(f"{name}8", space, fun, f_opt, _PAPER_XOPT.copy(), cat,
                   f"{name} on the paper's box (3 continuous, 5 integer of 21/5/5/5/121 values)")


def gear() -> TestFunction:
    """Gear train design: 4 integers in 12..60; f = (1/6.931 - x1 x2 / (x3 x4))^2."""
    space = DesignSpace(names=["x1", "x2", "x3", "x4"], lower=[12] * 4, upper=[60] * 4,
                        integer=[True] * 4)

    def fun(X):
        X = np.atleast_2d(X)
        return (1.0 / 6.931 - X[:, 0] * X[:, 1] / (X[:, 2] * X[:, 3])) ** 2

    x_opt = np.array([19.0, 16.0, 43.0, 49.0])
    return TestFunction("gear", space, fun, float(fun(x_opt)[0]), x_opt, "classic-minlp",
                   "gear train (Sandgren 1990; RBFOpt test set): 4 integers of 49 values")


def nvs09() -> TestFunction:
    """MINLPLib nvs09: 10 integers in 3..9; optimum -43.1343 at all 9."""
    space = DesignSpace(names=[f"x{i}" for i in range(10)], lower=[3] * 10, upper=[9] * 10,
                        integer=[True] * 10)

    def fun(X):
        X = np.atleast_2d(X)
        return (np.log(X - 2) ** 2 + np.log(10 - X) ** 2).sum(1) - np.prod(X, axis=1) ** 0.2

    x_opt = np.full(10, 9.0)
    return TestFunction("nvs09", space, fun, float(fun(x_opt)[0]), x_opt, "classic-minlp",
                   "MINLPLib nvs09 (RBFOpt test set): 10 integers of 7 values")


# -- the broader benchmark set (issue 9) ---------------------------------------------------------
CATEGORIES = ("unimodal-illcond", "multimodal", "deceptive", "classic-minlp")


def _rotation(d: int, seed: int) -> np.ndarray:
    """A fixed random orthogonal matrix (QR of a seeded Gaussian matrix, signs fixed)."""
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((d, d)))
    return q * np.sign(np.diag(r))


def ellipsoid(z, cond: float = 1e6):
    """sum_i cond^(i/(d-1)) z_i^2: separable, condition number ``cond``; 0 at z = 0."""
    d = z.shape[1]
    return (cond ** (np.arange(d) / max(d - 1, 1)) * z ** 2).sum(1)


def bent_cigar(z):
    """z_1^2 + 1e6 sum_{i>1} z_i^2 (CEC/BBOB bent cigar); 0 at z = 0."""
    return z[:, 0] ** 2 + 1e6 * (z[:, 1:] ** 2).sum(1)


def griewank(z):
    i = np.arange(1, z.shape[1] + 1)
    return 1.0 + (z ** 2).sum(1) / 4000.0 - np.prod(np.cos(z / np.sqrt(i)), axis=1)


def schwefel(z):
    """Schwefel 2.26: 418.9829 d - sum z sin(sqrt|z|); minimiser 420.968746 per coordinate."""
    return 418.9829 * z.shape[1] - (z * np.sin(np.sqrt(np.abs(z)))).sum(1)


_SCHWEFEL_ARGMIN = 420.968746


def lunacek(z):
    """Lunacek bi-Rastrigin (double funnel; the wider funnel at mu1 holds the worse optimum)."""
    d = z.shape[1]
    mu0 = 2.5
    s = 1.0 - 1.0 / (2.0 * np.sqrt(d + 20.0) - 8.2)
    mu1 = -np.sqrt((mu0 ** 2 - 1.0) / s)
    funnels = np.minimum(((z - mu0) ** 2).sum(1), d + s * ((z - mu1) ** 2).sum(1))
    return funnels + 10.0 * (1.0 - np.cos(2 * np.pi * (z - mu0))).sum(1)


def _names(d):
    return [f"x{i}" for i in range(d)]


def _mapped(name, g, lower, upper, integer, x_opt, z_opt, step, category, source) -> TestFunction:
    """f(x) = g(z* + (x - x*) * step); see the module docstring."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    x_opt = np.asarray(x_opt, float)
    z_opt = np.broadcast_to(np.asarray(z_opt, float), x_opt.shape).copy()
    step = np.broadcast_to(np.asarray(step, float), x_opt.shape).copy()
    space = DesignSpace(names=_names(len(x_opt)), lower=lower, upper=upper, integer=list(integer))

    def fun(X):
        return g(z_opt + (np.atleast_2d(X) - x_opt) * step)

    return TestFunction(name, space, fun, float(g(z_opt[None, :])[0]), x_opt, category, source)


def _alternate(d, cont_lb, cont_ub, int_lb, int_ub):
    """Bounds for d variables alternating continuous (even index) and integer (odd index)."""
    integer = [i % 2 == 1 for i in range(d)]
    lb = [int_lb if m else cont_lb for m in integer]
    ub = [int_ub if m else cont_ub for m in integer]
    return lb, ub, integer


def ellipsoid_mi10() -> TestFunction:
    """Ellipsoid, condition 1e6, 10 variables: 5 continuous in [-5, 5] (step 1) and 5 integers
    in -10..10 (21 values, step 0.5), alternating so that both kinds get stiff directions."""
    lb, ub, integer = _alternate(10, -5.0, 5.0, -10, 10)
    x_opt = [1.3, 3, -2.7, -6, 0.4, 7, 3.1, -2, -1.9, 4]
    step = [0.5 if m else 1.0 for m in integer]
    return _mapped("ellipsoid_mi10", ellipsoid, lb, ub, integer, x_opt, 0.0, step,
                   "unimodal-illcond",
                   "ellipsoid sum 1e6^(i/9) z_i^2 (Hansen et al., BBOB f2); f* = 0")


def rotellipsoid_int6() -> TestFunction:
    """Rotated ellipsoid (condition 1e4) on 6 integers in 0..99 (100 values, step 0.1)."""
    R = _rotation(6, 906)

    def g(z):
        return ellipsoid(z @ R.T, 1e4)

    return _mapped("rotellipsoid_int6", g, [0] * 6, [99] * 6, [True] * 6,
                   [71, 23, 58, 12, 86, 40], 0.0, 0.1, "unimodal-illcond",
                   "rotated ellipsoid sum 1e4^(i/5) (Rz)_i^2, R fixed orthogonal (BBOB f10); "
                   "f* = 0")


def cigar_mi8() -> TestFunction:
    """Rotated bent cigar, 8 variables: 4 continuous in [0, 1] (step 10) and 4 integers in
    0..30 (31 values, step 1/3)."""
    R = _rotation(8, 908)
    lb, ub, integer = _alternate(8, 0.0, 1.0, 0, 30)
    step = [1.0 / 3.0 if m else 10.0 for m in integer]

    def g(z):
        return bent_cigar(z @ R.T)

    return _mapped("cigar_mi8", g, lb, ub, integer, [0.31, 21, 0.74, 9, 0.52, 26, 0.18, 14],
                   0.0, step, "unimodal-illcond",
                   "rotated bent cigar (Rz)_1^2 + 1e6 sum_{i>1} (Rz)_i^2 (BBOB f12); f* = 0")


def quad_int12() -> TestFunction:
    """Rotated ellipsoid (condition 1e3) on 12 integers in -1..1 (3 values, step 1)."""
    R = _rotation(12, 912)

    def g(z):
        return ellipsoid(z @ R.T, 1e3)

    return _mapped("quad_int12", g, [-1] * 12, [1] * 12, [True] * 12,
                   [1, -1, 0, 1, 1, -1, 0, -1, 1, 0, -1, 1], 0.0, 1.0, "unimodal-illcond",
                   "convex integer quadratic: rotated ellipsoid, condition 1e3, 3^12 points; "
                   "f* = 0")


def rastrigin_int8() -> TestFunction:
    """Rastrigin on 8 integers in 0..40 (41 values, step 0.25: a local minimum every 4 steps)."""
    return _mapped("rastrigin_int8", rastrigin, [0] * 8, [40] * 8, [True] * 8,
                   [29, 11, 33, 7, 24, 16, 37, 3], 0.0, 0.25, "multimodal",
                   "Rastrigin 10 d + sum z^2 - 10 cos(2 pi z); f* = 0")


def griewank_mi10() -> TestFunction:
    """Griewank, 10 variables: 5 continuous in [-1, 1] (step 300), 5 integers in 0..50
    (51 values, step 12)."""
    lb, ub, integer = _alternate(10, -1.0, 1.0, 0, 50)
    step = [12.0 if m else 300.0 for m in integer]
    x_opt = [0.42, 37, -0.67, 8, 0.15, 44, 0.81, 19, -0.29, 30]
    return _mapped("griewank_mi10", griewank, lb, ub, integer, x_opt, 0.0, step, "multimodal",
                   "Griewank 1 + sum z^2/4000 - prod cos(z_i/sqrt(i)); f* = 0")


def levy_int6() -> TestFunction:
    """Levy on 6 integers in 0..30 (31 values, step 0.5)."""
    return _mapped("levy_int6", levy, [0] * 6, [30] * 6, [True] * 6,
                   [22, 7, 19, 27, 4, 13], 1.0, 0.5, "multimodal",
                   "Levy (Surjanovic & Bingham, Virtual Library); f* = 0 at z = 1")


def ackley_int12() -> TestFunction:
    """Ackley on 12 integers in 0..20 (21 values, step 1.5)."""
    return _mapped("ackley_int12", ackley, [0] * 12, [20] * 12, [True] * 12,
                   [14, 5, 17, 9, 2, 12, 19, 7, 15, 3, 10, 16], 0.0, 1.5, "multimodal",
                   "Ackley (a=20, b=0.2, c=2 pi); f* = 0 (4.4e-16 in floating point)")


def schwefel_mi6() -> TestFunction:
    """Schwefel 2.26, 6 variables: 3 continuous in [-500, 500] (z = x) and 3 integers in 0..50
    (51 values, step 20, z in [-499.03, 500.97]). Deceptive: the second-best minimum is far
    from the best."""
    lb, ub, integer = _alternate(6, -500.0, 500.0, 0, 50)
    x_opt = [_SCHWEFEL_ARGMIN if not m else 46 for m in integer]
    step = [20.0 if m else 1.0 for m in integer]
    return _mapped("schwefel_mi6", schwefel, lb, ub, integer, x_opt, _SCHWEFEL_ARGMIN, step,
                   "deceptive", "Schwefel 2.26: 418.9829 d - sum z sin sqrt|z|; f* = 7.6e-5 "
                   "at z = 420.968746")


def lunacek_mi8() -> TestFunction:
    """Lunacek bi-Rastrigin, 8 variables: 4 continuous in [-5, 5] (z = x), 4 integers in
    0..20 (21 values, step 0.5, z in [-5, 5])."""
    lb, ub, integer = _alternate(8, -5.0, 5.0, 0, 20)
    x_opt = [15 if m else 2.5 for m in integer]
    step = [0.5 if m else 1.0 for m in integer]
    return _mapped("lunacek_mi8", lunacek, lb, ub, integer, x_opt, 2.5, step, "deceptive",
                   "Lunacek bi-Rastrigin (Lunacek et al. 2008; BBOB f24 unrotated); f* = 0 "
                   "at z = mu0 = 2.5")


def trap_int6() -> TestFunction:
    """Deceptive trap on 6 integers in 0..9 (10 values): per variable t(9) = 0, otherwise
    t(x) = 0.2 + 0.8 x / 9, so every slope leads to the local optimum at 0 (f = 1.2)."""
    space = DesignSpace(names=_names(6), lower=[0] * 6, upper=[9] * 6, integer=[True] * 6)

    def fun(X):
        X = np.atleast_2d(X)
        return np.where(X >= 9, 0.0, 0.2 + 0.8 * X / 9.0).sum(1)

    return TestFunction("trap_int6", space, fun, 0.0, np.full(6, 9.0), "deceptive",
                   "integer deceptive trap (after Deb & Goldberg 1993); f* = 0 at x = 9")


_GEAR_TARGET = 144279.32477276


def gear4() -> TestFunction:
    """MINLPLib gear4 as in RBFOpt's test set: 4 integers in 12..60, x5 in [0, 100]:
    f = -1e6 x1 x2 / (x3 x4) + 2 x5 + 144279.32477276, plus 10 * violation of the
    constraint -1e6 x1 x2 / (x3 x4) + x5 + 144279.32477276 >= 0. f* = 1.6434284739."""
    space = DesignSpace(names=_names(5), lower=[12] * 4 + [0], upper=[60] * 4 + [100],
                        integer=[True] * 4 + [False])

    def fun(X):
        X = np.atleast_2d(X)
        r = 1e6 * X[:, 0] * X[:, 1] / (X[:, 2] * X[:, 3])
        return -r + 2 * X[:, 4] + _GEAR_TARGET + 10.0 * np.maximum(0.0, r - X[:, 4] - _GEAR_TARGET)

    x_opt = np.array([19.0, 16.0, 43.0, 49.0, 1e6 * 19 * 16 / (43 * 49) - _GEAR_TARGET])
    return TestFunction("gear4", space, fun, float(fun(x_opt)[0]), x_opt, "classic-minlp",
                   "MINLPLib gear4 (RBFOpt test set), constraint as a penalty")


def _schoen(name: str, n_int: int, n_cont: int, seed: int) -> TestFunction:
    """Schoen's function (Schoen 1993; mixed-integer versions in RBFOpt's test set): 50 points
    z_j in the unit box with values f_j; f(u) = sum_j f_j w_j / sum_j w_j with
    w_j = prod_{k != j} |u - z_k|^2 (i.e. weights 1/|u - z_j|^2), u = x / 10, so f(z_j) = f_j
    and f >= min f_j everywhere. Here f_j ~ U(0, 1000) for 49 points (seeded) and -1000 at
    one point whose integer coordinates are on the grid: f* = -1000. Integers 0..10 (11
    values) then continuous [0, 10]."""
    d = n_int + n_cont
    rng = np.random.default_rng(seed)
    Z = rng.random((50, d))
    f = rng.uniform(0.0, 1000.0, 50)
    x_opt = np.concatenate([rng.integers(1, 10, n_int).astype(float),
                            np.round(rng.uniform(0.5, 9.5, n_cont), 4)])
    Z[-1] = x_opt / 10.0
    f[-1] = -1000.0
    space = DesignSpace(names=_names(d), lower=[0] * d, upper=[10] * d,
                        integer=[True] * n_int + [False] * n_cont)

    def fun(X):
        U = np.atleast_2d(X) / 10.0
        D = ((U[:, None, :] - Z[None, :, :]) ** 2).sum(2)
        hit = D == 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            W = 1.0 / D
            out = (W * f).sum(1) / W.sum(1)
        rows = hit.any(1)
        out[rows] = f[np.argmax(hit[rows], axis=1)]
        return out

    return TestFunction(name, space, fun, -1000.0, x_opt, "classic-minlp",
                        f"Schoen function, {n_int} integer + {n_cont} continuous, 50 points "
                        f"(seed {seed})")


def schoen6_int() -> TestFunction:
    return _schoen("schoen6_int", 4, 2, 61)


def schoen10_int() -> TestFunction:
    return _schoen("schoen10_int", 6, 4, 101)


_BUILDERS = {
    "gear": gear, "nvs09": nvs09, "gear4": gear4, "schoen6_int": schoen6_int,
    "schoen10_int": schoen10_int, "ellipsoid_mi10": ellipsoid_mi10,
    "rotellipsoid_int6": rotellipsoid_int6, "cigar_mi8": cigar_mi8, "quad_int12": quad_int12,
    "rastrigin_int8": rastrigin_int8, "griewank_mi10": griewank_mi10, "levy_int6": levy_int6,
    "ackley_int12": ackley_int12, "schwefel_mi6": schwefel_mi6, "lunacek_mi8": lunacek_mi8,
    "trap_int6": trap_int6,
}

# The broader benchmark (benchmarks/optimiser/optimiser.py): the paper's box plus the problems
# above.
BENCHMARK = tuple(f"{n}8" for n in PAPER_SIZE) + tuple(_BUILDERS)


def get(name: str, seed: int = 0) -> TestFunction:
    """The problem ``name`` of BENCHMARK or FRESH (a fresh instance: the one of ``seed``)."""
    if name in FRESH:
        return fresh(name, seed)
    if name in _CLASSIC:
        return paper_size(name)
    if name.endswith("8") and name[:-1] in _CLASSIC:
        return paper_size(name[:-1])
    if name in _BUILDERS:
        return _BUILDERS[name]()
    raise KeyError(f"unknown problem {name!r}; known: {', '.join(BENCHMARK + FRESH)}")


# -- fresh instances: judged on what nobody tuned on ------------------------------------------
# Eight-variable families whose instance is drawn from a seed: which variables are integer,
# their ranges, the continuous bounds, where the optimum lies and (where the family is
# separable, so that a rotation changes its character) a rotation about the optimum. The
# optimum value stays the family's own, g(z*). Every instance is new: nothing in lccopt was
# tuned on them (benchmarks/optimiser/optimiser.py --problems fresh-... --seeds 100-111).
_FRESH_MIXED = ("ackley", "rastrigin", "levy", "rosenbrock", "styblinski_tang", "zakharov")
_FRESH_INTEGER = ("ellipsoid_int", "rastrigin_int")
# Mixed families whose integers all have 5 values: the integer lattice is coarse in the
# classic function's domain (Ackley's: 16 units of z apart), so a local basin of the
# continuous part holds each integer assignment, and a run must move the integers as such.
_FRESH_FIVE = ("ackley", "rastrigin", "levy", "styblinski_tang")
FRESH = (tuple(f"fresh-{n}" for n in _FRESH_MIXED + _FRESH_INTEGER)
         + tuple(f"fresh5-{n}" for n in _FRESH_FIVE))
_FRESH_ROTATED = {"ackley", "rastrigin", "levy", "styblinski_tang", "ellipsoid_int"}
_FRESH_VALUES = (5, 11, 21, 51, 121)  # integer ranges to draw from (the paper's box: 5 to 121)
_FRESH_DIM, _FRESH_N_INT = 8, 5


def _ellipsoid_1e4(z):
    return ellipsoid(z, 1e4)


def fresh(family: str, seed: int) -> TestFunction:
    """The instance of ``family`` (a name of FRESH; "fresh-" may be left off) for ``seed``.

    Mixed families: 8 variables, 5 of them integer (chosen at random) with 5 to 121 values each
    ("fresh5-": 5 values each), continuous bounds [0, 10^U(-1, 3)]; the box maps onto the
    classic function's usual domain (as ``paper_size``), its optimum moved to a random
    integer-feasible point x* away from the bounds. Integer families: 8 integers of 11 to 51
    values; "ellipsoid_int" a rotated ellipsoid (condition 1e4), "rastrigin_int" Rastrigin with
    a local minimum every 4 steps. ``f(x) = g(z* + R ((x - x*) * step))``, R a random rotation
    for the families of _FRESH_ROTATED (identity otherwise): g >= g(z*) everywhere, so f* =
    g(z*) at x*.
    """
    five = family.startswith("fresh5-")
    name = family.removeprefix("fresh5-" if five else "fresh-")
    if name not in (_FRESH_FIVE if five else _FRESH_MIXED + _FRESH_INTEGER):
        raise KeyError(f"unknown family {family!r}; known: {', '.join(FRESH)}")
    prefix = "fresh5-" if five else "fresh-"
    rng = np.random.default_rng([int(seed), FRESH.index(f"{prefix}{name}"), 43])
    d = _FRESH_DIM
    if name in _FRESH_MIXED:
        g, width, zstar = _CLASSIC[name]
        integer = np.zeros(d, dtype=bool)
        integer[rng.choice(d, _FRESH_N_INT, replace=False)] = True
        values = np.full(d, 5) if five else rng.choice(_FRESH_VALUES, d)
    else:
        g, width, zstar = ({"ellipsoid_int": (_ellipsoid_1e4, 10.0, 0.0),
                            "rastrigin_int": (rastrigin, 10.24, 0.0)})[name]
        integer = np.ones(d, dtype=bool)
        values = rng.choice((11, 21, 41, 51), d)
    upper = np.where(integer, values - 1.0, 10.0 ** rng.uniform(-1.0, 3.0, d))
    lower = np.zeros(d)
    # the optimum: integers on the grid, everything within the middle 80 % of its range
    u = rng.uniform(0.1, 0.9, d)
    x_opt = np.where(integer, np.rint(u * upper), u * upper)
    step = width / upper
    if name == "rastrigin_int":
        step = np.full(d, 0.25)  # a local minimum every 4 integers
    R = _rotation(d, int(rng.integers(2 ** 31))) if name in _FRESH_ROTATED else np.eye(d)
    z_opt = np.full(d, zstar)
    space = DesignSpace(names=_names(d), lower=lower, upper=upper, integer=list(integer))

    def fun(X):
        return g(z_opt + ((np.atleast_2d(X) - x_opt) * step) @ R.T)

    category = "unimodal-illcond" if name in ("rosenbrock", "zakharov", "ellipsoid_int") \
        else "multimodal"
    ranges = "/".join(str(int(v)) for v in values[integer])
    kind = f"{int(integer.sum())} integer of {ranges} values"
    return TestFunction(f"{prefix}{name}", space, fun, float(g(z_opt[None, :])[0]), x_opt, category,
                        f"{name}, instance of seed {seed}: 8 variables, {kind}"
                        + (", rotated" if name in _FRESH_ROTATED else ""))
