"""The ringing rig as the paper's text builds it (section 2.1.1, Fig. 1c, Table 1), for warpdem and Yade alike.

warpdem's everyday ringing rig (``scenes.ringing``) hinges the tool on a joint and pins the load at the blade tip.
The paper's Yade rig has no joint: the tool is a clump of facets free to translate in y and z and to turn about x
(translation along x and rotations about y and z blocked), held by contacts only:

- a fixed ball (r 19 mm, rho 7850, friction 5 deg) in the hole at the shank's top end ("the centre of the sweep
  tool's rotations was contained in a specially adapted sphere, located in the hole");
- three spring spheres (r 20 mm, rho 100, nu 0.3, friction 5 deg, cohesion 2e4 / 1e4 Pa, eta 0.001, Table 2's E and
  local damping; DoFs: translation along y and rotation about y) between the shank's rear face and a fixed support
  sphere;
- the load: a sphere of r 15 mm (E 1e7, nu 0.3, friction 60 deg; DoFs y and z) resting on the tool under gravity
  (here on a horizontal load plate, one triangle of the tool 50 mm above the blade tip and 70 mm forward of the
  pivot: the paper does not say where the load touches; on the blade in front of the shank the sphere would sit
  on facet seams and edges, where Yade counts a contact per facet and warpdem one, which a twin must avoid).

:func:`twin_spec` writes that rig as plain arrays (geometry, materials, readings, time step, hit): the single
source of truth from which both engines build it (``benchmarks/yade/ringing_twin.py`` in Yade 2023.02a,
:func:`run_twin` in warpdem). Geometry: warpdem's parametric sweep (``scenes.sweep``; the paper's STL is not
published) with the upper shank cut 35 mm below the pivot and a 12-sided tube of facets (inscribed radius 19 mm)
around the pivot as the hole; the ball touches every side of the tube at one point inside a triangle (the tube is
offset along x so that no contact point lies on a diagonal).

Readings of what the text leaves open (each a variant of the spec):

- ``inertia``: "parallel_axis" (eq. (1) read as SolidWorks products about the CAD origin and moved to the centre
  of mass, as ``scenes.sweep`` does: the tensor about the COM) or "diagonal" (eq. (1)'s diagonal used as the
  clump's principal moments about its COM, world axes: "the values of the diagonal of this matrix shall be
  specified in the simulation setup");
- ``load_mass``: "stated" (Table 1's density 1.866e6 kg/m^3: 26.4 kg) or "20kg" (the "calculated to be 20 kg");
- ``damping``: "springs" (local damping on the spring spheres only, Yade's ``State.isDamped``) or "all" (every
  body damped by the configuration's coefficient).
Not varied here (one choice, stated): where the load sphere touches the tool (the load plate above); the pivot
ball's Young's modulus (Table 1's "1.10" read as 1e9 Pa, the tool's); the hit (an angular velocity about x, the same
in both engines).
"""

from __future__ import annotations

import math

import numpy as np

from . import paper
from .sweep import PAPER_PRODUCTS_CAD, SweepTool, build_sweep

PIVOT_BALL = {"radius": 0.019, "young": 1e9, "poisson": 0.3, "density": 7850.0, "friction_angle": 5.0}
"""Table 1's fixed ball at the centre of the tool's rotation (its Young's modulus printed as "1.10": read 1e9 Pa)."""
LOAD_SPHERE = {"radius": paper.LOAD_RADIUS, "young": paper.LOAD_YOUNG, "poisson": 0.3, "density": 1.866e6,
               "friction_angle": paper.LOAD_FRICTION}
"""Table 1's loading sphere (its density as printed: 26.4 kg with r 15 mm)."""
TOOL = {"young": paper.TOOL_YOUNG, "poisson": paper.TOOL_POISSON, "friction_angle": paper.TOOL_FRICTION,
        "mass": 7.692}
