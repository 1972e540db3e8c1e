"""Export warpdem's rigid ci soil-bin scene (GA set 11, 0.62 m/s) for its Yade twin.

Run from the repository root (the project's Python, warpdem installed):

    python benchmarks/yade/soil_bin_twin_export.py A      # -> benchmarks/yade/soil_bin_twin_spec_A.npz
    python benchmarks/yade/soil_bin_twin_export.py C      # -> benchmarks/yade/soil_bin_twin_spec_C.npz
    python benchmarks/yade/soil_bin_twin_export.py C --scale strip   # -> ..._spec_C_strip.npz (paper's members)
    python benchmarks/yade/soil_bin_twin_export.py A --deposit-friction 0   # -> ..._spec_A_dense.npz (dense bed)

The scene is built exactly as ``scenes.soil_bin.run_soil_bin`` builds it for
``SoilBinConfig(scale="ci", assembly=X, springs=(0,), parameter_set=11, speed=(0.62,))`` (same functions, same
order): the bed from ``bed_for(config, cache_dir="results/beds")`` (deposited on the CPU when not cached), the tool
placed by ``place_tool``, the start trench cleared by ``clear_start``, the bin walls from ``bin_mesh``, the model from
``scenes.soil_bin.build_scene`` and dt = min(0.3 pwave, 0.5 critical) as run_soil_bin computes it. Nothing is re-derived
by hand: every array below is read back from warpdem's model / simulation after construction.

Keys of the npz (SI units; ns spheres, np particles):

- ``assembly``, ``scale``, ``parameter_set``, ``seed``, ``bed_file``, ``warpdem_config`` (json of the config)
- ``sphere_pos`` (ns, 3): sphere centres AS WARPDEM SIMULATES THEM (body position + float32 member offset rotated:
  clump members differ from the bed's centres by < 1e-8 m); ``sphere_pos_bed`` (ns, 3): the bed's centres.
  ``sphere_radius`` (ns,), ``sphere_particle`` (ns,) particle index (members of a clump contiguous), warpdem's order
  (single spheres first, then clumps, as ``Bed.add_to``); ``sphere_bed_index`` (ns,): each sphere's index in the
  bed (``Bed.centres``) it came from.
- ``particle_mass`` (np,), ``particle_com`` (np, 3), ``particle_inertia`` (np, 3) (principal moments),
  ``particle_quat`` (np, 4) (x, y, z, w) as warpdem uses them; ``particle_n_members`` (np,).
  warpdem's clump rule is Yade's (sum of member masses, overlaps counted twice; parallel axes; principal frame),
  ``clump_rule_check`` holds the max relative difference to that rule recomputed here in numpy.
- ``bin_tri`` (10, 3, 3), ``tool_lower_tri`` (k, 3, 3), ``tool_upper_tri`` (m, 3, 3): world triangles at the start
  pose (warpdem's face order and winding).
- materials ``soil_*`` and ``tool_*`` (the tool material is also the bin walls'): young, poisson (= ks/kn),
  density, friction_angle_deg, friction_angle_rad, normal_cohesion, shear_cohesion, eta_roll, eta_twist, alpha_kr,
  alpha_ktw, moment_law, fragile, cohesive (warpdem's Material fields) and the same with suffix ``_f32``: the
  float32 values warpdem's kernels actually read (friction in radians).
- ``gravity`` (3,), ``dt`` (warpdem's, exactly), ``speed`` [m/s], ``tool_velocity`` (3,), ``travel`` [m],
  ``steady_travel`` [m], ``record_every`` [steps], ``n_steps`` (the carriage stops at this step: the run ends),
  ``sample_rate`` [Hz], ``local_damping`` (0), ``always_use_moment_law`` (True), ``use_incremental_form`` (True),
  ``unp_max`` (0), ``set_cohesion_now`` (True), ``set_cohesion_on_new_contacts`` (False), ``cohesion_note``.
- ``n_particles``, ``n_spheres``, ``n_clumps``, ``tool_mass`` (7.692, unused: the tool is kinematic),
  ``bounds_lo``/``bounds_hi`` (warpdem's escape box).
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import warp as wp

wp.config.quiet = True

import warpdem as wd  # noqa: E402
from scenes import soil_bin as sb  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
SPEED = 0.62
PARAMETER_SET = 11

COHESION_NOTE = (
    "warpdem: Simulation(...); sim.set_cohesion_now() before the first step; cohesion_on_new_contacts=False. In the "
    "first step every contact that exists (overlap >= 0; all are new) gets cohesion if both materials are cohesive "
    "(an = min(Cn) min(R1,R2)^2, as = min(Cs) min(R1,R2)^2; soil-soil: Cn, Cs of GA set 11; soil-wall/tool: the tool "
    "material is cohesive=True with Cn = Cs = 0, so these contacts are flagged cohesive with zero adhesion and break "
    "at their first tension or slip); no contact created later gets cohesion. Yade equivalent: "
    "Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True, setCohesionOnNewContacts=False) set before "
    "O.run (contacts created in iteration 0 get cohesion; Yade clears setCohesionNow itself in iteration 1), both "
    "CohFrictMat with isCohesive=True, the tool/wall material with normalCohesion = shearCohesion = 0 (NOT Yade's "
    "default -1)."
)


def config_for(assembly: str, scale: str = "ci", deposit_friction: float = sb.DEPOSIT_FRICTION) -> sb.SoilBinConfig:
    return sb.SoilBinConfig(scale=scale, assembly=assembly, springs=(0,), parameter_set=PARAMETER_SET, speed=(SPEED,),
                            deposit_friction=deposit_friction)


def spec_name(assembly: str, scale: str = "ci", deposit_friction: float = sb.DEPOSIT_FRICTION) -> str:
    """The spec's file name: ``soil_bin_twin_spec_C.npz`` at ci scale, ``soil_bin_twin_spec_C_strip.npz`` else;
    ``..._dense.npz`` for a bed deposited without friction."""
    dense = "" if deposit_friction == sb.DEPOSIT_FRICTION else ("_dense" if deposit_friction == 0 else
                                                                 f"_deposit{deposit_friction:g}")
    return f"soil_bin_twin_spec_{assembly}{'' if scale == 'ci' else '_' + scale}{dense}.npz"


def build(assembly: str, device: str = "cpu", scale: str = "ci", deposit_friction: float = sb.DEPOSIT_FRICTION) -> dict:
    """The scene exactly as run_soil_bin builds it; returns config, bed, tool, keep, model, state, sim, dt."""
    config = config_for(assembly, scale, deposit_friction)
    t0 = time.perf_counter()
    bed = sb.bed_for(config, device=device, cache_dir=ROOT / "results" / "beds",
                     progress=lambda phase, t, ke: print(f"  deposit {phase} t={t:.2f} s KE/particle={ke:.2e} J",
                                                        flush=True) if int(round(t / 0.02)) % 25 == 0 else None)
    t_bed = time.perf_counter() - t0
    # run_soil_bin's prologue, verbatim (rigid: springs [0], speeds [SPEED])
    springs, speeds = [0], [SPEED]
    tool = sb.place_tool(bed, config.working_depth, None)
    model, state, info = sb.build_scene(config, bed, tool, springs, speeds, device, None, {})
    dt = config.dt or min(0.3 * wd.pwave_timestep(model), 0.5 * wd.critical_timestep(model))
    p = config.preset
    travel = config.travel or p["travel"]
    lo = np.array([-bed.bin_size[0], -0.5, -0.5])
    hi = np.array([bed.bin_size[0], bed.bin_size[1] + travel + 1.0, 2.0])
    sim = wd.Simulation(model, state, dt=dt, always_use_moment_law=True, bounds=(lo, hi),
                        cohesion_on_new_contacts=getattr(config, "cohesion_on_new_contacts", False))
    every = max(1, int(round(1.0 / (config.sample_rate * dt))))
    stop = int(np.ceil(travel / SPEED / dt / every) * every)
    keep = sb.clear_start(bed, tool)
    return dict(config=config, bed=bed, tool=tool, keep=keep, model=model, state=state, sim=sim, dt=dt,
                travel=travel, every=every, stop=stop, lo=lo, hi=hi, info=info, t_bed=t_bed)


def material_keys(prefix: str, m: wd.Material, model: wd.Model, index: int) -> dict[str, np.ndarray]:
    out = {f"{prefix}_{k}": np.asarray(v) for k, v in asdict(m).items()}
    out[f"{prefix}_friction_angle_deg"] = np.float64(m.friction_angle)
    out[f"{prefix}_friction_angle_rad"] = np.float64(np.radians(m.friction_angle))
    out.pop(f"{prefix}_friction_angle")
    for key, arr in (("young", model.mat_young), ("poisson", model.mat_poisson), ("friction_angle_rad",
                     model.mat_friction), ("normal_cohesion", model.mat_normal_cohesion),
                     ("shear_cohesion", model.mat_shear_cohesion), ("eta_roll", model.mat_eta_roll),
                     ("eta_twist", model.mat_eta_twist), ("alpha_kr", model.mat_alpha_kr),
                     ("alpha_ktw", model.mat_alpha_ktw)):
        out[f"{prefix}_{key}_f32"] = np.float64(arr.numpy()[index])
    return out


def yade_clump_rule(centres: np.ndarray, radii: np.ndarray, rho: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Yade's sum-of-spheres rule in numpy: mass, centre of mass, sorted principal moments."""
    m = rho * 4.0 / 3.0 * np.pi * radii**3
    com = (m[:, None] * centres).sum(0) / m.sum()
    it = np.zeros((3, 3))
    for mi, ri, x in zip(m, radii, centres, strict=True):
        d = x - com
        it += 0.4 * mi * ri * ri * np.eye(3) + mi * (d @ d * np.eye(3) - np.outer(d, d))
    return float(m.sum()), com, np.sort(np.linalg.eigvalsh(it))


