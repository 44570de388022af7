"""The case schema's degradation: section, the settlement prediction's keys."""

from __future__ import annotations

from dataclasses import replace

from ..degradation.inputs import LAW_NAMES, LIMIT_MEASURES, READINGS, SOILS
from .kinds import (
    Named,
    Num,
    NumOrSection,
    Section,
    Str,
)
from .plausible import SEAT_WHY

# The settlement prediction (lccopt/degradation, docs/settlement.md). Law parameters without a
# default here get the chosen law's default from lccopt/config/degradation.py (the other law's
# keys stay absent); sources in docs/settlement.md, "Parameters".
_ROSE = "(ROSE, Deltares / TU Delft, citing Varandas et al. 2014; not checked against the paper)"
_LAW = Section({
    "name": Str("varandas: Varandas, Hölscher & Silva (2014), Proc IMechE F 228(3) 242-259, "
                "doi:10.1177/0954409712471610, settlement from the load histogram; logarithmic: "
                "S = s1 (F/F0)^m (1 + C ln N), Hettler's form, strain hardening",
                LAW_NAMES, default="varandas", required=False),
    "alpha": Num("varandas: load exponent (settlement grows as F^(alpha+1)). Default 0.6 "
                 + _ROSE, gt=0, le=10.0, required=False, keep_absent=True),
    "beta": Num("varandas: cycle exponent (under one load, settlement grows as about "
                "N^(1-beta)). Default 0.82 " + _ROSE, gt=0, le=0.99, required=False,
                keep_absent=True),
    "gamma": Num("varandas: settlement after reference_cycles cycles of reference_force. "
                 "Default 10 mm " + _ROSE, "m", gt=0, le=1.0, shown="mm", required=False,
                 keep_absent=True),
    "reference_force": Num("varandas, logarithmic: reference force F0 per rail seat. Default "
                           "50 kN " + _ROSE, "N", gt=0, le=1e7, shown="kN", required=False,
                           keep_absent=True),
    "reference_cycles": Num("varandas: reference number of cycles N0. Default 1e6 " + _ROSE,
                            ge=1, le=1e12, required=False, keep_absent=True),
    "first_cycle": Num("logarithmic: settlement s1 after the first cycle of F0 (required: no "
                       "published value could be found)", "m", gt=0, le=1.0, shown="mm",
                       required=False, keep_absent=True),
    "log_rate": Num("logarithmic: C (required: no published value could be found)", gt=0,
                    le=1000.0, required=False, keep_absent=True),
    "exponent": Num("logarithmic: load exponent m. Default 1.6 (Hettler's, as ROSE writes the "
                    "law)", gt=0, le=10.0, required=False, keep_absent=True),
}, "the settlement law, driven by the peak ballast force of each axle passing each sleeper",
   required=False)
