"""Tables 5-7 of the paper for this model, from finished runs of the study's configs.

    for o in F_rms F_max E_rms E_max; do lccopt optimise configs/single-$o.yaml; done
    lccopt optimise configs/moo.yaml
    python -m benchmarks.paper.paper_study [runs]

Prints, for each single-objective optimum and the multi-objective compromise, the design and
every objective's change against the reference design, and the ASF worst values the paper's
rule gives (the largest F_max and E_max among the single-objective optima).
"""

from __future__ import annotations

import sys
from pathlib import Path

import h5py
import numpy as np

OBJ = ("F_rms", "F_max", "E_rms", "E_max")


def best_row(path: Path) -> dict:
    with h5py.File(path, "r") as f:
        e = f["evaluations"]
        ok = e["status"].asstr()[()] == "ok"
        value = np.where(ok, e["value"][()], np.inf)
        i = int(np.argmin(value))
        ref = {k: float(f["reference/objectives"].attrs[k]) for k in OBJ}
        row = {k: float(e[k][i]) for k in OBJ}
        wall = sum(float(v) for v in e["wall_time"][()])
        return {"id": int(e["id"][i]), "x": e["x"][i], "obj": row, "ref": ref,
                "n": int(f.attrs["n_evaluations"]), "finished": bool(f.attrs["finished"]),
                "sim_time": wall}


def design(x) -> str:
    return (f"{x[0] / 1e6:.0f}, {x[1] / 1e6:.0f}, {x[2] / 1e6:.0f}; {x[3]:.0f}; "
            f"{x[4]:.0f}, {x[5]:.0f}, {x[6]:.0f}; {x[7]:.0f}")


def main(runs: str = "runs") -> None:
    runs = Path(runs)
    rows = {}
    for o in OBJ:
        p = runs / f"single-{o}" / "results.h5"
        if p.exists():
            rows[f"min {o}"] = best_row(p)
    if (runs / "moo" / "results.h5").exists():
        rows["moo (F_max, E_max)"] = best_row(runs / "moo" / "results.h5")
    if not rows:
        sys.exit(f"no finished runs under {runs}")
    print("| optimised | " + " | ".join(OBJ)
          + " | design (x_r [MN/m]; x_n; x_s; x_l) | best # / evaluations |")
    print("|---|" + "---|" * (len(OBJ) + 2))
    for name, r in rows.items():
        cells = []
        for k in OBJ:
            d = (r["obj"][k] - r["ref"][k]) / r["ref"][k] * 100
            own = k in name
            cells.append(f"**{d:+.1f} %**" if own else f"{d:+.1f} %")
        print(f"| {name} | " + " | ".join(cells) + f" | {design(r['x'])} | #{r['id']} / {r['n']} |")
    ref = next(iter(rows.values()))["ref"]
    print("| reference design | " + " | ".join(f"{ref[k]:.5g}" for k in OBJ)
          + " | 1120, 1120, 1120; 8; 6, 6, 4; 0 | |")
    singles = [r for n, r in rows.items() if n.startswith("min")]
    if len(singles) == 4:
        worst = [max(r["obj"][k] for r in singles) for k in ("F_max", "E_max")]
        print("\nASF worst values by the paper's rule (largest among the single-objective "
              f"optima): F_max {worst[0]:.0f} N, E_max {worst[1]:.3g} J")


if __name__ == "__main__":
    main(*sys.argv[1:])
