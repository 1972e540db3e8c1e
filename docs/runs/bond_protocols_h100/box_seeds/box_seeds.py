"""The "bonded" soil's shear box on fresh samples, one sample (seed) at a time.

    python docs/runs/bond_protocols_h100/box_seeds/box_seeds.py SCALE DEVICE SEED [SEED ...]

The soil is `calibration.passive_study.SOILS["bonded"]`: GA set 11 with 4x its normal and shear cohesion, bonds
that yield (fragile False), in the box preset's own sample (deposited without friction, bonded at rest) at the
preset's normal stresses (5, 10, 20 kPa). Each seed deposits its own sample. Prints one RESULT line per seed.
"""

import json
import sys
import time

from calibration.passive_study import SOILS
from scenes import shear_box

scale, device, seeds = sys.argv[1], sys.argv[2], [int(s) for s in sys.argv[3:]]
soil = SOILS["bonded"]
for seed in seeds:
    base = shear_box.preset(scale, "C", ga_set=11, seed=seed, fragile=soil["fragile"])
    factor = soil["normal_cohesion"] / base.normal_cohesion
    assert abs(base.friction_angle - soil["friction_angle"]) < 1e-3, (base.friction_angle, soil)
    cfg = base.replace(normal_cohesion=soil["normal_cohesion"], shear_cohesion=factor * base.shear_cohesion)
    t0 = time.perf_counter()
    res = shear_box.run_shear_box(cfg, device)
    print("RESULT", json.dumps({
        "scale": scale, "device": device, "seed": seed, "cohesion_factor": factor,
        "normal_cohesion_pa": cfg.normal_cohesion, "shear_cohesion_pa": cfg.shear_cohesion,
        "normal_stresses_pa": list(cfg.normal_stresses), "cohesion_kpa": res.fit.cohesion / 1e3,
        "friction_angle_deg": res.fit.friction_angle_deg, "r2": res.fit.r2,
        "peak_kpa": [c.peak_shear_stress / 1e3 for c in res.curves], "wall_s": time.perf_counter() - t0}),
        flush=True)
