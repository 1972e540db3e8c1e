"""The rigid tool's draught against speed, and the paper's Table 7 reductions re-paired at equal speeds.

Table 3 pairs every passive run with a rigid run at about its own speed; the paper's DEM (Table 7) took one rigid
run at 0.68 m/s for every configuration, although the passive runs went at 0.52 to 0.70 m/s. A soil's draught grows
with speed, so a slow passive run compared with a fast rigid run shows a reduction that is partly the speed's.

:func:`run_sweep` runs the rigid tool at several speeds (worlds of one simulation, one bed), fits a line through
the steady means (weighted by their standard errors) and re-pairs Table 7: the paper's rigid draught F_7 at 0.68 m/s
is carried to each configuration's speed v by warpdem's relative speed dependence, F_7 L(v) / L(0.68) (L: the
fitted line), and every reduction is recomputed against it. Each recomputed reduction carries the standard error
that the line's uncertainty gives it. Outputs (``write``): summary.json, rigid_speed.png, report.md.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from warpdem.files import write_atomic, write_text_atomic
from warpdem.vtk import VtkWriter

from . import figures, paper
from . import soil_bin as sb

SWEEP_SPEEDS = (0.45, 0.50, 0.55, 0.60, 0.65, 0.70, 0.75)
"""default carriage speeds [m/s] of the sweep: Table 3's range (0.52-0.70 m/s) and a little beyond."""
TABLE7_RIGID_SPEED = 0.68
"""the speed [m/s] of Table 7's one rigid run per assembly."""
TABLE7_COLUMNS = {"a": "A, 1 m bin", "b": "B, 1 m bin", "c": "C, 1 m bin", "c_final": "C, final 2 m bin"}
"""Table 7's columns: assembly and bin (the final column is the paper's corrected-geometry model)."""


@dataclass
class SpeedLine:
    """A straight line through draughts against speed: F(v) = intercept + slope v [N], with the parameters'
    covariance (2, 2) [N^2, N^2 s/m, N^2 s^2/m^2] (scaled by the reduced chi^2 when that exceeds 1)."""

    intercept: float
    slope: float
    cov: list[list[float]]
    chi2_dof: float

    def at(self, v: float) -> tuple[float, float]:
        """F(v) [N] and its standard error [N]."""
        g = np.array([1.0, v])
        return self.intercept + self.slope * v, float(np.sqrt(g @ np.asarray(self.cov) @ g))

    def ratio(self, v: float, v_ref: float) -> tuple[float, float]:
        """F(v) / F(v_ref) [-] and its standard error (delta method; the line's parameters are correlated)."""
        a, b = self.intercept, self.slope
        fv, fr = a + b * v, a + b * v_ref
        grad = np.array([(fr - fv) / fr**2, (v * fr - v_ref * fv) / fr**2])
        return fv / fr, float(np.sqrt(grad @ np.asarray(self.cov) @ grad))


def fit_line(speeds: np.ndarray, means: np.ndarray, sems: np.ndarray) -> SpeedLine:
    """Weighted least-squares line through steady means [N] (n,) at speeds [m/s] (n,) with standard errors [N]
    (n,). The covariance is scaled by chi^2 / (n - 2) when that exceeds 1 (scatter beyond the stated errors)."""
    v, y, s = (np.asarray(x, dtype=float) for x in (speeds, means, sems))
    if len(v) < 3 or np.ptp(v) <= 0:
        raise ValueError(f"speeds: a line needs at least 3 points over more than one speed, got {v.tolist()}")
    if not np.all(np.isfinite(y) & np.isfinite(s) & (s > 0)):
        raise ValueError(f"means and sems must be finite and sems positive, got {y.tolist()}, {s.tolist()}")
    a = np.column_stack([np.ones_like(v), v]) / s[:, None]
    coef, *_ = np.linalg.lstsq(a, y / s, rcond=None)
    cov = np.linalg.inv(a.T @ a)
    chi2_dof = float(np.sum((a @ coef - y / s) ** 2) / (len(v) - 2))
    return SpeedLine(float(coef[0]), float(coef[1]), (cov * max(1.0, chi2_dof)).tolist(), chi2_dof)


