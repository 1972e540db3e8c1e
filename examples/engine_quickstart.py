"""warpdem's engine API in one small, runnable scene (about half a minute on 2 CPU cores).

1. Deposit cohesive spheres and a few two-sphere clumps into an open box (local damping while they settle).
2. Build the cutting scene from the deposited bed: a steel plate (a closed triangle mesh, a free rigid body that may
   only slide along x) is pulled through the bed by a spring from a kinematic carriage. Two worlds in one launch,
   differing only in the soil's friction angle (per-world overrides).
3. Run with observers (the plate's contact force, the spring force), save a checkpoint half way, and continue a
   second simulation from it.

    python examples/engine_quickstart.py [--device cpu|cuda] [--out DIR] [--verbose]

The checkpoint goes to a temporary folder, removed at the end (``--out DIR`` keeps it there); Warp's banner, module
loads and CUDA-driver warning are off unless ``--verbose``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import warp as wp

import warpdem as wd

SOIL = wd.Material(young=1e7, poisson=0.3, density=2650.0, friction_angle=30.0,  # [Pa], [-], [kg/m^3], [deg]
                   normal_cohesion=2e4, shear_cohesion=1e4, moment_law=True, eta_roll=0.1, eta_twist=0.1)
STEEL = wd.Material(young=2e8, poisson=0.3, density=7850.0, friction_angle=25.0)
BOX = (0.20, 0.08, 0.10)  # [m]


def open_box(size: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Floor and four walls of [0, x] x [0, y] x [0, z]: vertices [m] (8, 3), triangles (10, 3)."""
    x, y, z = size
    v = np.array([[0, 0, 0], [x, 0, 0], [x, y, 0], [0, y, 0], [0, 0, z], [x, 0, z], [x, y, z], [0, y, z]], float)
    quads = [(0, 1, 2, 3), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    return v, np.array([[a, b, c] for a, b, c, _ in quads] + [[a, c, d] for a, _, c, d in quads])


def closed_box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """A closed cuboid [lo, hi] [m] as 12 outward-wound triangles (a mesh trimesh can give mass properties)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                  [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], float)
    f = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                  [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])
    return v, f


def deposit(device: str, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Step 1: sphere centres [m] (n, 3) and radii [m] (n,) of the settled bed, in the order they were added (the
    single spheres, then the 4 clumps' two members each)."""
    rng = np.random.default_rng(seed)
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("soil", SOIL)
    b.add_material("steel", STEEL)
    v, f = open_box(BOX)
    b.add_mesh("box", v, f, "steel")
    pitch = 0.0125
    grid = np.stack(np.meshgrid(np.arange(15), np.arange(6), np.arange(5), indexing="ij"), -1).reshape(-1, 3)
    centres = (grid + 0.5) * pitch + np.array([0.006, 0.003, 0.004])
    radii = rng.uniform(0.004, 0.005, len(centres))
    b.add_spheres(centres, radii, "soil", group="soil")                      # (n, 3) [m], (n,) [m]
    for k in range(4):                                                        # rigid clumps: Yade's mass rule
        c = np.array([0.03 + 0.04 * k, 0.04, 0.08])
        b.add_clump(np.array([c - (0.004, 0, 0), c + (0.004, 0, 0)]), np.array([0.005, 0.005]), "soil",
                    group="soil")
    b.set_local_damping("soil", 0.4)                                          # Cundall damping per group
    model, state = b.finalize(device)
    sim = wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model))
    sim.advance(int(0.25 / sim.dt))                                           # 0.25 s of settling
    return sim.data.sphere_pos.numpy(), model.host["sphere_radius"]


