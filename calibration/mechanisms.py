"""Candidate mechanisms for model criticism: named physical extensions of a DEM rig.

A mechanism is not a correction of outputs: it names physics the baseline rig lacks, brings its own parameters
(genes: ranges and scales) and says how it changes the rig through *knobs*, named physical settings that a rig model
(``calibration.rig_models``) implements in the DEM scene: a torque in the hinge integrator, a spring law, a body's
mass, the spring's preload, the sensor's reading. A rig supports a set of knobs; a mechanism applies to a rig when
the rig supports all of its knobs.

Built-in mechanisms (rationale in each entry): ``pivot_friction``, ``progressive_spring``, ``series_compliance``,
``extra_mass``, ``load_inertia``, ``pose_change``, ``sensor_offset``, ``sensor_drift``, ``stack_preload``,
``speed_dependence``, ``rigid_reference_speed``.
Register your own::

    from calibration.mechanisms import Mechanism, register
    from calibration.genes import Gene
    register(Mechanism("stiff_pivot", "Pivot bushing compliance", "rubber bushing ...",
                       genes=(Gene("bushing_friction", 0.01, 1.0, log=True, unit="N m"),),
                       knobs=lambda p: {"pivot_friction": p["bushing_friction"]}))
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from .genes import Gene


@dataclass(frozen=True)
class Mechanism:
    """A named physical extension of a rig.

    name: identifier (``[a-z_]+``); title: a short human name; rationale: why it could be there, physically;
    genes: its parameters (SI, with ranges the fit searches); knobs: parameter values -> the rig knobs to set
    (knob name -> value in SI); rigs: the rigs it is meant for (documentation; applicability is decided by the
    knobs a rig supports); needs_series: it only shows in time series (skipped on summary-only data).
    """

    name: str
    title: str
    rationale: str
    genes: tuple[Gene, ...]
    knobs: Callable[[dict[str, float]], dict[str, float]]
    rigs: tuple[str, ...] = ("ringing", "soil-bin")
    needs_series: bool = False
    signature: str = ""
    """what it does to the observables, for the report."""
    extra: dict[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.name.replace("_", "").isalnum() or not self.name.islower():
            raise ValueError(f"mechanism name must be lower_case, got {self.name!r}")
        names = [g.name for g in self.genes]
        if len(set(names)) != len(names):
            raise ValueError(f"mechanism {self.name!r}: gene names repeat: {names}")

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


register(Mechanism(
    "pivot_friction", "Dry friction at the pivot",
    "The shank turns about a pin in a bore; a dry (Coulomb) friction torque there takes a fixed amount of "
    "amplitude per cycle instead of a fixed fraction, so the decay is linear, damping grows as the amplitude falls "
    "and the tool can stop short of its equilibrium.",
    genes=(Gene("pivot_friction", 1e-3, 3.0, log=True, unit="N m"),),
    knobs=lambda p: {"pivot_friction": p["pivot_friction"]},
    signature="damping that rises late in a decay and for small swings; equal for all stiffnesses"))
register(Mechanism(
    "progressive_spring", "Progressive spring stack",
    "Stacked disc springs (DIN 2093) stiffen with deflection when discs go flat or touch the guide; F = k u + "
    "k3 u^3 about the free length makes the tangent stiffness grow with the static deflection, most for the "
    "softest stacks, and the frequency grow with amplitude.",
    genes=(Gene("progressive", 1e4, 1e14, log=True, unit="N/m^3"),),
    knobs=lambda p: {"progressive": p["progressive"]},
    signature="soft configurations stiffer than their nominal rate; frequency falling along a decay"))
register(Mechanism(
    "series_compliance", "Compliance in series with the springs",
    "Shank, clamps and frame are not rigid: a stiffness ks in series gives the stack k ks/(k+ks), which lowers the "
    "stiff configurations most and compresses the range of frequencies a spring count can give.",
    genes=(Gene("series_stiffness", 1e3, 1e8, log=True, unit="N/m"),),
    knobs=lambda p: {"series_stiffness": p["series_stiffness"]},
    signature="stiff configurations softer than nominal; frequency ratio below sqrt of the stiffness ratio"))
register(Mechanism(
    "extra_mass", "Extra mass on the tool",
    "Preload hardware, clamps and the sensor's moving parts ride with the tool: more mass and inertia about the "
    "pivot lower every frequency by the same factor and the damping ratio of a given dashpot with it.",
    genes=(Gene("extra_mass", 0.0, 30.0, unit="kg"),),
    knobs=lambda p: {"extra_mass": p["extra_mass"]},
    signature="all frequencies lower by one factor"))
register(Mechanism(
    "load_inertia", "Load force without its mass",
    "A ringing test's load may be applied by a cable, a lever or a spring balance rather than a dead weight: the "
    "force and its moment stay, but only part of the load's mass swings with the tool, so every frequency rises "
    "by one factor (less so for the stiff configurations, whose own inertia weighs more) and a given dashpot's "
    "damping ratio rises.",
    genes=(Gene("load_mass_fraction", 0.02, 1.0, unit="-"),),
    knobs=lambda p: {"load_mass_fraction": p["load_mass_fraction"]},
    rigs=("ringing",),
    signature="all frequencies higher by about one factor"))
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
    rigs=("soil-bin",),
    signature="mean displacements shifted by one constant"))
register(Mechanism(
    "sensor_drift", "Sensor drift",
    "Strain gauges and displacement sensors drift with temperature and creep: a slope in time under the signal, "
    "which biases a decay's fitted damping and a run's mean.",
    genes=(Gene("sensor_drift", -5e-3, 5e-3, unit="m/s"),),
    knobs=lambda p: {"sensor_drift": p["sensor_drift"]},
    rigs=("soil-bin",),
    needs_series=True,
    signature="a trend in time under the signal"))
register(Mechanism(
    "stack_preload", "Preloaded spring stack on a stop",
    "A plate-spring stack is assembled compressed between its seats: the tool rests on a stop at its drawing pose "
    "until the load exceeds the preload, then deflects by the excess only. The stiff configurations barely leave "
    "the stop (and barely vibrate); every soft one reads its deflection less the preload's compression.",
    genes=(Gene("stack_preload", 0.0, 5e-3, unit="m"),),
    knobs=lambda p: {"stack_preload": p["stack_preload"]},
    rigs=("soil-bin",),
    signature="mean displacements low by a constant, the stiffest configurations at zero"))
register(Mechanism(
    "speed_dependence", "Speed-dependent soil resistance",
    "Soil resistance grows with the tool's speed (rate-dependent strength, soil acceleration): a resistance "
    "b v on the tool adds draught in proportion to the speed of each run.",
    genes=(Gene("soil_viscosity", 1.0, 1e3, log=True, unit="N s/m"),),
    knobs=lambda p: {"soil_viscosity": p["soil_viscosity"]},
    rigs=("soil-bin",),
    signature="draught residuals growing with the speed of the run"))
register(Mechanism(
    "rigid_reference_speed", "Rigid reference at another speed",
    "A reduction compares a passive run with a rigid run. Taken against one rigid run at one speed (as the paper's "
    "Table 7, 0.68 m/s) while each passive run went at its own speed, every reduction carries the soil's speed "
    "dependence: a configuration run slower than the rigid reference shows a reduction that is partly the speed's, "
    "a faster one an increase.",
    genes=(Gene("rigid_speed", 0.4, 0.8, unit="m/s"),),
    knobs=lambda p: {"rigid_speed": p["rigid_speed"]},
    rigs=("soil-bin",),
    signature="reduction residuals falling with the configuration's speed, zero at the reference's speed"))
