"""Candidate mechanisms for model criticism: named physical extensions of a DEM rig.

A mechanism is not a correction of outputs: it names physics the baseline rig lacks, brings its own parameters
(genes: ranges and scales) and says how it changes the rig through *knobs*, named physical settings that a rig model
(``calibration.rig_models``) implements in the DEM scene: a torque in the hinge integrator, a spring law, a body's
mass, the spring's preload, the sensor's reading. A rig supports a set of knobs; a mechanism applies to a rig when
the rig supports all of its knobs.

Built-in mechanisms (rationale in each entry): ``pivot_friction``, ``progressive_spring``, ``series_compliance``,
``extra_mass``, ``load_inertia``, ``pose_change``, ``sensor_offset``, ``sensor_drift``, ``stack_preload``,
``speed_dependence``, ``rigid_reference_speed``, ``progressive_stack``, ``lever_geometry``, ``sensor_lever``,
``soil_tool_friction``, ``soil_tool_adhesion``, ``soil_bond_strength``, ``bed_density``, ``bond_settling``,
``yielding_bonds``, ``fragile_bonds``, ``mount_pitch``.

A mechanism without genes is a discrete alternative (the soil's bonds yield instead of breaking): its fit is the
baseline's genes refitted with its knobs set, and the diagnosis counts the choice as one degree of freedom.

Physical bounds (issue #39, item 1): every gene of a mechanism has a physical range, from the rig (its
:class:`RigFacts`: the stacks' rates and travel, the tool's mass, the first swing) where the rig states one, with its
source (:meth:`Mechanism.physical`): a preload within the stiffest stack's travel, a stack's hardening within DIN
2093's tolerance of its load at 0.75 h0, a pivot friction below the springs' moment at the first swing. The fit
searches the gene's range cut to that bound; a fit that ends on the bound is not named as a cause
(``calibration.diagnosis``): the data ask for more than the mechanism physically gives, so the cause is likely
outside it. ``produces``: the baseline deviations a mechanism would make a fitted baseline absorb (item 2);
``ridge``: how a gene's fitted size moves along the ringing baseline's inertia-stiffness ridge (value ~ J^p).

Register your own::

    from calibration.mechanisms import Mechanism, register
    from calibration.genes import Gene
    register(Mechanism("stiff_pivot", "Pivot bushing compliance", "rubber bushing ...",
                       genes=(Gene("bushing_friction", 0.01, 1.0, log=True, unit="N m"),),
                       knobs=lambda p: {"pivot_friction": p["bushing_friction"]}))
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from scenes.rigs import RINGING, SOIL_BIN

from .genes import Gene

SEARCH_ONLY = "the search range (no physical bound stated for it)"
"""the source of a bound that is only the gene's search range."""


@dataclass(frozen=True)
class Bound:
    """A physical range of one gene (SI, the gene's unit) and where it comes from."""

    low: float
    high: float
    source: str


@dataclass(frozen=True)
class RigFacts:
    """What a rig states that bounds the mechanisms' parameters (SI; NaN or empty where the rig does not say).

    rig: "ringing" or "soil-bin"; springs (n_configs,): units per stack; rates (n_configs,) [N/m]: the stated rates;
    travel (n_configs,) [m]: each stack's service travel (DIN 2093: 0.75 h0 per unit); working_deflection
    (n_configs,) [m]: each stack's static deflection under the rig's load (ringing: nominal; soil bin: the measured
    mean displacement at the sensor, where the stacks' stated lever is); swing_moment [N m]: the
    smallest moment of the springs at a configuration's first swing (K theta_1); tool_mass [kg]; lever [m]: the
    stacks' and the sensor's stated lever about the pivot; seat_radius [m]: how far from its axis a stack's seat may
    bear on the shank (the discs' outer radius); sensor_tolerance [m]: how far the sensor's contact point may sit
    from its stated lever; soil_friction [deg]: the soil's internal friction angle (its shear box); soil_cohesion
    [Pa]: the soil's own contact normal cohesion (its bonds' tensile strength per R^2); soil_fragile: whether the
    soil's bonds break for good at their strength (True) or yield (False; None where the rig does not say)."""

    rig: str
    springs: tuple[int, ...] = ()
    rates: tuple[float, ...] = ()
    travel: tuple[float, ...] = ()
    working_deflection: tuple[float, ...] = ()
    swing_moment: float = math.nan
    tool_mass: float = math.nan
    lever: float = math.nan
    seat_radius: float = math.nan
    sensor_tolerance: float = math.nan
    soil_friction: float = math.nan
    soil_cohesion: float = math.nan
    soil_fragile: bool | None = None


