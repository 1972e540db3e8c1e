"""The passive tool as the laboratory built it, described once for the ringing rig and the soil bin.

One description (:class:`PassiveTool`, read from a ``tool.toml``) holds everything about the spring-mounted sweep
that a calibration may fit or a user may know: the spring rates of the eight stacks (DIN 2093 times a factor),
the tool's inertia (the CAD value times a factor), a compliance in series with the stack, the stack's preload,
how much of the ringing test's 200 N load swings with the tool, the damping of each stack and whether Table 2's
support offsets apply. The ringing rig (:meth:`PassiveTool.ringing_config`) and the soil bin
(:meth:`PassiveTool.soil_bin_knobs`) are built from the same numbers, so a value fitted on one is the value used
by the other, and every fitted number has a physical bound (:data:`BOUNDS`) against which a fit is judged.

Geometry (``scenes.sweep``, frame x lateral = pivot axis, y travel, z up): the stack pushes on the shank's rear face
at the sensor point, ``a`` = 0.1 m below the pivot (the paper's sensor lever, Fig. 4a; the paper's Fig. 16 reads the
displacement "at the point of contact between the spring and the sweep tool's shank"), along +y. A backward rotation
theta of the tool (the soil's push) moves the sensor by r = a theta against travel: the lab's displacement,
positive backward.

The stacks (section 2.1.1, Fig. 1b): a unit is two DIN 2093 discs 25 x 12.2 x 0.9 in parallel, n units in series
(n = 4 ... 32), rate k_DIN(n) = 3.0e6 / n N/m as the paper quotes. DIN 2093 (1992), section 7.1: a disc of group 1
(thickness under 1.25 mm) may carry +25 % / -7.5 % of its nominal load at s = 0.75 h0, which bounds a stack's rate
factor to [0.925, 1.25]. Series B 25 x 12.2 x 0.9 has a free cone height h0 = 0.7 mm, so a stack of n units travels
at most 0.75 h0 n = 0.525 n mm in service: its preload (a compression at assembly) and its working deflection
together stay within that.

Closed forms (small rotations; used by the fit and checked against the simulated rigs in tests/test_passive_tool.py):

- ringing: J theta'' + c a^2 theta' + (k_e a^2 + K_g) theta = 0, with J = f_J J_CAD + phi m_L r_L^2 (the tool's
  inertia about the pivot and the load's riding mass), k_e = (1 / (f_k k_DIN) + 1 / k_s)^-1, K_g = m g h_c + F_L d_L
  (the tool's pendulum stiffness and the load's, which acts like a weight whether it rides or not):
  f = sqrt((k_e a^2 + K_g) / J) sqrt(1 - zeta^2) / (2 pi);
- statics: M + a T(o - r) + m g (y_c + z_c r / a) = 0 for the sensor's reading r under a backward moment M about
  the pivot [N m], with T(u) the stack's tension law at stretch u (the engine's spring law: preload, rate, stop) and
  o the support offset; the lab zeroes its sensor at rest (M = 0), so its reading is r(M) - r(0).
"""

from __future__ import annotations

import functools
import math
import tomllib
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

import numpy as np

from warpdem.errors import InputError, check_keys, count_table

from . import paper
from .sweep import SweepParams, SweepTool, build_sweep

