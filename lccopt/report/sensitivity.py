"""Which design variables move an objective: variance-based (Sobol') sensitivity indices of a
cubic RBF surrogate fitted to a run's evaluations.

The indices are those of the surrogate over the whole design space (each variable uniform over
its range, in ratios where the case searches it on a log scale, integers uniform over their
values), estimated with Saltelli's sampling and Jansen's estimators: first-order S_i (the share
of the variance that x_i explains alone) and total-effect ST_i (with all its interactions).
They are as good as the surrogate: its leave-one-out error is returned with them, and where it
is large the indices are only a rough guide. Deterministic (a fixed scrambled Sobol' sequence),
so a report drawn twice shows the same bars.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .data import FRONT_COLOR, RunData
from .plotting import pyplot, save_figure

SAMPLES = 2048  # base samples: (d + 2) x SAMPLES surrogate evaluations, a fraction of a second


@dataclass
class Indices:
    first: np.ndarray        # S_i per variable
    total: np.ndarray        # ST_i per variable
    loo_error: float         # leave-one-out rms error of the surrogate / std of the values
    n_points: int            # evaluations the surrogate was fitted to


def to_unit(x: np.ndarray, lower, upper, log) -> np.ndarray:
    """Design points (n, d) in the unit box the way the optimiser sees them."""
    x = np.asarray(x, dtype=float)
    lo, hi, lg = (np.asarray(a) for a in (lower, upper, log))
    span = np.where(hi > lo, hi - lo, 1.0)
    u = (x - lo) / span
    if lg.any():
        with np.errstate(divide="ignore", invalid="ignore"):
            ul = (np.log(x) - np.log(lo)) / np.where(hi > lo, np.log(hi) - np.log(lo), 1.0)
        u = np.where(lg, ul, u)
    return u


def _sample(u: np.ndarray, lower, upper, integer) -> np.ndarray:
    """Unit-box samples of a uniform design: integers uniform over their values, snapped."""
    lo, hi, it = (np.asarray(a) for a in (lower, upper, integer))
    n_values = np.where(it, hi - lo + 1, 1.0)
    snapped = (np.minimum(np.floor(u * n_values), n_values - 1)) / np.where(n_values > 1,
                                                                            n_values - 1, 1.0)
    return np.where(it, snapped, u)


def sobol_indices(x: np.ndarray, f: np.ndarray, lower, upper, integer, log,
                  samples: int = SAMPLES) -> Indices | None:
    """Indices of objective values ``f`` at designs ``x`` (finite rows only); None when there
    are too few points to fit a surrogate or the values do not vary."""
    from scipy.stats import qmc

    from ..optim.rbf import CubicRBF

    keep = np.all(np.isfinite(x), axis=1) & np.isfinite(f)
    x, f = x[keep], f[keep]
    d = x.shape[1]
    if len(f) < d + 2 or np.ptp(f) == 0:
        return None
    U = to_unit(x, lower, upper, log)
    U, first = np.unique(U, axis=0, return_index=True)
    f = f[first]
    rbf = CubicRBF().fit(U, f)
    loo = rbf.loo_residuals([f])[0]
    loo_error = (float(np.sqrt(np.nanmean(loo ** 2)) / np.std(f)) if np.isfinite(loo).any()
                 else np.nan)

    base = qmc.Sobol(2 * d, scramble=True, seed=20240611).random(samples)
    A = _sample(base[:, :d], lower, upper, integer)
    B = _sample(base[:, d:], lower, upper, integer)
    ABs = np.repeat(A[None], d, axis=0)
    ABs[np.arange(d), :, np.arange(d)] = B.T
    y = rbf(np.vstack([A, B, ABs.reshape(-1, d)]))
    fa, fb, fab = y[:samples], y[samples:2 * samples], y[2 * samples:].reshape(d, samples)
    var = np.var(np.concatenate([fa, fb]))
    if not var > 0:
        return None
    first_order = np.mean(fb[None] * (fab - fa[None]), axis=1) / var      # Saltelli 2010
    total = 0.5 * np.mean((fa[None] - fab) ** 2, axis=1) / var            # Jansen 1999
    return Indices(np.clip(first_order, 0.0, 1.0), np.clip(total, 0.0, None), loo_error, len(f))


def sensitivity_of(run: RunData) -> dict:
    """{objective: Indices} for each objective the run minimised (lccopt.report.sensitivity)."""
    lower = np.array([v.lower for v in run.variables], float)
    upper = np.array([v.upper for v in run.variables], float)
    if not (np.isfinite(lower).all() and np.isfinite(upper).all()):
        return {}
    integer = np.array([v.integer for v in run.variables], bool)
    log = np.array([bool(getattr(v, "log", False)) for v in run.variables], bool)
    out = {}
    for k in run.objectives:
        f = np.where(run.ok, run.obj[k], np.nan)
        ind = sobol_indices(run.x, f, lower, upper, integer, log)
        if ind is not None:
            out[k] = ind
    return out


def fig_sensitivity(run: RunData, out: Path, indices: dict) -> Path | None:
    """Variance-based sensitivity indices of each objective (total effect, first order inside)."""
    if not indices:
        return None
    plt = pyplot()
    from matplotlib.patches import Patch

    d = len(run.variables)
    fig, axes = plt.subplots(1, len(indices), figsize=(4.6 * len(indices) + 1.4, 0.42 * d + 1.8),
                             sharey=True, squeeze=False)
    y = np.arange(d)[::-1]
    for ax, (k, ind) in zip(axes[0], indices.items()):
        ax.barh(y, ind.total, height=0.7, color=FRONT_COLOR, alpha=0.35, label="total effect ST_i")
        ax.barh(y, ind.first, height=0.4, color=FRONT_COLOR, label="first order S_i")
        ax.set_xlim(0, max(1.0, float(np.max(ind.total)) * 1.05))
        quality = (f"{ind.n_points} evaluations; surrogate's leave-one-out\nerror "
                   f"{ind.loo_error:.0%} of "
                   f"the values' spread" if np.isfinite(ind.loo_error) else "")
        ax.set_title(f"{k}\n{quality}", fontsize=8.5)
        ax.set_xlabel("share of the objective's variance")
        ax.grid(axis="x", alpha=0.3)
    short = (("railpad stiffness, sleeper", "pad, sleeper"), (" from the interface", ""),
             (" next to the interface", ""), (" from the entry slab edge", ""))
    labels = []
    for v in run.variables:
        label = v.label
        for a, b in short:
            label = label.replace(a, b)
        labels.append(f"{v.name}: {label}")
    axes[0, 0].set_yticks(y)
    axes[0, 0].set_yticklabels(labels, fontsize=8)
    fig.suptitle("Which design variables move the objectives over the whole design space "
                 "(variance-based indices of a surrogate)", fontsize=9.5)
    fig.legend(handles=[Patch(color=FRONT_COLOR, alpha=0.35,
                              label="total effect ST_i (with interactions)"),
                        Patch(color=FRONT_COLOR, label="first order S_i (alone)")],
               loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 0.94))
    return save_figure(fig, out / "sensitivity.png")
