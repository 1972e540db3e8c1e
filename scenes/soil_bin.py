"""The soil bin (section 2.1.2, Tables 3 and 7): the sweep pulled through a deposited bed, rigid or on springs.

Frame: x lateral, y travel (the carriage moves +y), z up; the bin spans x in [-W/2, W/2], y in [0, L], z in [0, H].

- Rigid tool: every DoF blocked, moving at the carriage speed (``springs = 0``).
- Passive tool: hinged at its pivot (rotation about x only), the pivot carried at the speed, held by the springs on
  the shank's rear face at the sensor point, 100 mm below the pivot. Spring models: "linear" (default): a linear
  spring-dashpot with the DIN 2093 stiffness of the configuration and a dashpot giving Table 2's measured damping
  ratio for the hinged tool alone; "paper": three spring spheres and a support sphere with Table 2's calibrated
  Young's modulus and local damping (its stiff, light spheres need a ~5e-6 s step, 10x smaller than the soil's).
  Table 2's support offset (+ = against travel) moves the spring's anchor (or the support sphere) back, which lets
  the tool lean back (the paper's "initial backward bending"); the support sphere is moved into its offset over
  the run's first ``SUPPORT_RAMP`` seconds, each world by its own offset.
- Soil: a deposited :class:`~scenes.assemblies.Bed` with the paper's E, nu, rho and a GA parameter set of Tables
  4-6 (default: the set closest to the laboratory shear box for the assembly: A 1, B 8, C 11), cohesion set on the
  initial contacts, rolling/twisting resistance on every contact, no local damping (as the paper).

Per run and world: draught (contact force of the lower half against travel), the sensor point's displacement
relative to the carriage, kinetic energy of tool and soil (translational, rotational; eq. 6), the soil's
coordination number, and steady-state statistics after ``steady_travel`` of travel (0.5 m at paper scale).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

import numpy as np

import warpdem as wd
from warpdem import mass as massprops
from warpdem.errors import BudgetExhausted, InputError
from warpdem.files import write_atomic
from warpdem.vtk import VtkWriter

from . import analysis, paper, replica_beds
from .assemblies import AssemblySpec, Bed, bin_mesh, deposit
from .passive_tool import PassiveTool
from .ringing import check_per_world, series_rate
from .sweep import SweepTool, add_sweep, build_sweep, pitch_matrix

DEFAULT_SET = {"A": 1, "B": 8, "C": 11}
"""GA set (Tables 4-6) per assembly whose shear-box result is closest to the laboratory's (32.3 deg, 6.4 kPa) by the
sum of relative errors of friction angle and cohesion."""

SCALES = {
    # bin (W, L, H) [m], bed depth [m], member radius [m], travel [m], steady-state start [m]
    # (the tool is 0.27 m long: travel + 0.3 m must fit in L; walls high enough that no particle is thrown out)
    "ci": {"bin": (0.5, 0.65, 0.45), "bed_depth": 0.2, "radius": 0.02, "travel": 0.3, "steady_travel": 0.15},
    "cpu": {"bin": (0.7, 1.1, 0.45), "bed_depth": 0.22, "radius": 0.015, "travel": 0.75, "steady_travel": 0.45},
    "paper": {"bin": (1.0, 2.0, 0.5), "bed_depth": 0.25, "radius": 0.007, "travel": 1.6, "steady_travel": 0.5},
    # the paper's first, 1 m long bin (its calibration and Table 7's 1 m columns) at the paper scale's members
    "paper_1m": {"bin": (1.0, 1.0, 0.5), "bed_depth": 0.25, "radius": 0.007, "travel": 0.65, "steady_travel": 0.3},
    # the paper's members and bed depth in a shorter, narrower bin: small enough for a Yade twin on a CPU
    "strip": {"bin": (0.6, 0.75, 0.45), "bed_depth": 0.25, "radius": 0.007, "travel": 0.45, "steady_travel": 0.2},
}
SPRING_MODELS = ("linear", "paper")
DEPOSIT_FRICTION = 30.0
"""contact friction [deg] of a bed's deposition (``SoilBinConfig.deposit_friction``'s default): porosity 0.456,
coordination 4.9 at paper scale for assembly C (docs/fidelity.md)."""
KNOBS = ("stiffness", "dashpot", "pivot_friction", "extra_mass", "progressive", "series_stiffness", "soil_viscosity",
         "stack_preload", "tool_mass_scale", "tool_friction", "tool_adhesion", "soil_cohesion_scale", "mount_pitch")
"""per-world settings and extensions of the passive rig with linear springs (``run_soil_bin(knobs=...)``), SI: stiffness
[N/m] (default DIN 2093 of the configuration), dashpot [N s/m] (default: Table 2's measured damping ratio for the
hinged tool alone), pivot_friction [N m] (Coulomb torque at the hinge), extra_mass [kg] (added to the tool,
distributed like its own), progressive [N/m^3] (cubic term of the stack, F = k u + k3 u^3), series_stiffness [N/m]
(frame and shank in series: k ks / (k + ks); inf = rigid), soil_viscosity [N s/m] (a rate-dependent soil resistance b
v against travel at the share's tip; it adds to the draught), stack_preload [m] (the stack assembled compressed by
this much at the drawing pose, against a stop: the tool rests on the stop until the spring's load exceeds k x
stack_preload, then deflects by the excess / k; the stop is STOP_RATIO times the spring's rate). The rigid tool takes
soil_viscosity, tool_friction, tool_adhesion and soil_cohesion_scale only (its motion is prescribed). tool_mass_scale
[-] (> 0) multiplies the tool's mass and inertia (``scenes.passive_tool.PassiveTool.inertia_factor``). tool_friction
[deg] (0 <= phi < 90): the soil-steel contacts' own friction angle (``ModelBuilder.set_pair_friction``; without it
they take the smaller of the soil's and the tool's, i.e. the soil's), the sweep's and the bin walls' alike (both are
of the "tool" material). tool_adhesion [Pa] (>= 0; 0: none): the soil-steel pair's adhesion
(``ModelBuilder.set_pair_adhesion``): every new contact of a soil particle with the sweep or a bin wall is bonded
with tensile and shear strength tool_adhesion x R^2 (R the sphere's radius), a bond that fails leaving a frictional
contact. soil_cohesion_scale [-] (>= 0): the soil's normal and shear cohesion (its bonds' strength) times this, on
top of the soil's own or overridden values. mount_pitch [deg] (within +-MAX_MOUNT_PITCH): the sweep clamped to its
hinge turned backwards by this angle (``scenes.sweep.pitch_matrix``): its triangles and centre of mass turned about
the pivot, the spring's seat and the sensor's target on the clamp where the drawing has them (the spring unloaded at
the start as without it); the tool then works at another attack angle with another moment of its weight, and the
displacement is the clamp's, read from the start."""
MAX_MOUNT_PITCH = 15.0
"""the largest mount_pitch knob [deg] taken (a clamping error of the shank on its hinge)."""
SOIL_KNOBS = ("tool_friction", "tool_adhesion", "soil_cohesion_scale")
"""the knobs of the soil and its contacts with the steel: any tool and spring model takes them (a rigid tool's runs
compared with passive ones must take them too)."""
RIGID_KNOBS = ("soil_viscosity", *SOIL_KNOBS)
"""the knobs a rigid tool takes (its motion is prescribed)."""
STOP_RATIO = 100.0
"""stiffness of the preloaded stack's stop relative to the stack's rate: the tool presses into it by at most 1 % of
the preload's compression (a metal stop is stiffer still; this keeps the spring's time step far above the soil's)."""
SUPPORT_RAMP = 0.1
"""time [s] over which the paper's spring model moves its support into Table 2's offset at the start of a run
(set at once, an offset of millimetres would overlap the 3.4 g spring spheres by that much and blow them apart)."""
SETTLE_DAMPING = 0.4
"""local damping [-] of the soil while it settles before a run (``SoilBinConfig.settle_time``; the deposition's)."""
DRAG_ANCHOR = 100.0
"""distance ahead of the tip [m] of the static anchor of the soil-viscosity dashpot: its line stays along travel."""


