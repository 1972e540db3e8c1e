"""Rig models for model criticism: a measured data set, the DEM rig that simulates each of its configurations, and
the observables extracted the same way from both.

A rig model (see :class:`RingingRigModel`) states

- ``configs``: one dict per measured configuration (spring count, nominal stiffness, ...);
- ``observables``, their ``units`` and ``measured`` (n_configs, n_observables): what is compared, in SI units
  (a draught reduction in %);
- ``sigma`` (n_configs, n_observables): the 1-sigma uncertainty of every measured value, from a stated relative or
  absolute uncertainty per observable (``describe_uncertainty``), which weights the residuals and decides whether a
  residual is larger than noise;
- ``genes``: the baseline's own parameters, fitted with every candidate (``fixed`` holds those given instead);
- ``knobs``: the physical extensions its DEM scene implements (see ``calibration.mechanisms``);
- ``simulate(cases)``: DEM results for (configuration, parameters) pairs, all as the worlds of batched simulations;
- ``covariates()``: per-configuration quantities a residual may depend on;
- optionally ``settings()`` (what the simulations depend on besides the cases), ``state()`` and ``restore(state)``
  (results a resumed diagnosis must reuse), for checkpoints.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from scenes import analysis, rigs
from warpdem.errors import InputError

from .genes import Gene
from .measured import Measured


@dataclass
class Case:
    """One simulation request: configuration index and parameter values (baseline genes and knobs, SI)."""

    config: int
    params: dict[str, float]


@dataclass
class SimOutput:
    values: np.ndarray
    """observables per case (n_cases, n_observables), NaN where the extraction failed."""
    covariates: dict[str, np.ndarray] = field(default_factory=dict)
    """simulated covariates per case, e.g. the static deflection [m] (n_cases,)."""
    series: list[tuple[np.ndarray, np.ndarray]] | None = None
    """(time [s], signal [m]) per case, when asked for."""
    failed: list[str] | None = None
    """per case, why the extraction failed ("" where it did not), when the rig says."""


KNOB_OFF = {"series_stiffness": math.inf, "load_mass_fraction": 1.0, "soil_cohesion_scale": 1.0}
"""the value of a knob that leaves a rig as it is, where it is not 0 (a case without the knob gets it)."""
READING_KNOBS = ("sensor_offset", "sensor_drift", "sensor_lever", "rigid_speed")
"""the soil-bin knobs that change how a run is read or compared, not the simulation."""
CONFIG_KNOBS = ("deposit_friction", "settle_time", "fragile")
"""the soil-bin knobs that are fields of the run's ``scenes.soil_bin.SoilBinConfig``, one value for all the worlds
of a simulation, so the rig model runs each value's worlds apart: deposit_friction [deg] (the bed deposited again
with this contact friction, denser or looser, and the runs on that bed), settle_time [s] (the bed settled this
long before the bonds are set on its contacts and the tool moves: bonds made on a bed at rest or not) and fragile
[-] (1: the soil's bonds break for good at their strength; 0: they yield and hold, Yade's ``fragile=False``)."""
RIGID_SWEEP = (0.45, 0.55, 0.65, 0.75)
"""carriage speeds [m/s] of the rigid runs through which the soil-bin rig model fits the rigid draught's line against
speed (for the rigid_speed knob), besides the measured speeds."""


def _shared_knobs(params: dict[str, float]) -> dict[str, float]:
    """The knobs of ``scenes.soil_bin.SOIL_KNOBS`` and :data:`CONFIG_KNOBS` among a case's parameters (the rigid
    runs take them too)."""
    from scenes.soil_bin import SOIL_KNOBS

    return {k: float(params[k]) for k in SOIL_KNOBS + CONFIG_KNOBS if k in params}


RINGING_UNCERTAINTY = {"frequency": 0.01, "damping": 0.10, "frequency_late": 0.02, "damping_late": 0.20,
                       "damping_exponent": 0.15, "frequency_exponent": 0.01}
"""default 1-sigma uncertainties of the ringing observables. Relative: a strain-gauge or displacement record at
2400 Hz gives the frequency of a 2-10 Hz decay to well below 1 %, but the spring stacks of one nominal rate scatter
by a few % (stiffness, hence ~1 % in frequency); log decrements from a few cycles of a hand-hammered decay repeat to
about 10 % (20 % from the second half of a decay alone). Absolute, for the within-record signatures (their values
sit near 0): ``damping_exponent`` 0.15 and ``frequency_exponent`` 0.01, floors under each record's own standard
error of the fit (:func:`decay_signatures`), which is added in quadrature."""
RINGING_ABSOLUTE = frozenset({"damping_exponent", "frequency_exponent"})
"""ringing observables whose stated uncertainty is absolute."""
FAILED_DAMPING = 0.5
"""a simulated record with fewer than two peaks of a free vibration (stuck or overdamped) has a damping ratio of at
least about this: its damping residual is scored against it (one-sided), its other observables count as unknown."""


def envelope_fit(times: np.ndarray, amps: np.ndarray) -> tuple[float, float, float, float]:
    """The decay law of successive peak amplitudes: dA/dt = -lam A0^-p A^(1+p), i.e.
    A(t) = A0 (1 + p lam t)^(-1/p) (p = -1: linear decay, dry friction; 0: exponential, viscous; +1: 1/t,
    quadratic drag). Least squares on ln A. Returns (p, standard error of p, lam [1/s], A0)."""
    from scipy.optimize import least_squares

    t = np.asarray(times, float) - float(times[0])
    la = np.log(np.asarray(amps, float))

    def g(x: np.ndarray) -> np.ndarray:  # log1p(x) / x, 1 at x = 0
        small = np.abs(x) < 1e-8
        return np.where(small, 1.0 - 0.5 * x, np.log1p(np.where(small, 0.0, np.maximum(x, -1 + 1e-12)))
                        / np.where(small, 1.0, x))

    def res(q: np.ndarray) -> np.ndarray:
        ln_a0, ln_lam, p = q
        x = p * np.exp(ln_lam) * t
        return ln_a0 - np.exp(ln_lam) * t * g(x) - la

    lam0 = max((la[0] - la[-1]) / max(t[-1], 1e-9), 1e-6)
    best = None
    for p0 in (-0.8, 0.0, 0.8):
        try:
            r = least_squares(res, [la[0], math.log(lam0), p0], bounds=([-np.inf, -20, -3], [np.inf, 10, 3]))
        except ValueError:
            continue
        if best is None or r.cost < best.cost:
            best = r
    if best is None or t.size < 4:
        return math.nan, math.nan, math.nan, math.nan
    dof = t.size - 3
    s2 = 2 * best.cost / dof
    try:
        cov = np.linalg.inv(best.jac.T @ best.jac) * s2
        se = float(math.sqrt(max(cov[2, 2], 0.0)))
    except np.linalg.LinAlgError:
        se = math.inf
    return float(best.x[2]), se, float(math.exp(best.x[1])), float(math.exp(best.x[0]))


def decay_signatures(fit: object) -> dict[str, float]:
    """Within-record signatures of a decay from its successive maxima (a ``scenes.analysis.RingDown``):

    - ``damping_exponent`` p of the envelope law (:func:`envelope_fit`): how the damping per cycle changes with
      amplitude, d ln(decrement) / d ln(amplitude): -1 dry friction, 0 viscous, +1 quadratic drag;
    - ``frequency_exponent``: d ln(f) / d ln(amplitude) within the decay, from the periods between successive
      maxima against their mean amplitude (> 0: a hardening spring; 0: linear);

    each with its standard error (``*_se``). NaN with fewer than 4 maxima."""
    out = {"damping_exponent": math.nan, "damping_exponent_se": math.nan, "frequency_exponent": math.nan,
           "frequency_exponent_se": math.nan}
    t, a = np.asarray(fit.peak_times, float), np.asarray(fit.peak_amplitudes, float)
    ok = a > 0
    t, a = t[ok], a[ok]
    if t.size < 4:
        return out
    p, se, _, _ = envelope_fit(t, a)
    out["damping_exponent"], out["damping_exponent_se"] = p, se
    period, amp = np.diff(t), np.sqrt(a[:-1] * a[1:])
    x, y = np.log(amp), np.log(period)
    if np.ptp(x) > 0:
        res = stats.linregress(x, y)
        out["frequency_exponent"] = float(-res.slope)
        out["frequency_exponent_se"] = float(res.stderr) if x.size > 2 else math.inf
    return out


def first_swing(t: np.ndarray, x: np.ndarray, fit: object) -> float:
    """The first swing of a decay about its offset [units of x], signed: the largest deviation in the period before
    the first maximum the fit used (a minimum before it is the first swing when the hit went the other way)."""
    t0 = float(fit.peak_times[0])
    sel = (t >= t0 - fit.period_s) & (t <= t0 + 1e-9)
    d = np.asarray(x, float)[sel] - fit.offset
    return float(d[np.argmax(np.abs(d))])


def hit_velocity(amplitude: float, frequency: float, damping: float) -> float:
    """The initial velocity [units of x / s] that gives a linear oscillator at rest its first swing ``amplitude``:
    x = v0 / w_d e^(-zeta w_n t) sin(w_d t) peaks at w_d t1 = atan(sqrt(1 - zeta^2) / zeta)."""
    z = min(max(damping, 0.0), 0.95) if math.isfinite(damping) else 0.0
    wn = 2 * math.pi * frequency / math.sqrt(1 - z * z)
    if z == 0:
        return amplitude * wn
    s = math.sqrt(1 - z * z)
    return amplitude * wn * math.exp(z / s * math.atan2(s, z))


def ringdown_observables(t: np.ndarray, x: np.ndarray, late: bool) -> dict[str, float]:
    """Frequency [Hz] and damping ratio of a decay by eqs. (3)-(5) (``scenes.analysis.ringdown``); with ``late``,
    also of its second half (from a quarter period before its middle peak on): the amplitude dependence that
    separates viscous damping (constant) from dry friction (rising) and a progressive spring (frequency falling),
    the signatures of :func:`decay_signatures` and ``first_swing`` (signed, :func:`first_swing`).
    NaN where a fit fails (an overdamped or stuck decay), with the reason in ``failed`` (else "")."""
    out: dict[str, object] = {"frequency": math.nan, "damping": math.nan, "failed": ""}
    if late:
        out.update(frequency_late=math.nan, damping_late=math.nan, first_swing=math.nan,
                   **{k: math.nan for k in ("damping_exponent", "damping_exponent_se", "frequency_exponent",
                                            "frequency_exponent_se")})
    try:
        fit = analysis.ringdown(t, x)
    except ValueError as e:
        out["failed"] = str(e).split("\n")[0]
        return out
    out["frequency"], out["damping"] = fit.frequency_hz, fit.damping_ratio
    if late:
        out.update(decay_signatures(fit))
        out["first_swing"] = first_swing(t, x, fit)
        if fit.peak_times.size >= 5:
            start = fit.peak_times[fit.peak_times.size // 2] - 0.25 * fit.period_s
            sel = t >= start
            try:
                f2 = analysis.ringdown(t[sel], x[sel], offset=fit.offset)
                out["frequency_late"], out["damping_late"] = f2.frequency_hz, f2.damping_ratio
            except ValueError:
                pass
    return out


def _stated(defaults: dict[str, float], given: dict[str, float] | None) -> dict[str, float]:
    """The defaults with the user's values, each checked by name and sign."""
    out = dict(defaults)
    for k, v in (given or {}).items():
        if k not in out:
            raise InputError(f"uncertainty: unknown observable {k!r}; known {sorted(out)}")
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise InputError(f"uncertainty {k!r} must be a finite positive number, got {v!r}")
        out[k] = float(v)
    return out