def export(assembly: str, scale: str = "ci", deposit_friction: float = sb.DEPOSIT_FRICTION) -> Path:
    t0 = time.perf_counter()
    s = build(assembly, scale=scale, deposit_friction=deposit_friction)
    model, sim, config, tool, bed = s["model"], s["sim"], s["config"], s["tool"], s["bed"]
    h = model.host
    soil_group = model.names["group"]["soil"]
    soil_body = np.flatnonzero(h["body_group"] == soil_group)
    first = int(soil_body.min())
    assert np.array_equal(soil_body, np.arange(first, first + len(soil_body))), "soil bodies are not contiguous"
    sphere_body = h["sphere_body"]
    assert np.all(sphere_body >= first), "a non-soil body has spheres"
    particle = (sphere_body - first).astype(np.int64)
    assert np.all(np.diff(particle) >= 0), "members of a particle are not contiguous"
    pos = sim.data.sphere_pos.numpy().astype(np.float64).copy()
    radius = h["sphere_radius"].copy()
    # the bed's centres in the same order (Bed.add_to's order, kept particles only)
    starts = np.flatnonzero(np.r_[True, np.diff(bed.particle) != 0])
    ends = np.r_[starts[1:], len(bed.particle)]
    single = (ends - starts) == 1
    sel = s["keep"]
    bed_order = np.concatenate([starts[single & sel]] + [np.arange(a, b) for a, b in
                                                         zip(starts[~single & sel], ends[~single & sel], strict=True)])
    pos_bed = bed.centres[bed_order]
    assert np.allclose(radius, bed.radii[bed_order], rtol=0, atol=0), "radius order mismatch"
    dev = np.abs(pos - pos_bed).max()
    print(f"  warpdem sphere centres vs bed centres: max |diff| = {dev:.3e} m")
    assert dev < 1e-7
    st = sim.state.numpy()
    n_part = int(particle.max()) + 1
    n_members = np.bincount(particle, minlength=n_part)
    rho = config.soil_material().density
    pb = soil_body[:n_part]
    rule = 0.0
    for p_ in np.flatnonzero(n_members > 1):
        mm = particle == p_
        m_, com_, i_ = yade_clump_rule(pos_bed[mm], radius[mm], rho)
        rule = max(rule, abs(h["body_mass"][pb[p_]] / m_ - 1), np.abs(st["body_pos"][pb[p_]] - com_).max() / 0.02,
                   np.abs(np.sort(h["body_inertia"][pb[p_]]) / i_ - 1).max())
    print(f"  clump mass/COM/inertia vs Yade's sum-of-spheres rule (from the bed centres): max rel diff {rule:.2e}")
    bv, bf = sb.bin_mesh(bed.bin_size)
    mats = model.names["material"]
    soil_m = config.soil_material()
    tool_m = wd.Material(young=sb.paper.TOOL_YOUNG, poisson=sb.paper.TOOL_POISSON, density=7850.0,
                         friction_angle=sb.paper.TOOL_FRICTION)
    tb = model.names["body"]["sweep_lower"]
    data = dict(
        assembly=np.array(assembly), scale=np.array(config.scale), parameter_set=np.int64(PARAMETER_SET),
        seed=np.int64(config.seed), warpdem_config=np.array(json.dumps(asdict(config))),
        bed_porosity=np.float64(bed.porosity), bed_coordination=np.float64(bed.coordination),
        bin_size=np.array(bed.bin_size), bed_depth=np.float64(bed.depth),
        sphere_pos=pos, sphere_pos_bed=pos_bed, sphere_radius=radius, sphere_particle=particle,
        sphere_bed_index=bed_order.astype(np.int64),
        particle_mass=h["body_mass"][pb], particle_com=st["body_pos"][pb], particle_inertia=h["body_inertia"][pb],
        particle_quat=st["body_quat"][pb], particle_n_members=n_members, clump_rule_check=np.float64(rule),
        bin_tri=bv[bf], tool_lower_tri=tool.lower.vertices[tool.lower.faces],
        tool_upper_tri=tool.upper.vertices[tool.upper.faces],
        tool_tip=tool.tip, tool_body_pos0=st["body_pos"][tb],
        gravity=np.array(model.gravity, dtype=np.float64), dt=np.float64(s["dt"]), speed=np.float64(SPEED),
        tool_velocity=st["body_vel"][tb], travel=np.float64(s["travel"]),
        steady_travel=np.float64(config.steady_travel or config.preset["steady_travel"]),
        record_every=np.int64(s["every"]), n_steps=np.int64(s["stop"]), sample_rate=np.float64(config.sample_rate),
        working_depth=np.float64(config.working_depth),
        local_damping=np.float64(np.abs(model.group_damping.numpy()).max()),
        always_use_moment_law=np.bool_(sim.always_use_moment_law), use_incremental_form=np.bool_(True),
        unp_max=np.float64(sim.options.unp_max), set_cohesion_now=np.bool_(True),
        set_cohesion_on_new_contacts=np.bool_(sim.cohesion_on_new_contacts),
        cohesion_note=np.array(COHESION_NOTE),
        n_particles=np.int64(n_part), n_spheres=np.int64(len(radius)), n_clumps=np.int64((n_members > 1).sum()),
        tool_mass=np.float64(tool.mass), bounds_lo=s["lo"], bounds_hi=s["hi"],
        warpdem_skin=np.float64(sim.skin), pwave_dt=np.float64(wd.pwave_timestep(model)),
        critical_dt=np.float64(wd.critical_timestep(model)), bed_wall_s=np.float64(s["t_bed"]),
    )
    data.update(material_keys("soil", soil_m, model, mats["soil"]))
    data.update(material_keys("tool", tool_m, model, mats["tool"]))
    # the builder's tool material must be the one described here
    assert abs(data["tool_young_f32"] - tool_m.young) < 1e-3 * tool_m.young
    out = HERE / spec_name(assembly, scale, deposit_friction)
    np.savez_compressed(out, **data)
    print(f"  {assembly}: {n_part} particles, {len(radius)} spheres, {int((n_members > 1).sum())} clumps, "
          f"dt = {s['dt']:.6e} s, record every {s['every']} steps, {s['stop']} steps; bed {s['t_bed']:.1f} s; "
          f"wrote {out.relative_to(ROOT)} ({out.stat().st_size} bytes) in {time.perf_counter() - t0:.1f} s")
    return out


if __name__ == "__main__":
    argv = sys.argv[1:]
    scale = argv[argv.index("--scale") + 1] if "--scale" in argv else "ci"
    friction = (float(argv[argv.index("--deposit-friction") + 1]) if "--deposit-friction" in argv
                else sb.DEPOSIT_FRICTION)
    names = [a for k, a in enumerate(argv)
             if not a.startswith("--") and (k == 0 or argv[k - 1] not in ("--scale", "--deposit-friction"))]
    for a in names or ["A"]:
        export(a.upper(), scale, friction)