"""Table 1's STL geometry (dynamic) and the mass of section 2.1.1."""
HOLE_SIDES = 12
SHANK_CUT = 0.035
"""the upper shank ends this far below the pivot [m] (the ball, r 19 mm, sits above it in the tube)."""
LOAD_PLATE = {"y": 0.03, "length": 0.10, "half_width": 0.05, "height": 0.05, "load_y": 0.07}
"""the load plate [m]: one horizontal triangle on the tool, forward of the pivot, ``height`` above the blade tip,
its base at y = ``y`` (``half_width`` to each side) and its apex ``length`` further forward; the load sphere's centre
at y = ``load_y`` (30 mm from the nearest edge). The moment of the load about the pivot presses the shank into the
spring column."""
INITIAL_OVERLAP = 1e-6
"""overlap [m] of each contact of the spring column at the start (spheres, support, shank)."""
SETTLE_TIME, RING_TIME = 0.3, 1.5
"""[s]: settling under gravity with damping 0.7 on every dynamic body, then free ringing after the hit."""
SETTLE_DAMPING = 0.7
HIT_SWING = 5e-5
"""the hit: an angular velocity about x that would swing the sensor point by this much [m] at Table 2's measured
frequency, w0 = 2 pi f HIT_SWING / 0.1 m (backwards, like a blow on the blade's front)."""
READINGS = {
    "stated": {"inertia": "parallel_axis", "load_mass": "stated", "damping": "springs"},
    "inertia_diagonal": {"inertia": "diagonal", "load_mass": "stated", "damping": "springs"},
    "load_20kg": {"inertia": "parallel_axis", "load_mass": "20kg", "damping": "springs"},
    "damping_all": {"inertia": "parallel_axis", "load_mass": "stated", "damping": "all"},
}
"""the variants run in both engines: name -> readings."""


def _tube(centre: np.ndarray, radius: float, x0: float, x1: float, sides: int) -> tuple[np.ndarray, np.ndarray]:
    """A tube of ``sides`` flat sides around the x axis through ``centre``, inscribed radius ``radius`` [m], from
    x0 to x1 [m]: vertices (2 sides, 3), faces (2 sides, 3). Each quad is split along one diagonal."""
    r_corner = radius / math.cos(math.pi / sides)
    ang = 2 * math.pi * (np.arange(sides) + 0.5) / sides
    ring = np.stack([np.cos(ang), np.sin(ang)], axis=1) * r_corner
    v = np.concatenate([np.column_stack([np.full(sides, x), centre[1] + ring[:, 0], centre[2] + ring[:, 1]])
                        for x in (x0, x1)])
    f = []
    for k in range(sides):
        a, b = k, (k + 1) % sides
        f += [(a, b, b + sides), (a, b + sides, a + sides)]
    return v, np.array(f, dtype=np.int64)