BASELINE_GENES = {
    "dashpot": Gene("dashpot", 10.0, 3e4, log=True, unit="N s/m"),
    "inertia_factor": Gene("inertia_factor", 0.1, 10.0, log=True, unit="-"),
    "stiffness_scale": Gene("stiffness_scale", 0.25, 4.0, log=True, unit="-"),
}
"""the ringing baseline's first-order unknowns (fitted when the rig description marks them uncertain): the dashpot
along the springs at the spring lever (one for all configurations), a factor on the rig's inertia about the pivot,
a factor on every spring rate."""
UNCERTAIN_GENE = {"damping": "dashpot", "inertia": "inertia_factor", "stiffness": "stiffness_scale"}
DAMPING_SCALE = Gene("damping_scale", 0.2, 5.0, log=True, unit="-")
"""with ``damping = "per_configuration"`` the baseline's damping gene: one factor on every configuration's own damping
ratio (its dashpot set from the ratio by the linear oscillator's closed form), so a mechanism that damps can take
its share. Each configuration's ratio is an input then (its record's, unless the description states it): its held-out
``damping`` is not a prediction; ``damping_late`` and the decay's signatures still are."""


def lever_scaling(ratio: float) -> dict[str, float]:
    """What a stack bearing on the shank at ``ratio`` times the sensor's lever a is, for a spring at a (the DEM's):
    the factor on each of its settings that gives the same moment about the pivot at every rotation theta. Closed
    form: the stack compresses u = ratio a theta and pushes back at ratio a, so a rate k gives k ratio^2 a^2 theta
    (factor ratio^2), a dashpot c ratio^2, a cubic term k3 u^3 gives k3 ratio^4 a^4 theta^3 (ratio^4), and a preload
    p (the stack's compression at the stop) the threshold moment k p ratio a (k ratio^2 times p / ratio)."""
    if not (math.isfinite(ratio) and ratio > 0):
        raise InputError(f"spring_lever must be a positive ratio, got {ratio}")
    return {"stiffness": ratio**2, "dashpot": ratio**2, "progressive": ratio**4, "stack_preload": 1.0 / ratio}


def build_tool_mass() -> float:
    """The sweep's mass [kg] (``scenes.sweep``)."""
    from scenes.sweep import build_sweep

    return float(build_sweep().mass)


