"""The ringing calibration of the passive tool within physical bounds: one tool, eight stacks, fitted jointly.

Table 2's eight frequencies are fitted by the closed-form ringing rig of ``scenes.passive_tool`` (checked against
the simulated rig in tests/test_passive_tool.py), with every free number inside :data:`scenes.passive_tool.BOUNDS`:

- model "one rate": the DIN 2093 rates of all stacks times one factor, the tool's inertia factor, one compliance in
  series with every stack and the load's riding fraction: four numbers for eight frequencies;
- model "rate per stack": each stack its own rate factor within the DIN tolerance (the same discs re-stacked still
  differ), with the same tool numbers.

Damping is not fitted: each stack's dashpot gives the ringing rig Table 2's measured damping ratio (the ratios,
0.04-0.27, follow no trend with the stack: stack friction). A number that ends on its bound is reported as such:
the data ask for more than the physical range allows, and the cause lies outside the model. What the fit cannot
reach is reported per configuration, never absorbed into a number out of range.

:func:`fit_joint` fits Table 2's frequencies and Table 3's mean displacements together with one tool: the shank
length (the pivot's height, which the paper does not give), the rate factor and the inertia factor are shared by
both rigs; the mounts are either shared (one series compliance) or each rig's own (the ringing instrument's series
compliance and riding load; the soil bin's holder's compliance and preload). Table 3's displacement is the closed
form's reading under the soil's moment about the pivot, the lab's passive draught times a lever measured in the
simulated soil bin at one shank length and moved to any other exactly (a force's moment about a point raised by dL
grows by its horizontal component times dL).

Afterwards :func:`simulate` runs warpdem's ringing rig (linear springs) built from the fitted description and
reads frequency and damping from its record as the paper does (eqs. 3-5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from scenes import paper
from scenes.passive_tool import BOUNDS, PassiveTool, bound_status

MODELS = ("one rate", "rate per stack")
MOUNTS = ("shared", "per rig")
FREQUENCY_TOLERANCE = 0.05
"""the issue's tolerance on a ringing frequency (relative): the joint fit's scale of a frequency residual."""
DISPLACEMENT_TOLERANCE = (1e-3, 0.25)
"""the issue's tolerance on a mean displacement: 1 mm or 25 %, whichever is larger: the joint fit's scale of a
displacement residual."""
BOUND_RTOL = 1e-3
"""a jointly fitted number within this fraction of a bound is reported at it (its cost is flat to 1e-4 there)."""


@dataclass
class ToolFit:
    """A bounded fit of Table 2's frequencies."""

    model: str
    tool: PassiveTool
    rows: list[dict[str, float]]
    """per configuration: springs, measured and fitted frequency [Hz], relative error [%]."""
    bounds: dict[str, str]
    """per fitted number: "inside", "at its lower bound", "at its upper bound"."""
    rms_pct: float
    """root mean square of the relative frequency errors [%]."""
    within_5pct: int
    """configurations whose fitted frequency lies within 5 % of the measured."""

    def to_dict(self) -> dict[str, object]:
        return {"model": self.model, "tool": self.tool.to_dict(), "rows": self.rows, "bounds": self.bounds,
                "rms_pct": self.rms_pct, "within_5pct": self.within_5pct}


def _stiffness(compliance: float) -> float:
    """A series stiffness [N/m] from the compliance a fit varies [m/N] (0: none, inf)."""
    return math.inf if compliance <= 0 else 1.0 / compliance


def _unpack(x: np.ndarray, base: PassiveTool, model: str) -> PassiveTool:
    inertia, compliance, phi = float(x[0]), float(x[1]), float(x[2])
    kw: dict[str, object] = {"inertia_factor": inertia, "load_mass_fraction": phi,
                             "series_stiffness": _stiffness(compliance)}
    if model == "one rate":
        kw["rate_factor"] = float(x[3])
    else:
        kw["rate_factors"] = {n: float(v) for n, v in zip(paper.SPRING_COUNTS, x[3:], strict=True)}
    return replace(base, **kw)


