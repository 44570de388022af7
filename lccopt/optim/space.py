"""Design space: bounded continuous and integer variables plus given points.

The optimiser works on the unit box internally (so that distances and the RBF
shape do not depend on the units of the variables); this module owns the
mapping both ways and the rounding of integer variables.

A continuous variable with positive bounds may be searched on a log scale (``log``):
its search coordinate is ln x, so equal ratios are equal steps (a stiffness from 50 to
1200 MN/m: 50 -> 100 is as far as 600 -> 1200). The optimiser draws its steps and its
initial design in search coordinates (``to_search``/``from_search``) and measures
distance in the unit box of those; points themselves stay in the variables' own units.
For a linear variable every mapping is the identity, bit for bit.

A variable whose 0 leaves a component out (``switch``: the Type II strip, 0 to 12 m) is an
on/off choice with a value behind it. Searched as one range, "off" is a single value of
121: a Latin hypercube seldom draws it and a step from a long strip seldom reaches it past
the short strips between (benchmarks/RESULTS-optimiser.md, "Why moo's fresh phases end in
the strip basin"). Its search coordinate therefore runs from -upper to upper: the negative
half is "off" (0), the positive half the value itself, so that a design and a step draw
"off" as often as "on". Values stay in the variable's own units; 0 maps to -upper / 2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np


@dataclass
class DesignSpace:
    """Bounded continuous and integer variables, with the points always proposed first.

    Parameters
    ----------
    names : list of str
        Unique variable names.
    lower, upper : list of float
        Finite bounds (integers for an integer variable); lower == upper fixes a variable.
    integer : list of bool
        Which variables take integer values only.
    given : list of list of float, optional
        Valid, distinct points (the reference design) the optimiser proposes first.
    log : list of bool, optional
        Continuous variables with positive bounds searched on a log scale.
    switch : list of bool, optional
        Variables from 0 searched as off (0) or on (a value), each half of the search range.

    Raises
    ------
    ValueError
        With the variable's name: bounds not finite or crossed, integer bounds not integral,
        a log scale on an integer or non-positive variable, a given point outside the space.
    """

    names: list[str]
    lower: list[float]
    upper: list[float]
    integer: list[bool]
    given: list[list[float]] = field(default_factory=list)
    log: list[bool] | None = None      # per variable: searched on a log scale (None: none)
    switch: list[bool] | None = None   # per variable: 0 = off, half the search range

    @classmethod
    def of(cls, dimensions, given=()) -> "DesignSpace":
        """The space of some variables, each an object with ``name``, ``lower``, ``upper``,
        ``integer``, ``log`` and ``switch`` (``lccopt.config.variables.Variable``)."""
        dims = list(dimensions)
        log = [bool(d.log) for d in dims]
        switch = [bool(d.switch) for d in dims]
        return cls(names=[d.name for d in dims], lower=[d.lower for d in dims],
                   upper=[d.upper for d in dims], integer=[d.integer for d in dims],
                   given=[list(g) for g in given], log=log if any(log) else None,
                   switch=switch if any(switch) else None)

    def __post_init__(self) -> None:
        self.names = [str(n) for n in self.names]
        self.lower = [float(v) for v in np.asarray(self.lower, dtype=float).ravel()]
        self.upper = [float(v) for v in np.asarray(self.upper, dtype=float).ravel()]
        self.integer = [bool(v) for v in self.integer]
        d = len(self.names)
        if d == 0:
            raise ValueError("design space needs at least one variable")
        if len(set(self.names)) != d:
            raise ValueError(f"variable names must be unique: {self.names}")
        self.log = [False] * d if self.log is None else [bool(v) for v in self.log]
        self.switch = [False] * d if self.switch is None else [bool(v) for v in self.switch]
        for what, seq in (("lower", self.lower), ("upper", self.upper), ("integer", self.integer),
                          ("log", self.log), ("switch", self.switch)):
            if len(seq) != d:
                raise ValueError(f"{what} has {len(seq)} entries, expected {d} (one per variable)")
        for i, name in enumerate(self.names):
            lo, hi = self.lower[i], self.upper[i]
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise ValueError(f"variable {name!r}: bounds must be finite, got [{lo}, {hi}]")
            if lo > hi:
                raise ValueError(f"variable {name!r}: lower bound {lo} > upper bound {hi}")
            if self.integer[i] and (lo != round(lo) or hi != round(hi)):
                raise ValueError(f"integer variable {name!r}: bounds must be integers, "
                                 f"got [{lo}, {hi}]")
            if self.log[i] and (self.integer[i] or not lo > 0):
                raise ValueError(f"variable {name!r}: a log scale needs a continuous variable with "
                                 f"positive bounds, got [{lo}, {hi}]")
            if self.switch[i] and (self.log[i] or not lo == 0 < hi):
                raise ValueError(f"variable {name!r}: an on/off switch needs a linear range from "
                                 f"0, got [{lo}, {hi}]")
        given = np.asarray(self.given, dtype=float)
        if given.size == 0:
            given = np.empty((0, d))
        if given.ndim == 1:
            given = given[None, :]
        if given.ndim != 2 or given.shape[1] != d:
            raise ValueError(f"given points must each have {d} values, got shape {given.shape}")
        for j, g in enumerate(given):
            self.check(g, what=f"given point {j}")
        for j in range(len(given)):
            for k in range(j):
                if np.array_equal(given[j], given[k]):
                    raise ValueError(f"given points {k} and {j} are the same point")
        self.given = [[float(v) for v in g] for g in given]

    # -- arrays -----------------------------------------------------------
    @property
    def dim(self) -> int:
        """The number of variables."""
        return len(self.names)

    # the bounds and kinds as arrays
    lb = property(lambda self: np.array(self.lower), doc="Lower bounds.")
    ub = property(lambda self: np.array(self.upper), doc="Upper bounds.")
    int_mask = property(lambda self: np.array(self.integer, dtype=bool),
                        doc="True for the integer variables.")
    log_mask = property(lambda self: np.array(self.log, dtype=bool),
                        doc="True for the variables searched on a log scale.")
    switch_mask = property(lambda self: np.array(self.switch, dtype=bool),
                           doc="True for the variables searched as off/on.")
    search_ub = property(lambda self: self.to_search(self.ub),
                         doc="Upper bounds in search coordinates.")

    @property
    def search_lb(self) -> np.ndarray:
        """Lower bounds in search coordinates (a switch's: -upper, the end of its off half)."""
        lb = self.to_search(self.lb)
        m = self.switch_mask
        return np.where(m, -self.ub, lb) if m.any() else lb

    @property
    def span(self) -> np.ndarray:
        """Range of each variable; 1 for fixed variables so that scaling never divides by 0."""
        return _width(self.lb, self.ub)

    @property
    def search_span(self) -> np.ndarray:
        """``span`` in search coordinates (ln ub - ln lb for a log variable)."""
        return _width(self.search_lb, self.search_ub)

    @property
    def given_array(self) -> np.ndarray:
        """The given points as an (n, d) array."""
        return np.array(self.given, dtype=float).reshape(-1, self.dim)

    # -- mapping ----------------------------------------------------------
    def to_search(self, x: np.ndarray) -> np.ndarray:
        """Search coordinates: ln x for log variables, x itself for the others but a switch's
        0 (off), which is the middle of its off half, -upper / 2."""
        x = np.asarray(x, dtype=float)
        m = self.log_mask
        if m.any():
            with np.errstate(divide="ignore", invalid="ignore"):
                x = np.where(m, np.log(np.where(m, x, 1.0)), x)
        w = self.switch_mask
        if w.any():
            x = np.where(w & (x <= 0), -0.5 * self.ub, x)
        return x

    def from_search(self, s: np.ndarray) -> np.ndarray:
        """Back from search coordinates (not clipped: ``snap`` puts a point on the bounds)."""
        s = np.asarray(s, dtype=float)
        w = self.switch_mask
        if w.any():
            s = np.where(w & (s < 0), 0.0, s)
        m = self.log_mask
        if not m.any():
            return s
        return np.where(m, np.exp(np.where(m, s, 0.0)), s)

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        """Points (d,) or (n, d) to the unit box of search coordinates."""
        return (self.to_search(x) - self.search_lb) / self.search_span

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Points of the unit box back to the variables' units (not snapped)."""
        return self.from_search(self.search_lb + np.asarray(u, dtype=float) * self.search_span)

    def snap(self, x: np.ndarray) -> np.ndarray:
        """Clip to the bounds and round the integer variables (works on (d,) or (n, d))."""
        x = np.clip(np.asarray(x, dtype=float), self.lb, self.ub)
        m = self.int_mask
        if m.any():
            x[..., m] = np.rint(x[..., m])
        return x

    def check(self, x, what: str = "point") -> np.ndarray:
        """x as a float array if it is a valid point (shape, finite, in bounds, integers
        integral), else ValueError naming ``what`` and the variable."""
        x = np.asarray(x, dtype=float)
        if x.shape != (self.dim,):
            raise ValueError(f"{what}: expected {self.dim} values, got shape {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{what}: values must be finite, got {x.tolist()}")
        bad = (x < self.lb) | (x > self.ub)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{what}: {self.names[i]}={x[i]} outside "
                             f"[{self.lower[i]}, {self.upper[i]}]")
        m = self.int_mask
        if np.any(x[m] != np.rint(x[m])):
            i = int(np.flatnonzero(m & (x != np.rint(x)))[0])
            raise ValueError(f"{what}: integer variable {self.names[i]}={x[i]} is not integral")
        return x

    # -- integer grid -----------------------------------------------------
    @property
    def n_grid(self) -> float:
        """Number of distinct points if every variable is integer (or fixed), else inf."""
        span = self.ub - self.lb
        if np.any(~self.int_mask & (span > 0)):
            return math.inf
        return float(np.prod(np.where(self.int_mask, span + 1, 1.0)))

    def grid(self) -> np.ndarray:
        """All points of a finite (all-integer) space, in lexicographic order."""
        if not math.isfinite(self.n_grid):
            raise ValueError("space has continuous variables; it has no finite grid")
        axes = [np.arange(lo, hi + 1.0) if m else np.array([lo])
                for lo, hi, m in zip(self.lower, self.upper, self.integer)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, self.dim)

    # -- serialisation ------------------------------------------------------
    def to_dict(self) -> dict:
        """Plain JSON types (``from_dict`` reads them back)."""
        out = {"names": list(self.names), "lower": list(self.lower), "upper": list(self.upper),
               "integer": list(self.integer), "given": [list(g) for g in self.given]}
        if any(self.log):  # absent otherwise: a space without log scales reads the same
            out["log"] = list(self.log)
        if any(self.switch):
            out["switch"] = list(self.switch)
        return out

    def without_switches(self) -> "DesignSpace":
        """The same space with every variable searched as one range (an optimiser whose
        settings do not search switches)."""
        return replace(self, switch=None) if any(self.switch) else self

    @classmethod
    def from_dict(cls, d: dict) -> "DesignSpace":
        """The space a ``to_dict`` wrote."""
        return cls(names=d["names"], lower=d["lower"], upper=d["upper"],
                   integer=d["integer"], given=d.get("given", []), log=d.get("log"),
                   switch=d.get("switch"))


def _width(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """hi - lo, 1 where that is not positive (a fixed variable: scaling never divides by 0)."""
    s = hi - lo
    return np.where(s > 0, s, 1.0)