class RingingRigModel:
    """The ringing rig (``scenes.ringing``, linear spring model) against measured ringing data.

    Configurations come from the summary's rows (``springs``, optional ``stiffness`` [N/m]: default the
    description's rate or DIN 2093 of Table 2) or, without a summary, from the series' headers. With a
    displacement or force series for every configuration, the observables are extracted from the series
    (frequency, damping, both over the second half of the decay, and the within-record signatures
    ``damping_exponent`` and ``frequency_exponent``, :func:`decay_signatures`), and each configuration is simulated
    at its record's first swing (amplitude and sign; ``description.hit``); otherwise they are the summary's
    ``frequency`` and ``damping``.

    ``description`` (:mod:`calibration.rig_description`; default: the paper's rig) says what the rig is; warpdem's
    rig is set up to behave like it (:func:`calibration.rig_description.equivalent`) and its readings are given in
    the description's units (spring rates and dashpot at the spring lever, the sensor's displacement). Baseline
    genes: those of :data:`BASELINE_GENES` that the description marks uncertain (``dashpot`` unless ``fixed``).
    Knobs: pivot_friction [N m], extra_mass [kg], progressive [N/m^3], series_stiffness [N/m], free_pose (0/1),
    load_mass_fraction [-], sensor_offset [m], sensor_drift [m/s] (on the displacement record); progressive and
    series_stiffness act at the spring lever, like the rates.
    """

    rig = rigs.RINGING.name
    uncertainty_defaults = RINGING_UNCERTAINTY
    units = {"frequency": "Hz", "damping": "-", "frequency_late": "Hz", "damping_late": "-", "damping_exponent": "-",
             "frequency_exponent": "-"}

    def __init__(self, measured: Measured, *, device: str | None = None, fixed: dict[str, float] | None = None,
                 ring_time: float | None = None, settle_time: float = 0.25, hit_amplitude: float = 0.5,
                 load_force: float | None = None, uncertainty: dict[str, float] | None = None,
                 max_worlds: int = 2000, description: object | None = None) -> None:
        from scenes import paper

        from . import rig_description as rd

        self.device = device
        self.fixed = dict(fixed or {})
        unknown = set(self.fixed) - {"dashpot"}
        if unknown:
            raise InputError(f"fixed: unknown baseline parameters {sorted(unknown)}; the ringing rig has 'dashpot'")
        if description is None:
            description = rd.RingingRigDescription(load_force=float(load_force or paper.LOAD_FORCE))
        elif load_force is not None:
            raise InputError("give load_force in the rig description, not beside it")
        self.description = description
        self.reference = rd.paper_rig()
        self.settle_time, self.hit_amplitude = float(settle_time), float(hit_amplitude)
        self.load_force = float(description.load_force)
        self.max_worlds = int(max_worlds)
        s = measured.summary
        if "springs" in s:
            springs = [int(n) for n in s["springs"]]
        else:
            springs = sorted({int(x.config["springs"]) for x in measured.series})
        if not springs:
            raise InputError("measured data name no configuration (no 'springs' column and no series)")
        if len(set(springs)) != len(springs):
            raise InputError(f"{measured.source}: one row per spring configuration, got springs {springs}")
        for n in springs:
            if n not in paper.SPRING_COUNTS:
                raise InputError(f"springs must be among {paper.SPRING_COUNTS}, got {n}")
        rates = description.spring_rates
        default = [rates.get(n, paper.ringing_row(n)["stiffness_n_per_m"]) for n in springs]
        stiffness = s.get("stiffness", np.array(default, dtype=float))
        self.configs = [{"springs": n, "stiffness": float(k)} for n, k in zip(springs, stiffness, strict=True)]
        series = {int(x.config["springs"]): x for x in measured.series}
        self.has_series = bool(series) and all(n in series for n in springs)
        unc = _stated(RINGING_UNCERTAINTY, uncertainty)
        self.measured_failures: list[str] = []
        self.swing = np.full(len(springs), np.nan)
        if self.has_series:
            self.observables = ("frequency", "damping", "frequency_late", "damping_late", "damping_exponent",
                                "frequency_exponent")
            rows, se = [], []
            for j, n in enumerate(springs):
                x = series[n]
                obs = ringdown_observables(x.time, x.values, True)
                if obs["failed"]:
                    self.measured_failures.append(f"{n} springs: {obs['failed']}")
                rows.append([obs[k] for k in self.observables])
                se.append([obs.get(k + "_se", 0.0) for k in self.observables])
                self.swing[j] = obs["first_swing"]
            self.measured = np.array(rows, dtype=float)
            self.measured_se = np.nan_to_num(np.array(se, dtype=float), nan=0.0, posinf=0.0)
            self.measured_series = [(series[n].time, series[n].values) for n in springs]
            duration = max(float(series[n].time[-1] - series[n].time[0]) for n in springs)
            self.ring_time = float(ring_time or duration)
            self.sample_rate = float(np.median([series[n].sample_rate for n in springs]))
        else:
            missing = [k for k in ("frequency", "damping") if k not in s]
            if missing:
                raise InputError(f"measured ringing data need series or summary columns {missing}")
            self.observables = ("frequency", "damping")
            self.measured = np.column_stack([s["frequency"], s["damping"]])
            self.measured_se = np.zeros_like(self.measured)
            self.measured_series = None
            self.ring_time = float(ring_time or 2.0)
            self.sample_rate = paper.SAMPLE_RATE
        self.uncertainty = {k: unc[k] for k in self.observables}
        """1-sigma uncertainty per observable: relative, absolute for RINGING_ABSOLUTE."""
        stated = np.array([[unc[k] if k in RINGING_ABSOLUTE else abs(m) * unc[k]
                            for k, m in zip(self.observables, row, strict=True)] for row in self.measured])
        self.sigma = np.sqrt(stated**2 + self.measured_se**2)
        wanted = [UNCERTAIN_GENE[u] for u in rd.UNCERTAIN if u in description.uncertain or u == "damping"]
        genes = dict(BASELINE_GENES)
        if description.tool_inertia or description.spring_lever or description.spring_rates:
            genes["dashpot"] = self._dashpot_gene()
        self.damping_ratio: np.ndarray | None = None
        if description.damping == "per_configuration":
            if "dashpot" in self.fixed:
                raise InputError("fixed: dashpot and a rig description with damping = \"per_configuration\" "
                                 "exclude each other")
            self.damping_ratio = self._damping_ratios()
            genes["dashpot"] = DAMPING_SCALE
        self.datum_scale: float | None = None
        """the rate factor the description's static deflection fixes (None: no datum)."""
        if description.static_deflection is not None:
            self.datum_scale = self._datum_scale()
            wanted = [g for g in wanted if g != "stiffness_scale"]
        self.genes = tuple(genes[g] for g in wanted if g not in self.fixed)
        # with the inertia fitted, the knobs that only change the inertia (extra_mass, load_mass_fraction: the
        # mechanisms extra_mass and load_inertia) would duplicate a baseline gene: the rig does not offer them
        self.knobs = frozenset({"pivot_friction", "progressive", "series_stiffness", "free_pose", "sensor_offset",
                                "sensor_drift"}
                               | ({"extra_mass"} if "inertia" not in description.uncertain else set())
                               | ({"load_mass_fraction"} if description.load_mass_rides
                                  and "inertia" not in description.uncertain else set()))
        if not all(math.isnan(t) for t in self._travel()):
            self.knobs = self.knobs | {"progressive_factor"}
        self.hit = self._hits()
        self._geometry: dict[str, float] | None = None

    def _statics(self) -> dict[str, float]:
        """The described rig's small-swing numbers (module ``calibration.rig_description``): spring lever a,
        sensor lever s [m], the load's moment F l [N m] and the gravity stiffness K_g = F d + m g z_c [N m/rad]
        (without ``tool_mass``: the sweep's, scaled with the stated inertia)."""
        d, ref = self.description, self.reference
        a = d.spring_lever or ref.lever
        arm = d.load_arm if d.load_arm is not None else ref.load_arm
        depth = d.load_depth if d.load_depth is not None else ref.load_depth
        scale = (d.tool_inertia / ref.tool_inertia) if d.tool_inertia else 1.0
        if d.tool_mass is not None:
            k_tool, m_tool = d.tool_mass * 9.81 * d.tool_com[1], d.tool_mass * 9.81 * d.tool_com[0]
        else:
            k_tool, m_tool = scale * ref.tool_gravity_stiffness, scale * ref.tool_moment
        return {"a": a, "s": d.sensor_lever or a, "load_moment": d.load_force * arm,
                "k_grav": d.load_force * depth + k_tool, "moment": d.load_force * arm + m_tool}

    def _datum_scale(self) -> float:
        """The rate factor that the static deflection fixes, from the linear statics of the described rig: the
        load's moment F l turns the rig by theta = F l / (sigma k a^2 + K_g), the sensor reads s theta."""
        n, reading = self.description.static_deflection
        st = self._statics()
        rates = self.description.spring_rates
        from scenes import paper

        k = rates.get(n, paper.ringing_row(n)["stiffness_n_per_m"])
        sigma = (st["s"] * st["load_moment"] / reading - st["k_grav"]) / (k * st["a"] ** 2)
        if not sigma > 0:
            raise InputError(f"rig description: static_deflection {reading!r} m on {n} springs is more than the "
                             f"load's moment against the rig's gravity stiffness alone gives")
        return float(sigma)

    def _damping_ratios(self) -> np.ndarray:
        """Each configuration's damping ratio for ``damping = "per_configuration"``: the description's, else its
        record's (summary) measured one."""
        out = []
        stated = self.description.damping_ratios
        k = self.observables.index("damping") if "damping" in self.observables else None
        for j, c in enumerate(self.configs):
            z = stated.get(c["springs"], self.measured[j, k] if k is not None else math.nan)
            if not (math.isfinite(z) and z > 0):
                raise InputError(f"damping = \"per_configuration\": no damping ratio for {c['springs']} springs "
                                 f"(state it in damping_ratios)")
            out.append(float(z))
        return np.array(out)

    def _travel(self) -> list[float]:
        """Each stack's service travel [m]: unit_travel x units, DIN 2093's with the default rates, else NaN."""
        from scenes.passive_tool import stack_travel

        d = self.description
        if d.unit_travel is not None:
            return [d.unit_travel * c["springs"] for c in self.configs]
        if not d.spring_rates:
            return [stack_travel(c["springs"]) for c in self.configs]
        return [math.nan] * self.n_configs

    def facts(self) -> object:
        """What the described rig states that bounds the mechanisms (``calibration.mechanisms.RigFacts``)."""
        from . import mechanisms as mech

        st = self._statics()
        k = np.array([c["stiffness"] for c in self.configs])
        theta = np.abs(self.swing) / st["s"]
        moment = (k * st["a"] ** 2 + st["k_grav"]) * theta
        d = self.description
        mass = d.tool_mass if d.tool_mass is not None else (
            build_tool_mass() * ((d.tool_inertia / self.reference.tool_inertia) if d.tool_inertia else 1.0))
        return mech.RigFacts(self.rig, tuple(c["springs"] for c in self.configs), tuple(map(float, k)),
                             tuple(self._travel()), tuple(map(float, abs(st["moment"]) / st["a"] / k)),
                             float(np.min(moment)) if np.all(np.isfinite(moment)) else math.nan, float(mass))

    def baseline_bounds(self) -> dict[str, object]:
        """The physical ranges of the baseline's first-order factors (``calibration.mechanisms.Bound``): the rates
        within DIN 2093's tolerance, the inertia within +-10 % of the stated (CAD) one."""
        from scenes.passive_tool import DIN_RATE_TOLERANCE, INERTIA_TOLERANCE

        from . import mechanisms as mech

        return {"stiffness_scale": mech.Bound(*DIN_RATE_TOLERANCE, "DIN 2093 section 7.1: a stack's rate within "
                                              "-7.5 % / +25 % of its nominal"),
                "inertia_factor": mech.Bound(*INERTIA_TOLERANCE, "a CAD estimate of a tool's inertia about its "
                                             "pivot: +-10 % (scenes.passive_tool.INERTIA_TOLERANCE)")}

    @property
    def n_configs(self) -> int:
        return len(self.configs)

    def _hits(self) -> np.ndarray | None:
        """The sensor's initial velocity per configuration in warpdem's rig [m/s] (None: ``hit_amplitude``)."""
        eq = self._equivalent(1.0)
        hit = self.description.hit
        if not isinstance(hit, str):
            return np.full(self.n_configs, float(hit) / eq.reading_factor)
        if not self.has_series:
            return None
        out = np.zeros(self.n_configs)
        for j in range(self.n_configs):
            f, z, a = self.measured[j, 0], self.measured[j, 1], self.swing[j]
            if not (np.isfinite(f) and np.isfinite(a)) or a == 0:
                return None  # a record without a decay: fall back to hit_amplitude for all
            out[j] = hit_velocity(a, f, z) / eq.reading_factor
        return out

    def _dashpot_gene(self) -> Gene:
        """The dashpot's range for a described rig: damping ratios 0.002 (stiffest configuration) to 0.5 (softest)
        with the stated inertia, at the spring lever [N s/m]."""
        eq = self._equivalent(1.0)
        k_rot = np.array([c["stiffness"] for c in self.configs]) * eq.rate_factor * self.reference.lever**2
        a2 = eq.rate_factor * self.reference.lever**2
        lo = 2 * 0.002 * math.sqrt(k_rot.min() * eq.inertia) / a2
        hi = 2 * 0.5 * math.sqrt(k_rot.max() * eq.inertia) / a2
        return Gene("dashpot", float(f"{lo:.2g}"), float(f"{hi:.2g}"), log=True, unit="N s/m")

    def _equivalent(self, inertia_factor: float) -> object:
        from .rig_description import equivalent

        return equivalent(self.description, inertia_factor, self.reference)

    def describe_config(self, j: int) -> str:
        c = self.configs[j]
        return f"{c['springs']} springs (k = {c['stiffness']:.3g} N/m)"

    def describe_uncertainty(self) -> dict[str, str]:
        return {k: (f"{u:.3g} (absolute, with each record's fit error)" if k in RINGING_ABSOLUTE
                    else f"{100 * u:.3g} %") for k, u in self.uncertainty.items()}

    def describe_fit(self, params: dict[str, float]) -> list[str]:
        """The first-order adjustments of a fitted baseline, in words."""
        out = []
        if "inertia_factor" in params:
            eq = self._equivalent(params["inertia_factor"])
            out.append(f"your rig's effective inertia about the pivot is {params['inertia_factor']:.3g}x the stated "
                       f"one ({eq.inertia:.4g} kg m^2)")
        if "stiffness_scale" in params:
            out.append(f"its springs act with {params['stiffness_scale']:.3g}x the stated rates")
        if "stiffness_scale" in params and "inertia_factor" in params:
            ratio = params["stiffness_scale"] / params["inertia_factor"]
            out.append(f"ringing records fix the rates relative to the inertia, {ratio:.3g}x the stated ratio; only "
                       "their ratio is determined (a measured static deflection would separate them)")
        if "dashpot" in params:
            out.append(f"a dashpot of {params['dashpot']:.4g} N s/m along the springs")
        if self.datum_scale is not None:
            n, u = self.description.static_deflection
            out.append(f"the static deflection {1e3 * u:.4g} mm on {n} springs fixes the rates at "
                       f"{self.datum_scale:.3g}x the stated ones")
        if "damping_scale" in params:
            z = ", ".join(f"{c['springs']}: {zz:.3g}" for c, zz in zip(self.configs, self.damping_ratio, strict=True))
            out.append(f"each configuration's own damping ratio ({z}) times {params['damping_scale']:.3g}")
        return out

    def dashpots(self, configs: list[int], params: list[dict[str, float]]) -> list[float]:
        """The dashpot [N s/m at the spring lever] of each case: ``dashpot``, or with per-configuration damping
        c_j = damping_scale 2 zeta_j sqrt(K_j J) / a^2, the linear oscillator's (K_j = sigma k_j a^2 + K_g, J the
        rig's inertia about the pivot with the case's inertia factor)."""
        if self.damping_ratio is None:
            return [float(p["dashpot"]) for p in params]
        st = self._statics()
        out = []
        for j, p in zip(configs, params, strict=True):
            k_rot = self._scale(p) * self.configs[j]["stiffness"] * st["a"] ** 2 + st["k_grav"]
            inertia = self._equivalent(p.get("inertia_factor", 1.0)).inertia
            out.append(float(p["damping_scale"] * 2 * self.damping_ratio[j] * math.sqrt(k_rot * inertia)
                             / st["a"] ** 2))
        return out

    def _scale(self, p: dict[str, float]) -> float:
        """The case's factor on every spring rate: fitted, else the datum's, else 1."""
        return float(p.get("stiffness_scale", self.datum_scale if self.datum_scale is not None else 1.0))

    def settings(self) -> dict[str, object]:
        """What the simulations depend on besides the cases (a diagnosis checkpoint must match it)."""
        return {"fixed": self.fixed, "ring_time": self.ring_time, "settle_time": self.settle_time,
                "hit_amplitude": self.hit_amplitude, "load_force": self.load_force, "sample_rate": self.sample_rate,
                "max_worlds": self.max_worlds, "device": str(self.device),
                "description": self.description.to_dict(), "hit": None if self.hit is None else self.hit.tolist()}

    def state(self) -> dict[str, object]:
        """Results a resumed diagnosis must not simulate again (none: every ringing result is the fitter's)."""
        return {}

    def restore(self, state: dict[str, object]) -> None:
        """Take back :meth:`state`."""

    def _spring_force(self) -> float:
        """The spring's static force under the load at the pose of warpdem's rig [N] (tension positive)."""
        if self._geometry is None:
            from scenes.ringing import gravity_moment, load_point_on
            from scenes.sweep import build_sweep

            tool = build_sweep()
            lever = float(abs(tool.sensor_point[2] - tool.pivot[2]))
            eq = self._equivalent(1.0)
            load_point = load_point_on(tool, eq.load_offset)
            m_tool = gravity_moment(tool, 0.0, load_point)
            moment = eq.tool_mass_scale * m_tool + gravity_moment(tool, eq.load_force / 9.81, load_point) - m_tool
            self._geometry = {"force": moment / lever}
        return self._geometry["force"]

    def covariates(self) -> dict[str, np.ndarray]:
        """Per configuration: spring count, stated stiffness [N/m] and nominal static deflection of the springs [m]
        (the diagnosis replaces it with the one its fitted baseline simulates)."""
        k = np.array([c["stiffness"] for c in self.configs])
        eq = self._equivalent(1.0)
        return {"springs": np.array([c["springs"] for c in self.configs], dtype=float), "stiffness": k,
                "static_deflection": np.abs(self._spring_force()) / (k * eq.rate_factor) * math.sqrt(eq.rate_factor)}

    def simulate(self, cases: list[Case], keep_series: bool = False, progress: object | None = None) -> SimOutput:
        """Run every case as a world of batched ringing simulations (at most ``max_worlds`` per simulation)."""
        from scenes.ringing import RingingConfig, run_ringing

        values = np.full((len(cases), len(self.observables)), np.nan)
        static = np.full(len(cases), np.nan)
        failed = [""] * len(cases)
        series: list[tuple[np.ndarray, np.ndarray]] = []
        for start in range(0, len(cases), self.max_worlds):
            chunk = cases[start:start + self.max_worlds]
            params = [{**self.fixed, **c.params} for c in chunk]
            eqs = [self._equivalent(p.get("inertia_factor", 1.0)) for p in params]
            rate = eqs[0].rate_factor
            fields: dict[str, object] = {}
            if any(e.tool_mass_scale != 1.0 for e in eqs):
                fields["tool_mass_scale"] = tuple(e.tool_mass_scale for e in eqs)
            if not self.description.load_mass_rides:
                fields["load_mass_fraction"] = (0.0,) * len(chunk)
            elif any("load_mass_fraction" in p for p in params) or any(e.load_mass_fraction != 1.0 for e in eqs):
                fields["load_mass_fraction"] = tuple(e.load_mass_fraction * float(p.get("load_mass_fraction", 1.0))
                                                     for e, p in zip(eqs, params, strict=True))
            scale = {"series_stiffness": rate, "progressive": rate * rate}
            travel = self._travel()
            for p, c in zip(params, chunk, strict=True):  # a stack's hardening by its own (fitted) rate and travel
                if "progressive_factor" in p:
                    k = self._scale(p) * self.configs[c.config]["stiffness"]
                    p["progressive"] = p.pop("progressive_factor") * k / travel[c.config] ** 2 + p.get("progressive",
                                                                                                         0.0)
            for knob in ("pivot_friction", "extra_mass", "progressive", "series_stiffness", "free_pose"):
                if any(knob in p for p in params):
                    fields[knob] = tuple(float(p.get(knob, KNOB_OFF.get(knob, 0.0))) * scale.get(knob, 1.0)
                                         for p in params)
            if self.hit is not None:
                fields["hit_velocity"] = tuple(float(self.hit[c.config]) for c in chunk)
            cfg = RingingConfig(
                springs=tuple(self.configs[c.config]["springs"] for c in chunk), spring_model="linear",
                load_force=eqs[0].load_force,
                stiffness=tuple(self.configs[c.config]["stiffness"] * self._scale(p) * rate
                                for c, p in zip(chunk, params, strict=True)), load_offset=eqs[0].load_offset,
                dashpot=tuple(c * rate for c in self.dashpots([c.config for c in chunk], params)),
                settle_time=self.settle_time,
                ring_time=self.ring_time, hit_amplitude=self.hit_amplitude, sample_rate=self.sample_rate, **fields)
            done, size = start, len(chunk)
            res = run_ringing(cfg, device=self.device,
                              progress=(lambda d, n, what, s0=done, m=size: progress(s0 + m * d / n, len(cases), what))
                              if progress else None)
            reading = eqs[0].reading_factor
            for w, p in enumerate(params):
                x = (res.displacement[:, w] * reading + p.get("sensor_offset", 0.0)
                     + p.get("sensor_drift", 0.0) * res.time)
                obs = ringdown_observables(res.time, x, self.has_series)
                values[start + w] = [obs[k] for k in self.observables]
                failed[start + w] = obs["failed"]
                static[start + w] = abs(res.spring_deflection[w]) * math.sqrt(rate)
                if keep_series:
                    series.append((res.time.copy(), x.copy()))
        return SimOutput(values, {"static_deflection": static}, series if keep_series else None, failed)

    def failure_bound(self) -> np.ndarray:
        """Per observable, the value a failed simulated extraction is scored against (one-sided: the simulation is
        at least this), NaN where a failure tells nothing about the observable (it counts as unknown)."""
        return np.array([FAILED_DAMPING if k == "damping" else math.nan for k in self.observables])