_PASSAGES = dict(unit="1/year", le=1e8, why="a busy line carries some 10^5-10^6 passages a year")
# Traffic as people count it: trains a day and what each train is, or axle passes a year
# (lccopt/config/degradation.py turns them into passages of the modelled vehicle).
_TRAINS = {
    "trains_per_day": Num("trains a day on the modelled track, each of vehicles_per_train or "
                          "bogies_per_train (instead of passages_per_year)", gt=0, le=5000.0,
                          why="a busy track carries some 50-500 trains a day", required=False,
                          keep_absent=True),
    "vehicles_per_train": Num("vehicles (cars) of each train, each on two bogies of two axles "
                              "like the modelled one (a four-car VIRM: 4)", integer=True, ge=1,
                              le=100, required=False, keep_absent=True),
    "bogies_per_train": Num("bogies of each train (instead of vehicles_per_train: articulated "
                            "trains, locomotives and wagons mixed)", integer=True, ge=1, le=400,
                            required=False, keep_absent=True),
    "axle_passes_per_year": Num("axle passes a year, every axle of the modelled vehicle's load "
                                "(instead of trains or passages)", gt=0, le=1e9,
                                why="a busy line carries some 10^5-10^7 axle passes a year",
                                required=False, keep_absent=True),
}
DEGRADATION = Section({
    "horizon_years": Num("the horizon: the settlement objectives are the track's state after "
                         "this many years of the traffic (a tamped track's: its worst over "
                         "them). Default 10 years (when horizon_axle_passes is not given)",
                         "year", gt=0, le=200.0,
                         required=False, keep_absent=True),
    "horizon_axle_passes": Num("the horizon in axle passes of the modelled rail, all "
                               "conditions together (instead of horizon_years)", gt=0, le=1e10,
                               required=False, keep_absent=True),
    "passages_per_year": Num("a case without conditions: passages of its vehicle a year (a "
                             "bogie: one bogie, 2 axles; a half car: one car, 4 axles; "
                             "three-dof: one wheelset). Or trains_per_day with "
                             "vehicles_per_train or bogies_per_train, or axle_passes_per_year",
                             gt=0, required=False, keep_absent=True, **_PASSAGES),
    **{k: replace(v, doc="a case without conditions: " + v.doc) for k, v in _TRAINS.items()},
    "traffic": Named(NumOrSection(
        "passages of the condition's vehicle a year (0: it counts for the paper's objectives "
        "only), or its trains",
        Num("passages a year", ge=0, **_PASSAGES),
        Section({"passages_per_year": Num("passages of the condition's vehicle a year", ge=0,
                                          required=False, keep_absent=True, **_PASSAGES),
                 **_TRAINS})),
        "a case with conditions: the traffic of each condition, every condition named",
        keep_absent=True),
    "law": _LAW,
    "rail_seats": Num("the law's force = rail_seats x the modelled support force (one rail "
                      "seat); 1 as ROSE applies the Varandas defaults", gt=0, le=10.0,
                      default=1.0, required=False),
    "reading": Str("how a passage loads the ballast: axle, each axle's own peak force is one "
                   "load cycle; passage, every axle counts with the passage's largest peak "
                   "(ROSE's reading)", READINGS, default="axle", required=False),
    "subgrade": Section({
        "soil": Str("the subgrade's soil class after Li & Selig (1996): ML silt, MH elastic "
                    "silt, CL lean clay, CH fat clay; none: the ballast law alone",
                    SOILS + ("none",), default="CL", required=False),
        "strength": Num("the soil's static (compressive) strength under a support of "
                        "reference_stiffness. Default 150 kPa: a stiff clay (100-200 kPa, "
                        "Terzaghi & Peck's consistency classes)", "Pa", gt=0, le=1e8,
                        shown="kPa", default=150.0e3, required=False),
        "reference_stiffness": Num("the support stiffness per rail seat (track.support) the "
                                   "strength is given for: a case's softer support is a weaker "
                                   "soil, its strength scaled in proportion. Default 45 MN/m "
                                   "(configs/reference.yaml)", "N/m", ge=1e6, shown="MN/m",
                                   why=SEAT_WHY, default=45.0e6, required=False),
        "depth": Num("from the sleeper's base to the top of the subgrade (ballast and "
                     "sub-ballast). Default 0.5 m", "m", gt=0, le=10.0, default=0.5,
                     required=False),
        "thickness": Num("the subgrade layer whose strain settles the track. Default 2 m",
                         "m", gt=0, le=50.0, default=2.0, required=False),
    }, "the subgrade below the ballast (and below the ERS slab): its own law, Li & Selig "
       "(1996) as ROSE applies it, fed the stress of each sleeper's force (docs/settlement.md)",
       required=False),
    "settling_sleepers": Num("entry sleepers nearest the interface that settle by their own "
                             "loads (at most evaluation.sleepers: the runs pass the whole "
                             "vehicle over those)", integer=True, ge=1, le=500, default=20,
                             required=False),
    "follower_flat": Num("the entry sleepers beyond the settling ones settle as the farthest of "
                         "them over this length (the open track)", "m", ge=0, le=500.0,
                         default=10.0, required=False),
    "follower_taper": Num("beyond follower_flat they taper to no settlement over this length "
                          "(the rail's pinned end would otherwise hold the settled track up)",
                          "m", gt=0,
                          le=500.0, default=20.0, required=False),
    "tolerance": Num("error allowed in the loads the law is fed between simulations: the "
                     "accuracy and cost knob (2 kN: the 10-year profile within 0.02 mm of a "
                     "4x finer run; benchmarks/RESULTS-settlement.md)", "N", gt=0, le=50e3,
                     shown="kN", default=2.0e3, required=False),
    "steps_per_decade": Num("blocks of load cycles per decade of cycles, at most", gt=0,
                            le=100.0, default=8.0, required=False),
    "max_simulations": Num("the most simulations of each condition in one prediction, the "
                           "first and last included (the cost cap; about 13 are needed for "
                           "10^7 axle passes at 2 kN)", integer=True, ge=2, le=1000, default=30,
                           required=False),
    "limit": Section({
        "measure": Str("the measure the limit is on", LIMIT_MEASURES,
                       default="differential_settlement", required=False),
        "value": Num("the limit", "m", gt=0, le=1.0, shown="mm", default=3.0e-3,
                     required=False),
    }, "the limit that years_to_limit and maintenance_rate count to, and that tamping (if any) "
       "is done at. Default: differential settlement 3 mm (an assumption, not a standard's "
       "value)", required=False),
    "tamping": Section({
        "unreachable_sleepers": Num("sleepers next to the slab a tamping machine cannot reach "
                                    "(not lifted). Default 2: the group of hanging sleepers "
                                    "tamping did not cure next to the level crossing Le Pen et "
                                    "al. (2014) monitored (an assumption: set your machine's "
                                    "reach)", integer=True, ge=0, le=500, default=2,
                                    required=False),
        "min_interval": Num("the least time between two tampings (and from the new track to the "
                            "first): the limit reached sooner is tamped then. Default 0.1 year",
                            "year", gt=0, le=50.0, default=0.1, required=False),
    }, "tamp when the limit is reached: the reachable settling sleepers are lifted to the "
       "slab's level and their ballast settles anew (fast at first); objectives interventions, "
       "years_to_limit (to the first) (docs/settlement.md)", required=False,
       none_if_absent=True, keep_absent=True),
}, "predict the settlement of each design under its traffic and judge it by the settlement "
   "objectives (docs/settlement.md)", required=False, none_if_absent=True, keep_absent=True)