G = 9.81
"""gravity [m/s^2] (every warpdem rig's)."""
DISC_CONE_HEIGHT = 0.7e-3
"""free cone height h0 of a DIN 2093 series B 25 x 12.2 x 0.9 disc [m]."""
SERVICE_TRAVEL = 0.75
"""DIN 2093's service deflection of a disc as a fraction of h0 (its nominal load is specified there)."""
DISC_OUTER_RADIUS = 12.5e-3
"""outer radius of a DIN 2093 series B 25 x 12.2 x 0.9 disc [m]: a stack's seat bears on the shank within it."""
SENSOR_MOUNT_TOLERANCE = 10e-3
"""how far the displacement sensor's contact point may sit from the lever the paper gives for it (100 mm, Fig. 4a)
[m]: warpdem's assumption (the paper states the lever, not its tolerance); it bounds the sensor_lever mechanism."""
DIN_RATE_TOLERANCE = (0.925, 1.25)
"""DIN 2093 (1992) section 7.1, group 1 (t < 1.25 mm): a disc's load at s = 0.75 h0 within -7.5 % / +25 % of the
nominal: the bounds of the rate factor of a stack."""
INERTIA_TOLERANCE = (0.9, 1.1)
"""bounds of the tool's inertia about the pivot relative to warpdem's sweep (the paper's CAD mass and inertia about
its centre of mass on warpdem's parametric geometry, whose pivot-to-centre-of-mass distance the paper does not
give): +-10 %."""
SHANK_LENGTH_RANGE = (0.30, 0.80)
"""range of the pivot's height above the blade tip [m] a fit may use (the paper gives no value): at the low end the
sensor point (0.1 m below the pivot) sits 0.05 m above the soil surface at the 0.15 m working depth; the high end is
a long cultivator shank. warpdem's assumption, like its 0.6 m default."""
SERIES_STIFFNESS_MIN = 1.0e5
"""the softest frame and mounting in series with a stack [N/m] a fit may use: softer than the softest stack (32
units, 0.94e5 N/m) it would set every configuration's frequency by itself, which Table 2's spread rules out."""
MIN_RIDING = 1e-3
"""the smallest riding fraction of the ringing load that warpdem's ringing rig simulates as a mass (below: none)."""
STOP_RATIO = 100.0
"""a preloaded stack rests on a stop this many times stiffer than its rate (``scenes.soil_bin.STOP_RATIO``)."""


@functools.cache
def _sweep(shank_length: float) -> SweepTool:
    return build_sweep(SweepParams(shank_length=shank_length))


@functools.cache
def _row(springs: int) -> dict[str, float]:
    return paper.ringing_row(springs)


def din_rate(springs: int) -> float:
    """The paper's DIN 2093 rate [N/m] of a stack of ``springs`` units in series (Table 2's column)."""
    return float(_row(springs)["stiffness_n_per_m"])


def stack_travel(springs: int) -> float:
    """Service travel of a stack of ``springs`` units in series [m]: 0.75 h0 per unit (DIN 2093)."""
    return SERVICE_TRAVEL * DISC_CONE_HEIGHT * springs


BOUNDS: dict[str, tuple[float, float]] = {
    "rate_factor": DIN_RATE_TOLERANCE,
    "inertia_factor": INERTIA_TOLERANCE,
    "series_stiffness": (SERIES_STIFFNESS_MIN, math.inf),
    "preload": (0.0, stack_travel(min(paper.SPRING_COUNTS))),
    "load_mass_fraction": (0.0, 1.0),
    "shank_length": SHANK_LENGTH_RANGE,
}
"""physical range of every number a fit may change: rate factor (DIN 2093 tolerance), inertia factor (CAD estimate),
series stiffness [N/m], preload [m] (within the stiffest stack's service travel, 2.1 mm for 4 units), the load's
riding fraction and the shank length [m] (:data:`SHANK_LENGTH_RANGE`)."""