@dataclass(frozen=True)
class Mechanism:
    """A named physical extension of a rig.

    name: identifier (``[a-z_]+``); title: a short human name; rationale: why it could be there, physically;
    genes: its parameters (SI, with ranges the fit searches); knobs: parameter values -> the rig knobs to set
    (knob name -> value in SI); rigs: the rigs it is meant for (documentation; applicability is decided by the
    knobs a rig supports); needs_series: it only shows in time series (skipped on summary-only data); varies: the
    configurations' covariates (``rig.covariates()``) its effect is told by (skipped on data where one of them is
    the same in every configuration: there it is a free offset that would absorb any other cause under its name).
    """

    name: str
    title: str
    rationale: str
    genes: tuple[Gene, ...]
    knobs: Callable[[dict[str, float]], dict[str, float]]
    rigs: tuple[str, ...] = (RINGING.name, SOIL_BIN.name)
    needs_series: bool = False
    varies: tuple[str, ...] = ()
    signature: str = ""
    """what it does to the observables, for the report."""
    extra: dict[str, object] = field(default_factory=dict)
    bounds: Callable[[RigFacts], dict[str, Bound]] | None = None
    """physical ranges of (some of) its genes from the rig's facts; a gene left out keeps its search range."""
    produces: tuple[str, ...] = ()
    """baseline deviations it would make a fitted baseline absorb: "stiffness_high", "stiffness_low",
    "inertia_high", "inertia_low" (the search tries these mechanisms first when the baseline shows one)."""
    applies: Callable[[RigFacts], bool] | None = None
    """whether it changes a rig with these facts (a discrete alternative offered only where the rig is the other
    way; None: wherever the rig has its knobs)."""
    ridge: dict[str, float] = field(default_factory=dict)
    """gene -> p: along the inertia-stiffness ridge of a ringing fit (rates and inertia scaled together) the gene's
    fitted value scales as J^p (a torque, a series stiffness, a mass: 1; a cubic spring term, whose stiffening at
    the static deflection the data hold as k3 / k^3: 3; a fraction, a sensor reading: 0, left out)."""

    def __post_init__(self) -> None:
        if not self.name.replace("_", "").isalnum() or not self.name.islower():
            raise ValueError(f"mechanism name must be lower_case, got {self.name!r}")
        names = [g.name for g in self.genes]
        if len(set(names)) != len(names):
            raise ValueError(f"mechanism {self.name!r}: gene names repeat: {names}")

    def physical(self, facts: RigFacts | None) -> dict[str, Bound]:
        """Every gene's physical range (cut to its search range) with its source."""
        given = self.bounds(facts) if (self.bounds is not None and facts is not None) else {}
        out = {}
        for g in self.genes:
            b = given.get(g.name)
            if b is None or not (math.isfinite(b.low) or math.isfinite(b.high)):
                out[g.name] = Bound(g.low, g.high, SEARCH_ONLY)
            else:
                out[g.name] = Bound(max(g.low, b.low), min(g.high, b.high), b.source)
        return out

    def bounded_genes(self, facts: RigFacts | None) -> tuple[Gene, ...]:
        """Its genes with ranges cut to their physical bounds (a bound narrower than a tenth of a percent of the
        range keeps a sliver, so the gene stays defined)."""
        out = []
        for g in self.genes:
            b = self.physical(facts)[g.name]
            lo, hi = b.low, b.high
            if not hi > lo:
                hi = lo * 1.001 if lo > 0 else lo + 1e-3 * (g.high - g.low)
            out.append(Gene(g.name, float(lo), float(hi), log=g.log, unit=g.unit))
        return tuple(out)

    def knob_names(self) -> set[str]:
        """The knobs this mechanism sets (evaluated at the middle of its ranges)."""
        mid = {g.name: float(g.from_ga(sum(g.ga_range) / 2)) for g in self.genes}
        return set(self.knobs(mid))


