"""The workflow's report: Tables 2, 3 and 7 beside warpdem's values, with standard errors, and figures like the
paper's Figs. 16-19 with the laboratory's values drawn in (:mod:`calibration.paper_workflow`)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from scenes import figures, paper
from scenes.soil_bin import SCALES
from warpdem.files import write_text_atomic

from .workflow_config import CALIBRATION_SCALE, SCREEN_SCALE, VARIANTS, WorkflowConfig


def _f(v: object, digits: int = 4) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{v:.{digits}g}" if isinstance(v, float) else str(v)


def _pm(e: dict, digits: int = 4) -> str:
    return f"{_f(e['mean'], digits)} ± {_f(e['sem'], 2)}"


def _plt():
    return figures.plt()


def plot_reductions(table3: dict, path: Path, assembly: str = "C") -> None:
    """Reduction per configuration: warpdem (both variants, replica-mean ± SE), the laboratory (Table 3) and the
    paper's DEM (Table 7: the final model in the 2 m bin, ``assembly`` in the 1 m bin)."""
    rows = [{"springs": r["springs"], "mean": r["reduction"]["mean"], "sem": r["reduction"]["sem"],
             "label": f"warpdem, {VARIANT_LABELS.get(variant, variant)}, mean of {table3['replicas']} beds"}
            for variant in VARIANTS for r in table3["variants"][variant]]
    figures.plot_reductions(rows, path, assembly=assembly,
                            title="Draught reduction of the passive tool against the rigid tool at its speed "
                                  "(Table 3's pairing)")


VARIANT_LABELS = {"offset": "with Table 2's support offsets", "no_offset": "without the support offsets"}

FIGURE_CAPTIONS = {
    "fig_reductions.png":
        "Draught reduction [%] per configuration: warpdem's (both variants of the passive tool, the mean over the "
        "beds +-1 standard error from their scatter) beside the laboratory's (Table 3) and the paper's DEM "
        "(Table 7: its final model in the 2 m bin, and the assembly in the 1 m calibration bin).",
    "fig16_draught_displacement.png":
        "Fig. 16-like, one panel per configuration (the passive tool with Table 2's support offsets): replica 0's "
        "draught [N] of the passive tool (blue) and of the rigid tool at the same speed (grey), and the passive "
        "tool's displacement [mm] (green, right axis), against the carriage's travel. Thick lines over the steady "
        "window: the means over all beds (the report's table), bands +-1 standard error; dashed: the laboratory's "
        "means (Table 3: passive draught red, rigid black, displacement green); dotted red: the paper's final DEM "
        "(Table 7). Each trace ends where its carriage stops at the end of travel (the steady window's end); the "
        "records after it (the tool standing still while slower worlds finish) are left out, as they are of the "
        "statistics; the displacement's record at the stop itself is left out of the plot too (the carriage has "
        "overshot the travel there by up to one record interval x its speed, which that one reading takes as "
        "displacement). The displacement is zeroed on the tool at rest before the cut; a negative value means the "
        "tool moved forward of its rest pose.",
    "fig17_fft_draught.png":
        "Fig. 17-like, one panel per configuration: amplitude spectrum [N] of replica 0's steady draught, passive "
        "tool and rigid tool at the same speed, 100 Hz Butterworth low-pass first (as the paper); the resolution "
        "is 1 / the steady window's duration.",
    "fig18_fft_displacement.png":
        "Fig. 18-like, one panel per configuration: amplitude spectrum [mm] of replica 0's steady displacement of "
        "the passive tool (100 Hz low-pass first).",
    "fig19_tool_kinetic_energy.png":
        "Fig. 19-like, one panel per configuration: replica 0's kinetic energy [J] of the passive tool against "
        "travel, total (solid) and rotational (dotted); thick line over the steady window: its steady mean, band "
        "+-1 standard deviation of the record.",
}


def figure_captions(names: list[str]) -> list[str]:
    """The report's lines for the figures ``names``: each image with its caption (:func:`scenes.figures.figure_captions`
    with this report's :data:`FIGURE_CAPTIONS`)."""
    return figures.figure_captions(names, FIGURE_CAPTIONS)


