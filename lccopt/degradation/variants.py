"""The law's uncertainty: the variants of a settlement prediction a ranking is checked under
(docs/settlement.md, "Rankings and the law's uncertainty").

Eight variants of the case's law, each alone: every parameter of the Varandas law 30 % lower
and higher (α; the cycle exponent 1 - β, since β itself 30 % higher passes 1 and the
settlement stops growing; γ), the other reading of the load history (each axle's own peak or
the passage's peak for every axle) and the other law, matched to the case's at its two ends
(the first cycle and N0 cycles of F0), so that the variant is the law's form, not its
magnitude. A logarithmic case varies first_cycle, log_rate and its exponent instead.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import brentq

from .inputs import READINGS, DegradationSpec, LawSpec
from .laws import harmonic

SPREAD = 0.3


def _params(law: LawSpec) -> dict:
    return dict(law.parameters)


def _with(law: LawSpec, **changes) -> LawSpec:
    p = _params(law)
    p.update(changes)
    return LawSpec(law.name, tuple(p.items()))


def other_law(law: LawSpec) -> LawSpec:
    """The other law, matched to ``law`` under a constant load F0: the same settlement after
    the first cycle and after N0 cycles, the same load exponent.

    Varandas -> logarithmic: S = γ H_β(N)/H_β(N0) gives s1 = γ / H_β(N0) (N = 1) and
    1 + C ln N0 = H_β(N0) (N = N0), m = α + 1. Logarithmic -> Varandas: N0 = 10^6, α = m - 1,
    γ = s1 (1 + C ln N0), β such that H_β(N0) = 1 + C ln N0.

    Parameters
    ----------
    law
        the case's law.

    Returns
    -------
    LawSpec
    """
    p = _params(law)
    if law.name == "varandas":
        h = float(harmonic(p["n0"], p["beta"]))
        return LawSpec("logarithmic", (("first_cycle", p["gamma"] / h),
                                       ("log_rate", (h - 1.0) / np.log(p["n0"])),
                                       ("exponent", p["alpha"] + 1.0), ("f0", p["f0"])))
    n0 = 1.0e6
    target = 1.0 + p["log_rate"] * np.log(n0)
    beta = brentq(lambda b: float(harmonic(n0, b)) - target, 1e-3, 0.999) \
        if 1.0 < target < float(harmonic(n0, 1e-3)) else 0.82
    return LawSpec("varandas", (("alpha", max(p["exponent"] - 1.0, 0.05)), ("beta", beta),
                                ("gamma", p["first_cycle"] * target), ("f0", p["f0"]),
                                ("n0", n0)))


def law_variants(spec: DegradationSpec) -> list[tuple[str, DegradationSpec]]:
    """The eight variants of ``spec``'s law (module docstring), each a (label, spec).

    Parameters
    ----------
    spec
        the case's prediction.

    Returns
    -------
    list of (str, DegradationSpec)
    """
    law = spec.law
    p = _params(law)
    out = []
    if law.name == "varandas":
        for sign, word in ((-1, "-30 %"), (1, "+30 %")):
            f = 1.0 + sign * SPREAD
            out += [(f"alpha {word}", _with(law, alpha=p["alpha"] * f)),
                    (f"1 - beta {word}", _with(law, beta=1.0 - (1.0 - p["beta"]) * f)),
                    (f"gamma {word}", _with(law, gamma=p["gamma"] * f))]
    else:
        for sign, word in ((-1, "-30 %"), (1, "+30 %")):
            f = 1.0 + sign * SPREAD
            out += [(f"exponent {word}", _with(law, exponent=p["exponent"] * f)),
                    (f"log_rate {word}", _with(law, log_rate=p["log_rate"] * f)),
                    (f"first_cycle {word}", _with(law, first_cycle=p["first_cycle"] * f))]
    out = [(label, replace(spec, law=v)) for label, v in out]
    other = next(r for r in READINGS if r != spec.reading)
    out.append((f"{other} reading", replace(spec, reading=other)))
    o = other_law(law)
    out.append((f"{o.name} law (matched)", replace(spec, law=o)))
    return out