def fit_table2(model: str = "one rate", base: PassiveTool | None = None, starts: int = 8, seed: int = 0) -> ToolFit:
    """Fit Table 2's frequencies with the closed-form rig, every number within its bound (module docstring).

    ``base``: the description whose other numbers (damping, preload, offsets) are kept. ``starts``: least-squares
    runs from random points inside the bounds (the best is kept).
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    base = base or PassiveTool()
    tool = base.sweep()
    measured = np.array([paper.ringing_row(n)["measured_freq_hz"] for n in paper.SPRING_COUNTS])
    rate_lo, rate_hi = BOUNDS["rate_factor"]
    n_rates = 1 if model == "one rate" else len(paper.SPRING_COUNTS)
    lo = np.array([BOUNDS["inertia_factor"][0], 0.0, 0.0] + [rate_lo] * n_rates)
    hi = np.array([BOUNDS["inertia_factor"][1], 1.0 / BOUNDS["series_stiffness"][0], 1.0] + [rate_hi] * n_rates)

    def residual(x: np.ndarray) -> np.ndarray:
        d = _unpack(x, base, model)
        return np.log([d.ringing_frequency(n, tool) for n in paper.SPRING_COUNTS] / measured)

    rng = np.random.default_rng(seed)
    best = None
    for k in range(starts):
        x0 = np.array([1.0, 0.0, 0.0] + [1.0] * n_rates) if k == 0 else lo + rng.random(len(lo)) * (hi - lo)
        r = least_squares(residual, np.clip(x0, lo, hi), bounds=(lo, hi), x_scale=np.maximum(hi - lo, 1e-9))
        if best is None or r.cost < best.cost:
            best = r
    fitted = _unpack(best.x, base, model)
    rows = []
    for n, f_m in zip(paper.SPRING_COUNTS, measured, strict=True):
        f = fitted.ringing_frequency(n, tool)
        rows.append({"springs": n, "measured_freq_hz": float(f_m), "fit_freq_hz": f,
                     "error_pct": 100.0 * (f - f_m) / f_m, "rate_n_per_m": fitted.rate(n),
                     "effective_rate_n_per_m": fitted.effective_rate(n), "dashpot_n_s_per_m": fitted.dashpot(n, tool)})
    bounds = fitted.bounds_report(("inertia_factor", "series_stiffness", "load_mass_fraction")
                                  + (("rate_factor",) if model == "one rate" else ()))
    if model == "rate per stack":
        for n, v in fitted.rate_factors.items():
            bounds[f"rate_factor[{n}]"] = bound_status(v, BOUNDS["rate_factor"])
    errors = np.array([r["error_pct"] for r in rows])
    return ToolFit(model, fitted, rows, bounds, float(np.sqrt(np.mean(errors**2))),
                   int(np.sum(np.abs(errors) <= 5.0)))


def simulate(fit: ToolFit, device: str | None = None) -> list[dict[str, float]]:
    """warpdem's ringing rig built from the fitted description, all eight stacks as worlds of one simulation:
    per configuration the simulated frequency and damping ratio (eqs. 3-5 on the sensor's record) beside the
    closed form's and Table 2's."""
    from scenes.ringing import run_ringing

    res = run_ringing(fit.tool.ringing_config(), device=device, tool=fit.tool.sweep())
    out = []
    for row, f, z in zip(fit.rows, res.frequency_hz, res.damping_ratio, strict=True):
        n = row["springs"]
        out.append({"springs": n, "sim_freq_hz": float(f), "sim_damping": float(z), "fit_freq_hz": row["fit_freq_hz"],
                    "measured_freq_hz": row["measured_freq_hz"],
                    "measured_damping": paper.ringing_row(n)["measured_damping"],
                    "sim_error_pct": 100.0 * (float(f) - row["measured_freq_hz"]) / row["measured_freq_hz"]})
    return out


@dataclass
class JointFit:
    """Table 2's frequencies and Table 3's mean displacements fitted with one tool (:func:`fit_joint`)."""

    mounts: str
    tool: PassiveTool
    """the fitted description: its ringing rig and its soil bin (``bin_series_stiffness``, ``preload``)."""
    frequency_rows: list[dict[str, float]]
    """per configuration: springs, measured and fitted frequency [Hz], error [%]."""
    displacement_rows: list[dict[str, float]]
    """per configuration: springs, lab passive draught [N], lever about the pivot [m], lab and fitted mean
    displacement [mm], within (1 mm or 25 %: 1.0, else 0.0)."""
    bounds: dict[str, str]
    cost: float
    """half the sum of squared residuals, each in units of its tolerance."""
    profile: list[dict[str, float]]
    """the best cost and its parts at each shank length held fixed [m]."""

    def to_dict(self) -> dict[str, object]:
        return {"mounts": self.mounts, "tool": self.tool.to_dict(), "frequency_rows": self.frequency_rows,
                "displacement_rows": self.displacement_rows, "bounds": self.bounds, "cost": self.cost,
                "profile": self.profile}


_JOINT_NAMES = {"shared": ("shank_length", "rate_factor", "inertia_factor", "series_stiffness", "load_mass_fraction",
                           "preload"),
                "per rig": ("shank_length", "rate_factor", "inertia_factor", "series_stiffness", "load_mass_fraction",
                            "preload", "bin_series_stiffness")}


def _joint_tool(x: np.ndarray, mounts: str, base: PassiveTool) -> PassiveTool:
    kw: dict[str, object] = {}
    for name, v in zip(_JOINT_NAMES[mounts], x, strict=True):
        kw[name] = _stiffness(float(v)) if name.endswith("series_stiffness") else float(v)
    return replace(base, **kw)


def fit_joint(arms: dict[int, float], arm_shank_length: float, mounts: str = "per rig",
              base: PassiveTool | None = None, starts: int = 6, seed: int = 0,
              profile: tuple[float, ...] = (0.30, 0.35, 0.40, 0.45, 0.50, 0.60, 0.70, 0.80),
              held_out: tuple[int, ...] = (), targets: dict[str, np.ndarray] | None = None,
              shank_length: float | None = None) -> JointFit:
    """Fit Table 2's eight frequencies and Table 3's eight mean displacements with one tool, every number within
    :data:`scenes.passive_tool.BOUNDS`.

    Args:
        arms: per spring count, the soil's moment about the pivot per unit of draught [m], measured in the
            simulated soil bin with the shank ``arm_shank_length`` [m] (``passive_study.soil_levers``). At a shank
            length L the lever is arms[n] + (L - arm_shank_length).
        mounts: "shared": one series compliance for both rigs (``bin_series_stiffness`` None); "per rig": the
            soil bin's holder has its own (module docstring).
        base: the description whose other numbers (damping, offsets) are kept.
        starts: least-squares runs from random points inside the bounds (the best is kept).
        profile: shank lengths [m] at which the fit is repeated with the shank held: how well the data pin it.
        held_out: spring counts whose displacement is left out of the fit (and predicted): a cross-validation.
        targets: other data than the paper's, each (8,) in SPRING_COUNTS order: "freq_hz" (Table 2's ringing
            frequencies [Hz]), "disp_m" (Table 3's mean displacements [m]), "draught_n" (Table 3's passive draught
            [N]).
        shank_length: hold the shank length at this value [m] (None: fitted).

    Residuals: log(f / f_lab) / 0.05 for each frequency; (d - d_lab) / max(1 mm, 0.25 d_lab) for each
    displacement, d the closed form's lab reading (zeroed at rest) under the moment D_lab x lever, D_lab Table 3's
    passive draught.
    """
    if mounts not in MOUNTS:
        raise ValueError(f"mounts must be one of {MOUNTS}, got {mounts!r}")
    missing = [n for n in paper.SPRING_COUNTS if n not in arms]
    if missing:
        raise ValueError(f"arms lacks spring counts {missing}")
    base = base or PassiveTool()
    if targets is None:
        t3 = paper.table("soil_bin_measured")
        row = {int(n): i for i, n in enumerate(t3["springs"])}
        targets = {"draught_n": [float(t3["passive_draught_mean_n"][row[n]]) for n in paper.SPRING_COUNTS],
                   "disp_m": [1e-3 * float(t3["displacement_mean_mm"][row[n]]) for n in paper.SPRING_COUNTS],
                   "freq_hz": [paper.ringing_row(n)["measured_freq_hz"] for n in paper.SPRING_COUNTS]}
    draught, d_lab, f_lab = (np.asarray(targets[k], dtype=np.float64) for k in ("draught_n", "disp_m", "freq_hz"))
    d_tol = np.maximum(DISPLACEMENT_TOLERANCE[0], DISPLACEMENT_TOLERANCE[1] * np.abs(d_lab))
    names = _JOINT_NAMES[mounts]
    span = {"shank_length": BOUNDS["shank_length"], "rate_factor": BOUNDS["rate_factor"],
            "inertia_factor": BOUNDS["inertia_factor"], "load_mass_fraction": BOUNDS["load_mass_fraction"],
            "preload": BOUNDS["preload"], "series_stiffness": (0.0, 1.0 / BOUNDS["series_stiffness"][0]),
            "bin_series_stiffness": (0.0, 1.0 / BOUNDS["series_stiffness"][0])}
    lo, hi = np.array([span[k][0] for k in names]), np.array([span[k][1] for k in names])

    def predict(x: np.ndarray) -> tuple[PassiveTool, np.ndarray, np.ndarray, np.ndarray]:
        tool = _joint_tool(x, mounts, base)
        sweep = tool.sweep()
        lever = np.array([arms[n] + tool.shank_length - arm_shank_length for n in paper.SPRING_COUNTS])
        f = np.array([tool.ringing_frequency(n, sweep) for n in paper.SPRING_COUNTS])
        d = np.array([tool.lab_reading(n, m, sweep) for n, m in zip(paper.SPRING_COUNTS, draught * lever,
                                                                     strict=True)])
        return tool, f, d, lever

    fitted = np.array([n not in held_out for n in paper.SPRING_COUNTS])

    def residual(x: np.ndarray) -> np.ndarray:
        _, f, d, _ = predict(x)
        return np.concatenate([np.log(f / f_lab) / FREQUENCY_TOLERANCE, ((d - d_lab) / d_tol)[fitted]])

    def solve(fixed_shank: float | None) -> object:
        lo_k, hi_k = lo.copy(), hi.copy()
        if fixed_shank is not None:
            lo_k[0], hi_k[0] = fixed_shank, fixed_shank * (1 + 1e-12)
        rng = np.random.default_rng(seed)
        best = None
        for _ in range(starts):
            x0 = lo_k + rng.random(len(lo_k)) * (hi_k - lo_k)
            r = least_squares(residual, x0, bounds=(lo_k, hi_k), x_scale=np.maximum(hi_k - lo_k, 1e-9))
            if best is None or r.cost < best.cost:
                best = r
        return best

    best = solve(shank_length)
    if shank_length is not None:
        best.x[0] = shank_length  # exactly the held value (its bounds are a hair apart)
    tool, f, d, lever = predict(best.x)
    prof = []
    for shank in profile:
        r = solve(shank)
        res = r.fun
        prof.append({"shank_length": shank, "cost": float(r.cost), "frequency_cost": float(0.5 * np.sum(res[:8] ** 2)),
                     "displacement_cost": float(0.5 * np.sum(res[8:] ** 2))})
    freq_rows = [{"springs": n, "measured_freq_hz": float(fm), "fit_freq_hz": float(ff),
                  "error_pct": float(100.0 * (ff - fm) / fm)}
                 for n, fm, ff in zip(paper.SPRING_COUNTS, f_lab, f, strict=True)]
    disp_rows = [{"springs": n, "lab_draught_n": float(D), "lever_m": float(lv), "lab_disp_mm": 1e3 * float(dl),
                  "fit_disp_mm": 1e3 * float(dd), "within": float(abs(dd - dl) <= tol),
                  "held_out": float(n in held_out)}
                 for n, D, lv, dl, dd, tol in zip(paper.SPRING_COUNTS, draught, lever, d_lab, d, d_tol, strict=True)]
    bounds = {}
    for name, v in zip(names, best.x, strict=True):
        if name.endswith("series_stiffness"):
            bounds[name] = bound_status(getattr(tool, name), BOUNDS["series_stiffness"], BOUND_RTOL)
        else:
            bounds[name] = bound_status(float(v), BOUNDS[name], BOUND_RTOL)
    return JointFit(mounts, tool, freq_rows, disp_rows, bounds, float(best.cost), prof)
