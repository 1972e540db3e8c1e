"""Golden bits: SHA-256 hashes of small CPU scenes that run every stage and path of the engine's step.

A refactoring of the engine that must not change a result (issue #40) checks that these hashes stay the same: the
final body poses and velocities, sphere kinematics, force and torque sums, spring forces, energies, counters and
the contact lists with their history, per scene. The scenes (all on the CPU, a few seconds each once compiled):

- ``packing_sphere`` / ``packing_pair``: 40 cohesive spheres with the moment law (rolling and twisting) on a
  floor triangle pair, three worlds with per-world friction and damping, energies tracked; contacts a thread per
  sphere / a thread per candidate; stage by stage.
- ``packing_worlds``: the same a thread per world, many steps per launch (``world_steps``), with a cohesion step
  (distance bonding) half way and pose records inside the world kernel (``Simulation.run``'s pose observers).
- ``plate_clumps`` / ``plate_clumps_worlds``: spheres and two-sphere clumps in an open box, a dynamic plate (a
  closed mesh sliding along x) pulled through them by a spring from a kinematic carriage, two worlds; stage by
  stage / world steps.
- ``ringing_paper``: the ringing rig (hinged sweep on a pivot, spring spheres against the blade mesh), two
  worlds, world steps, damping changed by the setter between two advances.
- ``ringing_linear``: the linear-spring ringing rig with pivot friction, a progressive stack and a riding load
  (pin spring, preloaded massless force), stage by stage.
- ``soil_bin_passive``: the ci soil bin (assembly C's clumps, the committed ci bed) with a passive tool on its
  springs and carriage (stop stiffness, preload), bonds set at the first step, a few hundred steps.
- ``checkpoint``: a packing run saved half way, loaded into a new simulation and continued (its hash; the
  uninterrupted run must give the same bits, checked here for the state, forces, energies and the sphere-sphere
  history as tests/test_checkpoint.py does).
- ``threads2``: 4,200 spheres in a box shared between two CPU threads (the barrier path), a few dozen steps.

    python benchmarks/golden_bits.py            # print the hashes and compare with golden_bits.json
    python benchmarks/golden_bits.py --record   # write golden_bits.json
    python benchmarks/golden_bits.py --only packing_sphere,checkpoint

The model is built with machine-independent arithmetic: the bodies' principal axes by Jacobi rotations
(``warpdem.mass.symmetric_eigen``), the builder's frame changes and vector norms element-wise (``mass.rows_times``,
``mass.norm``), not by LAPACK / BLAS, whose OpenBLAS kernels (chosen by the CPU) rounded the last bits differently on
two x86-64 machines.
The hashes are the same with ``OPENBLAS_CORETYPE`` Prescott, Haswell, SkylakeX and unset (checked on this project's
machine).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import warpdem as wd  # noqa: E402

GOLDEN = Path(__file__).with_suffix(".json")
DEVICE = "cpu"
SOIL = wd.Material(young=1e7, poisson=0.3, density=2650.0, friction_angle=30.0, normal_cohesion=2e4,
                   shear_cohesion=1e4, moment_law=True, eta_roll=0.1, eta_twist=0.1)
STEEL = wd.Material(young=2e8, poisson=0.3, density=7850.0, friction_angle=25.0)
PLATE_STEPS = 8000
"""steps of the plate scenes (the plate meets the first spheres after about 3,000)."""


# ----------------------------------------------------------------------------- hashing
def digest(sim: wd.Simulation) -> dict[str, str]:
    """SHA-256 (hex, first 16 digits) of each group of final arrays, and of all of them ("all")."""
    s, d, c = sim.state, sim.data, sim.contacts
    groups = {
        "state": [getattr(s, k).numpy() for k in s.ARRAYS] + [np.array([s.time, s.step])],
        "spheres": [d.sphere_pos.numpy(), d.sphere_vel.numpy(), d.sphere_angvel.numpy(), d.sphere_arm.numpy()],
        "forces": [d.body_force.numpy(), d.body_torque.numpy(), d.mesh_force.numpy(), d.mesh_torque.numpy(),
                   d.mesh_force_sum.numpy(), d.spring_force.numpy()],
        "energy": [d.energy.numpy()],
        "lists": [c.ss.start.numpy(), c.ss.count.numpy(), c.ss.key_a.numpy(), c.ss.hist.numpy(),
                  c.st.start.numpy(), c.st.count.numpy(), c.st.key_a.numpy(), c.st.key_b.numpy(), c.st.hist.numpy()],
        "counters": [d.counters.numpy(), d.fault.numpy(), sim.control.group_damping.numpy(),
                     sim.control.pivot_vel.numpy()],
    }
    out = {}
    total = hashlib.sha256()
    for name, arrays in groups.items():
        h = hashlib.sha256()
        for a in arrays:
            b = np.ascontiguousarray(a).tobytes()
            h.update(b)
            total.update(b)
        out[name] = h.hexdigest()[:16]
    out["all"] = total.hexdigest()
    return out


# ----------------------------------------------------------------------------- scenes
def _packing(n_worlds: int = 3) -> tuple[wd.Model, wd.State]:
    from test_worlds import packing_scene

    over = {"material:soil:friction_angle": np.array([20.0, 30.0, 40.0])[:n_worlds],
            "damping:soil": np.array([0.1, 0.3, 0.5])[:n_worlds]}
    return packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=n_worlds, overrides=over)


def packing_sphere() -> wd.Simulation:
    sim = wd.Simulation(*_packing(), dt=2e-5, cohesion_on_new_contacts=True, track_energy=True,
                        contact_threads="sphere")
    sim.advance(15000)
    return sim


def packing_pair() -> wd.Simulation:
    sim = wd.Simulation(*_packing(), dt=2e-5, cohesion_on_new_contacts=True, track_energy=True,
                        contact_threads="pair")
    sim.advance(15000)
    return sim


def packing_worlds() -> wd.Simulation:
    sim = wd.Simulation(*_packing(), dt=2e-5, track_energy=True, world_steps=True, bond_detection_factor=1.05,
                        always_use_moment_law=True)
    sim.advance(12000)
    sim.set_cohesion_now()
    sim.advance(1000)
    sim.run(800, record_every=8, observers={"p": wd.observers.body_point("first", (0.0, 0.0, 0.0))})
    return sim


def _plate_scene() -> tuple[wd.Model, wd.State]:
    from examples.engine_quickstart import BOX, closed_box, open_box

    rng = np.random.default_rng(3)
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("soil", SOIL)
    b.add_material("steel", STEEL)
    v, f = open_box(BOX)
    b.add_mesh("box", v, f, "steel")
    pitch = 0.0105
    grid = np.stack(np.meshgrid(np.arange(12), np.arange(6), np.arange(3), indexing="ij"), -1).reshape(-1, 3)
    centres = (grid + 0.5) * pitch + np.array([0.05, 0.006, 0.0])
    b.add_spheres(centres, rng.uniform(0.0045, 0.005, len(centres)), "soil", group="soil")
    for k in range(4):
        c = np.array([0.07 + 0.025 * k, 0.04, 0.045])
        b.add_clump(np.array([c - (0.004, 0, 0), c + (0.004, 0, 0)]), np.array([0.005, 0.0045]), "soil",
                    group="soil")
    b.set_local_damping("soil", 0.2)
    lo, hi = np.array([0.02, 0.01, 0.0]), np.array([0.03, BOX[1] - 0.01, 0.06])
    pv, pf = closed_box(tuple(lo), tuple(hi))
    plate = b.add_mesh("plate", pv, pf, "steel", kind="dynamic", blocked="yzXYZ")
    anchor = np.array([hi[0], BOX[1] / 2, hi[2]])
    ahead = anchor + (0.05, 0.0, 0.0)
    carriage = b.add_rigid_body(ahead, velocity=(0.5, 0.0, 0.0), name="carriage")
    b.add_spring("pull", carriage, ahead, plate, anchor, stiffness=2e3, damping=5.0)
    return b.finalize(DEVICE, n_worlds=2, overrides={"material:soil:friction_angle": [20.0, 40.0]})


def plate_clumps() -> wd.Simulation:
    model, state = _plate_scene()
    sim = wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model), track_energy=True)
    sim.set_cohesion_now()
    sim.advance(PLATE_STEPS)
    return sim


def plate_clumps_worlds() -> wd.Simulation:
    model, state = _plate_scene()
    sim = wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model), track_energy=True, world_steps=True)
    sim.set_cohesion_now()
    sim.advance(PLATE_STEPS)
    return sim


def ringing_paper() -> wd.Simulation:
    from scenes.ringing import RingingConfig, build_ringing, ringing_dt

    cfg = RingingConfig(springs=(4, 32), spring_model="paper")
    rig = build_ringing(cfg)
    model, state = rig.builder.finalize(DEVICE, n_worlds=2, overrides=rig.overrides)
    sim = wd.Simulation(model, state, dt=ringing_dt(cfg, model), world_steps=True, track_energy=True)
    sim.set_local_damping("tool", 0.5)
    sim.advance(600)
    sim.set_local_damping("tool", 0.0)
    angvel = state.body_angvel.numpy()
    angvel[[model.body_index("sweep_lower", w) for w in range(2)], 0] -= 0.01  # a small hit: contacts stay
    state.body_angvel.assign(angvel)
    sim.advance(2000)
    return sim


def ringing_linear() -> wd.Simulation:
    from scenes.ringing import RingingConfig, build_ringing, ringing_dt

    cfg = RingingConfig(springs=(8, 16), spring_model="linear", pivot_friction=(0.05, 0.1), progressive=(1e7, 2e7),
                        load_mass_fraction=(0.5, 0.7))
    rig = build_ringing(cfg)
    model, state = rig.builder.finalize(DEVICE, n_worlds=2, overrides=rig.overrides)
    sim = wd.Simulation(model, state, dt=ringing_dt(cfg, model), track_energy=True)
    angvel = state.body_angvel.numpy()
    angvel[:, 0] += 0.5
    state.body_angvel.assign(angvel)
    sim.advance(1500)
    return sim


def soil_bin_passive() -> wd.Simulation:
    from scenes import soil_bin as sb
    from scenes.assemblies import Bed

    bed = Bed.load(ROOT / "benchmarks" / "results" / "beds" / "bed_ci_C_d1bcbd134fb2.npz")
    cfg = sb.SoilBinConfig(scale="ci", assembly="C", springs=(16, 32), parameter_set=11)
    tool = sb.place_tool(bed, cfg.working_depth)
    model, state, _ = sb.build_scene(cfg, bed, tool, [16, 32], [0.6, 0.6], DEVICE)
    sim = wd.Simulation(model, state, dt=sb.default_dt(model, cfg.spring_model, False), always_use_moment_law=True,
                        track_energy=True)
    sim.set_cohesion_now()
    sim.advance(600)
    sim.set_body_velocity("sweep_lower", (0.0, 0.3, 0.0), worlds=[1])
    sim.advance(400)
    return sim


def checkpoint() -> wd.Simulation:
    def make() -> wd.Simulation:
        return wd.Simulation(*_packing(2), dt=2e-5, cohesion_on_new_contacts=True, track_energy=True)

    a = make()
    a.advance(12000)
    a.set_local_damping("soil", 0.05)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "ck.npz"
        wd.checkpoint.save(a, path)
        a.advance(1000)
        b = make()
        wd.checkpoint.load(b, path)
    b.advance(1000)
    da, db = digest(a), digest(b)
    differ = [k for k in da if k not in ("all", "forces", "lists") and da[k] != db[k]]
    if differ or not (np.array_equal(a.data.body_force.numpy(), b.data.body_force.numpy())
                      and np.array_equal(a.contacts.ss.hist.numpy(), b.contacts.ss.hist.numpy())):
        raise AssertionError(f"checkpoint: the restored run differs from the uninterrupted one ({differ})")
    return b


def threads2() -> wd.Simulation:
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("soil", SOIL)
    b.add_material("steel", STEEL)
    size = (0.32, 0.32, 0.2)
    from examples.engine_quickstart import open_box

    v, f = open_box(size)
    b.add_mesh("box", v, f, "steel")
    rng = np.random.default_rng(5)
    grid = np.stack(np.meshgrid(np.arange(21), np.arange(20), np.arange(10), indexing="ij"), -1).reshape(-1, 3)
    centres = (grid + 0.5) * 0.0100 + np.array([0.02, 0.02, 0.0])
    b.add_spheres(centres, rng.uniform(0.0047, 0.0052, len(centres)), "soil", group="soil")
    b.set_local_damping("soil", 0.3)
    model, state = b.finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model), cpu_threads=2, track_energy=True)
    if sim.parts != 2:
        raise AssertionError(f"threads2: expected 2 CPU threads, got {sim.parts}")
    sim.set_cohesion_now()
    sim.advance(300)
    return sim


SCENES: dict[str, Callable[[], wd.Simulation]] = {
    f.__name__: f for f in (packing_sphere, packing_pair, packing_worlds, plate_clumps, plate_clumps_worlds,
                            ringing_paper, ringing_linear, soil_bin_passive, checkpoint, threads2)
}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--record", action="store_true", help="write the hashes to golden_bits.json")
    p.add_argument("--only", default="", help="comma-separated scene names (default: all)")
    args = p.parse_args(argv)
    wd.init_quietly()
    names = [n for n in args.only.split(",") if n] or list(SCENES)
    golden = json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {}
    results, bad = {}, []
    for name in names:
        t0 = time.perf_counter()
        sim = SCENES[name]()
        h = digest(sim)
        results[name] = h
        contacts = int(wd.observers.contact_count(sim).sum())
        ok = golden.get(name, {}).get("all") == h["all"]
        if not ok:
            bad.append(name)
        diff = "" if ok or name not in golden else " (differs: " + ", ".join(
            k for k in h if k != "all" and golden[name].get(k) != h[k]) + ")"
        print(f"{name:20s} {h['all']}  {'same' if ok else 'DIFFERENT'}{diff}  {time.perf_counter() - t0:.1f} s, "
              f"{contacts} contacts, step {sim.state.step}, dt {sim.dt:.3g} s",
              flush=True)
    if args.record:
        GOLDEN.write_text(json.dumps({**golden, **results}, indent=1, sort_keys=True) + "\n")
        print(f"recorded {len(results)} scenes in {GOLDEN.name}")
        return 0
    print("golden bits unchanged" if not bad else f"golden bits CHANGED: {', '.join(bad)}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