def repair_table7(line: SpeedLine, v_ref: float = TABLE7_RIGID_SPEED) -> list[dict[str, object]]:
    """Table 7's reductions recomputed against its rigid draught carried to each configuration's speed by
    ``line``'s relative speed dependence. One row per passive configuration: springs, speed [m/s], the laboratory's
    reduction (Table 3) [%], and per Table 7 column: the paper's reduction as printed and as its draughts give it
    (they differ in one cell: A, 4 springs, 5.57 printed, 3.65 % from 341.19 and 328.72 N), the re-paired rigid
    reference [N], the
    re-paired reduction [%] and its standard error [percentage points], and whether each sign equals the
    laboratory's."""
    t3, t7 = paper.table("soil_bin_measured"), paper.table("soil_bin_dem")
    rows = []
    for i in np.nonzero(t7["springs"] > 0)[0]:
        n, v = int(t7["springs"][i]), float(t7["speed_mean_m_s"][i])
        lab = float(t3["reduction_pct"][t3["springs"] == n][0])
        ratio, ratio_se = line.ratio(v, v_ref)
        row: dict[str, object] = {"springs": n, "speed": v, "lab_reduction": lab, "speed_ratio": ratio,
                                  "speed_ratio_se": ratio_se}
        for col in TABLE7_COLUMNS:
            rigid7 = float(t7[f"{col}_mean_n"][t7["springs"] == 0][0])
            passive = float(t7[f"{col}_mean_n"][i])
            ref = rigid7 * ratio
            red = 100.0 * (ref - passive) / ref
            red_se = 100.0 * passive / ref * ratio_se / ratio  # d red / d ratio = 100 passive / (rigid7 ratio^2)
            row[col] = {"paper_reduction": float(t7[f"{col}_red_pct"][i]),
                        "paper_reduction_from_draughts": 100.0 * (rigid7 - passive) / rigid7, "rigid_reference": ref,
                        "reduction": red, "reduction_se": red_se,
                        "paper_sign_right": bool(np.sign(t7[f"{col}_red_pct"][i]) == np.sign(lab)),
                        "repaired_sign_right": bool(np.sign(red) == np.sign(lab))}
        rows.append(row)
    return rows


def inertial_slope(bed: sb.Bed, v: float, width: float = 0.3, depth: float = paper.WORKING_DEPTH) -> float:
    """dF/dv [N s/m] of the inertial term rho_b w d v^2 (soil of bulk density rho_b [kg/m^3] accelerated to the
    tool's speed over its cut, ``width`` x ``depth`` [m]) at speed ``v`` [m/s]: 2 rho_b w d v. An order of
    magnitude to set beside the measured slope, not a model of the tool."""
    return 2.0 * paper.SOIL_DENSITY * (1.0 - bed.porosity) * width * depth * v


def run_sweep(config: sb.SoilBinConfig, speeds: tuple[float, ...] = SWEEP_SPEEDS, *, device: str | None = None,
              cache_dir: str | Path | None = None, checkpoint: str | Path | None = None,
              progress: object | None = None, vtk: tuple[object, int] | None = None,
              soil: dict[str, float] | None = None) -> dict[str, object]:
    """The rigid tool at every speed of ``speeds`` [m/s] as worlds of one simulation on ``config``'s bed. Returns
    the bed, the run, its steady rows (one per speed), the fitted line, the re-paired Table 7 rows and the soil.
    ``vtk``: see :func:`scenes.soil_bin.run_soil_bin`. ``soil``: the soil material's fields in every world (e.g.
    ``friction_angle`` [deg], ``normal_cohesion`` [Pa]; ``calibration.genes.soil_fields`` of a calibrated set);
    default the config's GA set."""
    speeds = tuple(float(v) for v in speeds)
    if len(speeds) < 3 or not all(math.isfinite(v) and v > 0 for v in speeds) or len(set(speeds)) != len(speeds):
        raise ValueError(f"speeds: at least 3 distinct positive speeds [m/s], got {list(speeds)}")
    bed = sb.bed_for(config, device=device, cache_dir=cache_dir)
    overrides = {k: [float(v)] * len(speeds) for k, v in soil.items()} if soil else None
    run = sb.run_soil_bin(config, [0] * len(speeds), bed=bed, device=device, speeds=list(speeds), progress=progress,
                          checkpoint=checkpoint, vtk=vtk, soil_overrides=overrides)
    rows = run.steady
    line = fit_line(np.array(speeds), np.array([r["draught_mean"] for r in rows]),
                    np.array([r["draught_sem"] for r in rows]))
    return {"bed": bed, "run": run, "rows": rows, "line": line, "table7": repair_table7(line), "soil": soil}