def plot_series(out: Path, config: WorkflowConfig, table3: dict) -> list[str]:
    """Figs. 16-19-like plots from replica 0's series: draught and displacement against travel with the
    means over the beds and the laboratory's, FFTs of the steady draught and displacement, the tool's kinetic
    energy; each cut at its carriage's stop."""
    from scenes import analysis

    plt = _plt()
    t3, t7 = paper.table("soil_bin_measured"), paper.table("soil_bin_dem")
    job_of = {}
    for f in sorted((out / "table3").glob("*.npz")):  # replica 0's worlds of each job
        if f.name.startswith("."):  # a write that was killed left its temporary file
            continue
        with np.load(f) as d:
            s = {k: d[k] for k in d.files}
        if "springs" in s:  # the job's kind and its saved worlds' springs and speeds
            kind, springs, speeds_w = str(s["kind"]), s["springs"].tolist(), s["speeds"].tolist()
        else:  # written before they were saved with the series: every world of the job is replica 0's
            done = json.loads((out / "table3" / f"{f.stem}.json").read_text())
            kind, springs, speeds_w = f.stem.split("_", 1)[1].rsplit("_", 1)[0], done["springs"], done["speeds"]
        for w, n in enumerate(springs):
            job_of[(kind, n, round(speeds_w[w], 6))] = (s, w)
    names = []
    start = config.steady_travel or SCALES[config.scale]["steady_travel"]
    speeds = config.speeds()
    shown = [("offset", n) for n in config.springs]
    row_of = {r["springs"]: r for r in table3["variants"]["offset"]}
    rigid_of = {round(r["speed"], 6): r for r in table3["rigid"]}
    beds = table3["replicas"]

    def cut(s: dict, w: int) -> int:
        return figures.moving_records(s["travel"][:, w])

    # Fig. 16
    fig, axes = plt.subplots(len(shown), 1, figsize=(11, 2.4 * len(shown)), sharex=True, squeeze=False)
    legend: dict[str, object] = {}
    for a, (kind, n) in zip(axes[:, 0], shown, strict=True):
        s, w = job_of[(kind, n, round(speeds[n], 6))]
        r, wr = job_of[("rigid", 0, round(speeds[n], 6))]
        m, mr = cut(s, w), cut(r, wr)
        end = float(s["travel"][m - 1, w])
        a.axvspan(start, end, color="0.93", zorder=0, label="steady window")
        a.plot(r["travel"][:mr, wr], r["draught"][:mr, wr], lw=0.5, color="0.6", label="rigid draught, replica 0")
        a.plot(s["travel"][:m, w], s["draught"][:m, w], lw=0.6, color="C0", label="passive draught, replica 0")
        row, rig = row_of.get(n), rigid_of.get(round(speeds[n], 6))
        if rig is not None:
            figures.steady_band(a, start, end, rig["draught"]["mean"], rig["draught"]["sem"], "0.3",
                                f"rigid draught, mean of {beds} beds ± SE")
        if row is not None:
            figures.steady_band(a, start, end, row["draught"]["mean"], row["draught"]["sem"], "C1",
                                f"passive draught, mean of {beds} beds ± SE")
        i = np.nonzero(t3["springs"] == n)[0][0]
        a.axhline(t3["passive_draught_mean_n"][i], color="C3", ls="--", lw=1, label="passive draught, laboratory")
        a.axhline(t3["rigid_draught_mean_n"][i], color="k", ls="--", lw=0.8, label="rigid draught, laboratory")
        a.axhline(t7["c_final_mean_n"][t7["springs"] == n][0], color="C3", ls=":", lw=0.9,
                  label="passive draught, paper's final DEM (Table 7)")
        a.set_ylabel("draught [N]")
        a.set_title(f"{n} springs at {speeds[n]:.2f} m/s", fontsize=9, loc="left")
        b = a.twinx()
        md = figures.displacement_records(s["travel"][:, w])
        disp = 1e3 * s["displacement"][:md, w]
        lab = float(t3["displacement_mean_mm"][i])
        b.plot(s["travel"][:md, w], disp, color="C2", lw=0.6, label="displacement, replica 0")
        if row is not None:
            figures.steady_band(b, start, end, row["displacement_mm"]["mean"], row["displacement_mm"]["sem"], "C2",
                                f"displacement, mean of {beds} beds ± SE")
        b.axhline(lab, color="C2", ls="--", lw=0.8, label="displacement, laboratory")
        lo, hi = min(float(disp.min()), lab, 0.0), max(float(disp.max()), lab, 0.0)
        b.set_ylim(lo - 0.1 * (hi - lo), hi + 0.15 * (hi - lo))
        b.set_ylabel("disp. [mm]", color="C2")
        for ax_ in (a, b):
            for h, label in zip(*ax_.get_legend_handles_labels(), strict=True):
                legend.setdefault(label, h)
    axes[-1, 0].set_xlabel("carriage travel [m]")
    fig.suptitle("Draught and tool displacement against travel (like the paper's Fig. 16; with Table 2's support "
                 "offsets); each trace ends at its carriage's stop", fontsize=10, y=1.0)
    fig.legend(list(legend.values()), list(legend), loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=3,
               fontsize=8)
    figures.save(fig, out / "fig16_draught_displacement.png", 100, tight_box=True)
    names.append("fig16_draught_displacement.png")
    # Figs. 17-19: one panel per configuration, as the paper's
    cols = 4
    rows_n = int(np.ceil(len(shown) / cols))
    for key, fname, unit, what in (
            ("draught", "fig17_fft_draught.png", "N", "Spectrum of the steady draught (like the paper's Fig. 17)"),
            ("displacement", "fig18_fft_displacement.png", "mm",
             "Spectrum of the passive tool's steady displacement (like the paper's Fig. 18)"),
            ("ke_tool", "fig19_tool_kinetic_energy.png", "J", "The passive tool's kinetic energy (like the paper's "
             "Fig. 19)")):
        fig, axes = plt.subplots(rows_n, cols, figsize=(3.6 * cols, 3.0 * rows_n), squeeze=False)
        legend = {}
        resolution = 0.0
        for a, (kind, n) in zip(axes.flat, shown, strict=False):
            s, w = job_of[(kind, n, round(speeds[n], 6))]
            m = cut(s, w)
            a.set_title(f"{n} springs at {speeds[n]:.2f} m/s", fontsize=9)
            if key == "ke_tool":
                x = s["travel"][:m, w]
                ke = s["ke_tool"][:m, w]
                a.plot(x, ke.sum(axis=-1), lw=0.6, color="C0", label="warpdem, total (replica 0)")
                a.plot(x, ke[:, 1], lw=0.6, ls=":", color="C0", label="warpdem, rotational (replica 0)")
                st = x >= start
                tot = ke.sum(axis=-1)[st]
                if st.any():
                    figures.steady_band(a, start, float(x[-1]), float(tot.mean()), float(tot.std()), "C1",
                                        "warpdem, steady mean ± std")
                if figures.fig19_reference(a, n, float(x[-1]), "C3"):
                    a.lines[-1].set_label("paper's DEM trend (Fig. 19)")
                a.set_xlabel("carriage travel [m]")
            else:
                scale = 1e3 if key == "displacement" else 1.0
                jobs = [("passive tool", s, w, "C0")]
                if key == "draught":
                    r, wr = job_of[("rigid", 0, round(speeds[n], 6))]
                    jobs.append(("rigid tool", r, wr, "0.5"))
                for label, js, jw, color in jobs:
                    mj = cut(js, jw) if key == "draught" else figures.displacement_records(js["travel"][:, jw])
                    sel = np.zeros(len(js["time"]), bool)
                    sel[:mj] = js["travel"][:mj, jw] >= start
                    f, amp = analysis.spectrum(js["time"][sel], scale * js[key][sel, jw], cutoff_hz=100.0)
                    a.plot(f, amp, lw=0.7, color=color, label=f"warpdem, {label} (replica 0)")
                    resolution = max(resolution, 1.0 / float(np.ptp(js["time"][sel])))
                figures.fft_references(a, key, [n], {n: "C3"})
                if key == "displacement":  # one legend entry per kind of reference, not per configuration
                    for line in a.lines[1:]:
                        text = line.get_label()
                        line.set_label("paper's DEM peak (Fig. 18d)" if "paper" in text else
                                       "laboratory ringing frequency (Table 2)")
                a.set_xlim(0, 60)
                a.set_xlabel("frequency [Hz]")
            a.set_ylabel(f"{'kinetic energy' if key == 'ke_tool' else 'amplitude'} [{unit}]")
            for h, label in zip(*a.get_legend_handles_labels(), strict=True):
                legend.setdefault(label, h)
        for a in list(axes.flat)[len(shown):]:
            a.set_visible(False)
        fig.suptitle(what + (f"; resolution {resolution:.2g} Hz" if resolution else ""), fontsize=10)
        fig.legend(list(legend.values()), list(legend), loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=3,
                   fontsize=8)
        figures.save(fig, out / fname, 100, tight_box=True)
        names.append(fname)
    return names


