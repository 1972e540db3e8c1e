"""Timestep throughput: particle-steps per second on a dense cohesive sphere packing with rolling resistance.

    python benchmarks/throughput.py --device cpu --sizes 1000 8000 27000 --yade
    python benchmarks/throughput.py --device cuda --sizes 1000000 4000000 16000000

The packing: spheres of radius 5 mm (+0..1 %, seeded) on a cubic lattice of pitch 1.995 r, so each sphere overlaps
its 6 lattice neighbours; every contact is made cohesive at the first step (Cn = Cs = 1e6 Pa), the moment
law is on (eta_roll = eta_twist = 0.3, always_use_moment_law), E = 1e7 Pa, no gravity, no damping, dt = 0.3 x the
P-wave step. The bonds hold the lattice, so every step evaluates ~3 contacts per sphere with the full law.
With ``--yade`` the same scene runs in Yade 2023.02a (``yade -n -j2``) and the ratio warpdem/Yade is printed.
Warp's CPU backend runs each kernel on one thread; Yade's -j2 uses two OpenMP threads.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

R = 0.005
PITCH = 1.995 * R
MAT = dict(young=1e7, poisson=0.3, density=2700.0, friction_angle=30.0, normal_cohesion=1e6, shear_cohesion=1e6,
           moment_law=True, eta_roll=0.3, eta_twist=0.3)


def lattice(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    side = int(round(n ** (1 / 3)))
    idx = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    pos = idx * PITCH
    rad = R * rng.uniform(1.0, 1.01, len(idx))
    # every lattice neighbour overlaps by 0.005 r .. 0.025 r (forces up to ~6 N, bonds hold 25 N)
    return pos, rad


def timed_run(builder: object, device: str, steps: int, warmup: int, threads: int | None = None,
              contact_threads: str = "pair") -> tuple[object, float, float]:
    """Build ``builder``'s scene on ``device``, bond every contact at the first step (moment law on, no damping,
    dt = 0.3 x the P-wave step), run ``warmup`` steps, then time ``steps``: (simulation, setup [s], wall [s]).
    ``contact_threads``: Simulation's option of that name."""
    import warp as wp

    import warpdem as wd

    t0 = time.time()
    model, state = builder.finalize(device)
    sim = wd.Simulation(model, state, dt=0.3 * wd.pwave_timestep(model), always_use_moment_law=True,
                        graph_steps=min(200, steps), cpu_threads=threads, contact_threads=contact_threads)
    sim.set_cohesion_now()
    setup = time.time() - t0
    sim.advance(warmup)
    wp.synchronize_device(device)
    t = time.time()
    sim.advance(steps)
    wp.synchronize_device(device)
    return sim, setup, time.time() - t


def run_warpdem(n: int, device: str, steps: int, warmup: int, threads: int | None = None) -> dict:
    import warp as wp

    wp.config.quiet = True
    import warpdem as wd

    pos, rad = lattice(n)
    b = wd.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_material("soil", wd.Material(**MAT))
    b.add_spheres(pos, rad, "soil")
    sim, setup, wall = timed_run(b, device, steps, warmup, threads)
    model = sim.model
    counts = sim.contacts.ss.count.numpy()
    contacts = int(wd.observers.contact_count(sim).sum()) if n <= 100_000 else int(counts.sum())
    return {"engine": "warpdem", "device": str(model.device), "threads": sim.parts, "spheres": len(pos),
            "steps": steps,
            "wall_s": wall, "particle_steps_per_s": len(pos) * steps / wall, "setup_s": setup,
            "contacts_or_candidates": contacts, "rebuilds": sim.rebuild_count}


YADE_TIMED_RUN = r"""
O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D()], [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True)],
                    [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True, always_use_moment_law=True)]),
    NewtonIntegrator(gravity=(0, 0, 0), damping=0.0)]
O.dt = 0.3 * PWaveTimeStep()
O.run(cfg["warmup"], True)
t = time.time(); O.run(cfg["steps"], True); wall = time.time() - t
"""
"""the Yade scripts' engines (the cohesive-frictional law, no gravity, no damping) and their timed run."""