def _box(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A closed box [m]: vertices (8, 3), faces (12, 3) (outward)."""
    x = [lo[0], hi[0]]
    y = [lo[1], hi[1]]
    z = [lo[2], hi[2]]
    v = np.array([[x[i], y[j], z[k]] for k in (0, 1) for j in (0, 1) for i in (0, 1)], dtype=np.float64)
    f = [(0, 2, 3), (0, 3, 1), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4),
         (2, 6, 7), (2, 7, 3), (0, 4, 6), (0, 6, 2), (1, 3, 7), (1, 7, 5)]
    return v, np.array(f, dtype=np.int64)


def twin_tool(tool: SweepTool | None = None) -> dict[str, np.ndarray]:
    """The twin's tool geometry [m]: lower half (blade + lower shank, as ``scenes.sweep``), upper half (the upper
    shank cut SHANK_CUT below the pivot, the tube around the pivot and the load plate), key points."""
    tool = tool or build_sweep()
    up = tool.upper.vertices
    shank_v, shank_f = _box(np.array([up[:, 0].min(), up[:, 1].min(), up[:, 2].min()]),
                            np.array([up[:, 0].max(), up[:, 1].max(), tool.pivot[2] - SHANK_CUT]))
    r = PIVOT_BALL["radius"]
    # the ball touches each side at x = pivot x; the tube runs from -1/4 to +3/4 of its length around it, so
    # that point lies inside one triangle of each side, not on the diagonal
    length = 0.02
    tube_v, tube_f = _tube(tool.pivot, r, tool.pivot[0] - 0.25 * length, tool.pivot[0] + 0.75 * length, HOLE_SIDES)
    plate_v, plate_f = load_plate(tool)
    upper_v = np.concatenate([shank_v, tube_v, plate_v])
    upper_f = np.concatenate([shank_f, tube_f + len(shank_v), plate_f + len(shank_v) + len(tube_v)])
    return {"lower_vertices": tool.lower.vertices, "lower_faces": tool.lower.faces, "upper_vertices": upper_v,
            "upper_faces": upper_f, "pivot": tool.pivot, "sensor_point": tool.sensor_point, "tip": tool.tip,
            "com": tool.com, "inertia_parallel_axis": tool.inertia,
            "inertia_diagonal": np.diag(np.diag(PAPER_PRODUCTS_CAD)).astype(np.float64)}


def load_plate(tool: SweepTool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The horizontal triangle [m] the load sphere rests on: vertices (3, 3), faces (1, 3). One triangle, so the
    sphere touches one face far from every edge (on a seam of two facets Yade makes two contacts and warpdem one)."""
    tool = tool or build_sweep()
    y0, z = LOAD_PLATE["y"], float(tool.tip[2]) + LOAD_PLATE["height"]
    half, length = LOAD_PLATE["half_width"], LOAD_PLATE["length"]
    x = float(tool.pivot[0])
    v = np.array([[x - half, y0, z], [x + half, y0, z], [x, y0 + length, z]], dtype=np.float64)
    return v, np.array([[0, 1, 2]], dtype=np.int64)


def load_position(tool: SweepTool | None = None) -> np.ndarray:
    """Centre [m] (3,) of the load sphere resting on the load plate (touching it, no overlap)."""
    tool = tool or build_sweep()
    v, _ = load_plate(tool)
    return np.array([float(tool.pivot[0]), LOAD_PLATE["load_y"], v[0, 2] + LOAD_SPHERE["radius"]])