def cutting_scene(device: str, centres: np.ndarray, radii: np.ndarray, angles: list[float]
                  ) -> tuple[wd.Model, wd.State]:
    """Step 2: the settled bed (the last 8 spheres are the 4 clumps' members), a plate pulled along +x by a spring
    from a carriage moving at 0.2 m/s, one world per friction angle [deg] in ``angles``."""
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("soil", SOIL)
    b.add_material("steel", STEEL)
    v, f = open_box(BOX)
    b.add_mesh("box", v, f, "steel")
    top = float(np.max(centres[:, 2] + radii))
    lo, hi = np.array([0.004, 0.01, top - 0.03]), np.array([0.010, BOX[1] - 0.01, top + 0.03])  # 30 mm deep
    clear = ~np.all((centres > lo - radii[:, None] - 1e-3) & (centres < hi + radii[:, None] + 1e-3), axis=1)
    n_single = len(radii) - 8
    keep = clear[:n_single]
    b.add_spheres(centres[:n_single][keep], radii[:n_single][keep], "soil", group="soil")
    for k in range(4):
        s = slice(n_single + 2 * k, n_single + 2 * k + 2)
        if clear[s].all():                                                     # no member inside the plate
            b.add_clump(centres[s], radii[s], "soil", group="soil")
    pv, pf = closed_box(tuple(lo), tuple(hi))
    plate = b.add_mesh("plate", pv, pf, "steel", kind="dynamic", blocked="yzXYZ")      # slides along x only
    anchor = np.array([hi[0], BOX[1] / 2, hi[2]])
    ahead = anchor + (0.05, 0.0, 0.0)
    carriage = b.add_rigid_body(ahead, velocity=(0.2, 0.0, 0.0), name="carriage")    # kinematic: DoFs imposed
    b.add_spring("pull", carriage, ahead, plate, anchor, stiffness=2e3, damping=5.0)  # [N/m], [N s/m]
    return b.finalize(device, n_worlds=len(angles), overrides={"material:soil:friction_angle": angles})


def main(device: str | None = None, out: str | Path | None = None) -> dict[str, object]:
    """Run the three steps; returns the series of the run, the continued run's, and the simulations. ``out``: the
    folder of the checkpoint (default: a temporary folder, removed at the end)."""
    device = device or ("cuda" if wp.is_cuda_available() else "cpu")
    centres, radii = deposit(device)
    angles = [20.0, 40.0]
    model, state = cutting_scene(device, centres, radii, angles)
    sim = wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model))
    observers = {"plate": wd.observers.mesh_wrench("plate"),           # (worlds, 2, 3): force [N], moment [N m]
                 "pull": wd.observers.spring_force("pull")}             # (worlds,) [N], tension positive
    n = int(0.3 / sim.dt)
    x0 = sim.state.body_pos.numpy()[:, 0].copy()
    first = sim.run(n // 2, record_every=50, observers=observers)
    with tempfile.TemporaryDirectory(prefix="warpdem_quickstart_") as scratch:
        path = Path(out or scratch) / "quickstart_checkpoint.npz"
        wd.checkpoint.save(sim, path)
        rest = sim.run(n - n // 2, record_every=50, observers=observers)
        again = wd.Simulation(*cutting_scene(device, centres, radii, angles), dt=sim.dt)
        wd.checkpoint.load(again, path)                                # the same scene, continued from the file
    rest_again = again.run(n - n // 2, record_every=50, observers=observers)
    moved = sim.state.body_pos.numpy()[:, 0] - x0
    for w, a in enumerate(angles):
        i = model.bodies_per_world * w + model.names["body"]["plate"]
        print(f"friction {a:.0f} deg: mean spring pull {rest['pull'][:, w].mean():.2f} N over the last 0.15 s; "
              f"the plate moved {1e3 * moved[i]:.1f} mm (the carriage {1e3 * 0.2 * sim.state.time:.0f} mm)")
    return {"first": first, "rest": rest, "rest_again": rest_again, "sim": sim, "again": again}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None, help="Warp device (default: cuda if available, else cpu)")
    parser.add_argument("--out", default=None, help="keep the checkpoint in this folder (default: a temporary one)")
    parser.add_argument("--verbose", action="store_true", help="keep Warp's banner and module-load lines")
    args = parser.parse_args()
    if not args.verbose:
        wd.init_quietly()
    main(args.device, args.out)
