"""Throughput of what a soil-bin run does: the rigid sweep cutting the deposited assembly-C bed, rebuilds included.

    python benchmarks/soil_bin_throughput.py --device cpu --scale cpu --worlds 2 --threads 1 2

``scenes.soil_bin.run_soil_bin`` as ``warpdem soil-bin`` runs it (the tool placed on the bed, gravity, walls,
the carriage at Table 3's 0.68 m/s over the scale's travel, observers every record), ``--worlds`` rigid worlds in
one simulation, once per ``--threads`` value (CPU threads sharing a step, through ``WARPDEM_CPU_THREADS``). The bed
is deposited once and cached (the same cache as ``bed_throughput.py``). Reported: particle-steps per second
(spheres of all worlds x steps / wall time of the whole call: model build, records and rebuilds included) and the mean
draught of world 0, which must not depend on the number of threads.

    python benchmarks/soil_bin_throughput.py --device cuda --scale paper --worlds 4 --replicas --travel 0.2

``--replicas``: the worlds stand on replica beds 0 .. worlds - 1 of one population (``scenes.replica_beds``; each
deposited once and cached) instead of all on one bed: the same run with the parked particles that a shared layout
needs (reported: spheres per world of the layout, parked ones included, the particles each world simulates, and
the wall time per step to compare with the same worlds on one bed). ``--travel`` [m] shortens the run (default:
the scale's). Each line also gives the setup's wall time (``setup_s``: model build, layout, first lists), the wall
time per step without it (``run_ms_per_step``) and the candidate-list rebuilds (a world's displacement triggers one
for all worlds, so worlds on one bed, moving alike, rebuild together, and distinct beds rebuild more often).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--scale", default="cpu", choices=("ci", "cpu", "paper"))
    p.add_argument("--worlds", type=int, default=2, help="rigid worlds in the simulation")
    p.add_argument("--threads", type=int, nargs="+", default=[0], help="CPU threads per step (0: every core)")
    p.add_argument("--cache", default=str(Path(__file__).resolve().parent / ".beds"),
                   help="folder of deposited beds (made once; default: benchmarks/.beds)")
    p.add_argument("--json", default=None, help="append results to this JSON-lines file")
    p.add_argument("--replicas", action="store_true", help="each world on its own replica bed")
    p.add_argument("--travel", type=float, default=None, help="[m] of travel (default: the scale's)")
    args = p.parse_args()

    import warp as wp

    wp.config.quiet = True
    from scenes.soil_bin import SoilBinConfig, bed_for, run_soil_bin

    config = SoilBinConfig(scale=args.scale, assembly="C", springs=(0,), speed=(0.68,), travel=args.travel,
                           steady_travel=0.5 * args.travel if args.travel else None)
    if args.replicas:
        bed = [bed_for(config, device=args.device, cache_dir=args.cache, replica=r) for r in range(args.worlds)]
    else:
        bed = bed_for(config, device=args.device, cache_dir=args.cache)
    for threads in args.threads:
        if threads:
            os.environ["WARPDEM_CPU_THREADS"] = str(threads)
        else:
            os.environ.pop("WARPDEM_CPU_THREADS", None)
        run = run_soil_bin(config, [0] * args.worlds, bed=bed, device=args.device)
        scene = "soil bin, rigid sweep" + (", replica beds" if args.replicas else "")
        res = {"engine": "warpdem", "scene": scene, "device": args.device, "scale": args.scale,
               "threads": threads or "all", "worlds": args.worlds, "spheres": run.n_spheres * args.worlds,
               "steps": run.steps, "wall_s": run.wall_s,
               # with replica beds the layout's spheres include parked ones: compare wall_ms_per_step instead
               "particle_steps_per_s": None if args.replicas else run.n_spheres * args.worlds * run.steps / run.wall_s,
               "draught_mean_n": run.steady[0]["draught_mean"], "particles_simulated": run.n_particles,
               "wall_ms_per_step": 1e3 * run.wall_s / run.steps, "setup_s": run.setup_s, "rebuilds": run.rebuilds,
               "run_ms_per_step": 1e3 * (run.wall_s - run.setup_s) / run.steps}
        print(json.dumps(res))
        if args.json:
            with open(args.json, "a") as f:
                f.write(json.dumps(res) + "\n")


if __name__ == "__main__":
    main()
