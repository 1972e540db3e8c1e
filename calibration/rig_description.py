"""A ringing rig as its user knows it, and the warpdem rig that behaves like it.

Measured ringing records come from a rig that is not the paper's: another tool, other lever arms, a load applied
by a cable instead of a hanging weight. A user describes the rig in a small file next to the data
(``rig.toml`` or ``rig.json``; every length from the pivot axis, SI units)::

    # rig.toml
    tool_inertia = 0.35        # tool's moment of inertia about the pivot axis [kg m^2], without the load
    tool_mass = 4.0            # [kg] and its centre of mass [m]: forward of the pivot (the load's side), below it
    tool_com = [0.02, 0.10]    #   (its weight's moment and gravity stiffness; default: the sweep's, scaled)
    spring_lever = 0.45        # pivot axis to the springs' line of action [m]
    sensor_lever = 0.50        # pivot axis to the displacement sensor [m]
    load_force = 150.0         # vertical load [N] (0: none)
    load_arm = 0.30            # horizontal distance from the pivot axis to the load's line of action [m]
    load_depth = 0.50          # depth of the load's point below the pivot axis [m] (its gravity stiffness F d)
    load_mass_rides = false    # true: a hanging dead weight (F/g swings with the tool); false: a cable, a balance
    hit = "record"             # "record": each configuration's first swing from its record; or the sensor's
                               # initial velocity [m/s]
    uncertain = ["inertia", "stiffness", "damping"]   # first-order unknowns the baseline fits
    damping = "per_configuration"  # or "one_dashpot" (default): one dashpot for all configurations
    unit_travel = 0.525e-3     # service travel of one unit of a stack [m] (default: DIN 2093 25 x 12.2 x 0.9,
                               #   0.75 h0, with the default rates; unknown with stated rates unless given)
    [spring_rates]             # [N/m] per spring count (default: DIN 2093 of Table 2)
    4 = 2.1e5
    [damping_ratios]           # with damping = "per_configuration": each configuration's damping ratio [-]
    4 = 0.27                   #   (default: each record's own measured ratio)
    [static_deflection]        # one absolute datum: the sensor's reading [m] under the load (load_force at
    springs = 4                #   load_arm, load_depth) against its reading without it, on this configuration;
    deflection = 1.2e-3        #   it fixes the rates, so a fit of the inertia is no longer a ratio

Every key is optional; the defaults are the paper's rig as warpdem builds it (``scenes.ringing``: the sweep's
inertia, its springs at the sensor's height, the 200 N weight hanging at the blade tip).

warpdem's ringing rig is a hinged tool on a linear spring (``scenes.ringing``). A rig that turns about one axis is
described, for small swings, by its inertia about the axis J, the springs' rotational stiffness k a^2, the load
(its moment F l, its gravity stiffness F d: a pendulum, whether the load is a weight or a cable's pull, and the
inertia of its riding mass) and the lever that turns a rotation into the sensor's reading. :func:`equivalent` maps
the description onto warpdem's rig with the same J and k a^2 (the tool's mass and inertia scaled,
``tool_mass_scale``; the spring rate scaled by (a / a0)^2; the load acting at the described point) and scales the
simulated sensor reading by s / a0. The tool's own weight (``tool_mass`` at ``tool_com``) adds a moment and a
gravity stiffness; warpdem's tool carries the sweep's, scaled with its inertia, and the load's point is moved so
that the sums are the described rig's. Without ``tool_mass`` the sweep's scaled weight stands for the tool's (for
the paper's rig its gravity stiffness is under 3 % of the springs' k a^2, up to 25 % for soft springs on a light
rig: describe the tool's mass then).
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from warpdem.errors import InputError, check_keys, count_table

DAMPING = ("one_dashpot", "per_configuration")
"""the baseline's damping: one dashpot for all configurations, or each configuration's own damping ratio (stated in
``damping_ratios`` or its record's) times one fitted factor ``damping_scale``."""
UNCERTAIN = ("inertia", "stiffness", "damping")
"""first-order unknowns a baseline may fit: ``inertia`` (a factor on the rig's inertia about the pivot),
``stiffness`` (a factor on every spring rate), ``damping`` (one dashpot for all configurations)."""
FILES = ("rig.toml", "rig.json")
"""the names under which :func:`find_description` looks for a description next to measured data."""


class DescriptionError(InputError):
    """A rig description with a bad or unknown entry (the message names it, its value and what is allowed)."""


@dataclass(frozen=True)
class RingingRigDescription:
    """A ringing rig (module docstring). Lengths [m] from the pivot axis, forces [N], inertia [kg m^2]; None:
    the paper's rig's value."""

    tool_inertia: float | None = None
    tool_mass: float | None = None
    tool_com: tuple[float, float] | None = None
    """(forward, below) the pivot [m]; needed with tool_mass."""
    spring_lever: float | None = None
    sensor_lever: float | None = None
    """default: the spring lever (the paper's sensor sits at the springs)."""
    load_force: float = 200.0
    load_arm: float | None = None
    load_depth: float | None = None
    load_mass_rides: bool = True
    spring_rates: dict[int, float] = field(default_factory=dict)
    hit: str | float = "record"
    uncertain: tuple[str, ...] = ("damping",)
    damping: str = "one_dashpot"
    damping_ratios: dict[int, float] = field(default_factory=dict)
    """per spring count, the damping ratio [-] of ``damping = "per_configuration"`` (default: the record's)."""
    static_deflection: tuple[int, float] | None = None
    """(spring count, the sensor's reading under the load against without it [m]): one absolute datum."""
    unit_travel: float | None = None
    """service travel of one unit of a stack [m] (None: DIN 2093 25 x 12.2 x 0.9's with the default rates)."""
    source: str = ""
    """where it was read from (empty: built in code)."""

    def __post_init__(self) -> None:
        for name in ("tool_inertia", "tool_mass", "spring_lever", "sensor_lever", "load_arm", "load_depth"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise DescriptionError(f"rig description: {name} must be a positive number [SI], got {v!r}")
        if (self.tool_mass is None) != (self.tool_com is None):
            raise DescriptionError("rig description: tool_mass and tool_com go together (the weight and where it "
                                   f"acts), got tool_mass={self.tool_mass!r}, tool_com={self.tool_com!r}")
        if self.tool_com is not None and (len(self.tool_com) != 2 or not all(
                isinstance(v, (int, float)) and math.isfinite(v) for v in self.tool_com)):
            raise DescriptionError(f"rig description: tool_com must be [forward, below] [m], got {self.tool_com!r}")
        if not (isinstance(self.load_force, (int, float)) and math.isfinite(self.load_force) and self.load_force >= 0):
            raise DescriptionError(f"rig description: load_force must be a number >= 0 [N], got {self.load_force!r}")
        if not isinstance(self.load_mass_rides, bool):
            raise DescriptionError(f"rig description: load_mass_rides must be true or false, got "
                                   f"{self.load_mass_rides!r}")
        if self.load_mass_rides and self.load_force == 0:
            raise DescriptionError("rig description: load_mass_rides = true needs a load_force > 0")
        from scenes.paper import SPRING_COUNTS

        for n, k in self.spring_rates.items():
            if n not in SPRING_COUNTS:
                raise DescriptionError(f"rig description: spring_rates key {n!r} is not a spring count of the rig; "
                                       f"allowed {', '.join(map(str, SPRING_COUNTS))}")
            if not (isinstance(k, (int, float)) and math.isfinite(k) and k > 0):
                raise DescriptionError(f"rig description: spring_rates[{n}] must be a positive rate [N/m], got {k!r}")
        if isinstance(self.hit, str):
            if self.hit != "record":
                raise DescriptionError(f"rig description: hit must be \"record\" or the sensor's initial velocity "
                                       f"[m/s], got {self.hit!r}")
        elif not (math.isfinite(self.hit) and self.hit != 0):
            raise DescriptionError(f"rig description: hit must be a non-zero velocity [m/s], got {self.hit!r}")
        if self.damping not in DAMPING:
            raise DescriptionError(f"rig description: damping must be one of {list(DAMPING)}, got {self.damping!r}")
        for n, z in self.damping_ratios.items():
            if n not in SPRING_COUNTS:
                raise DescriptionError(f"rig description: damping_ratios key {n!r} is not a spring count of the rig; "
                                       f"allowed {', '.join(map(str, SPRING_COUNTS))}")
            if not (isinstance(z, (int, float)) and math.isfinite(z) and 0 < z < 1):
                raise DescriptionError(f"rig description: damping_ratios[{n}] must be a ratio in (0, 1), got {z!r}")
        if self.damping_ratios and self.damping != "per_configuration":
            raise DescriptionError("rig description: damping_ratios need damping = \"per_configuration\"")
        if self.static_deflection is not None:
            n, u = self.static_deflection
            if n not in SPRING_COUNTS:
                raise DescriptionError(f"rig description: static_deflection springs {n!r} is not a spring count of "
                                       f"the rig; allowed {', '.join(map(str, SPRING_COUNTS))}")
            if not (isinstance(u, (int, float)) and math.isfinite(u) and u > 0):
                raise DescriptionError(f"rig description: static_deflection deflection must be a positive reading "
                                       f"[m], got {u!r}")
            if self.load_force == 0:
                raise DescriptionError("rig description: static_deflection needs a load_force > 0 (the known load)")
        if self.unit_travel is not None and not (isinstance(self.unit_travel, (int, float))
                                                 and math.isfinite(self.unit_travel) and self.unit_travel > 0):
            raise DescriptionError(f"rig description: unit_travel must be a positive length [m], got "
                                   f"{self.unit_travel!r}")
        bad = [u for u in self.uncertain if u not in UNCERTAIN]
        if bad:
            raise DescriptionError(f"rig description: uncertain entries {bad} unknown; allowed {list(UNCERTAIN)}")

    def to_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["spring_rates"] = {str(k): v for k, v in self.spring_rates.items()}
        d["uncertain"] = list(self.uncertain)
        d["damping_ratios"] = {str(k): v for k, v in self.damping_ratios.items()}
        d["static_deflection"] = list(self.static_deflection) if self.static_deflection else None
        return d


KEYS = {"tool_inertia", "tool_mass", "tool_com", "spring_lever", "sensor_lever", "load_force", "load_arm", "load_depth",
        "load_mass_rides", "spring_rates", "hit", "uncertain", "damping", "damping_ratios", "static_deflection",
        "unit_travel"}


def parse(data: dict[str, object], source: str = "") -> RingingRigDescription:
    """A description from a parsed TOML/JSON table; unknown keys are errors."""
    check_keys(f"rig description{' ' + source if source else ''}", data, KEYS, DescriptionError)
    kw: dict[str, object] = {}
    for k, v in data.items():
        if k in ("spring_rates", "damping_ratios"):
            what = "a rate [N/m]" if k == "spring_rates" else "a damping ratio [-]"
            kw[k] = count_table(f"rig description: {k}", v, what, DescriptionError)
        elif k == "static_deflection":
            if not isinstance(v, dict) or set(v) != {"springs", "deflection"}:
                raise DescriptionError(f"rig description: static_deflection must be a table with springs and "
                                       f"deflection [m], got {v!r}")
            try:
                kw[k] = (int(v["springs"]), float(v["deflection"]))
            except (TypeError, ValueError):
                raise DescriptionError(f"rig description: static_deflection {v!r}: a spring count and a reading "
                                       f"[m] are needed") from None
        elif k == "damping":
            kw[k] = v
        elif k == "uncertain":
            if isinstance(v, str):
                v = [s.strip() for s in v.split(",") if s.strip()]
            if not isinstance(v, list):
                raise DescriptionError(f"rig description: uncertain must be a list of {list(UNCERTAIN)}, got {v!r}")
            kw[k] = tuple(str(s) for s in v)
        elif k in ("load_mass_rides", "hit"):
            kw[k] = v
        elif k == "tool_com":
            if not isinstance(v, list):
                raise DescriptionError(f"rig description: tool_com must be [forward, below] [m], got {v!r}")
            kw[k] = tuple(v)
        else:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise DescriptionError(f"rig description: {k} must be a number, got {v!r}")
            kw[k] = float(v)
    return RingingRigDescription(**kw, source=source)


def load(path: str | Path) -> RingingRigDescription:
    """Read a description from a ``.toml`` or ``.json`` file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise DescriptionError(f"rig description {str(p)!r} cannot be read: {e}") from None
    try:
        data = json.loads(text) if p.suffix == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as e:
        raise DescriptionError(f"rig description {str(p)!r} is not valid {p.suffix[1:].upper()}: {e}") from None
    if not isinstance(data, dict):
        raise DescriptionError(f"rig description {str(p)!r} must be a table of keys, got {type(data).__name__}")
    return parse(data, str(p))


def find_description(folder: str | Path) -> RingingRigDescription | None:
    """The description next to measured data (``rig.toml`` or ``rig.json`` in the folder), or None."""
    found = [Path(folder) / f for f in FILES if (Path(folder) / f).exists()]
    if len(found) > 1:
        raise DescriptionError(f"{folder}: both rig.toml and rig.json; keep one")
    return load(found[0]) if found else None


@dataclass(frozen=True)
class PaperRig:
    """The reference numbers of warpdem's ringing rig (``scenes.ringing``, linear spring model)."""

    tool_inertia: float
    """the sweep's inertia about the pivot axis [kg m^2]."""
    lever: float
    """pivot to the springs (and the sensor) [m]."""
    load_arm: float
    """horizontal distance pivot to the blade tip where the load acts [m]."""
    load_radius: float
    """distance pivot to the blade tip [m]."""
    load_depth: float
    """depth of the blade tip below the pivot [m]."""
    tool_moment: float
    """the sweep's weight moment about the pivot axis [N m], as (forward) x (weight)."""
    tool_gravity_stiffness: float
    """the sweep's m g (depth of its centre of mass) [N m/rad]."""


def paper_rig() -> PaperRig:
    from scenes.sweep import build_sweep

    tool = build_sweep()
    r = np.asarray(tool.tip, float) - tool.pivot
    c = tool.com - tool.pivot
    forward = math.copysign(1.0, r[1])
    return PaperRig(float(tool.inertia_about(tool.pivot)[0, 0]), float(abs(tool.sensor_point[2] - tool.pivot[2])),
                    float(abs(r[1])), float(math.hypot(r[1], r[2])), float(-r[2]),
                    float(tool.mass * 9.81 * forward * c[1]), float(-tool.mass * 9.81 * c[2]))


@dataclass(frozen=True)
class Equivalent:
    """warpdem's rig settings that behave like a described rig (module docstring)."""

    tool_mass_scale: float
    """the sweep's mass and inertia times this."""
    load_force: float
    """[N]."""
    load_offset: tuple[float, float] | None
    """where it acts: (forward, below) the pivot [m]; None: the blade tip (the paper's)."""
    load_mass_fraction: float
    """of load_force / g riding with the tool (0: none)."""
    rate_factor: float
    """spring rate (and dashpot, and any series stiffness) in warpdem's rig per unit of the described one,
    (a / a0)^2; a cubic spring term scales by (a / a0)^4."""
    reading_factor: float
    """the described sensor's reading per unit of warpdem's sensor reading, s / a0."""
    inertia: float
    """the described rig's inertia about the pivot, tool and riding load [kg m^2]."""


def equivalent(desc: RingingRigDescription, inertia_factor: float = 1.0, ref: PaperRig | None = None) -> Equivalent:
    """warpdem's settings for the described rig, its inertia about the pivot times ``inertia_factor``."""
    ref = ref or paper_rig()
    a = desc.spring_lever or ref.lever
    s = desc.sensor_lever or a
    arm = desc.load_arm if desc.load_arm is not None else ref.load_arm
    depth = desc.load_depth if desc.load_depth is not None else ref.load_depth
    offset = None if desc.load_arm is None and desc.load_depth is None else (arm, depth)
    tool = desc.tool_inertia or ref.tool_inertia
    force = desc.load_force if desc.load_force > 0 else 1e-6  # no load: a vanishing force keeps the rig defined
    load_inertia = desc.load_force / 9.81 * (arm**2 + depth**2) if desc.load_mass_rides else 0.0
    total = inertia_factor * (tool + load_inertia)
    frac = 0.0
    if desc.load_mass_rides:  # the riding load as stated, but never more than 95 % of the fitted inertia
        frac = min(1.0, 0.95 * total / load_inertia)
    scale = (total - frac * load_inertia) / ref.tool_inertia
    if desc.tool_inertia is None and inertia_factor == 1.0:
        scale = 1.0  # the sweep's exactly
    if desc.tool_mass is not None:
        # the load's point moved so that the load's and the scaled sweep's moment and gravity stiffness add up to
        # the described tool's and load's (the riding load's inertia follows the point: a few fixed-point rounds)
        if desc.load_force == 0:
            force = 10.0  # a massless pull that exists only to carry the difference
        moment = desc.load_force * arm + desc.tool_mass * 9.81 * desc.tool_com[0]
        stiff = desc.load_force * depth + desc.tool_mass * 9.81 * desc.tool_com[1]
        m = desc.load_force / 9.81 if desc.load_mass_rides else 0.0
        for _ in range(50):
            arm2 = (moment - scale * ref.tool_moment) / force
            depth2 = (stiff - scale * ref.tool_gravity_stiffness) / force
            j_load = m * (arm2**2 + depth2**2)
            frac = min(1.0, 0.95 * total / j_load) if m > 0 else 0.0
            scale = (total - frac * j_load) / ref.tool_inertia
        offset = (arm2, depth2)
    return Equivalent(scale, force, offset, frac, (a / ref.lever) ** 2, s / ref.lever, total)