YADE_SCRIPT = r"""
import json, time, numpy as np
cfg = json.load(open(CFG))
pos = np.load(cfg["pos"]); rad = np.load(cfg["rad"])
m = O.materials.append(CohFrictMat(young=1e7, poisson=0.3, density=2700, frictionAngle=np.radians(30),
    normalCohesion=1e6, shearCohesion=1e6, momentRotationLaw=True, etaRoll=0.3, etaTwist=0.3, isCohesive=True))
for p, r in zip(pos, rad):
    O.bodies.append(sphere(tuple(p), float(r), material=m))
""" + YADE_TIMED_RUN + r"""
json.dump({"engine": "yade -j2", "spheres": len(pos), "steps": cfg["steps"], "wall_s": wall,
           "particle_steps_per_s": len(pos) * cfg["steps"] / wall, "contacts": O.interactions.countReal()},
          open(cfg["out"], "w"))
"""


def run_yade_script(script: str, arrays: dict[str, np.ndarray], steps: int, warmup: int) -> dict | None:
    """Run a Yade benchmark script (``yade -n -j2``; None without Yade). The script reads ``CFG``, a JSON file
    naming each array's .npy file under its key, ``steps``, ``warmup`` and ``out``, and writes its result there."""
    if shutil.which("yade") is None:
        return None
    with tempfile.TemporaryDirectory() as d:
        cfg = {"steps": steps, "warmup": warmup, "out": os.path.join(d, "out.json")}
        for name, a in arrays.items():
            cfg[name] = os.path.join(d, f"{name}.npy")
            np.save(cfg[name], a)
        json.dump(cfg, open(os.path.join(d, "cfg.json"), "w"))
        path = os.path.join(d, "bench.py")
        open(path, "w").write(f"CFG = {os.path.join(d, 'cfg.json')!r}\n" + script)
        subprocess.run(["yade", "-n", "-j2", "-x", path], check=True, capture_output=True)
        return json.load(open(cfg["out"]))


def run_yade(n: int, steps: int, warmup: int) -> dict | None:
    pos, rad = lattice(n)
    return run_yade_script(YADE_SCRIPT, {"pos": pos, "rad": rad}, steps, warmup)


def emit(res: list[dict], yade: dict | None, json_path: str | None) -> None:
    """Print warpdem's result (res[0], with its ratio to Yade's when ``yade`` is given) and Yade's, one JSON line
    each, appending them to ``json_path`` if given."""
    if yade:
        res.append(yade)
        res[0]["ratio_to_yade"] = res[0]["particle_steps_per_s"] / yade["particle_steps_per_s"]
    for r in res:
        print(json.dumps(r))
        sys.stdout.flush()
        if json_path:
            with open(json_path, "a") as f:
                f.write(json.dumps(r) + "\n")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--sizes", type=int, nargs="+", default=[1000, 8000, 27000])
    p.add_argument("--steps", type=int, default=0, help="timed steps (default: scaled to the size)")
    p.add_argument("--threads", type=int, default=None, help="CPU threads sharing a step (default: all cores)")
    p.add_argument("--yade", action="store_true", help="also run the scene in Yade 2023.02a (-j2)")
    p.add_argument("--json", default=None, help="append results to this JSON-lines file")
    args = p.parse_args()
    for n in args.sizes:
        steps = args.steps or int(np.clip(2e8 / n if "cuda" in args.device else 4e6 / n, 100, 4000))
        res = [run_warpdem(n, args.device, steps, warmup=min(200, steps), threads=args.threads)]
        emit(res, run_yade(n, steps, warmup=20) if args.yade else None, args.json)


if __name__ == "__main__":
    main()
