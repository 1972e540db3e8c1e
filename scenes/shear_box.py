"""Direct shear box (paper section 2.3, Fig. 10): peak shear stress at several normal stresses and the Mohr-Coulomb
fit (cohesion, internal friction angle, R^2) of a DEM soil sample.

    cfg = preset("ci")                                   # assembly A, GA set 1, 5/10/20 kPa, 50 mm/s
    dry, wet = run_shear_boxes([cfg.cohesionless(), cfg])  # one batched simulation, one world per normal stress
    print(wet.table()); wet.fit.cohesion, wet.fit.friction_angle_deg, wet.fit.r2

Frame: x = shear direction, y across, z up (gravity -z). Units: SI (m, kg, s, Pa); angles in degrees.

Rig (boxes and plate are triangle meshes; both faces of a facet are active):

- sample: a bed from :func:`scenes.assemblies.deposit` (assembly A, B or C) deposited under gravity into a bin of
  the box's plan (x in [-L/2, L/2], y in [0, L]) and cut to ``sample_height`` H. By default the deposition is
  frictionless (``deposit_friction_angle=0``), the usual way of making a dense DEM sample: a dense sample has a
  distinct peak (a loose one hardens to its critical state and its "peak" is the end of the test);
- box: split at the shear plane z_s = H/2 into a lower half (walls up to z_s and a floor) and an upper half (walls
  from z_s up). Each half has a horizontal flange at z_s reaching past the shear displacement outwards, so the soil
  of one half that travels past the other half's wall stays covered while the halves slide. The halves touch (no
  gap) at the start. Walls and flanges are frictionless steel (the paper's tool stiffness): a frictionless wall
  carries no vertical load (no silo effect), so all of the normal load reaches the shear plane, and adds no
  friction to the measured horizontal force. The floor and the loading plate are rough (friction angle 40 deg, above
  the soil's, so contacts with them slide at the soil's friction, like toothed porous stones);
- normal load, a dead weight: the loading plate (a square mesh of side L) is attached to a ballast sphere above it,
  one rigid body with only the z translation free, of mass sigma_n L^2 / g. The ballast is a sphere of the soil's
  size in its own material, so a per-world density override gives each world its own normal stress, and one batched
  simulation runs every normal stress (and several samples, e.g. with and without cohesion) at once. (A mesh given
  an explicit mass has it in every world; a sphere's mass follows its material's per-world density.) Dead weight
  rather than a servo during shear: the normal force is exact at equilibrium, needs no gains and lets the plate
  rise with dilation, as in the laboratory;
- consolidation: the plate is brought down by a velocity servo onto the bed (no free-fall impact) until it carries
  its weight, then released; the sample is consolidated when the plate carries its weight within 5 % and the soil is
  at rest. In a batch each config's worlds leave the servo together when all of them carry their plates, whatever
  the other configs do. With ``consolidation_time`` (T, T) every world consolidates for exactly T, so a config's
  result does not depend on the configs batched with it (a calibration's individuals); otherwise the batch ends
  when its slowest world has settled. Cohesion is then set on every soil-soil contact
  (``Simulation.set_cohesion_now``; box, plate and ballast are not cohesive, so nothing bonds to the rig) and the
  local damping switches to ``shear_damping``, by default 0: Cundall damping opposes the accelerating part of every
  unbalanced force, which on the steadily moving lower soil acts as a drag (with 0.2 the lower half pushed 1-5 %
  harder than the upper half held); without it the two halves' mean forces balance to 0.2 % and the contacts'
  friction alone dissipates;
- cohesion model: the paper does not say whether cohesion was given to new contacts (Yade's
  setCohesionOnNewContacts) nor whether bonds were fragile, so both are options. Defaults: ``fragile=True`` (Yade's
  CohFrictMat default: a bond breaks for good at its strength) and ``cohesion_on_new_contacts=False``, the rule of
  both soil rigs (``scenes.paper.COHESION_ON_NEW_CONTACTS``, chosen by the evidence in docs/fidelity.md: closer to
  the paper's own shear-box friction angles over its 15 GA sets; at paper scale the other rule adds 10 % to the
  soil bin's rigid draught). It matters: at the ``ci`` scale GA set 1's bonds
  (Cs min(R)^2 ~ 0.5 N, below the ~1-2 N contact forces) give c ~ 1 kPa when fragile (they break within the first
  millimetre, long before the frictional peak) and ~3 kPa when not (the paper's DEM: 7 kPa); the cohesionless sample
  gives c ~ 0.1-0.5 kPa, and phi ~ 41 deg in all three;
- shear: the lower half moves along +x at ``shear_rate`` while the upper half and the plate are held in x. The shear
  force is the x force of the soil on the upper half plus that on the plate (together they hold the upper soil),
  averaged over each recording interval. Shear stress = force / L^2; the normal stress on the shear plane is the
  plate's weight plus the weight of the soil above z_s (measured after consolidation) over L^2. Nominal areas on both
  (an area correction would scale tau and sigma alike at a given displacement). The peak shear stress is the maximum
  of the curve after a centred moving average over ``smoothing`` of displacement (a noisy curve's raw maximum is
  biased upwards). The force of the soil on the lower half is recorded too: in a quasi-static test it balances the
  upper one;
- rolling and twisting resistance act on every contact (``always_use_moment_law=True``): the paper's calibrated
  eta_roll = eta_twist describe the soil grains, not only their bonds.

Quasi-static check: the inertial number I = gamma_dot d sqrt(rho_s / sigma_n) (GDR MiDi 2004) with d the particles'
mean bounding diameter, the nominal shear rate gamma_dot = v / h, h = min(sample height, 10 d) (a shear band's
width) and rho_s the particle density, reported per normal stress. By the mu(I) rheology (Jop et al. 2006:
mu = mu_s + (mu_2 - mu_s) / (1 + I_0 / I), mu_2 - mu_s ~ 0.26, I_0 ~ 0.28) the friction coefficient exceeds its
quasi-static value by about 0.9 I: under 0.01 (0.5 deg) for I < 0.01. The ``ci`` preset has I = 3e-3 to 6e-3.

Material defaults: the paper's GA parameter set (Tables 4-6) of the chosen assembly whose DEM shear box result is
closest to the laboratory shear box at the soil bin's moisture (3.96 % d.b.: c = 6.4 kPa, phi = 32.3 deg), by the sum
of squared relative differences in c and phi: set 1 for A, set 8 for B, set 11 for C. Any field can be overridden.

Presets (:func:`preset`): ``ci`` (tests: ~600 spheres per world, half a minute for six worlds on 2 CPU cores),
``cpu`` (minutes) and ``paper`` (a GPU run).
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import warpdem as wd
from warpdem.files import write_text_atomic
from warpdem.vtk import VtkWriter

from . import figures, paper
from .analysis import MohrCoulomb, mohr_coulomb
from .assemblies import AssemblySpec, Bed, deposit

GRAVITY = 9.81
"""gravitational acceleration [m/s^2] (along -z)."""
LAB_MOISTURE = 3.96
"""moisture content of the soil bin tests [% d.b.]; its laboratory shear box result selects the default GA set."""
SCALES = ("ci", "cpu", "paper")
#: bounding radius of a particle in member radii, per assembly (assemblies.loose_particles): presets scale the
#: member radius by it so that the box holds as many particle lengths whatever the shape
_EXTENT = {"A": 1.0, "B": 1.5, "C": 2.0}
#: the plate counts as loaded (servo off) and as consolidated when its contact force is within this fraction of its
#: weight ...
_PLATE_BALANCE = 0.05
#: ... and the soil's mean kinetic energy per particle is below this fraction of m_p g d (a particle's weight times
#: its diameter: a quiet bed whatever the particle size)
_KE_FRACTION = 1e-4
#: the consolidation servo resets the plate's velocity at this interval [s], well under the loaded plate's
#: response time W / (k v) (about 1 ms for the ci sample: W ~ 50-200 N, k ~ 1e6 N/m, v = 0.1 m/s) ...
_SERVO_INTERVAL = 1e-4
#: ... and the released plate's balance is checked at this interval [s]
_CHECK_INTERVAL = 2e-3
#: fixed consolidation time [s] of the boxes that calibrations and screenings batch (``consolidation_time`` (T, T)):
#: a set's result then does not depend on the sets batched with it. Lone samples consolidate in 0.07-0.10 s (``ci``),
#: 0.11-0.16 s (``cpu``, 15 samples of docs/runs/soil_ga_loose_box_h100x2) and 0.08-0.09 s (``paper``).
BATCH_CONSOLIDATION = 0.2
#: shear band width in mean particle diameters, for the inertial number
_BAND_DIAMETERS = 10.0
#: names of the rig's meshes (the lower half's body carries "lower" and "floor", the ballast carries "plate")
_MESHES = ("lower", "floor", "upper", "plate")


# --------------------------------------------------------------------------------------------------- parameters
def lab_strength(moisture_pct: float = LAB_MOISTURE) -> tuple[float, float]:
    """The laboratory shear box's cohesion [kPa] and internal friction angle [deg] at the moisture nearest to
    ``moisture_pct`` [% dry basis] (section 2.3)."""
    lab = paper.table("direct_shear_lab")
    row = int(np.argmin(np.abs(lab["moisture_pct_db"] - moisture_pct)))
    return float(lab["cohesion_kpa"][row]), float(lab["internal_friction_angle_deg"][row])


def lab_distance(cohesion_kpa: float | np.ndarray, friction_deg: float | np.ndarray,
                 lab: tuple[float, float] | None = None) -> float | np.ndarray:
    """Distance of a Mohr-Coulomb result to the laboratory's: (dc / c_lab)^2 + (dphi / phi_lab)^2 [-]."""
    c_lab, phi_lab = lab or lab_strength()
    return ((np.asarray(cohesion_kpa) - c_lab) / c_lab) ** 2 + ((np.asarray(friction_deg) - phi_lab) / phi_lab) ** 2


