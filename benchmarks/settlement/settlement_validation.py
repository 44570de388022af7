"""The settlement model against what published measurements of transitions show
(docs/settlement.md, "Validation"; the figure docs/settlement-validation.png).

No measured dataset of a transition or crossing could be read here (only the abstracts and
introductions of the papers), so the comparison is of trends: configs/settlement.yaml's
reference design, tamped at its limit, and

* the loaded deflection of each sleeper along the approach (the rail's static deflection
  under the bogie's wheels above that sleeper, from its level at rest: what geophones and
  digital image correlation measure as trains pass) on the new track, just before and just
  after the first tamping and at the horizon, with the voids under the sleepers: Le Pen et
  al. (2014) found a group of hanging sleepers on the approach of a UK level crossing that
  tamping did not cure;
* the settlement along the approach early in the life: Wang, Markine & Liu (2017) say the dip
  in the approaching zone appears shortly after installation or renewal.

    python -m benchmarks.settlement.settlement_validation --out docs/settlement-validation.png
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
from pathlib import Path

import numpy as np

from lccopt.config import load_case
from lccopt.degradation.assessment import predict
from lccopt.degradation.loading import entry_zone
from lccopt.degradation.statics import ZoneStatics
from lccopt.vti.track import build_track
from lccopt.vti.vehicle import build_vehicle


def loaded_deflection(statics, zone, gap, sleeper_x, offsets, loads):
    """Each settling sleeper's deflection [m] under the wheels with one above it, from its
    position at rest (both on the track with ``gap``)."""
    n = len(sleeper_x)
    rest, _ = statics.equilibrium(gap, np.zeros((1, statics.m)))
    cases = statics.wheel_cases(sleeper_x, offsets, loads)
    u, _ = statics.equilibrium(gap, cases.a)
    own = u[np.arange(len(cases.own)), cases.own] - rest[0, cases.own]
    return own.reshape(cases.shape).max(axis=0)[:n]


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("docs/settlement-validation.png"))
    a = p.parse_args(argv)
    case = load_case("configs/settlement.yaml")
    spec = case.degradation_spec()
    design = case.track_design(case.reference)
    r = predict(spec, design)
    scenario = spec.settling_traffic[0].scenario
    track = build_track(scenario, design)
    zone = entry_zone(track, spec.settling_sleepers, spec.follower_flat, spec.follower_taper)
    statics = ZoneStatics(track, zone.supports)
    vehicle = build_vehicle(scenario.vehicle)
    offsets = np.asarray(vehicle.wheel_offsets, float)
    loads = np.asarray(vehicle.static_wheel_loads, float)
    x = r.sleeper_x - track.interface[0]
    tamped = np.flatnonzero(r.tamped)
    moments = [(0, "new track")]
    if tamped.size:
        moments += [(tamped[0] - 1, f"before the first tamping ({r.years[tamped[0]]:.2g} years)"),
                    (tamped[0], "just after it")]
    moments.append((len(r.years) - 1, f"{r.years[-1]:.3g} years ({int(tamped.size)} tampings)"))
    slab = r.rail["slab"]
    rows = []
    for i, label in moments:
        gap = zone.gaps(np.maximum(r.settlement[i] - slab[i], 0.0))
        d = loaded_deflection(statics, zone, gap, r.sleeper_x, offsets, loads)
        rows.append((label, d, r.void[i], r.settlement[i]))
        print(f"{label}: loaded deflection [mm] from the slab: "
              + " ".join(f"{v * 1e3:.2f}" for v in d[:8]) + " ...; voids "
              + " ".join(f"{v * 1e3:.2f}" for v in r.void[i][:5]))
    early = np.flatnonzero(r.years <= 1 / 12)[-1]
    s = r.settlement[early]
    print(f"after {r.years[early] * 12:.2g} months the largest settlement is "
          f"{abs(x[int(np.argmax(s))]):.2f} m from the slab ({s.max() * 1e3:.2f} mm; the first "
          f"sleeper {s[0] * 1e3:.2f} mm)")

    from lccopt.report.plotting import pyplot, save_figure

    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6.6), sharex=True)
    colors = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, len(rows)))
    for (label, d, v, _), c in zip(rows, colors):
        a1.plot(x, d * 1e3, "o-", color=c, ms=3, label=label)
        a2.plot(x, v * 1e3, "o-", color=c, ms=3, label=label)
    for ax in (a1, a2):
        ax.axvspan(0.0, 0.6, color="0.88")
        ax.axvline(0.0, color="0.3", lw=0.9)
    reach = x[spec.tamping.unreachable_sleepers - 1] if spec.tamping else None
    if reach is not None:
        a1.axvspan(reach - 0.2, 0.0, color="#f2c8b5", alpha=0.5, lw=0,
                   label="out of the tamping machine's reach")
    a1.set(ylabel="loaded deflection [mm]",
           title="each sleeper under the bogie's wheels (static), from its level at rest")
    a2.set(ylabel="void at rest [mm]", xlabel="position from the slab edge [m]")
    a1.legend(frameon=False, fontsize=8)
    fig.suptitle("configs/settlement.yaml, reference design: the law's values, not a forecast")
    fig.tight_layout()
    save_figure(fig, a.out)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