@dataclass(frozen=True)
class PassiveTool:
    """The spring-mounted sweep, described once (module docstring). SI units.

    Attributes:
        rate_factor: every stack's rate per unit of its DIN 2093 rate [-].
        rate_factors: per stack (spring count -> factor), overriding ``rate_factor`` for that stack [-].
        inertia_factor: the tool's mass and inertia about the pivot per unit of warpdem's sweep's [-] (the mass
            distributed like the sweep's).
        series_stiffness: a compliance in series with each stack (frame, shank, mounting) [N/m]; inf: none. It
            acts in the ringing rig, and in the soil bin unless ``bin_series_stiffness`` is given.
        bin_series_stiffness: the soil bin's own compliance in series with each stack [N/m] (inf: none), where its
            stack holder is not the ringing instrument's (Table 2's ringing test stands the stacks "between two
            supporting surfaces of the instrument", section 2.1.1); None: ``series_stiffness``.
        preload: the stack's compression at assembly in the soil bin's holder [m], against a stop at the drawing
            pose: the tool rests on the stop until the stack's load exceeds rate x preload. 0: none. The ringing
            rig has none: a preload above the load's moment would hold the ringing tool on its stop, and Table 2
            shows it ringing on its stack.
        load_mass_fraction: of the ringing test's load F / g, the part that swings with the tool [-] (1: a hanging
            dead weight; 0: a pull without mass, e.g. a cable over a spring balance).
        damping_ratio: per stack (spring count -> damping ratio [-] of the ringing rig on that stack, load
            included, as Table 2 measures it); a stack missing here takes Table 2's measured ratio. It sets the
            stack's dashpot (:meth:`dashpot`), which the soil bin uses as it is.
        support_offsets: apply Table 2's support offsets (the paper's final DEM: the stack's seat moved along
            travel, + against it) in the soil bin.
        shank_length: the pivot's height above the blade tip [m] (``scenes.sweep.SweepParams.shank_length``; the
            paper gives none: 0.6 m is warpdem's assumption). It sets the draught's lever about the pivot and the
            tool's inertia about it (the paper's mass and inertia about the centre of mass, moved there).
        source: where it was read from (empty: built in code).
    """

    rate_factor: float = 1.0
    rate_factors: dict[int, float] = field(default_factory=dict)
    inertia_factor: float = 1.0
    series_stiffness: float = math.inf
    bin_series_stiffness: float | None = None
    preload: float = 0.0
    load_mass_fraction: float = 0.0
    damping_ratio: dict[int, float] = field(default_factory=dict)
    support_offsets: bool = False
    shank_length: float = SweepParams.shank_length
    source: str = ""

    def __post_init__(self) -> None:
        for name in ("rate_factor", "inertia_factor", "series_stiffness", "shank_length"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0 and not math.isnan(v)):
                raise InputError(f"tool description: {name} must be a positive number, got {v!r}")
        b = self.bin_series_stiffness
        if b is not None and not (isinstance(b, (int, float)) and not isinstance(b, bool) and b > 0
                                  and not math.isnan(b)):
            raise InputError(f"tool description: bin_series_stiffness must be a positive number [N/m] (inf: none), "
                             f"got {b!r}")
        if not math.isfinite(self.rate_factor) or not math.isfinite(self.inertia_factor):
            raise InputError(f"tool description: rate_factor and inertia_factor must be finite, got "
                             f"{self.rate_factor!r}, {self.inertia_factor!r}")
        if not (math.isfinite(self.preload) and self.preload >= 0):
            raise InputError(f"tool description: preload must be a length >= 0 [m], got {self.preload!r}")
        if not 0.0 <= self.load_mass_fraction <= 1.0:
            raise InputError(f"tool description: load_mass_fraction must be in [0, 1], got "
                             f"{self.load_mass_fraction!r}")
        for label, table, ok in (("rate_factors", self.rate_factors, lambda v: math.isfinite(v) and v > 0),
                                 ("damping_ratio", self.damping_ratio, lambda v: 0 <= v < 1)):
            for n, v in table.items():
                if n not in paper.SPRING_COUNTS:
                    raise InputError(f"tool description: {label} names spring count {n!r}; known "
                                     f"{list(paper.SPRING_COUNTS)}")
                if not (isinstance(v, (int, float)) and ok(float(v))):
                    raise InputError(f"tool description: {label}[{n}] out of range, got {v!r}")
        travel = min(stack_travel(n) for n in paper.SPRING_COUNTS)
        if self.preload > travel:
            raise InputError(f"tool description: preload must lie within the stiffest stack's service travel "
                             f"({travel * 1e3:.2f} mm, DIN 2093), got {self.preload * 1e3:.3g} mm")

    def sweep(self) -> SweepTool:
        """The sweep of this description (its pivot at the origin; ``scenes.soil_bin.place_tool`` places it)."""
        return _sweep(self.shank_length)

    # ------------------------------------------------------------------------------------------- the stacks
    def rate(self, springs: int) -> float:
        """The stack's own rate [N/m]: its factor times DIN 2093's."""
        return self.rate_factors.get(springs, self.rate_factor) * din_rate(springs)

    def bin_series(self) -> float:
        """The soil bin's compliance in series with each stack [N/m] (inf: none)."""
        return self.series_stiffness if self.bin_series_stiffness is None else float(self.bin_series_stiffness)

    def effective_rate(self, springs: int, rig: str = "ringing") -> float:
        """The stack and the series compliance of ``rig`` ("ringing" or "soil bin") together [N/m]:
        k k_s / (k + k_s)."""
        if rig not in ("ringing", "soil bin"):
            raise ValueError(f"rig must be 'ringing' or 'soil bin', got {rig!r}")
        k = self.rate(springs)
        k_s = self.series_stiffness if rig == "ringing" else self.bin_series()
        return k if math.isinf(k_s) else k * k_s / (k + k_s)

    def zeta(self, springs: int) -> float:
        """The ringing rig's damping ratio on this stack [-], load included (Table 2's measured where not given)."""
        return float(self.damping_ratio.get(springs, _row(springs)["measured_damping"]))

    # ------------------------------------------------------------------------------------------- the tool
    def pivot_inertia(self, tool: SweepTool | None = None) -> float:
        """The tool's inertia about the pivot axis [kg m^2]: the factor times the sweep's."""
        tool = tool or self.sweep()
        return float(self.inertia_factor * tool.inertia_about(tool.pivot)[0, 0])

    def tool_gravity_stiffness(self, tool: SweepTool | None = None) -> float:
        """The tool's pendulum stiffness about the pivot, m g h_c [N m/rad] (its mass scaled with its inertia)."""
        tool = tool or self.sweep()
        return float(-self.inertia_factor * tool.mass * G * (tool.com[2] - tool.pivot[2]))

    def ringing_stiffness_inertia(self, springs: int, tool: SweepTool | None = None,
                                  load_force: float = paper.LOAD_FORCE) -> tuple[float, float]:
        """The ringing rig's rotational stiffness about the pivot [N m/rad] and inertia [kg m^2], the load
        ``load_force`` [N] at the blade tip: (k_e a^2 + K_g, J) of the module docstring."""
        tool = tool or self.sweep()
        a = lever(tool)
        r = np.asarray(tool.tip, dtype=np.float64) - tool.pivot
        inertia = self.pivot_inertia(tool) + self.load_mass_fraction * load_force / G * (r[1] ** 2 + r[2] ** 2)
        k_rot = self.effective_rate(springs) * a**2 + self.tool_gravity_stiffness(tool) + load_force * (-r[2])
        return float(k_rot), float(inertia)

    def dashpot(self, springs: int, tool: SweepTool | None = None) -> float:
        """The stack's dashpot [N s/m]: the one that gives the ringing rig (load included) its damping ratio,
        2 zeta sqrt(K J) / a^2. The same dashpot acts in the soil bin."""
        tool = tool or self.sweep()
        k_rot, inertia = self.ringing_stiffness_inertia(springs, tool)
        return 2.0 * self.zeta(springs) * math.sqrt(k_rot * inertia) / lever(tool) ** 2

    # ------------------------------------------------------------------------------------------- closed forms
    def ringing_frequency(self, springs: int, tool: SweepTool | None = None,
                          load_force: float = paper.LOAD_FORCE) -> float:
        """Damped frequency [Hz] of the ringing rig (module docstring) on this stack, the load ``load_force`` [N]
        at the blade tip, the stack's dashpot (:meth:`dashpot`, set for the standard load)."""
        tool = tool or self.sweep()
        k_rot, inertia = self.ringing_stiffness_inertia(springs, tool, load_force)
        zeta = self.dashpot(springs, tool) * lever(tool) ** 2 / (2.0 * math.sqrt(k_rot * inertia))
        return math.sqrt(k_rot / inertia) * math.sqrt(max(0.0, 1.0 - zeta**2)) / (2.0 * math.pi)

    def tension(self, springs: int, stretch: float) -> float:
        """The soil bin's stack's tension [N] (> 0 pulls the tool back) at ``stretch`` u [m] from its rest length:
        the engine's spring law with preload P = -k_e preload (a compression), F = P + k_e u, and the stop
        (STOP_RATIO k_e) on the side the preload drives (u > 0); k_e with the soil bin's series compliance."""
        k = self.effective_rate(springs, "soil bin")
        p = -k * self.preload
        f = p + k * stretch
        if p * stretch < 0.0:
            f += STOP_RATIO * k * stretch
        return f

    def sensor_reading(self, springs: int, moment: float, tool: SweepTool | None = None,
                       offset: float = 0.0) -> float:
        """The sensor's displacement [m] (backward positive, from the drawing pose) at rest under a backward moment
        ``moment`` about the pivot [N m], the stack's seat moved ``offset`` [m] against travel. Solves the
        moment balance of the module docstring (small rotations) by bisection."""
        tool = tool or self.sweep()
        a = lever(tool)
        c = tool.com - tool.pivot
        weight = self.inertia_factor * tool.mass * G

        def balance(r: float) -> float:  # backward moment on the tool at reading r; decreasing in r
            return moment + a * self.tension(springs, offset - r) + weight * (c[1] + c[2] * r / a)

        lo, hi = -0.5, 0.5
        if balance(lo) < 0 or balance(hi) > 0:
            raise InputError(f"sensor_reading: no rest within +-0.5 m for moment {moment!r} N m")
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if balance(mid) > 0 else (lo, mid)
        return 0.5 * (lo + hi)

    def lab_reading(self, springs: int, moment: float, tool: SweepTool | None = None, offset: float = 0.0) -> float:
        """What the lab's sensor reads [m] under a backward moment [N m]: the reading zeroed at rest (no moment)."""
        return self.sensor_reading(springs, moment, tool, offset) - self.sensor_reading(springs, 0.0, tool, offset)

    def stack_force(self, springs: int, reading: float, tool: SweepTool | None = None, offset: float = 0.0) -> float:
        """The stack's push on the shank [N] (> 0: compression, pushing the tool forward) when the lab's sensor
        reads ``reading`` [m] (zeroed at rest): -T at the stretch the reading sets. Times the lever, the moment
        that holds the tool against the soil (less the tool's weight's)."""
        rest = self.sensor_reading(springs, 0.0, tool, offset)
        return -self.tension(springs, offset - (rest + reading))

    # ------------------------------------------------------------------------------------------- the rigs
    def ringing_config(self, springs: tuple[int, ...] = paper.SPRING_COUNTS, **kw: object) -> object:
        """warpdem's ringing rig (linear springs) for these stacks: a ``scenes.ringing.RingingConfig``. A riding
        fraction under MIN_RIDING (0.02 kg of the 200 N load, 0.3 % of the frequency) is taken as none: the pin
        that carries a riding load would need a time step below 1e-5 s for less."""
        from .ringing import RingingConfig

        n = len(springs)
        phi = self.load_mass_fraction if self.load_mass_fraction >= MIN_RIDING else 0.0
        return RingingConfig(
            springs=tuple(springs), spring_model="linear",
            stiffness=tuple(self.rate(s) for s in springs),
            series_stiffness=None if math.isinf(self.series_stiffness) else (self.series_stiffness,) * n,
            tool_mass_scale=None if self.inertia_factor == 1.0 else (self.inertia_factor,) * n,
            load_mass_fraction=(phi,) * n,
            dashpot=tuple(self.dashpot(s) for s in springs), **kw)

    def soil_bin_knobs(self, springs: list[int] | tuple[int, ...], tool: SweepTool | None = None
                       ) -> dict[str, list[float]]:
        """Per-world knobs of ``scenes.soil_bin.run_soil_bin`` (passive worlds) for these stacks."""
        tool = tool or self.sweep()
        knobs: dict[str, list[float]] = {
            "stiffness": [self.rate(s) for s in springs],
            "dashpot": [self.dashpot(s, tool) for s in springs],
        }
        if not math.isinf(self.bin_series()):
            knobs["series_stiffness"] = [self.bin_series()] * len(springs)
        if self.preload > 0:
            knobs["stack_preload"] = [self.preload] * len(springs)
        if self.inertia_factor != 1.0:
            knobs["tool_mass_scale"] = [self.inertia_factor] * len(springs)
        return knobs

    def offsets(self, springs: list[int] | tuple[int, ...]) -> list[float]:
        """The stack seat's offset per world [m] (+ against travel): Table 2's where ``support_offsets``, else 0."""
        return [1e-3 * _row(s)["support_offset_mm"] if self.support_offsets else 0.0 for s in springs]

    def rest_readings(self, springs: list[int] | tuple[int, ...], tool: SweepTool | None = None) -> np.ndarray:
        """The sensor's reading at rest (no soil) per world [m] (n,), from the drawing pose: the lab's zero."""
        tool = tool or self.sweep()
        return np.array([self.sensor_reading(s, 0.0, tool, o) for s, o in zip(springs, self.offsets(springs),
                                                                              strict=True)])

    # ------------------------------------------------------------------------------------------- files
    def bounds_report(self, names: tuple[str, ...] = tuple(BOUNDS), rtol: float = 1e-6) -> dict[str, str]:
        """For each bounded number: "inside", "at its lower bound" or "at its upper bound" (within ``rtol``)."""
        return {name: bound_status(getattr(self, name), BOUNDS[name], rtol) for name in names}

    def to_toml(self) -> str:
        """The description as TOML (``load_toml`` reads it back)."""
        lines = ["# the passive tool (scenes/passive_tool.py): SI units"]
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "source" or isinstance(v, dict) or v is None:
                continue
            if isinstance(v, bool):
                lines.append(f"{f.name} = {'true' if v else 'false'}")
            elif isinstance(v, float) and math.isinf(v):
                lines.append(f"{f.name} = inf")
            else:
                lines.append(f"{f.name} = {float(v)!r}")
        for name in ("rate_factors", "damping_ratio"):
            table = getattr(self, name)
            if table:
                lines.append(f"[{name}]")
                lines += [f'"{n}" = {float(v)!r}' for n, v in sorted(table.items())]
        return "\n".join(lines) + "\n"

    def to_dict(self) -> dict[str, object]:
        d = asdict(self)
        for name in ("rate_factors", "damping_ratio"):
            d[name] = {str(k): v for k, v in d[name].items()}
        if d["bin_series_stiffness"] is not None and math.isinf(d["bin_series_stiffness"]):
            d["bin_series_stiffness"] = "inf"  # JSON's null means "the ringing rig's"
        return d