def twin_spec(tool: SweepTool | None = None) -> dict[str, np.ndarray]:
    """Every input of the twin as arrays (SI): geometry (:func:`twin_tool`), spheres, materials, Table 2's genes
    per configuration, readings, time step, settling, ringing and the hit."""
    tool = tool or build_sweep()
    geo = twin_tool(tool)
    s = np.asarray(tool.sensor_point, dtype=np.float64)
    sp = paper.SPRING_SPHERE
    r = sp["radius"]
    rows = [paper.ringing_row(n) for n in paper.SPRING_COUNTS]
    spec: dict[str, np.ndarray] = {
        **geo,
        "tool_mass": np.float64(TOOL["mass"]), "tool_young": np.float64(TOOL["young"]),
        "tool_poisson": np.float64(TOOL["poisson"]), "tool_friction_deg": np.float64(TOOL["friction_angle"]),
        "pivot_ball_centre": np.asarray(tool.pivot, dtype=np.float64),
        **{f"pivot_ball_{k}": np.float64(v) for k, v in PIVOT_BALL.items()},
        # spring spheres 3, 2, 1 from the shank backwards, then the support sphere: each INITIAL_OVERLAP into
        # its neighbour (and sphere 3 into the shank), so that both engines have the column's contacts (and bond
        # them) at the first step
        "spring_centres": np.array([s - (0.0, r - INITIAL_OVERLAP + k * (2 * r - INITIAL_OVERLAP), 0.0)
                                    for k in range(3)]),
        "support_centre": s - (0.0, r - INITIAL_OVERLAP + 3 * (2 * r - INITIAL_OVERLAP), 0.0),
        "initial_overlap": np.float64(INITIAL_OVERLAP),
        **{f"spring_{k}": np.float64(v) for k, v in sp.items()},
        "load_centre": load_position(tool),
        **{f"load_{k}": np.float64(v) for k, v in LOAD_SPHERE.items()},
        "load_density_20kg": np.float64(20.0 / (4.0 / 3.0 * math.pi * LOAD_SPHERE["radius"] ** 3)),
        "springs": np.array(paper.SPRING_COUNTS, dtype=np.int64),
        "spring_young_table2": np.array([rw["dem_spring_young_pa"] for rw in rows]),
        "local_damping_table2": np.array([rw["dem_local_damping"] for rw in rows]),
        "measured_freq_hz": np.array([rw["measured_freq_hz"] for rw in rows]),
        "calibrated_freq_hz": np.array([rw["calibrated_freq_hz"] for rw in rows]),
        "calibrated_damping": np.array([rw["calibrated_damping"] for rw in rows]),
        "dt": np.float64(paper.RINGING_DT), "gravity": np.array([0.0, 0.0, -9.81]),
        "settle_time": np.float64(SETTLE_TIME), "settle_damping": np.float64(SETTLE_DAMPING),
        "ring_time": np.float64(RING_TIME), "sample_rate": np.float64(paper.SAMPLE_RATE),
        "hit_angvel_x": np.array([-2 * math.pi * rw["measured_freq_hz"] * HIT_SWING / 0.1 for rw in rows]),
        "reading_names": np.array(list(READINGS)),
        "reading_inertia": np.array([v["inertia"] for v in READINGS.values()]),
        "reading_load_mass": np.array([v["load_mass"] for v in READINGS.values()]),
        "reading_damping": np.array([v["damping"] for v in READINGS.values()]),
    }
    return spec


def _spec_value(spec: dict[str, np.ndarray], key: str) -> float:
    return float(np.asarray(spec[key]))


def build_twin(spec: dict[str, np.ndarray], reading: str, configs: list[int] | None = None,
               spring_young: np.ndarray | None = None):
    """warpdem's model of the twin for one reading: one world per configuration index of ``configs`` (default
    all of the spec's; an index may repeat). ``spring_young``: the spring spheres' Young's modulus per world [Pa]
    (n_worlds,) instead of the spec's (Table 2's). Returns (builder, overrides, info)."""
    import warpdem as wd

    if reading not in READINGS:
        raise ValueError(f"reading must be one of {sorted(READINGS)}, got {reading!r}")
    rd = READINGS[reading]
    configs = list(range(len(spec["springs"]))) if configs is None else list(configs)
    b = wd.ModelBuilder(gravity=tuple(np.asarray(spec["gravity"], dtype=float)))
    b.add_material("tool", wd.Material(young=_spec_value(spec, "tool_young"),
                                       poisson=_spec_value(spec, "tool_poisson"), density=7850.0,
                                       friction_angle=_spec_value(spec, "tool_friction_deg"), cohesive=False))
    b.add_material("pivot", wd.Material(young=_spec_value(spec, "pivot_ball_young"),
                                        poisson=_spec_value(spec, "pivot_ball_poisson"),
                                        density=_spec_value(spec, "pivot_ball_density"),
                                        friction_angle=_spec_value(spec, "pivot_ball_friction_angle"),
                                        cohesive=False))
    eta = _spec_value(spec, "spring_eta_roll")
    young = np.asarray(spec["spring_young_table2"], dtype=float)[configs] if spring_young is None else \
        np.broadcast_to(np.asarray(spring_young, dtype=float), (len(configs),)).copy()
    b.add_material("spring", wd.Material(young=float(young[0]), poisson=_spec_value(spec, "spring_poisson"),
                                         density=_spec_value(spec, "spring_density"),
                                         friction_angle=_spec_value(spec, "spring_friction_angle"),
                                         normal_cohesion=_spec_value(spec, "spring_normal_cohesion"),
                                         shear_cohesion=_spec_value(spec, "spring_shear_cohesion"),
                                         eta_roll=eta, eta_twist=eta, moment_law=True))
    density = _spec_value(spec, "load_density" if rd["load_mass"] == "stated" else "load_density_20kg")
    b.add_material("load", wd.Material(young=_spec_value(spec, "load_young"), poisson=_spec_value(spec, "load_poisson"),
                                       density=density, friction_angle=_spec_value(spec, "load_friction_angle"),
                                       cohesive=False))
    inertia = np.asarray(spec["inertia_parallel_axis" if rd["inertia"] == "parallel_axis" else "inertia_diagonal"],
                         dtype=float)
    body = b.add_mesh("tool_lower", spec["lower_vertices"], spec["lower_faces"], "tool", kind="dynamic",
                      mass=_spec_value(spec, "tool_mass"), com=spec["com"], inertia=inertia, blocked="xYZ",
                      group="tool")
    b.add_mesh("tool_upper", spec["upper_vertices"], spec["upper_faces"], "tool", body=body)
    b.add_sphere(spec["pivot_ball_centre"], _spec_value(spec, "pivot_ball_radius"), "pivot", blocked="xyzXYZ",
                 group="pivot")
    r = _spec_value(spec, "spring_radius")
    for c in np.asarray(spec["spring_centres"], dtype=float):
        b.add_sphere(c, r, "spring", blocked="xzXZ", group="springs")
    b.add_sphere(spec["support_centre"], r, "spring", blocked="xyzXYZ", group="support")
    b.add_sphere(spec["load_centre"], _spec_value(spec, "load_radius"), "load", blocked="xXYZ", group="load",
                 name="load")
    overrides = {"material:spring:young": young}
    return b, overrides, {"configs": configs, "reading": rd, "load_density": density}


