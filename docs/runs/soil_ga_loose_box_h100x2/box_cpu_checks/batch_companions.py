"""The accepted individual's shear box alone and in one batch with other individuals (the same sample).

    python docs/runs/soil_ga_loose_box_h100x2/box_cpu_checks/batch_companions.py SCALE [DEVICE] [COMPANIONS] [fixed]

COMPANIONS: "slow" (default: individuals 53, 57, 12 and 51, eta_roll 0.40-0.83, slow to settle) or "batch3" (every
other individual of the accepted one's GA batch: 13 in all, 39 worlds; in the `cpu` box about 254,000 spheres, past
``warpdem.simulation.LARGE_STEP_SPHERES``, so CUDA steps one step per graph as in the GA, a lone box several).
"fixed": every world consolidates for ``scenes.shear_box.BATCH_CONSOLIDATION`` (what calibrations now use) instead
of the box's adaptive end (what this calibration used).
"""

import json
import sys

from calibration.genes import soil_fields
from calibration.problems import calibrated_soil
from scenes import shear_box

scale = sys.argv[1]
device = sys.argv[2] if len(sys.argv) > 2 else "cpu"
companions = sys.argv[3] if len(sys.argv) > 3 else "slow"
fixed = len(sys.argv) > 4 and sys.argv[4] == "fixed"
records = json.load(open("docs/runs/soil_ga_loose_box_h100x2/archive.json"))["records"]
cal = calibrated_soil("docs/runs/soil_ga_loose_box_h100x2")
base = shear_box.preset(scale, "C", fragile=cal["fragile"], **cal["box_changes"])
if fixed:
    base = base.replace(consolidation_time=(shear_box.BATCH_CONSOLIDATION,) * 2)
others = ([53, 57, 12, 51] if companions == "slow"
          else [r["index"] for r in records if r["batch"] == records[33]["batch"] and r["index"] != 33])


def config(i: int) -> shear_box.ShearBoxConfig:
    fields = soil_fields(records[i]["genes"])
    return base.replace(**{k: float(v) for k, v in fields.items()}, label=f"individual {i}")


bed = shear_box.make_bed(base, device)
alone = shear_box.run_shear_boxes([config(33)], device, bed=bed)[0]
batch = shear_box.run_shear_boxes([config(i) for i in [33, *others]], device, bed=bed)
print("RESULT", json.dumps({
    "device": device, "scale": scale, "companions": others, "consolidation_time": base.consolidation_time,
    "spheres_per_world": len(bed.radii),
    "alone": [alone.fit.cohesion, alone.fit.friction_angle_deg, alone.consolidation_time],
    "batch": [[r.fit.cohesion, r.fit.friction_angle_deg, r.consolidation_time] for r in batch],
    "alone_peaks": [c.peak_shear_stress for c in alone.curves],
    "batch_peaks": [c.peak_shear_stress for c in batch[0].curves]}))
