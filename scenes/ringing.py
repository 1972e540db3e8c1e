"""The ringing test (section 2.1.1, Fig. 1c, Table 2): the sweep on its springs, a 200 N load, a hammer hit.

The rig, in the simulation frame (x lateral = pivot axis, y travel, z up; gravity -z):

- the sweep (``scenes.sweep``) hinged at its pivot (rotation about x only; the carriage stands still);
- the load: a body of mass F/g (200 N / g = 20.4 kg) pinned at the blade tip by a stiff spring (1e8 N/m, 350 Hz
  against the 2-10 Hz of the rig), its rotations and lateral translation blocked (the paper's loading sphere has
  DoFs y and z only). Its weight, forward of the pivot, turns the tool backwards like the draught, and its mass
  rides with the tool. It has no contact geometry (assumption: the paper does not say where its sphere touches);
- the springs, acting along +y on the shank's rear face at the sensor point, 100 mm below the pivot:
  model "paper": three spring spheres (r = 20 mm, rho = 100 kg/m^3, DoFs y and rotation about y) between the shank
  and a fixed support sphere, with Table 2's calibrated Young's modulus and local damping per configuration;
  model "linear": one linear spring-dashpot with the DIN 2093 stiffness of the configuration and a dashpot chosen
  for a damping ratio (default: Table 2's measured one) from the rig's own inertia and stiffness.

Procedure: settle under the load with heavy local damping, restore the damping of the model, hit: give the tool the
angular velocity that makes the sensor point swing by ``hit_amplitude`` times the static spring deflection, then
record the sensor point's displacement along y at 2400 Hz (the laboratory's strain-gauge rate) and fit frequency and
damping ratio by eqs. (3)-(5). All eight configurations run as the worlds of one simulation.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

import warpdem as wd
from warpdem.mass import quats_to_matrices

from . import analysis, paper
from .sweep import SweepTool, add_sweep, build_sweep

SPRING_MODELS = ("paper", "linear", "twin")
PER_WORLD = ("spring_young", "local_damping", "stiffness", "damping_ratio", "dashpot", "pivot_friction", "extra_mass",
             "progressive", "series_stiffness", "free_pose", "load_mass_fraction", "tool_mass_scale", "hit_velocity")
"""RingingConfig fields holding one value per world."""
LINEAR_ONLY = ("dashpot", "progressive", "series_stiffness", "free_pose")
PIN_STIFFNESS = 1e8
"""stiffness of the pin holding the load at the blade tip [N/m]."""
LOAD_ANCHOR = 100.0
"""distance below the blade tip [m] of the static anchor of the massless part of the load (a constant-force spring
along -z)."""
PIN_DAMPING_RATIO = 0.2
"""damping ratio of the pin holding the load (its own 350 Hz mode is damped out within a few periods)."""
SETTLE_DAMPING = 0.7
"""local damping during settling [-] (Cundall; removed before the hit)."""


@dataclass
class RingingConfig:
    """Parameters of a ringing run. Lengths [m], times [s], forces [N]."""

    springs: tuple[int, ...] = paper.SPRING_COUNTS
    """one world per entry; a count may repeat (e.g. a GA population of one configuration)."""
    spring_model: str = "paper"
    load_force: float = paper.LOAD_FORCE
    spring_young: tuple[float, ...] | None = None
    """model "paper": spring spheres' Young's modulus per world [Pa] (default: Table 2's calibrated)."""
    local_damping: tuple[float, ...] | None = None
    """model "paper": spring spheres' local damping per world [-] (default: Table 2's calibrated)."""
    stiffness: tuple[float, ...] | None = None
    """model "linear": spring stiffness per world [N/m] (default: the DIN 2093 stiffness of the configuration)."""
    damping_ratio: tuple[float, ...] | None = None
    """model "linear": target damping ratio per world (default: Table 2's measured)."""
    dashpot: tuple[float, ...] | None = None
    """model "linear": the dashpot's coefficient per world [N s/m]; given, it replaces ``damping_ratio``."""
    # Extensions of the rig (per world; None = absent). Model criticism (calibration.diagnosis) switches them on.
    pivot_friction: tuple[float, ...] | None = None
    """dry friction torque at the pivot [N m] (Coulomb; the tool sticks when the other torques cannot beat it)."""
    extra_mass: tuple[float, ...] | None = None
    """mass added to the tool [kg], distributed like the tool's own (preload hardware, clamps); its weight is
    carried by the spring's preload, so the pose stays the static equilibrium."""
    progressive: tuple[float, ...] | None = None
    """model "linear": cubic stiffness of the spring stack [N/m^3], F = k u + k3 u^3 about its free length: the
    tangent stiffness at the static deflection u0 is k + 3 k3 u0^2, larger for the softer stacks."""
    series_stiffness: tuple[float, ...] | None = None
    """model "linear": stiffness of the frame and shank in series with the springs [N/m] (inf: rigid): the stack
    then acts with k ks / (k + ks) (the frame taken massless; the dashpot acts across both; with a progressive
    stack, on the linear part only)."""
    load_mass_fraction: tuple[float, ...] | None = None
    """fraction of the load's mass (F/g) that rides with the tool, in [0, 1] (default 1: a dead weight); the rest
    of the load force acts without mass (a cable, lever or spring balance applying it), so the tool swings with
    less inertia under the same moment. 0 (no load body at all) must hold for every world or for none."""
    tool_mass_scale: tuple[float, ...] | None = None
    """factor on the tool's mass and inertia tensor (> 0; default 1): a rig whose tool is lighter or heavier than
    the sweep, its mass distributed like the sweep's."""
    load_offset: tuple[float, float] | None = None
    """where the load acts, from the pivot [m]: (forward along the blade tip's side, below); default the blade
    tip. The load's gravity stiffness is F x below, its moment F x forward, its riding mass's inertia
    m (forward^2 + below^2)."""
    hit_velocity: tuple[float, ...] | None = None
    """the sensor point's velocity along y given by the hit [m/s], per world, either sign (default: from
    ``hit_amplitude``); a swing of first amplitude A at angular frequency w needs about A w."""
    free_pose: tuple[float, ...] | None = None
    """model "linear": 1 = the spring is unloaded at the CAD pose and the tool settles under the load into its
    deflected pose (lever arms and the spring's line change with it); 0 = preloaded so that the CAD pose is the
    static equilibrium."""
    settle_time: float = 0.25
    ring_time: float = 2.0
    hit_amplitude: float = 0.5
    """sensor swing of the hit as a fraction of the static spring deflection (< 1 keeps spring spheres touching)."""
    sample_rate: float = paper.SAMPLE_RATE
    dt: float | None = None
    """time step [s]; default 0.5 x the critical step, at most half the sampling interval."""

    def __post_init__(self) -> None:
        if self.spring_model not in SPRING_MODELS:
            raise ValueError(f"spring_model must be one of {SPRING_MODELS}, got {self.spring_model!r}")
        for n in self.springs:
            if n not in paper.SPRING_COUNTS:
                raise ValueError(f"springs must be among {paper.SPRING_COUNTS}, got {n!r}")
        for name in ("load_force", "settle_time", "ring_time", "hit_amplitude", "sample_rate"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")
        if self.load_offset is not None:
            off = tuple(float(v) for v in self.load_offset)
            if len(off) != 2 or not all(math.isfinite(v) for v in off):
                raise ValueError(f"load_offset must be (forward, below) [m], got {self.load_offset!r}")
            self.load_offset = off
        for name in PER_WORLD:
            values = getattr(self, name)
            if values is None:
                continue
            values = tuple(float(v) for v in np.ravel(values))
            if len(values) != len(self.springs):
                raise ValueError(f"{name} needs one value per world ({len(self.springs)}), got {len(values)}")
            check_per_world(name, values)
            setattr(self, name, values)
        if self.spring_model in ("paper", "twin"):
            for name in LINEAR_ONLY:
                if getattr(self, name) is not None:
                    raise ValueError(f"{name} applies to spring_model 'linear' only")
        if self.spring_model == "twin":
            for name in ("pivot_friction", "extra_mass", "load_mass_fraction", "tool_mass_scale"):
                if getattr(self, name) is not None:
                    raise ValueError(f"{name} is not a setting of spring_model 'twin' (its pivot is a ball with "
                                     "friction, its load a sphere)")
            if self.load_force != paper.LOAD_FORCE:
                raise ValueError(f"spring_model 'twin' carries Table 1's load sphere; load_force must be "
                                 f"{paper.LOAD_FORCE}, got {self.load_force!r}")

    def per_world(self, name: str, column: str | float) -> np.ndarray:
        """The per-world values of field ``name``; where it is None, Table 2's ``column`` (a name) or a constant."""
        values = getattr(self, name)
        if values is None:
            if isinstance(column, str):
                values = [paper.ringing_row(n)[column] for n in self.springs]
            else:
                values = [column] * len(self.springs)
        return np.asarray(values, dtype=np.float64)


def check_per_world(name: str, values: tuple[float, ...]) -> None:
    """Check per-world values of a rig setting (ringing and soil bin): series_stiffness > 0 (inf: rigid),
    load_mass_fraction in [0, 1] (0 in every world or none), stiffness and tool_mass_scale finite and > 0,
    hit_velocity finite and non-zero, mount_pitch finite (either sign), anything else finite and >= 0."""
    if name == "series_stiffness":
        ok, rule = all(v > 0 and not math.isnan(v) for v in values), "positive (inf: rigid)"
    elif name == "load_mass_fraction":
        ok, rule = all(0 <= v <= 1 for v in values) and (all(v > 0 for v in values) or not any(values)), \
            "in [0, 1], 0 for every world or for none"
    elif name == "tool_mass_scale":
        ok, rule = all(math.isfinite(v) and v > 0 for v in values), "finite and positive"
    elif name == "hit_velocity":
        ok, rule = all(math.isfinite(v) and v != 0 for v in values), "finite and non-zero"
    elif name == "stiffness":
        ok, rule = all(math.isfinite(v) and v > 0 for v in values), "finite and positive"
    elif name == "mount_pitch":
        ok, rule = all(math.isfinite(v) for v in values), "finite"
    else:
        ok, rule = all(math.isfinite(v) and v >= 0 for v in values), "finite and non-negative"
    if not ok:
        raise ValueError(f"{name} must be {rule}, got {values}")


def series_rate(k: np.ndarray, k_s: np.ndarray) -> np.ndarray:
    """Rate [N/m] of springs k in series with a compliance of rate k_s (inf: rigid): k k_s / (k + k_s), (n,)."""
    k, k_s = np.asarray(k, dtype=np.float64), np.asarray(k_s, dtype=np.float64)
    rigid = np.isinf(k_s)
    finite = np.where(rigid, 1.0, k_s)
    return np.where(rigid, k, k * finite / (k + finite))


@dataclass
class RingingRig:
    """A built ringing rig: the builder, per-world overrides and the numbers needed to analyse it."""

    builder: wd.ModelBuilder
    overrides: dict[str, object]
    tool: SweepTool
    config: RingingConfig
    load_point: np.ndarray
    """where the load hangs (the blade tip) [m] (3,)."""
    lever: float
    """lever arm of the springs about the pivot [m]."""
    stiffness: np.ndarray
    """DIN 2093 stiffness per world [N/m] (n_worlds,)."""
    info: dict[str, object] = field(default_factory=dict)


def load_point_on(tool: SweepTool, load_offset: tuple[float, float] | None = None) -> np.ndarray:
    """Where the load acts [m] (3,): the blade tip, or ``load_offset`` = (forward on the tip's side, below) from the
    pivot."""
    tip = np.asarray(tool.tip, dtype=np.float64)
    if load_offset is None:
        return tip
    forward = math.copysign(1.0, tip[1] - tool.pivot[1])
    return tool.pivot + np.array([0.0, forward * load_offset[0], -load_offset[1]])


def rig_inertia(tool: SweepTool, load_mass: float, load_point: np.ndarray, tool_mass_scale: float = 1.0) -> float:
    """Moment of inertia of tool (its mass and inertia times ``tool_mass_scale``) + load (a point mass) about the
    pivot axis x [kg m^2]."""
    r = load_point - tool.pivot
    return float(tool_mass_scale * tool.inertia_about(tool.pivot)[0, 0] + load_mass * (r[1] ** 2 + r[2] ** 2))


def gravity_stiffness(tool: SweepTool, load_mass: float, load_point: np.ndarray, g: float = 9.81,
                      tool_mass_scale: float = 1.0) -> float:
    """Rotational stiffness of gravity about the pivot [N m/rad]: -m g z for the tool and the hanging load (a
    constant vertical load force acts like the weight of load_mass = F / g)."""
    return float(-tool_mass_scale * tool.mass * g * (tool.com[2] - tool.pivot[2])
                 - load_mass * g * (load_point[2] - tool.pivot[2]))


def gravity_moment(tool: SweepTool, load_mass: float, load_point: np.ndarray, g: float = 9.81) -> float:
    """Moment of the weights of tool and load about the pivot axis x at the initial pose [N m] (< 0: backwards)."""
    weight = np.array([0.0, 0.0, -g])
    m_tool = np.cross(tool.com - tool.pivot, tool.mass * weight)[0]
    return float(m_tool + np.cross(load_point - tool.pivot, load_mass * weight)[0])


def analytic_frequency(rig: RingingRig, stiffness: float, damping: float,
                       load_mass_fraction: float = 1.0, tool_mass_scale: float = 1.0) -> tuple[float, float]:
    """Damped frequency [Hz] and damping ratio of the linear-spring rig (small oscillations about equilibrium).

    I theta'' + c a^2 theta' + (k a^2 + K_g) theta = 0 with I the inertia of tool and the load's riding mass
    (``load_mass_fraction`` of F/g) about the pivot, a the spring's lever arm, K_g the stiffness of gravity and the
    load force (tool's centre of mass and the load point hang below the pivot; a constant vertical force acts like
    a weight). Neglected: the preload's geometric stiffness (F0 * 0.02 m < 0.2 % of k a^2) and the pin's compliance.
    """
    m_load = rig.config.load_force / 9.81
    inertia = rig_inertia(rig.tool, load_mass_fraction * m_load, rig.load_point, tool_mass_scale)
    k_rot = stiffness * rig.lever**2 + gravity_stiffness(rig.tool, m_load, rig.load_point,
                                                         tool_mass_scale=tool_mass_scale)
    wn = math.sqrt(k_rot / inertia)
    zeta = damping * rig.lever**2 / (2.0 * math.sqrt(k_rot * inertia))
    if zeta >= 1.0:
        return math.nan, zeta  # overdamped: no oscillation
    return wn * math.sqrt(1.0 - zeta**2) / (2.0 * math.pi), zeta


def build_ringing(config: RingingConfig | None = None, tool: SweepTool | None = None) -> RingingRig:
    """The ringing rig with one world per spring configuration in ``config.springs``."""
    cfg = config or RingingConfig()
    tool = tool or build_sweep()
    rows = [paper.ringing_row(n) for n in cfg.springs]
    stiffness = cfg.per_world("stiffness", "stiffness_n_per_m")
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("tool", wd.Material(young=paper.TOOL_YOUNG, poisson=paper.TOOL_POISSON, density=7850.0,
                                       friction_angle=paper.TOOL_FRICTION))
    add_sweep(b, tool, "tool", mount="hinged", group="tool")
    m_load = cfg.load_force / 9.81
    load_point = load_point_on(tool, cfg.load_offset)
    r_load = paper.LOAD_RADIUS
    massless = cfg.load_mass_fraction is not None and not any(cfg.load_mass_fraction)
    if not massless:
        b.add_rigid_body(load_point, mass=m_load, inertia=np.eye(3) * 0.4 * m_load * r_load**2, blocked="xXYZ",
                         group="load", name="load")
        b.add_spring("pin", b.body_names["sweep_lower"], load_point, b.body_names["load"], load_point,
                     stiffness=PIN_STIFFNESS, damping=2.0 * PIN_DAMPING_RATIO * math.sqrt(PIN_STIFFNESS * m_load),
                     rest_length=0.0)
    s = np.asarray(tool.sensor_point, dtype=np.float64)
    lever = float(abs(s[2] - tool.pivot[2]))
    overrides: dict[str, object] = {}
    if massless:  # the whole load force without mass, on the tool itself
        below = load_point - (0.0, 0.0, LOAD_ANCHOR)
        anchor = b.add_rigid_body(below, name="load_anchor")
        b.add_spring("load_force", anchor, below, b.body_names["sweep_lower"], load_point, stiffness=0.0)
        overrides["spring:load_force:preload"] = np.full(len(cfg.springs), cfg.load_force)
    elif cfg.load_mass_fraction is not None:
        # part of the load as mass on the pin, the rest a massless constant force (zero-rate spring, preloaded)
        frac = cfg.per_world("load_mass_fraction", 1.0)
        below = load_point - (0.0, 0.0, LOAD_ANCHOR)
        anchor = b.add_rigid_body(below, name="load_anchor")
        b.add_spring("load_force", anchor, below, b.body_names["sweep_lower"], load_point, stiffness=0.0)
        overrides["body:load:mass"] = frac * m_load
        overrides["spring:pin:damping"] = 2.0 * PIN_DAMPING_RATIO * np.sqrt(PIN_STIFFNESS * frac * m_load)
        overrides["spring:load_force:preload"] = (1.0 - frac) * cfg.load_force
    if cfg.pivot_friction is not None:
        overrides["body:sweep_lower:pivot_friction"] = cfg.per_world("pivot_friction", 0.0)
    extra = cfg.per_world("extra_mass", 0.0)
    scale = cfg.per_world("tool_mass_scale", 1.0)
    if cfg.extra_mass is not None or cfg.tool_mass_scale is not None:
        overrides["body:sweep_lower:mass"] = scale * tool.mass + extra
    info: dict[str, object] = {"load_mass_kg": m_load, "rows": rows}
    if cfg.spring_model == "paper":
        sp = paper.SPRING_SPHERE
        r = sp["radius"]
        young = cfg.per_world("spring_young", "dem_spring_young_pa")
        b.add_material("spring", wd.Material(young=float(young[0]), poisson=sp["poisson"],
                                             density=sp["density"], friction_angle=sp["friction_angle"]))
        for k in range(3):  # spring spheres 3, 2, 1 from the shank backwards
            b.add_sphere(s - (0.0, (2 * k + 1) * r, 0.0), r, "spring", blocked="xzXZ", group="springs")
        b.add_sphere(s - (0.0, 7 * r, 0.0), r, "spring", blocked="xyzXYZ", group="support")
        overrides["material:spring:young"] = young
        overrides["damping:springs"] = cfg.per_world("local_damping", "dem_local_damping")
    else:
        length = 0.1
        # the spring acts straight below the pivot at the sensor's height: its preload then has no lever along y
        # and its line does not turn with a small swing (at the sensor point itself, 18 mm behind the pivot, the
        # ~100 N preload would add ~-2 N m/rad)
        s = np.array([s[0], tool.pivot[1], s[2]])
        carriage = b.add_rigid_body(s - (0.0, length, 0.0), name="carriage")
        # the spring's force at the CAD pose (tension positive): the static equilibrium under the load and the
        # tool's weight (with any extra mass), or nothing for a free pose
        m_tool = gravity_moment(tool, 0.0, load_point)
        force = ((scale + extra / tool.mass) * m_tool + gravity_moment(tool, m_load, load_point) - m_tool) / lever
        force = force * (1.0 - cfg.per_world("free_pose", 0.0))
        k_s = cfg.per_world("series_stiffness", math.inf)
        k_eff = series_rate(stiffness, k_s)
        k3 = cfg.per_world("progressive", 0.0)
        stretch = np.array([_stretch(f, k, c) for f, k, c in zip(force, k_eff, k3, strict=True)])
        b.add_spring("spring", carriage, s - (0.0, length, 0.0), b.body_names["sweep_lower"], s,
                     stiffness=float(k_eff[0]), rest_length=length - float(stretch[0]))
        if cfg.dashpot is not None:
            damping = cfg.per_world("dashpot", 0.0)
        else:
            zeta = cfg.per_world("damping_ratio", "measured_damping")
            frac = cfg.per_world("load_mass_fraction", 1.0)
            inertia = np.array([rig_inertia(tool, f * m_load, load_point, m) for f, m in zip(frac, scale, strict=True)])
            k_rot = stiffness * lever**2 + np.array([gravity_stiffness(tool, m_load, load_point, tool_mass_scale=m)
                                                     for m in scale])
            damping = 2.0 * np.asarray(zeta) * np.sqrt(k_rot * inertia) / lever**2
        overrides["spring:spring:stiffness"] = k_eff
        overrides["spring:spring:damping"] = damping
        overrides["spring:spring:rest_length"] = length - stretch
        if cfg.progressive is not None:
            overrides["spring:spring:progressive"] = k3
        info["dashpot_n_s_per_m"] = damping
        info["spring_force_n"] = force
        info["spring_stretch_m"] = stretch
    return RingingRig(b, overrides, tool, cfg, load_point, lever, stiffness, info)


def _stretch(force: float, k: float, k3: float) -> float:
    """The stretch u [m] of a spring with F = k u + k3 u^3 carrying ``force`` [N] (tension positive)."""
    if k3 == 0.0:
        return force / k
    roots = np.roots([k3, 0.0, k, -force])
    return float(roots[np.argmin(np.abs(roots.imag))].real)


@dataclass
class RingingResult:
    """Sensor displacement after the hit and its fit per configuration."""

    springs: tuple[int, ...]
    spring_model: str
    time: np.ndarray
    """time since the hit [s] (k,)."""
    displacement: np.ndarray
    """sensor point displacement along y from its settled position [m] (k, n_configs)."""
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    static_deflection: np.ndarray
    """sensor displacement while settling under the load before the hit [m] (n_configs,) (about 0 for the linear
    model, whose spring starts preloaded at equilibrium)."""
    spring_deflection: np.ndarray
    """the spring's deflection at rest under the load, as simulated [m] (n_configs,): linear model, its stretch
    (from the preload) plus the settling; spring spheres, the settling."""
    dt: float
    wall_s: float
    config: dict
    analytic: dict[str, np.ndarray] = field(default_factory=dict)

    def table(self) -> list[dict[str, float]]:
        """One row per configuration: simulated and Table 2's frequency and damping, relative errors."""
        out = []
        for k, n in enumerate(self.springs):
            row = paper.ringing_row(n)
            f, z = float(self.frequency_hz[k]), float(self.damping_ratio[k])
            out.append({
                "springs": n, "freq_hz": f, "damping": z,
                "measured_freq_hz": row["measured_freq_hz"], "measured_damping": row["measured_damping"],
                "paper_dem_freq_hz": row["calibrated_freq_hz"], "paper_dem_damping": row["calibrated_damping"],
                "re_freq": _re(f, row["measured_freq_hz"]),
                "re_damp": _re(z, row["measured_damping"]),
                **({"analytic_freq_hz": float(self.analytic["freq_hz"][k]),
                    "analytic_damping": float(self.analytic["damping"][k])} if self.analytic else {}),
            })
        return out


def _re(sim: float, target: float) -> float:
    """Eq. (8)/(9) relative error, NaN where the simulation gave no value."""
    return float(analysis.relative_error(sim, target)) if np.isfinite(sim) else math.nan


def ringing_dt(cfg: RingingConfig, model: wd.Model) -> float:
    """The ringing run's time step [s]: ``cfg.dt``, or half the critical step of ``model`` and at least two steps a
    sample (``cfg.sample_rate``)."""
    return cfg.dt or min(0.5 * wd.critical_timestep(model), 0.5 / cfg.sample_rate)


def run_ringing(config: RingingConfig | None = None, *, device: str | None = None, tool: SweepTool | None = None,
                progress: object | None = None) -> RingingResult:
    """Build, settle, hit and record the ringing rig for every configuration; fit eqs. (3)-(5)."""
    import time

    cfg = config or RingingConfig()
    if cfg.spring_model == "twin":
        return _run_twin(cfg, device, progress)
    rig = build_ringing(cfg, tool)
    model, state = rig.builder.finalize(device, n_worlds=len(cfg.springs), overrides=rig.overrides)
    dt = ringing_dt(cfg, model)
    wd.check_step_count("ringing run", cfg.settle_time + cfg.ring_time, dt,
                        "cfg.dt" if cfg.dt else "0.5 x the critical step (spring stiffness, Young's moduli)")
    sim = wd.Simulation(model, state, dt=dt, world_steps=True)  # small worlds: a thread runs a world's steps
    t0 = time.perf_counter()
    sensor = wd.observers.body_point("sweep_lower", rig.tool.sensor_point)
    s0 = sensor(sim)[:, 1].copy()
    # settle under the load
    damped = [g for g in ("tool", "load", "springs") if g in model.names["group"]]
    saved = sim.control.group_damping.numpy().reshape(model.n_worlds, model.n_groups).copy()
    for g in damped:
        sim.set_local_damping(g, SETTLE_DAMPING)
    n_settle = int(round(cfg.settle_time / dt))
    sim.run(n_settle, progress=(lambda d, n: progress(d, n_settle, "settle")) if progress else None)
    for g in damped:
        sim.set_local_damping(g, saved[:, model.names["group"][g]])
    static = sensor(sim)[:, 1] - s0
    # the hit: an angular velocity about x giving a sensor swing of hit_amplitude * |static deflection|
    body = np.arange(model.n_worlds) * model.bodies_per_world + model.names["body"]["sweep_lower"]
    f_guess = np.array([paper.ringing_row(n)["measured_freq_hz"] for n in cfg.springs])
    if cfg.spring_model == "linear":  # preloaded at equilibrium: the spring's deflection under the load
        m_load = cfg.load_force / 9.81
        deflection = abs(gravity_moment(rig.tool, m_load, rig.load_point)) / rig.lever / rig.stiffness
    else:
        deflection = np.abs(static)
    omega0 = cfg.hit_amplitude * deflection * 2 * np.pi * f_guess / rig.lever
    angvel, vel, pos = state.body_angvel.numpy().copy(), state.body_vel.numpy().copy(), state.body_pos.numpy()
    angvel[body] = 0.0
    angvel[body, 0] = -omega0  # backwards, like a hammer blow on the blade's front
    if cfg.hit_velocity is not None:  # the sensor below the pivot moves along y at angvel_x * lever
        angvel[body, 0] = cfg.per_world("hit_velocity", 0.0) / rig.lever
    pivot = pos[body] + np.einsum("nij,nj->ni", quats_to_matrices(state.body_quat.numpy()[body]),
                                  model.host["body_pivot"][body])
    vel[body] = np.cross(angvel[body], pos[body] - pivot)
    if "load" in model.names["body"]:  # the load rides with the tool: the velocity of its pin, omega x (pin - pivot)
        load = np.arange(model.n_worlds) * model.bodies_per_world + model.names["body"]["load"]
        vel[load] = np.cross(angvel[body], pos[load] - pivot)
    state.body_angvel.assign(angvel)
    state.body_vel.assign(vel)
    every = max(1, int(round(1.0 / (cfg.sample_rate * dt))))
    n_ring = int(round(cfg.ring_time / dt / every)) * every  # whole records: uniform sampling
    settled = sensor(sim)[:, 1].copy()
    # the sensor reads only the tool's pose, which the world kernel records (no hand-over to the host per record)
    out = sim.run(n_ring, record_every=every, observers={"sensor": sensor},
                  progress=(lambda d, n: progress(d, n_ring, "ring")) if progress else None)
    wall = time.perf_counter() - t0
    t = out["time"] - out["time"][0]
    disp = out["sensor"][:, :, 1] - settled
    freq, zeta = np.full(len(cfg.springs), np.nan), np.full(len(cfg.springs), np.nan)
    for k in range(len(cfg.springs)):
        try:
            fit = analysis.ringdown(t, disp[:, k])
            freq[k], zeta[k] = fit.frequency_hz, fit.damping_ratio
        except ValueError:
            pass  # too few peaks (overdamped): left as NaN and reported
    analytic: dict[str, np.ndarray] = {}
    if cfg.spring_model == "linear":
        pairs = [analytic_frequency(rig, float(k), float(c), float(f), float(m))
                 for k, c, f, m in zip(series_rate(rig.stiffness, cfg.per_world("series_stiffness", math.inf)),
                                       rig.info["dashpot_n_s_per_m"], cfg.per_world("load_mass_fraction", 1.0),
                                       cfg.per_world("tool_mass_scale", 1.0), strict=True)]
        analytic = {"freq_hz": np.array([p[0] for p in pairs]), "damping": np.array([p[1] for p in pairs])}
    spring = static + rig.info["spring_stretch_m"] if cfg.spring_model == "linear" else static
    return RingingResult(tuple(cfg.springs), cfg.spring_model, t, disp, freq, zeta, static, spring, dt, wall,
                         asdict(cfg), analytic)


def _run_twin(cfg: RingingConfig, device: str | None, progress: object | None) -> RingingResult:
    """spring_model "twin": the paper's rig as its text builds it (``scenes.ringing_twin``, "stated" reading),
    with the spring spheres' genes of ``cfg`` (default Table 2's); its own settling (0.3 s), hit and time step
    (4.969e-6 s); ``cfg.ring_time`` of ringing. f and zeta by ``ringing_twin.frequency_damping`` (a 30 Hz low-pass
    first)."""
    from . import ringing_twin

    spec = ringing_twin.twin_spec()
    index = [paper.SPRING_COUNTS.index(n) for n in cfg.springs]
    w = ringing_twin.run_twin(spec, "stated", index, spring_young=cfg.per_world("spring_young", "dem_spring_young_pa"),
                              local_damping=cfg.per_world("local_damping", "dem_local_damping"), device=device,
                              ring_time=cfg.ring_time,
                              progress=(lambda ph, d, n: progress(d, n, ph)) if progress else None)
    disp = w["sensor_y"] - w["sensor_y"][0]
    fz = np.array([ringing_twin.frequency_damping(w["time"], w["sensor_y"][:, k]) for k in range(len(index))])
    static = np.asarray(w["settle_sensor_y"], dtype=np.float64)
    return RingingResult(tuple(cfg.springs), "twin", w["time"], disp, fz[:, 0], fz[:, 1], static, static,
                         float(np.asarray(spec["dt"])), float(w["wall_s"]), asdict(cfg))