REGISTRY: dict[str, Mechanism] = {}
"""name -> Mechanism; :func:`register` adds to it."""


def register(mechanism: Mechanism, *, replace: bool = False) -> Mechanism:
    """Add a mechanism to the registry (an existing name needs ``replace=True``)."""
    if mechanism.name in REGISTRY and not replace:
        raise ValueError(f"mechanism {mechanism.name!r} is already registered (pass replace=True)")
    REGISTRY[mechanism.name] = mechanism
    return mechanism


def get(name: str) -> Mechanism:
    if name not in REGISTRY:
        raise ValueError(f"unknown mechanism {name!r}; registered: {sorted(REGISTRY)}")
    return REGISTRY[name]



DIN_LOAD_TOLERANCE = 0.25
"""DIN 2093 (1992) section 7.1, group 1: a disc's load at s = 0.75 h0 within +25 % of its nominal (and -7.5 %): a
stack's hardening above its linear rate stays within that at its service travel."""


def _finite(xs: tuple[float, ...]) -> list[float]:
    return [x for x in xs if math.isfinite(x)]


def _friction_bound(f: RigFacts) -> dict[str, Bound]:
    if f.rig == RINGING.name and math.isfinite(f.swing_moment):
        return {"pivot_friction": Bound(0.0, f.swing_moment, "a Coulomb oscillator stops where the springs' moment "
                                        "K theta falls below the friction torque: above the smallest first-swing "
                                        "moment K theta_1 of the measured configurations a decay could not be "
                                        "recorded (closed form)")}
    moments = [k * abs(x) * f.lever for k, x in zip(f.rates, f.working_deflection, strict=False)
               if math.isfinite(k * x * f.lever)]
    if f.rig != SOIL_BIN.name or not moments:
        return {}
    return {"pivot_friction": Bound(0.0, min(moments), "the springs turn the tool back against the friction: their "
                                    "moment at the measured mean deflection, k x a (the smallest over the "
                                    "configurations), above the friction torque, or a tool the soil pushed back "
                                    "could not swing forward again")}


def _progressive_bound(f: RigFacts) -> dict[str, Bound]:
    lim = [DIN_LOAD_TOLERANCE * k / s**2 for k, s in zip(f.rates, f.travel, strict=False)
           if math.isfinite(s) and s > 0]
    if not lim:
        return {}
    return {"progressive": Bound(0.0, min(lim), "DIN 2093 section 7.1: every stack's load at its service travel "
                                 "s (0.75 h0 per unit) within +25 % of k s, so k3 s^2 <= 0.25 k for each stack")}


def _stack_hardening_bound(f: RigFacts) -> dict[str, Bound]:
    return {"hardening": Bound(0.0, DIN_LOAD_TOLERANCE, "DIN 2093 section 7.1: a disc's load at 0.75 h0 within +25 % "
                               "of the nominal, so the stack's force at its travel k s (1 + beta) has beta <= 0.25")}


def _series_bound(f: RigFacts) -> dict[str, Bound]:
    rates = _finite(f.rates)
    if not rates:
        return {}
    return {"series_stiffness": Bound(min(rates), math.inf, "softer than the softest stated stack, a compliance in "
                                      "series would set every configuration's stiffness by itself "
                                      "(scenes.passive_tool.SERIES_STIFFNESS_MIN for the paper's rig)")}


def _extra_mass_bound(f: RigFacts) -> dict[str, Bound]:
    if not math.isfinite(f.tool_mass):
        return {}
    return {"extra_mass": Bound(0.0, f.tool_mass, "hardware riding with the tool (clamps, preload nuts, the "
                                "sensor's moving part) weighs less than the tool itself (the rig's tool mass)")}


def _load_bound(f: RigFacts) -> dict[str, Bound]:
    return {"load_mass_fraction": Bound(0.0, 1.0, "a fraction of the load's own mass "
                                        "(scenes.passive_tool.BOUNDS['load_mass_fraction'])")}