def bound_status(value: float, bounds: tuple[float, float], rtol: float = 1e-6) -> str:
    """"at its lower bound", "at its upper bound" or "inside" ``bounds`` (lo, hi), within ``rtol``."""
    lo, hi = bounds
    if math.isfinite(lo) and value <= lo * (1 + rtol) + 1e-12:
        return "at its lower bound"
    if math.isfinite(hi) and value >= hi * (1 - rtol) - 1e-12:
        return "at its upper bound"
    return "inside"


def lever(tool: SweepTool) -> float:
    """The stack's (and the sensor's) lever about the pivot [m]: the sensor point's depth below it."""
    return float(abs(tool.sensor_point[2] - tool.pivot[2]))


KEYS = {f.name for f in fields(PassiveTool)} - {"source"}


def parse(data: dict[str, object], source: str = "") -> PassiveTool:
    """A description from a parsed TOML table; unknown keys and bad values are errors naming them."""
    check_keys(f"tool description{' ' + source if source else ''}", data, KEYS)
    kw: dict[str, object] = {}
    for k, v in data.items():
        if k in ("rate_factors", "damping_ratio"):
            kw[k] = count_table(f"tool description: {k}", v)
        elif k == "support_offsets":
            if not isinstance(v, bool):
                raise InputError(f"tool description: support_offsets must be true or false, got {v!r}")
            kw[k] = v
        else:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise InputError(f"tool description: {k} must be a number, got {v!r}")
            kw[k] = float(v)
    return PassiveTool(**kw, source=source)


