"""Export warpdem's consolidated direct-shear-box sample (assembly C, GA set 11) for its Yade twin.

Run from the repository root (the project's Python, warpdem installed):

    python benchmarks/yade/shear_box_twin_export.py ci     # -> benchmarks/yade/shear_box_twin_spec_ci.npz

The sample is made by ``scenes.shear_box.run_shear_boxes`` itself for ``shear_box.preset(SCALE, "C")`` (GA set 11,
normal stresses 5, 10, 20 kPa, seed 0) on the CPU: ``make_bed`` deposits it, ``build`` makes the rig, the plate is
brought down and the sample consolidated by ``consolidate``. The export hooks ``consolidate`` (a wrapper that calls
the original and then reads the simulation): the state read there is the one ``run_shear_boxes`` gives cohesion to
(``sim.set_cohesion_now()``) and then shears. ``run_shear_boxes`` then runs on to its end, and its own result (the
native run, contact histories of the consolidation kept) is stored too. Nothing is re-derived by hand: every array
is read back from warpdem's model / state.

Keys of the npz (SI units; W worlds = normal stresses, ns soil spheres, np particles):

- ``scale``, ``assembly``, ``ga_set``, ``seed``, ``warpdem_config`` (repr of the ShearBoxConfig), ``box_side``,
  ``sample_height``, ``z_shear``, ``shear_rate``, ``shear_displacement`` (fraction of L), ``record_every`` (fraction
  of L), ``smoothing`` (fraction of L), ``interval`` (steps per record), ``n_records``, ``smooth_width`` (records),
  ``normal_stress`` (W,) applied, ``normal_stress_plane`` (W,) on the shear plane (plate weight plus the soil above
  z_shear after consolidation, over L^2, as run_shear_boxes measures it).
- ``sphere_pos`` (W, ns, 3): soil sphere centres after consolidation, from each body's pose and warpdem's float32
  member offsets (what the kernels use); ``sphere_radius`` (ns,), ``sphere_particle`` (ns,) particle index (warpdem's
  order: single spheres first, then the clumps' members, ``Bed.add_to``); ``sphere_speed_max`` (W,) the largest
  sphere speed at the end of consolidation (the twins start at rest), ``particle_mass`` (np,), ``particle_inertia``
  (np, 3) principal moments.
- rig triangles in world coordinates after consolidation: ``lower_tri`` (16, 3, 3) (lower half's walls and flange,
  frictionless steel), ``floor_tri`` (2, 3, 3) (rough, moves with the lower half), ``upper_tri`` (16, 3, 3) (upper
  half, static, frictionless), ``plate_tri`` (W, 2, 3, 3) (rough loading plate, at each world's consolidated
  height); ``ballast_pos`` (W, 3), ``ballast_radius``, ``plate_mass`` (W,) (the plate body's mass, kg, as warpdem
  has it), ``lower_pos`` (W, 3) (the lower half's body position, unmoved during consolidation).
- materials ``soil_*``, ``box_*``, ``platen_*``, ``ballast_*`` (warpdem Material fields; friction in deg and rad;
  ballast density per world as ``ballast_density_world`` (W,)) and ``*_f32``: the float32 values the kernels read.
- ``gravity`` (3,), ``dt``, ``local_damping`` (shear damping, 0), ``always_use_moment_law`` (True),
  ``use_incremental_form`` (True), ``unp_max``, ``set_cohesion_on_new_contacts`` (False), ``cohesion_note``.
- the native run: ``native_disp`` (k, W), ``native_upper`` (k, W) (soil's x force on upper half + plate, interval
  means [N]), ``native_lower`` (k, W), ``native_rise`` (k, W), ``native_peak`` (W,) [Pa], ``native_cohesion`` [Pa],
  ``native_phi`` [deg], ``native_r2``, ``native_wall_s`` (consolidation + shear, deposition excluded),
  ``consolidation_time`` [s], ``bed_wall_s``, ``n_particles``, ``n_spheres``, ``n_clumps``, ``bed_porosity``,
  ``soil_ke_end`` (W,) soil kinetic energy at the end of consolidation [J].
"""

from __future__ import annotations

import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import warp as wp

wp.config.quiet = True

import warpdem as wd  # noqa: E402
from scenes import shear_box as sbx  # noqa: E402
from soil_bin_twin_export import material_keys  # noqa: E402  (this folder: run as a script, or on sys.path)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
KIND = "C"
GA_SET = 11

COHESION_NOTE = (
    "warpdem: after consolidation sim.set_cohesion_now() (the next step's existing contacts of cohesive materials get "
    "bonds: soil-soil an = Cn min(R1,R2)^2, as = Cs min(R1,R2)^2; box, platen and ballast materials are "
    "cohesive=False, so nothing bonds to the rig), cohesion_on_new_contacts=False, fragile bonds, "
    "always_use_moment_law=True. Yade: Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True, "
    "setCohesionOnNewContacts=False) set before O.run, rig materials isCohesive=False; "
    "Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True, always_use_moment_law=True).")