def _preload_bound(f: RigFacts) -> dict[str, Bound]:
    travel = _finite(f.travel)
    if not travel:
        return {}
    return {"stack_preload": Bound(0.0, min(travel), "DIN 2093: a stack's compression (preload and working "
                                   "deflection) stays within its service travel 0.75 h0 per unit; one preload for "
                                   "all stacks: the stiffest stack's travel (scenes.passive_tool.BOUNDS['preload'])")}


def _lever_bound(f: RigFacts) -> dict[str, Bound]:
    if not (math.isfinite(f.lever) and math.isfinite(f.seat_radius)) or f.lever <= 0:
        return {}
    r = f.seat_radius / f.lever
    return {"spring_lever": Bound(1.0 - r, 1.0 + r, f"the stack's seat bears on the shank within the discs' outer "
                                  f"radius ({1e3 * f.seat_radius:.1f} mm, DIN 2093 series B 25) of its axis at the "
                                  f"stated {1e3 * f.lever:.0f} mm lever")}


def _sensor_lever_bound(f: RigFacts) -> dict[str, Bound]:
    if not (math.isfinite(f.lever) and math.isfinite(f.sensor_tolerance)) or f.lever <= 0:
        return {}
    r = f.sensor_tolerance / f.lever
    return {"sensor_lever": Bound(1.0 - r, 1.0 + r, f"the sensor's contact point within {1e3 * f.sensor_tolerance:.0f}"
                                  f" mm of its stated {1e3 * f.lever:.0f} mm lever (scenes.passive_tool."
                                  "SENSOR_MOUNT_TOLERANCE, an assumption: the paper gives no tolerance)")}


MOUNT_PITCH_TOLERANCE = 3.0
"""how far [deg] the sweep may sit turned on its hinge clamp against the drawing (an assumption: the paper gives no
tolerance; a clamp bolted through holes with 1 mm of play over 40 mm turns by 1.4 deg, a shank bent in use more)."""


def _mount_pitch_bound(f: RigFacts) -> dict[str, Bound]:
    return {"mount_pitch": Bound(-MOUNT_PITCH_TOLERANCE, MOUNT_PITCH_TOLERANCE, f"the sweep within "
                                 f"{MOUNT_PITCH_TOLERANCE:g} deg of its drawn attitude on the hinge clamp "
                                 "(calibration.mechanisms.MOUNT_PITCH_TOLERANCE, an assumption: the paper gives no "
                                 "tolerance)")}


POTYONDY_RATIO = (0.5, 1.0)
"""soil-steel friction angle over the soil's internal friction angle: Potyondy (1961, Geotechnique 11(4)) measured
about 0.54 (smooth steel) to 0.76 (rough) on sand; an interface cannot be stronger than the soil itself (1)."""


def _tool_friction_bound(f: RigFacts) -> dict[str, Bound]:
    if not math.isfinite(f.soil_friction):
        return {}
    lo, hi = (r * f.soil_friction for r in POTYONDY_RATIO)
    return {"tool_friction": Bound(lo, hi, f"soil on steel: {POTYONDY_RATIO[0]:g}-{POTYONDY_RATIO[1]:g} x the soil's "
                                   f"internal friction angle ({f.soil_friction:g} deg, its shear box): Potyondy "
                                   "(1961) measured 0.54-0.76 for sand on smooth to rough steel; no interface is "
                                   "stronger than the soil")}


register(Mechanism(
    "pivot_friction", "Dry friction at the pivot",
    "The shank turns about a pin in a bore; a dry (Coulomb) friction torque there takes a fixed amount of "
    "amplitude per cycle instead of a fixed fraction, so the decay is linear, damping grows as the amplitude falls "
    "and the tool can stop short of its equilibrium.",
    genes=(Gene("pivot_friction", 1e-3, 100.0, log=True, unit="N m"),),
    knobs=lambda p: {"pivot_friction": p["pivot_friction"]},
    signature="damping that rises late in a decay and for small swings; equal for all stiffnesses",
    bounds=_friction_bound, ridge={"pivot_friction": 1.0}))
