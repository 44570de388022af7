"""The settled track as a track engineer measures it: the rail's level along the approach and
over the ERS, and the measures taken from it (docs/settlement.md, "Measures at the rail").

* **Step** at the entry interface: how far the rail sits below its level at the slab's edge
  within 3 m of the approach (the largest of level(x) - level(x_a) over [x_a - 3 m, x_a]).
* **Angle**: the rail's largest slope within 3 m either side of the interface (the
  inclination it runs down off the slab at), dimensionless (shown in mm/m).
* **Longitudinal level, EN 13848's D1 band**: the level band-passed to wavelengths of 3 to
  25 m (EN 13848-1's D1 range; a zero-phase 4th-order Butterworth, forward and backward,
  the standard's own filter not checked), its standard deviation and its largest deviation
  (mean to peak) over the approach's settling zone and the ERS. EN 13848-6 takes the
  standard deviation over 200 m sections: over a 200 m section holding only this transition
  it would be the value here × √(window / 200 m).

3 m: the shortest wavelength of the D1 band, the base over which the step and the angle
are taken. The level is sampled every 0.25 m, from 60 m before the interface to 30 m past the
ERS (the filter's reach; the settled track's followers taper to the as-built level within
it), continued at its end values beyond.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfiltfilt

SAMPLE = 0.25                 # [m] spacing of the level
D1_BAND = (3.0, 25.0)         # [m] wavelengths of EN 13848-1's D1 range
BASE = 3.0                    # [m] step and angle within this distance of the interface
_BEFORE, _AFTER = 60.0, 30.0  # [m] the level's reach either side of the zone and the ERS
_SOS = butter(4, [1.0 / D1_BAND[1], 1.0 / D1_BAND[0]], btype="bandpass", fs=1.0 / SAMPLE,
              output="sos")
MEASURES = ("rail_step", "rail_angle", "level_d1_std", "level_d1_max", "level_std")


def d1_level(level: np.ndarray) -> np.ndarray:
    """A level sampled every SAMPLE metres band-passed to the D1 wavelengths (3-25 m), zero
    phase; the level continues at its end values beyond the samples."""
    pad = int(round(2 * D1_BAND[1] / SAMPLE))
    z = np.pad(np.asarray(level, dtype=float), [(0, 0)] * (np.ndim(level) - 1) + [(pad, pad)],
               mode="edge")
    return sosfiltfilt(_SOS, z, axis=-1)[..., pad:-pad]


@dataclass(frozen=True)
class RailGrid:
    """Where the rail's level is taken and measured.

    x: the sample positions [m]; interface: x_a, the slab's entry edge [m]; window: (from,
    to) [m] of the D1 measures (the settling zone and the ERS); shown: the samples the
    history keeps (the settling zone - 3 m to the ERS's far edge); zone: (from, to) [m] of
    level_std (the settling zone ± 3 m, the first version's measure)."""
    x: np.ndarray
    interface: float
    window: tuple
    shown: np.ndarray
    zone: tuple

    @classmethod
    def of(cls, track, sleeper_x) -> "RailGrid":
        """The grid of a built level-crossing track and its settling sleepers' positions (a
        track without an ERS: the nearest settling sleeper stands for the interface)."""
        far, near = float(np.min(sleeper_x)), float(np.max(sleeper_x))
        x_a, x_b = (float(v) for v in getattr(track, "interface", (near, near)))
        lo = max(float(track.node_x[0]), far - _BEFORE)
        hi = min(float(track.node_x[-1]), x_b + _AFTER)
        x = lo + SAMPLE * np.arange(int(np.floor((hi - lo) / SAMPLE)) + 1)
        shown = np.flatnonzero((x >= far - 3.0 - 1e-9) & (x <= x_b + 1e-9))
        return cls(x, x_a, (far, x_b), shown, (far - 3.0, near + 3.0))

    def measures(self, level: np.ndarray) -> dict:
        """The measures (MEASURES) of a level [m] at ``x`` (downward positive)."""
        level = np.asarray(level, dtype=float)
        x, xa = self.x, self.interface
        at = float(np.interp(xa, x, level))
        before = (x >= xa - BASE) & (x <= xa)
        near = (x >= xa - BASE) & (x <= xa + BASE)
        slope = np.gradient(level, SAMPLE)
        d1 = d1_level(level)
        win = (x >= self.window[0]) & (x <= self.window[1])
        zone = (x >= self.zone[0]) & (x <= self.zone[1])
        return {"rail_step": float(np.max(level[before]) - at),
                "rail_angle": float(np.max(np.abs(slope[near]))),
                "level_d1_std": float(np.std(d1[win])),
                "level_d1_max": float(np.max(np.abs(d1[win]))),
                "level_std": float(np.std(level[zone]))}