def write_workflow_report(out: Path, config: WorkflowConfig, summary: dict, *, device: str | None,
                          status: str | None = None) -> Path:
    """Write ``report.md`` (and its figures) into ``out``; returns its path. ``summary`` holds the stages done
    (``ringing``: model -> stage result; ``draught``, ``screening``, ``table3``: present when done); ``status``: a
    line saying what is still to come (None: the run is complete)."""
    out = Path(out)
    t3, t7 = paper.table("soil_bin_measured"), paper.table("soil_bin_dem")
    c = config
    col = {"A": "a", "B": "b", "C": "c"}[c.assembly]
    lines = [f"# warpdem workflow — scale `{c.scale}`, assembly {c.assembly}, on `{device}`", "",
             "The paper's workflow end to end: ringing calibration -> draught calibration -> shear-box screening -> "
             "Table 3 on several independent beds. Configuration: `workflow.json`; every value below was computed "
             "by this run unless it is labelled as the laboratory's (Tables 2, 3) or the paper's DEM (Tables 2, 7).",
             ""]
    if status:
        lines += [f"**In progress:** {status}", ""]
    # --- Table 2
    for model, ring in summary.get("ringing", {}).items():
        genes = ("stiffness [N/m]", "damping ratio") if model == "linear" else ("spring E [Pa]", "local damping")
        keys = ("stiffness", "damping_ratio") if model == "linear" else ("young", "local_damping")
        lines += [f"## Ringing calibration, {'linear spring-dashpot' if model == 'linear' else 'spring spheres'} "
                  f"(Table 2; dt {ring['dt']:.3g} s, {ring['wall_s']:.0f} s)", "",
                  "Columns in three groups: **measured** (Table 2), the **paper's DEM** (its calibrated Yade model, "
                  "Table 2) and **warpdem** (this calibration: its genes, frequency, damping ratio and relative errors "
                  "against the measured values in %, and the individuals it simulated).", "",
                  f"| springs | measured f [Hz] | measured zeta [-] | paper's DEM f [Hz] | paper's DEM zeta [-] | "
                  f"warpdem {genes[0]} | warpdem {genes[1]} | warpdem f [Hz] | warpdem zeta [-] | warpdem RE f [%] | "
                  "warpdem RE zeta [%] | warpdem individuals |", "|---" * 12 + "|"]
        for r in ring["rows"]:
            row = paper.ringing_row(r["springs"])
            lines.append("| " + " | ".join([
                str(r["springs"]), _f(r["target_freq_hz"]), _f(r["target_damping"]), _f(row["calibrated_freq_hz"]),
                _f(row["calibrated_damping"]), _f(r[keys[0]]), _f(r[keys[1]]), _f(r["freq_hz"]), _f(r["damping"]),
                _f(100 * r["re_freq"], 3), _f(100 * r["re_damp"], 3), str(r["simulated"])]) + " |")
        lines.append("")
    # --- draught calibration and screening
    d, s = summary.get("draught"), summary.get("screening")
    if d is None:
        return _write(out, lines)
    lines += [f"## Draught calibration ({d['scale']} bin, {d['simulated']} individuals, {d['wall_s']:.0f} s)", "",
              f"Target: the laboratory's rigid draught at 0.62 m/s, {d['target_n']:.1f} N. Best individual: "
              f"{_f(d['best']['observables']['draught_mean_n'])} N (relative error "
              f"{_f(100 * d['best']['errors']['re_draught'], 3)} %), genes {d['best']['genes']}. "
              f"Accepted (|RE| < 10 %): {d['accepted']}. Details: `draught/report.md`.", ""]
    if s is None:
        return _write(out, lines)
    lines += [f"## Shear-box screening ({SCREEN_SCALE[c.scale]} scale, {s['wall_s']:.0f} s)", "",
              "The sets screened are " + ("the accepted ones." if s["from_accepted"] else
                                          "the fittest ones, since no set was accepted.")
              + " Laboratory: 6.4 kPa, 32.3 deg.", "",
              "| rank | friction angle [deg] | normal cohesion [Pa] | eta | draught [N] | c [kPa] | phi [deg] | "
              "distance |", "|---" * 8 + "|"]
    for r in s["rows"]:
        lines.append(f"| {r['rank']} | {_f(r['friction_angle'])} | {_f(r['normal_cohesion'])} | {_f(r['eta_roll'])} "
                     f"| {_f(r['draught_mean_n'])} | {_f(r['cohesion_kpa'])} | {_f(r['friction_angle_deg'])} | "
                     f"{_f(r['distance'], 3)} |")
    lines += ["", f"Soil of the Table 3 runs: rank 1, {s['chosen']}.", ""]
    # --- Table 3 / 7
    tab = summary.get("table3")
    if tab is None:
        return _write(out, lines)
    se = ("the standard error from the scatter over beds" if tab["replicas"] > 1 else
          "with one bed so far, the standard error of that record's mean from its autocorrelation "
          "(`analysis.steady_state`), which leaves out the bed-to-bed scatter")
    lines += [f"## Table 3 and Table 7 ({tab['replicas']} independent bed{'s' if tab['replicas'] > 1 else ''})", "",
              "Every reduction is against the rigid run on the same bed at the configuration's own speed (Table 3's "
              f"pairing), averaged over the beds; ± is {se}. Table 7's columns are the paper's DEM: assembly "
              f"{c.assembly} in the 1 m bin (its calibration bin; column {col.upper()}), and, for assembly C, the "
              "final model in the 2 m bin, whose reductions are against one rigid run at 0.68 m/s.", "",
              "Passive tool: " + ("the ringing calibration's springs (stiffness and dashpot per configuration, the "
                                  "paper's way)" if c.passive_tool is None else
                                  f"described once (`{c.passive_tool.get('source') or 'given in code'}`), the "
                                  "displacement zeroed at rest") + ".", ""]
    for variant in VARIANTS:
        cmp_ = tab["comparison"][variant]
        lines += [f"### Passive tool {'with' if variant == 'offset' else 'without'} Table 2's support offsets", "",
                  "| springs | speed [m/s] | rigid [N] | passive [N] | reduction [%] | disp. [mm] | lab rigid [N] | "
                  "lab passive [N] | lab red. [%] | lab disp. [mm] | paper DEM 1 m red. [%] | paper DEM final [N] | "
                  "paper DEM final red. [%] |", "|---" * 13 + "|"]
        for r in tab["variants"][variant]:
            i3 = np.nonzero(t3["springs"] == r["springs"])[0][0]
            i7 = np.nonzero(t7["springs"] == r["springs"])[0][0]
            lines.append("| " + " | ".join([
                str(r["springs"]), _f(r["speed"], 3), _pm(r["rigid"]), _pm(r["draught"]), _pm(r["reduction"], 3),
                _pm(r["displacement_mm"], 3), _f(t3["rigid_draught_mean_n"][i3]),
                _f(t3["passive_draught_mean_n"][i3]), _f(t3["reduction_pct"][i3], 3),
                _f(t3["displacement_mean_mm"][i3], 3), _f(t7[f"{col}_red_pct"][i7], 3), _f(t7["c_final_mean_n"][i7]),
                _f(t7["c_final_red_pct"][i7], 3)]) + " |")
        if any(r["displacement_mm"]["mean"] < 0 for r in tab["variants"][variant]):
            lines += ["", "A negative displacement: the sensor is zeroed on the tool at rest before the cut, so a "
                      "negative reading means the tool moved forward of its rest pose (towards the travel)."]
        met = (cmp_["mae_pp"] < 1.5 and cmp_["signs_right"] == cmp_["n"] and cmp_["max_sem_pp"] < 1.0)
        lines += ["", f"Against Table 3: MAE {cmp_['mae_pp']:.2f} ± {cmp_['mae_sem_pp']:.2f} percentage points, signs "
                  f"right {cmp_['signs_right']} of {cmp_['n']}, largest SE {cmp_['max_sem_pp']:.2f} pp. The paper's "
                  f"DEM in the 1 m bin (column {col.upper()}): MAE {cmp_['paper_dem_1m_mae_pp']:.2f} pp, signs right "
                  f"{cmp_['paper_dem_1m_signs_right']} of {cmp_['n']}; its final DEM (2 m bin): MAE "
                  f"{cmp_['paper_dem_mae_pp']:.2f} pp, signs right {cmp_['paper_dem_signs_right']} of "
                  f"{cmp_['n']}. Goal (MAE < 1.5 pp, every sign right, every SE < 1 pp): "
                  f"{'met' if met else 'not met'}.", ""]
    rig = tab["rigid"]
    lines += ["### Rigid tool", "", "| speed [m/s] | draught [N] | lab (Table 3 rows at this speed) [N] |",
              "|---|---|---|"]
    for r in rig:
        same = np.abs(t3["speed_mean_m_s"] - r["speed"]) < 5e-3
        lines.append(f"| {_f(r['speed'], 3)} | {_pm(r['draught'])} | "
                     f"{_f(float(np.mean(t3['rigid_draught_mean_n'][same])))} |")
    plot_reductions(tab, out / "fig_reductions.png", c.assembly)
    plots = ["fig_reductions.png"]
    try:
        plots += plot_series(out, c, tab)
    except KeyError:  # replica 0's series incomplete (jobs run elsewhere): the figures from series are skipped
        pass
    lines += ["", f"Calibration bin: `{CALIBRATION_SCALE[c.scale]}`; bed settling {c.settle_time} s; "
              f"worlds per simulation at most {c.worlds_per_job}.", ""]
    lines += figure_captions(plots)
    lines += limits_section(tab, s)
    lines += diagnosis_section(summary.get("diagnosis"))
    return _write(out, lines)