register(Mechanism(
    "progressive_spring", "Progressive spring stack",
    "Stacked disc springs (DIN 2093) stiffen with deflection when discs go flat or touch the guide; F = k u + "
    "k3 u^3 about the free length makes the tangent stiffness grow with the static deflection, most for the "
    "softest stacks, and the frequency grow with amplitude.",
    genes=(Gene("progressive", 1e4, 1e14, log=True, unit="N/m^3"),),
    knobs=lambda p: {"progressive": p["progressive"]},
    signature="soft configurations stiffer than their nominal rate; frequency falling along a decay",
    bounds=_progressive_bound, produces=("stiffness_high", "inertia_low"),
    # its stiffening 3 k3 u0^2 / k at the static deflection u0 ~ 1 / k: held by the data as k3 / k^3, so k3 ~ J^3
    ridge={"progressive": 3.0}))
register(Mechanism(
    "series_compliance", "Compliance in series with the springs",
    "Shank, clamps and frame are not rigid: a stiffness ks in series gives the stack k ks/(k+ks), which lowers the "
    "stiff configurations most and compresses the range of frequencies a spring count can give. In the soil bin it "
    "softens the passive stacks; the rigid tool's own shank compliance is left out: pitched over -4 ... +9 deg the "
    "rigid sweep's draught changes by +0.13 +- 0.21 % per degree (docs/runs/passive-tool-bonded-short-shank-h100_s3), "
    "so its shank would have to bend it back by about 8 deg (2 deg at the slope's upper two-SE bound) to move the "
    "rigid draught by 1 %.",
    genes=(Gene("series_stiffness", 1e3, 1e8, log=True, unit="N/m"),),
    knobs=lambda p: {"series_stiffness": p["series_stiffness"]},
    signature="stiff configurations softer than nominal; frequency ratio below sqrt of the stiffness ratio",
    bounds=_series_bound, produces=("stiffness_low", "inertia_high"), ridge={"series_stiffness": 1.0}))
register(Mechanism(
    "extra_mass", "Extra mass on the tool",
    "Preload hardware, clamps and the sensor's moving parts ride with the tool: more mass and inertia about the "
    "pivot lower every frequency by the same factor and the damping ratio of a given dashpot with it.",
    genes=(Gene("extra_mass", 0.0, 30.0, unit="kg"),),
    knobs=lambda p: {"extra_mass": p["extra_mass"]},
    signature="all frequencies lower by one factor",
    bounds=_extra_mass_bound, produces=("inertia_high", "stiffness_low"), ridge={"extra_mass": 1.0}))
register(Mechanism(
    "load_inertia", "Load force without its mass",
    "A ringing test's load may be applied by a cable, a lever or a spring balance rather than a dead weight: the "
    "force and its moment stay, but only part of the load's mass swings with the tool, so every frequency rises "
    "by one factor (less so for the stiff configurations, whose own inertia weighs more) and a given dashpot's "
    "damping ratio rises.",
    genes=(Gene("load_mass_fraction", 0.02, 1.0, unit="-"),),
    knobs=lambda p: {"load_mass_fraction": p["load_mass_fraction"]},
    rigs=(RINGING.name,),
    signature="all frequencies higher by about one factor",
    bounds=_load_bound, produces=("inertia_low", "stiffness_high")))
register(Mechanism(
    "pose_change", "Pose change with the static deflection",
    "The springs are unloaded at the drawing's pose: under the load the tool turns back by its static deflection, "
    "which changes the lever arms, the spring's line of action and, in soil, the attack angle.",
    genes=(),
    knobs=lambda p: {"free_pose": 1.0},
    signature="effects growing with the static deflection (soft configurations)"))
register(Mechanism(
    "sensor_offset", "Sensor offset",
    "A displacement sensor reads from a zero set before the run (with the tool unloaded, or leaning on a stop): "
    "every reading carries the same offset, which shifts mean displacements but not the vibration.",
    genes=(Gene("sensor_offset", -5e-3, 5e-3, unit="m"),),
    knobs=lambda p: {"sensor_offset": p["sensor_offset"]},
    rigs=(SOIL_BIN.name,),
    signature="mean displacements shifted by one constant"))
