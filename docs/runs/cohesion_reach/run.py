"""How far the contact cohesion reaches: the rigid sweep's draught and the shear box's Mohr-Coulomb cohesion
against the bonds' normal cohesion, everything else the soil of the paper-scale Table 3 run (friction 29.52 deg,
eta 0.0015; shear cohesion = normal / 2), on the CPU at reduced scale.

    python docs/runs/cohesion_reach/run.py [--only soil-bin|shear-box] [--out docs/runs/cohesion_reach]

Writes results.json (both parts; with --only, results_soil-bin.json or results_shear-box.json): per normal cohesion,
the soil bin's steady draught [N] with its standard error, the unbroken bonds at the start of the cut and at its end
(and along the travel), and the shear box's c [kPa] and phi [deg] with its peaks.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from scenes import shear_box as sbx
from scenes import soil_bin as sb

SOIL = {"friction_angle": 29.51974323486036, "eta_roll": 0.0015063318135471741}
"""rank 1 of the paper-scale screening (docs/runs/table3-paper-h100/screening.json)."""
ASSEMBLY_SHEAR = "A"
"""the shear box's assembly: A's single spheres (580 per world at ci scale; C has about 7 times as many, 15 worlds
of it ran past half an hour on this 2-core CPU)."""
COHESIONS = (15.0, 430.0, 4.2e4, 4.2e5, 4.2e6)
"""[Pa]: the screened sets' extremes (15 Pa, 42 kPa), the chosen set's 430 Pa, and 10x and 100x the GA's upper
bound (5e4 Pa, the paper's range)."""


def soil_bin(out: dict) -> None:
    cfg = sb.SoilBinConfig(scale="cpu", assembly="C", springs=(), seed=0)
    bed = sb.bed_for(cfg, device="cpu", cache_dir=Path("benchmarks/.beds"))
    n = len(COHESIONS)
    over = {"friction_angle": [SOIL["friction_angle"]] * n, "eta_roll": [SOIL["eta_roll"]] * n,
            "eta_twist": [SOIL["eta_roll"]] * n, "normal_cohesion": list(COHESIONS),
            "shear_cohesion": [0.5 * c for c in COHESIONS]}
    t0 = time.perf_counter()
    run = sb.run_soil_bin(cfg, [0] * n, bed=bed, device="cpu", speeds=[0.62] * n, soil_overrides=over)
    bonds = run.series["bonds"]
    pick = np.unique(np.linspace(1, len(run.time) - 1, 23).round().astype(int))
    out["soil_bin"] = {"scale": "cpu", "speed_m_s": 0.62, "spheres_per_world": run.n_spheres,
                       "wall_s": time.perf_counter() - t0,
                       "bonds_vs_travel": {"travel_m": run.travel[pick, 0].tolist(),
                                           "bonds": bonds[pick].T.tolist()},
                       "rows": [
                           {"normal_cohesion_pa": c, "draught_mean_n": r["draught_mean"],
                            "draught_sem_n": r["draught_sem"], "bonds_start": float(bonds[1, w]),
                            "bonds_end": float(bonds[-1, w])}
                           for w, (c, r) in enumerate(zip(COHESIONS, run.steady, strict=True))]}


def shear(out: dict) -> None:
    configs = [sbx.preset("ci", ASSEMBLY_SHEAR, friction_angle=SOIL["friction_angle"], eta_roll=SOIL["eta_roll"],
                          eta_twist=SOIL["eta_roll"], normal_cohesion=c, shear_cohesion=0.5 * c)
               for c in COHESIONS]
    t0 = time.perf_counter()
    res = sbx.run_shear_boxes(configs, "cpu")
    out["shear_box"] = {"scale": "ci", "assembly": ASSEMBLY_SHEAR, "wall_s": time.perf_counter() - t0, "rows": [
        {"normal_cohesion_pa": c, "c_kpa": r.fit.cohesion / 1e3, "phi_deg": r.fit.friction_angle_deg,
         "peaks_kpa": [cv.peak_shear_stress / 1e3 for cv in r.curves]}
        for c, r in zip(COHESIONS, res, strict=True)]}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="docs/runs/cohesion_reach")
    p.add_argument("--only", choices=("soil-bin", "shear-box"), default=None)
    args = p.parse_args()
    out: dict = {"soil": SOIL, "cohesions_pa": list(COHESIONS)}
    if args.only in (None, "soil-bin"):
        soil_bin(out)
    if args.only in (None, "shear-box"):
        shear(out)
    path = Path(args.out) / ("results.json" if args.only is None else f"results_{args.only}.json")
    path.write_text(json.dumps(out, indent=1, default=float) + "\n")
    print(json.dumps(out, indent=1, default=float))


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