def closest_ga_set(kind: str) -> int:
    """The paper's GA set (Tables 4-6) of assembly ``kind`` whose DEM shear box (c, phi) is closest to the
    laboratory result at :data:`LAB_MOISTURE`, by :func:`lab_distance`."""
    ga = paper.table("ga_sets")
    sel = np.flatnonzero(ga["assembly"] == kind)
    if len(sel) == 0:
        raise ValueError(f"no GA set for assembly {kind!r}")
    err = lab_distance(ga["shear_box_cohesion_kpa"][sel], ga["shear_box_friction_angle_deg"][sel])
    return int(ga["set"][sel[np.argmin(err)]])


def ga_set(number: int) -> dict[str, object]:
    """One row of the paper's GA sets (Tables 4-6): floats, and the assembly letter under ``assembly``."""
    ga = paper.table("ga_sets")
    idx = np.flatnonzero(ga["set"] == number)
    if len(idx) == 0:
        raise ValueError(f"GA set must be one of {ga['set'].astype(int).tolist()}, got {number!r}")
    return {k: (str(v[idx[0]]) if k == "assembly" else float(v[idx[0]])) for k, v in ga.items()}


@dataclass
class ShearBoxConfig:
    """A direct shear box test of one soil sample at several normal stresses. Lengths [m], stresses [Pa].

    Material fields left ``None`` take the values of GA set ``ga_set`` (default: :func:`closest_ga_set` of the
    assembly's kind) when the config is made; to switch sets with :meth:`replace`, pass those fields as ``None`` too.
    """

    assembly: AssemblySpec = field(default_factory=lambda: AssemblySpec(kind="A", radius=0.005))
    box_side: float = 0.10
    """inner side L of the square box (x, y) [m]."""
    sample_height: float = 0.06
    """height H of the deposited sample [m]; the shear plane is at H / 2."""
    normal_stresses: tuple[float, ...] = (5e3, 10e3, 20e3)
    """normal stresses applied by the plate [Pa], at least three distinct."""
    shear_rate: float = 0.05
    """speed of the lower half [m/s]."""
    shear_displacement: float = 0.15
    """total shear displacement as a fraction of the box side [-]."""
    record_every: float = 0.002
    """recording interval as a fraction of the box side [-] (the forces are averaged over it)."""
    smoothing: float = 0.01
    """width of the moving average applied before the peak is taken, as a fraction of the box side [-]."""
    ga_set: int | None = None
    friction_angle: float | None = None
    """contact friction angle [deg]."""
    normal_cohesion: float | None = None
    """normal cohesion Cn [Pa] (bond tensile strength Cn min(R)^2)."""
    shear_cohesion: float | None = None
    """shear cohesion Cs [Pa] (bond shear strength Cs min(R)^2)."""
    eta_roll: float | None = None
    eta_twist: float | None = None
    moment_law: bool = True
    fragile: bool = True
    """a bond breaks for good at its strength (Yade's default) or yields plastically."""
    cohesion_on_new_contacts: bool = paper.COHESION_ON_NEW_CONTACTS
    """contacts made during the test also get cohesion (Yade's setCohesionOnNewContacts; module docstring); default
    the soil bin's rule, bonds on the contacts at the start of shear only."""
    bond_detection_factor: float = 1.0
    """distance bonding when the bonds are set at the start of shear (``warpdem.Simulation``'s
    ``bond_detection_factor``, Yade's interactionDetectionFactor): pairs within this factor times their radii's sum
    are bonded, touching or not (1: touching pairs only)."""
    young: float = paper.SOIL_YOUNG
    poisson: float = paper.SOIL_POISSON
    density: float = paper.SOIL_DENSITY
    deposit_friction_angle: float = 0.0
    """contact friction during deposition [deg]: 0 makes a dense sample."""
    consolidation_damping: float = 0.4
    shear_damping: float = 0.0
    """Cundall local damping of soil and plate during consolidation and during shear [-]."""
    consolidation_time: tuple[float, float] = (0.02, 0.5)
    """minimum and maximum consolidation time [s]; equal: a fixed consolidation time, the same for every world of
    a batch (the result of one config then does not depend on the others batched with it)."""
    consolidation_speed: float = 0.1
    """top speed of the loading plate while the servo brings it onto the sample [m/s]."""
    dt_factor: float = 0.3
    """time step as a fraction of the P-wave critical step [-]."""
    seed: int = 0
    label: str = ""

    def __post_init__(self) -> None:
        if self.ga_set is None:
            self.ga_set = closest_ga_set(self.assembly.kind)
        row = ga_set(self.ga_set)
        defaults = {"friction_angle": row["friction_angle_deg"], "normal_cohesion": row["normal_cohesion_pa"],
                    "shear_cohesion": row["shear_cohesion_pa"], "eta_roll": row["eta_roll_twist"],
                    "eta_twist": row["eta_roll_twist"]}
        for k, v in defaults.items():
            if getattr(self, k) is None:
                setattr(self, k, float(v))
        self.normal_stresses = tuple(float(s) for s in self.normal_stresses)
        self.consolidation_time = tuple(float(t) for t in self.consolidation_time)
        if len(self.consolidation_time) != 2 or not 0 < self.consolidation_time[0] <= self.consolidation_time[1]:
            raise ValueError(f"consolidation_time must be (min, max) with 0 < min <= max [s], got "
                             f"{self.consolidation_time}")
        if len(set(self.normal_stresses)) < 3:
            raise ValueError(f"need at least three distinct normal stresses, got {self.normal_stresses}")
        if min(self.normal_stresses) <= 0:
            raise ValueError(f"normal stresses must be positive, got {self.normal_stresses}")
        if not (math.isfinite(self.bond_detection_factor) and 1.0 <= self.bond_detection_factor <= 3.0):
            raise ValueError(f"bond_detection_factor must be in [1, 3], got {self.bond_detection_factor!r}")
        for name in ("box_side", "sample_height", "shear_rate", "shear_displacement", "record_every", "smoothing",
                     "consolidation_speed", "dt_factor"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")
        d_max = 2 * self.assembly.radius * (1 + self.assembly.spread) * _EXTENT[self.assembly.kind]
        if self.box_side < 8 * d_max:
            raise ValueError(f"box side {self.box_side} m is under 8 largest particle lengths ({8 * d_max:.4g} m)")
        if self.sample_height < 4 * d_max:
            raise ValueError(f"sample height {self.sample_height} m is under 4 largest particle lengths "
                             f"({4 * d_max:.4g} m)")
        self.material()  # validates the material fields

    def material(self) -> wd.Material:
        """The soil particles' material."""
        return wd.Material(young=self.young, poisson=self.poisson, density=self.density,
                           friction_angle=self.friction_angle, normal_cohesion=self.normal_cohesion,
                           shear_cohesion=self.shear_cohesion, eta_roll=self.eta_roll, eta_twist=self.eta_twist,
                           moment_law=self.moment_law, fragile=self.fragile)

    def replace(self, **changes: object) -> ShearBoxConfig:
        """A copy with some fields changed (validated like a new config)."""
        return dataclasses.replace(self, **changes)

    def cohesionless(self) -> ShearBoxConfig:
        """The same sample without cohesion (Cn = Cs = 0)."""
        return self.replace(normal_cohesion=0.0, shear_cohesion=0.0,
                            label=(self.label + " " if self.label else "") + "cohesionless")

    @property
    def area(self) -> float:
        """Nominal shear area L^2 [m^2]."""
        return self.box_side**2

    def inertial_number(self, normal_stress: float) -> float:
        """I = gamma_dot d sqrt(rho / sigma) [-] (module docstring) at a normal stress [Pa]."""
        d = 2 * self.assembly.radius * _EXTENT[self.assembly.kind]
        h = min(self.sample_height, _BAND_DIAMETERS * d)
        return self.shear_rate / h * d * math.sqrt(self.density / normal_stress)


def preset(scale: str = "ci", kind: str = "A", **changes: object) -> ShearBoxConfig:
    """A configuration by scale, for assembly ``kind`` (A, B, C); ``changes`` override any field.

    - ``ci``: L = 100 mm, H = 60 mm, member radius 5 mm (A: L = 10 d, ~580 spheres per world), 50 mm/s, 15 mm of
      shear: six worlds (two samples x three stresses) take about half a minute on 2 CPU cores;
    - ``cpu``: member radius 3.5 mm (L = 14 d), 40 mm/s: minutes on a CPU;
    - ``paper``: member radius 2.5 mm (L = 20 d), H = 50 mm, 20 mm/s, 20 mm of shear: a GPU run.

    For B and C the member radius is divided by the particle's bounding radius (1.5, 2) so that the box holds as many
    particle lengths (more spheres: B ~3x, C ~7x those of A).
    """
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {SCALES}, got {scale!r}")
    if kind not in _EXTENT:
        raise ValueError(f"kind must be one of {tuple(_EXTENT)}, got {kind!r}")
    radius, height, rate, shear = {"ci": (0.005, 0.06, 0.05, 0.15), "cpu": (0.0035, 0.06, 0.04, 0.15),
                                   "paper": (0.0025, 0.05, 0.02, 0.2)}[scale]
    base: dict[str, object] = {"assembly": AssemblySpec(kind=kind, radius=radius / _EXTENT[kind]),
                               "box_side": 0.10, "sample_height": height, "shear_rate": rate,
                               "shear_displacement": shear}
    base.update(changes)
    return ShearBoxConfig(**base)


# --------------------------------------------------------------------------------------------------- results
@dataclass
class ShearCurve:
    """One normal stress's test. Curves have k samples, one per recording interval."""

    normal_stress: float
    """applied by the plate [Pa]."""
    normal_stress_plane: float
    """on the shear plane: plate weight plus the weight of the soil above it, over the nominal area [Pa]."""
    displacement: np.ndarray
    """shear displacement of the lower half at the middle of each interval [m] (k,)."""
    shear_stress: np.ndarray
    """soil's x force on the upper half and the plate over the nominal area [Pa] (k,), interval means."""
    shear_stress_lower: np.ndarray
    """soil's -x force on the lower half over the nominal area [Pa] (k,), interval means (balances the above)."""
    vertical_displacement: np.ndarray
    """plate rise since the start of shear [m] (k,) (positive: dilation)."""
    peak_shear_stress: float
    """maximum of the smoothed shear stress curve [Pa]."""
    peak_displacement: float
    """where it occurs [m]."""
    inertial_number: float
    """at this normal stress [-] (module docstring)."""


@dataclass
class ShearBoxResult:
    """A shear box test: one curve per normal stress, the peaks and their Mohr-Coulomb fit."""

    config: ShearBoxConfig
    curves: list[ShearCurve]
    fit: MohrCoulomb
    """cohesion [Pa], friction_angle_deg [deg], r2 [-] of the peaks against the normal stress on the plane."""
    n_particles: int
    porosity: float
    """of the deposited bed, before consolidation [-]."""
    dt: float
    """time step [s]."""
    consolidation_time: float
    """simulated consolidation time [s]."""
    wall_s: float
    """wall time of the batched simulation this test was part of, deposition excluded [s]."""
    settled: bool = True
    """every normal stress's sample was consolidated (plate balanced, soil at rest) when the shear began."""

    @property
    def normal_stress(self) -> np.ndarray:
        """Normal stresses on the shear plane [Pa] (n,)."""
        return np.array([c.normal_stress_plane for c in self.curves])

    @property
    def peak_shear_stress(self) -> np.ndarray:
        """Peak shear stresses [Pa] (n,)."""
        return np.array([c.peak_shear_stress for c in self.curves])

    def to_dict(self) -> dict[str, object]:
        """Parameters and scalar results for reports (the curves left out)."""
        cfg = self.config
        return {
            "label": cfg.label, "assembly": cfg.assembly.kind, "member_radius_m": cfg.assembly.radius,
            "ga_set": cfg.ga_set, "friction_angle_contact_deg": cfg.friction_angle,
            "normal_cohesion_pa": cfg.normal_cohesion, "shear_cohesion_pa": cfg.shear_cohesion,
            "eta_roll": cfg.eta_roll, "eta_twist": cfg.eta_twist, "fragile": cfg.fragile,
            "cohesion_on_new_contacts": cfg.cohesion_on_new_contacts,
            "bond_detection_factor": cfg.bond_detection_factor, "box_side_m": cfg.box_side,
            "sample_height_m": cfg.sample_height, "shear_rate_m_s": cfg.shear_rate,
            "shear_displacement_m": cfg.shear_displacement * cfg.box_side, "n_particles": self.n_particles,
            "porosity": self.porosity, "dt_s": self.dt, "consolidation_time_s": self.consolidation_time,
            "settled": self.settled, "normal_stress_applied_pa": [c.normal_stress for c in self.curves],
            "normal_stress_plane_pa": self.normal_stress.tolist(),
            "peak_shear_stress_pa": self.peak_shear_stress.tolist(),
            "peak_displacement_m": [c.peak_displacement for c in self.curves],
            "inertial_number": [c.inertial_number for c in self.curves],
            "cohesion_pa": self.fit.cohesion, "friction_angle_deg": self.fit.friction_angle_deg, "r2": self.fit.r2,
            "wall_s": self.wall_s,
        }

    def table(self) -> str:
        """A plain-text report: one row per normal stress, then the fit."""
        cfg = self.config
        label = f" {cfg.label}" if cfg.label else ""
        row = ga_set(cfg.ga_set)
        own = (cfg.friction_angle, cfg.eta_roll) == (row["friction_angle_deg"], row["eta_roll_twist"])
        soil = (f"GA set {cfg.ga_set}" if own
                else f"contact friction {cfg.friction_angle:.1f} deg, eta {cfg.eta_roll:.3g}")
        lines = [f"direct shear box{label} (assembly {cfg.assembly.kind}, {soil}, "
                 f"{self.n_particles} particles, L = {cfg.box_side * 1e3:.0f} mm, H = {cfg.sample_height * 1e3:.0f} "
                 f"mm, v = {cfg.shear_rate * 1e3:.0f} mm/s, Cn = {cfg.normal_cohesion / 1e3:.1f} kPa, "
                 f"Cs = {cfg.shear_cohesion / 1e3:.1f} kPa)",
                 f"{'sigma_applied kPa':>18} {'sigma_plane kPa':>16} {'tau_peak kPa':>13} {'at mm':>7} {'I':>8}"]
        for c in self.curves:
            lines.append(f"{c.normal_stress / 1e3:18.2f} {c.normal_stress_plane / 1e3:16.2f} "
                         f"{c.peak_shear_stress / 1e3:13.2f} {c.peak_displacement * 1e3:7.2f} "
                         f"{c.inertial_number:8.2e}")
        lines.append(f"Mohr-Coulomb: c = {self.fit.cohesion / 1e3:.2f} kPa, phi = {self.fit.friction_angle_deg:.2f} "
                     f"deg, R^2 = {self.fit.r2:.4f}  (simulation {self.wall_s:.1f} s)")
        return "\n".join(lines)


# --------------------------------------------------------------------------------------------------- geometry
def _quad(a: int, b: int, c: int, d: int) -> list[list[int]]:
    return [[a, b, c], [a, c, d]]


def box_half(side: float, z0: float, z1: float, flange: float, flange_at: float) -> tuple[np.ndarray, np.ndarray]:
    """One box half without floor: four walls x in [-L/2, L/2], y in [0, L], z in [z0, z1] [m] and a horizontal
    flange at z = ``flange_at`` reaching ``flange`` [m] outwards. Returns (vertices (16, 3), faces (16, 3))."""
    h = side / 2
    x0, x1, y0, y1 = -h, h, 0.0, side
    v = [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
         [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]]
    f = _quad(0, 1, 5, 4) + _quad(1, 2, 6, 5) + _quad(2, 3, 7, 6) + _quad(3, 0, 4, 7)
    g, zf = flange, flange_at
    v += [[x0, y0, zf], [x1, y0, zf], [x1, y1, zf], [x0, y1, zf],
          [x0 - g, y0 - g, zf], [x1 + g, y0 - g, zf], [x1 + g, y1 + g, zf], [x0 - g, y1 + g, zf]]
    for k in range(4):  # the ring between the box outline and the grown outline
        a, b = 8 + k, 8 + (k + 1) % 4
        f += _quad(a, b, b + 4, a + 4)
    return np.array(v, dtype=np.float64), np.array(f, dtype=np.int64)


def square(side: float, z: float) -> tuple[np.ndarray, np.ndarray]:
    """A horizontal square x in [-L/2, L/2], y in [0, L] at height z [m] (floor, plate). Returns (v (4, 3), f)."""
    h = side / 2
    v = np.array([[-h, 0, z], [h, 0, z], [h, side, z], [-h, side, z]], dtype=np.float64)
    return v, np.array(_quad(0, 1, 2, 3), dtype=np.int64)


# --------------------------------------------------------------------------------------------------- the scene
def make_bed(config: ShearBoxConfig, device: str | None = None,
             progress: Callable[[str, float, float], None] | None = None) -> Bed:
    """Deposit the sample: the config's assembly in a bin of the box's plan, cut to the sample height.
    ``progress(phase, simulated time [s], kinetic energy per particle [J])``: see :func:`assemblies.deposit`."""
    side = config.box_side
    return deposit(config.assembly, (side, side, 2.2 * config.sample_height), config.sample_height,
                   seed=config.seed, device=device, friction_angle=config.deposit_friction_angle, progress=progress)


@dataclass
class _Rig:
    """What a run needs to know about the built scene."""

    z_shear: float
    """height of the shear plane [m]."""
    plate_mass: np.ndarray
    """mass of the plate body (ballast) per world [kg] (n_worlds,)."""


def build(configs: Sequence[ShearBoxConfig], bed: Bed) -> tuple[wd.ModelBuilder, dict[str, object], _Rig]:
    """The scene of a batch of tests: one world per (config, normal stress), config after config.

    Returns the builder, the per-world overrides for :meth:`ModelBuilder.finalize` and rig data.
    """
    ref = configs[0]
    side, r = ref.box_side, ref.assembly.radius
    z_shear = ref.sample_height / 2
    flange = ref.shear_displacement * side + 4 * r * (1 + ref.assembly.spread) * _EXTENT[ref.assembly.kind]
    plate_z0 = float(np.max(bed.centres[:, 2] + bed.radii)) + 0.1 * r
    wall_top = plate_z0 + max(0.5 * ref.sample_height, 6 * r)
    masses = np.array([s * c.area / GRAVITY for c in configs for s in c.normal_stresses])
    rho = masses / (4.0 / 3.0 * math.pi * r**3)

    b = wd.ModelBuilder(gravity=(0.0, 0.0, -GRAVITY))
    b.add_material("soil", ref.material())
    steel = {"young": paper.TOOL_YOUNG, "poisson": paper.TOOL_POISSON, "density": 7850.0, "cohesive": False}
    b.add_material("box", wd.Material(friction_angle=0.0, **steel))
    b.add_material("platen", wd.Material(friction_angle=paper.TOOL_FRICTION, **steel))
    b.add_material("ballast", wd.Material(young=ref.young, poisson=ref.poisson, density=float(rho[0]),
                                          friction_angle=0.0, cohesive=False))
    b.add_mesh("lower", *box_half(side, 0.0, z_shear, flange, z_shear), "box", kind="kinematic")
    b.add_mesh("floor", *square(side, 0.0), "platen", body=b.body_names["lower"])
    b.add_mesh("upper", *box_half(side, z_shear, wall_top, flange, z_shear), "box", kind="static")
    ballast = b.add_sphere((0.0, side / 2, wall_top + 2 * r), r, "ballast", group="plate", blocked="xyXYZ",
                           name="ballast")
    b.add_mesh("plate", *square(side, plate_z0), "platen", body=ballast)
    bed.add_to(b, "soil", group="soil")
    b.set_local_damping("soil", ref.consolidation_damping)
    b.set_local_damping("plate", ref.consolidation_damping)
    overrides: dict[str, object] = {"material:ballast:density": rho}
    for name in ("friction_angle", "normal_cohesion", "shear_cohesion", "eta_roll", "eta_twist"):
        overrides[f"material:soil:{name}"] = np.array([getattr(c, name) for c in configs for _ in c.normal_stresses])
    return b, overrides, _Rig(z_shear, masses)


# --------------------------------------------------------------------------------------------------- running
_BATCH_SHARED = ("assembly", "box_side", "sample_height", "shear_rate", "shear_displacement", "record_every",
                 "moment_law", "fragile", "cohesion_on_new_contacts", "bond_detection_factor", "young", "poisson",
                 "density", "deposit_friction_angle", "consolidation_damping", "shear_damping", "consolidation_time",
                 "consolidation_speed", "dt_factor", "seed")


def _check_batch(configs: Sequence[ShearBoxConfig]) -> None:
    """Configs run in one simulation must share everything but the per-world soil values and the stresses."""
    for c in configs[1:]:
        for k in _BATCH_SHARED:
            if getattr(c, k) != getattr(configs[0], k):
                raise ValueError(f"configs run together must have the same {k}: {getattr(configs[0], k)!r} vs "
                                 f"{getattr(c, k)!r}")


class _Probe:
    """Per-world readings: forces on the rig's meshes (averaged over steps), plate height, lower half position."""

    def __init__(self, sim: wd.Simulation) -> None:
        m = sim.model
        self.sim = sim
        self.mesh_idx = {k: np.arange(m.n_worlds) * m.meshes_per_world + m.names["mesh"][k] for k in _MESHES}

    def advance_mean(self, n: int) -> dict[str, np.ndarray]:
        """Step n times; the mean contact force on each mesh over those steps [N], (n_worlds, 3) per mesh (summed
        on the device step by step, ``Data.mesh_force_sum``)."""
        self.sim.data.mesh_force_sum.zero_()
        self.sim.advance(n)
        total = self.sim.data.mesh_force_sum.numpy()
        return {k: total[i] / n for k, i in self.mesh_idx.items()}

    def position(self, body: str, axis: int) -> np.ndarray:
        """One coordinate of a body's position per world [m] (n_worlds,)."""
        return wd.observers.body_poses(self.sim, body)[0][:, axis]


def soil_ke_per_particle(sim: wd.Simulation) -> np.ndarray:
    """Mean kinetic energy of the soil's bodies per world [J] (n_worlds,)."""
    m = sim.model
    n = int(np.sum(m.host["body_group"][: m.bodies_per_world] == m.group_index("soil")))
    return wd.observers.group_kinetic_energy("soil")(sim).sum(axis=1) / max(n, 1)


def soil_weight_above(sim: wd.Simulation, z: float) -> np.ndarray:
    """Weight [N] of the soil bodies whose centre of mass is above height z [m], per world (n_worlds,)."""
    m = sim.model
    soil = m.host["body_group"] == m.group_index("soil")
    above = soil & (sim.state.body_pos.numpy()[:, 2] > z)
    return np.bincount(m.host["body_world"], weights=m.host["body_mass"] * above, minlength=m.n_worlds) * GRAVITY


def consolidate(sim: wd.Simulation, probe: _Probe, cfg: ShearBoxConfig, rig: _Rig,
                progress: Callable[[str, float, float], None] | None,
                groups: Sequence[np.ndarray] | None = None) -> tuple[float, np.ndarray]:
    """Bring the plates onto the samples and let them settle under their weights; returns the time taken [s] and
    whether each world's sample settled (n_worlds,) bool.

    Servo stage: every ``_SERVO_INTERVAL`` the plate's vertical velocity is reset to -v (1 - F/W), clipped to +-v,
    v = ``consolidation_speed`` (F: the soil's force on the plate averaged over the interval, W: the plate's weight),
    until F is within 5 % of W in every world of its group (``groups``: the worlds of each config, default one
    group of all). Released stage: the plate is a dead weight; the samples are consolidated when F is within 5 % of
    W and the soil is at rest (module constants), after at least ``consolidation_time[0]``. At
    ``consolidation_time[1]`` it warns and returns. With min = max every world consolidates for exactly that time:
    a group's servo depends only on its own worlds, and so its result on nothing else in the batch.
    """
    t_min, t_max = cfg.consolidation_time
    fixed = t_min == t_max
    n_fixed = int(round(t_max / sim.dt))
    servo_chunk = max(1, int(round(_SERVO_INTERVAL / sim.dt)))
    check_chunk = max(1, int(round(_CHECK_INTERVAL / sim.dt)))
    weight = rig.plate_mass * GRAVITY
    m_p = cfg.density * 4.0 / 3.0 * math.pi * cfg.assembly.radius**3
    ke_quiet = _KE_FRACTION * m_p * GRAVITY * 2 * cfg.assembly.radius
    groups = [np.arange(sim.model.n_worlds)] if groups is None else [np.asarray(g) for g in groups]
    servo = np.ones(len(groups), dtype=bool)
    t, steps, done = 0.0, 0, False
    while not done and (steps < n_fixed if fixed else t < t_max):
        chunk = servo_chunk if servo.any() else check_chunk
        if fixed:
            chunk = min(chunk, n_fixed - steps)
        f = probe.advance_mean(chunk)
        steps += chunk
        t += chunk * sim.dt
        load = f["plate"][:, 2] / weight  # the soil pushes the plate up (+z)
        balanced = np.abs(load - 1.0) < _PLATE_BALANCE
        if servo.any():
            worlds = np.concatenate([g for g, on in zip(groups, servo, strict=True) if on])
            vz = -cfg.consolidation_speed * np.clip(1.0 - load[worlds], -1.0, 1.0)
            sim.set_body_velocity("ballast", np.stack([0 * vz, 0 * vz, vz], axis=1), worlds=worlds)
            servo &= ~np.array([bool(np.all(balanced[g])) for g in groups])
        elif not fixed:
            done = t >= t_min and bool(np.all(balanced)) and bool(np.all(soil_ke_per_particle(sim) < ke_quiet))
        if progress is not None:
            progress("consolidate", t, t_max)
    settled = balanced & (soil_ke_per_particle(sim) < ke_quiet) if fixed or not done else \
        np.ones(sim.model.n_worlds, dtype=bool)
    if fixed:
        t = steps * sim.dt
    if not settled.all():
        warnings.warn(f"{int(np.sum(~settled))} of {len(settled)} samples had not settled at {t:.3g} s (plate load / "
                      f"weight: {np.round(load, 3).tolist()}); shearing anyway", RuntimeWarning, stacklevel=3)
    return t, settled


def moving_average(y: np.ndarray, width: int) -> np.ndarray:
    """Centred moving average over ``width`` samples, the window shrinking at the ends."""
    if width <= 1 or len(y) < 2:
        return y.copy()
    kernel = np.ones(width)
    return np.convolve(y, kernel, mode="same") / np.convolve(np.ones_like(y), kernel, mode="same")


def shear_sample(sim: wd.Simulation, probe: _Probe, cfg: ShearBoxConfig,
           progress: Callable[[str, float, float], None] | None,
           vtk: tuple[VtkWriter, int] | None = None) -> dict[str, np.ndarray]:
    """Move the lower half at the shear rate; interval means of the forces, (k, n_worlds) arrays. ``vtk``: a
    ParaView frame at the start and at every ``every``-th record."""
    dt = sim.dt
    interval = max(1, int(round(cfg.record_every * cfg.box_side / cfg.shear_rate / dt)))
    n_rec = int(math.ceil(cfg.shear_displacement * cfg.box_side / cfg.shear_rate / dt / interval))
    x0, z0 = probe.position("lower", 0), probe.position("ballast", 2)
    sim.set_body_velocity("lower", (cfg.shear_rate, 0.0, 0.0))
    rec: dict[str, list[np.ndarray]] = {"disp": [], "upper": [], "lower": [], "rise": []}
    if vtk is not None:
        vtk[0].write(sim)
    for k in range(n_rec):
        f = probe.advance_mean(interval)
        if vtk is not None and (k + 1) % vtk[1] == 0:
            vtk[0].write(sim)
        rec["disp"].append(probe.position("lower", 0) - x0 - 0.5 * interval * dt * cfg.shear_rate)
        rec["upper"].append(f["upper"][:, 0] + f["plate"][:, 0])
        rec["lower"].append(-(f["lower"][:, 0] + f["floor"][:, 0]))
        rec["rise"].append(probe.position("ballast", 2) - z0)
        if progress is not None:
            progress("shear", (k + 1) * interval * dt, n_rec * interval * dt)
    return {k: np.array(v) for k, v in rec.items()}


def run_shear_boxes(configs: Sequence[ShearBoxConfig], device: str | None = None, *, bed: Bed | None = None,
                    progress: Callable[[str, float, float], None] | None = None,
                    vtk: tuple[VtkWriter, int] | None = None) -> list[ShearBoxResult]:
    """Run several shear box tests of one sample (e.g. with and without cohesion) as one batched simulation, one
    world per (config, normal stress). The configs must agree on everything but the soil's friction angle,
    cohesions, eta_roll, eta_twist and the normal stresses.

    Args:
        configs: the tests. device: Warp device (None: Warp's default).
        bed: a deposited sample from :func:`make_bed` (default: deposited now for the first config).
        progress: called as progress(phase, done, total), phase "consolidate" or "shear", times [s].
        vtk: (a :class:`warpdem.vtk.VtkWriter`, every): ParaView frames of every world while shearing, at its
            start and at every ``every``-th record.
    Returns:
        One :class:`ShearBoxResult` per config.
    """
    configs = list(configs)
    if not configs:
        raise ValueError("no configs given")
    _check_batch(configs)
    cfg = configs[0]
    if bed is None:
        bed = make_bed(cfg, device, progress and (lambda phase, t, _ke: progress(f"deposit {phase}", t, 3.0)))
    t0 = time.perf_counter()
    b, overrides, rig = build(configs, bed)
    n_worlds = sum(len(c.normal_stresses) for c in configs)
    model, state = b.finalize(device, n_worlds=n_worlds, overrides=overrides)
    dt = cfg.dt_factor * wd.pwave_timestep(model)
    wd.check_step_count("shear box", cfg.consolidation_time[1] + cfg.shear_displacement * cfg.box_side / cfg.shear_rate,
                        dt, f"dt_factor {cfg.dt_factor:g} x the P-wave step (Young's moduli, particle size)")
    sim = wd.Simulation(model, state, dt=dt, always_use_moment_law=True,
                        cohesion_on_new_contacts=cfg.cohesion_on_new_contacts,
                        bond_detection_factor=cfg.bond_detection_factor)
    probe = _Probe(sim)
    sizes = [len(c.normal_stresses) for c in configs]
    starts = np.cumsum([0, *sizes])
    t_cons, settled = consolidate(sim, probe, cfg, rig, progress,
                                  [np.arange(a, a + n) for a, n in zip(starts, sizes, strict=False)])
    sigma_plane = (rig.plate_mass * GRAVITY + soil_weight_above(sim, rig.z_shear)) / cfg.area
    sim.set_cohesion_now()
    sim.set_local_damping("soil", cfg.shear_damping)
    sim.set_local_damping("plate", cfg.shear_damping)
    rec = shear_sample(sim, probe, cfg, progress, vtk)
    wall = time.perf_counter() - t0

    width = max(1, int(round(cfg.smoothing / cfg.record_every)))
    results, w = [], 0
    for c in configs:
        curves = []
        for s in c.normal_stresses:
            tau = rec["upper"][:, w] / c.area
            smooth = moving_average(tau, width)
            i = int(np.argmax(smooth))
            curves.append(ShearCurve(
                normal_stress=s, normal_stress_plane=float(sigma_plane[w]), displacement=rec["disp"][:, w],
                shear_stress=tau, shear_stress_lower=rec["lower"][:, w] / c.area,
                vertical_displacement=rec["rise"][:, w], peak_shear_stress=float(smooth[i]),
                peak_displacement=float(rec["disp"][i, w]), inertial_number=c.inertial_number(float(sigma_plane[w]))))
            w += 1
        fit = mohr_coulomb([cv.normal_stress_plane for cv in curves], [cv.peak_shear_stress for cv in curves])
        results.append(ShearBoxResult(c, curves, fit, bed.n_particles, bed.porosity, dt, t_cons, wall,
                                      bool(np.all(settled[w - len(curves):w]))))
    return results


def run_shear_box(config: ShearBoxConfig, device: str | None = None,
                  progress: Callable[[str, float, float], None] | None = None, *,
                  bed: Bed | None = None, vtk: tuple[VtkWriter, int] | None = None) -> ShearBoxResult:
    """Run one shear box test, all its normal stresses in one batched simulation (see :func:`run_shear_boxes`)."""
    return run_shear_boxes([config], device, bed=bed, progress=progress, vtk=vtk)[0]


if __name__ == "__main__":  # pragma: no cover - a manual run: python -m scenes.shear_box [scale] [kind] [device]
    import sys

    args = sys.argv[1:]
    base = preset(args[0] if args else "ci", args[1] if len(args) > 1 else "A")
    for res in run_shear_boxes([base.cohesionless(), base.replace(label="cohesive")],
                               args[2] if len(args) > 2 else None):
        print(res.table())


# --------------------------------------------------------------------------------------------------- report
def write_report(result: ShearBoxResult, out: str | Path) -> Path:
    """Write ``out``/report.md, series.npz (every curve) and fig_shear_box.png (shear stress against displacement
    per normal stress; the peaks and their Mohr-Coulomb line beside the laboratory's at its moisture)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    c_lab, phi_lab = lab_strength()
    series = {}
    for k, c in enumerate(result.curves):
        series.update({f"displacement_{k}": c.displacement, f"shear_stress_{k}": c.shear_stress,
                       f"vertical_displacement_{k}": c.vertical_displacement})
    np.savez_compressed(out / "series.npz", normal_stress_plane=result.normal_stress, **series)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for c in result.curves:
        a.plot(1e3 * c.displacement, 1e-3 * c.shear_stress, lw=0.8,
               label=f"{1e-3 * c.normal_stress_plane:.1f} kPa")
    a.set_xlabel("shear displacement [mm]")
    a.set_ylabel("shear stress [kPa]")
    a.legend(title="normal stress", fontsize=7)
    s = np.linspace(0.0, 1.1 * result.normal_stress.max(), 50)
    b.plot(1e-3 * result.normal_stress, 1e-3 * result.peak_shear_stress, "o", label="warpdem peaks")
    b.plot(1e-3 * s, 1e-3 * (result.fit.cohesion + s * np.tan(np.radians(result.fit.friction_angle_deg))), "-",
           label=f"warpdem: c {result.fit.cohesion / 1e3:.2f} kPa, phi {result.fit.friction_angle_deg:.1f} deg")
    b.plot(1e-3 * s, c_lab + 1e-3 * s * np.tan(np.radians(phi_lab)), "k--",
           label=f"laboratory: c {c_lab:.1f} kPa, phi {phi_lab:.1f} deg")
    b.set_xlabel("normal stress on the plane [kPa]")
    b.set_ylabel("peak shear stress [kPa]")
    b.legend(fontsize=7)
    figures.save(fig, out / "fig_shear_box.png", 110)
    d_c, d_phi = result.fit.cohesion / 1e3 - c_lab, result.fit.friction_angle_deg - phi_lab
    text = [
        "# warpdem shear box", "", "```", result.table(), "```", "",
        f"The laboratory's direct shear box at {LAB_MOISTURE} % moisture (section 2.3): c = {c_lab:.1f} kPa, "
        f"phi = {phi_lab:.1f} deg. This sample's Mohr-Coulomb fit of its {len(result.curves)} peaks: "
        f"c = {result.fit.cohesion / 1e3:.2f} kPa ({d_c:+.2f} kPa), phi = {result.fit.friction_angle_deg:.1f} deg "
        f"({d_phi:+.1f} deg), R^2 = {result.fit.r2:.4f}: the sample's cohesion is "
        f"{result.fit.cohesion / 1e3 / c_lab:.2f} times the laboratory's and its friction angle "
        f"{'within' if abs(d_phi) <= 2 else 'more than'} 2 deg of it. With {len(result.curves)} normal stresses "
        f"the fit has {len(result.curves) - 2} degree(s) of freedom: R^2 says how straight the peaks lie, not how "
        "certain c and phi are. The cohesion comes from the bonds set on the contacts when shearing starts (none "
        "on new contacts, `scenes.paper.COHESION_ON_NEW_CONTACTS`).",
        "", "Series: `series.npz` (per normal stress k: displacement_k [m], shear_stress_k [Pa], "
        "vertical_displacement_k [m]). Parameters: `config.json`, `summary.json`.", "",
        "![shear box](fig_shear_box.png)", ""]
    path = out / "report.md"
    write_text_atomic(path, "\n".join(text))
    return path
