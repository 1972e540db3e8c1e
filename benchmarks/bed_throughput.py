"""Timestep throughput on a deposited soil bed (what a soil bin runs), beside the lattice of ``throughput.py``.

    python benchmarks/bed_throughput.py --device cpu --yade                     # one cpu-scale bed, and Yade -j2
    python benchmarks/bed_throughput.py --device cuda --bed BED.npz --sizes 1000000 4000000 16000000

The bed: assembly C (single spheres and three-sphere elongated clumps) deposited under gravity by
``scenes.assemblies`` at the ``cpu`` soil-bin scale (``--scale``), its spheres in the order deposition leaves them
(no spatial sort). For sizes above the bed's, copies of the bed are laid side by side on a grid with a gap of two
particle sizes (no contacts across copies), copy after copy in memory. The law as the soil bin runs it, less the
tool and the walls: cohesive-frictional contacts with rolling and twisting resistance (CohFrictMat, E = 1e7 Pa,
nu = 0.4, 30 deg, Cn = Cs = 1e6 Pa so that the bonds set at the first step hold the bed without gravity or walls,
eta_roll = eta_twist = 0.3, always_use_moment_law), clumps as rigid bodies, no gravity, no damping, dt = 0.3 x the
P-wave step. With ``--yade`` the same bed (the same clumps, the same material) runs in Yade 2023.02a
(``yade -n -j2``) and the ratio warpdem / Yade is printed. Warp's CPU backend runs each kernel on one thread.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from throughput import YADE_TIMED_RUN, emit, run_yade_script, timed_run  # benchmarks/throughput.py, beside this script

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

MAT = dict(young=1e7, poisson=0.4, density=2700.0, friction_angle=30.0, normal_cohesion=1e6, shear_cohesion=1e6,
           moment_law=True, eta_roll=0.3, eta_twist=0.3)


def deposited_bed(scale: str, seed: int, cache: Path, path: str | None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bed's sphere centres [m] (n, 3), radii [m] (n,) and particle index (n,): read from ``path`` (a saved
    bed, e.g. one of a paper-scale run's) or deposited once on the CPU and cached."""
    from scenes.assemblies import Bed
    from scenes.soil_bin import SoilBinConfig, bed_for

    if path:
        bed = Bed.load(path)
    else:
        bed = bed_for(SoilBinConfig(scale=scale, assembly="C", seed=seed), device="cpu", cache_dir=cache)
    return bed.centres, bed.radii, bed.particle


