"""Surrogate optimisation with no railway knowledge (paper Steps A and C-G).

space      DesignSpace: bounds, integer flags, given points; unit-box mapping
sampling   integer-aware Latin hypercube without duplicates
rbf        cubic RBF with linear tail (Eqs. 8-10)
strategy   MSRS/DYCORS mixed-integer ask/tell Strategy with a JSON state
scalarise  augmented Chebyshev ASF (Eq. 7) and Pareto mask
"""
