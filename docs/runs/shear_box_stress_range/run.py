"""Does the shear box's cohesion intercept depend on the normal stresses it is fitted over? (issue #38)

The laboratory's dry sand (0.19 % moisture) shows 8.7 kPa of cohesion in its shear box (the paper, section 2.3): an
intercept of a Mohr-Coulomb line through peaks, not capillary bonding. The paper does not give the normal stresses.
This runs warpdem's shear box (ci scale, assembly A, 5 mm members, a dense sample) with GA set 1 (assembly A's set;
the paper's DEM box gave it c = 7.0 kPa, phi = 29.2 deg) with and without its contact cohesion, at 5/10/20 kPa,
at 20/40/80 and 50/100/200 kPa, as one batched simulation (18 worlds), and writes results.json beside this script.

    python docs/runs/shear_box_stress_range/run.py [--device cpu] [--seed 0]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from scenes.shear_box import preset, run_shear_boxes

p = argparse.ArgumentParser()
p.add_argument("--device", default="cpu")
p.add_argument("--seed", type=int, default=0)
args = p.parse_args()
base = preset("ci", "A", ga_set=1, seed=args.seed)
ranges = {"low": (5e3, 10e3, 20e3), "mid": (20e3, 40e3, 80e3), "high": (50e3, 100e3, 200e3)}
configs = []
for name, stresses in ranges.items():
    cfg = base.replace(normal_stresses=stresses, label=f"{name} stresses")
    configs += [cfg, cfg.cohesionless()]
t0 = time.perf_counter()
results = run_shear_boxes(configs, args.device)
rows = []
for cfg, res in zip(configs, results, strict=True):
    rows.append({"label": cfg.label, "normal_stresses_kpa": [s / 1e3 for s in cfg.normal_stresses],
                 "normal_cohesion_pa": cfg.normal_cohesion, "cohesion_kpa": res.fit.cohesion / 1e3,
                 "friction_angle_deg": res.fit.friction_angle_deg, "r2": res.fit.r2,
                 "peaks_kpa": [float(x) / 1e3 for x in res.peak_shear_stress]})
    print(rows[-1])
out = Path(__file__).with_name(f"results_seed{args.seed}.json")
out.write_text(json.dumps({"device": args.device, "seed": args.seed, "wall_s": time.perf_counter() - t0,
                           "rows": rows}, indent=1))
print(f"wrote {out} ({time.perf_counter() - t0:.0f} s)")