def _fmt(x: float, digits: int = 3) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:.{digits}g}"


def plot(result: dict[str, object], path: Path, title: str) -> None:
    """Rigid draught against speed with standard errors, the fitted line and its band, and the inertial slope."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, line = result["rows"], result["line"]
    v = np.array([r["speed"] for r in rows])
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2))
    ax[0].errorbar(v, [r["draught_mean"] for r in rows], yerr=[r["draught_sem"] for r in rows], fmt="o", capsize=3,
                   label="warpdem, steady mean ± SE")
    vv = np.linspace(v.min() - 0.02, v.max() + 0.02, 50)
    fit = np.array([line.at(x) for x in vv])
    ax[0].plot(vv, fit[:, 0], "C1", label=f"line: {line.slope:.0f} N per m/s")
    ax[0].fill_between(vv, fit[:, 0] - fit[:, 1], fit[:, 0] + fit[:, 1], color="C1", alpha=0.2)
    f68 = line.at(TABLE7_RIGID_SPEED)[0]
    k = inertial_slope(result["bed"], TABLE7_RIGID_SPEED) / (2 * TABLE7_RIGID_SPEED)
    ax[0].plot(vv, f68 + k * (vv**2 - TABLE7_RIGID_SPEED**2), "C2--", label="inertial term ρ_b w d v² (through the "
               "line at 0.68)")
    t3 = paper.table("soil_bin_measured")
    ax2 = ax[0].twinx()
    ax2.plot(t3["speed_mean_m_s"], t3["rigid_draught_mean_n"], "k^", label="lab rigid runs (Table 3, right axis)")
    ax2.set_ylabel("lab rigid draught [N]")
    ax[0].set_xlabel("carriage speed [m/s]")
    ax[0].set_ylabel("warpdem rigid draught [N]")
    h1, l1 = ax[0].get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax[0].legend(h1 + h2, l1 + l2, fontsize=7, loc="upper left")
    ax[0].set_title(title, fontsize=9)
    t7 = result["table7"]
    x = np.arange(len(t7))
    ax[1].axhline(0, color="k", lw=0.6)
    ax[1].plot(x, [r["lab_reduction"] for r in t7], "ks", label="lab (Table 3)")
    for j, col in enumerate(("c", "c_final")):
        ax[1].plot(x + 0.1 * j, [r[col]["paper_reduction"] for r in t7], f"C{j}o", mfc="none",
                   label=f"paper DEM {TABLE7_COLUMNS[col]}, rigid at 0.68")
        ax[1].errorbar(x + 0.1 * j, [r[col]["reduction"] for r in t7], yerr=[r[col]["reduction_se"] for r in t7],
                       fmt=f"C{j}o", capsize=2, label=f"paper DEM {TABLE7_COLUMNS[col]}, rigid at own speed")
    ax[1].set_xticks(x, [f"{r['springs']}\n{r['speed']:.2f}" for r in t7])
    ax[1].set_xlabel("springs / speed [m/s]")
    ax[1].set_ylabel("draught reduction [%]")
    ax[1].legend(fontsize=7)
    figures.save(fig, path, 110)


def sweep_meaning(line: SpeedLine, table7: list[dict[str, object]]) -> list[str]:
    """A short "what this means" paragraph generated from the fitted line and the re-paired Table 7 rows (their
    ``speed`` [m/s] and the laboratory's ``lab_reduction`` [%]); one markdown item per finding."""
    f68 = line.at(TABLE7_RIGID_SPEED)[0]
    se_b = math.sqrt(line.cov[1][1])
    speeds = [float(r["speed"]) for r in table7] or [TABLE7_RIGID_SPEED]
    v_lo = min(speeds)
    shift = 100.0 * line.slope * (TABLE7_RIGID_SPEED - v_lo) / f68
    lab_mean = float(np.mean([abs(float(r["lab_reduction"])) for r in table7])) if table7 else float("nan")
    out = []
    if abs(line.slope) < 2.0 * se_b:
        out.append(f"- The sweep cannot tell the rigid draught's speed dependence from none: the slope "
                   f"{line.slope:.1f} N s/m is within two standard errors ({se_b:.1f} N s/m) of zero. A longer "
                   "steady window or a larger bed would narrow it.")
    else:
        out.append(f"- The rigid draught {'rises' if line.slope > 0 else 'falls'} with speed: "
                   f"{100 * line.slope * 0.1 / f68:+.1f} % of F(0.68) per 0.1 m/s (slope {line.slope:.1f} +- "
                   f"{se_b:.1f} N s/m).")
    out.append(f"- Pairing a passive run at {v_lo:.2f} m/s with a rigid run at {TABLE7_RIGID_SPEED:.2f} m/s, as "
               f"Table 7 does, moves its reduction by {shift:+.1f} percentage points on this line; the laboratory's "
               f"reductions average {lab_mean:.1f} % in magnitude, so the pairing "
               f"{'matters' if abs(shift) >= 0.25 * lab_mean else 'matters little'} beside them.")
    if line.chi2_dof > 2.0:
        out.append(f"- The steady means scatter about the line more than their standard errors allow (reduced chi^2 "
                   f"{line.chi2_dof:.1f}): either the draught is not linear in speed here or the errors are "
                   "underestimated; the line's errors were scaled up accordingly.")
    return out


def _soil_text(soil: dict[str, float] | None, config: sb.SoilBinConfig) -> str:
    protocol = (f"bed deposited at {config.deposit_friction:g} deg, settled {config.settle_time:g} s, "
                f"{'fragile' if config.fragile else 'yielding'} bonds")
    if not soil:
        return f"GA set {config.parameter_set or sb.DEFAULT_SET[config.assembly]}; {protocol}"
    return (f"soil: contact friction {soil['friction_angle']:.2f} deg, normal cohesion "
            f"{soil['normal_cohesion']:.4g} Pa, rolling coefficient {soil['eta_roll']:.4g}; {protocol}")


def report(result: dict[str, object], config: sb.SoilBinConfig, device: str, wall: float) -> str:
    """Markdown: the sweep's table, the line, and Table 7 re-paired (signs against the laboratory's)."""
    rows, line, bed, run = result["rows"], result["line"], result["bed"], result["run"]
    lines = [f"# Rigid draught against speed — scale `{config.scale}`, assembly {config.assembly}, on `{device}`", "",
             f"Bed: {bed.n_particles} particles ({len(bed.radii)} spheres), porosity {bed.porosity:.3f}, seed "
             f"{config.seed}; {_soil_text(result.get('soil'), config)}; one simulation of "
             f"{len(rows)} worlds, {run.steps} steps of {run.dt:.3g} s, {run.wall_s:.0f} s of {wall:.0f} s wall.", "",
             "| speed [m/s] | draught [N] | SE [N] | std [N] |", "|---|---|---|---|"]
    lines += [f"| {r['speed']:.2f} | {r['draught_mean']:.1f} | {r['draught_sem']:.1f} | {r['draught_std']:.1f} |"
              for r in rows]
    se_b = math.sqrt(line.cov[1][1])
    f68 = line.at(TABLE7_RIGID_SPEED)[0]
    lines += ["", f"Weighted line: F = {line.intercept:.1f} + {line.slope:.1f} v N (slope SE {se_b:.1f} N s/m, "
              f"reduced chi^2 {line.chi2_dof:.2f}); relative slope at 0.68 m/s {100 * line.slope / f68:.1f} % per "
              f"m/s. Between 0.52 and 0.68 m/s the line changes by {line.slope * 0.16:.1f} N "
              f"({100 * line.slope * 0.16 / f68:.1f} % of F(0.68)). The inertial term rho_b w d v^2 alone has a "
              f"slope of {inertial_slope(bed, TABLE7_RIGID_SPEED):.0f} N s/m at 0.68 m/s.", "",
             "## Table 7 re-paired: each reduction against the rigid draught at its own speed", "",
             "Table 7's rigid draught (one run at 0.68 m/s) carried to each configuration's speed by the line's "
             "relative speed dependence; SE from the line's uncertainty only. Signs compared with Table 3's.", "",
             "| springs | speed | lab red. [%] | " + " | ".join(
                 f"{TABLE7_COLUMNS[c]}: paper red. | re-paired red. ± SE" for c in TABLE7_COLUMNS) + " |",
             "|---" * (3 + 2 * len(TABLE7_COLUMNS)) + "|"]
    for r in result["table7"]:
        cells = [str(r["springs"]), f"{r['speed']:.2f}", f"{r['lab_reduction']:+.2f}"]
        for c in TABLE7_COLUMNS:
            e = r[c]
            cells += [f"{e['paper_reduction']:+.2f}{'' if e['paper_sign_right'] else ' ✗'}",
                      f"{e['reduction']:+.2f} ± {e['reduction_se']:.2f}{'' if e['repaired_sign_right'] else ' ✗'}"]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "✗: sign differs from the laboratory's. The re-paired reductions are computed from Table 7's "
              "draughts; every printed reduction equals its draughts' within rounding except assembly A with 4 "
              "springs (printed 5.57 %, draughts 341.19 and 328.72 N give 3.65 %). Signs right, of 8:", ""]
    for c in TABLE7_COLUMNS:
        t7 = result["table7"]
        mae0 = np.mean([abs(r[c]["paper_reduction"] - r["lab_reduction"]) for r in t7])
        mae1 = np.mean([abs(r[c]["reduction"] - r["lab_reduction"]) for r in t7])
        lines.append(f"- {TABLE7_COLUMNS[c]}: paper {sum(r[c]['paper_sign_right'] for r in t7)}, re-paired "
                     f"{sum(r[c]['repaired_sign_right'] for r in t7)}; MAE against Table 3 {mae0:.2f} -> "
                     f"{mae1:.2f} percentage points")
    lines += ["", "## What this means", "", *sweep_meaning(line, result["table7"]), "",
              "![rigid draught against speed](rigid_speed.png)", ""]
    return "\n".join(lines)