register(Mechanism(
    "sensor_drift", "Sensor drift",
    "Strain gauges and displacement sensors drift with temperature and creep: a slope in time under the signal, "
    "which biases a decay's fitted damping and a run's mean.",
    genes=(Gene("sensor_drift", -5e-3, 5e-3, unit="m/s"),),
    knobs=lambda p: {"sensor_drift": p["sensor_drift"]},
    rigs=(SOIL_BIN.name,),
    needs_series=True,
    signature="a trend in time under the signal"))
register(Mechanism(
    "stack_preload", "Preloaded spring stack on a stop",
    "A plate-spring stack is assembled compressed between its seats: the tool rests on a stop at its drawing pose "
    "until the load exceeds the preload, then deflects by the excess only. The stiff configurations barely leave "
    "the stop (and barely vibrate); every soft one reads its deflection less the preload's compression.",
    genes=(Gene("stack_preload", 0.0, 5e-3, unit="m"),),
    knobs=lambda p: {"stack_preload": p["stack_preload"]},
    rigs=(SOIL_BIN.name,),
    signature="mean displacements low by a constant, the stiffest configurations at zero",
    bounds=_preload_bound))
register(Mechanism(
    "speed_dependence", "Speed-dependent soil resistance",
    "Soil resistance grows with the tool's speed (rate-dependent strength, soil acceleration): a resistance "
    "b v on the tool adds draught in proportion to the speed of each run.",
    genes=(Gene("soil_viscosity", 1.0, 1e3, log=True, unit="N s/m"),),
    knobs=lambda p: {"soil_viscosity": p["soil_viscosity"]},
    rigs=(SOIL_BIN.name,), varies=("speed",),
    signature="draught residuals growing with the speed of the run"))
register(Mechanism(
    "rigid_reference_speed", "Rigid reference at another speed",
    "A reduction compares a passive run with a rigid run. Taken against one rigid run at one speed (as the paper's "
    "Table 7, 0.68 m/s) while each passive run went at its own speed, every reduction carries the soil's speed "
    "dependence: a configuration run slower than the rigid reference shows a reduction that is partly the speed's, "
    "a faster one an increase.",
    genes=(Gene("rigid_speed", 0.4, 0.8, unit="m/s"),),
    knobs=lambda p: {"rigid_speed": p["rigid_speed"]},
    rigs=(SOIL_BIN.name,), varies=("speed",),
    signature="reduction residuals falling with the configuration's speed, zero at the reference's speed"))
register(Mechanism(
    "progressive_stack", "Progressive stacks, each by its own rate",
    "A stack of n disc units in series deflects each disc by u / n, so a hardening of the discs gives every stack "
    "the same law in u / s (s its service travel, 0.75 h0 per unit): F = k u (1 + beta (u / s)^2), k3 = beta k / s^2 "
    "per configuration. DIN 2093 holds the load at s within +25 % of k s, so beta <= 0.25.",
    genes=(Gene("hardening", 1e-3, 3.0, log=True, unit="-"),),
    knobs=lambda p: {"progressive_factor": p["hardening"]},
    signature="frequencies falling along a decay in proportion to (swing / travel)^2; under one load a uniform "
              "stiffening (the stacks' deflection per travel is the same)",
    bounds=_stack_hardening_bound, produces=("stiffness_high", "inertia_low")))
register(Mechanism(
    "lever_geometry", "The stacks' load line off the sensor's lever",
    "A stack pushes on the shank through a seat whose contact can sit anywhere within the discs' outer radius: at "
    "lambda times the stated lever a its moment about the pivot is k lambda^2 a^2 theta, so every configuration "
    "turns by 1 / lambda^2 of what the stated geometry gives under the same load, while the sensor still reads "
    "the rotation at a.",
    genes=(Gene("spring_lever", 0.7, 1.3, unit="-"),),
    knobs=lambda p: {"spring_lever": p["spring_lever"]},
    rigs=(SOIL_BIN.name,),
    signature="every configuration's deflection scaled by one factor 1 / lambda^2 (its vibration with it)",
    bounds=_lever_bound, produces=("stiffness_high", "stiffness_low")))
