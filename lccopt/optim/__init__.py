"""Surrogate optimisation with no railway knowledge (paper Steps A and C-G); docs/optimiser.md.

space         DesignSpace: bounds, integer flags, given points; unit-box mapping
sampling      integer-aware Latin hypercube without duplicates
rbf           cubic RBF with a linear or quadratic tail (Eqs. 8-10)
settings      Settings (recorded by a run) and the method's constants
surrogates    scalar RBF (capping and tail by cross-validation), composite surrogate
candidates    DYCORS steps, bound probes; the candidate-generator extension point
local_search  mixed-integer local search of the surrogate
context       per-ask working data: duplicate test, points to keep away from
restarts      phases and the restart policy (fresh, from the best point, probes, subspace)
state         the strategy's state as JSON
strategy      the MSRS/DYCORS mixed-integer ask/tell Strategy
scalarise     augmented Chebyshev ASF (Eq. 7) and Pareto mask
"""