def limits(tab: dict, screening: dict | None) -> dict:
    """What this run's own numbers say about its distance from Table 3, per variant of ``tab`` (the Table 3
    stage's summary) and from the shear-box ``screening``: the passive tool's mean displacement against the
    laboratory's (ratio per configuration, [-]), the spread (max - min) of the reductions [percentage points] and
    their Pearson correlation with the laboratory's over the configurations, and the screened soils' shear-box
    strength and the range of normal cohesion [Pa] and draught [N] over the screened sets."""
    t3 = paper.table("soil_bin_measured")
    out: dict = {"variants": {}}
    for variant, rows in tab["variants"].items():
        idx = [int(np.nonzero(t3["springs"] == r["springs"])[0][0]) for r in rows]
        sim_red = np.array([r["reduction"]["mean"] for r in rows])
        lab_red = np.asarray(t3["reduction_pct"], dtype=float)[idx]
        sim_disp = np.array([r["displacement_mm"]["mean"] for r in rows])
        lab_disp = np.asarray(t3["displacement_mean_mm"], dtype=float)[idx]
        out["variants"][variant] = {
            "springs": [int(r["springs"]) for r in rows],
            "disp_ratio": (sim_disp / lab_disp).tolist(),
            "sim_disp_mm": [float(sim_disp.min()), float(sim_disp.max())],
            "lab_disp_mm": [float(lab_disp.min()), float(lab_disp.max())],
            "sim_reduction_pct": [float(sim_red.min()), float(sim_red.max())],
            "lab_reduction_pct": [float(lab_red.min()), float(lab_red.max())],
            "correlation": float(np.corrcoef(sim_red, lab_red)[0, 1]) if len(rows) > 2 else float("nan")}
    if screening is not None and screening.get("rows"):
        rows = screening["rows"]
        chosen = min(rows, key=lambda r: r["rank"])
        out["screening"] = {
            "cohesion_kpa": float(chosen["cohesion_kpa"]), "friction_angle_deg": float(chosen["friction_angle_deg"]),
            "normal_cohesion_pa": [min(r["normal_cohesion"] for r in rows), max(r["normal_cohesion"] for r in rows)],
            "draught_n": [min(r["draught_mean_n"] for r in rows), max(r["draught_mean_n"] for r in rows)],
            "n_sets": len(rows)}
    return out