register(Mechanism(
    "sensor_lever", "The sensor's lever",
    "The displacement sensor reads the tool's rotation at its own contact point: mounted at lambda times the stated "
    "lever, every reading (mean, vibration, trend) is lambda times the stated geometry's, and the draught and its "
    "reductions do not change.",
    genes=(Gene("sensor_lever", 0.7, 1.3, unit="-"),),
    knobs=lambda p: {"sensor_lever": p["sensor_lever"]},
    rigs=(SOIL_BIN.name,),
    signature="every displacement scaled by one factor, the reductions unchanged",
    bounds=_sensor_lever_bound))
register(Mechanism(
    "soil_tool_friction", "Soil-steel friction of its own",
    "A contact takes the smaller of its two materials' friction angles (Yade's default), so a soil calibrated to a "
    "few degrees of contact friction (the paper's assembly C sets: 5.1-7.5 deg) also slides on the steel sweep at "
    "that angle, far below what sand shows on steel. Friction on the blade is part of the draught and of the moment "
    "that deflects the passive tool.",
    genes=(Gene("tool_friction", 2.0, 45.0, unit="deg"),),
    knobs=lambda p: {"tool_friction": p["tool_friction"]},
    rigs=(SOIL_BIN.name,),
    signature="the draught and the deflection up together, rigid and passive alike",
    bounds=_tool_friction_bound))


def _tool_adhesion_bound(f: RigFacts) -> dict[str, Bound]:
    if not (math.isfinite(f.soil_cohesion) and f.soil_cohesion > 0):
        return {}
    return {"tool_adhesion": Bound(0.0, f.soil_cohesion, f"soil on steel adheres at most as the soil holds to itself: "
                                   f"up to the soil's own contact cohesion ({f.soil_cohesion:g} Pa); no interface "
                                   "is stronger than the soil")}


register(Mechanism(
    "soil_tool_adhesion", "Soil adhering to the steel",
    "Moist soil sticks to steel: a new soil-steel contact holds in tension and shear up to an adhesion before it "
    "lets go or slides, so soil rides on the blade and the shank and drags along them, adding to the draught and to "
    "the moment that deflects the passive tool. The bonds break as the soil flows past and form again on new "
    "contacts (a contact's friction angle is a separate mechanism, soil_tool_friction).",
    genes=(Gene("tool_adhesion", 10.0, 1e6, log=True, unit="Pa"),),
    knobs=lambda p: {"tool_adhesion": p["tool_adhesion"]},
    rigs=(SOIL_BIN.name,),
    signature="the draught and the deflection up together, rigid and passive alike",
    bounds=_tool_adhesion_bound))
BOND_STRENGTH_TOLERANCE = 0.25
"""how far [-, relative] the soil's contact cohesion may sit from its calibrated value: the shear box's tolerance on
c (25 %), taken onto the contact cohesion (an assumption: in the bonded soil's box c grows about in proportion with
it, 5.2 to 15.7 kPa for 3x to 10x set 11's, docs/runs/bond_protocols_h100)."""


def _bond_strength_bound(f: RigFacts) -> dict[str, Bound]:
    return {"soil_cohesion_scale": Bound(1 - BOND_STRENGTH_TOLERANCE, 1 + BOND_STRENGTH_TOLERANCE,
                                         "the soil's bonds as calibrated within the shear box's tolerance on c "
                                         "(calibration.mechanisms.BOND_STRENGTH_TOLERANCE, an assumption)")}


register(Mechanism(
    "soil_bond_strength", "The soil's bonds stronger or weaker than calibrated",
    "How many of the soil's bonds survive the bed's own weight and reach the tool depends on how and when they were "
    "made (the bond protocol: on a settled bed or not, yielding or fragile) and on their strength against the "
    "contact forces: bonds stronger than calibrated survive where weaker ones break, and the soil in front of the "
    "blade fails as a stronger or a weaker block. Both rigid and passive runs change.",
    genes=(Gene("soil_cohesion_scale", 0.1, 10.0, log=True, unit="-"),),
    knobs=lambda p: {"soil_cohesion_scale": p["soil_cohesion_scale"]},
    rigs=(SOIL_BIN.name,),
    signature="the draught up or down, rigid and passive alike; the bonds surviving to the tool with it",
    bounds=_bond_strength_bound))
