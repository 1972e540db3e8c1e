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

    python benchmarks/soil_bin_throughput.py --device cuda --scale paper --worlds 4 --travel 0.2 --skin-factor 0.2 0.8

``--skin-factor F ...``: one run per factor, the contact lists' skin F x the mean sphere radius
(``run_soil_bin``'s ``skin_factor``; the engine's default 0.2): a larger skin rebuilds less often and holds more
candidates per sphere; the records are the same (tests/test_broadphase.py), only the speed changes.

    python benchmarks/soil_bin_throughput.py --device cuda --scale paper --worlds 4 --travel 0.2 --kernel-times 25

``--kernel-times N`` (CUDA): Warp's activity timing (``wp.timing_begin``) over the whole run, setup included: the
N activities (kernels, copies, memsets) of most GPU time with their launches and time per step, their sum against
the run's wall time (the rest is the host's), then a line of JSON per activity (``"activity"``) to the ``--json``
file. The timing itself slows the launches: read the shares, not the throughput, of such a run. A step's kernels run
in a CUDA graph, which the timing sees as one activity (``graph``); ``--no-graphs`` launches them one by one
(``Simulation(graph_steps=1)``) so that each kernel is seen, at the cost of the launches' host time.

    python benchmarks/soil_bin_throughput.py --device cpu --scale cpu --worlds 1 --travel 0.2 --rebuild-stats

``--rebuild-stats``: at every list rebuild, the spheres' displacements since the previous build (read on the host
before the broad phase runs; slow on CUDA): the median over the rebuilds of their largest, 99.9th, 99th and 90th
percentile and median [m], against the skin, and where the largest was. What a skin sized per sphere could gain.
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
    p.add_argument("--kernel-times", type=int, default=0, metavar="N",
                   help="CUDA: print the N activities of most GPU time (Warp's activity timing)")
    p.add_argument("--no-graphs", action="store_true",
                   help="launch each step's kernels one by one (Simulation(graph_steps=1)), no CUDA graphs")
    p.add_argument("--skin-factor", type=float, nargs="+", default=[None], metavar="F",
                   help="the contact lists' skin as F x the mean sphere radius, one run each (default: the engine's "
                        "0.2)")
    p.add_argument("--rebuild-stats", action="store_true",
                   help="the spheres' displacements between list rebuilds (host reads at every rebuild)")
    args = p.parse_args()

    import warp as wp

    wp.config.quiet = True
    from scenes.soil_bin import SoilBinConfig, bed_for, run_soil_bin
    from warpdem.simulation import SKIN_FACTOR

    if args.no_graphs:  # every Simulation of this process without captured graphs (a benchmark's switch)
        import functools

        import warpdem

        warpdem.Simulation.__init__ = functools.partialmethod(warpdem.Simulation.__init__, graph_steps=1)
    stats: list[tuple] = []
    if args.rebuild_stats:
        watch_rebuilds(stats)

    config = SoilBinConfig(scale=args.scale, assembly="C", springs=(0,), speed=(0.68,), travel=args.travel,
                           steady_travel=0.5 * args.travel if args.travel else None)
    if args.replicas:
        bed = [bed_for(config, device=args.device, cache_dir=args.cache, replica=r) for r in range(args.worlds)]
    else:
        bed = bed_for(config, device=args.device, cache_dir=args.cache)
    for threads, skin in [(n, f) for n in args.threads for f in args.skin_factor]:
        if threads:
            os.environ["WARPDEM_CPU_THREADS"] = str(threads)
        else:
            os.environ.pop("WARPDEM_CPU_THREADS", None)
        if args.kernel_times:
            wp.timing_begin(cuda_filter=wp.TIMING_ALL)
        run = run_soil_bin(config, [0] * args.worlds, bed=bed, device=args.device, skin_factor=skin)
        if args.kernel_times:
            activity_table(wp.timing_end(), run.steps, run.wall_s, args.kernel_times, args.json)
        if args.rebuild_stats:
            rebuild_table(stats)
            stats.clear()
        scene = "soil bin, rigid sweep" + (", replica beds" if args.replicas else "") + \
            (", no graphs" if args.no_graphs else "")
        res = {"engine": "warpdem", "scene": scene, "device": args.device, "scale": args.scale,
               "threads": threads or "all", "skin_factor": skin or SKIN_FACTOR, "worlds": args.worlds,
               "spheres": run.n_spheres * args.worlds,
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


def watch_rebuilds(out: list) -> None:
    """Wrap the broad phase's build (a benchmark's probe, for this process): before each rebuild, append the
    spheres' displacements since the previous build [m] (ns,), the skin [m] and the position of the sphere that moved
    most [m] (3,)."""
    import numpy as np

    import warpdem.broadphase as bp

    build = bp.build

    def probed(grid, cell, skin, model, state, data, contacts, parts=None):  # noqa: ANN001, ANN202
        x = data.sphere_pos.numpy()
        d = np.linalg.norm(x - contacts.build_pos.numpy(), axis=1)
        if d.max() > 0.0:  # not the first build
            out.append((d, skin, x[d.argmax()]))
        return build(grid, cell, skin, model, state, data, contacts, parts)

    bp.build = probed


def rebuild_table(stats: list) -> None:
    """Print the median over the rebuilds of the displacements' largest, 99.9th, 99th, 90th percentile and median."""
    import numpy as np

    if not stats:
        print("no rebuild after the first build")
        return
    q = np.array([[d.max(), *np.percentile(d, (99.9, 99.0, 90.0, 50.0))] for d, _, _ in stats])
    med = np.median(q, axis=0)
    at = np.array([x for _, _, x in stats])
    print(f"{len(stats)} rebuilds, skin {stats[0][1]:.4g} m; displacement since the last build, median over the "
          f"rebuilds [m]: largest {med[0]:.3g}, 99.9 % {med[1]:.3g}, 99 % {med[2]:.3g}, 90 % {med[3]:.3g}, "
          f"median {med[4]:.3g}; the largest at x, y, z [m] (median) {np.round(np.median(at, axis=0), 3)}")


def activity_table(results: list, steps: int, wall_s: float, top: int, json_path: str | None) -> None:
    """Warp's timing results (``wp.timing_end()``) summed per activity name: the ``top`` of most GPU time printed
    (total [ms], launches, [us] per step, share of all GPU time), every activity as a JSON line to ``json_path``."""
    total: dict[str, list[float]] = {}
    for r in results:
        name = r.name.split("(")[0]
        t = total.setdefault(name, [0.0, 0])
        t[0] += r.elapsed
        t[1] += 1
    gpu_ms = sum(t[0] for t in total.values())
    launches = sum(t[1] for t in total.values())
    print(f"GPU activity {gpu_ms / 1e3:.2f} s of {wall_s:.2f} s wall ({launches / steps:.1f} activities per step,"
          f" {steps} steps)")
    rows = sorted(total.items(), key=lambda kv: -kv[1][0])
    for name, (ms, n) in rows[:top]:
        print(f"  {ms:9.1f} ms {n:8d} x {1e3 * ms / steps:8.2f} us/step {100 * ms / gpu_ms:5.1f} %  {name[:90]}")
    if json_path:
        with open(json_path, "a") as f:
            for name, (ms, n) in rows:
                f.write(json.dumps({"activity": name, "ms": ms, "count": n, "steps": steps}) + "\n")


if __name__ == "__main__":
    main()