SOIL_VARIANTS = {"ci_soil": ("ci", ROOT / "docs" / "runs" / "soil_ga_loose_box_h100x2")}
"""twin names beside the scales: the preset's sample with the soil of a calibration folder (its best individual,
bonds' rule and box stresses; ``calibration.problems.calibrated_soil``) instead of GA set 11."""


def config_for(scale: str) -> sbx.ShearBoxConfig:
    if scale in SOIL_VARIANTS:
        from calibration.problems import calibrated_box, calibrated_soil

        base, folder = SOIL_VARIANTS[scale]
        return sbx.preset(base, KIND, **calibrated_box(calibrated_soil(folder)))
    cfg = sbx.preset(scale, KIND)
    assert cfg.ga_set == GA_SET, cfg.ga_set
    return cfg


def spec_path(scale: str) -> Path:
    return HERE / f"shear_box_twin_spec_{scale}.npz"


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (n, 3) by quaternions q (n, 4) (x, y, z, w)."""
    u, w = q[:, :3], q[:, 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def export(scale: str) -> Path:
    t0 = time.perf_counter()
    cfg = config_for(scale)
    bed = sbx.make_bed(cfg, "cpu")
    t_bed = time.perf_counter() - t0
    print(f"  bed: {bed.n_particles} particles, {len(bed.radii)} spheres, porosity {bed.porosity:.3f}, "
          f"{t_bed:.1f} s", flush=True)
    snap: dict[str, object] = {}
    original = sbx.consolidate

    def hooked(sim, probe, c, rig, progress):
        t_cons = original(sim, probe, c, rig, progress)
        # copies: on the CPU, a Warp array's numpy() is a view that the shear would overwrite
        state = {k: np.array(v, copy=True) for k, v in sim.state.numpy().items()}
        snap.update(sim=sim, rig=rig, t_cons=t_cons, state=state, step=sim.state.step,
                    ke=sbx.soil_ke_per_particle(sim), weight_above=sbx.soil_weight_above(sim, rig.z_shear),
                    t=time.perf_counter())
        return t_cons

    sbx.consolidate = hooked
    try:
        t1 = time.perf_counter()
        res = sbx.run_shear_boxes([cfg], "cpu", bed=bed)[0]
        t_run = time.perf_counter() - t1
    finally:
        sbx.consolidate = original
    sim, rig, st = snap["sim"], snap["rig"], snap["state"]
    model = sim.model
    h = model.host
    W, bpw, spw = model.n_worlds, model.bodies_per_world, model.spheres_per_world
    soil_g = model.group_index("soil")
    soil_body0 = np.flatnonzero(h["body_group"][:bpw] == soil_g)
    sph0 = np.flatnonzero(np.isin(h["sphere_body"][:spw], soil_body0))
    first = int(soil_body0.min())
    assert np.array_equal(soil_body0, np.arange(first, first + len(soil_body0))), "soil bodies not contiguous"
    particle = (h["sphere_body"][sph0] - first).astype(np.int64)
    assert np.all(np.diff(particle) >= 0)
    offsets = model.sphere_offset.numpy().astype(np.float64)
    pos = np.zeros((W, len(sph0), 3))
    vel = np.zeros_like(pos)
    for w in range(W):
        s = sph0 + w * spw
        b = h["sphere_body"][s]
        arm = quat_rotate(st["body_quat"][b], offsets[s])
        pos[w] = st["body_pos"][b] + arm
        vel[w] = st["body_vel"][b] + np.cross(st["body_angvel"][b], arm)
    radius = h["sphere_radius"][sph0].copy()
    n_part = int(particle.max()) + 1
    n_members = np.bincount(particle, minlength=n_part)
    pb = soil_body0[:n_part]
    # the rig's meshes in world coordinates (mesh bodies: identity orientation, checked)
    names = model.names["mesh"]

    def tri(name: str, w: int) -> np.ndarray:
        k = names[name]
        body = int(h["mesh_body"][w * model.meshes_per_world + k])
        q = st["body_quat"][body]
        assert np.allclose(q, [0, 0, 0, 1], atol=1e-12), (name, q)
        return h["mesh_vertices_local"][k][h["mesh_faces"][k]] + st["body_pos"][body]

    for w in range(1, W):  # the box halves do not move during consolidation
        for name in ("lower", "floor", "upper"):
            assert np.array_equal(tri(name, w), tri(name, 0)), name
    ballast = [model.body_index("ballast", w) for w in range(W)]
    lower = [model.body_index("lower", w) for w in range(W)]
    mats = model.names["material"]
    steel = {"young": sbx.paper.TOOL_YOUNG, "poisson": sbx.paper.TOOL_POISSON, "density": 7850.0, "cohesive": False}
    box_m = wd.Material(friction_angle=0.0, **steel)
    platen_m = wd.Material(friction_angle=sbx.paper.TOOL_FRICTION, **steel)
    rho = rig.plate_mass / (4.0 / 3.0 * np.pi * cfg.assembly.radius**3)
    ballast_m = wd.Material(young=cfg.young, poisson=cfg.poisson, density=float(rho[0]), friction_angle=0.0,
                            cohesive=False)
    interval = max(1, int(round(cfg.record_every * cfg.box_side / cfg.shear_rate / sim.dt)))
    n_rec = int(np.ceil(cfg.shear_displacement * cfg.box_side / cfg.shear_rate / sim.dt / interval))
    curves = res.curves
    data = dict(
        scale=np.array(scale), assembly=np.array(KIND), ga_set=np.int64(cfg.ga_set), seed=np.int64(cfg.seed),
        warpdem_config=np.array(repr(cfg)), box_side=np.float64(cfg.box_side),
        sample_height=np.float64(cfg.sample_height), z_shear=np.float64(rig.z_shear),
        shear_rate=np.float64(cfg.shear_rate), shear_displacement=np.float64(cfg.shear_displacement),
        record_every=np.float64(cfg.record_every), smoothing=np.float64(cfg.smoothing), interval=np.int64(interval),
        n_records=np.int64(n_rec), smooth_width=np.int64(max(1, int(round(cfg.smoothing / cfg.record_every)))),
        normal_stress=np.array(cfg.normal_stresses),
        normal_stress_plane=np.array([c.normal_stress_plane for c in curves]),
        soil_weight_above=np.asarray(snap["weight_above"], np.float64),
        sphere_pos=pos, sphere_radius=radius, sphere_particle=particle,
        sphere_speed_max=np.linalg.norm(vel, axis=2).max(axis=1),
        particle_mass=h["body_mass"][pb], particle_inertia=h["body_inertia"][pb],
        lower_tri=tri("lower", 0), floor_tri=tri("floor", 0), upper_tri=tri("upper", 0),
        plate_tri=np.stack([tri("plate", w) for w in range(W)]),
        ballast_pos=st["body_pos"][ballast], ballast_radius=np.float64(cfg.assembly.radius),
        plate_mass=h["body_mass"][ballast], plate_mass_rig=np.asarray(rig.plate_mass, np.float64),
        ballast_density_world=rho, lower_pos=st["body_pos"][lower], lower_vel_end=st["body_vel"][lower],
        gravity=np.array(model.gravity, dtype=np.float64), dt=np.float64(sim.dt),
        pwave_dt=np.float64(wd.pwave_timestep(model)), dt_factor=np.float64(cfg.dt_factor),
        local_damping=np.float64(cfg.shear_damping), always_use_moment_law=np.bool_(sim.always_use_moment_law),
        use_incremental_form=np.bool_(True), unp_max=np.float64(sim.options.unp_max),
        set_cohesion_on_new_contacts=np.bool_(sim.cohesion_on_new_contacts), cohesion_note=np.array(COHESION_NOTE),
        native_disp=np.stack([c.displacement for c in curves], 1),
        native_upper=np.stack([c.shear_stress for c in curves], 1) * cfg.area,
        native_lower=np.stack([c.shear_stress_lower for c in curves], 1) * cfg.area,
        native_rise=np.stack([c.vertical_displacement for c in curves], 1),
        native_peak=res.peak_shear_stress, native_cohesion=np.float64(res.fit.cohesion),
        native_phi=np.float64(res.fit.friction_angle_deg), native_r2=np.float64(res.fit.r2),
        native_wall_s=np.float64(res.wall_s), native_run_s=np.float64(t_run),
        consolidation_time=np.float64(snap["t_cons"]), consolidation_steps=np.int64(snap["step"]),
        bed_wall_s=np.float64(t_bed), n_particles=np.int64(n_part), n_spheres=np.int64(len(radius)),
        n_clumps=np.int64((n_members > 1).sum()), bed_porosity=np.float64(bed.porosity),
        soil_ke_end=np.asarray(snap["ke"], np.float64) * n_part,
    )
    data.update(material_keys("soil", cfg.material(), model, mats["soil"]))
    data.update(material_keys("box", box_m, model, mats["box"]))
    data.update(material_keys("platen", platen_m, model, mats["platen"]))
    data.update(material_keys("ballast", ballast_m, model, mats["ballast"]))
    for k in ("young", "poisson", "friction_angle_rad"):  # the materials described are the builder's
        for p in ("box", "platen", "ballast"):
            assert abs(data[f"{p}_{k}_f32"] - data[f"{p}_{k}"]) <= 1e-6 * max(1.0, abs(data[f"{p}_{k}"])), (p, k)
    out = spec_path(scale)
    np.savez_compressed(out, **data)
    print(res.table())
    print(f"  {scale}: {n_part} particles ({int((n_members > 1).sum())} clumps), {len(radius)} spheres, "
          f"dt = {sim.dt:.6e} s, consolidation {snap['t_cons']:.3f} s ({snap['step']} steps), shear {n_rec} x "
          f"{interval} steps; run_shear_boxes {t_run:.1f} s; wrote {out.relative_to(ROOT)} ({out.stat().st_size} "
          f"bytes) in {time.perf_counter() - t0:.1f} s", flush=True)
    return out


if __name__ == "__main__":
    for s in sys.argv[1:] or ["ci"]:
        export(s)