SOIL_BIN_UNCERTAINTY = {"reduction": 2.0, "displacement_mean": 2e-4, "displacement_trend": 1e-4,
                        "draught_mean": 0.03, "rigid_draught_mean": 0.03}
"""default 1-sigma uncertainties of the measured soil-bin observables: ``reduction`` absolute, 2 percentage points
(Table 3's eight rigid runs of one nominal condition scatter by 1.5 % (SD 5.1 N of 338 N), and a reduction is the
difference of two runs: sqrt(2) x 1.5 %); ``displacement_mean`` absolute, 0.2 mm (the runs' own displacement SD is
0.06-0.19 mm; the sensor's zero is set once per run); ``displacement_trend`` (from series) absolute, 0.1 mm/s
(over a 3 s laboratory run it moves the reading by 0.3 mm, beyond the runs' SD); draught means relative, 3 % (twice
the rigid runs' scatter). The simulation's own sampling error (the standard error of each steady-state mean or
trend, from the baseline's runs) is added in quadrature: a reduced-scale DEM run is short and noisy."""
SOIL_BIN_ABSOLUTE = frozenset({"reduction", "displacement_mean", "displacement_trend"})
"""observables whose stated uncertainty is absolute (in their unit); the others' is relative."""


def _own_sem(rows: list[dict[str, float]], sem: str) -> float:
    """The realizations' own standard errors ``sem`` combined: sqrt(sum sem^2) / len(rows)."""
    return math.sqrt(sum(float(row[sem]) ** 2 for row in rows)) / len(rows)