@dataclass
class SoilBinConfig:
    """A soil-bin study: one bed, one rigid run and/or passive runs (one world per spring configuration)."""

    scale: str = "cpu"
    assembly: str = "C"
    springs: tuple[int, ...] = (0, 16, 32)
    """spring configurations; 0 is the rigid tool."""
    spring_model: str = "linear"
    speed: tuple[float, ...] | None = None
    """carriage speed per configuration [m/s]; default Table 7's mean speeds."""
    working_depth: float = paper.WORKING_DEPTH
    parameter_set: int | None = None
    support_offset: bool = True
    """apply Table 2's support offsets (the paper's final model)."""
    travel: float | None = None
    steady_travel: float | None = None
    sample_rate: float = 500.0
    """recording rate [Hz] (the FFT low-pass is at 100 Hz)."""
    seed: int = 0
    dt: float | None = None
    settle_time: float = 0.0
    """[s] before the tool moves, the bed settles this long under gravity with the run's soil material, without
    bonds and with local damping SETTLE_DAMPING on the soil (tool, carriages and support at rest); the bonds are
    then set on the contacts of that moment and the run's clock starts at 0. With 0 (default) the bonds go on the
    deposited bed's contacts at once. The bed is deposited with friction 30 deg and damping 0.4: a weaker soil set
    started from it without settling is not at rest (docs/fidelity.md)."""
    member_radius: float | None = None
    """radius of the assembly's member spheres [m] (default: the scale's; the paper does not print its sizes)."""
    cohesion_on_new_contacts: bool = paper.COHESION_ON_NEW_CONTACTS
    """False (default, both soil rigs' rule: ``scenes.paper.COHESION_ON_NEW_CONTACTS``): cohesion on the contacts of
    the first step only (the bed's, Yade's setCohesionNow); True: also on every contact made during the run (Yade's
    setCohesionOnNewContacts)."""
    bond_detection_factor: float = 1.0
    """distance bonding at the bonding step (``warpdem.Simulation``'s ``bond_detection_factor``, Yade's
    interactionDetectionFactor): sphere pairs within this factor times their radii's sum are bonded, touching or not
    (1: touching pairs only). With Yade's law a gap g is a tension kn g at once, so only gaps below Cn r / E keep
    their bond (benchmarks/yade/bond_protocols_report.md)."""
    fragile: bool = True
    """the soil's bonds break for good at their strength (Yade's CohFrictMat default), or, False, yield in tension
    (deleted at their first tensile yield: Yade's unpMax = 0) and keep their shear strength while sliding."""
    deposit_friction: float = DEPOSIT_FRICTION
    """contact friction [deg] while the bed is deposited (``scenes.assemblies.deposit``; no cohesion, damping 0.4):
    a lower friction packs the bed denser (0: the densest random packing of the particles' shapes), the way Yade
    users compact a bed before giving it its material. The run's own soil material is set afterwards."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.deposit_friction) and 0.0 <= self.deposit_friction < 90.0):
            raise ValueError(f"deposit_friction must be in [0, 90) deg, got {self.deposit_friction!r}")
        if self.scale not in SCALES:
            raise ValueError(f"scale must be one of {sorted(SCALES)}, got {self.scale!r}")
        if self.spring_model not in SPRING_MODELS:
            raise ValueError(f"spring_model must be one of {SPRING_MODELS}, got {self.spring_model!r}")
        for n in self.springs:
            if n != 0 and n not in paper.SPRING_COUNTS:
                raise ValueError(f"springs must be 0 (rigid) or among {paper.SPRING_COUNTS}, got {n!r}")
        if self.speed is not None and len(self.speed) != len(self.springs):
            raise ValueError(f"speed needs one value per spring configuration ({len(self.springs)}), got {self.speed}")
        if not (math.isfinite(self.settle_time) and self.settle_time >= 0):
            raise ValueError(f"settle_time must be finite and >= 0 s, got {self.settle_time!r}")
        if not (math.isfinite(self.bond_detection_factor) and 1.0 <= self.bond_detection_factor <= 3.0):
            raise ValueError(f"bond_detection_factor must be in [1, 3], got {self.bond_detection_factor!r}")
        if self.member_radius is not None and not 0 < self.member_radius < 0.05:
            raise ValueError(f"member_radius must be in (0, 0.05) m, got {self.member_radius!r}")
        if not 0 < self.working_depth < SCALES[self.scale]["bed_depth"]:
            raise ValueError(f"working_depth must be in (0, bed depth), got {self.working_depth!r}")
        for name in ("travel", "steady_travel", "dt"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise InputError(f"{name} must be finite and > 0 (or None for the scale's), got {v!r}")
        if not (math.isfinite(self.sample_rate) and self.sample_rate > 0):
            raise InputError(f"sample_rate must be finite and > 0 Hz, got {self.sample_rate!r}")
        travel = self.travel or self.preset["travel"]
        steady = self.steady_travel or self.preset["steady_travel"]
        if steady >= travel:
            raise InputError(f"steady_travel ({steady!r} m) must be shorter than travel ({travel!r} m): the steady "
                             f"state is averaged between them")

    @property
    def preset(self) -> dict:
        return SCALES[self.scale]

    def speeds(self) -> list[float]:
        """carriage speed [m/s] of each configuration of ``springs`` (len(springs),)."""
        if self.speed is not None:
            return [float(v) for v in self.speed]
        t7 = paper.table("soil_bin_dem")
        return [float(t7["speed_mean_m_s"][t7["springs"] == n][0]) for n in self.springs]

    def rigid_speeds(self) -> list[float]:
        """The rigid runs a study makes [m/s], ascending: one at every distinct speed of its configurations (the
        rigid row's own and each passive configuration's), so that every reduction pairs equal speeds (Table 3's
        pairing). Empty without a rigid configuration (0) in ``springs``."""
        if 0 not in self.springs:
            return []
        return sorted({speed_key(v) for v in self.speeds()})

    def soil_material(self) -> wd.Material:
        """The soil contact material: the paper's E, nu, rho and the GA set's friction, cohesion, eta."""
        sets = paper.table("ga_sets")
        k = (self.parameter_set or DEFAULT_SET[self.assembly]) - 1
        if not 0 <= k < len(sets["set"]):
            raise ValueError(f"parameter_set must be in 1..{len(sets['set'])}, got {self.parameter_set!r}")
        eta = float(sets["eta_roll_twist"][k])
        return wd.Material(young=paper.SOIL_YOUNG, poisson=paper.SOIL_POISSON, density=paper.SOIL_DENSITY,
                           friction_angle=float(sets["friction_angle_deg"][k]),
                           normal_cohesion=float(sets["normal_cohesion_pa"][k]),
                           shear_cohesion=float(sets["shear_cohesion_pa"][k]), eta_roll=eta, eta_twist=eta,
                           moment_law=True, fragile=self.fragile)


def speed_key(speed: float) -> float:
    """A speed [m/s] as the key that pairs a passive run with its rigid reference (rounded to 1 um/s, so that equal
    speeds written differently, 0.62 and 0.6200000001, pair)."""
    return round(float(speed), 6)


def reduction(passive: float, passive_sem: float, rigid: float, rigid_sem: float) -> tuple[float, float]:
    """Draught reduction of a passive run against a rigid run, 100 (rigid - passive) / rigid [%], and its standard
    error [percentage points] from the two means' standard errors [N] taken as independent:
    100 sqrt(sem_p^2 + (passive / rigid)^2 sem_r^2) / rigid (first-order propagation)."""
    red = 100.0 * (rigid - passive) / rigid
    sem = 100.0 * math.hypot(passive_sem, passive / rigid * rigid_sem) / rigid
    return red, sem


def pair_reductions(rows: list[dict[str, object]]) -> list[dict[str, object]]:
    """Every passive row (``springs`` > 0) gets the reduction against the rigid row (``springs`` 0) at its own speed
    (:func:`speed_key`): ``rigid_reference_speed`` [m/s], ``rigid_reference_draught`` and ``_sem`` [N],
    ``reduction_pct`` [%] and ``reduction_sem`` [percentage points]; None where no rigid run has its speed. Rigid
    rows get None in these fields. Rows need ``speed``, ``draught_mean`` and ``draught_sem``; changed in place and
    returned."""
    rigid = {speed_key(r["speed"]): r for r in rows if r["springs"] == 0}
    for r in rows:
        ref = rigid.get(speed_key(r["speed"])) if r["springs"] else None
        r["rigid_reference_speed"] = None if ref is None else float(ref["speed"])
        r["rigid_reference_draught"] = None if ref is None else float(ref["draught_mean"])
        r["rigid_reference_sem"] = None if ref is None else float(ref["draught_sem"])
        if ref is None:
            r["reduction_pct"] = r["reduction_sem"] = None
        else:
            r["reduction_pct"], r["reduction_sem"] = reduction(float(r["draught_mean"]), float(r["draught_sem"]),
                                                               float(ref["draught_mean"]), float(ref["draught_sem"]))
    return rows


def ensemble(values: list[float], record_sems: list[float]) -> dict[str, float]:
    """Mean of replicas and its standard errors: ``sem`` from the scatter over replicas (std with ddof 1 over
    sqrt(n); with one replica, its record's own), ``record_sem`` from the records' own standard errors
    (sqrt(sum sem_r^2) / n), ``std`` over replicas, ``n``."""
    v = np.asarray(values, dtype=np.float64)
    s = np.asarray(record_sems, dtype=np.float64)
    n = len(v)
    record_sem = float(np.sqrt(np.sum(s**2)) / n) if n else math.nan
    std = float(np.std(v, ddof=1)) if n > 1 else math.nan
    return {"mean": float(np.mean(v)) if n else math.nan, "sem": std / math.sqrt(n) if n > 1 else record_sem,
            "record_sem": record_sem, "std": std, "n": n}


def replica_table(rows: list[dict[str, object]]) -> list[dict[str, object]]:
    """The table of runs on replica beds: ``rows`` are the worlds' steady rows (each with ``replica_seed``, as
    :func:`run_soil_bin` gives them on replica beds). Each replica's passive rows are paired with that replica's
    rigid row at the same speed (:func:`pair_reductions`), as the laboratory paired its runs; then one row per
    configuration and speed, over the replicas (:func:`ensemble`):

    - ``draught_mean`` [N]: the replicas' mean; ``draught_sem``: its standard error from their scatter (with one
      replica, the record's own); ``draught_record_sem`` from the records' own; ``draught_replica_std`` over
      replicas; ``draught_std``: the replicas' mean fluctuation within a record (as a single run's row);
    - ``displacement_mean``, ``_sem`` [m] likewise;
    - ``reduction_pct``, ``reduction_sem`` [%, percentage points]: the mean of the replicas' own reductions and its
      standard error; ``rigid_reference_draught``, ``_sem`` [N] the rigid rows' ensemble (None where a replica has
      no rigid run at that speed);
    - ``replicas``: their number; ``per_replica``: each replica's draught, displacement and reduction."""
    by_replica: dict[int, list[dict[str, object]]] = {}
    for r in rows:
        if "replica_seed" not in r:
            raise InputError("replica_table: every row needs replica_seed (a world on a replica bed)")
        by_replica.setdefault(int(r["replica_seed"]), []).append(dict(r))
    groups: dict[tuple[int, float], list[dict[str, object]]] = {}
    for rep in sorted(by_replica):
        for r in pair_reductions(by_replica[rep]):
            groups.setdefault((int(r["springs"]), speed_key(r["speed"])), []).append(r)
    table = []
    for (n, _), reps in groups.items():
        d = ensemble([x["draught_mean"] for x in reps], [x["draught_sem"] for x in reps])
        disp = ensemble([x["displacement_mean"] for x in reps], [x["displacement_sem"] for x in reps])
        row: dict[str, object] = {
            "springs": n, "speed": float(reps[0]["speed"]), "replicas": len(reps),
            "draught_mean": d["mean"], "draught_sem": d["sem"], "draught_record_sem": d["record_sem"],
            "draught_replica_std": d["std"], "draught_std": float(np.mean([x["draught_std"] for x in reps])),
            "displacement_mean": disp["mean"], "displacement_sem": disp["sem"],
            "rigid_reference_speed": None, "rigid_reference_draught": None, "rigid_reference_sem": None,
            "reduction_pct": None, "reduction_sem": None}
        if n and all(x["reduction_pct"] is not None for x in reps):
            red = ensemble([x["reduction_pct"] for x in reps], [x["reduction_sem"] for x in reps])
            ref = ensemble([x["rigid_reference_draught"] for x in reps], [x["rigid_reference_sem"] for x in reps])
            row.update(rigid_reference_speed=reps[0]["rigid_reference_speed"], rigid_reference_draught=ref["mean"],
                       rigid_reference_sem=ref["sem"], reduction_pct=red["mean"], reduction_sem=red["sem"])
        row["per_replica"] = [{"replica": int(x["replica_seed"]), "draught_mean": x["draught_mean"],
                               "draught_sem": x["draught_sem"], "displacement_mean": x["displacement_mean"],
                               "reduction_pct": x["reduction_pct"], "reduction_sem": x["reduction_sem"]}
                              for x in reps]
        table.append(row)
    return table