def from_dict(data: dict[str, object]) -> PassiveTool:
    """A description from :meth:`PassiveTool.to_dict` as JSON stores it (an infinite series stiffness as null, an
    infinite soil-bin series stiffness as "inf")."""
    d = {k: v for k, v in data.items() if k != "source"}
    if d.get("series_stiffness") is None:
        d["series_stiffness"] = math.inf
    if d.get("bin_series_stiffness", 0.0) is None:
        del d["bin_series_stiffness"]
    elif d.get("bin_series_stiffness") == "inf":
        d["bin_series_stiffness"] = math.inf
    return parse(d, str(data.get("source", "")))


JOINT_TOOL_FILE = Path(__file__).parent / "data" / "passive_tool_joint.toml"
"""the full workflow's default passive tool: Table 2's frequencies and Table 3's mean displacements fitted together
(``calibration.tool_fit.fit_joint``, mounts per rig, shank 0.44 m; docs/runs/passive-tool-joint-fit), run in the soil
bin at paper scale in docs/runs/passive-tool-described-h100."""


def joint_tool() -> PassiveTool:
    """The tool of :data:`JOINT_TOOL_FILE`, its source named by the package path (the same on every machine, so
    a run's configuration does not depend on where warpdem is installed)."""
    return replace(load_toml(JOINT_TOOL_FILE), source="scenes/data/passive_tool_joint.toml")


def load_toml(path: str | Path) -> PassiveTool:
    """Read a description from a TOML file (errors name the file and the entry)."""
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"tool description {str(p)!r} cannot be read: {e}") from None
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"tool description {str(p)!r} is not valid TOML: {e}") from None
    return parse(data, str(p))
