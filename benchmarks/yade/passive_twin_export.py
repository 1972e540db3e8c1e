"""Export warpdem's PASSIVE ci soil-bin scene (GA set 11, 0.62 m/s, linear spring) for its Yade twin, with warpdem's
own passive runs' records.

Run from the repository root (the project's Python, warpdem installed; one CPU thread):

    python benchmarks/yade/passive_twin_export.py A --springs 16 32 --seeds 1 2 3 4 5 6 7 8 --per-facet
        # -> benchmarks/yade/passive_twin_spec_A_16.npz, passive_twin_spec_A_32.npz
    python benchmarks/yade/passive_twin_export.py A --springs 16 --effects-check
        # -> benchmarks/yade/passive_twin_effects_A_16.npz: warpdem's own knobs (pitch, stack_preload,
        #    pivot_friction, extra_mass) over the first 0.012 m, for the Yade script's hidden-effect options
    python benchmarks/yade/passive_twin_export.py A --springs 4 8 12 16 20 24 28 32 --no-support-offset
        # -> benchmarks/yade/passive_twin_spec_A_<n>_nooffset.npz: Table 2's support offsets off
        #    (SoilBinConfig(support_offset=False), the baseline of calibration.rig_models.SoilBinRigModel), same bed
        #    and tool pose, with warpdem's main-bed run (--seeds adds realizations; --no-warpdem: the scene only);
        #    read by passive_twin.py --no-support-offset and passive_twin_table.py

The scene is ``scenes.soil_bin.run_soil_bin``'s for ``SoilBinConfig(scale="ci", assembly=X, springs=(n,),
parameter_set=11, speed=(0.62,))`` (spring_model "linear", support offsets on: the config's defaults; off with
``--no-support-offset``), one passive world, no knobs, no ``passive_tool``, no pitch. Its bed and tool pose are the
RIGID twin's (``soil_bin_twin_spec_X.npz``, through ``soil_bin_twin_compare.spec_bed_and_tool``: the deposited bed's
centres and the sweep moved to the exported tip), so that both twins cut the same bed (a deposition repeated on
another CPU or Warp build is another bed) and ``run_soil_bin`` is called with ``place=False``. The spec is read back
from the model that ``scenes.soil_bin.build_scene`` makes with run_soil_bin's own arguments (nothing re-derived by
hand), and ``run_soil_bin`` itself is then run (main bed, and every ``--seeds k``: the bed with every particle
displaced by RandomState(k).uniform(-1e-9, 1e-9) m, as the rigid twin) with a hook that checks its scene is the
exported one and records the tool's rotation, angular velocity and the spring's force besides run_soil_bin's own
series.

Keys of the npz (SI units) besides the rigid export's bed and material keys (``sphere_*``, ``particle_*``,
``soil_*``, ``tool_*`` materials, ``bin_tri``, ``tool_lower_tri``, ``tool_upper_tri``, ``gravity``, ``dt``, ...;
see soil_bin_twin_export.py):

- ``springs``, ``spring_model`` ("linear"), ``support_offset`` [m] (Table 2's, + against travel),
  ``measured_damping`` (Table 2's zeta), ``spring_stiffness_din`` [N/m], ``dashpot_f64`` [N s/m]
  (``dashpot_for``).
- the hinged tool as warpdem's model holds it: ``tool_mass`` [kg], ``tool_com`` (3,) (body position at the start),
  ``tool_quat`` (x, y, z, w) (principal frame), ``tool_inertia_principal`` (3,), ``tool_inertia_com`` (3, 3) (world
  axes), ``tool_pivot`` (3,) (body position + R(q) pivot_local: the model's pivot), ``tool_pivot_local`` (3,),
  ``tool_inertia_pivot`` (3, 3) and ``tool_ip_xx`` (the moment about the pivot's x axis, the one the hinge uses),
  ``tool_blocked`` ("YZ"), ``tool_pivot_friction`` (0), ``tool_group_damping`` (0), ``pivot_velocity`` (3,),
  ``sensor_point`` (3,) (the tool's sensor point, where run_soil_bin's displacement observer reads),
  ``lever`` [m] (|z_sensor - z_pivot|).
- the spring (kernel values, float32 as the kernel reads them, converted to float64): ``spring_stiffness``,
  ``spring_damping``, ``spring_rest_length``, ``spring_preload``, ``spring_progressive``, ``spring_stop_stiffness``,
  ``spring_point_a_local`` / ``spring_point_b_local`` (3,) (body frames), ``carriage_pos`` (3,),
  ``carriage_velocity`` (3,), ``spring_anchor`` (3,) (carriage position + point_a: world, start) and
  ``spring_attach`` (3,) (tool position + R(q) point_b: world, start).
- closed forms: ``k_rot`` = k a^2 - m g (z_com - z_pivot) [N m/rad], ``ring_freq_hz`` = sqrt(k_rot / I_p) / (2 pi),
  ``ring_freq_damped_hz`` (times sqrt(1 - zeta^2)).
- warpdem's runs (R = 1 + number of seeds; realization 0 is the main bed): ``warp_seeds`` (R,) (-1 = main),
  ``warp_step`` (k,), ``warp_time`` (k,), ``warp_draught``, ``warp_displacement``, ``warp_rotation`` (rad, about
  +x, from the start: atan2(M21, M11) of M = R(q) R(q0)^T), ``warp_spring_force`` (N, tension > 0; the last step's,
  as ``observers.spring_force``), ``warp_ke_tool`` (J, translation + rotation) (R, k) (float32);
  ``warp_steady_draught`` / ``_displacement`` (R, 3): mean, std, sem (run_soil_bin's own steady rows),
  ``warp_wall_s`` (R,), ``warp_scene_check`` (json of the max differences).
- with ``--per-facet``: ``facet_draught``, ``facet_displacement``, ``facet_rotation``, ``facet_spring_force``
  (R, k) float32 and ``facet_wall_s`` (R,): a diagnostic rebuild of the same scene with every sweep triangle its own
  mesh on the one hinged body (Yade's facets; see per_facet_run).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

wp.config.quiet = True

import warpdem as wd  # noqa: E402
from scenes import paper  # noqa: E402
from scenes import soil_bin as sb  # noqa: E402
from scenes.sweep import inertia_about_point  # noqa: E402
from warpdem import mass as massprops  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))
import soil_bin_twin_compare as rigid_cmp  # noqa: E402
import soil_bin_twin_export as rigid_ex  # noqa: E402

SPEED = rigid_ex.SPEED
PARAMETER_SET = rigid_ex.PARAMETER_SET


def config_for(assembly: str, springs: int, support_offset: bool = True) -> sb.SoilBinConfig:
    return sb.SoilBinConfig(scale="ci", assembly=assembly, springs=(springs,), parameter_set=PARAMETER_SET,
                            speed=(SPEED,), support_offset=support_offset)


def spec_name(assembly: str, springs: int, support_offset: bool = True) -> str:
    """``passive_twin_spec_<A>_<n>.npz``; without the support offset ``passive_twin_spec_<A>_<n>_nooffset.npz``."""
    return f"passive_twin_spec_{assembly}_{springs}{'' if support_offset else '_nooffset'}.npz"


def rotation_x(q: np.ndarray, q0: np.ndarray) -> float:
    """The rotation [rad] about +x from orientation q0 to q (x, y, z, w): atan2(M21, M11), M = R(q) R(q0)^T."""
    m = massprops.quat_to_matrix(q) @ massprops.quat_to_matrix(q0).T
    return math.atan2(m[2, 1], m[1, 1])


class Hook:
    """run_soil_bin's ``viewer`` hook: checks that the scene it runs is the exported one (before the first step) and
    records the tool's rotation, angular velocity and the spring's force at every record."""

    def __init__(self, spec: dict[str, np.ndarray], perturbed: bool) -> None:
        self.spec = spec
        self.perturbed = perturbed
        self.rows: list[tuple[float, ...]] = []
        self.check: dict[str, float] = {}

    def __call__(self, sim: wd.Simulation) -> Hook:
        self.sim = sim
        m, sp = sim.model, self.spec
        h = m.host
        st = sim.state.numpy()
        self.tb = m.names["body"]["sweep_lower"]
        self.q0 = st["body_quat"][self.tb].copy()
        tol_p = 2e-9 if self.perturbed else 1e-15
        out = {
            "sphere_pos": float(np.abs(sim.data.sphere_pos.numpy() - sp["sphere_pos"]).max()),
            "sphere_radius": float(np.abs(h["sphere_radius"] - sp["sphere_radius"]).max()),
            "dt": abs(sim.dt - float(sp["dt"])),
            "tool_com": float(np.abs(st["body_pos"][self.tb] - sp["tool_com"]).max()),
            "tool_quat": float(np.abs(st["body_quat"][self.tb] - sp["tool_quat"]).max()),
            "tool_mass": abs(float(h["body_mass"][self.tb]) - float(sp["tool_mass"])),
        }
        for k in ("stiffness", "damping", "rest_length", "preload", "stop_stiffness", "progressive"):
            out["spring_" + k] = abs(float(getattr(m, "spring_" + k).numpy()[0]) - float(sp["spring_" + k]))
        for name, key in (("bin", "bin_tri"), ("sweep_lower", "tool_lower_tri"), ("sweep_upper", "tool_upper_tri")):
            k = m.names["mesh"][name]
            b = h["mesh_body"][k]
            rot = massprops.quat_to_matrix(st["body_quat"][b])
            world = h["mesh_vertices_local"][k][h["mesh_faces"][k]] @ rot.T + st["body_pos"][b]
            out[f"tri_{name}"] = float(np.abs(world - sp[key]).max())
        tol = {k: 1e-15 for k in out}
        tol.update(sphere_pos=tol_p, tool_com=tol_p + 1e-15, tri_sweep_lower=tol_p + 1e-15,
                   tri_sweep_upper=tol_p + 1e-15, tri_bin=1e-15, tool_quat=1e-15)
        bad = {k: v for k, v in out.items() if v > tol[k]}
        if bad:
            raise AssertionError(f"run_soil_bin's scene differs from the spec: {bad}")
        self.check = out
        return self

    def as_observer(self, _observers: dict | None = None) -> object:
        def f(sim: wd.Simulation) -> np.ndarray:
            st = sim.state.numpy()
            q = st["body_quat"][self.tb]
            self.rows.append((sim.state.step, rotation_x(q, self.q0), float(st["body_angvel"][self.tb][0]),
                              float(sim.data.spring_force.numpy()[0])))
            return np.zeros(1)

        return f

    def close(self) -> None:
        pass


def scene_spec(assembly: str, springs: int, support_offset: bool = True) -> dict[str, np.ndarray]:
    """The passive scene as run_soil_bin builds it (build_scene with its arguments), read back from the model."""
    rigid = rigid_cmp.load(HERE / rigid_ex.spec_name(assembly))
    config = config_for(assembly, springs, support_offset)
    bed, tool = rigid_cmp.spec_bed_and_tool(assembly, rigid)
    # run_soil_bin's prologue (place=False, no knobs, no passive_tool, no pitch)
    model, state, info = sb.build_scene(config, bed, tool, [springs], [SPEED], "cpu", None, {}, None)
    dt = config.dt or sb.default_dt(model, config.spring_model, False)
    travel = config.travel or config.preset["travel"]
    lo = np.array([-bed.bin_size[0], -0.5, min(-0.5, info.get("garage_bottom", 0.0) - 0.1)])
    hi = np.array([bed.bin_size[0], bed.bin_size[1] + travel + 1.0, 2.0])
    sim = wd.Simulation(model, state, dt=dt, always_use_moment_law=True, bounds=(lo, hi),
                        cohesion_on_new_contacts=config.cohesion_on_new_contacts,
                        bond_detection_factor=config.bond_detection_factor)
    every = max(1, int(round(1.0 / (config.sample_rate * dt))))
    stop = int(np.ceil(travel / SPEED / dt / every) * every)
    h = model.host
    st = sim.state.numpy()
    names = model.names["body"]
    tb, cb = names["sweep_lower"], names["carriage"]
    soil_body = np.flatnonzero(h["body_group"] == model.names["group"]["soil"])
    first = int(soil_body.min())
    particle = (h["sphere_body"] - first).astype(np.int64)
    n_part = int(particle.max()) + 1
    if n_part != int(rigid["n_particles"]):
        raise AssertionError(f"passive scene has {n_part} particles, the rigid spec {int(rigid['n_particles'])}")
    pos = sim.data.sphere_pos.numpy().astype(np.float64).copy()
    if np.abs(pos - rigid["sphere_pos"]).max() > 1e-15 or not np.array_equal(particle, rigid["sphere_particle"]):
        raise AssertionError("passive scene's spheres differ from the rigid spec's")
    rot = massprops.quat_to_matrix(st["body_quat"][tb])
    i_com = rot @ np.diag(h["body_inertia"][tb]) @ rot.T
    pivot_local = h["body_pivot"][tb]
    pivot = st["body_pos"][tb] + rot @ pivot_local
    mass = float(h["body_mass"][tb])
    com = st["body_pos"][tb].copy()
    i_p = inertia_about_point(i_com, mass, com, pivot)
    sp = {k: float(getattr(model, "spring_" + k).numpy()[0]) for k in ("stiffness", "damping", "rest_length",
                                                                         "preload", "progressive", "stop_stiffness")}
    assert int(model.spring_body_a.numpy()[0]) == cb and int(model.spring_body_b.numpy()[0]) == tb
    pa = model.spring_point_a.numpy()[0].astype(np.float64)
    pb = model.spring_point_b.numpy()[0].astype(np.float64)
    rot_c = massprops.quat_to_matrix(st["body_quat"][cb])
    anchor = st["body_pos"][cb] + rot_c @ pa
    attach = st["body_pos"][tb] + rot @ pb
    row = paper.ringing_row(springs)
    zeta = row["measured_damping"]
    lever = float(abs(tool.sensor_point[2] - tool.pivot[2]))
    g = np.array(model.gravity, dtype=np.float64)
    k_rot = sp["stiffness"] * lever**2 - mass * abs(g[2]) * (com[2] - pivot[2])
    f0 = math.sqrt(k_rot / i_p[0, 0]) / (2 * math.pi)
    tool_group = model.names["group"]["tool"]
    damping = model.group_damping.numpy().reshape(model.n_worlds, -1)
    data: dict[str, np.ndarray] = {k: rigid[k] for k in (
        "assembly", "scale", "parameter_set", "seed", "bed_porosity", "bed_coordination", "bin_size", "bed_depth",
        "sphere_radius", "sphere_particle", "particle_n_members", "tool_tip",
        "working_depth") if k in rigid}
    data.update(
        sphere_pos=pos, n_particles=np.int64(n_part), n_spheres=np.int64(len(pos)),
        n_clumps=np.int64((np.bincount(particle) > 1).sum()),
        warpdem_config=np.array(json.dumps(sb.asdict(config))), rigid_spec=np.array(rigid_ex.spec_name(assembly)),
        bin_tri=rigid["bin_tri"], tool_lower_tri=tool.lower.vertices[tool.lower.faces],
        tool_upper_tri=tool.upper.vertices[tool.upper.faces],
        gravity=g, dt=np.float64(dt), speed=np.float64(SPEED), travel=np.float64(travel),
        steady_travel=np.float64(config.steady_travel or config.preset["steady_travel"]),
        record_every=np.int64(every), n_steps=np.int64(stop), sample_rate=np.float64(config.sample_rate),
        local_damping=np.float64(damping[0, model.names["group"]["soil"]]),
        tool_group_damping=np.float64(damping[0, tool_group]),
        always_use_moment_law=np.bool_(sim.always_use_moment_law), use_incremental_form=np.bool_(True),
        unp_max=np.float64(sim.options.unp_max), set_cohesion_now=np.bool_(True),
        set_cohesion_on_new_contacts=np.bool_(sim.cohesion_on_new_contacts),
        cohesion_note=np.array(rigid_ex.COHESION_NOTE), bounds_lo=lo, bounds_hi=hi,
        pwave_dt=np.float64(wd.pwave_timestep(model)), critical_dt=np.float64(wd.critical_timestep(model)),
        springs=np.int64(springs), spring_model=np.array(config.spring_model), stop_ratio=np.float64(sb.STOP_RATIO),
        support_offset=np.float64(info["support_offset_m"][0]), measured_damping=np.float64(zeta),
        spring_stiffness_din=np.float64(row["stiffness_n_per_m"]),
        dashpot_f64=np.float64(sb.dashpot_for(tool, np.array([row["stiffness_n_per_m"]]), np.array([zeta]))[0]),
        tool_mass=np.float64(mass), tool_com=com, tool_quat=st["body_quat"][tb].copy(),
        tool_inertia_principal=h["body_inertia"][tb].copy(), tool_inertia_com=i_com, tool_pivot=pivot,
        tool_pivot_local=pivot_local.copy(), tool_inertia_pivot=i_p, tool_ip_xx=np.float64(i_p[0, 0]),
        tool_blocked=np.array("YZ"), tool_flags=np.int64(h["body_flags"][tb]),
        tool_pivot_friction=np.float64(model.body_pivot_friction.numpy()[tb]),
        pivot_velocity=st["body_vel"][tb].copy(), tool_velocity=st["body_vel"][tb].copy(),
        tool_pivot_geometry=np.asarray(tool.pivot), sensor_point=np.asarray(tool.sensor_point), lever=np.float64(lever),
        tool_com_geometry=np.asarray(tool.com), tool_mass_geometry=np.float64(tool.mass),
        spring_point_a_local=pa, spring_point_b_local=pb, carriage_pos=st["body_pos"][cb].copy(),
        carriage_velocity=st["body_vel"][cb].copy(), spring_anchor=anchor, spring_attach=attach,
        k_rot=np.float64(k_rot), ring_freq_hz=np.float64(f0),
        ring_freq_damped_hz=np.float64(f0 * math.sqrt(max(0.0, 1 - zeta**2))),
        **{"spring_" + k: np.float64(v) for k, v in sp.items()},
    )
    data.update(rigid_ex.material_keys("soil", config.soil_material(), model, model.names["material"]["soil"]))
    tool_m = wd.Material(young=paper.TOOL_YOUNG, poisson=paper.TOOL_POISSON, density=7850.0,
                         friction_angle=paper.TOOL_FRICTION)
    data.update(rigid_ex.material_keys("tool", tool_m, model, model.names["material"]["tool"]))
    # the model's pivot is the tool's; the spring's ends are the carriage's anchor and the sensor point
    assert np.abs(pivot - tool.pivot).max() < 1e-12, (pivot, tool.pivot)
    assert np.abs(attach - tool.sensor_point).max() < 1e-7, (attach, tool.sensor_point)
    return data


def warpdem_runs(assembly: str, springs: int, spec: dict[str, np.ndarray], seeds: list[int],
                 support_offset: bool = True) -> dict[str, np.ndarray]:
    """run_soil_bin itself on the exported bed (and each seed's shifted bed); its series and the hook's records."""
    rigid = rigid_cmp.load(HERE / rigid_ex.spec_name(assembly))
    config = config_for(assembly, springs, support_offset)
    keys = ("draught", "displacement", "rotation", "spring_force", "ke_tool")
    out: dict[str, list] = {k: [] for k in keys}
    steady_d, steady_x, walls, checks = [], [], [], []
    step = time_ = None
    for seed in [None] + list(seeds):
        bed, tool = rigid_cmp.spec_bed_and_tool(assembly, rigid, seed)
        hook = Hook(spec, perturbed=seed is not None)
        t0 = time.perf_counter()
        run = sb.run_soil_bin(config, [springs], bed=bed, device="cpu", viewer=hook, tool=tool, place=False)
        wall = time.perf_counter() - t0
        rows = np.array(hook.rows)
        st_ = np.round(run.time / run.dt).astype(int)
        if not np.array_equal(rows[:, 0].astype(int), st_):
            raise AssertionError("hook records do not match run_soil_bin's records")
        step, time_ = st_, run.time
        out["draught"].append(run.series["draught"][:, 0])
        out["displacement"].append(run.series["displacement"][:, 0])
        out["rotation"].append(rows[:, 1])
        out["spring_force"].append(rows[:, 3])
        out["ke_tool"].append(run.series["ke_tool"][:, 0].sum(axis=-1))
        r = run.steady[0]
        steady_d.append([r["draught_mean"], r["draught_std"], r["draught_sem"]])
        steady_x.append([r["displacement_mean"], r["displacement_std"], r["displacement_sem"]])
        walls.append(wall)
        checks.append(hook.check)
        print(f"  warpdem {assembly} {springs} springs, {'main' if seed is None else f'seed {seed}'}: draught "
              f"{r['draught_mean']:.1f} +- {r['draught_sem']:.1f} N, displacement {1e3 * r['displacement_mean']:.3f} "
              f"+- {1e3 * r['displacement_sem']:.3f} mm, rotation end {math.degrees(rows[-1, 1]):.3f} deg; "
              f"{wall:.1f} s", flush=True)
    res = {f"warp_{k}": np.array(v, dtype=np.float32) for k, v in out.items()}  # records: float32 (small files)
    res.update(warp_seeds=np.array([-1] + list(seeds), np.int64), warp_step=step, warp_time=time_,
               warp_steady_draught=np.array(steady_d), warp_steady_displacement=np.array(steady_x),
               warp_wall_s=np.array(walls), warp_scene_check=np.array(json.dumps(checks)))
    return res


def per_facet_run(assembly: str, springs: int, spec: dict[str, np.ndarray], seed: int | None) -> dict[str, np.ndarray]:
    """A diagnostic, not run_soil_bin: the same scene rebuilt with build_scene's calls (same order, values and
    overrides) except that every triangle of the sweep is its own mesh (all on the one hinged body), which is how
    Yade's facets behave: a sphere on an edge or vertex shared by several triangles gets a contact with each
    (warpdem merges the contacts of one mesh). Returns its records (as warpdem_runs' keys)."""
    rigid = rigid_cmp.load(HERE / rigid_ex.spec_name(assembly))
    config = config_for(assembly, springs)
    bed, tool = rigid_cmp.spec_bed_and_tool(assembly, rigid, seed)
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("soil", config.soil_material())
    b.add_material("tool", wd.Material(young=paper.TOOL_YOUNG, poisson=paper.TOOL_POISSON, density=7850.0,
                                       friction_angle=paper.TOOL_FRICTION))
    v, f = sb.bin_mesh(bed.bin_size)
    b.add_mesh("bin", v, f, "tool")
    v0 = (0.0, SPEED, 0.0)
    tri = np.array([[0, 1, 2]])
    low, up = tool.lower.vertices[tool.lower.faces], tool.upper.vertices[tool.upper.faces]
    body = b.add_mesh("sweep_lower", low[0], tri, "tool", kind="dynamic", mass=tool.mass, com=tool.com,
                      inertia=tool.inertia, blocked="YZ", pivot=tool.pivot, velocity=v0, group="tool")
    for k in range(1, len(low)):
        b.add_mesh(f"lower{k}", low[k], tri, "tool", body=body)
    for k in range(len(up)):
        b.add_mesh(f"upper{k}", up[k], tri, "tool", body=body)
    bed.add_to(b, "soil", group="soil", keep=sb.clear_start(bed, tool))
    s = np.asarray(tool.sensor_point)
    length = 0.1
    carriage_pos = s - (0.0, length, 0.0)
    carriage = b.add_rigid_body(carriage_pos, name="carriage", velocity=v0)
    b.add_spring("spring", carriage, carriage_pos, body, s, stiffness=1.0, rest_length=length)
    row = paper.ringing_row(springs)
    k = np.array([row["stiffness_n_per_m"]])
    model, state = b.finalize("cpu", n_worlds=1, overrides={
        "body:sweep_lower:velocity": [v0], "body:carriage:velocity": [v0], "spring:spring:stiffness": k,
        "spring:spring:damping": sb.dashpot_for(tool, k, np.array([row["measured_damping"]])),
        "spring:spring:point_a": [carriage_pos - (0.0, float(spec["support_offset"]), 0.0)]})
    sim = wd.Simulation(model, state, dt=float(spec["dt"]), always_use_moment_law=True,
                        bounds=(spec["bounds_lo"], spec["bounds_hi"]), cohesion_on_new_contacts=False)
    if sim.dt != float(spec["dt"]) or float(model.spring_damping.numpy()[0]) != float(spec["spring_damping"]):
        raise AssertionError("per-facet scene differs from the spec")
    sim.set_cohesion_now()
    names = model.names["mesh"]
    lower = [names["sweep_lower"]] + [names[f"lower{k}"] for k in range(1, len(low))]
    tb = model.names["body"]["sweep_lower"]
    q0 = sim.state.numpy()["body_quat"][tb].copy()
    sensor = wd.observers.body_point("sweep_lower", s)
    s0 = float(sensor(sim)[0, 1])
    speed = float(spec["speed"])

    def pose(sm: wd.Simulation) -> np.ndarray:
        st = sm.state.numpy()
        return np.array([rotation_x(st["body_quat"][tb], q0), st["body_angvel"][tb][0]])

    t0 = time.perf_counter()
    out = sim.run(int(spec["n_steps"]), record_every=int(spec["record_every"]), observers={
        "draught": lambda sm: -float(sm.data.mesh_force.numpy()[lower, 1].sum()),
        "displacement": lambda sm: -(float(sensor(sm)[0, 1]) - s0 - speed * sm.state.time),
        "pose": pose, "spring_force": wd.observers.spring_force("spring"),
        "ke_tool": lambda sm: float(wd.observers.group_kinetic_energy("tool")(sm)[0].sum())})
    return {"draught": out["draught"], "displacement": out["displacement"], "rotation": out["pose"][:, 0],
            "angvel": out["pose"][:, 1], "spring_force": np.asarray(out["spring_force"]).reshape(-1),
            "ke_tool": out["ke_tool"], "wall_s": time.perf_counter() - t0, "step": np.round(out["time"] / sim.dt)}


def per_facet_runs(assembly: str, springs: int, spec: dict[str, np.ndarray], seeds: list[int]
                   ) -> dict[str, np.ndarray]:
    """per_facet_run on the main bed and every seed's: keys ``facet_<key>`` (R, k) float32, ``facet_wall_s``."""
    runs = []
    for seed in [None] + list(seeds):
        r = per_facet_run(assembly, springs, spec, seed)
        if not np.array_equal(r["step"].astype(int), spec["warp_step"]):
            raise AssertionError("per-facet records are not run_soil_bin's")
        st = rigid_cmp.steady(spec["warp_time"], r["draught"], spec)
        print(f"  warpdem per facet {assembly} {springs} springs, {'main' if seed is None else f'seed {seed}'}: "
              f"draught {st.mean:.1f} +- {st.sem:.1f} N; {r['wall_s']:.1f} s", flush=True)
        runs.append(r)
    out = {f"facet_{k}": np.array([r[k] for r in runs], dtype=np.float32)
           for k in ("draught", "displacement", "rotation", "spring_force")}
    out["facet_wall_s"] = np.array([r["wall_s"] for r in runs])
    return out


EFFECT_CASES = {  # name: (run_soil_bin knobs, pitch, the Yade script's options)
    "clean": ({}, None, ""),
    "start1": ({}, [1.0], "--start-rotation 1"),
    "preload1mm": ({"stack_preload": [1e-3]}, None, "--preload 1e-3"),
    "friction0.5": ({"pivot_friction": [0.5]}, None, "--pivot-friction 0.5"),
    "mass2": ({"extra_mass": [2.0]}, None, "--extra-mass 2"),
}
EFFECT_TRAVEL = 0.012
"""[m] of travel of the hidden-effect checks (250 steps at 0.62 m/s: the tool swings free of the soil for the
first ~175 steps)."""


def effects_check(assembly: str, springs: int) -> Path:
    """run_soil_bin with each of warpdem's own knobs (or pitch) that the Yade script's hidden-effect options copy
    (EFFECT_CASES), on the exported bed for EFFECT_TRAVEL: per record the tool's rotation about +x from the drawing
    pose (atan2(M21, M11), M = R(q) R(q_drawing)^T, q_drawing the spec's tool_quat), the displacement and the spring
    force, into passive_twin_effects_<A>_<springs>.npz (keys ``<case>_rotation``, ``<case>_displacement``,
    ``<case>_spring_force``, ``step``, ``yade_options`` (json: case -> the Yade script's options))."""
    rigid = rigid_cmp.load(HERE / rigid_ex.spec_name(assembly))
    q_draw = rigid_cmp.load(HERE / spec_name(assembly, springs))["tool_quat"]
    out: dict[str, np.ndarray] = {}
    for name, (knobs, pitch, _) in EFFECT_CASES.items():
        config = sb.SoilBinConfig(scale="ci", assembly=assembly, springs=(springs,), parameter_set=PARAMETER_SET,
                                  speed=(SPEED,), travel=EFFECT_TRAVEL, steady_travel=EFFECT_TRAVEL / 2)
        bed, tool = rigid_cmp.spec_bed_and_tool(assembly, rigid)
        rows: list[tuple[float, ...]] = []

        def viewer(sim: wd.Simulation, rows: list = rows) -> object:
            tb = sim.model.names["body"]["sweep_lower"]

            class Rec:
                def as_observer(self, _o: dict | None = None) -> object:
                    def f(sm: wd.Simulation) -> np.ndarray:
                        q = sm.state.numpy()["body_quat"][tb]
                        rows.append((sm.state.step, rotation_x(q, q_draw), float(sm.data.spring_force.numpy()[0])))
                        return np.zeros(1)

                    return f

                def close(self) -> None:
                    pass

            return Rec()

        run = sb.run_soil_bin(config, [springs], bed=bed, device="cpu", viewer=viewer, tool=tool, place=False,
                              knobs=knobs or None, pitch=pitch)
        r = np.array(rows)
        out["step"] = r[:, 0].astype(np.int64)
        out[f"{name}_rotation"] = r[:, 1]
        out[f"{name}_displacement"] = run.series["displacement"][:, 0]
        out[f"{name}_spring_force"] = r[:, 2]
    out["yade_options"] = np.array(json.dumps({k: v[2] for k, v in EFFECT_CASES.items()}))
    path = HERE / f"passive_twin_effects_{assembly}_{springs}.npz"
    np.savez_compressed(path, **out)
    print(f"  wrote {path.relative_to(ROOT)} ({path.stat().st_size} bytes)", flush=True)
    return path


def export(assembly: str, springs: int, seeds: list[int], per_facet: bool = False, support_offset: bool = True,
           warpdem: bool = True) -> Path:
    """The spec (scene_spec) with warpdem's runs (main bed and ``seeds``; none with ``warpdem=False``: the scene
    only) and, with ``per_facet``, the per-facet rebuild's; ``support_offset=False``: Table 2's support offsets off
    (SoilBinConfig(support_offset=False), the rig model's baseline) -> passive_twin_spec_<A>_<n>_nooffset.npz."""
    t0 = time.perf_counter()
    data = scene_spec(assembly, springs, support_offset)
    if warpdem:
        data.update(warpdem_runs(assembly, springs, data, seeds, support_offset))
    if per_facet:
        if not (warpdem and support_offset):
            raise SystemExit("--per-facet needs warpdem's runs and the support offsets (the report's set-up)")
        data.update(per_facet_runs(assembly, springs, data, seeds))
    out = HERE / spec_name(assembly, springs, support_offset)
    np.savez_compressed(out, **data)
    print(f"  {assembly} {springs} springs: {int(data['n_particles'])} particles, dt = {float(data['dt']):.6e} s, "
          f"{int(data['n_steps'])} steps; k = {float(data['spring_stiffness']):.0f} N/m, c = "
          f"{float(data['spring_damping']):.2f} N s/m, offset {1e3 * float(data['support_offset']):+.1f} mm, I_p = "
          f"{float(data['tool_ip_xx']):.5f} kg m^2, ring {float(data['ring_freq_hz']):.3f} Hz; wrote "
          f"{out.relative_to(ROOT)} ({out.stat().st_size} bytes) in {time.perf_counter() - t0:.1f} s", flush=True)
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("assemblies", nargs="*", default=["A"])
    ap.add_argument("--springs", nargs="+", type=int, default=[16, 32])
    ap.add_argument("--seeds", nargs="*", type=int, default=[])
    ap.add_argument("--per-facet", action="store_true",
                    help="also run the diagnostic rebuild with one mesh per sweep triangle (Yade's facets)")
    ap.add_argument("--effects-check", action="store_true",
                    help="only the hidden-effect check (effects_check) for the existing specs")
    ap.add_argument("--no-support-offset", action="store_true",
                    help="Table 2's support offsets off (the rig model's baseline): "
                         "passive_twin_spec_<A>_<n>_nooffset.npz")
    ap.add_argument("--no-warpdem", action="store_true", help="the scene only: no run_soil_bin runs")
    a = ap.parse_args()
    for asm in a.assemblies:
        for n in a.springs:
            if n not in paper.SPRING_COUNTS:
                raise SystemExit(f"springs must be among {paper.SPRING_COUNTS}, got {n}")
            if a.effects_check:
                effects_check(asm.upper(), n)
            else:
                export(asm.upper(), n, a.seeds, a.per_facet, support_offset=not a.no_support_offset,
                       warpdem=not a.no_warpdem)
