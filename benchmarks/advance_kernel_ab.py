"""The ringing batch's world kernel alone against a calibration's records: the same 13 worlds advanced 11,400 steps
in one advance (one ``world_steps_kernel`` launch: the kernel's own time per step) and in 200 advances of 57 steps
(a calibration's records: host reads and launches between them), then a host profile of the records. With the
long advance, each world's clock cycles per step (lane 0, its four stages summed; and every world's four stages):
the kernel lasts as long as its slowest world.

    cd benchmarks && python3 advance_kernel_ab.py            # on the GPU machine, after its staging
    cd _ab/benchmarks && python3 /path/to/advance_kernel_ab.py  # another tree (gpu_ab.sh's _ab*/ sides)

Run from a tree's ``benchmarks/`` folder: it times the warpdem of that tree. Prints us/step for each, twice.
"""

from __future__ import annotations

import cProfile
import pstats
import sys
import time

sys.path.insert(0, ".")  # this tree's benchmarks/ (step_profile) and warpdem
sys.path.insert(0, "..")


def main() -> None:
    import warp as wp

    wp.config.quiet = True
    from step_profile import ringing_simulation

    sim = ringing_simulation(13, "cuda", world_steps=True)
    sim.advance(1140)
    wp.synchronize_device("cuda")
    for _ in range(2):
        sim.world_stage_cycles.zero_()
        t = time.perf_counter()
        sim.advance(11400)
        wp.synchronize_device("cuda")
        print("one advance(11400): us/step", round(1e6 * (time.perf_counter() - t) / 11400, 2))
        cycles = sim.world_stage_cycles.numpy().reshape(sim.model.n_worlds, -1) / 11400
        total = cycles.sum(axis=1)
        print("  cycles per step of each world (lane 0, stages summed): min", round(total.min()), "mean",
              round(total.mean()), "max", round(total.max()), "; the slowest world's stages",
              [round(c) for c in cycles[total.argmax()]])
        print("  every world's stages (contacts, bodies, spheres, end):",
              "; ".join(" ".join(str(round(c)) for c in row) for row in cycles))
        t = time.perf_counter()
        for _ in range(200):
            sim.advance(57)
        wp.synchronize_device("cuda")
        print("200 x advance(57): us/step", round(1e6 * (time.perf_counter() - t) / 11400, 2))
    profile = cProfile.Profile()
    profile.enable()
    for _ in range(200):
        sim.advance(57)
    wp.synchronize_device("cuda")
    profile.disable()
    pstats.Stats(profile).sort_stats("tottime").print_stats(10)


if __name__ == "__main__":
    main()