def limits_section(tab: dict, screening: dict | None) -> list[str]:
    """The report's lines on what limits the match with Table 3, from :func:`limits` (this run's numbers only;
    the diagnosis, stage 5, fits the candidate mechanisms)."""
    lim = limits(tab, screening)
    lines = ["", "## What limits the match (this run's numbers)", ""]
    still, narrow = True, True  # in every variant: most tools move less than half the laboratory's; narrow spread
    for variant, v in lim["variants"].items():
        ratio = np.array(v["disp_ratio"])
        small = [n for n, q in zip(v["springs"], ratio, strict=True) if q < 0.5]
        still = still and 2 * len(small) > len(ratio)
        narrow = narrow and (v["sim_reduction_pct"][1] - v["sim_reduction_pct"][0]
                             < 0.5 * (v["lab_reduction_pct"][1] - v["lab_reduction_pct"][0]))
        lines.append(
            f"- {'With' if variant == 'offset' else 'Without'} the support offsets: the passive tool's mean "
            f"displacement is {v['sim_disp_mm'][0]:.2f}-{v['sim_disp_mm'][1]:.2f} mm against the laboratory's "
            f"{v['lab_disp_mm'][0]:.2f}-{v['lab_disp_mm'][1]:.2f} mm (ratio {ratio.min():.2f}-{ratio.max():.2f}; "
            f"below half the laboratory's for {len(small)} of {len(ratio)} configurations"
            + (f": {', '.join(str(n) for n in small)} springs" if small else "") + "). The reductions span "
            f"{v['sim_reduction_pct'][0]:.1f} to {v['sim_reduction_pct'][1]:.1f} % "
            f"({v['sim_reduction_pct'][1] - v['sim_reduction_pct'][0]:.1f} pp) against "
            f"{v['lab_reduction_pct'][0]:.1f} to {v['lab_reduction_pct'][1]:.1f} % "
            f"({v['lab_reduction_pct'][1] - v['lab_reduction_pct'][0]:.1f} pp); their correlation with the "
            f"laboratory's over the configurations is r = {v['correlation']:.2f}.")
    if "screening" in lim:
        sc = lim["screening"]
        lines.append(
            f"- The soil: the chosen set gives c = {sc['cohesion_kpa']:.2f} kPa and phi = "
            f"{sc['friction_angle_deg']:.1f} deg in the shear box against the laboratory's 6.4 kPa and 32.3 deg. "
            f"The {sc['n_sets']} screened sets reach draughts of {sc['draught_n'][0]:.0f}-{sc['draught_n'][1]:.0f} N "
            f"with normal cohesions from {sc['normal_cohesion_pa'][0]:.3g} to {sc['normal_cohesion_pa'][1]:.3g} Pa"
            + (": the draught does not pin the cohesion down." if sc["normal_cohesion_pa"][1]
               > 10 * sc["normal_cohesion_pa"][0] and sc["draught_n"][1] < 1.05 * sc["draught_n"][0] else "."))
    if still and narrow:
        lines += ["", "Most simulated tools move less than half as far as the laboratory's, and the reductions "
                  "spread less than half as wide: this points at the passive tool's motion in the soil, not at the "
                  "bed-to-bed scatter (which the replicas average out), as what keeps the reductions from the "
                  "laboratory's."]
    return lines + [""]