def run_twin(spec: dict[str, np.ndarray], reading: str, configs: list[int] | None = None, *,
             spring_young: np.ndarray | None = None, local_damping: np.ndarray | None = None,
             device: str | None = None, ring_time: float | None = None, progress: object | None = None
             ) -> dict[str, np.ndarray]:
    """Settle, hit and ring the twin in warpdem, as the Yade script does (module docstring): one world per entry
    of ``configs`` (spec indices, default all; the hit is the configuration's). ``spring_young`` [Pa] and
    ``local_damping`` [-] (n_worlds,): the spring spheres' genes per world instead of Table 2's (a GA population).
    Returns time since the hit [s] (k,), the sensor point's y [m] (k, n), the settled state (sensor displacement
    y, z [m] (n,), load sphere centre [m] (n, 3)) and the wall time [s]."""
    import time

    import warpdem as wd

    t0 = time.perf_counter()
    b, overrides, info = build_twin(spec, reading, configs, spring_young)
    configs = info["configs"]
    model, state = b.finalize(device, n_worlds=len(configs), overrides=overrides)
    dt = _spec_value(spec, "dt")
    sim = wd.Simulation(model, state, dt=dt, always_use_moment_law=True)
    sim.set_cohesion_now()
    sensor = wd.observers.body_point("tool_lower", spec["sensor_point"])
    s0 = sensor(sim).copy()
    dynamic = ("tool", "springs", "load")
    for g in dynamic:
        sim.set_local_damping(g, _spec_value(spec, "settle_damping"))
    n_settle = int(round(_spec_value(spec, "settle_time") / dt))
    sim.run(n_settle, progress=(lambda d, n: progress("settle", d, n_settle)) if progress else None)
    damp = np.asarray(spec["local_damping_table2"], dtype=float)[configs] if local_damping is None else \
        np.broadcast_to(np.asarray(local_damping, dtype=float), (len(configs),)).copy()
    for g in dynamic:
        sim.set_local_damping(g, damp if (g == "springs" or info["reading"]["damping"] == "all") else 0.0)
    settled = sensor(sim) - s0
    # the hit: an angular velocity about x added to the tool, the tool's COM and the load sphere moving with it
    m = model
    tool = np.arange(m.n_worlds) * m.bodies_per_world + m.names["body"]["tool_lower"]
    load = np.arange(m.n_worlds) * m.bodies_per_world + m.names["body"]["load"]
    w = np.zeros((m.n_worlds, 3))
    w[:, 0] = np.asarray(spec["hit_angvel_x"], dtype=float)[configs]
    angvel, vel, pos = state.body_angvel.numpy().copy(), state.body_vel.numpy().copy(), state.body_pos.numpy()
    pivot = np.asarray(spec["pivot_ball_centre"], dtype=float)
    angvel[tool] += w
    vel[tool] += np.cross(w, pos[tool] - pivot)
    vel[load] += np.cross(w, pos[load] - pivot)
    state.body_angvel.assign(angvel)
    state.body_vel.assign(vel)
    load_centre = pos[load].copy()
    every = max(1, int(round(1.0 / (_spec_value(spec, "sample_rate") * dt))))
    ring = ring_time if ring_time is not None else _spec_value(spec, "ring_time")
    n_ring = int(round(ring / dt / every)) * every
    out = sim.run(n_ring, record_every=every, observers={"y": lambda s_: sensor(s_)[:, 1].copy()},
                  progress=(lambda d, n: progress("ring", d, n_ring)) if progress else None)
    return {"time": out["time"] - out["time"][0], "sensor_y": out["y"], "settle_sensor_y": settled[:, 1],
            "settle_sensor_z": settled[:, 2], "settled_load_centre": load_centre,
            "springs": np.asarray(spec["springs"])[configs], "wall_s": np.float64(time.perf_counter() - t0)}


