"""Where a step's time goes: each launch of a step timed on its own, on the deposited bed of ``bed_throughput.py`` or
on a calibration's ringing batch.

    python benchmarks/step_profile.py --device cpu --steps 300
    python benchmarks/step_profile.py --device cuda --bed BED.npz --size 4000000 --steps 100
    python benchmarks/step_profile.py --device cuda --scene ringing --worlds 13 --steps 2000

The step is the one :meth:`warpdem.Simulation.advance` replays (its recorded launches), run op by op with a device
synchronisation after each, so each op's wall time is its own (on CUDA this adds a launch latency per op that a
captured graph does not pay: read the CUDA column as kernel time plus ~5-10 us). On CUDA the kernels' own execution
times (CUDA events, ``wp.timing_begin``) are printed beside it. Rebuilds of the candidate lists are timed as one op
("rebuild"). ``--scene ringing``: the 16-spring ringing rig with the paper's spring spheres, one world per
individual (``--worlds``), at the step a calibration uses (scenes/ringing.py). Prints a table, milliseconds per step
and share of the step, largest first.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
from bed_throughput import bed_scene, deposited_bed, tiled  # benchmarks/bed_throughput.py, beside this script

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def op_name(op: object) -> str:
    """A readable name for one recorded op: the kernel's name, a phase's (shared out between CPU threads), or the
    array method's."""
    if hasattr(op, "parts"):
        return "phase " + op.name + " (" + ", ".join(op_name(o) for o in op.parts[0]) + f") x {len(op.parts)}"
    owner = getattr(op, "__self__", None)
    kernel = getattr(owner, "kernel", None)
    if kernel is not None:
        return kernel.key.split(".")[-1]
    return getattr(op, "__name__", repr(op))


def bed_simulation(pos: np.ndarray, rad: np.ndarray, particle: np.ndarray, device: str, threads: int | None,
                   contact_threads: str = "pair") -> object:
    """The bonded bed of ``bed_throughput.py`` as a Simulation (cohesion set at its first step)."""
    import warpdem as wd

    model, state = bed_scene(pos, rad, particle).finalize(device)
    sim = wd.Simulation(model, state, dt=0.3 * wd.pwave_timestep(model), always_use_moment_law=True,
                        cpu_threads=threads, contact_threads=contact_threads)
    sim.set_cohesion_now()
    return sim


def ringing_simulation(worlds: int, device: str, world_steps: bool = False, lanes: int | None = None,
                       stride: int | None = None) -> object:
    """The ringing rig of ``warpdem calibrate ringing`` (16 springs, the paper's spring spheres), ``worlds`` copies,
    at the time step of scenes.ringing.run_ringing (which runs it with ``world_steps``); ``lanes``, ``stride``:
    threads per world and the stride between those that take items (default: the device's)."""
    import warpdem as wd
    from scenes.ringing import RingingConfig, build_ringing, ringing_dt

    cfg = RingingConfig(springs=(16,) * worlds, spring_model="paper")
    rig = build_ringing(cfg)
    model, state = rig.builder.finalize(device, n_worlds=worlds, overrides=rig.overrides)
    return wd.Simulation(model, state, dt=ringing_dt(cfg, model), world_steps=world_steps, world_lanes=lanes,
                          world_lane_stride=stride)


