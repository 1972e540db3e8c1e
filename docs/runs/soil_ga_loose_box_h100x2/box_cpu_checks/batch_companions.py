"""The accepted individual's shear box alone and in one batch with four slow-settling individuals (same sample).

    python docs/runs/soil_ga_loose_box_h100x2/box_cpu_checks/batch_companions.py SCALE
"""

import json
import sys

from calibration.genes import soil_fields
from calibration.problems import calibrated_soil
from scenes import shear_box

scale = sys.argv[1]
records = json.load(open("docs/runs/soil_ga_loose_box_h100x2/archive.json"))["records"]
cal = calibrated_soil("docs/runs/soil_ga_loose_box_h100x2")
base = shear_box.preset(scale, "C", fragile=cal["fragile"], **cal["box_changes"])


def config(i: int) -> shear_box.ShearBoxConfig:
    fields = soil_fields(records[i]["genes"])
    return base.replace(**{k: float(v) for k, v in fields.items()}, label=f"individual {i}")


bed = shear_box.make_bed(base, "cpu")
alone = shear_box.run_shear_boxes([config(33)], "cpu", bed=bed)[0]
batch = shear_box.run_shear_boxes([config(i) for i in (33, 53, 57, 12, 51)], "cpu", bed=bed)
print("RESULT", json.dumps({
    "alone": [alone.fit.cohesion, alone.fit.friction_angle_deg, alone.consolidation_time],
    "batch": [[r.fit.cohesion, r.fit.friction_angle_deg, r.consolidation_time] for r in batch],
    "alone_peaks": [c.peak_shear_stress for c in alone.curves],
    "batch_peaks": [c.peak_shear_stress for c in batch[0].curves]}))
