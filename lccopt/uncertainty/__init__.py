"""The track as built rather than as drawn, and designs judged over it (docs/robust.md).

* ``fields``: random fields over the sleepers (a Gaussian field with a correlation length,
  turned into lognormal or uniform factors, or into hanging sleepers with their gaps);
* ``statistics``: the robust objectives (mean, quantile, probability of not beating the
  reference design) over a design's realisations, and the grammar of their names.

Pure numerics: nothing here reads a case, a file or a run. The config layer draws a case's
realisations with ``fields`` (``lccopt.config.uncertainty``); the problem and the report
judge them with ``statistics``.
"""
