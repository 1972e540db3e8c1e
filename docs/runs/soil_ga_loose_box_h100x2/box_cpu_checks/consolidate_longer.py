"""The calibrated soil's `cpu` shear box on the CPU, consolidated at least TMIN seconds.

    python docs/runs/soil_ga_loose_box_h100x2/box_cpu_checks/consolidate_longer.py TMIN SEED
"""

import json
import sys

from calibration.problems import calibrated_box, calibrated_soil
from scenes import shear_box

tmin, seed = float(sys.argv[1]), int(sys.argv[2])
cal = calibrated_soil("docs/runs/soil_ga_loose_box_h100x2")
cfg = shear_box.preset("cpu", "C", seed=seed, **calibrated_box(cal), consolidation_time=(tmin, max(0.5, tmin)))
d = shear_box.run_shear_box(cfg, "cpu").to_dict()
print(json.dumps({"tmin": tmin, "seed": seed, "t_cons": d["consolidation_time_s"], "c": d["cohesion_pa"],
                  "phi": d["friction_angle_deg"], "por": d["porosity"], "wall": d["wall_s"]}))