register(Mechanism(
    "bed_density", "A denser or looser bed",
    "How densely the bin's soil is packed sets each particle's contacts, how far the soil must dilate to shear and "
    "how much of it the blade lifts: a denser bed draws more and fails in larger blocks, a looser one less. The "
    "simulation's bed density is its deposition's (a protocol, not a soil property): deposited with a lower "
    "contact friction the bed packs denser (paper scale: porosity 0.327 at 0 deg, 0.456 at the default 30 deg). "
    "The laboratory's bed density is not given, so the range is the one this deposition makes, not a measured "
    "bound. Rigid and passive runs change alike (each on its own bed).",
    genes=(Gene("deposit_friction", 0.0, 30.0, unit="deg"),),
    knobs=lambda p: {"deposit_friction": p["deposit_friction"]},
    rigs=(SOIL_BIN.name,),
    signature="the draught up with the density, rigid and passive alike; the deflection with the draught"))
register(Mechanism(
    "bond_settling", "Bonds made on a bed at rest, or not",
    "The soil's bonds are set on the contacts the bed has when they are made: on a freshly deposited bed that was "
    "never at rest they carry its settling and break under its own weight before the tool arrives (the strip twin: "
    "36,901 bonds down to 320 in Yade and warpdem alike); on a bed that has settled first they hold and reach the "
    "tool. How long the laboratory's soil rested between preparation and the pass is not given: the range is the "
    "protocol's (0: bonds at once; the bonded soil settles 1 s), not a measured bound. Rigid and passive runs "
    "change alike.",
    genes=(Gene("settle_time", 0.0, 2.0, unit="s"),),
    knobs=lambda p: {"settle_time": p["settle_time"]},
    rigs=(SOIL_BIN.name,),
    signature="the draught up with the bonds that survive to the tool, rigid and passive alike"))
_BOND_RULE = (
    "Yade's cohesive-frictional law either breaks a bond for good once its normal or shear force reaches its "
    "strength (fragile, Yade's default) or lets it yield: a sheared bond slides at its strength and keeps its "
    "cohesion, a tensile one is deleted at its first yield (Yade's unpMax = 0, warpdem's default). Which the paper "
    "used is not given (its CohFrictMat settings are not listed). Yielding bonds survive the bed's settling and the "
    "blade's first touch, so the soil ahead of the tool holds together longer; fragile ones leave a frictional soil. "
    "A choice, not a range: no gene. Rigid and passive runs change alike.")
register(Mechanism(
    "yielding_bonds", "The soil's bonds yield instead of breaking",
    _BOND_RULE, genes=(), knobs=lambda p: {"fragile": 0.0}, rigs=(SOIL_BIN.name,),
    signature="the draught up with the bonds that hold, rigid and passive alike",
    applies=lambda f: f.soil_fragile is True))
register(Mechanism(
    "fragile_bonds", "The soil's bonds break for good at their strength",
    _BOND_RULE, genes=(), knobs=lambda p: {"fragile": 1.0}, rigs=(SOIL_BIN.name,),
    signature="the draught down with the bonds lost, rigid and passive alike",
    applies=lambda f: f.soil_fragile is False))
register(Mechanism(
    "mount_pitch", "The sweep clamped at another attitude",
    "The passive sweep is clamped to its hinge: turned back (or forward) on the clamp against the drawing, its blade "
    "works at another attack angle and its weight hangs at another lever, while the stack's seat and the sensor's "
    "target on the clamp stay where the drawing has them. The passive runs' draught and deflection change; the "
    "rigid runs, whose tool is bolted to the carriage, do not.",
    genes=(Gene("mount_pitch", -6.0, 6.0, unit="deg"),),
    knobs=lambda p: {"mount_pitch": p["mount_pitch"]},
    rigs=(SOIL_BIN.name,),
    signature="reductions and deflections shifted together in every configuration, the rigid draught unchanged",
    bounds=_mount_pitch_bound))
