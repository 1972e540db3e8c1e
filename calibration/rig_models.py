"""Rig models for model criticism: a measured data set, the DEM rig that simulates each of its configurations, and
the observables extracted the same way from both.

A rig model (see :class:`RingingRigModel`) states

- ``configs``: one dict per measured configuration (spring count, nominal stiffness, ...);
- ``observables`` and ``measured`` (n_configs, n_observables): what is compared, in SI units;
- ``uncertainty`` (n_observables,): the relative measurement uncertainty of each observable (1 sigma), which weights
  the residuals and decides whether a residual is larger than noise;
- ``genes``: the baseline's own parameters, fitted with every candidate (``fixed`` holds those given instead);
- ``knobs``: the physical extensions its DEM scene implements (see ``calibration.mechanisms``);
- ``simulate(cases)``: DEM results for (configuration, parameters) pairs, all as the worlds of batched simulations;
- ``covariates()``: per-configuration quantities a residual may depend on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from warpdem import analysis

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


RINGING_UNCERTAINTY = {"frequency": 0.01, "damping": 0.10, "frequency_late": 0.02, "damping_late": 0.20}
"""default relative 1-sigma uncertainties of the ringing observables: a strain-gauge or displacement record at
2400 Hz gives the frequency of a 2-10 Hz decay to well below 1 %, but the spring stacks of one nominal rate scatter
by a few % (stiffness, hence ~1 % in frequency); log decrements from a few cycles of a hand-hammered decay repeat to
about 10 % (20 % from the second half of a decay alone)."""


def ringdown_observables(t: np.ndarray, x: np.ndarray, late: bool) -> dict[str, float]:
    """Frequency [Hz] and damping ratio of a decay by eqs. (3)-(5) (``warpdem.analysis.ringdown``); with ``late``,
    also of its second half (from a quarter period before its middle peak on): the amplitude dependence that
    separates viscous damping (constant) from dry friction (rising) and a progressive spring (frequency falling).
    NaN where a fit fails (an overdamped or stuck decay)."""
    out = {"frequency": math.nan, "damping": math.nan}
    if late:
        out.update(frequency_late=math.nan, damping_late=math.nan)
    try:
        fit = analysis.ringdown(t, x)
    except ValueError:
        return out
    out["frequency"], out["damping"] = fit.frequency_hz, fit.damping_ratio
    if late and fit.peak_times.size >= 5:
        start = fit.peak_times[fit.peak_times.size // 2] - 0.25 * fit.period_s
        sel = t >= start
        try:
            f2 = analysis.ringdown(t[sel], x[sel], offset=fit.offset)
            out["frequency_late"], out["damping_late"] = f2.frequency_hz, f2.damping_ratio
        except ValueError:
            pass
    return out


class RingingRigModel:
    """The ringing rig (``scenes.ringing``, linear spring model) against measured ringing data.

    Configurations come from the summary's rows (``springs``, optional ``stiffness`` [N/m]: default DIN 2093 of
    Table 2) or, without a summary, from the series' headers. With a displacement or force series for every
    configuration, the observables are extracted from the series (frequency, damping and both over the second
    half of the decay); otherwise they are the summary's ``frequency`` and ``damping``.

    Baseline parameters: the dashpot c [N s/m] acting along the spring, one value for all configurations (fitted
    unless given in ``fixed``). Knobs: pivot_friction [N m], extra_mass [kg], progressive [N/m^3],
    series_stiffness [N/m], free_pose (0/1), sensor_offset [m], sensor_drift [m/s] (on the displacement record).
    """

    rig = "ringing"
    knobs = frozenset({"pivot_friction", "extra_mass", "progressive", "series_stiffness", "free_pose",
                       "sensor_offset", "sensor_drift"})

    def __init__(self, measured: Measured, *, device: str | None = None, fixed: dict[str, float] | None = None,
                 ring_time: float | None = None, settle_time: float = 0.25, hit_amplitude: float = 0.5,
                 load_force: float | None = None, uncertainty: dict[str, float] | None = None,
                 max_worlds: int = 2000) -> None:
        from scenes import paper

        self.device = device
        self.fixed = dict(fixed or {})
        unknown = set(self.fixed) - {"dashpot"}
        if unknown:
            raise ValueError(f"fixed: unknown baseline parameters {sorted(unknown)}; the ringing rig has 'dashpot'")
        self.settle_time, self.hit_amplitude = float(settle_time), float(hit_amplitude)
        self.load_force = float(load_force or paper.LOAD_FORCE)
        self.max_worlds = int(max_worlds)
        s = measured.summary
        if "springs" in s:
            springs = [int(n) for n in s["springs"]]
        else:
            springs = sorted({int(x.config["springs"]) for x in measured.series})
        if not springs:
            raise ValueError("measured data name no configuration (no 'springs' column and no series)")
        if len(set(springs)) != len(springs):
            raise ValueError(f"one row per spring configuration, got springs {springs}")
        for n in springs:
            if n not in paper.SPRING_COUNTS:
                raise ValueError(f"springs must be among {paper.SPRING_COUNTS}, got {n}")
        stiffness = s.get("stiffness", np.array([paper.ringing_row(n)["stiffness_n_per_m"] for n in springs]))
        self.configs = [{"springs": n, "stiffness": float(k)} for n, k in zip(springs, stiffness, strict=True)]
        series = {int(x.config["springs"]): x for x in measured.series}
        self.has_series = bool(series) and all(n in series for n in springs)
        if self.has_series:
            self.observables = ("frequency", "damping", "frequency_late", "damping_late")
            rows = []
            for n in springs:
                x = series[n]
                rows.append([ringdown_observables(x.time, x.values, True)[k] for k in self.observables])
            self.measured = np.array(rows)
            duration = max(float(series[n].time[-1] - series[n].time[0]) for n in springs)
            self.ring_time = float(ring_time or duration)
            self.sample_rate = float(np.median([series[n].sample_rate for n in springs]))
        else:
            missing = [k for k in ("frequency", "damping") if k not in s]
            if missing:
                raise ValueError(f"measured ringing data need series or summary columns {missing}")
            self.observables = ("frequency", "damping")
            self.measured = np.column_stack([s["frequency"], s["damping"]])
            self.ring_time = float(ring_time or 2.0)
            self.sample_rate = paper.SAMPLE_RATE
        unc = dict(RINGING_UNCERTAINTY)
        for k, v in (uncertainty or {}).items():
            if k not in unc:
                raise ValueError(f"uncertainty: unknown observable {k!r}; known {sorted(unc)}")
            if not v > 0:
                raise ValueError(f"uncertainty {k!r} must be positive, got {v!r}")
            unc[k] = float(v)
        self.uncertainty = np.array([unc[k] for k in self.observables])
        self.genes = tuple(g for g in (Gene("dashpot", 10.0, 3e4, log=True, unit="N s/m"),)
                           if g.name not in self.fixed)
        self._geometry: dict[str, float] | None = None

    @property
    def n_configs(self) -> int:
        return len(self.configs)

    def describe_config(self, j: int) -> str:
        c = self.configs[j]
        return f"{c['springs']} springs (k = {c['stiffness']:.3g} N/m)"

    def _spring_force(self) -> float:
        """The spring's static force under the load at the CAD pose [N] (tension positive)."""
        if self._geometry is None:
            from scenes.ringing import gravity_moment
            from scenes.sweep import build_sweep

            tool = build_sweep()
            lever = float(abs(tool.sensor_point[2] - tool.pivot[2]))
            load_point = np.asarray(tool.tip, dtype=np.float64)
            self._geometry = {"force": gravity_moment(tool, self.load_force / 9.81, load_point) / lever}
        return self._geometry["force"]

    def covariates(self) -> dict[str, np.ndarray]:
        """Per configuration: spring count, nominal stiffness [N/m] and nominal static deflection [m]."""
        k = np.array([c["stiffness"] for c in self.configs])
        return {"springs": np.array([c["springs"] for c in self.configs], dtype=float), "stiffness": k,
                "static_deflection": np.abs(self._spring_force()) / k}

    def simulate(self, cases: list[Case], keep_series: bool = False, progress: object | None = None) -> SimOutput:
        """Run every case as a world of batched ringing simulations (at most ``max_worlds`` per simulation)."""
        from scenes.ringing import RingingConfig, run_ringing

        values = np.full((len(cases), len(self.observables)), np.nan)
        static = np.full(len(cases), np.nan)
        series: list[tuple[np.ndarray, np.ndarray]] = []
        for start in range(0, len(cases), self.max_worlds):
            chunk = cases[start:start + self.max_worlds]
            params = [{**self.fixed, **c.params} for c in chunk]
            fields: dict[str, object] = {}
            for knob in ("pivot_friction", "extra_mass", "progressive", "series_stiffness", "free_pose"):
                if any(knob in p for p in params):
                    default = math.inf if knob == "series_stiffness" else 0.0
                    fields[knob] = tuple(float(p.get(knob, default)) for p in params)
            cfg = RingingConfig(
                springs=tuple(self.configs[c.config]["springs"] for c in chunk), spring_model="linear",
                load_force=self.load_force, stiffness=tuple(self.configs[c.config]["stiffness"] for c in chunk),
                dashpot=tuple(float(p["dashpot"]) for p in params), settle_time=self.settle_time,
                ring_time=self.ring_time, hit_amplitude=self.hit_amplitude, sample_rate=self.sample_rate, **fields)
            done, size = start, len(chunk)
            res = run_ringing(cfg, device=self.device,
                              progress=(lambda d, n, what, s0=done, m=size: progress(s0 + m * d / n, len(cases), what))
                              if progress else None)
            for w, p in enumerate(params):
                x = res.displacement[:, w] + p.get("sensor_offset", 0.0) + p.get("sensor_drift", 0.0) * res.time
                obs = ringdown_observables(res.time, x, self.has_series)
                values[start + w] = [obs[k] for k in self.observables]
                static[start + w] = res.static_deflection[w]
                if keep_series:
                    series.append((res.time.copy(), x.copy()))
        return SimOutput(values, {"static_deflection": static}, series if keep_series else None)


def make_rig_model(rig: str, measured: Measured, **kw: object) -> RingingRigModel:
    """The rig model of ``rig`` ("ringing"; "soil-bin" is not built yet) for a measured data set."""
    if rig == "ringing":
        return RingingRigModel(measured, **kw)
    if rig == "soil-bin":
        raise NotImplementedError("the soil-bin rig model for diagnosis is not built yet (see the issue's notes)")
    raise ValueError(f"rig must be 'ringing' or 'soil-bin', got {rig!r}")
