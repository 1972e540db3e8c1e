import sys
sys.path.insert(0, "tests")
from dataclasses import replace
import numpy as np
from scenes import soil_bin as sb
DEVICE = "cuda"
CFG = sb.SoilBinConfig(scale="ci", springs=(0,), travel=0.05, steady_travel=0.02)
beds = [sb.bed_for(CFG, device=DEVICE, replica=r) for r in range(2)]
for order in [(0, 1), (1, 0)]:
    pair = [beds[k] for k in order]
    tool = sb.place_tool(pair, CFG.working_depth)
    model, _, _ = sb._build(CFG, pair, tool, [0, 0], [0.68, 0.68], DEVICE)
    cfg = replace(CFG, dt=sb.default_dt(model, CFG.spring_model, rigid=True))
    run = sb.run_soil_bin(cfg, [0, 0], bed=pair, device=DEVICE, speeds=[0.68, 0.68], tool=tool, place=False)
    alone = sb.run_soil_bin(cfg, [0], bed=pair[0], device=DEVICE, speeds=[0.68], tool=tool, place=False)
    d = alone.series["draught"][:, 0]
    print("order", order, "n", len(d), "nonzero", np.count_nonzero(d), "max", np.abs(d).max(),
          "world1 max", np.abs(run.series["draught"][:, 1]).max(), "equal", np.array_equal(run.series["draught"][:, 0], d),
          "coord equal", np.array_equal(run.series["coordination"][:, 0], alone.series["coordination"][:, 0]))
    print("  offsets", [r["surface_offset"] for r in run.steady], "tool", tool)
    print("  draught", np.round(d, 1).tolist())