def diagnosis_section(diag: dict | None) -> list[str]:
    """The report's lines on the diagnosis of Table 3 (stage 5), pointing to its own report."""
    if diag is None:
        return []
    cause = f": **{' + '.join(diag['cause'])}**" if diag["cause"] else ""
    lines = ["", f"## Diagnosis of Table 3 ({diag['scale']} bin, {diag['n_simulations']} simulated worlds)", "",
             f"Verdict: {diag['verdict']}{cause}"
             + (" (a residual larger than the stated noise remains)" if diag["cause"] and diag["residual_left"]
                else "") + ". Candidates by held-out loss: " + (", ".join(diag["ranking"]) or "none") + ". "
             "Every fitted point is one soil-bin run per configuration on one bed of the calibration bin, with the "
             "soil of the Table 3 runs. " + _rounds_text(diag.get("rounds"))
             + "Details, fits and figures: `diagnosis/report.md`.", ""]
    return lines


def _rounds_text(rounds: int | None) -> str:
    """How far the diagnosis's fits went (``diagnosis.json``'s rounds; absent in a folder made before it was kept)."""
    if rounds is None:
        return ""
    if rounds == 1:
        return ("Its fits are the first round's grid alone (`--diagnosis-rounds 1`): each mechanism's best grid "
                "point, not refined by Levenberg-Marquardt steps: a refined fit's loss on all data can only be "
                "lower (it chooses among more points), its held-out losses may move either way. ")
    return f"Its fits: a grid, then {rounds - 1} Levenberg-Marquardt round{'s' * (rounds > 2)}. "


def _write(out: Path, lines: list[str]) -> Path:
    path = out / "report.md"
    write_text_atomic(path, "\n".join(lines) + "\n")
    return path
