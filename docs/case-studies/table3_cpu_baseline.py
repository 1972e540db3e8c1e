"""Table 3 at `cpu` scale: the baseline soil-bin rig alone (GA set 11) and its simulation standard errors.

    python docs/case-studies/table3_cpu_baseline.py [DEVICE]     # prints one JSON line (table3_cpu_baseline.json)
"""

import json
import sys
import time

from calibration import measured
from calibration.rig_models import Case, SoilBinRigModel

t0 = time.time()
rig = SoilBinRigModel(measured.from_paper("soil-bin"), device=sys.argv[1] if len(sys.argv) > 1 else None,
                      scale="cpu", cache_dir="results/beds",
                      observables=("reduction", "displacement_mean", "rigid_draught_mean", "draught_mean"))
rig.bed()
bed_s = time.time() - t0
sem = rig.simulation_sigma  # simulates the baseline once (cached)
base = rig.simulate([Case(j, {}) for j in range(rig.n_configs)]).values
print(json.dumps({"wall_s": time.time() - t0, "bed_s": bed_s, "observables": rig.observables,
                  "baseline": base.tolist(), "sim_sem": sem.tolist(), "measured": rig.measured.tolist()}))