LOWPASS_HZ = 30.0
"""the records are low-passed (zero-phase Butterworth) at this cutoff before the ringdown fit: the load sphere's own
~20 Hz contact mode and a ~50 Hz one ripple the signal by a few % and break the peak picker's steady rhythm."""


def frequency_damping(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Damped frequency [Hz] and damping ratio [-] of a ringing record (time [s] (k,), sensor y [m] (k,)) after a
    LOWPASS_HZ low-pass, by ``scenes.analysis.ringdown``'s fit; NaN where no free vibration is found."""
    from . import analysis

    fs = 1.0 / float(np.mean(np.diff(t)))
    try:
        r = analysis.ringdown(t, analysis.lowpass(y - y[0], fs, cutoff_hz=LOWPASS_HZ))
    except ValueError:
        return math.nan, math.nan
    return float(r.frequency_hz), float(r.damping_ratio)


def compare(yade: dict[str, np.ndarray], warp: dict[str, dict[str, np.ndarray]]) -> list[dict[str, object]]:
    """Rows (reading, springs): f [Hz] and zeta [-] of both engines' records and their relative differences, and
    Table 2's calibrated values. ``yade``: the Yade npz (keys f"{reading}/{springs}/time" and ".../sensor_y");
    ``warp``: reading -> :func:`run_twin` result."""
    rows = []
    for reading, w in warp.items():
        for k, n in enumerate(np.asarray(w["springs"]).tolist()):
            p = f"{reading}/{n}/"
            fy, zy = frequency_damping(np.asarray(yade[p + "time"]), np.asarray(yade[p + "sensor_y"]))
            fw, zw = frequency_damping(np.asarray(w["time"]), np.asarray(w["sensor_y"])[:, k])
            i = list(np.asarray(yade["springs"]).tolist()).index(n)
            rows.append({"reading": reading, "springs": n, "yade_f": fy, "yade_zeta": zy, "warp_f": fw,
                         "warp_zeta": zw, "df": (fw - fy) / fy, "dzeta": (zw - zy) / zy,
                         "table2_f": float(yade["calibrated_freq_hz"][i]),
                         "table2_zeta": float(yade["calibrated_damping"][i])})
    return rows