def combine_realizations(run: object, r: int) -> object:
    """A soil-bin run of n x ``r`` worlds (each configuration's ``r`` realizations consecutive) as one of n worlds:
    each steady statistic's mean over its realizations, its standard error (``*_sem``) the larger of the
    realizations' scatter, std(ddof=1) / sqrt(r), and their own, sqrt(sum sem^2) / r (a few chaotic realizations can
    agree by chance; a run's own SE can miss slow drifts); the series' mean over the realizations. ``run``: a
    ``scenes.soil_bin.SoilBinRun``."""
    from dataclasses import replace

    n = len(run.steady) // r
    if n * r != len(run.steady) or r < 2:
        raise ValueError(f"combine_realizations: {len(run.steady)} worlds are not a multiple of r = {r} >= 2")
    steady = []
    for j in range(n):
        rows = run.steady[j * r:(j + 1) * r]
        out: dict[str, float] = {}
        for k, v in rows[0].items():
            if k.endswith("_sem"):
                continue
            if not isinstance(v, (int, float, np.floating, np.integer)):
                out[k] = v
                continue
            x = np.array([float(row[k]) for row in rows])
            out[k] = float(x.mean())
            sem = f"{k.removesuffix('_mean')}_sem"  # draught_mean's is draught_sem, displacement_trend's _trend_sem
            if sem in rows[0]:
                out[sem] = max(float(x.std(ddof=1)) / math.sqrt(r), _own_sem(rows, sem))
        for k in rows[0]:  # a standard error without its statistic: the runs' own combined
            if k.endswith("_sem") and k not in out:
                out[k] = _own_sem(rows, k)
        steady.append(out)

    def mean(a: np.ndarray) -> np.ndarray:
        return a.reshape(a.shape[0], n, r, *a.shape[2:]).mean(axis=2)

    return replace(run, springs=tuple(run.springs[::r]), speeds=tuple(run.speeds[::r]), travel=mean(run.travel),
                   series={k: mean(v) for k, v in run.series.items()}, steady=steady)


