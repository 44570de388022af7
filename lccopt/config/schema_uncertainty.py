"""The case schema's uncertainty: section, the track as built rather than as drawn."""

from __future__ import annotations

from ..uncertainty.fields import DISTRIBUTIONS
from .kinds import (
    Num,
    Section,
    Str,
)

# The track as built rather than as drawn (lccopt/uncertainty, docs/robust.md): random
# variations over the sleepers, each quantity a field of its own. Defaults and their sources:
# docs/robust.md, "The quantities".
MAX_REALISATIONS = 500
_ROSE_FIELD = ("(ROSE, Deltares / TU Delft: rose/utils/random_field.py and its demo, "
               "cov 0.25 over 20 m)")
_CORRELATION_DOC = ("correlation length l along the track: rho(r) = exp(-(pi/4) (r/l)^2) "
                    "between sleepers r apart (ROSE's Gaussian model); 0: each sleeper on its "
                    "own")
# both bounds of a coefficient of variation, one reason: messages name the bound broken
_COV_WHY = "a spread is 0 or more; one above the mean is no longer one track"


def _variation(doc: str, cov: Num, correlation: float | None, extra: dict | None = None,
               mean_doc: str | None = None) -> Section:
    fields = {
        "distribution": Str("lognormal (positive, skewed: ROSE's) or uniform (a tolerance band; "
                            "cov at most 0.5)", DISTRIBUTIONS, default="lognormal",
                            required=False),
        "cov": cov,
        "correlation_length": Num(_CORRELATION_DOC + (f". Default {correlation:g} m"
                                                      if correlation else ""),
                                  "m", ge=0, le=1000.0, default=correlation or 0.0,
                                  required=False),
    }
    if mean_doc:
        fields["mean"] = Num(mean_doc, gt=0, le=10.0, default=1.0, required=False)
    fields.update(extra or {})
    return Section(fields, doc, required=False, none_if_absent=True, keep_absent=True)


UNCERTAINTY = Section({
    "realisations": Num("realisations of the track drawn for a run: every design is simulated "
                        "on each of them (and on the track as drawn), the same ones for every "
                        "design", integer=True, ge=2, le=MAX_REALISATIONS,
                        why="a spread needs two; beyond 500 the statistics no longer move"),
    "seed": Num("seed the realisations are drawn from. Default: optimisation.seed (0 without "
                "one); another seed draws fresh realisations (to judge designs on tracks "
                "their optimisation never saw)", integer=True, ge=0, required=False,
                keep_absent=True),
    "support_stiffness": _variation(
        "each sleeper's ballast/subgrade stiffness (a factor on the drawing's, strengthened "
        "sleepers too); {} takes the defaults",
        Num("coefficient of variation of the factor. Default 0.25 " + _ROSE_FIELD, ge=0,
            le=1.0, default=0.25, required=False, why=_COV_WHY), 20.0),
    "support_damping": _variation(
        "each sleeper's ballast/subgrade damping (a factor on the drawing's); {} takes the "
        "defaults",
        Num("coefficient of variation of the factor. Default 0.25 " + _ROSE_FIELD, ge=0,
            le=1.0, default=0.25, required=False, why=_COV_WHY), 20.0,
        {"field": Str("stiffness: drawn from support_stiffness's field, so that damping rises "
                      "with stiffness sleeper by sleeper (ROSE draws both from one seed); own: "
                      "a field of its own", ("stiffness", "own"), default="stiffness",
                      required=False)}),
    "pad_stiffness": _variation(
        "each railpad's stiffness (a factor on the catalogue's or the design's; pad damping "
        "follows it): manufacturing tolerance (cov) and ageing (mean)",
        Num("coefficient of variation of the factor (required: no published spread of pad "
            "stiffness in track could be found)", ge=0, le=1.0, why=_COV_WHY), None,
        mean_doc="mean factor: 1 (the default) for new pads as catalogued; above 1 for pads "
                 "that stiffened with age"),
    "settlement_coefficient": _variation(
        "each settling sleeper's ballast settlement (a factor on the settlement law's "
        "coefficient: gamma of varandas, first_cycle of logarithmic); needs degradation:",
        Num("coefficient of variation of the factor (required: no published spread from "
            "sleeper to sleeper could be found)", ge=0, le=1.0, why=_COV_WHY), None),
    "initial_void": Section({
        "probability": Num("fraction of the ballast sleepers that hang (required: hanging "
                           "sleepers are common on crossing approaches, Le Pen et al., "
                           "but no published fraction fits every site)", ge=0, le=1),
        "gap": Num("mean gap between a hanging sleeper and its ballast (required)", "m", ge=0,
                   le=0.05, shown="mm", why="a void deeper than 50 mm is a missing sleeper"),
        "cov": Num("coefficient of variation of the gap (lognormal). Default 0: every hanging "
                   "sleeper hangs by gap", ge=0, le=2.0, default=0.0, required=False),
        "correlation_length": Num(_CORRELATION_DOC + " (a length groups hanging sleepers: "
                                  "they often come in a row, Lazarevic et al. 2016)", "m",
                                  ge=0, le=1000.0, default=0.0, required=False),
    }, "sleepers that hang over a void at rest (the unilateral support model)",
       required=False, none_if_absent=True, keep_absent=True),
}, "random variations over the sleepers: every design is judged on the same realisations of "
   "the track (docs/robust.md); robust objectives mean(F_max), q90(F_max), p_worse(F_max)",
   required=False, none_if_absent=True, keep_absent=True)