def tiled(centres: np.ndarray, radii: np.ndarray, particle: np.ndarray, n_min: int
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Copies of the bed on an x-y grid (gap: 4 x the largest radius) until it holds at least ``n_min`` spheres."""
    copies = max(1, int(np.ceil(n_min / len(radii))))
    nx = int(np.ceil(np.sqrt(copies)))
    span = centres.max(axis=0) - centres.min(axis=0) + 4.0 * radii.max()
    pos, rad, part = [], [], []
    for c in range(copies):
        shift = np.array([(c % nx) * span[0], (c // nx) * span[1], 0.0])
        pos.append(centres + shift)
        rad.append(radii)
        part.append(particle + c * (particle.max() + 1))
    return np.concatenate(pos), np.concatenate(rad), np.concatenate(part)


def cell_ordered(pos: np.ndarray, rad: np.ndarray, particle: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The same bed with its particles renumbered along a Morton (Z-order) curve of cells of one particle size (a
    clump's members stay together): what a spatial sort in the engine would give."""
    starts = np.flatnonzero(np.r_[True, np.diff(particle) != 0])
    ends = np.r_[starts[1:], len(particle)]
    cell = np.floor((pos[starts] - pos.min(axis=0)) / (4.0 * rad.max())).astype(np.uint64)
    code = np.zeros(len(starts), np.uint64)
    for bit in range(21):
        for axis in range(3):
            code |= ((cell[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    order = np.concatenate([np.arange(starts[k], ends[k]) for k in np.argsort(code, kind="stable")])
    new_particle = np.repeat(np.arange(len(starts)), (ends - starts)[np.argsort(code, kind="stable")])
    return pos[order], rad[order], new_particle


def bed_scene(pos: np.ndarray, rad: np.ndarray, particle: np.ndarray) -> object:
    """A ModelBuilder of the bed (assembly C clumps, the benchmark's material MAT, no gravity, no walls)."""
    import warp as wp

    wp.config.quiet = True
    import warpdem as wd
    from scenes.assemblies import AssemblySpec, Bed

    b = wd.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_material("soil", wd.Material(**MAT))
    Bed(AssemblySpec(kind="C"), (1.0, 1.0, 1.0), 0.1, pos, rad, particle).add_to(b, "soil")
    return b


def run_warpdem(pos: np.ndarray, rad: np.ndarray, particle: np.ndarray, device: str, steps: int, warmup: int,
                scene: str, threads: int | None = None, contact_threads: str = "pair") -> dict:
    import warpdem as wd

    sim, setup, wall = timed_run(bed_scene(pos, rad, particle), device, steps, warmup, threads, contact_threads)
    model = sim.model
    contacts = int(wd.observers.contact_count(sim).sum()) if len(rad) <= 100_000 else -1
    return {"engine": "warpdem", "scene": scene, "device": str(model.device), "threads": sim.parts,
            "contact_threads": contact_threads,
            "spheres": len(rad),
            "particles": int(len(np.unique(particle))), "steps": steps, "wall_s": wall,
            "particle_steps_per_s": len(rad) * steps / wall, "setup_s": setup, "contacts": contacts,
            "rebuilds": sim.rebuild_count}


YADE_SCRIPT = r"""
import json, time, numpy as np
cfg = json.load(open(CFG))
pos = np.load(cfg["pos"]); rad = np.load(cfg["rad"]); part = np.load(cfg["part"])
m = O.materials.append(CohFrictMat(young=1e7, poisson=0.4, density=2700, frictionAngle=np.radians(30),
    normalCohesion=1e6, shearCohesion=1e6, momentRotationLaw=True, etaRoll=0.3, etaTwist=0.3, isCohesive=True))
starts = np.flatnonzero(np.r_[True, np.diff(part) != 0]); ends = np.r_[starts[1:], len(part)]
for s, e in zip(starts, ends):
    members = [sphere(tuple(pos[k]), float(rad[k]), material=m) for k in range(s, e)]
    if len(members) == 1:
        O.bodies.append(members[0])
    else:
        O.bodies.appendClumped(members)
""" + YADE_TIMED_RUN + r"""
json.dump({"engine": "yade -j2", "scene": "deposited bed C", "spheres": len(pos), "steps": cfg["steps"],
           "wall_s": wall, "particle_steps_per_s": len(pos) * cfg["steps"] / wall,
           "contacts": O.interactions.countReal()}, open(cfg["out"], "w"))
"""


def run_yade(pos: np.ndarray, rad: np.ndarray, particle: np.ndarray, steps: int, warmup: int) -> dict | None:
    return run_yade_script(YADE_SCRIPT, {"pos": pos, "rad": rad, "part": particle}, steps, warmup)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--sizes", type=int, nargs="+", default=[0], help="sphere counts (0: the bed once)")
    p.add_argument("--scale", default="cpu", choices=("ci", "cpu", "paper"), help="the deposited bed's scale")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--cache", default=str(Path(__file__).resolve().parent / ".beds"),
                   help="folder of deposited beds (made once; default: benchmarks/.beds)")
    p.add_argument("--bed", default=None, help="a saved bed (.npz) to use instead (e.g. a paper-scale run's)")
    p.add_argument("--steps", type=int, default=0, help="timed steps (default: scaled to the size)")
    p.add_argument("--sorted", action="store_true", help="renumber the particles along a Morton curve first")
    p.add_argument("--threads", type=int, default=None, help="CPU threads sharing a step (default: all cores)")
    p.add_argument("--yade", action="store_true", help="also run the bed in Yade 2023.02a (-j2)")
    p.add_argument("--json", default=None, help="append results to this JSON-lines file")
    p.add_argument("--contact-threads", nargs="+", default=["pair"], choices=("sphere", "pair"),
                   help="Simulation(contact_threads=...): each given one is timed in turn")
    args = p.parse_args()
    base = deposited_bed(args.scale, args.seed, Path(args.cache), args.bed)
    for n in args.sizes:
        pos, rad, part = tiled(*base, n)
        if args.sorted:
            pos, rad, part = cell_ordered(pos, rad, part)
        steps = args.steps or int(np.clip((2e8 if "cuda" in args.device else 4e6) / len(rad), 100, 4000))
        scene = "deposited bed C" + (", Morton order" if args.sorted else "")
        res = [run_warpdem(pos, rad, part, args.device, steps, warmup=min(200, steps), scene=scene,
                           threads=args.threads, contact_threads=ct) for ct in args.contact_threads]
        emit(res, run_yade(pos, rad, part, steps, warmup=20) if args.yade else None, args.json)


if __name__ == "__main__":
    main()