class SoilBinRigModel:
    """The soil bin (``scenes.soil_bin``, linear spring model) against measured soil-bin data (like Table 3).

    Configurations: the summary's rows (``springs``, ``speed`` [m/s], optional ``stiffness`` [N/m], default DIN 2093
    of Table 2). Observables: those of ``reduction`` [%] (draught reduction of the passive tool against a rigid run
    at the same speed), ``displacement_mean`` [m] (mean displacement at the sensor), ``draught_mean`` and
    ``rigid_draught_mean`` [N] that the summary has; by default the reduction and the displacement, which do not
    depend on the soil's absolute strength (a reduced-scale bed draws less than the laboratory's soil). Their stated
    uncertainty: ``uncertainty`` (absolute in their unit for the reduction and displacements, relative for draughts;
    default :data:`SOIL_BIN_UNCERTAINTY`), or each row's own where the summary has a column ``<observable>_se`` (a
    standard error, e.g. over repeated runs; the caller's ``uncertainty`` still wins).

    Baseline: the scene as calibrated (the soil's GA set, Table 2's spring rates and measured damping ratios); no
    fitted gene (``fixed`` may set a baseline knob for every case, e.g. ``dashpot``). Table 2's support offsets (the
    paper's final model) are off by default: the paper set them per configuration from the measured rotation of the
    shank, so they are a fit of the displacement this diagnosis criticises (``support_offset=True`` restores them).
    Knobs: pivot_friction, extra_mass, progressive, series_stiffness, soil_viscosity, stack_preload (DEM:
    ``scenes.soil_bin.KNOBS``), spring_lever [-] (the stacks bear on the shank at this many times the sensor's
    lever: the DEM's spring, at the sensor's lever, gets the same moment-rotation law: rate x lambda^2, a given
    dashpot x lambda^2, progressive x lambda^4, preload / lambda; without a dashpot knob the measured damping ratio
    is kept), sensor_lever [-] (the sensor reads at this many times its stated lever: every displacement reading
    scaled by it, before the offset), tool_friction [deg] (the soil-steel contacts' own friction angle) and
    tool_adhesion [Pa] (the soil-steel pair's adhesion) and soil_cohesion_scale [-] (the soil's bonds' strength
    times this), in the passive and the rigid runs alike
    (``scenes.soil_bin.KNOBS``), deposit_friction [deg] (the bed deposited again with this contact friction: a
    denser or looser bed), settle_time [s] (the bed settled this long before its bonds are set and the tool
    moves) and fragile [-] (1 or 0: the soil's bonds break at their strength or yield), passive and rigid runs
    alike (:data:`CONFIG_KNOBS`; only where the rig model deposits its own beds, not with a given ``bed`` or
    ``tool``), sensor_offset [m] (added to the displacement reading) and rigid_speed [m/s]
    (every reduction taken against a rigid run at this one speed instead of the configuration's own: the rigid
    draught at the configuration's speed moved along the rigid draught's line against speed, fitted through rigid
    runs at :data:`RIGID_SWEEP` and the measured speeds; the rigid runs are simulated once). Rigid runs (one per
    measured speed) are simulated once; passive runs are cached by their physical parameters, so a sensor-only
    change costs no simulation.

    Series: with a force (draught) series for every configuration and no ``draught_mean`` column, their steady
    means are ``draught_mean`` (an observable to ask for: by default the draught's level is not compared).
    With a displacement series for every configuration (``signal: displacement``, keyed by ``springs``),
    ``displacement_mean`` and ``displacement_trend`` [m/s] (its least-squares slope in time) come from the series'
    steady part (travel = speed x time from the record's start >= ``measured_steady_travel``, default the
    simulation's steady travel), and the knob sensor_drift [m/s] joins: a reading off by drift x time since the
    record's start, applied on the measured record's time base (so it shifts a mean by drift x the window's mean
    time, and a trend by drift).

    ``scale``, ``assembly``, ``parameter_set``, ``seed``, ``working_depth``, ``travel``, ``steady_travel``,
    ``support_offset``, ``settle_time`` [s], ``fragile``, ``deposit_friction`` [deg]: the
    ``scenes.soil_bin.SoilBinConfig`` of the simulations;
    ``soil``: soil contact parameters replacing the GA set's in every run (``friction_angle`` [deg],
    ``normal_cohesion``, ``shear_cohesion`` [Pa], ``eta_roll``, ``eta_twist`` [-]; e.g. a set calibrated at the
    simulation's scale); ``bed``: a deposited bed to use (else made or read from ``cache_dir``), or realizations:
    a list of beds that can be worlds of one simulation (replica beds of one population,
    ``scenes.replica_beds.perturbed`` copies of one bed), every case then run on each and its observables the
    realizations' mean, its standard error the larger of their scatter's (std / sqrt(n)) and the runs' own combined
    (sqrt(sum sem^2) / n); ``tool``: the
    sweep (``scenes.sweep.SweepTool``) already placed on that bed, used where it is (``run_soil_bin``'s
    ``place=False``; e.g. a twin's exported scene, with its ``bed``; default: the sweep placed on the bed's surface
    by every run); ``max_worlds``:
    passive worlds per simulation; ``simulator``: what runs the soil bin instead of the DEM,
    ``simulator(config, springs, speeds, knobs, soil_overrides) -> scenes.soil_bin.SoilBinRun``
    (``run_soil_bin``'s arguments and result; for tests with an independent model).
    """

    rig = rigs.SOIL_BIN.name
    uncertainty_defaults = SOIL_BIN_UNCERTAINTY
    knobs = frozenset({"pivot_friction", "extra_mass", "progressive", "series_stiffness", "soil_viscosity",
                       "stack_preload", "sensor_offset", "rigid_speed", "progressive_factor", "spring_lever",
                       "sensor_lever", "tool_friction", "tool_adhesion", "soil_cohesion_scale", "mount_pitch"})
    units = {"reduction": "%", "displacement_mean": "m", "displacement_trend": "m/s", "draught_mean": "N",
             "rigid_draught_mean": "N"}
    genes: tuple[Gene, ...] = ()

    def __init__(self, measured: Measured, *, device: str | None = None, fixed: dict[str, float] | None = None,
                 scale: str = "ci", assembly: str = "C", parameter_set: int | None = None, seed: int = 0,
                 working_depth: float | None = None, travel: float | None = None,
                 steady_travel: float | None = None, support_offset: bool = False, settle_time: float = 0.0,
                 fragile: bool = True, deposit_friction: float = 30.0, soil: dict[str, float] | None = None,
                 observables: tuple[str, ...] | None = None,
                 uncertainty: dict[str, float] | None = None, max_worlds: int = 64, bed: object | None = None,
                 tool: object | None = None, cache_dir: str | None = None, measured_steady_travel: float | None = None,
                 runs_from: SoilBinRigModel | None = None, simulator: Callable[..., object] | None = None) -> None:
        from scenes import paper
        from scenes import soil_bin as sb

        self.device = device
        self.fixed = dict(fixed or {})
        allowed = set(sb.KNOBS) - {"stiffness"} | {"rigid_speed"}
        unknown = set(self.fixed) - allowed
        if unknown:
            raise InputError(f"fixed: unknown knobs {sorted(unknown)}; the soil-bin rig has {sorted(allowed)}")
        s = measured.summary
        for col in ("springs", "speed"):
            if col not in s:
                raise InputError(f"measured soil-bin data need a summary column {col!r} (have {sorted(s)})")
        springs = [int(n) for n in s["springs"]]
        for n in springs:
            if n not in paper.SPRING_COUNTS:
                raise InputError(f"springs must be among {paper.SPRING_COUNTS}, got {n}")
        stiffness = s.get("stiffness", np.array([paper.ringing_row(n)["stiffness_n_per_m"] for n in springs]))
        self.configs = [{"springs": n, "speed": float(v), "stiffness": float(k)}
                        for n, v, k in zip(springs, s["speed"], stiffness, strict=True)]
        self.config = sb.SoilBinConfig(scale=scale, assembly=assembly, springs=tuple(sorted(set(springs))),
                                       spring_model="linear", parameter_set=parameter_set, seed=seed,
                                       travel=travel, steady_travel=steady_travel, support_offset=support_offset,
                                       settle_time=settle_time, fragile=fragile, deposit_friction=deposit_friction,
                                       **({"working_depth": working_depth} if working_depth else {}))
        columns = dict(s)
        start = float(measured_steady_travel or self.config.steady_travel or self.config.preset["steady_travel"])

        def steady(x: object, speed: float) -> analysis.SteadyState:
            t = x.time - x.time[0]
            return analysis.steady_state(t, x.values, speed * t, start_travel=start)

        by_signal = {sig: {int(x.config["springs"]): x for x in measured.series if x.signal == sig}
                     for sig in ("displacement", "force")}
        if (by_signal["displacement"] or by_signal["force"]) and len(set(springs)) != len(springs):
            raise InputError(f"series are keyed by spring count: one configuration per count, got {springs}")
        force = by_signal["force"]
        if force and all(n in force for n in springs) and "draught_mean" not in columns:
            # draught records of the passive tool: their steady means are the draught_mean observable
            columns["draught_mean"] = np.array([steady(force[c["springs"]], c["speed"]).mean for c in self.configs])
        disp = by_signal["displacement"]
        self.has_series = bool(disp) and all(n in disp for n in springs)
        self.measured_series = None
        self._drift_time = None
        if self.has_series:
            stats = [steady(disp[c["springs"]], c["speed"]) for c in self.configs]
            columns["displacement_mean"] = np.array([st.mean for st in stats])
            columns["displacement_trend"] = np.array([st.trend for st in stats])
            self._drift_time = np.array([st.t_mean for st in stats])
            self.measured_series = [(disp[c["springs"]].time - disp[c["springs"]].time[0],
                                     disp[c["springs"]].values) for c in self.configs]
            self.knobs = type(self).knobs | {"sensor_drift"}
        if observables is None:
            observables = tuple(k for k in ("reduction", "displacement_mean", "displacement_trend") if k in columns)
        if not observables:
            raise InputError("measured soil-bin data need a 'reduction' or 'displacement_mean' column or "
                             "displacement series (or name the observables)")
        for k in observables:
            if k not in self.units:
                raise InputError(f"observables: unknown {k!r}; known {sorted(self.units)}")
            if k not in columns:
                raise InputError(f"observables: the measured data have no {k!r} (summary column or series)")
        self.observables = tuple(observables)
        self.measured = np.column_stack([columns[k] for k in self.observables])
        unc = _stated(SOIL_BIN_UNCERTAINTY, uncertainty)
        self.uncertainty = {k: unc[k] for k in self.observables}
        # a row's own standard error (a summary column <observable>_se) replaces the default; the caller's wins
        self.row_se = tuple(k for k in self.observables if f"{k}_se" in columns and k not in (uncertainty or {}))
        self.stated_sigma = np.column_stack([
            columns[f"{k}_se"] if k in self.row_se else
            np.full(len(springs), unc[k]) if k in SOIL_BIN_ABSOLUTE else unc[k] * np.abs(columns[k])
            for k in self.observables])
        if not np.all(np.isfinite(self.stated_sigma)):
            raise InputError("measured soil-bin data: a standard-error column has an empty cell for an observable's "
                             "row")
        self._data_reference = self._shared_data_reference(columns)
        fields = ("friction_angle", "normal_cohesion", "shear_cohesion", "eta_roll", "eta_twist")
        self.soil = {k: float(v) for k, v in (soil or {}).items()}
        for k, v in self.soil.items():
            if k not in fields:
                raise InputError(f"soil: unknown parameter {k!r}; known {fields}")
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"soil: {k} must be finite and non-negative, got {v!r}")
        if tool is not None and bed is None:
            raise InputError("tool: a placed tool needs the bed it was placed on (bed=...)")
        self._beds = list(bed) if isinstance(bed, (list, tuple)) else None
        if self._beds is not None and not self._beds:
            raise InputError("bed: an empty list of realizations")
        self._bed = self._beds[0] if self._beds else bed
        self._other_beds: dict[float, object] = {}
        """beds deposited with another contact friction (the deposit_friction knob) by that friction [deg]."""
        if bed is None and tool is None and (runs_from is None or runs_from.deposits_beds):
            self.knobs = self.knobs | set(CONFIG_KNOBS)
        self.tool = tool
        self.cache_dir = cache_dir
        self.max_worlds = int(max_worlds)
        self._rigid: dict[float, dict[str, float]] = {}
        self._rigid_line: tuple[float, float] | None = None
        self._rigid_tool: dict[tuple, dict[float, dict[str, float]]] = {}
        """rigid runs with knobs of ``scenes.soil_bin.SOIL_KNOBS``: ((name, value), ...) -> speed -> mean, sem."""
        self.simulator = simulator
        self._passive: dict[tuple, dict[str, object]] = {}
        self._sim_sigma: np.ndarray | None = None
        self._sim_reference: tuple[np.ndarray, np.ndarray] | None = None
        if runs_from is not None:  # the same scene's simulated runs, e.g. for a second data set
            if runs_from.settings() != self.settings():
                raise ValueError("runs_from: the other rig model simulates another scene (settings differ)")
            self._bed, self._rigid, self._passive = runs_from._bed, runs_from._rigid, runs_from._passive
            self._beds = runs_from._beds
            self.tool = runs_from.tool
            self._rigid_tool = runs_from._rigid_tool
            self._other_beds = runs_from._other_beds
            self.simulator = runs_from.simulator

    @property
    def n_configs(self) -> int:
        return len(self.configs)

    def describe_config(self, j: int) -> str:
        c = self.configs[j]
        return f"{c['springs']} springs (k = {c['stiffness']:.3g} N/m, {c['speed']:.2f} m/s)"

    def describe_uncertainty(self) -> dict[str, str]:
        out = {}
        for i, (k, u) in enumerate(self.uncertainty.items()):
            if k in self.row_se:
                se = self.stated_sigma[:, i]
                out[k] = f"the data's standard errors, {se.min():.3g}-{se.max():.3g} {self.units[k]}"
                continue
            out[k] = f"{u:.3g} {self.units[k]} (absolute)" if k in SOIL_BIN_ABSOLUTE else f"{100 * u:.3g} %"
        if self._sim_sigma is not None:
            for i, k in enumerate(self.observables):
                out[k] += f" + simulation SEM {np.nanmedian(self._sim_sigma[:, i]):.3g} {self.units[k]} (median)"
        return out

    @property
    def simulation_sigma(self) -> np.ndarray:
        """The baseline simulation's standard error of each observable's steady-state mean, in its unit
        (n_configs, n_obs); the first use simulates the baseline (cached for the fits)."""
        if self._sim_sigma is None:
            out = self.simulate([Case(j, {}) for j in range(self.n_configs)], _sem=True)
            self._sim_sigma = np.nan_to_num(out.values, nan=0.0)
            self._sim_reference = self._shared_simulated_reference()
        return self._sim_sigma

    def _shared_data_reference(self, columns: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """The measured reductions' shared rigid references: per row, the index of its rigid run (-1: none known)
        and the reduction's loading on that run's error, a_j = 100 P_j s_R / R^2 [percentage points]
        (d reduction / d R = 100 P / R^2, P = R (1 - reduction / 100) the passive draught the row's reduction
        implies), so that Cov(reduction_i, reduction_j) = a_i a_j for rows of one rigid run.

        Rows share a rigid run when the summary gives ``rigid_draught_mean`` and ``rigid_draught_mean_se`` and
        they agree in both and in speed (the Yade twin's tables: one rigid ensemble for every row). A summary that
        pairs each row with a rigid run of its own (Table 3: each row's rigid draught differs) or gives no rigid
        standard error has none: the data's reductions are then taken as independent of one another (only the
        simulation's shared rigid runs correlate them). The stated uncertainty of a row's reduction is taken to
        include its rigid run's part (a row's ``reduction_se`` propagated from both, as the twin's tables are;
        the default 2 points, from two runs' scatter): a loading above it is refused."""
        from scenes import soil_bin as sb

        n = self.n_configs
        group, load = np.full(n, -1), np.zeros(n)
        if "reduction" not in self.observables or not {"rigid_draught_mean", "rigid_draught_mean_se"} <= set(columns):
            return group, load
        k = self.observables.index("reduction")
        rigid = np.asarray(columns["rigid_draught_mean"], dtype=np.float64)
        se = np.asarray(columns["rigid_draught_mean_se"], dtype=np.float64)
        red = self.measured[:, k]
        ok = np.isfinite(rigid) & np.isfinite(se) & np.isfinite(red) & (rigid > 0)
        keys = [(sb.speed_key(c["speed"]), float(r), float(e)) for c, r, e in zip(self.configs, rigid, se,
                                                                                    strict=True)]
        index: dict[tuple, int] = {}
        for j in np.flatnonzero(ok):
            group[j] = index.setdefault(keys[j], len(index))
            load[j] = (100.0 - red[j]) * se[j] / rigid[j]
        if np.any(load > self.stated_sigma[:, k] * (1 + 1e-9)):
            j = int(np.argmax(load - self.stated_sigma[:, k]))
            raise InputError(f"measured soil-bin data: {self.describe_config(j)}'s stated reduction uncertainty "
                             f"{self.stated_sigma[j, k]:.3g} % is below its rigid reference's own part "
                             f"{load[j]:.3g} % (100 P s_R / R^2)")
        return group, load

    def _shared_simulated_reference(self) -> tuple[np.ndarray, np.ndarray]:
        """The baseline's simulated reductions' shared rigid runs: per configuration, the index of the rigid run its
        reduction is taken against (one per speed and shared knobs) and the loading a_j = 100 P_j s_R / R^2
        [percentage points] on that run's standard error s_R (P_j the baseline's passive draught, R the rigid
        draught, with the ``fixed`` knobs), as :meth:`simulation_sigma` fixes the simulation's errors at the
        baseline. With ``rigid_speed`` the reference is the run at the configuration's own speed moved along the
        rigid line: its error is that run's (the line's slope is taken as exact, as in ``rigid_reference``)."""
        from scenes import soil_bin as sb

        n = self.n_configs
        group, load = np.full(n, -1), np.zeros(n)
        if "reduction" not in self.observables:
            return group, load
        index: dict[tuple, int] = {}
        for j in range(n):
            case = Case(j, {})
            p = dict(self.fixed)
            speed = self.configs[j]["speed"]
            tool = _shared_knobs(p)
            rigid, rigid_sem = self._compared_rigid(speed, p)
            passive = float(self._passive[self._physical(case)]["draught_mean"])
            if not (math.isfinite(rigid) and math.isfinite(rigid_sem) and math.isfinite(passive) and rigid != 0):
                continue
            group[j] = index.setdefault((tuple(sorted(tool.items())), sb.speed_key(speed)), len(index))
            load[j] = 100.0 * abs(passive) * rigid_sem / rigid**2
        return group, load

    def residual_correlation(self) -> np.ndarray | None:
        """The correlation of the residuals (sim - measured) / sigma (n_configs n_obs, n_configs n_obs), flattened
        configuration-major (entry j n_obs + k: configuration j, observable k), in units of :attr:`sigma`; None
        where they are independent. Reductions that share a rigid reference share its error, on either side
        (``calibration.diagnosis.Whitening`` whitens the residuals with it):

            Cov(red_i, red_j) = (100 P_i / R^2)(100 P_j / R^2) var(R)

        for each side whose rows i != j share one rigid run R: the measured data's (:meth:`_shared_data_reference`:
        the rigid run's standard error where the data give it) and the simulation's (warpdem's rigid run at the
        configuration's speed, its standard error from the baseline's run, :meth:`_shared_simulated_reference`).
        Both sides' errors are independent of each other and add. The diagonal stays 1: each reduction's own
        sigma already holds its rigid run's share (the simulation's by ``scenes.soil_bin.reduction``'s
        propagation; the data's by assumption, see :meth:`_shared_data_reference`). Other observables (and a
        ``rigid_draught_mean`` observable) are taken as independent."""
        if "reduction" not in self.observables:
            return None
        sigma = self.sigma[:, self.observables.index("reduction")]
        if self._sim_reference is None:
            self._sim_reference = self._shared_simulated_reference()
        n, n_obs = self.n_configs, len(self.observables)
        cov = np.zeros((n, n))
        for group, load in (self._data_reference, self._sim_reference):
            same = (group[:, None] == group[None, :]) & (group[:, None] >= 0)
            cov += np.where(same, np.outer(load, load), 0.0)
        np.fill_diagonal(cov, 0.0)
        if not np.any(cov):
            return None
        corr = np.eye(n * n_obs)
        idx = np.arange(n) * n_obs + self.observables.index("reduction")
        corr[np.ix_(idx, idx)] += cov / np.outer(sigma, sigma)
        return corr

    @property
    def sigma(self) -> np.ndarray:
        """Stated uncertainty and the simulation's standard error, in quadrature (n_configs, n_obs)."""
        return np.sqrt(self.stated_sigma**2 + self.simulation_sigma**2)

    def settings(self) -> dict[str, object]:
        """What the simulations depend on besides the cases (a diagnosis checkpoint must match it)."""
        from dataclasses import asdict

        out = {"fixed": self.fixed, "config": asdict(self.config), "soil": self.soil, "max_worlds": self.max_worlds,
               "bed": None if self._bed is None or self.cache_dir else "given", "device": str(self.device)}
        if self.tool is not None:
            out["tool"] = "given"
        if self.realizations > 1:
            out["realizations"] = self.realizations
        return out

    @property
    def realizations(self) -> int:
        """Runs per case (the beds given as realizations; 1 for one bed)."""
        return len(self._beds) if self._beds else 1

    def state(self) -> dict[str, object]:
        """The simulation's standard errors and the rigid runs, which a resumed diagnosis must reuse (a new
        realisation would not match the fitted points)."""
        return {"sim_sigma": None if self._sim_sigma is None else self._sim_sigma.tolist(),
                "sim_reference": None if self._sim_reference is None else [a.tolist() for a in self._sim_reference],
                "rigid": [[v, r["mean"], r["sem"]] for v, r in self._rigid.items()],
                "rigid_tool": [[[list(kv) for kv in a], v, r["mean"], r["sem"]] for a, t in self._rigid_tool.items()
                               for v, r in t.items()],
                "rigid_line": None if self._rigid_line is None else list(self._rigid_line)}

    def restore(self, state: dict[str, object]) -> None:
        """Take back :meth:`state`."""
        if state.get("sim_sigma") is not None:
            self._sim_sigma = np.array(state["sim_sigma"], dtype=np.float64)
        if state.get("sim_reference") is not None:
            group, load = state["sim_reference"]
            self._sim_reference = (np.array(group, dtype=int), np.array(load, dtype=np.float64))
        for v, mean, sem in state.get("rigid", []):
            self._rigid[round(float(v), 6)] = {"mean": float(mean), "sem": float(sem)}  # soil_bin.speed_key
        for a, v, mean, sem in state.get("rigid_tool", []):  # a: [[knob, value], ...], or an angle (saved earlier)
            tool = {"tool_friction": float(a)} if isinstance(a, (int, float)) else {k: float(x) for k, x in a}
            self._rigid_table(tool)[round(float(v), 6)] = {"mean": float(mean), "sem": float(sem)}
        if state.get("rigid_line") is not None:
            self._rigid_line = (float(state["rigid_line"][0]), float(state["rigid_line"][1]))

    def covariates(self) -> dict[str, np.ndarray]:
        """Per configuration: spring count, stiffness [N/m], speed [m/s], measured displacement [m] (if any); the
        diagnosis adds the static deflection its fitted baseline simulates (the tool's mean deflection at work)."""
        out = {k: np.array([c[k] for c in self.configs], dtype=float) for k in ("springs", "stiffness", "speed")}
        if "displacement_mean" in self.observables:
            out["displacement"] = self.measured[:, self.observables.index("displacement_mean")]
        return out

    @property
    def deposits_beds(self) -> bool:
        """Whether the rig model deposits its own beds (no ``bed`` or ``tool`` given), so that the bed's density and
        its bond protocol are knobs (:data:`CONFIG_KNOBS`)."""
        return "deposit_friction" in self.knobs

    def bed(self, deposit_friction: float | None = None) -> object:
        """The bed (with realizations: the first); with ``deposit_friction`` [deg] other than the config's, the bed
        of the same config deposited with that contact friction (made or read from ``cache_dir``, kept)."""
        from dataclasses import replace

        from scenes import soil_bin as sb

        if deposit_friction is not None and deposit_friction != self.config.deposit_friction:
            if deposit_friction not in self._other_beds:
                config = replace(self.config, deposit_friction=deposit_friction)
                self._other_beds[deposit_friction] = sb.bed_for(config, device=self.device, cache_dir=self.cache_dir)
            return self._other_beds[deposit_friction]
        if self._bed is None:
            self._bed = sb.bed_for(self.config, device=self.device, cache_dir=self.cache_dir)
        return self._bed

    def _physical(self, case: Case) -> tuple:
        """The key of a passive run: configuration and the knobs that change the DEM (not the sensor's)."""
        p = {**self.fixed, **case.params}
        return (case.config,) + tuple(sorted((k, float(v)) for k, v in p.items()
                                             if k not in READING_KNOBS))

    def _soil(self, n: int) -> dict[str, object] | None:
        return {k: [v] * n for k, v in self.soil.items()} or None

    def _run(self, springs: list[int], speeds: list[float], knobs: dict[str, list[float]] | None,
             progress: object | None) -> object:
        """One simulation of the soil bin (the DEM, or ``simulator``): a ``scenes.soil_bin.SoilBinRun``. A knob of
        :data:`CONFIG_KNOBS` must be one value for every world: it is the simulation's config (and bed)."""
        from dataclasses import replace

        from scenes import soil_bin as sb

        config = self.config
        for name in CONFIG_KNOBS:
            if knobs and name in knobs:
                values = {float(v) for v in knobs[name]}
                if len(values) != 1:
                    raise ValueError(f"{name}: one simulation's worlds share their config, got {sorted(values)}")
                config = replace(config, **{name: type(getattr(config, name))(values.pop())})  # fragile: a bool
                knobs = {k: v for k, v in knobs.items() if k != name} or None
        r = self.realizations
        if r > 1:  # every world once per realization, realization-minor
            springs, speeds = [n for n in springs for _ in range(r)], [v for v in speeds for _ in range(r)]
            knobs = {k: [x for x in v for _ in range(r)] for k, v in (knobs or {}).items()} or None
        soil = self._soil(len(springs))
        if self.simulator is not None:
            run = self.simulator(config, springs, speeds, knobs, soil)
        else:
            bed = self._beds * (len(springs) // r) if r > 1 else self.bed(config.deposit_friction)
            run = sb.run_soil_bin(config, springs, bed=bed, device=self.device, speeds=speeds, knobs=knobs,
                                  progress=progress, soil_overrides=soil, tool=self.tool, place=self.tool is None)
        return run if r == 1 else combine_realizations(run, r)

    def _tool_friction_off(self) -> float:
        """The soil-steel friction angle [deg] of the scene without the knob: the smaller of the soil's and the
        tool's (Yade's rule), for a case without the knob batched with one that has it."""
        from scenes import paper

        soil = float(self.soil.get("friction_angle", self.config.soil_material().friction_angle))
        return min(soil, paper.TOOL_FRICTION)

    def _rigid_table(self, tool: dict[str, float] | None) -> dict[float, dict[str, float]]:
        """The rigid runs by speed: the scene's own, or with the knobs ``tool`` of ``scenes.soil_bin.SOIL_KNOBS``."""
        if not tool:
            return self._rigid
        return self._rigid_tool.setdefault(tuple(sorted((k, float(v)) for k, v in tool.items())), {})

    def _run_rigid(self, speeds: list[float], progress: object | None, tool: dict[str, float] | None = None) -> None:
        from scenes import soil_bin as sb

        table = self._rigid_table(tool)
        todo = sorted({sb.speed_key(v) for v in speeds} - set(table))
        if not todo:
            return
        knobs = {k: [float(v)] * len(todo) for k, v in tool.items()} if tool else None
        run = self._run([0] * len(todo), todo, knobs, progress)
        for v, row in zip(todo, run.steady, strict=True):
            table[v] = {"mean": row["draught_mean"], "sem": row["draught_sem"]}

    def rigid_reference(self, speed: float, rigid_speed: float | None = None,
                        tool: dict[str, float] | None = None) -> tuple[float, float]:
        """The rigid draught [N] and its standard error [N] that a passive run at ``speed`` [m/s] is compared with:
        the rigid run at ``speed`` (Table 3's pairing), or with ``rigid_speed`` (the rigid_speed knob) that run
        moved along the rigid draught's line against speed to ``rigid_speed`` (the line's slope is fitted once,
        through rigid runs at :data:`RIGID_SWEEP` and every measured speed). With ``tool`` (knobs of
        ``scenes.soil_bin.SOIL_KNOBS``, name -> value) the rigid tool runs with them too (the line's slope stays the
        scene's own). Simulates what is missing."""
        from scenes import soil_bin as sb
        from scenes import speed_sweep

        self._run_rigid([speed], None, tool)
        rig = self._rigid_table(tool)[sb.speed_key(speed)]
        if rigid_speed is None or sb.speed_key(rigid_speed) == sb.speed_key(speed):
            return rig["mean"], rig["sem"]
        if self._rigid_line is None:
            self._run_rigid(list(RIGID_SWEEP) + [c["speed"] for c in self.configs], None)
            v = np.array(sorted(self._rigid))
            line = speed_sweep.fit_line(v, np.array([self._rigid[x]["mean"] for x in v]),
                                        np.array([self._rigid[x]["sem"] for x in v]))
            self._rigid_line = (line.intercept, line.slope)
        return rig["mean"] + self._rigid_line[1] * (rigid_speed - speed), rig["sem"]

    def _compared_rigid(self, speed: float, params: dict[str, float]) -> tuple[float, float]:
        """The rigid draught [N] and its standard error [N] that a passive case at ``speed`` [m/s] with ``params``
        (the fixed knobs and the case's) is compared with: :meth:`rigid_reference` with its rigid_speed and shared
        knobs, plus the soil_viscosity's drag on the rigid tool, which moves at its carriage speed exactly."""
        rigid_speed = params.get("rigid_speed")
        rigid, rigid_sem = self.rigid_reference(speed, rigid_speed, _shared_knobs(params))
        drag = params.get("soil_viscosity", 0.0) * (speed if rigid_speed is None else rigid_speed)
        return rigid + drag, rigid_sem

    def facts(self) -> object:
        """What the soil-bin rig states that bounds the mechanisms (``calibration.mechanisms.RigFacts``): the stated
        rates, each stack's DIN 2093 travel, the measured mean displacements (the stacks' working deflection), the
        sweep's mass, its stacks' and sensor's lever, the discs' radius and the sensor's mounting tolerance, the
        laboratory's internal friction angle, the soil's own contact normal cohesion and whether its bonds are
        fragile."""
        from scenes.passive_tool import DISC_OUTER_RADIUS, SENSOR_MOUNT_TOLERANCE, lever, stack_travel
        from scenes.shear_box import lab_strength
        from scenes.sweep import build_sweep

        from . import mechanisms as mech

        tool = build_sweep()
        deflection = (tuple(map(float, self.measured[:, self.observables.index("displacement_mean")]))
                      if "displacement_mean" in self.observables else ())
        return mech.RigFacts(self.rig, tuple(c["springs"] for c in self.configs),
                             tuple(float(c["stiffness"]) for c in self.configs),
                             tuple(stack_travel(c["springs"]) for c in self.configs), deflection,
                             tool_mass=float(tool.mass),
                             lever=lever(tool), seat_radius=DISC_OUTER_RADIUS,
                             sensor_tolerance=SENSOR_MOUNT_TOLERANCE, soil_friction=lab_strength()[1],
                             soil_cohesion=float(self.soil.get("normal_cohesion",
                                                               self.config.soil_material().normal_cohesion)),
                             soil_fragile=bool(self.config.fragile))

    def _run_passive(self, keys: list[tuple], keep_series: bool, progress: object | None) -> None:
        from scenes.passive_tool import stack_travel

        todo = [k for k in dict.fromkeys(keys) if k not in self._passive
                or (keep_series and "series" not in self._passive[k])]
        per_run = max(1, self.max_worlds // self.realizations)
        run_of = [tuple(dict(k[1:]).get(n, getattr(self.config, n)) for n in CONFIG_KNOBS) for k in todo]
        chunks = [[k for k, c in zip(todo, run_of, strict=True) if c == cfg][start:start + per_run]
                  for cfg in dict.fromkeys(run_of) for start in range(0, run_of.count(cfg), per_run)]
        for chunk in chunks:  # a simulation's worlds share one config and bed
            cfgs = [self.configs[k[0]] for k in chunk]
            params = [dict(k[1:]) for k in chunk]
            for p, c in zip(params, cfgs, strict=True):  # a stack's hardening by its own rate and DIN travel
                if "progressive_factor" in p:
                    p["progressive"] = (p.pop("progressive_factor") * c["stiffness"] / stack_travel(c["springs"]) ** 2
                                        + p.get("progressive", 0.0))
            scale = [lever_scaling(p.pop("spring_lever", 1.0)) for p in params]
            for p, sc in zip(params, scale, strict=True):
                for name in ("dashpot", "progressive", "stack_preload"):
                    if name in p:
                        p[name] *= sc[name]
            knobs: dict[str, list[float]] = {"stiffness": [c["stiffness"] * sc["stiffness"]
                                                           for c, sc in zip(cfgs, scale, strict=True)]}
            for name in sorted({n for p in params for n in p}):
                if name == "dashpot" and not all(name in p for p in params):
                    raise ValueError("dashpot must be given for every case or none")
                off = (self._tool_friction_off() if name == "tool_friction" else getattr(self.config, name)
                       if name in CONFIG_KNOBS else KNOB_OFF.get(name, 0.0))
                knobs[name] = [p.get(name, off) for p in params]
            run = self._run([c["springs"] for c in cfgs], [c["speed"] for c in cfgs], knobs, progress)
            for w, (key, row) in enumerate(zip(chunk, run.steady, strict=True)):
                entry: dict[str, object] = {k: row[k] for k in ("draught_mean", "draught_sem", "displacement_mean",
                                                                "displacement_sem", "displacement_trend",
                                                                "displacement_trend_sem", "steady_time_mean")}
                if keep_series:  # up to the carriage's stop (a faster carriage stops before the run ends)
                    n_moving = int(np.argmax(run.travel[:, w] >= run.travel[:, w].max())) + 1
                    entry["series"] = (run.time[:n_moving].copy(), run.series["displacement"][:n_moving, w].copy())
                self._passive[key] = entry

    def simulate(self, cases: list[Case], keep_series: bool = False, progress: object | None = None,
                 _sem: bool = False) -> SimOutput:
        """The observables of every case (n_cases, n_obs) (with ``_sem``: their simulation standard errors)."""
        from scenes import soil_bin as sb

        tools = [_shared_knobs({**self.fixed, **c.params}) for c in cases]  # the rigid runs alike
        for tool in {tuple(sorted(t.items())) for t in tools}:
            self._run_rigid([self.configs[c.config]["speed"] for c, t in zip(cases, tools, strict=True)
                             if tuple(sorted(t.items())) == tool], progress, dict(tool))
        keys = [self._physical(c) for c in cases]
        self._run_passive(keys, keep_series, progress)
        values = np.full((len(cases), len(self.observables)), np.nan)
        static = np.full(len(cases), np.nan)
        series = []
        for i, (case, key) in enumerate(zip(cases, keys, strict=True)):
            p = {**self.fixed, **case.params}
            speed = self.configs[case.config]["speed"]
            run = self._passive[key]
            rigid, rigid_sem = self._compared_rigid(speed, p)
            passive = float(run["draught_mean"])
            reduction, reduction_sem = sb.reduction(passive, float(run["draught_sem"]), rigid, rigid_sem)
            # the sensor: offset + drift x time since the record's start (the measured record's time base)
            offset, drift, gain = p.get("sensor_offset", 0.0), p.get("sensor_drift", 0.0), p.get("sensor_lever", 1.0)
            t_mean = float(run["steady_time_mean"]) if self._drift_time is None else self._drift_time[case.config]
            if _sem:
                obs = {"reduction": reduction_sem,
                       "displacement_mean": gain * float(run["displacement_sem"]),
                       "displacement_trend": gain * float(run["displacement_trend_sem"]),
                       "draught_mean": float(run["draught_sem"]), "rigid_draught_mean": rigid_sem}
            else:
                obs = {"reduction": reduction,
                       "displacement_mean": gain * float(run["displacement_mean"]) + offset + drift * t_mean,
                       "displacement_trend": gain * float(run["displacement_trend"]) + drift,
                       "draught_mean": passive, "rigid_draught_mean": rigid}
            values[i] = [obs[k] for k in self.observables]
            static[i] = abs(float(run["displacement_mean"]))  # the tool's deflection under the working load
            if keep_series:
                t, x = run["series"]
                series.append((t, gain * x + offset + drift * t))
        return SimOutput(values, {"static_deflection": static}, series if keep_series else None)


RIG_MODELS: dict[str, type] = {rigs.RINGING.name: RingingRigModel, rigs.SOIL_BIN.name: SoilBinRigModel}
"""the diagnosis model of each rig that has one (``scenes.rigs``)."""


def rig_model_class(rig: str) -> type:
    """The rig model class of ``rig`` (a name of ``scenes.rigs``); InputError naming the rigs that have one."""
    return RIG_MODELS[rigs.get(rig, tuple(RIG_MODELS)).name]


def make_rig_model(rig: str, measured: Measured, **kw: object) -> RingingRigModel | SoilBinRigModel:
    """The rig model of ``rig`` ("ringing" or "soil-bin") for a measured data set."""
    return rig_model_class(rig)(measured, **kw)