def json_safe(value: object) -> object:
    """``value`` with every NaN or infinite float (also numpy's, in dicts, lists and tuples) replaced by None, and
    numpy scalars by Python's: what ``json.dumps`` writes as standard JSON (null, not NaN)."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def bed_path(config: SoilBinConfig, cache_dir: str | Path, replica: int | None = None) -> Path:
    """Where :func:`bed_for` keeps the bed of a config (scale, assembly, member radius, seed; a replica bed's
    number) in ``cache_dir``."""
    p = config.preset
    spec = AssemblySpec(kind=config.assembly, radius=config.member_radius or p["radius"])
    what = [asdict(spec), p["bin"], p["bed_depth"], config.seed] + ([] if replica is None else ["replica", replica])
    if config.deposit_friction != DEPOSIT_FRICTION:
        what.append(["deposit_friction", config.deposit_friction])
    key = hashlib.sha1(json.dumps(what).encode()).hexdigest()[:12]
    return Path(cache_dir) / f"bed_{config.scale}_{config.assembly}_{key}.npz"


def bed_for(config: SoilBinConfig, *, device: str | None = None, cache_dir: str | Path | None = None,
            progress: object | None = None, replica: int | None = None) -> Bed:
    """The deposited bed for a config (scale, assembly, seed), read from ``cache_dir`` if it was made before.

    ``replica``: replica bed number ``replica`` (>= 0) of the population ``config.seed`` instead
    (``assemblies.deposit(seed=replica, population_seed=config.seed)``); replica beds of one config can be worlds
    of one simulation (:func:`run_soil_bin`)."""
    p = config.preset
    spec = AssemblySpec(kind=config.assembly, radius=config.member_radius or p["radius"])
    path = bed_path(config, cache_dir, replica) if cache_dir else None
    if path is not None and path.exists():
        return Bed.load(path)
    packing = {"friction_angle": config.deposit_friction,  # a denser packing needs more particles to fill the depth
               "porosity_guess": 0.45 if config.deposit_friction >= 20.0 else 0.36}
    if replica is None:
        bed = deposit(spec, p["bin"], p["bed_depth"], seed=config.seed, device=device, progress=progress, **packing)
    else:
        if not (isinstance(replica, int) and replica >= 0):
            raise InputError(f"replica must be an integer >= 0, got {replica!r}")
        bed = deposit(spec, p["bin"], p["bed_depth"], seed=replica, device=device,
                      progress=progress, population_seed=config.seed, **packing)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        bed.save(path)
    return bed


def bed_surface(bed: Bed) -> float:
    """The bed's surface [m]: the mean top of the particles in the upper 10 % of the bed."""
    top = bed.centres[:, 2] + bed.radii
    return float(np.mean(np.sort(top)[-max(1, len(top) // 10):]))


def place_tool(bed: Bed | list[Bed], working_depth: float, tool: SweepTool | None = None) -> SweepTool:
    """The sweep with its tip ``working_depth`` below the bed surface (:func:`bed_surface`; of replica beds, one
    per world, the mean of their surfaces: one tool pose serves every world) and its rearmost point 10 mm inside
    the bin's rear wall (y = 0)."""
    tool = tool or build_sweep()
    surface = bed_surface(bed) if isinstance(bed, Bed) else float(np.mean([bed_surface(x) for x in bed]))
    dz = surface - working_depth - tool.tip[2]
    dy = 0.01 - float(min(tool.lower.vertices[:, 1].min(), tool.upper.vertices[:, 1].min()))
    return tool.moved(np.array([0.0, dy, dz]))


def clear_start(bed: Bed, tool: SweepTool, margin: float = 0.002) -> np.ndarray:
    """Particles kept (n_particles,) bool: those with no member inside the tool's lower-half bounding box grown by
    the member radius + ``margin`` [m] (the starting trench)."""
    lo, hi = tool.lower.vertices.min(axis=0), tool.lower.vertices.max(axis=0)
    grow = (bed.radii + margin)[:, None]
    inside = np.all((bed.centres > lo - grow) & (bed.centres < hi + grow), axis=1)
    hit = np.zeros(bed.n_particles, bool)
    np.logical_or.at(hit, bed.particle, inside)
    return ~hit


@dataclass
class SoilBinRun:
    """Time series and statistics of one simulation (rigid, or the passive configurations as worlds)."""

    springs: tuple[int, ...]
    speeds: tuple[float, ...]
    time: np.ndarray
    """[s] (k,)."""
    travel: np.ndarray
    """carriage travel [m] (k, n_worlds); each carriage stops after the configured travel."""
    series: dict[str, np.ndarray]
    """draught [N], displacement [m] (sensor relative to the carriage, along y), ke_tool / ke_soil [J]
    (translational, rotational) (k, n_worlds, 2), coordination [-], bonds (unbroken cohesive soil-soil contacts)
    [-]; each (k, n_worlds[, 2])."""
    steady: list[dict[str, float]] = field(default_factory=list)
    """per world, over the steady part of its travel: draught_/displacement_ mean, std, sem, trend [unit/s],
    trend_sem (see ``scenes.analysis.steady_state``), steady_time_mean [s], ke_tool_/ke_soil_ mean and std,
    coordination_start/_end, bonds_start/_end (unbroken cohesive soil-soil contacts at the first record after the
    bonds are set and at the end)."""
    n_particles: int | list[int] = 0
    """soil particles simulated (the bed's, less the tool's starting trench); with replica beds, per world."""
    n_spheres: int = 0
    """spheres per world (with replica beds, the shared layout's: parked ones and the spring spheres included)."""
    dt: float = 0.0
    steps: int = 0
    wall_s: float = 0.0
    """the whole call [s] (model build, settling, records and rebuilds included)."""
    setup_s: float = 0.0
    """the part of ``wall_s`` [s] before the run's first step: tool placement, model build (with replica beds the
    shared layout and the fitted poses), the Simulation's first lists and the settling (``settle_time``)."""
    rebuilds: int = 0
    """candidate-list rebuilds of the simulation (any world's displacement triggers one for all)."""
    settle_s: float = 0.0
    """the settling's wall [s] (``settle_time``; in the call that settled, when the run was resumed)."""
    steps_s: float = 0.0
    """the wall of the run's steps after the settling [s], records, rebuilds and checkpoints included, over all
    its calls (steps redone after a kill counted once)."""

    def save(self, path: str | Path) -> None:
        """Into one .npz (written atomically): the arrays as arrays, the rest as JSON (NaN kept as NaN); :meth:`load`
        reads it back."""
        meta = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("time", "travel", "series")}
        meta["series"] = sorted(self.series)
        arrays = {"time": self.time, "travel": self.travel, **{f"series_{k}": v for k, v in self.series.items()}}
        write_atomic(Path(path), lambda tmp: np.savez_compressed(
            tmp, meta=json.dumps(meta, default=lambda o: o.item() if hasattr(o, "item") else str(o)), **arrays))

    @classmethod
    def load(cls, path: str | Path) -> SoilBinRun:
        """A run written by :meth:`save`."""
        with np.load(path) as z:
            meta = json.loads(str(z["meta"]))
            series = {k: z[f"series_{k}"] for k in meta.pop("series")}
            meta["springs"], meta["speeds"] = tuple(meta["springs"]), tuple(meta["speeds"])
            return cls(time=z["time"], travel=z["travel"], series=series, **meta)


def _check_knobs(knobs: dict[str, object] | None, n_worlds: int, rigid: bool, spring_model: str
                 ) -> dict[str, np.ndarray]:
    """Per-world knob arrays (n_worlds,), checked by name and value."""
    out: dict[str, np.ndarray] = {}
    for name, values in (knobs or {}).items():
        if name not in KNOBS:
            raise ValueError(f"knobs: unknown knob {name!r}; known {KNOBS}")
        if rigid and name not in RIGID_KNOBS:
            raise ValueError(f"knobs: the rigid tool takes {', '.join(RIGID_KNOBS)} only, got {name!r}")
        if not rigid and spring_model != "linear" and name not in SOIL_KNOBS:
            raise ValueError(f"knobs: {name!r} needs spring_model 'linear', got {spring_model!r}")
        a = np.broadcast_to(np.asarray(values, dtype=np.float64), (n_worlds,)).copy()
        check_per_world(name, tuple(a.tolist()))
        if name == "mount_pitch" and np.any(np.abs(a) > MAX_MOUNT_PITCH):
            raise ValueError(f"knobs: mount_pitch must lie within +-{MAX_MOUNT_PITCH} deg, got {a.tolist()}")
        out[name] = a
    return out


def dashpot_for(tool: SweepTool, stiffness: np.ndarray, damping_ratio: np.ndarray) -> np.ndarray:
    """The linear spring's dashpot [N s/m] (n,) that gives the hinged tool alone (no soil, no load) on springs of
    ``stiffness`` [N/m] (n,) the damping ratio ``damping_ratio`` [-] (n,): 2 zeta sqrt(k_rot I_p) / s^2, with the
    pivot inertia I_p [kg m^2], the sensor lever s [m] and the rotational stiffness k s^2 less gravity's."""
    lever = float(abs(tool.sensor_point[2] - tool.pivot[2]))
    i_p = tool.inertia_about(tool.pivot)[0, 0]
    k_rot = np.asarray(stiffness) * lever**2 - tool.mass * 9.81 * (tool.com[2] - tool.pivot[2])
    return 2.0 * np.asarray(damping_ratio) * np.sqrt(k_rot * i_p) / lever**2


def build_scene(config: SoilBinConfig, bed: Bed | list[Bed], tool: SweepTool, springs: list[int],
                speeds: list[float], device: str | None, soil_overrides: dict[str, object] | None = None,
                knobs: dict[str, np.ndarray] | None = None, pitch: np.ndarray | None = None
                ) -> tuple[wd.Model, wd.State, dict]:
    """The Model and State that :func:`run_soil_bin` runs (a world per entry of ``springs``, carriage speeds
    ``speeds`` [m/s]) and a dict of what it needs besides; for tests and benchmarks that build the same scene."""
    rigid = all(n == 0 for n in springs)
    knobs = knobs or {}
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("soil", config.soil_material())
    b.add_material("tool", wd.Material(young=paper.TOOL_YOUNG, poisson=paper.TOOL_POISSON, density=7850.0,
                                       friction_angle=paper.TOOL_FRICTION))
    v, f = bin_mesh(bed.bin_size if isinstance(bed, Bed) else bed[0].bin_size)
    b.add_mesh("bin", v, f, "tool")
    v0 = (0.0, speeds[0], 0.0)
    add_sweep(b, tool, "tool", mount="rigid" if rigid else "hinged", velocity=v0, group="tool")
    first_soil = sum(len(r) for r in b.sphere_radius)
    turn = tool_turn(len(springs), pitch, knobs)
    poses = [tool] if turn is None else [tool.pitched(a) for a in np.unique(turn)]
    if isinstance(bed, Bed):
        layout = None
        keep = np.logical_and.reduce([clear_start(bed, t) for t in poses])
        bed.add_to(b, "soil", group="soil", keep=keep)
        info: dict[str, object] = {"n_particles": int(keep.sum())}
    else:  # replica beds, one per world: one shared layout, each world's missing particles parked
        travel = config.travel or config.preset["travel"]
        garage = (-bed[0].bin_size[0], bed[0].bin_size[0], -0.4, bed[0].bin_size[1] + travel + 0.9)
        layout = replica_beds.shared_layout(
            bed, [np.logical_and.reduce([clear_start(x, t) for t in poses]) for x in bed], garage)
        members = layout.bed.add_to(b, "soil", group="soil")
        b.set_local_damping(replica_beds.PARKED_GROUP, 0.0)
        info = {"n_particles": [int(n) for n in layout.n_particles], "garage_bottom": layout.garage_bottom}
    overrides: dict[str, object] = {"body:sweep_lower:velocity": [(0.0, s, 0.0) for s in speeds]}
    for name, values in (soil_overrides or {}).items():
        overrides[f"material:soil:{name}"] = values
    if "tool_friction" in knobs:  # checked by the builder (0 <= phi < 90 deg)
        overrides["pair:soil:tool:friction_angle"] = knobs["tool_friction"]
    if "tool_adhesion" in knobs:  # 0: none (a bond of zero strength is not the same: it takes the moment law)
        overrides["pair:soil:tool:adhesion"] = np.where(knobs["tool_adhesion"] > 0.0, knobs["tool_adhesion"], -1.0)
    if "soil_cohesion_scale" in knobs:
        soil = config.soil_material()
        for f in ("normal_cohesion", "shear_cohesion"):
            base = np.asarray(overrides.get(f"material:soil:{f}", getattr(soil, f)), dtype=np.float64)
            overrides[f"material:soil:{f}"] = knobs["soil_cohesion_scale"] * base
    if "soil_viscosity" in knobs:
        # a dashpot from a static anchor far ahead to the tip: its force is b v against travel
        tip = np.asarray(tool.tip, dtype=np.float64)
        b.add_spring("soil_viscosity", b.body_names["bin"], tip + (0.0, DRAG_ANCHOR, 0.0),
                     b.body_names["sweep_lower"], tip, stiffness=0.0)
        overrides["spring:soil_viscosity:damping"] = knobs["soil_viscosity"]
    if not rigid:
        s = np.asarray(tool.sensor_point)
        rows = [paper.ringing_row(n) for n in springs]
        offsets = [1e-3 * r["support_offset_mm"] if config.support_offset else 0.0 for r in rows]
        if config.spring_model == "linear":
            length = 0.1
            # each world's anchor sits its offset (+ = against travel) behind the spring's unloaded place, so the
            # spring starts stretched by the offset and pulls the tool back by it; the carriage itself sits at the
            # unloaded place in every world, so that a world's geometry does not depend on the others of its batch
            carriage_pos = s - (0.0, length, 0.0)
            carriage = b.add_rigid_body(carriage_pos, name="carriage", velocity=v0)
            b.add_spring("spring", carriage, carriage_pos, b.body_names["sweep_lower"], s, stiffness=1.0,
                         rest_length=length)
            k = knobs.get("stiffness", np.array([r["stiffness_n_per_m"] for r in rows]))
            if "dashpot" in knobs:
                dashpot = knobs["dashpot"]
            else:
                dashpot = dashpot_for(tool, k, np.array([r["measured_damping"] for r in rows]))
            k_eff = series_rate(k, knobs.get("series_stiffness", np.full(len(springs), math.inf)))
            overrides.update({
                "body:carriage:velocity": [(0.0, sp, 0.0) for sp in speeds],
                "spring:spring:stiffness": k_eff,
                "spring:spring:damping": dashpot,
                "spring:spring:point_a": [carriage_pos - (0.0, off, 0.0) for off in offsets],
            })
            if "progressive" in knobs:
                overrides["spring:spring:progressive"] = knobs["progressive"]
            if "stack_preload" in knobs:
                # compression (< 0) pushing the tool forward onto a stop at the drawing pose
                overrides["spring:spring:preload"] = -k_eff * knobs["stack_preload"]
                overrides["spring:spring:stop_stiffness"] = STOP_RATIO * k_eff
            if "pivot_friction" in knobs:
                overrides["body:sweep_lower:pivot_friction"] = knobs["pivot_friction"]
            if "mount_pitch" in knobs:  # the seat on the clamp: where the drawing has it once the tool is turned
                overrides["spring:spring:point_b"] = [tool.pitched(-a).sensor_point for a in knobs["mount_pitch"]]
            if "extra_mass" in knobs or "tool_mass_scale" in knobs:
                scale = knobs.get("tool_mass_scale", np.ones(len(springs)))
                overrides["body:sweep_lower:mass"] = scale * tool.mass + knobs.get("extra_mass", 0.0)
        else:
            sp = paper.SPRING_SPHERE
            r = sp["radius"]
            b.add_material("spring", wd.Material(young=rows[0]["dem_spring_young_pa"], poisson=sp["poisson"],
                                                 density=sp["density"], friction_angle=sp["friction_angle"]))
            for kk in range(3):
                b.add_sphere(s - (0.0, (2 * kk + 1) * r, 0.0), r, "spring", blocked="xzXZ", group="springs",
                             velocity=v0)
            # the support starts touching the column and is moved into its offset during the run's first
            # SUPPORT_RAMP seconds (run_soil_bin)
            b.add_sphere(s - (0.0, 7 * r, 0.0), r, "spring", blocked="xyzXYZ", group="support",
                         velocity=v0, name="support")
            overrides.update({
                "material:spring:young": [row["dem_spring_young_pa"] for row in rows],
                "damping:springs": [row["dem_local_damping"] for row in rows],
                "body:support:velocity": [(0.0, sp_, 0.0) for sp_ in speeds],
            })
        info["support_offset_m"] = offsets
    model, state = b.finalize(device, n_worlds=len(springs), overrides=overrides)
    if layout is not None:
        replica_beds.place_worlds(model, state, layout, members, first_soil)
    if turn is not None:
        pitch_tool(model, state, tool, turn)
    info["pitch_deg"] = None if pitch is None else pitch.tolist()
    return model, state, info


def tool_turn(n_worlds: int, pitch: np.ndarray | None, knobs: dict[str, np.ndarray]) -> np.ndarray | None:
    """Each world's tool turned backwards at the start [deg] (n_worlds,): its start pitch and its mount_pitch knob
    together; None where neither is given."""
    if pitch is None and "mount_pitch" not in knobs:
        return None
    return (np.zeros(n_worlds) if pitch is None else pitch) + knobs.get("mount_pitch", np.zeros(n_worlds))


def pitch_tool(model: wd.Model, state: wd.State, tool: SweepTool, pitch: np.ndarray) -> None:
    """Turn each world's tool backwards by ``pitch`` [deg] (n_worlds,) about its pivot, keeping its velocities:
    before a Simulation is made of the state."""
    host = state.numpy()
    for w, angle in enumerate(pitch):
        b = model.body_index("sweep_lower", w)
        rot = pitch_matrix(float(angle))
        host["body_pos"][b] = tool.pivot + massprops.rows_times(host["body_pos"][b] - tool.pivot, rot.T)
        q = host["body_quat"][b]
        host["body_quat"][b] = massprops.matrix_to_quat(massprops.rows_times(rot, massprops.quat_to_matrix(q)))
    for k in ("body_pos", "body_quat"):
        getattr(state, k).assign(host[k])


def _stop_carriages(sim: wd.Simulation, worlds: np.ndarray) -> None:
    """Stop the driven bodies (tool or its pivot, spring carriage, support sphere) of the given worlds."""
    for name in ("sweep_lower", "carriage", "support"):
        if name in sim.model.names["body"]:
            sim.set_body_velocity(name, (0.0, 0.0, 0.0), worlds)


def _settle(sim: wd.Simulation, duration: float, carriage_vel: np.ndarray,
            progress: Callable[[int, int], None] | None = None) -> None:
    """Let the bed settle for ``duration`` [s] with the driven bodies at rest and damping SETTLE_DAMPING on the soil,
    then give the driven bodies their carriage velocities [m/s] (n_worlds, 3) back and start the clock at 0.
    ``progress(steps done, steps)`` as :meth:`warpdem.Simulation.run` reports it."""
    m = sim.model
    worlds = np.arange(m.n_worlds)
    _stop_carriages(sim, worlds)
    soil = m.names["group"]["soil"]
    saved = sim.control.group_damping.numpy().reshape(m.n_worlds, m.n_groups)[:, soil].copy()
    sim.set_local_damping("soil", SETTLE_DAMPING)
    sim.run(int(round(duration / sim.dt)), progress=progress)
    sim.set_local_damping("soil", saved)
    for name in ("sweep_lower", "carriage", "support"):
        if name in m.names["body"]:
            sim.set_body_velocity(name, carriage_vel)
    sim.state.time, sim.state.step = 0.0, 0


class RunCheckpoint:
    """Checkpoints of one soil-bin run in a folder: the engine's state (``sim_<step>.npz``, which includes the
    stopped carriages), the records so far (``records_<step>.npz``) and ``latest.json`` naming the last complete
    pair, the run it belongs to and what the run set up before its first step (written last, atomically: a kill at
    any moment leaves a usable checkpoint)."""

    def __init__(self, folder: str | Path, key: str) -> None:
        self.folder = Path(folder)
        self.key = key

    def meta(self) -> dict[str, object] | None:
        """latest.json of this run (key, step and the run's ``extra``), None if there is no checkpoint; ValueError
        if the folder holds another run's."""
        latest = self.folder / "latest.json"
        if not latest.exists():
            return None
        meta = json.loads(latest.read_text())
        if meta["key"] != self.key:
            raise ValueError(f"checkpoint folder {str(self.folder)!r} belongs to another soil-bin run (other scene, "
                             "configurations, speeds, knobs or soil); remove it or choose another folder")
        return meta

    def load(self, sim: wd.Simulation) -> tuple[int, dict[str, np.ndarray]] | None:
        """Restore the latest checkpoint into ``sim``; returns (step, records so far) or None if there is none."""
        meta = self.meta()
        if meta is None:
            return None
        step = int(meta["step"])
        wd.checkpoint.load(sim, self.folder / f"sim_{step}.npz")
        with np.load(self.folder / f"records_{step}.npz") as f:
            records = {k: f[k] for k in f.files}
        return step, records

    def save(self, sim: wd.Simulation, records: dict[str, np.ndarray], extra: dict[str, object] | None = None
             ) -> None:
        """Write the state at the current step and the records so far, then point latest.json at them (with
        ``extra``: what the run set up before its first step and needs again when it resumes, JSON)."""
        self.folder.mkdir(parents=True, exist_ok=True)
        step = sim.state.step
        wd.checkpoint.save(sim, self.folder / f"sim_{step}.npz")
        tmp = self.folder / f"records_{step}.tmp.npz"
        np.savez(tmp, **records)
        tmp.replace(self.folder / f"records_{step}.npz")
        meta = self.folder / "latest.json.tmp"
        meta.write_text(json.dumps({"key": self.key, "step": step, **({"extra": extra} if extra else {})}))
        meta.replace(self.folder / "latest.json")
        for old in self.folder.glob("*_*.npz"):
            if old.stem.split("_")[-1] != str(step):
                old.unlink()


def default_dt(model: wd.Model, spring_model: str, rigid: bool) -> float:
    """The run's time step [s]: 0.3 x the P-wave step and 0.5 x the spring step of the model; for the paper's spring
    spheres, no more than 0.3 x the P-wave step of the stiffest of Table 2's eight, so that every mix of passive
    configurations in a batch runs at one step (a world's result then does not depend on its batch mates)."""
    dt = min(0.3 * wd.pwave_timestep(model), 0.5 * wd.critical_timestep(model))
    if spring_model == "paper" and not rigid:
        sp = paper.SPRING_SPHERE
        young = max(paper.ringing_row(n)["dem_spring_young_pa"] for n in paper.SPRING_COUNTS)
        dt = min(dt, 0.3 * sp["radius"] / math.sqrt(young / sp["density"]))
    return dt


def run_soil_bin(config: SoilBinConfig, springs: list[int], *, bed: Bed | list[Bed], device: str | None = None,
                 tool: SweepTool | None = None, progress: object | None = None,
                 viewer: object | None = None, soil_overrides: dict[str, object] | None = None,
                 speeds: list[float] | None = None, knobs: dict[str, object] | None = None,
                 checkpoint: str | Path | None = None, checkpoint_every: float = 60.0,
                 deadline: float | None = None, place: bool = True, vtk: tuple[object, int] | None = None,
                 passive_tool: PassiveTool | None = None, pitch: list[float] | None = None,
                 skin_factor: float | None = None) -> SoilBinRun:
    """One simulation: rigid tools (every entry of ``springs`` 0) or passive configurations, one world each.

    ``bed``: the bed of every world, or replica beds (``assemblies.deposit(population_seed=...)``), one per world:
    independent beds as worlds of one simulation (``scenes.replica_beds``; the tool sits at their mean surface,
    each world's own surface is in ``SoilBinRun``'s steady rows as ``surface_offset``).

    ``tool``: the sweep (default :func:`scenes.sweep.build_sweep`), put on the bed's surface by :func:`place_tool`
    unless ``place`` is False (then it is used where it is, e.g. a twin's exported scene).

    ``speeds``: carriage speed per world [m/s] (n_worlds,) (default: the config's speed of each spring count).
    ``knobs``: per-world settings and extensions, name -> (n_worlds,) values (see :data:`KNOBS`).
    ``skin_factor``: the contact lists' skin as this multiple of the mean sphere radius (0 < f <= 2; None: the
    engine's default, 0.2). A larger skin rebuilds the lists less often and holds more candidate pairs: the speed
    changes, the physics does not (every touching pair is in the lists either way), so it is not part of a
    checkpoint's identity.

    ``viewer``: an optional warpdem.viewer.RerunViewer factory ``f(sim) -> viewer`` streamed at every record with
    the draught, displacement and kinetic energies.
    ``vtk``: (a :class:`warpdem.vtk.VtkWriter`, every): ParaView frames of every world at every ``every``-th record.
    ``soil_overrides``: per-world soil material fields, field -> (n_worlds,) values (e.g. ``friction_angle`` [deg],
    ``normal_cohesion`` [Pa]): a calibration population as worlds of one simulation.
    ``checkpoint``: a folder (see :class:`RunCheckpoint`) written every ``checkpoint_every`` seconds of wall time
    and at every carriage stop; when it holds a checkpoint of the same run, the run resumes from it and ends as
    the uninterrupted one would (bit for bit on the CPU).
    ``deadline``: a ``time.time()`` [s] after which the run saves its checkpoint and raises
    :class:`warpdem.errors.BudgetExhausted` (needs ``checkpoint``); called again, it continues.
    ``passive_tool``: the spring-mounted tool described once (``scenes.passive_tool``): its rates, dashpots, series
    compliance, preload, mass and support offsets set the passive worlds (``knobs`` given as well override its
    values by name; its ``support_offsets`` replaces ``config.support_offset``), and the displacement is read as
    the lab reads it, zeroed on the tool at rest on its springs (its closed-form rest pose, no soil). Without it,
    the displacement is the sensor's motion from the drawing pose.
    ``pitch``: per world, the tool's backward rotation about its pivot at the start [deg] (n_worlds,) (rigid:
    the pose it keeps; passive: where its springs take it from). The particles any world's tool would overlap at
    the start are left out of every world.
    ``progress(steps done, steps)``: over the bed's settling (``config.settle_time``) and the travel together.
    """
    t0 = time.perf_counter()
    if deadline is not None and checkpoint is None:
        raise ValueError("deadline needs a checkpoint folder to stop into")
    if 0 in springs and any(n != 0 for n in springs):
        raise ValueError(f"rigid and passive tools run in separate simulations: springs must be all 0 or all "
                         f"passive configurations, got {springs}")
    if speeds is None:
        all_speeds = dict(zip(config.springs, config.speeds(), strict=True))
        speeds = [all_speeds[n] for n in springs]
    elif len(speeds) != len(springs) or not all(v > 0 for v in speeds):
        raise ValueError(f"speeds needs one positive value per world ({len(springs)}), got {speeds}")
    speeds = [float(v) for v in speeds]
    if not isinstance(bed, Bed):
        bed = list(bed)
        if len(bed) != len(springs):
            raise InputError(f"bed: replica beds need one per world ({len(springs)}), got {len(bed)}")
        replica_beds.check_replicas(bed)
    if skin_factor is not None and not (math.isfinite(skin_factor) and 0.0 < skin_factor <= 2.0):
        raise InputError(f"skin_factor must be in (0, 2] (or None for the engine's default), got {skin_factor!r}")
    rigid = all(n == 0 for n in springs)
    tool = place_tool(bed, config.working_depth, tool) if place or tool is None else tool
    rest = np.zeros(len(springs))
    if passive_tool is not None and not rigid:
        if config.spring_model != "linear":
            raise InputError(f"passive_tool needs spring_model 'linear', got {config.spring_model!r}")
        config = replace(config, support_offset=passive_tool.support_offsets)
        knobs = {**passive_tool.soil_bin_knobs(springs, tool), **(knobs or {})}
        rest = passive_tool.rest_readings(springs, tool)
    knob_arrays = _check_knobs(knobs, len(springs), rigid, config.spring_model)
    pitches = None
    if pitch is not None:
        pitches = np.asarray(pitch, dtype=np.float64).reshape(-1)
        if len(pitches) != len(springs) or not np.all(np.isfinite(pitches)) or np.any(np.abs(pitches) > 30):
            raise InputError(f"pitch needs one angle per world ({len(springs)}) within +-30 deg, got {list(pitch)}")
    model, state, info = build_scene(config, bed, tool, springs, speeds, device, soil_overrides, knob_arrays,
                                     pitches)
    dt = config.dt or default_dt(model, config.spring_model, rigid)
    p = config.preset
    travel = config.travel or p["travel"]
    wd.check_step_count("soil-bin run", config.settle_time + travel / min(speeds), dt,
                        "config.dt" if config.dt else "the Young's moduli and particle size (0.3 x the P-wave step) "
                        "and the springs' stiffness (0.5 x their step)")
    bin_size = bed.bin_size if isinstance(bed, Bed) else bed[0].bin_size
    lo = np.array([-bin_size[0], -0.5, min(-0.5, info.get("garage_bottom", 0.0) - 0.1)])
    hi = np.array([bin_size[0], bin_size[1] + travel + 1.0, 2.0])
    skin = None if skin_factor is None else skin_factor * float(model.host["sphere_radius"].mean())
    sim = wd.Simulation(model, state, dt=dt, always_use_moment_law=True, bounds=(lo, hi), skin=skin,
                        cohesion_on_new_contacts=config.cohesion_on_new_contacts,
                        bond_detection_factor=config.bond_detection_factor)
    speeds_a = np.asarray(speeds)
    carriage_vel = np.stack([np.zeros_like(speeds_a), speeds_a, np.zeros_like(speeds_a)], axis=1)
    # the sensor's material point in each world (pitched where a pitch is given). With a described tool or a pitch
    # it is fixed on the body at the initial pose and read from the drawing pose (a pitched world's reading includes
    # its pitch, the tool's settling is part of the reading, the rest reading is taken off); otherwise it is the
    # point at the sensor after the settling, read from there. Either way it is fixed before a checkpoint is loaded.
    # (a mount_pitch knob turns the sweep on its clamp, not the clamp: the sensor's point stays where it is drawn)
    drawing = passive_tool is not None or pitches is not None
    points = (np.tile(tool.sensor_point, (len(springs), 1)) if pitches is None
              else np.array([tool.pitched(a).sensor_point for a in pitches]))
    sensor = wd.observers.body_point("sweep_lower", points)
    if drawing:
        sensor(sim)
    every = max(1, int(round(1.0 / (config.sample_rate * dt))))
    # each world's carriage stops after `travel` (whole records, so the sampling stays uniform); the run ends when
    # the slowest one does
    stop = (np.ceil(travel / speeds_a / dt / every) * every).astype(int)
    n_steps = int(stop.max())
    n_settle = int(round(config.settle_time / dt)) if config.settle_time > 0 else 0
    ck, extra = None, None
    if checkpoint is not None:
        bed_digest = hashlib.sha256(b"".join(np.ascontiguousarray(x.centres).tobytes()
                                             + np.ascontiguousarray(x.radii).tobytes()
                                             for x in ([bed] if isinstance(bed, Bed) else bed))).hexdigest()
        key = json.dumps([asdict(config), list(springs), speeds, {k: np.asarray(v).tolist() for k, v in
                          knob_arrays.items()}, {k: np.asarray(v).tolist() for k, v in (soil_overrides or {}).items()},
                          bed_digest, float(dt)] + ([] if pitches is None else [pitches.tolist()]), sort_keys=True,
                         default=str)
        ck = RunCheckpoint(checkpoint, hashlib.sha256(key.encode()).hexdigest())
        extra = (ck.meta() or {}).get("extra")
    if extra is None:  # a new run (or a checkpoint without its setup: settled again, then replaced by the load)
        t_settle = time.perf_counter()
        if n_settle:  # the progress runs over the settling and the travel together
            _settle(sim, config.settle_time, carriage_vel,
                    (lambda d, n: progress(d, n_settle + n_steps)) if progress else None)
        settle_s = time.perf_counter() - t_settle
        sim.set_cohesion_now()
        s0 = np.full(len(springs), tool.sensor_point[1]) if drawing else sensor(sim)[:, 1].copy()
    else:  # resumed: the checkpoint holds the settled, bonded state; the sensor's zero and point come with it
        s0 = np.asarray(extra["s0"], dtype=np.float64)
        sensor.local = np.asarray(extra["sensor_local"], dtype=np.float64)
        settle_s = float(extra.get("settle_s", 0.0))
    steps_before = float((extra or {}).get("steps_s", 0.0))
    setup = {"s0": s0.tolist(), "sensor_local": np.asarray(sensor.local).tolist(), "settle_s": settle_s}
    contact = wd.observers.mesh_wrench("sweep_lower")
    if "soil_viscosity" in knob_arrays:  # the dashpot pushes back (compression, < 0) while the tool advances
        drag = wd.observers.spring_force("soil_viscosity")

        def draught(s: wd.Simulation) -> np.ndarray:
            return -contact(s)[:, 0, 1] - drag(s)
    else:
        def draught(s: wd.Simulation) -> np.ndarray:
            return -contact(s)[:, 0, 1]
    observers = {
        "draught": draught,
        # against the carriage where it is: it stops at its last whole record, up to a record past ``travel``
        "displacement": lambda s: -(sensor(s)[:, 1] - s0 - speeds_a * np.minimum(s.state.time, stop * dt)) - rest,
        "ke_tool": wd.observers.group_kinetic_energy("tool"),
        "ke_soil": wd.observers.group_kinetic_energy("soil"),
        "coordination": wd.observers.coordination_number("soil"),
        "bonds": wd.observers.cohesive_bonds("soil"),
    }
    # the spring spheres' support moves into its offset (+ = against travel) over SUPPORT_RAMP, then rides along
    events, ramp = set(stop.tolist()), -1
    if config.spring_model == "paper" and not rigid and any(info["support_offset_m"]):
        ramp = int(np.ceil(SUPPORT_RAMP / dt / every) * every)
        events.add(ramp)
        off = np.asarray(info["support_offset_m"])
        if extra is None:  # (a resumed run's support has the velocity its checkpoint holds)
            sim.set_body_velocity("support", carriage_vel - np.outer(off / (ramp * dt), (0.0, 1.0, 0.0)))

    if vtk is not None:
        observers["vtk"] = vtk[0].as_observer(int(vtk[1]))
    view = viewer(sim) if viewer is not None else None
    if view is not None:
        observers["viewer"] = view.as_observer({k: observers[k] for k in ("draught", "displacement", "ke_tool",
                                                                         "ke_soil")})
    parts: list[dict[str, np.ndarray]] = []
    done = 0
    if ck is not None:
        resumed = ck.load(sim)
        if resumed is not None:
            done, records = resumed
            parts.append({k: v for k, v in records.items() if k != "viewer"})
    chunk = every * max(1, int(round(0.05 / (every * dt))))  # 0.05 s of simulated time between checkpoint chances
    saved_at = time.perf_counter()
    setup_s = saved_at - t0
    t_steps = saved_at
    for end in sorted(events):
        while done < end:
            k = min(chunk, end - done) if ck is not None else end - done
            part = sim.run(k, record_every=every, observers=observers,
                           progress=(lambda d, n, base=done: progress(n_settle + base + d, n_settle + n_steps))
                           if progress else None)
            part.pop("vtk", None)  # frames are files, not series
            parts.append(part if not parts else {kk: v[1:] for kk, v in part.items()})  # drop the repeated record
            done += k
            if done == ramp:  # the support has reached its offset: it rides with the carriage
                moving = np.nonzero(stop > ramp)[0]
                sim.set_body_velocity("support", carriage_vel[moving], moving)
            if done == end:
                _stop_carriages(sim, np.nonzero(stop == end)[0])
            late = deadline is not None and time.time() >= deadline and done < n_steps
            if ck is not None and (done == end or late or time.perf_counter() - saved_at >= checkpoint_every):
                parts = [{kk: np.concatenate([p_[kk] for p_ in parts]) for kk in parts[0] if kk != "viewer"}]
                ck.save(sim, parts[0], {**setup, "steps_s": steps_before + time.perf_counter() - t_steps})
                saved_at = time.perf_counter()
            if late:
                raise BudgetExhausted(f"soil-bin run stopped at its budget after step {done} of {n_steps}; its "
                                      f"checkpoint is in {str(checkpoint)!r}")
    out = {k: np.concatenate([p_[k] for p_ in parts]) for k in parts[0]}
    steps_s = steps_before + time.perf_counter() - t_steps
    if view is not None:
        view.close()
        observers.pop("viewer")
    observers.pop("vtk", None)
    t = out["time"]
    trav = np.minimum(t[:, None] * speeds_a[None, :], travel)
    series = {k: np.asarray(out[k]) for k in observers}
    start = config.steady_travel or p["steady_travel"]
    steady = []
    surfaces = None if isinstance(bed, Bed) else [bed_surface(x) for x in bed]
    for w, n in enumerate(springs):
        row: dict[str, float] = {"springs": n, "speed": speeds[w]}
        if surfaces is not None:  # this world's own surface against the tool's (the beds' mean)
            row["replica_seed"] = bed[w].seed
            row["surface_offset"] = surfaces[w] - float(np.mean(surfaces))
        moving = out["step"] <= stop[w]
        for k in ("draught", "displacement"):
            st = analysis.steady_state(t[moving], series[k][moving, w], trav[moving, w], start_travel=start)
            row[f"{k}_mean"], row[f"{k}_std"], row[f"{k}_sem"] = st.mean, st.std, st.sem
            row[f"{k}_trend"], row[f"{k}_trend_sem"] = st.trend, st.trend_sem
        row["steady_time_mean"] = st.t_mean
        for k in ("ke_tool", "ke_soil"):
            st = analysis.steady_state(t[moving], series[k][moving, w].sum(axis=-1), trav[moving, w],
                                       start_travel=start)
            row[f"{k}_mean"], row[f"{k}_std"] = st.mean, st.std
        row["coordination_start"] = float(series["coordination"][1, w])  # record 0 precedes the first contacts
        row["coordination_end"] = float(series["coordination"][-1, w])
        row["bonds_start"] = float(series["bonds"][1, w])
        row["bonds_end"] = float(series["bonds"][-1, w])
        steady.append(row)
    return SoilBinRun(tuple(springs), tuple(speeds), t, trav, series, steady, info["n_particles"],
                      model.spheres_per_world, dt, n_steps, time.perf_counter() - t0, setup_s, sim.rebuild_count,
                      settle_s, steps_s)


def run_study(config: SoilBinConfig, *, device: str | None = None, cache_dir: str | Path | None = None,
              progress: object | None = None, viewer: object | None = None, vtk_every: int | None = None,
              vtk_dir: str | Path | None = None,
              checkpoint_dir: str | Path | None = None,
              deposit_progress: object | None = None, bed: Bed | None = None,
              replicas: int = 1, passive_tool: PassiveTool | None = None) -> dict[str, object]:
    """The bed, the rigid runs (if 0 in springs) and the passive runs (one simulation each, one world per speed or
    configuration). With 0 in ``springs`` the rigid tool runs at every distinct speed of the configurations
    (:meth:`SoilBinConfig.rigid_speeds`, as worlds of one simulation) and every passive row's reduction is against
    the rigid run at its own speed (:func:`pair_reductions`); the table has one rigid row per speed.
    ``viewer`` (see :func:`run_soil_bin`) streams the passive run (or the rigid one if there is none).
    ``vtk_every``: ParaView frames of every run at every ``vtk_every``-th record, into ``vtk_dir``/<run name>.
    ``checkpoint_dir``: each run checkpoints into a subfolder (``rigid``, ``passive``) and resumes from it after a
    kill (a run that had finished is read back, not run again); the subfolders are removed when the study is
    done. ``progress(run, done, total)``: each run's progress, ``run`` "rigid" or "passive" (simulated times [s]).
    ``deposit_progress``: the deposition's progress callback (:func:`scenes.assemblies.deposit`) when the bed is
    made. ``bed``: use this bed instead (e.g. one already made).

    ``replicas`` >= 2: every run on that many replica beds (``bed_for(config, replica=r)``, one population of
    particles, each bed set down from its own seed) as worlds of the same simulations, the tool at their mean
    surface; each replica's reductions against its own rigid run, and the table over the replicas
    (:func:`replica_table`: standard errors from the replicas' scatter). Not with ``bed``.
    ``passive_tool``: the passive runs' tool, described once (see :func:`run_soil_bin`).
    Returns {"bed" (the first replica's with replicas), "beds" (every bed), "runs": name -> SoilBinRun, "table":
    rows, "steady_travel": [m], "replicas"}."""
    import shutil

    if not (isinstance(replicas, int | np.integer) and not isinstance(replicas, bool) and replicas >= 1):
        raise InputError(f"replicas must be an integer >= 1, got {replicas!r}")
    if replicas > 1 and bed is not None:
        raise InputError(f"replicas = {replicas} deposits its own replica beds: pass no bed")
    geometry = passive_tool.sweep() if passive_tool is not None else None  # the rigid tool's too: one tool
    if replicas > 1:
        beds = [bed_for(config, device=device, cache_dir=cache_dir, progress=deposit_progress, replica=r)
                for r in range(replicas)]
        tool = place_tool(beds, config.working_depth, geometry)  # one tool pose for every run and replica
    else:
        beds = [bed or bed_for(config, device=device, cache_dir=cache_dir, progress=deposit_progress)]
        tool = geometry
    bed = beds[0]
    runs = {}
    passive = [n for n in config.springs if n != 0]
    rigid_speeds = config.rigid_speeds()
    groups = [(name, springs, speeds) for name, springs, speeds in (
        ("rigid", [0] * len(rigid_speeds), rigid_speeds),
        ("passive", passive, [v for n, v in zip(config.springs, config.speeds(), strict=True) if n != 0]))
        if springs]
    streamed = groups[-1][0]  # the passive run, else the rigid one
    for name, springs, speeds in groups:
        folder = Path(checkpoint_dir) / name if checkpoint_dir is not None else None
        world_beds: Bed | list[Bed] = bed
        if replicas > 1:  # replica after replica, each with every configuration of the group
            world_beds = [b for b in beds for _ in springs]
            springs, speeds = springs * replicas, speeds * replicas
        run_progress = (lambda d, n, name=name: progress(name, d, n)) if progress else None
        runs[name] = run_soil_bin(config, springs, bed=world_beds, device=device, progress=run_progress, speeds=speeds,
                                  viewer=viewer if name == streamed else None, checkpoint=folder,
                                  vtk=(VtkWriter(Path(vtk_dir) / name), vtk_every) if vtk_every else None,
                                  tool=tool, place=replicas == 1,
                                  passive_tool=passive_tool if name == "passive" else None)
    if checkpoint_dir is not None:
        for name, _, _ in groups:
            shutil.rmtree(Path(checkpoint_dir) / name, ignore_errors=True)
        with contextlib.suppress(OSError):  # the folder too, unless something else is in it
            Path(checkpoint_dir).rmdir()
    rows = [r for run in runs.values() for r in run.steady]
    rows = replica_table(rows) if replicas > 1 else pair_reductions(rows)
    return {"bed": bed, "beds": beds, "runs": runs, "table": rows, "replicas": replicas,
            "steady_travel": config.steady_travel or config.preset["steady_travel"]}