def write(result: dict[str, object], out: Path, config: sb.SoilBinConfig, device: str, wall: float) -> None:
    """summary.json (rows, line, re-paired Table 7; null for missing values), rigid_speed.png and report.md."""
    bed, run = result["bed"], result["run"]
    summary = {"config": asdict(config), "soil": result.get("soil"), "device": device, "wall_s": wall,
               "rows": result["rows"],
               "line": asdict(result["line"]), "table7": result["table7"],
               "bed": {"particles": bed.n_particles, "spheres": int(len(bed.radii)), "porosity": bed.porosity},
               "run": {"dt": run.dt, "steps": run.steps, "wall_s": run.wall_s}}
    write_text_atomic(out / "summary.json", json.dumps(sb.json_safe(summary), indent=2))
    write_atomic(out / "series.npz", lambda p: np.savez_compressed(
        p, time=run.time, travel=run.travel, draught=run.series["draught"], speeds=np.array(run.speeds)))
    write_atomic(out / "rigid_speed.png", lambda p: plot(
        result, p, f"scale {config.scale}, assembly {config.assembly}, {device}"))
    write_text_atomic(out / "report.md", report(result, config, device, wall))


def main(out: str | Path, config: sb.SoilBinConfig, speeds: tuple[float, ...] = SWEEP_SPEEDS, *,
         device: str = "cpu", progress: object | None = None, vtk_every: int | None = None,
         soil: dict[str, float] | None = None) -> dict[str, object]:
    """Run the sweep into ``out`` (bed cache OUT/beds, checkpoint OUT/checkpoints/rigid_speed, removed when done)
    and write its files; returns the result of :func:`run_sweep`. ``vtk_every``: ParaView frames of every world at
    every ``vtk_every``-th record, into OUT/vtk/. ``soil``: see :func:`run_sweep`."""
    import shutil

    t0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ck = out / "checkpoints" / "rigid_speed"
    vtk = (VtkWriter(out / "vtk"), vtk_every) if vtk_every else None
    result = run_sweep(config, speeds, device=device, cache_dir=out / "beds", checkpoint=ck, progress=progress,
                       vtk=vtk, soil=soil)
    write(result, out, config, device, time.perf_counter() - t0)
    shutil.rmtree(ck, ignore_errors=True)
    return result