def advance_per_step(worlds: int, device: str, steps: int, every: int = 57
                     ) -> tuple[dict[str, float], dict[str, dict[str, float]]]:
    """Wall seconds per step of the ringing batch as a calibration advances it (``every`` steps between records),
    stage by stage (one launch per stage; several steps per CUDA graph), a block of threads per world (world_steps,
    the device's layout) and, on CUDA, one warp of 32 threads per world that all take items (world_steps_warp) and
    one thread per world (world_steps_1_lane); on CUDA also each world-step mode's clock cycles per stage
    (:func:`stage_cycles`)."""
    import warp as wp

    out, cycles = {}, {}
    layouts = {"stages": (None, None), "world_steps": (None, None), "world_steps_warp": (32, 1),
               "world_steps_1_lane": (1, 1)}
    modes = ("stages", "world_steps")
    if wp.get_device(device).is_cuda:
        modes += ("world_steps_warp", "world_steps_1_lane")
    for mode in modes:
        lanes, stride = layouts[mode]
        sim = ringing_simulation(worlds, device, world_steps=mode != "stages", lanes=lanes, stride=stride)
        sim.advance(every)
        wp.synchronize_device(device)
        t = time.perf_counter()
        for _ in range(max(1, steps // every)):
            sim.advance(every)
        wp.synchronize_device(device)
        out[mode] = (time.perf_counter() - t) / (max(1, steps // every) * every)
        if mode != "stages" and wp.get_device(device).is_cuda:
            cycles[mode] = stage_cycles(sim, (1 + max(1, steps // every)) * every)
    return out, cycles


def stage_cycles(sim: object, steps: int) -> dict[str, float]:
    """Per step, mean over worlds, the CUDA clock cycles of each stage of a world's step (world_steps.STAGES) with
    its barrier, as lane 0 sees it."""
    from warpdem import world_steps

    c = sim.world_stage_cycles.numpy().reshape(sim.model.n_worlds, len(world_steps.STAGES)) / steps
    return {name: float(c[:, q].mean()) for q, name in enumerate(world_steps.STAGES)}


def profile(sim: object, device: str, steps: int, warmup: int
            ) -> tuple[dict[str, float], float, int, dict[str, float]]:
    """Per-op wall seconds summed over ``steps`` steps, the total, the number of rebuilds, and on CUDA each
    kernel's own execution seconds (CUDA events)."""
    import warp as wp

    sim.advance(warmup)
    ops = sim.step_ops()
    names = [op_name(op) for op in ops]
    times: dict[str, float] = defaultdict(float)
    rebuilds = 0
    wp.synchronize_device(device)
    cuda = wp.get_device(device).is_cuda
    if cuda:
        wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)
    t_all = time.perf_counter()
    for _ in range(steps):
        t = time.perf_counter()
        if sim.contacts.rebuild_flag.numpy()[0]:
            sim.rebuild_lists()
            rebuilds += 1
            wp.synchronize_device(device)
            times["rebuild"] += time.perf_counter() - t
            ops = sim.step_ops()  # a rebuild may have grown (moved) the lists
            names = [op_name(op) for op in ops]
        for op, name in zip(ops, names, strict=True):
            t = time.perf_counter()
            op()
            wp.synchronize_device(device)
            times[name] += time.perf_counter() - t
    total = time.perf_counter() - t_all
    kernels: dict[str, float] = defaultdict(float)
    if cuda:
        for r in wp.timing_end():
            kernels[r.name.removeprefix("forward kernel ")] += 1e-3 * r.elapsed  # elapsed in ms
    return dict(times), total, rebuilds, dict(kernels)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--scene", default="bed", choices=("bed", "ringing"))
    p.add_argument("--worlds", type=int, default=13, help="ringing: worlds (individuals) in the batch")
    p.add_argument("--size", type=int, default=0, help="sphere count (0: the bed once)")
    p.add_argument("--scale", default="cpu", choices=("ci", "cpu", "paper"), help="the deposited bed's scale")
    p.add_argument("--bed", default=None, help="a saved bed (.npz) to use instead")
    p.add_argument("--cache", default=str(Path(__file__).resolve().parent / ".beds"),
                   help="folder of deposited beds (made once; default: benchmarks/.beds)")
    p.add_argument("--steps", type=int, default=300)
    p.add_argument("--warmup", type=int, default=20)
    p.add_argument("--threads", type=int, default=None, help="CPU threads sharing a step (default: all cores)")
    p.add_argument("--json", default=None, help="append the result to this JSON-lines file")
    p.add_argument("--advance", action="store_true",
                   help="ringing: time advance() as a calibration runs it, stage by stage and a thread per world")
    p.add_argument("--lineinfo", action="store_true",
                   help="compile CUDA kernels with line information (for a profiler such as Nsight Compute)")
    p.add_argument("--contact-threads", default="pair", choices=("sphere", "pair"),
                   help="bed: Simulation(contact_threads=...)")
    args = p.parse_args()
    if args.lineinfo:
        import warp as wp

        wp.config.lineinfo = True
    if args.scene == "ringing" and args.advance:
        per, cycles = advance_per_step(args.worlds, args.device, args.steps)
        print(f"ringing, {args.worlds} worlds on {args.device}, advance() in 57-step records: "
              + ", ".join(f"{k} {1e6 * v:.1f} us/step" for k, v in per.items()))
        for mode, c in cycles.items():
            print(f"  {mode}, clock cycles per step of each stage with its barrier (lane 0): "
                  + ", ".join(f"{k} {v:.0f}" for k, v in c.items()))
        if args.json:
            with open(args.json, "a") as f:
                f.write(json.dumps({"scene": "ringing-advance", "device": args.device, "worlds": args.worlds,
                                    "steps": args.steps, "us_per_step": {k: 1e6 * v for k, v in per.items()},
                                    "cycles_per_step": cycles}) + "\n")
        return
    if args.scene == "ringing":
        sim = ringing_simulation(args.worlds, args.device)
    else:
        pos, rad, part = deposited_bed(args.scale, 0, Path(args.cache), args.bed)
        if args.size > len(rad):
            pos, rad, part = tiled(pos, rad, part, args.size)
        sim = bed_simulation(pos, rad, part, args.device, args.threads, args.contact_threads)
    n = sim.model.n_spheres
    times, total, rebuilds, kernels = profile(sim, args.device, args.steps, args.warmup)
    print(f"{args.scene}: {n:,} spheres, {args.steps} steps on {args.device}: {1e3 * total / args.steps:.3f} ms/step "
          f"({n * args.steps / total:.3g} particle-steps/s op by op), {rebuilds} rebuilds")
    print(f"{'op':<60} {'ms/step':>9} {'share':>7}")
    for name, sec in sorted(times.items(), key=lambda kv: -kv[1]):
        print(f"{name:<60} {1e3 * sec / args.steps:9.4f} {100 * sec / total:6.1f}%")
    if kernels:
        print(f"{'kernel (its own execution, CUDA events)':<60} {'ms/step':>9}")
        for name, sec in sorted(kernels.items(), key=lambda kv: -kv[1]):
            print(f"{name:<60} {1e3 * sec / args.steps:9.4f}")
    if args.json:
        with open(args.json, "a") as f:
            f.write(json.dumps({"scene": args.scene, "device": args.device, "threads": args.threads, "spheres": n,
                                "contact_threads": args.contact_threads,
                                "steps": args.steps, "rebuilds": rebuilds, "ms_per_step": 1e3 * total / args.steps,
                                "ops_ms_per_step": {k: 1e3 * v / args.steps for k, v in times.items()},
                                "kernels_ms_per_step": {k: 1e3 * v / args.steps for k, v in kernels.items()}})
                    + "\n")


if __name__ == "__main__":
    main()
