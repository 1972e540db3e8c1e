"""Table 3 with the passive tool described once: the bounded ringing fit, its tool in the soil bin, a pitch sweep.

Stages (each written to ``OUT/<stage>.json`` when done; a soil-bin stage checkpoints into ``OUT/checkpoints/`` and
resumes where a deadline or a kill left it, so the same call continues):

1. ``ringing``: Table 2 fitted within the physical bounds (``calibration.tool_fit``, both models), and warpdem's
   ringing rig simulated with the "one rate" tool (every stack a world of one simulation);
2. ``rigid``: the rigid tool at each distinct speed of Table 3, plus the pitch sweep (the rigid tool turned back
   about its pivot by ``PITCHES`` degrees at ``PITCH_SPEED``): worlds of one simulation on one bed;
3. one stage per tool variant (``VARIANTS``): the eight passive configurations at Table 3's speeds, the
   displacement read as the lab reads it (zeroed on the tool at rest on its springs);
4. ``joint`` (CPU, after a "din_preload" stage): Table 2's frequencies and Table 3's displacements fitted with one
   tool (:func:`joint_record`), the soil's levers read off this run; :func:`joint_record` over several runs (beds)
   is ``warpdem passive-tool --joint-from``.

Finished runs on several beds make one Table 3 with :func:`beds_table` (``warpdem passive-tool --beds-from``).

The soil is one of :data:`SOILS` (default the paper-scale workflow's calibrated soil). :func:`write_report` writes
``report.md`` and the figures.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from scenes import analysis, figures, paper
from scenes import soil_bin as sb
from scenes.passive_tool import G, PassiveTool, from_dict, lever, load_toml
from scenes.sweep import SweepParams, build_sweep
from warpdem.errors import InputError
from warpdem.files import write_atomic, write_text_atomic

from .genes import soil_overrides
from .tool_fit import MOUNTS, fit_joint, fit_table2, simulate

PITCHES = (-4.0, -2.0, 2.0, 4.0, 6.0, 8.0, 9.0)
"""backward rotations of the rigid tool about its pivot [deg] besides 0 (the lab's displacements, 0.2-12.5 mm at
the 0.1 m sensor lever, are 0.1-7.2 deg)."""
PITCH_SPEED = 0.62
"""carriage speed of the pitch sweep [m/s] (Table 3's median speed)."""
SOILS = {
    "workflow": {"friction_angle": 29.51974323486036, "normal_cohesion": 430.4031570736236,
                 "eta_roll": 0.0015063318135471741, "fragile": True, "settle_time": 0.5},
    "bonded": {"friction_angle": 6.3017, "normal_cohesion": 4 * 22464.06, "eta_roll": 0.0632, "fragile": False,
               "settle_time": 1.0},
    "dense": {"friction_angle": 6.3017, "normal_cohesion": 22464.06, "eta_roll": 0.0632, "fragile": False,
              "settle_time": 1.0, "deposit_friction": 0.0},
}
"""the soils of the study (shear cohesion = half the normal cohesion; eta_twist = eta_roll):

- "workflow": the paper-scale workflow's calibrated soil (docs/runs/table3-paper-h100/summary.json, screening
  rank 1): its bonds break under the bed's own weight, its shear box gives 0.3-0.6 kPa; the bed settles 0.5 s;
- "bonded": GA set 11 with 4x its cohesions (89.9 / 44.9 kPa, 1.8x the paper's gene range), bonds that yield instead
  of breaking (fragile False), set on a bed settled 1.0 s: at paper scale its rigid draught is 337 N at 0.68 m/s and
  330 N at 0.52 m/s, its shear box c 6.7-7.6 kPa and phi 32-34 deg (docs/runs/bond_protocols_h100);
- "dense": GA set 11 as published with yielding bonds on a bed deposited without friction (coordination 8.7, the
  paper's 9.55), settled 1.0 s: rigid draught 369 N at 0.68 m/s (+10 % on the lab's), shear box c 2.1-2.3 kPa
  (docs/runs/bond_protocols_h100, "A dense bed"). Not calibrated: set 11 as printed."""
PRELOAD_TABLE3 = 1.44e-3
"""the stack preload [m] that Table 3's own displacements imply (d = 1.18 kN / k_DIN - 1.44 mm, r = 0.98): a
variant with it is not an independent prediction of the displacements."""
VARIANTS = ("fitted", "din_preload", "described", "described_offsets")
"""the tool variants of the passive stages: "fitted" (Table 2 fitted within bounds, one rate factor; no preload,
no offsets), "din_preload" (DIN 2093 rates, CAD inertia, no series compliance, PRELOAD_TABLE3), "described"
(the study's ``tool_file``, e.g. the joint fit's ``tool_joint.toml``; not run by default) and "described_offsets"
(the same tool with Table 2's support offsets, ``support_offsets = true``: on the study's own bed, so that the
offsets' effect is read against the same soil)."""
DEFAULT_VARIANTS = ("fitted", "din_preload")


def _genes(soil: dict) -> dict:
    """The workflow soil's record as the study's settings have always held it (its genes only)."""
    return {k: soil[k] for k in ("friction_angle", "normal_cohesion", "eta_roll")}


def calibrated_soil_of(folder: str) -> dict:
    """The soil of a ``calibrate draught`` / ``calibrate soil`` folder (its best individual and bed protocol), as
    :data:`SOILS` holds a soil; InputError when ``folder`` is neither a soil's name nor such a folder."""
    from .problems import calibrated_soil

    if not Path(folder).is_dir():
        raise InputError(f"soil must be one of {sorted(SOILS)} or a calibration's folder, got {folder!r}")
    cal = calibrated_soil(folder)
    if cal["assembly"] != "C":
        raise InputError(f"soil {folder!r}: calibrated with assembly {cal['assembly']}; the study's beds are "
                         "assembly C")
    return {k: cal[k] for k in ("friction_angle", "normal_cohesion", "eta_roll", "fragile", "settle_time",
                                "deposit_friction")}


def _json(path: Path, data: object) -> None:
    write_atomic(path, lambda tmp: Path(tmp).write_text(json.dumps(sb.json_safe(data), indent=1)))


def _table3() -> dict[int, dict[str, float]]:
    t = paper.table("soil_bin_measured")
    return {int(n): {k: float(v[i]) for k, v in t.items()} for i, n in enumerate(t["springs"])}


def _soil_folder_resolved(meta: dict[str, object]) -> dict[str, object]:
    """A study's record with its soil folder (``soil_name``, where it names a calibration's folder) as an absolute
    path: the same folder spelled another way (relative, absolute, through a link) is the same study."""
    name = meta.get("soil_name")
    if isinstance(name, str) and name not in SOILS and Path(name).is_dir():
        return {**meta, "soil_name": str(Path(name).resolve())}
    return meta


class PassiveStudy:
    """The study's folder and its stages (module docstring)."""

    def __init__(self, out: str | Path, *, scale: str = "paper", device: str | None = None, seed: int = 0,
                 travel: float | None = None, steady_travel: float | None = None, soil: str = "workflow",
                 shank_length: float = SweepParams.shank_length, pitches: tuple[float, ...] = PITCHES,
                 log: object = print, tool_file: str | Path | None = None) -> None:
        self.soil = SOILS.get(soil) or calibrated_soil_of(soil)
        settle_time = self.soil["settle_time"]
        self.out = Path(out)
        self.out.mkdir(parents=True, exist_ok=True)
        self.device, self.log = device, log
        self.shank_length = float(shank_length)
        self.described = None if tool_file is None else load_toml(tool_file)
        if self.described is not None and self.described.shank_length != self.shank_length:
            raise InputError(f"tool file {str(tool_file)!r}: its shank_length {self.described.shank_length!r} m is "
                             f"not the study's --shank-length {self.shank_length!r} m (the rigid reference's)")
        self.pitches = tuple(float(p) for p in pitches if p != 0.0)
        self.sweep = PassiveTool(shank_length=self.shank_length).sweep()
        self.config = sb.SoilBinConfig(scale=scale, assembly="C", springs=(0,), seed=seed, travel=travel,
                                       steady_travel=steady_travel, settle_time=settle_time, support_offset=False,
                                       fragile=self.soil["fragile"],
                                       deposit_friction=self.soil.get("deposit_friction", sb.DEPOSIT_FRICTION))
        meta = {"scale": scale, "seed": seed, "travel": travel, "steady_travel": steady_travel,
                "settle_time": settle_time, "soil": _genes(self.soil) if soil == "workflow" else self.soil,
                "pitches": self.pitches, "pitch_speed": PITCH_SPEED}
        if soil != "workflow":
            meta["soil_name"] = soil
        if self.shank_length != SweepParams.shank_length:
            meta["shank_length"] = self.shank_length
        p = self.out / "study.json"
        if p.exists():
            if _soil_folder_resolved(json.loads(p.read_text())) != _soil_folder_resolved(sb.json_safe(meta)):
                raise ValueError(f"{self.out} holds a study with other settings ({p}); choose another folder")
            return  # the same study: its record stays as first written (a soil folder spelled as then)
        _json(p, meta)

    def _done(self, stage: str) -> dict | None:
        p = self.out / f"{stage}.json"
        return json.loads(p.read_text()) if p.exists() else None

    def ringing(self) -> dict:
        if (done := self._done("ringing")) is not None:
            return done
        t0 = time.perf_counter()
        base = PassiveTool(shank_length=self.shank_length)
        fits = {m: fit_table2(m, base) for m in ("one rate", "rate per stack")}
        sim = simulate(fits["one rate"], device=self.device)
        out = {"fits": {m: f.to_dict() for m, f in fits.items()}, "simulated": sim,
               "wall_s": time.perf_counter() - t0}
        (self.out / "tool_fitted.toml").write_text(fits["one rate"].tool.to_toml())
        _json(self.out / "ringing.json", out)
        return out

    def tool(self, variant: str) -> PassiveTool:
        if variant == "fitted":
            return from_dict(self.ringing()["fits"]["one rate"]["tool"])  # fitted on this study's geometry
        if variant == "din_preload":
            return PassiveTool(preload=PRELOAD_TABLE3, shank_length=self.shank_length)
        if variant in ("described", "described_offsets"):
            if self.described is None:
                raise InputError(f"variant {variant!r} needs a tool file (--tool)")
            return replace(self.described, support_offsets=True) if variant == "described_offsets" else self.described
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")

    def _run(self, stage: str, springs: list[int], speeds: list[float], deadline: float | None,
             passive_tool: PassiveTool | None = None, pitch: list[float] | None = None) -> dict:
        if (done := self._done(stage)) is not None:
            return done
        cfg = self.config
        bed = sb.bed_for(cfg, device=self.device, cache_dir=self.out / "beds")
        n = len(springs)
        soil = self.soil
        overrides = soil_overrides(soil, n)
        self.log(f"{stage}: {n} worlds, springs {springs}, speeds {speeds} m/s" + (f", pitch {pitch}" if pitch else ""))
        t0 = time.perf_counter()
        run = sb.run_soil_bin(cfg, springs, bed=bed, device=self.device, speeds=speeds, soil_overrides=overrides,
                              checkpoint=self.out / "checkpoints" / stage, deadline=deadline,
                              passive_tool=passive_tool, pitch=pitch, tool=self.sweep)
        keep = {"time": run.time, "travel": run.travel, **{k: run.series[k] for k in ("draught", "displacement")}}
        write_atomic(self.out / f"{stage}.npz", lambda tmp: np.savez_compressed(tmp, **keep))
        out = {"rows": run.steady, "springs": springs, "speeds": speeds, "pitch": pitch, "dt": run.dt,
               "steps": run.steps, "spheres_per_world": run.n_spheres, "particles": run.n_particles,
               "rebuilds": run.rebuilds, "wall_s": time.perf_counter() - t0, "settle_s": run.settle_s,
               "steps_s": run.steps_s, "bed_wall_s": float(bed.wall_s), "device": self.device,
               "tool": None if passive_tool is None else passive_tool.to_dict()}
        _json(self.out / f"{stage}.json", out)
        return out

    def rigid(self, deadline: float | None = None) -> dict:
        t3 = _table3()
        speeds = sorted({round(r["speed_mean_m_s"], 2) for r in t3.values()})
        pitch = [0.0] * len(speeds) + list(self.pitches)
        return self._run("rigid", [0] * len(pitch), speeds + [PITCH_SPEED] * len(self.pitches), deadline,
                         pitch=pitch if self.pitches else None)

    def passive(self, variant: str, deadline: float | None = None) -> dict:
        t3 = _table3()
        springs = list(paper.SPRING_COUNTS)
        return self._run(f"passive_{variant}", springs, [t3[n]["speed_mean_m_s"] for n in springs], deadline,
                         passive_tool=self.tool(variant))

    def run(self, budget: float | None = None, variants: tuple[str, ...] = DEFAULT_VARIANTS) -> None:
        """Every stage not yet done, in order; with ``budget`` [s] a soil-bin stage stops at its deadline into its
        checkpoint (``warpdem.errors.BudgetExhausted``) and the same call continues it."""
        deadline = None if budget is None else time.time() + budget
        self.ringing()
        self.rigid(deadline)
        for v in variants:
            self.passive(v, deadline)
        if not (self.out / "joint.json").exists() and (self.out / "passive_din_preload.json").exists():
            _json(self.out / "joint.json", joint_record([self.out]))
        write_report(self.out)


# ----------------------------------------------------------------------------------------------------- report
def _rigid_by_speed(rigid: dict) -> dict[float, dict]:
    pitch = rigid["pitch"] or [0.0] * len(rigid["rows"])
    return {round(r["speed"], 2): r for r, p in zip(rigid["rows"], pitch, strict=True) if p == 0.0}


def passive_table(rigid: dict, passive: dict) -> list[dict[str, float]]:
    """Per configuration: simulated and lab displacement (mean, std) and reduction, each reduction against the
    rigid run at the passive run's speed (Table 3's pairing), with its standard error."""
    t3 = _table3()
    by_speed = _rigid_by_speed(rigid)
    rows = []
    for r in passive["rows"]:
        n = int(r["springs"])
        rig = by_speed[round(r["speed"], 2)]
        red, red_se = sb.reduction(r["draught_mean"], r["draught_sem"], rig["draught_mean"], rig["draught_sem"])
        lab = t3[n]
        rows.append({"springs": n, "speed": r["speed"], "rigid_n": rig["draught_mean"], "passive_n": r["draught_mean"],
                     "reduction_pct": red, "reduction_se": red_se, "lab_reduction_pct": lab["reduction_pct"],
                     "disp_mm": 1e3 * r["displacement_mean"], "disp_std_mm": 1e3 * r["displacement_std"],
                     "disp_sem_mm": 1e3 * r["displacement_sem"], "lab_disp_mm": lab["displacement_mean_mm"],
                     "lab_disp_std_mm": lab["displacement_std_mm"]})
    return rows


def displacement_verdict(rows: list[dict[str, float]]) -> dict[str, object]:
    """The issue's displacement criteria: within 1 mm or 25 % (count of 8), signs, rising trend (Spearman), std
    within a factor 2 (count)."""
    from scipy.stats import spearmanr

    close = [abs(r["disp_mm"] - r["lab_disp_mm"]) <= max(1.0, 0.25 * abs(r["lab_disp_mm"])) for r in rows]
    signs = [math.copysign(1, r["disp_mm"]) == math.copysign(1, r["lab_disp_mm"]) for r in rows]
    ratio = [r["disp_std_mm"] / r["lab_disp_std_mm"] for r in rows]
    rho = float(spearmanr([r["springs"] for r in rows], [r["disp_mm"] for r in rows]).statistic)
    return {"within": int(sum(close)), "signs": int(sum(signs)), "trend_spearman": rho,
            "std_within_2x": int(sum(0.5 <= q <= 2.0 for q in ratio)), "std_ratio": ratio}


def reduction_verdict(rows: list[dict[str, float]]) -> dict[str, float]:
    err = [r["reduction_pct"] - r["lab_reduction_pct"] for r in rows]
    signs = sum(math.copysign(1, r["reduction_pct"]) == math.copysign(1, r["lab_reduction_pct"]) for r in rows)
    return {"mae_pp": float(np.mean(np.abs(err))), "signs": int(signs),
            "max_se_pp": float(max(r["reduction_se"] for r in rows))}


def pitch_table(rigid: dict) -> list[dict[str, float]]:
    """The pitch sweep: draught per pitch [N] and its change against pitch 0 at the same speed [%]."""
    rows = [(p, r) for r, p in zip(rigid["rows"], rigid["pitch"], strict=True) if round(r["speed"], 2) == PITCH_SPEED]
    base = next(r for p, r in rows if p == 0.0)
    out = []
    for p, r in sorted(rows, key=lambda x: x[0]):
        change, se = sb.reduction(r["draught_mean"], r["draught_sem"], base["draught_mean"], base["draught_sem"])
        out.append({"pitch_deg": p, "draught_n": r["draught_mean"], "draught_sem": r["draught_sem"],
                    "change_pct": -change, "change_se": se})
    return out


def line_fit(x: list[float], y: list[float], se: list[float] | None = None) -> tuple[float, float]:
    """Slope of a straight line through (x, y) [y per x] and its standard error: weighted by 1 / se^2 when
    ``se`` is given (the points' own standard errors), else ordinary least squares (the scatter's)."""
    x_a, y_a = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    w = np.ones_like(x_a) if se is None else 1.0 / np.asarray(se, dtype=np.float64) ** 2
    xm = np.sum(w * x_a) / np.sum(w)
    sxx = np.sum(w * (x_a - xm) ** 2)
    slope = float(np.sum(w * (x_a - xm) * y_a) / sxx)
    if se is not None:
        return slope, float(math.sqrt(1.0 / sxx))
    resid = y_a - (np.mean(y_a) + slope * (x_a - xm))
    return slope, float(math.sqrt(np.sum(resid**2) / (len(x_a) - 2) / sxx))


def moment_arms(rows: list[dict[str, float]], tool: PassiveTool) -> list[dict[str, float]]:
    """Per configuration, the stack's force [N] that the mean displacement implies through the tool's own stack
    law, and the lever of the draught about the pivot it gives [m] (force x stack lever / draught), in the
    simulation and, with the same stack, in the laboratory (Table 3's displacement and passive draught)."""
    sweep = tool.sweep()
    a = lever(sweep)
    t3 = _table3()
    out = []
    for r in rows:
        n = r["springs"]
        f_sim = tool.stack_force(n, 1e-3 * r["disp_mm"], sweep)
        f_lab = tool.stack_force(n, 1e-3 * r["lab_disp_mm"], sweep)
        out.append({"springs": n, "force_n": f_sim, "arm_m": f_sim * a / r["passive_n"], "lab_force_n": f_lab,
                    "lab_arm_m": f_lab * a / t3[n]["passive_draught_mean_n"]})
    return out


def passive_runs(folders: list[str | Path], variant: str = "din_preload") -> list[dict]:
    """The finished passive stage ``variant`` of each folder (its ``passive_<variant>.json``), all of one shank
    length; a folder without one, an unreadable record or runs of different shanks are refused by name."""
    runs, shanks = [], set()
    for folder in folders:
        p = Path(folder) / f"passive_{variant}.json"
        if not p.is_file():
            raise InputError(f"{str(folder)!r} holds no finished {variant!r} passive run ({p.name})")
        try:
            data = json.loads(p.read_text())
            shanks.add(from_dict(data["tool"]).shank_length)  # runs older than the field: its default
        except (OSError, ValueError, KeyError, TypeError, InputError) as e:
            raise InputError(f"{str(p)!r} cannot be read as a passive run: {e}") from None
        runs.append(data)
    if len(shanks) != 1:
        raise InputError(f"the runs' shank lengths differ ({sorted(shanks)} m); give runs of one shank")
    return runs


def soil_levers(folders: list[str | Path], variant: str = "din_preload") -> tuple[dict[int, float], float]:
    """The soil's moment about the pivot per unit of draught [m], per spring count, from passive runs
    (:func:`passive_runs`): at each configuration's mean displacement, the moment that balances the tool's stack and
    weight there (the closed form's statics, :meth:`PassiveTool.sensor_reading`'s balance) over the mean draught;
    averaged over the folders (beds). Returns (levers, the runs' shank length [m])."""
    levers: dict[int, list[float]] = {}
    for data in passive_runs(folders, variant):
        tool = from_dict(data["tool"])
        sweep = tool.sweep()
        a, c = lever(sweep), sweep.com - sweep.pivot
        weight = tool.inertia_factor * sweep.mass * G
        for r in data["rows"]:
            n = int(r["springs"])
            reading = tool.sensor_reading(n, 0.0, sweep) + r["displacement_mean"]
            moment = a * tool.stack_force(n, r["displacement_mean"], sweep) - weight * (c[1] + c[2] * reading / a)
            levers.setdefault(n, []).append(moment / r["draught_mean"])
    return {n: float(np.mean(v)) for n, v in sorted(levers.items())}, tool.shank_length


def beds_table(folders: list[str | Path], variant: str = "described") -> list[dict[str, object]]:
    """Table 3 over several beds: each folder a finished study (its ``rigid.json`` and ``passive_<variant>.json``)
    on its own bed, each reduction taken against its own bed's rigid run (:func:`passive_table`).

    Returns per configuration (8,): springs; per_bed_pct (b,) [%]; reduction_pct, the beds' mean [%], and
    reduction_se, the beds' standard error (sample std / sqrt(b)) [%] (0 for one bed); own_se_pct, the records'
    own combined standard error (root mean square of the beds' / sqrt(b)) [%]; disp_mm and disp_std_mm, the beds'
    means of each bed's mean and std [mm]; disp_between_std_mm [mm] and passive_between_std_n [N], the sample std
    of the beds' means (NaN for one bed: the scatter of a run's mean from bed to bed, which Table 3's std columns
    may be, see :func:`beds_lines`); rigid_n and passive_n, the beds' mean draughts [N], rigid_per_bed_n (b,) [N]
    (each bed's rigid run at the configuration's speed); the lab's columns as :func:`passive_table`'s (and
    lab_passive_std_n, lab_rigid_n [N]). Folders of different shank lengths are refused (:func:`passive_runs`)."""
    folders = list(folders)
    tables = []
    for f, passive in zip(folders, passive_runs(folders, variant), strict=True):
        rigid = Path(f) / "rigid.json"
        if not rigid.is_file():
            raise InputError(f"{str(f)!r} holds no finished rigid stage (rigid.json)")
        tables.append(passive_table(json.loads(rigid.read_text()), passive))
    b = len(tables)
    rows = []
    for per in zip(*tables, strict=True):
        if len({r["springs"] for r in per}) != 1:
            raise InputError("the folders' passive runs list their configurations in different orders")
        red = np.array([r["reduction_pct"] for r in per])
        between = {k: float(np.std([r[key] for r in per], ddof=1)) if b > 1 else math.nan
                   for k, key in (("disp_between_std_mm", "disp_mm"), ("passive_between_std_n", "passive_n"))}
        rows.append({**{k: per[0][k] for k in ("springs", "speed", "lab_reduction_pct", "lab_disp_mm",
                                                  "lab_disp_std_mm")}, **between,
                     "lab_passive_std_n": _table3()[per[0]["springs"]]["passive_draught_std_n"],
                     "lab_rigid_n": _table3()[per[0]["springs"]]["rigid_draught_mean_n"],
                     "rigid_per_bed_n": [float(r["rigid_n"]) for r in per],
                     "per_bed_pct": red.tolist(), "reduction_pct": float(red.mean()),
                     "reduction_se": float(red.std(ddof=1) / math.sqrt(b)) if b > 1 else 0.0,
                     "own_se_pct": float(math.sqrt(np.mean([r["reduction_se"] ** 2 for r in per]) / b)),
                     **{k: float(np.mean([r[k] for r in per])) for k in ("disp_mm", "disp_std_mm", "rigid_n",
                                                                          "passive_n")}})
    return rows


def reduction_slope(rows: list[dict[str, object]]) -> dict[str, float]:
    """The reductions against the displacements, simulated and measured [pp/mm]: slope and its standard error of a
    line through the configurations' mean reductions (``reduction_pct`` against ``disp_mm``) weighted by
    1 / ``reduction_se``^2 (the SE from the weights alone, (A^T W A)^-1; NaN with fewer than two beds), and of the
    ordinary least-squares line through the lab's rows (``lab_reduction_pct`` against ``lab_disp_mm``; SE from its
    residuals, as ``scipy.stats.linregress``)."""
    from scipy.stats import linregress

    x = np.array([r["disp_mm"] for r in rows], dtype=np.float64)
    y = np.array([r["reduction_pct"] for r in rows], dtype=np.float64)
    se = np.array([r["reduction_se"] for r in rows], dtype=np.float64)
    slope = slope_se = math.nan
    if np.all(se > 0):
        w = 1.0 / se**2
        a = np.column_stack([np.ones_like(x), x])
        cov = np.linalg.inv(a.T @ (w[:, None] * a))
        slope, slope_se = float((cov @ a.T @ (w * y))[1]), float(math.sqrt(cov[1, 1]))
    lab = linregress([r["lab_disp_mm"] for r in rows], [r["lab_reduction_pct"] for r in rows])
    return {"slope_pp_per_mm": slope, "slope_se": slope_se, "lab_slope_pp_per_mm": float(lab.slope),
            "lab_slope_se": float(lab.stderr)}


def paired_changes(folders: list[str | Path], variant: str, against: str) -> dict[str, object]:
    """The ``variant`` tool's passive runs against the ``against`` tool's on the same beds: every folder that holds
    both (``passive_<variant>.json`` and ``passive_<against>.json``: one bed, one study) gives per configuration the
    passive draught's change 100 (P_variant / P_against - 1) [%] and the mean displacement's 1e3 (x_variant -
    x_against) [mm]. Returns folders (those paired) and left_out (those without the ``against`` run); rows (8,):
    springs, draught_change_pct (b,), draught_change_mean, draught_change_se [%], disp_change_mm (b,),
    disp_change_mean, disp_change_se [mm] (SE: sample std / sqrt(b), NaN for one bed); and over every pair (all
    configurations and beds) draught_change_all and disp_change_all: (mean, sample SE). InputError where no folder
    holds both, or their configurations differ."""
    paired = [f for f in folders if (Path(f) / f"passive_{against}.json").is_file()]
    if not paired:
        raise InputError(f"no folder holds both the {variant!r} and the {against!r} passive runs "
                         f"(passive_{against}.json)")
    runs = list(zip(passive_runs(paired, variant), passive_runs(paired, against), strict=True))
    springs = [int(r["springs"]) for r in runs[0][0]["rows"]]
    for f, (a, b) in zip(paired, runs, strict=True):
        if [int(r["springs"]) for r in a["rows"]] != springs or [int(r["springs"]) for r in b["rows"]] != springs:
            raise InputError(f"{str(f)!r}: the {variant!r} and {against!r} runs list other configurations")
    drag = np.array([[100.0 * (x["draught_mean"] / y["draught_mean"] - 1.0) for x, y in
                      zip(a["rows"], b["rows"], strict=True)] for a, b in runs])
    disp = np.array([[1e3 * (x["displacement_mean"] - y["displacement_mean"]) for x, y in
                      zip(a["rows"], b["rows"], strict=True)] for a, b in runs])
    beds = len(paired)
    drag_se, disp_se = ((v.std(axis=0, ddof=1) / math.sqrt(beds)) if beds > 1 else np.full(len(springs), math.nan)
                        for v in (drag, disp))
    rows = [{"springs": n, "draught_change_pct": drag[:, i].tolist(), "draught_change_mean": float(drag[:, i].mean()),
             "draught_change_se": float(drag_se[i]), "disp_change_mm": disp[:, i].tolist(),
             "disp_change_mean": float(disp[:, i].mean()), "disp_change_se": float(disp_se[i])}
            for i, n in enumerate(springs)]
    return {"variant": variant, "against": against, "folders": [str(f) for f in paired],
            "left_out": [str(f) for f in folders if f not in paired], "rows": rows,
            "draught_change_all": (float(drag.mean()), float(drag.std(ddof=1) / math.sqrt(drag.size))),
            "disp_change_all": (float(disp.mean()), float(disp.std(ddof=1) / math.sqrt(disp.size)))}


def paired_lines(p: dict[str, object]) -> list[str]:
    """The report's section on :func:`paired_changes`."""
    d, x = p["draught_change_all"], p["disp_change_all"]
    n_pairs = len(p["rows"]) * len(p["folders"])
    return [f"### The '{p['variant']}' tool against the '{p['against']}' tool on the same beds", "",
            "Beds holding both runs: " + ", ".join(f"`{f}`" for f in p["folders"])
            + ("; without the second: " + ", ".join(f"`{f}`" for f in p["left_out"]) if p["left_out"] else "")
            + f". Per bed and configuration, '{p['variant']}' minus '{p['against']}': the passive draught's change "
            "[%] and the zeroed mean displacement's [mm]; mean and standard error over the beds.", "",
            "| springs | draught change per bed [%] | mean +- SE [%] | displacement change per bed [mm] | "
            "mean +- SE [mm] |", "|---:|---|---|---|---|",
            *[f"| {r['springs']} | {', '.join(f'{v:+.1f}' for v in r['draught_change_pct'])} | "
              f"{r['draught_change_mean']:+.2f} +- {r['draught_change_se']:.2f} | "
              f"{', '.join(f'{v:+.2f}' for v in r['disp_change_mm'])} | {r['disp_change_mean']:+.2f} +- "
              f"{r['disp_change_se']:.2f} |" for r in p["rows"]], "",
            f"Over the {n_pairs} pairs: passive draught {d[0]:+.2f} +- {d[1]:.2f} %, displacement {x[0]:+.3f} +- "
            f"{x[1]:.3f} mm (mean and sample standard error of all pairs; the reduction against the shared rigid run "
            "changes by minus the draught's change times P / R).", ""]


def rigid_by_speed(rows: list[dict[str, object]]) -> list[dict[str, float]]:
    """The rigid draught over the beds at each measured speed: speed [m/s], mean and standard error over the beds
    [N] (sample std / sqrt(b); NaN for one bed), beds, and the lab's mean over its rows at that speed [N]."""
    out = []
    for v in sorted({round(r["speed"], 2) for r in rows}):
        at = [r for r in rows if round(r["speed"], 2) == v]
        per = np.array(at[0]["rigid_per_bed_n"], dtype=np.float64)  # one rigid run a bed and speed
        out.append({"speed": v, "rigid_n": float(per.mean()), "beds": len(per),
                    "rigid_se_n": float(per.std(ddof=1) / math.sqrt(len(per))) if len(per) > 1 else math.nan,
                    "lab_rigid_n": float(np.mean([r["lab_rigid_n"] for r in at]))})
    return out


def beds_lines(folders: list[str | Path], rows: list[dict[str, object]], variant: str) -> list[str]:
    """The report's section on a :func:`beds_table`."""
    dv, rv, sl = displacement_verdict(rows), reduction_verdict(rows), reduction_slope(rows)
    return [f"## Table 3 with the '{variant}' tool over {len(folders)} bed(s)", "",
            "Beds: " + ", ".join(f"`{f}`" for f in folders) + ". Each reduction is taken against the rigid run of "
            "its own bed at the same speed; mean and standard error over the beds (the records' own combined SE in "
            "brackets).", "",
            f"Displacement (means of the beds): {dv['within']} of 8 within 1 mm or 25 %, {dv['signs']} of 8 signs "
            f"right, rank correlation with the spring count {dv['trend_spearman']:+.2f} (lab +1.00), standard "
            f"deviation within a factor 2 in {dv['std_within_2x']} of 8. Reductions: MAE {rv['mae_pp']:.2f} pp, "
            f"{rv['signs']} of 8 signs (the paper's final DEM 3.12 pp, 5 of 8), largest SE {rv['max_se_pp']:.2f} "
            f"pp between the beds ({max(r['own_se_pct'] for r in rows):.2f} pp by the records' own; with few beds "
            "the between-bed SE is itself uncertain: read the larger).", "",
            "| springs | reduction per bed [%] | mean +- SE [%] | lab [%] | disp [mm] | std [mm] | lab disp [mm] | "
            "lab std [mm] |", "|---:|---|---|---:|---:|---:|---:|---:|",
            *[f"| {r['springs']} | {', '.join(f'{x:+.1f}' for x in r['per_bed_pct'])} | {r['reduction_pct']:+.2f} "
              f"+- {r['reduction_se']:.2f} ({r['own_se_pct']:.2f}) | {r['lab_reduction_pct']:+.2f} | "
              f"{r['disp_mm']:.2f} | {r['disp_std_mm']:.2f} | {r['lab_disp_mm']:.2f} | {r['lab_disp_std_mm']:.2f} |"
              for r in rows], "",
            ("Reduction against displacement: " + (
                f"{sl['slope_pp_per_mm']:+.2f} +- {sl['slope_se']:.2f} pp/mm (a line through the means above, "
                "weighted by their between-bed SEs)" if math.isfinite(sl["slope_pp_per_mm"]) else
                "not weighed with one bed (its between-bed SEs need two or more)")
             + f"; the lab's {sl['lab_slope_pp_per_mm']:+.2f} +- {sl['lab_slope_se']:.2f} pp/mm (least squares "
             "through Table 3's rows)."), "",
            "| speed [m/s] | rigid draught over the beds [N] | lab [N] |", "|---:|---:|---:|",
            *[f"| {q['speed']:.2f} | {q['rigid_n']:.1f}"
              + (f" +- {q['rigid_se_n']:.1f} ({q['beds']} beds)" if q["beds"] > 1 else " (one bed)")
              + f" | {q['lab_rigid_n']:.1f} |" for q in rigid_by_speed(rows)], "",
            *_between_lines(rows)]


def _between_lines(rows: list[dict[str, object]]) -> list[str]:
    """Table 3's std columns against the scatter of a run's mean from bed to bed (another reading of them)."""
    if any(math.isnan(r["disp_between_std_mm"]) for r in rows):
        return []
    from scipy.stats import chi2

    within = sum(0.5 <= r["disp_between_std_mm"] / r["lab_disp_std_mm"] <= 2.0 for r in rows)
    dof = len(rows[0]["per_bed_pct"]) - 1
    lo, hi = np.sqrt(chi2.ppf([0.025, 0.975], dof) / dof)
    return ["### Table 3's standard deviations: within a run, or from pass to pass?", "",
            "The paper does not say over what its standard deviations are taken. Within one simulated run the "
            "displacement and the draught fluctuate far more than Table 3's columns (above); compare the scatter of "
            f"a run's mean from bed to bed (sample std over the beds). A std over {dof + 1} beds is itself uncertain: "
            f"the 95 % range of its ratio to the true one is {lo:.2f}-{hi:.2f}.", "",
            "| springs | disp: bed-to-bed std [mm] | lab std [mm] | passive draught: bed-to-bed std [N] | lab std "
            "[N] |", "|---:|---:|---:|---:|---:|",
            *[f"| {r['springs']} | {r['disp_between_std_mm']:.3f} | {r['lab_disp_std_mm']:.3f} | "
              f"{r['passive_between_std_n']:.1f} | {r['lab_passive_std_n']:.1f} |" for r in rows], "",
            f"Bed-to-bed std of the displacement within a factor 2 of the lab's: {within} of 8.", ""]


def draught_plateau(folders: list[str | Path], variant: str = "described") -> analysis.Plateau | None:
    """Where the draught of every run in ``folders`` (their rigid stage and the variant's passive stage, each
    world a run, from the records that are there) is heading along the travel (:func:`scenes.analysis.plateau_fit`,
    over the travel the shortest run covers), against the steady window's mean; None where the records cannot say
    (fewer than two runs, or too short)."""
    travel, draught = [], []
    for f in folders:
        for name in ("rigid", f"passive_{variant}"):
            if (path := Path(f) / f"{name}.npz").is_file():
                with np.load(path) as rec:
                    travel.append(rec["travel"])
                    draught.append(rec["draught"])
    if not travel:
        return None
    k = min(len(t) for t in travel)
    try:
        return analysis.plateau_fit(np.concatenate([t[:k] for t in travel], axis=1),
                                    np.concatenate([d[:k] for d in draught], axis=1))
    except InputError:
        return None


def plateau_lines(fit: analysis.Plateau | None) -> list[str]:
    """The report's section on :func:`draught_plateau`."""
    if fit is None:
        return ["### Is the draught steady in its window?", "",
                "The folders' records are too few or too short to say.", ""]
    if not fit.levels_off:
        return ["### Is the draught steady in its window?", "",
                f"Over the {fit.n_worlds} runs (rigid and passive worlds) the draught does not level off within the "
                f"{fit.fit_span:.2f} m of travel fitted (`scenes.analysis.plateau_fit`): the approach to a plateau "
                f"is not identified (its length came out {fit.length:.3g} +- {fit.length_se:.2g} m), and a line "
                f"through the bins rises {fit.slope:.1f} +- {fit.slope_se:.1f} N per m of travel. The steady "
                f"window's bins average {fit.window_mean:.1f} N; the runs are still rising there, so a longer travel "
                "or a later window would raise its means.", ""]
    gap = 100 * (fit.window_mean / fit.plateau - 1)
    return ["### Is the draught steady in its window?", "",
            f"Over the {fit.n_worlds} runs (rigid and passive worlds) the draught approaches D(x) = "
            f"{fit.plateau:.1f} +- {fit.plateau_se:.1f} N - {fit.amplitude:.0f} N exp(-x / "
            f"({fit.length:.3f} +- {fit.length_se:.3f} m)) along the travel x (`scenes.analysis.plateau_fit`). "
            f"The steady window's bins average {fit.window_mean:.1f} N, {gap:+.1f} % against the plateau: "
            + ("the window starts after the approach has ended." if abs(gap) < 1.0 else
               "the window starts before the approach has ended, so its means lie below where the runs are heading "
               "(a longer travel or a later window would move them)."), ""]


def write_beds(out: str | Path, folders: list[str | Path], variant: str = "described",
               against: str | None = None) -> list[dict[str, object]]:
    """:func:`beds_table` of ``folders`` into ``out``: beds.json (with the draught's plateau,
    :func:`draught_plateau`, and with ``against`` the variant's runs paired with that variant's on the beds holding
    both, :func:`paired_changes`), beds.md and fig_table3_beds.png. Returns the rows."""
    out = Path(out)
    rows = beds_table(folders, variant)
    fit = draught_plateau(folders, variant)
    paired = None if against is None else paired_changes(folders, variant, against)
    _json(out / "beds.json", {"folders": [str(f) for f in folders], "variant": variant, "rows": rows,
                              "draught_plateau": None if fit is None else asdict(fit),
                              **({} if paired is None else {"paired": paired})})
    text = "\n".join(["# Table 3 over several beds", "", *beds_lines(folders, rows, variant), *plateau_lines(fit),
                      *([] if paired is None else paired_lines(paired))])
    write_text_atomic(out / "beds.md", text)
    table3_figure(rows, out / "fig_table3_beds.png", f"'{variant}' tool, {len(folders)} bed(s)",
                  f"warpdem (mean of {len(folders)} bed(s), SE)")
    return rows


NO_COMPLIANCE = 1e8
"""a fitted series stiffness above this [N/m] (133x the stiffest stack, 7.5e5 N/m: under 1 % of its compliance)
is reported as none."""


def joint_record(folders: list[str | Path], variant: str = "din_preload") -> dict[str, object]:
    """Table 2 and Table 3 fitted jointly (:func:`calibration.tool_fit.fit_joint`) with both mount hypotheses,
    the soil's levers measured in ``folders``' passive runs (:func:`soil_levers`), and for each hypothesis a
    leave-one-out check: each configuration's displacement predicted by a fit without it."""
    levers, shank = soil_levers(folders, variant)
    out: dict[str, object] = {"folders": [str(f) for f in folders], "variant": variant, "levers": levers,
                              "lever_shank_length": shank}
    for mounts in MOUNTS:
        fit = fit_joint(levers, shank, mounts).to_dict()
        fit["at_run_shank"] = fit_joint(levers, shank, mounts, profile=(), shank_length=shank).to_dict()
        loo = []
        for n in paper.SPRING_COUNTS:
            held = fit_joint(levers, shank, mounts, profile=(), held_out=(n,))
            row = next(r for r in held.displacement_rows if r["springs"] == n)
            loo.append({**row, "shank_length": held.tool.shank_length})
        fit["leave_one_out"] = loo
        out[mounts] = fit
    return out


def joint_lines(rec: dict) -> list[str]:
    """The report's section on a :func:`joint_record`."""
    lines = ["## Table 2 and Table 3 with one tool", "",
             f"Levers of the soil's moment about the pivot per unit of draught, measured in {len(rec['folders'])} "
             f"passive run(s) with the shank {rec['lever_shank_length']:.3f} m and moved to any other shank length "
             "(+dL): " + ", ".join(f"{n}: {v:.3f}" for n, v in rec["levers"].items()) + " m. Residuals in units of "
             "the issue's tolerances (frequency 5 %; displacement 1 mm or 25 %). The displacements are fitted here, "
             "so only the leave-one-out column predicts them.", ""]
    for mounts in MOUNTS:
        f = rec[mounts]
        t = f["tool"]
        loo = f["leave_one_out"]
        bin_ks = t["bin_series_stiffness"]
        bin_text = ("the same" if bin_ks is None else "none" if bin_ks == "inf" or bin_ks > NO_COMPLIANCE
                    else f"{bin_ks:.3g} N/m")
        lines += [f"### Mounts {mounts}: cost {f['cost']:.2f}", "",
                  f"shank length {t['shank_length']:.3f} m; rate factor {t['rate_factor']:.3f}; inertia factor "
                  f"{t['inertia_factor']:.3f}; series stiffness (ringing) {t['series_stiffness']:.3g} N/m; soil bin's "
                  f"{bin_text}; preload (soil bin) {1e3 * t['preload']:.2f} mm; "
                  f"riding load fraction {t['load_mass_fraction']:.3f}", "",
                  "Bounds: " + "; ".join(f"{k} {v}" for k, v in f["bounds"].items()), "",
                  f"Frequencies within 5 %: {sum(abs(r['error_pct']) <= 5 for r in f['frequency_rows'])} of 8. "
                  f"Displacements within 1 mm or 25 %: {int(sum(r['within'] for r in f['displacement_rows']))} of 8 "
                  f"fitted, {int(sum(r['within'] for r in loo))} of 8 left out.", "",
                  "| springs | lab f [Hz] | fit f [Hz] | error [%] | lever [m] | lab disp [mm] | fit disp [mm] | "
                  "left out [mm] |", "|---:|---:|---:|---:|---:|---:|---:|---:|"]
        lines += [f"| {fr['springs']} | {fr['measured_freq_hz']:.2f} | {fr['fit_freq_hz']:.2f} | "
                  f"{fr['error_pct']:+.1f} | {dr['lever_m']:.3f} | {dr['lab_disp_mm']:.2f} | {dr['fit_disp_mm']:.2f} | "
                  f"{lo['fit_disp_mm']:.2f} |" for fr, dr, lo in zip(f["frequency_rows"], f["displacement_rows"], loo,
                                                                    strict=True)]
        lines += ["", "Profile over the shank length (the fit repeated with it held): " + "; ".join(
            f"{p['shank_length']:.2f} m: {p['cost']:.1f} ({p['frequency_cost']:.1f} + {p['displacement_cost']:.1f})"
            for p in f["profile"]) + " (cost = frequencies' + displacements').", ""]
    return lines


def write_joint(out: str | Path, folders: list[str | Path]) -> dict[str, object]:
    """:func:`joint_record` of ``folders`` into ``out``: joint.json, joint.md and tool_joint.toml (the per-rig fit
    with the shank held at the runs' own). Returns the record."""
    out = Path(out)
    rec = joint_record(folders)
    _json(out / "joint.json", rec)
    text = "\n".join(["# Table 2 and Table 3 fitted with one tool", "",
                      "Runs: " + ", ".join(f"`{f}`" for f in folders), "", *joint_lines(rec)])
    write_text_atomic(out / "joint.md", text + "\n")
    write_text_atomic(out / "tool_joint.toml", from_dict(rec["per rig"]["at_run_shank"]["tool"]).to_toml())
    return rec


def quasi_static_sensitivity(tool: PassiveTool, springs: int, draught: float, arm: float,
                             sweep: object | None = None) -> float:
    """d(reading)/d(draught) [m/N]: how far the lab's sensor moves per newton of draught held at rest, the draught
    ``draught`` [N] acting ``arm`` [m] about the pivot (its moment through the stack law, preload and stop included;
    a central difference of :meth:`PassiveTool.lab_reading` over +-1 N m). In the stack's linear range it is
    arm a / (k a^2 + K_g) (a: the stack's lever, k: its rate, K_g: the tool's pendulum stiffness). ``sweep``: the
    tool's ``tool.sweep()``, when the caller has it already."""
    sweep = sweep or tool.sweep()
    m = draught * arm
    return arm * (tool.lab_reading(springs, m + 1.0, sweep) - tool.lab_reading(springs, m - 1.0, sweep)) / 2.0


def displacement_noise(series: dict[str, np.ndarray], rows: list[dict[str, float]], tool: PassiveTool,
                       steady_travel: float) -> list[dict[str, float]]:
    """Where the displacement's fluctuation comes from, per passive configuration.

    Below its natural frequency f_n the tool follows the draught at rest: its reading's fluctuation is the draught's
    fluctuation below f_n times :func:`quasi_static_sensitivity`. Above f_n its inertia filters the draught out.
    The same sensitivity turns the laboratory's displacement std into the most slow draught fluctuation its tool
    can have seen (sensor noise and faster motion only add to a reading's std).

    Args:
        series: a passive stage's records (``passive_<variant>.npz``): time [s] (k,), travel [m] (k, w), draught
            [N] (k, w), displacement [m] (k, w); world j is ``rows[j]``.
        rows: :func:`passive_table`'s rows (w,), with :func:`moment_arms`' ``arm_m`` and ``lab_arm_m`` merged in.
        tool: the stage's tool description. steady_travel: [m] where the steady window starts.

    Returns per configuration: f_n [Hz] (the tool alone on its stack, no ringing load), draught_std [N] and
    draught_slow_std [N] (below f_n: 4th-order Butterworth, zero phase) over the steady window while the carriage
    moves, sensitivity [mm/N], predicted_std_mm (sensitivity x draught_slow_std), disp_std_mm (simulated),
    lab_disp_std_mm, lab_draught_std [N] (Table 3's passive) and lab_slow_bound [N] (the lab's displacement std
    over the sensitivity at the lab's draught and lever).
    """
    from scipy import signal

    t = np.asarray(series["time"], dtype=np.float64)
    fs = 1.0 / float(np.median(np.diff(t)))
    t3 = _table3()
    sweep = tool.sweep()
    out = []
    for w, r in enumerate(rows):
        n = int(r["springs"])
        trav = np.asarray(series["travel"])[:, w]
        steady = (trav >= steady_travel) & (trav < trav.max())
        f_n = tool.ringing_frequency(n, sweep, load_force=0.0)
        sos = signal.butter(4, min(f_n, 0.45 * fs), fs=fs, output="sos")
        draught = np.asarray(series["draught"], dtype=np.float64)[:, w]
        slow = signal.sosfiltfilt(sos, draught)[steady]
        disp = 1e3 * np.asarray(series["displacement"], dtype=np.float64)[steady, w]
        s = 1e3 * quasi_static_sensitivity(tool, n, r["passive_n"], r["arm_m"], sweep)
        lab = t3[n]
        s_lab = 1e3 * quasi_static_sensitivity(tool, n, lab["passive_draught_mean_n"], r["lab_arm_m"], sweep)
        out.append({"springs": n, "f_n": f_n, "draught_std": float(draught[steady].std()),
                    "draught_slow_std": float(slow.std()), "sensitivity_mm_n": s,
                    "predicted_std_mm": s * float(slow.std()), "disp_std_mm": float(disp.std()),
                    "lab_disp_std_mm": lab["displacement_std_mm"], "lab_draught_std": lab["passive_draught_std_n"],
                    "lab_slow_bound": lab["displacement_std_mm"] / s_lab})
    return out


def lab_pitch_relation() -> list[dict[str, float]]:
    """What the laboratory implies: each configuration's mean displacement as a backward pitch (d / 0.1 m) and
    its draught change against the rigid tool (minus its reduction) [%]."""
    a = lever(build_sweep())
    return [{"springs": n, "pitch_deg": math.degrees(1e-3 * r["displacement_mean_mm"] / a),
             "change_pct": -r["reduction_pct"]} for n, r in sorted(_table3().items())]


def table3_figure(rows: list[dict[str, object]], path: Path, title: str, label: str) -> None:
    """Simulated against measured displacement (mean, std) and reduction (with its SE) per configuration: the
    rows of :func:`passive_table` or :func:`beds_table`, drawn into ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    n = [r["springs"] for r in rows]
    axes[0].errorbar(n, [r["disp_mm"] for r in rows], yerr=[r["disp_std_mm"] for r in rows], fmt="o-",
                     capsize=3, label="warpdem (mean, std)")
    axes[0].errorbar(n, [r["lab_disp_mm"] for r in rows], yerr=[r["lab_disp_std_mm"] for r in rows], fmt="s--",
                     color="k", capsize=3, label="laboratory, Table 3")
    axes[0].set_xlabel("springs")
    axes[0].set_ylabel("sensor displacement, zeroed at rest [mm]")
    axes[0].set_title(f"Tool displacement ({title})")
    axes[0].legend(fontsize=7)
    axes[1].errorbar(n, [r["reduction_pct"] for r in rows], yerr=[r["reduction_se"] for r in rows], fmt="o-",
                     capsize=3, label=label)
    axes[1].plot(n, [r["lab_reduction_pct"] for r in rows], "s--", color="k", label="laboratory, Table 3")
    axes[1].axhline(0, color="0.7", lw=0.8)
    axes[1].set_xlabel("springs")
    axes[1].set_ylabel("draught reduction against rigid [%]")
    axes[1].set_title("Draught reduction")
    axes[1].legend(fontsize=7)
    figures.save(fig, path, 120)


def write_report(out: str | Path) -> Path:
    """``report.md`` and figures from whatever stages are done."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    load = {p.stem: json.loads(p.read_text()) for p in out.glob("*.json")}
    lines = ["# The passive tool described once: Table 2 within bounds, Table 3 with its tool", ""]
    meta = load.get("study", {})
    lines += [f"Settings: scale {meta.get('scale')}, bed seed {meta.get('seed')}, travel {meta.get('travel')} m "
              f"(None: the scale's), steady state from {meta.get('steady_travel')} m, settle {meta.get('settle_time')} "
              f"s; soil: {meta.get('soil_name', 'workflow')} ({meta.get('soil')}; calibration.passive_study.SOILS).",
              ""]
    if "ringing" in load:
        ring = load["ringing"]
        lines += ["## Table 2 fitted within physical bounds", ""]
        for m, f in ring["fits"].items():
            t = f["tool"]
            lines += [f"### {m}: RMS error {f['rms_pct']:.1f} %, {f['within_5pct']} of 8 within 5 %", "",
                      f"rate factor {t['rate_factor']:.3f}, per stack {t['rate_factors'] or '-'}; inertia factor "
                      f"{t['inertia_factor']:.3f}; series stiffness {t['series_stiffness']:.3g} N/m; riding load "
                      f"fraction {t['load_mass_fraction']:.3g}", "",
                      "Bounds: " + "; ".join(f"{k} {v}" for k, v in f["bounds"].items()), "",
                      *(["A number on its bound: the data ask for more than its physical range allows, so a "
                         "mechanism is missing from this tool model (not absorbed into the number).", ""]
                        if any(v != "inside" for v in f["bounds"].values()) else []),
                      "| springs | lab f [Hz] | fitted f [Hz] | error [%] | stack rate [N/m] | with series [N/m] |",
                      "|---:|---:|---:|---:|---:|---:|"]
            lines += [f"| {r['springs']} | {r['measured_freq_hz']:.2f} | {r['fit_freq_hz']:.2f} | "
                      f"{r['error_pct']:+.1f} | {r['rate_n_per_m']:.3g} | {r['effective_rate_n_per_m']:.3g} |"
                      for r in f["rows"]]
            lines.append("")
        lines += ["### warpdem's ringing rig built from the 'one rate' tool (simulated, eqs. 3-5)", "",
                  "| springs | simulated f [Hz] | closed form [Hz] | lab f [Hz] | simulated zeta | lab zeta |",
                  "|---:|---:|---:|---:|---:|---:|"]
        lines += [f"| {r['springs']} | {r['sim_freq_hz']:.3f} | {r['fit_freq_hz']:.3f} | {r['measured_freq_hz']:.2f} | "
                  f"{r['sim_damping']:.3f} | {r['measured_damping']:.3f} |" for r in ring["simulated"]]
        lines.append("")
    if "rigid" in load and load["rigid"].get("pitch"):
        pt = pitch_table(load["rigid"])
        lines += ["## Pitch sweep of the rigid tool", "", "| pitch [deg] | draught [N] | SE [N] | change [%] |",
                  "|---:|---:|---:|---:|"]
        lines += [f"| {r['pitch_deg']:+.0f} | {r['draught_n']:.1f} | {r['draught_sem']:.1f} | "
                  f"{r['change_pct']:+.1f} +- {r['change_se']:.1f} |" for r in pt]
        lines += ["", "Laboratory (Table 3): displacement as pitch d / 0.1 m, draught change = -reduction:", "",
                  "| springs | pitch [deg] | change [%] |", "|---:|---:|---:|"]
        lines += [f"| {r['springs']} | {r['pitch_deg']:.2f} | {r['change_pct']:+.2f} |" for r in lab_pitch_relation()]
        lab = lab_pitch_relation()
        slope, slope_se = line_fit([r["pitch_deg"] for r in pt], [r["change_pct"] for r in pt],
                                   [max(r["change_se"], 1e-9) for r in pt])
        lab_slope, lab_se = line_fit([r["pitch_deg"] for r in lab], [r["change_pct"] for r in lab])
        lines += ["", f"Straight lines: warpdem's rigid tool {slope:+.2f} +- {slope_se:.2f} % per degree (weighted by "
                  f"the points' SE; they share pitch 0's run, so the SE is a lower bound); the laboratory's passive "
                  f"tool {lab_slope:+.2f} +- {lab_se:.2f} % per degree (ordinary least squares over its eight "
                  "configurations).", ""]
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.errorbar([r["pitch_deg"] for r in pt], [r["change_pct"] for r in pt], yerr=[r["change_se"] for r in pt],
                    fmt="o-", capsize=3, label=f"warpdem, rigid tool pitched, {PITCH_SPEED} m/s")
        ax.plot([r["pitch_deg"] for r in lab], [r["change_pct"] for r in lab], "s", color="k",
                label="laboratory: passive tool's mean pitch, -reduction")
        for r in lab:
            ax.annotate(str(r["springs"]), (r["pitch_deg"], r["change_pct"]), textcoords="offset points",
                        xytext=(4, 4), fontsize=7)
        ax.axhline(0, color="0.7", lw=0.8)
        ax.set_xlabel("backward pitch about the pivot [deg]")
        ax.set_ylabel("draught change against pitch 0 [%]")
        ax.set_title("Draught against the tool's pose")
        ax.legend(fontsize=7)
        figures.save(fig, out / "fig_pitch_sweep.png", 120)
    if "joint" in load:
        lines += joint_lines(load["joint"])
    for v in VARIANTS:
        if f"passive_{v}" not in load or "rigid" not in load:
            continue
        rows = passive_table(load["rigid"], load[f"passive_{v}"])
        dv, rv = displacement_verdict(rows), reduction_verdict(rows)
        lines += [f"## Table 3 with the '{v}' tool", "",
                  f"Displacement: {dv['within']} of 8 within 1 mm or 25 %, {dv['signs']} of 8 signs right, rank "
                  f"correlation with the spring count {dv['trend_spearman']:+.2f} (lab +1.00), standard deviation "
                  f"within a factor 2 in {dv['std_within_2x']} of 8. Reductions: MAE {rv['mae_pp']:.2f} pp, "
                  f"{rv['signs']} of 8 signs (the paper's final DEM 3.12 pp, 5 of 8; this project's previous run "
                  f"3.86 pp, 5 of 8), largest SE {rv['max_se_pp']:.2f} pp (one bed).", "",
                  "| springs | speed | rigid [N] | passive [N] | reduction [%] | lab [%] | disp [mm] | std | lab disp "
                  "| lab std |", "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        lines += [f"| {r['springs']} | {r['speed']:.2f} | {r['rigid_n']:.1f} | {r['passive_n']:.1f} | "
                  f"{r['reduction_pct']:+.1f} +- {r['reduction_se']:.1f} | {r['lab_reduction_pct']:+.2f} | "
                  f"{r['disp_mm']:.2f} | {r['disp_std_mm']:.2f} | {r['lab_disp_mm']:.2f} | {r['lab_disp_std_mm']:.2f} |"
                  for r in rows]
        tool = from_dict(load[f"passive_{v}"]["tool"]) if load[f"passive_{v}"].get("tool") else None
        if tool is not None:
            arms = moment_arms(rows, tool)
            lines += ["", "The stack's force that each mean displacement implies through this tool's stack law, and "
                      "the draught's lever about the pivot that follows (force x 0.1 m / passive draught):", "",
                      "| springs | force [N] | lever [m] | lab force [N] | lab lever [m] |",
                      "|---:|---:|---:|---:|---:|"]
            lines += [f"| {r['springs']} | {r['force_n']:.0f} | {r['arm_m']:.3f} | {r['lab_force_n']:.0f} | "
                      f"{r['lab_arm_m']:.3f} |" for r in arms]
            npz = out / f"passive_{v}.npz"
            if npz.exists():
                with np.load(npz) as z:
                    series = {k: z[k] for k in z.files}
                start = meta.get("steady_travel") or sb.SCALES[meta.get("scale", "paper")]["steady_travel"]
                noise = displacement_noise(series, [{**r, **a} for r, a in zip(rows, arms, strict=True)], tool,
                                           start)
                lines += ["", "### Where the displacement's fluctuation comes from", "",
                          "Below its natural frequency f_n (the tool alone on its stack) the tool follows the draught "
                          "at rest, so its reading fluctuates by the draught's slow fluctuation (below f_n) times the "
                          "tool's quasi-static sensitivity (closed form through its stack law). The laboratory's "
                          "displacement std over the same sensitivity bounds the slow draught fluctuation its tool "
                          "saw (sensor noise and faster motion only add to it).", "",
                          "| springs | f_n [Hz] | draught std [N] | below f_n [N] | sensitivity [mm/N] | predicted "
                          "std [mm] | simulated std [mm] | lab std [mm] | lab draught std [N] | lab below f_n, at "
                          "most [N] |", "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
                lines += [f"| {q['springs']} | {q['f_n']:.1f} | {q['draught_std']:.1f} | {q['draught_slow_std']:.1f}"
                          f" | {q['sensitivity_mm_n']:.4f} | {q['predicted_std_mm']:.2f} | {q['disp_std_mm']:.2f} | "
                          f"{q['lab_disp_std_mm']:.3f} | {q['lab_draught_std']:.1f} | {q['lab_slow_bound']:.1f} |"
                          for q in noise]
                ratio = [q["disp_std_mm"] / q["predicted_std_mm"] for q in noise]
                excess = [q["draught_slow_std"] / q["lab_slow_bound"] for q in noise]
                lines += ["", f"Simulated over predicted std: {min(ratio):.2f}-{max(ratio):.2f}. The simulated "
                          f"draught's slow fluctuation is {min(excess):.1f}-{max(excess):.1f}x the most the "
                          "laboratory's displacement allows."]
        lines.append("")
        table3_figure(rows, out / f"fig_table3_{v}.png", f"'{v}' tool", "warpdem (one bed, SE)")
    walls = {k: round(v.get("wall_s", 0.0), 1) for k, v in load.items() if isinstance(v, dict) and "wall_s" in v}
    lines += ["## Wall times [s]", "", "Each stage's last call: " + ", ".join(f"{k} {v}" for k, v in
                                                                            sorted(walls.items())), ""]
    split = {k: v for k, v in load.items() if isinstance(v, dict) and "steps_s" in v}
    if split:  # the stages' own split over all their calls (runs made before it was recorded have none)
        lines += ["| stage | bed deposition | settling | steps (all calls) | steps | rebuilds |",
                  "|---|---|---|---|---|---|"]
        lines += [f"| {k} | {v['bed_wall_s']:.1f} | {v['settle_s']:.1f} | {v['steps_s']:.1f} | {v['steps']} | "
                  f"{v['rebuilds']} |" for k, v in sorted(split.items())]
        lines += ["", "The bed is deposited once (its wall is the deposition's, in whichever stage made it); each "
                  "stage settles it again before its bonds are set.", ""]
    path = out / "report.md"
    path.write_text("\n".join(lines))
    return path

