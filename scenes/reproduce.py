"""The study of the paper at a chosen scale: ringing (every spring model) and soil bin, with a report.

Writes into one folder: config.json (every parameter, versions, device, seed), ringing_<model>.npz, soil_bin.npz,
summary.json, PNG plots (like the paper's Figs. 6, 16, 17, 18, 19) and report.md setting the results beside
Tables 2, 3 and 7. A call on a folder of an interrupted one keeps what that one finished: each spring model's ringing
result (``ringing_<model>.npz``, read back when its configuration is the same), the deposited bed (``beds/``) and
the soil-bin runs' checkpoints (``checkpoints/``).
"""

from __future__ import annotations

import json
import math
import platform
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from warpdem.files import write_atomic, write_text_atomic

from . import analysis, figures, paper, ringing, speed_sweep
from . import soil_bin as sb


def versions() -> dict[str, str]:
    import warp as wp

    import warpdem

    return {"warpdem": warpdem.__version__, "warp": wp.config.version, "numpy": np.__version__,
            "python": platform.python_version(), "platform": platform.platform()}


def _plt():
    return figures.plt()


def plot_ringing(results: dict[str, ringing.RingingResult], path: Path) -> None:
    """Fig. 6-like: sensor displacement [mm] after the hit, one panel per configuration, every spring model; each
    panel's title gives the laboratory's and the paper's DEM frequency and damping ratio (Table 2)."""
    plt = _plt()
    springs = next(iter(results.values())).springs
    fig, axes = plt.subplots(2, 4, figsize=(14, 6.4), sharex=True)
    for k, (n, ax) in enumerate(zip(springs, axes.flat, strict=False)):
        for name, res in results.items():
            ax.plot(res.time, 1e3 * res.displacement[:, k], lw=0.8,
                    label=f"warpdem {MODEL_LABELS.get(name, name)}: {res.frequency_hz[k]:.2f} Hz, "
                          f"zeta {res.damping_ratio[k]:.3f}")
        row = paper.ringing_row(n)
        ax.set_title(f"{n} springs: laboratory {row['measured_freq_hz']:.2f} Hz, zeta {row['measured_damping']:.3f}\n"
                     f"paper's DEM {row['calibrated_freq_hz']:.2f} Hz, zeta {row['calibrated_damping']:.3f}",
                     fontsize=8)
        ax.legend(fontsize=6)
    for ax in axes[-1, :]:
        ax.set_xlabel("time after the hit [s]")
    for ax in axes[:, 0]:
        ax.set_ylabel("sensor displacement [mm]")
    for ax in list(axes.flat)[len(springs):]:
        ax.set_visible(False)
    fig.suptitle("Ringing test (like the paper's Fig. 6): warpdem's spring models, uncalibrated, against Table 2",
                 fontsize=11)
    figures.save(fig, path, 110)


def _world_name(n: int, run: object, w: int) -> str:
    """A world's label: its configuration, and its replica bed where it has one."""
    rep = run.steady[w].get("replica_seed") if len(run.steady) > w else None
    return (f"rigid at {run.speeds[w]:.2f} m/s" if n == 0 else f"{n} springs at {run.speeds[w]:.2f} m/s") + \
        ("" if rep is None else f", replica {rep}")


FIGURE_CAPTIONS = {
    "fig16_draught_displacement.png":
        "Fig. 16-like: draught [N] (left axis) and, for the passive tool, the sensor's displacement [mm] (right axis, "
        "green) against the carriage's travel, one panel per simulated world. Thick lines over the shaded steady "
        "window: warpdem's steady means, their bands +-1 standard error (the report's table); dashed: the "
        "laboratory's means (Table 3: draught black, displacement green); dotted red: the paper's final DEM "
        "(Table 7). Each trace ends where its carriage stops at the end of travel (the steady window's end): a "
        "faster world's tool then stands still at the end of the bin while the slowest world finishes, and those "
        "records (no cutting; the soil relaxing against a stopped tool, its draught falling to zero or below) are "
        "left out of the plot, as they are of the statistics. The displacement's last record, at the stop itself, "
        "is left out of the plot too: the carriage has overshot the travel there by up to one record interval "
        "x its speed (about 1 mm), which that one reading takes as displacement. The displacement "
        "is zeroed on the tool at rest before the cut; a negative value means the tool moved forward of its rest "
        "pose.",
    "fig17_fft_draught.png":
        "Fig. 17-like: amplitude spectrum [N] of the steady draught (100 Hz Butterworth low-pass first, as the "
        "paper), every world; its resolution (in the title) is 1 / the steady window's duration.",
    "fig18_fft_disp.png":
        "Fig. 18-like: amplitude spectrum [mm] of the passive tool's steady displacement (100 Hz low-pass first); "
        "its resolution (in the title) is 1 / the steady window's duration.",
    "fig19_tool_kinetic_energy.png":
        "Fig. 19-like: the passive tool's kinetic energy [J] against travel, total (solid) and rotational (dotted); "
        "thick line over the steady window: its steady mean, band +-1 standard deviation of the record.",
    "fig_reductions.png":
        "Draught reduction [%] of each passive configuration against warpdem's rigid run at its own speed, +-1 "
        "standard error, beside the laboratory's (Table 3) and the paper's DEM (Table 7).",
}


def plot_soil_bin(study: dict, out: Path, assembly: str = "C") -> list[str]:
    """Figs. 16-19-like plots of the soil-bin runs and the reductions against the laboratory's; returns the file
    names (their captions: :data:`FIGURE_CAPTIONS`, with the references of Figs. 17-19 added by
    :func:`figure_captions`)."""
    plt = _plt()
    runs = study["runs"]
    names = []
    series = []
    for run in runs.values():
        for w, n in enumerate(run.springs):
            series.append((n, run, w))
    colors = {(id(run), w): f"C{k % 10}" for k, (n, run, w) in enumerate(series)}
    t3, t7 = paper.table("soil_bin_measured"), paper.table("soil_bin_dem")
    start = study["steady_travel"]
    # Fig. 16: draught and displacement vs travel up to each carriage's stop, the steady means with their standard
    # errors, the laboratory's and the paper's final DEM's means as references
    fig, ax = plt.subplots(len(series), 1, figsize=(11, 2.7 * len(series)), sharex=True, squeeze=False)
    legend: dict[str, object] = {}
    for a, (n, run, w) in zip(ax[:, 0], series, strict=True):
        m = figures.moving_records(run.travel[:, w])
        x = run.travel[:m, w]
        end = float(x[-1])
        st = run.steady[w] if len(run.steady) > w else {}
        a.plot(x, run.series["draught"][:m, w], lw=0.6, color="C0", label="draught, warpdem")
        a.axvspan(start, end, color="0.93", zorder=0, label="steady window")
        figures.steady_band(a, start, end, st.get("draught_mean"), st.get("draught_sem"), "C1",
                            "draught, warpdem steady mean ± SE")
        i = int(np.argmin(np.abs(t3["speed_mean_m_s"] - run.speeds[w]))) if n == 0 else \
            int(np.nonzero(t3["springs"] == n)[0][0])
        a.axhline(t3["passive_draught_mean_n" if n else "rigid_draught_mean_n"][i], color="k", ls="--", lw=0.9,
                  label="draught, laboratory (Table 3)")
        a.axhline(t7["c_final_mean_n"][t7["springs"] == n][0], color="C3", ls=":", lw=0.9,
                  label="draught, paper's final DEM (Table 7)")
        a.set_ylabel("draught [N]")
        a.set_title(_world_name(n, run, w), fontsize=9, loc="left")
        if n:
            b = a.twinx()
            md = figures.displacement_records(run.travel[:, w])
            disp = 1e3 * run.series["displacement"][:md, w]
            lab = float(t3["displacement_mean_mm"][i])
            b.plot(x[:md], disp, color="C2", lw=0.8, label="displacement, warpdem")
            dm, ds = st.get("displacement_mean"), st.get("displacement_sem")
            figures.steady_band(b, start, end, None if dm is None else 1e3 * dm, None if ds is None else 1e3 * ds,
                                "C2", "displacement, warpdem steady mean ± SE")
            b.axhline(lab, color="C2", ls="--", lw=0.9, label="displacement, laboratory (Table 3)")
            lo, hi = min(float(disp.min()), lab, 0.0), max(float(disp.max()), lab, 0.0)
            b.set_ylim(lo - 0.1 * (hi - lo), hi + 0.15 * (hi - lo))
            b.set_ylabel("displacement [mm]", color="C2")
            for h, label in zip(*b.get_legend_handles_labels(), strict=True):
                legend.setdefault(label, h)
        for h, label in zip(*a.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, h)
    ax[-1, 0].set_xlabel("carriage travel [m]")
    order = sorted(legend, key=lambda label: not label.startswith("draught"))  # draught entries first
    fig.legend([legend[k] for k in order], order, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=3,
               fontsize=8)
    fig.suptitle("Draught and tool displacement against travel (like the paper's Fig. 16); each trace ends at its "
                 "carriage's stop", fontsize=10)
    figures.save(fig, out / "fig16_draught_displacement.png", 110, tight_box=True)
    names.append("fig16_draught_displacement.png")
    # Figs. 17 and 18: FFT of the steady draught and displacement (100 Hz Butterworth low-pass first)
    for key, fname, unit, what in (("draught", "fig17_fft_draught.png", "N", "draught (like the paper's Fig. 17)"),
                                   ("displacement", "fig18_fft_disp.png", "mm",
                                    "passive tool's displacement (like the paper's Fig. 18)")):
        fig, a = plt.subplots(figsize=(10, 4.2))
        shown, resolution = [], 0.0
        for n, run, w in series:
            if key == "displacement" and n == 0:
                continue
            m = figures.moving_records(run.travel[:, w]) if key == "draught" else \
                figures.displacement_records(run.travel[:, w])
            sel = np.zeros(len(run.time), bool)
            sel[:m] = run.travel[:m, w] >= start
            scale = 1e3 if key == "displacement" else 1.0
            f, amp = analysis.spectrum(run.time[sel], scale * run.series[key][sel, w], cutoff_hz=100.0)
            a.plot(f, amp, lw=0.9, color=colors[(id(run), w)], label=f"warpdem, {_world_name(n, run, w)}")
            shown.append(n)
            resolution = max(resolution, 1.0 / float(np.ptp(run.time[sel])))
        figures.fft_references(a, key, shown, {n: colors[(id(run), w)] for n, run, w in series})
        a.set_xlim(0, 60)
        a.set_xlabel("frequency [Hz]")
        a.set_ylabel(f"amplitude [{unit}]")
        a.set_title(f"Spectrum of the steady {what}; resolution {resolution:.2g} Hz", fontsize=10)
        if a.get_legend_handles_labels()[0]:  # fig18 without a passive world: an empty axis, no legend
            a.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        fig.savefig(out / fname, dpi=110, bbox_inches="tight")
        plt.close(fig)
        names.append(fname)
    # Fig. 19: kinetic energy of the tool (total, rotational), its steady mean +- std, the paper's trend lines
    fig, a = plt.subplots(figsize=(10, 4.2))
    for n, run, w in series:
        if n == 0:
            continue
        m = figures.moving_records(run.travel[:, w])
        x = run.travel[:m, w]
        c = colors[(id(run), w)]
        ke = run.series["ke_tool"][:m, w]
        a.plot(x, ke.sum(axis=-1), lw=0.7, color=c, label=f"warpdem, {_world_name(n, run, w)}, total")
        a.plot(x, ke[:, 1], lw=0.7, ls=":", color=c, label=f"warpdem, {_world_name(n, run, w)}, rotational")
        st = run.steady[w] if len(run.steady) > w else {}
        figures.steady_band(a, start, float(x[-1]), st.get("ke_tool_mean"), st.get("ke_tool_std"), c,
                            f"warpdem, {n} springs, steady mean ± std")
        figures.fig19_reference(a, n, float(x[-1]), c)
    a.set_xlabel("carriage travel [m]")
    a.set_ylabel("kinetic energy of the tool [J]")
    a.set_title("The passive tool's kinetic energy (like the paper's Fig. 19)", fontsize=10)
    if a.get_legend_handles_labels()[0]:  # no passive world: an empty axis, no legend
        a.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.savefig(out / "fig19_tool_kinetic_energy.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    names.append("fig19_tool_kinetic_energy.png")
    # the reductions against the laboratory's and the paper's DEM
    n_beds = len(study.get("beds", [study.get("bed")]))
    rows = [{"springs": r["springs"], "mean": r["reduction_pct"], "sem": r["reduction_sem"],
             "label": "warpdem" + (f", mean of {n_beds} beds" if n_beds > 1 else "")}
            for r in study["table"] if r["springs"] and r.get("reduction_pct") is not None
            and math.isfinite(r["reduction_pct"])]
    if rows:
        figures.plot_reductions(rows, out / "fig_reductions.png", assembly=assembly,
                                title="Draught reduction of the passive tool against the rigid tool at its speed")
        names.append("fig_reductions.png")
    return names


def figure_captions(names: list[str]) -> list[str]:
    """The report's lines for the figures ``names``: each image with its caption (:func:`scenes.figures.figure_captions`
    with this report's :data:`FIGURE_CAPTIONS`)."""
    return figures.figure_captions(names, FIGURE_CAPTIONS)


def _fmt(v: float, digits: int = 3) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}g}"


def report(out: Path, config: dict, ring: dict[str, ringing.RingingResult], study: dict | None,
           plots: list[str], wall: float) -> str:
    """The Markdown report beside Tables 2, 3 and 7."""
    lines = [f"# warpdem reproduce — scale `{config['scale']}` on `{config['device']}`", "",
             f"Wall time {wall:.0f} s. Configuration, versions and seed: `config.json`. Every figure below was "
             "computed by this run; the paper's values are quoted from its tables.", ""]
    lines += ringing_section(ring)
    if study is not None:
        lines += soil_bin_section(config["soil_bin"]["assembly"], study, plots)
    text = "\n".join(lines) + "\n"
    (out / "report.md").write_text(text)
    return text


MODEL_NAMES = {"paper": "spring spheres (the paper's model, on warpdem's hinged rig)",
               "linear": "linear spring-dashpot (DIN 2093 stiffness, Table 2's damping)",
               "twin": "twin (the paper's rig as its text builds it)"}
MODEL_LABELS = {"paper": "spring spheres", "linear": "linear", "twin": "twin"}
"""short names of warpdem's spring models in figures and table headings ("paper" is warpdem's model of the paper's
spring spheres, not the paper's own DEM values, which are labelled "paper's DEM")."""


def ringing_section(ring: dict[str, ringing.RingingResult]) -> list[str]:
    """The ringing part of a report: per spring model a table grouped as measured (Table 2), the paper's DEM
    (Table 2) and warpdem (with its relative errors against the measured values [%]), then what they mean."""
    lines = ["## Ringing test (Table 2)", "",
             "One table per warpdem spring model. Columns in three groups: **measured** (the laboratory's ringing "
             "test, Table 2), **paper's DEM** (the paper's calibrated Yade model, Table 2) and **warpdem** (this "
             "run); RE: warpdem's relative error against the measured value, eqs. (8)-(9), in %. The rig's geometry "
             "(parametric sweep, load position) is warpdem's, not the paper's CAD: see scenes/ringing.py.", ""]
    tables = {m: r.table() for m, r in ring.items()}
    springs = next(iter(ring.values())).springs
    for m in ring:
        lines += [f"### warpdem {MODEL_NAMES.get(m, m)}", "",
                  "| springs | measured f [Hz] | measured zeta [-] | paper's DEM f [Hz] | paper's DEM zeta [-] | "
                  "warpdem f [Hz] | warpdem zeta [-] | warpdem RE f [%] | warpdem RE zeta [%] |",
                  "|---" * 9 + "|"]
        for k, n in enumerate(springs):
            row = paper.ringing_row(n)
            t = tables[m][k]
            lines.append("| " + " | ".join([
                str(n), _fmt(row["measured_freq_hz"], 4), _fmt(row["measured_damping"]),
                _fmt(row["calibrated_freq_hz"], 4), _fmt(row["calibrated_damping"]),
                _fmt(t["freq_hz"], 4), _fmt(t["damping"]), _fmt(100 * t["re_freq"], 2),
                _fmt(100 * t["re_damp"], 2)]) + " |")
        lines.append("")
    lines += ["What this means:", ""]
    for m, rows in tables.items():
        ref = np.abs([r["re_freq"] for r in rows])
        red = np.abs([r["re_damp"] for r in rows])
        worst = rows[int(np.argmax(ref))]
        text = (f"- {MODEL_NAMES.get(m, m)}: frequency off by {100 * np.median(ref):.1f} % (median over "
                f"{len(rows)} configurations; worst {100 * ref.max():.1f} % at {worst['springs']} springs), "
                f"damping ratio off by {100 * np.median(red):.1f} % (worst {100 * red.max():.1f} %)")
        if m == "linear":
            ratio = np.median([(r["measured_freq_hz"] / r["freq_hz"]) ** 2 for r in rows])
            text += (f". Its dashpot is chosen to give Table 2's damping, so only the frequency is a prediction: "
                     f"f grows as the square root of the stiffness, so the laboratory's frequencies need about "
                     f"{ratio:.2g} x the DIN 2093 stiffness (median), or less mass on the springs")
        lines.append(text + ".")
    lines += ["", "These are the models with their default (uncalibrated) parameters. Errors of more than a few per "
              "cent mean the rig's stiffness or damping, not the measurement, sets the result: "
              "`warpdem calibrate ringing --springs N --spring-model M` fits them to Table 2 (the linear model to "
              "within 0.05 % in this project's runs, `docs/runs/table3-paper-h100/`).", "",
              "![ringing](fig06_ringing.png)", "",
              "*Fig. 6-like: the sensor's displacement [mm] after the hit, one panel per configuration, each warpdem "
              "spring model with its frequency and damping ratio; the panel's title gives the laboratory's and the "
              "paper's DEM values (Table 2). A ring-down is one deterministic run: no error bar.*", ""]
    return lines


def write_ringing_report(out: Path, ring: dict[str, ringing.RingingResult], device: str) -> Path:
    """``warpdem ringing``'s results: report.md (Table 2 beside each model, what the numbers mean), series.npz
    (per model: time since the hit [s] (k,), sensor displacement [m] (k, n_configs), springs) and fig06_ringing.png,
    written into ``out``."""
    out = Path(out)
    plot_ringing(ring, out / "fig06_ringing.png")
    arrays = {}
    for m, r in ring.items():
        arrays[f"{m}_time"] = r.time
        arrays[f"{m}_displacement"] = r.displacement
        arrays[f"{m}_springs"] = np.asarray(r.springs)
    np.savez_compressed(out / "series.npz", **arrays)
    lines = [f"# warpdem ringing — on `{device}`", "",
             "Configuration: `config.json`; rows: `summary.json`; time series: `series.npz` (per model: time since the "
             "hit [s], sensor displacement [m] per configuration, springs).", ""]
    lines += ringing_section(ring)
    path = out / "report.md"
    write_text_atomic(path, "\n".join(lines) + "\n")
    return path


def soil_bin_section(assembly: str, study: dict, plots: list[str]) -> list[str]:
    """The soil-bin part of a report: the table beside Tables 3 and 7, what the numbers are, the figures."""
    lines: list[str] = []
    t3 = paper.table("soil_bin_measured")
    t7 = paper.table("soil_bin_dem")
    a = assembly
    col = {"A": "a", "B": "b", "C": "c"}[a]
    beds = study.get("beds", [study["bed"]])
    n_beds = len(beds)
    what = (f"{study['bed'].n_particles} particles, porosity {study['bed'].porosity:.3f}, initial coordination "
            f"{study['bed'].coordination:.2f}" if n_beds == 1 else
            f"{n_beds} replica beds of {min(b.n_particles for b in beds)}-{max(b.n_particles for b in beds)} "
            f"particles, porosity {min(b.porosity for b in beds):.3f}-{max(b.porosity for b in beds):.3f}, "
            f"initial coordination {min(b.coordination for b in beds):.2f}-{max(b.coordination for b in beds):.2f}")
    coord = [b.coordination for b in beds]
    lines += [f"## Soil bin, assembly {a} ({what}; the paper's initial coordination: "
              f"{({'A': 4.88, 'B': 9.63, 'C': 9.55}[a])})", "",
              f"The coordination number (contacts per particle) of warpdem's bed, {min(coord):.2f}"
              + (f"-{max(coord):.2f}" if n_beds > 1 else "") + f", is below the paper's "
              f"{({'A': 4.88, 'B': 9.63, 'C': 9.55}[a])}: warpdem's deposited bed is looser than the paper's (Yade "
              "counts the same bed alike; the paper does not print its counting rule; `docs/fidelity.md`)."
              if min(coord) < {'A': 4.88, 'B': 9.63, 'C': 9.55}[a] else
              f"The coordination number (contacts per particle) of warpdem's bed is {min(coord):.2f}"
              + (f"-{max(coord):.2f}" if n_beds > 1 else "") + " (`docs/fidelity.md` compares the beds).", "",
              "Columns in three groups: **warpdem** (this run), **measured** (the laboratory, Table 3) and the "
              "**paper's DEM** (Table 7).", "",
              "| springs | speed [m/s] | warpdem draught ± SE [N] | warpdem std [N] | "
              "warpdem rigid reference ± SE [N] | warpdem reduction ± SE [%] | warpdem displacement ± SE [mm] | "
              "measured draught [N] | measured reduction [%] | measured displacement [mm] | "
              f"paper's DEM {a} 1 m bin [N] | paper's DEM {a} 1 m reduction [%] | "
              "paper's DEM C final 2 m bin [N] | paper's DEM C final reduction [%] |",
              "|---" * 14 + "|"]

    def pm(v: float | None, e: float | None, digits: int = 4) -> str:
        return "–" if v is None or not math.isfinite(v) else f"{_fmt(v, digits)} ± {_fmt(e, 2)}"

    for r in study["table"]:
        n, v = r["springs"], r["speed"]
        i7 = np.nonzero(t7["springs"] == n)[0][0]
        paper_dem = [_fmt(t7[f"{c}_mean_n"][i7], 4) for c in (col, "c_final")]
        paper_red = [_fmt(t7[f"{c}_red_pct"][i7], 2) for c in (col, "c_final")]
        if n:
            i3 = np.nonzero(t3["springs"] == n)[0][0]
            lab = (t3["passive_draught_mean_n"][i3], t3["reduction_pct"][i3], t3["displacement_mean_mm"][i3])
        else:
            # Table 3's rigid runs at this speed (each passive run was paired with a rigid run of its own)
            same = np.abs(t3["speed_mean_m_s"] - v) < 5e-3
            lab = (float(np.mean(t3["rigid_draught_mean_n"][same])) if same.any() else math.nan, math.nan,
                   math.nan)
            if abs(v - speed_sweep.TABLE7_RIGID_SPEED) > 5e-3:
                paper_dem = paper_red = ["–", "–"]
        ref = "–" if not n else (f"{pm(r['rigid_reference_draught'], r['rigid_reference_sem'])} "
                                 f"({_fmt(r['rigid_reference_speed'])} m/s)"
                                 if r["rigid_reference_draught"] is not None else "none at this speed")
        lines.append("| " + " | ".join([
            "rigid" if n == 0 else str(n), _fmt(v), pm(r["draught_mean"], r["draught_sem"]),
            _fmt(r["draught_std"]), ref, pm(r["reduction_pct"], r["reduction_sem"], 2) if n else "–",
            pm(1e3 * r["displacement_mean"], 1e3 * r["displacement_sem"], 3) if n else "–", _fmt(lab[0], 4),
            _fmt(lab[1], 2), _fmt(lab[2]),
            paper_dem[0], paper_red[0], paper_dem[1], paper_red[1]]) + " |")
    se = ("SE: standard error of a steady mean from the record's autocorrelation; a reduction's SE propagates "
          "both means' (taken as independent)." if n_beds == 1 else
          f"each value is the mean over the {n_beds} replica beds (worlds of the same simulations, the tool at "
          "their mean surface) and its SE comes from their scatter (std over sqrt(n)); std: the draught's mean "
          "fluctuation within a record; a reduction is each replica's own, against its own rigid run, then "
          "averaged (`summary.json` has every replica's).")
    lines += ["", f"Steady state after {study['steady_travel']} m of travel; {se} Every reduction is against "
              "warpdem's rigid run at the configuration's own speed, "
              "as the laboratory paired its runs (Table 3); measured rigid draught: Table 3's rigid runs at that "
              "speed. The paper's DEM (Table 7) took every reduction against one rigid run at 0.68 m/s; its "
              f"columns are assembly {a} in the 1 m bin and the paper's final model (assembly C, 2 m bin, "
              "corrected geometry). `warpdem speed-sweep` measures the rigid draught against speed and "
              "re-pairs Table 7 at equal speeds.", ""]
    lines += soil_bin_meaning(study["table"], t3)
    lines += figure_captions(plots)
    return lines


NEGATIVE_DISPLACEMENT = ("A negative displacement: the sensor is zeroed on the tool at rest before the cut, so a "
                         "negative reading means the tool moved forward of its rest pose (towards the travel), not "
                         "back against its springs as the laboratory's did.")


def soil_bin_meaning(rows: list[dict], t3: dict) -> list[str]:
    """A "what this means" paragraph generated from the soil-bin rows and Table 3 (the laboratory's)."""
    out = ["What this means:", ""]
    rigid = [r for r in rows if r["springs"] == 0]
    ratios = []
    for r in rigid:
        same = np.abs(t3["speed_mean_m_s"] - r["speed"]) < 5e-3
        if same.any():
            ratios.append(r["draught_mean"] / float(np.mean(t3["rigid_draught_mean_n"][same])))
    if ratios:
        lo, hi = f"{100 * min(ratios):.0f}", f"{100 * max(ratios):.0f}"
        verdict = ("the simulated soil is weaker than the bin's" if max(ratios) < 1 else
                   "the simulated soil is stronger than the bin's" if min(ratios) > 1 else "about the bin's strength")
        out.append(f"- The rigid draught is {lo if lo == hi else lo + '-' + hi} % of the laboratory's at the same "
                   f"speeds: {verdict} (the draught calibration, `warpdem calibrate draught`, fits its strength).")
    passive = [r for r in rows if r["springs"] and r["reduction_pct"] is not None
               and math.isfinite(r["reduction_pct"])]
    if passive:
        unclear = [r for r in passive if abs(r["reduction_pct"]) < 2 * (r["reduction_sem"] or math.inf)]
        right = [r for r in passive
                 if np.sign(r["reduction_pct"]) == np.sign(t3["reduction_pct"][t3["springs"] == r["springs"]][0])]
        out.append(f"- {len(unclear)} of {len(passive)} reductions are within two standard errors of zero, so this "
                   f"run cannot tell their sign; {len(right)} of {len(passive)} have the laboratory's sign. "
                   "A longer travel or more beds (`warpdem soil-bin --replicas N`; `warpdem reproduce --workflow full` "
                   "runs replicas until the standard errors meet a target) narrows them.")
        disp = [1e3 * r["displacement_mean"] for r in passive]
        lab = [float(t3["displacement_mean_mm"][t3["springs"] == r["springs"]][0]) for r in passive]
        text = (f"- The passive tool's mean displacement is {min(disp):.2g} to {max(disp):.2g} mm against the "
                f"laboratory's {min(lab):.2g} to {max(lab):.2g} mm for the same configurations")
        if max(abs(d) for d in disp) < 0.5 * min(lab):
            text += ": a tool that moves much less than the laboratory's cannot change the draught as much"
        out.append(text + ".")
        if min(disp) < 0:
            out.append(f"- {NEGATIVE_DISPLACEMENT}")
    return out + [""]


def write_soil_bin_report(out: Path, config: dict, study: dict, device: str) -> Path:
    """``warpdem soil-bin``'s results: report.md (the table with standard errors beside the paper's, the figures),
    series.npz (every run's time series) and Figs. 16-19-like plots, written into ``out``."""
    out = Path(out)
    plots = plot_soil_bin(study, out, config["assembly"])
    arrays = {}
    for name, run in study["runs"].items():
        arrays[f"{name}_time"] = run.time
        arrays[f"{name}_travel"] = run.travel
        arrays[f"{name}_springs"] = np.asarray(run.springs)
        for k, v in run.series.items():
            arrays[f"{name}_{k}"] = v
    np.savez_compressed(out / "series.npz", **arrays)
    lines = [f"# warpdem soil bin — scale `{config['scale']}`, assembly {config['assembly']}, on `{device}`", "",
             "Configuration: `config.json`; rows: `summary.json`; time series: `series.npz` (per run: time [s], "
             "travel [m], springs, then draught [N], displacement [m], kinetic energies [J] per world).", ""]
    lines += soil_bin_section(config["assembly"], study, plots)
    path = out / "report.md"
    write_text_atomic(path, "\n".join(lines) + "\n")
    return path


_RINGING_ARRAYS = ("time", "displacement", "frequency_hz", "damping_ratio", "static_deflection", "spring_deflection")


def save_ringing(result: ringing.RingingResult, path: Path) -> None:
    """A ringing result as ``path`` (npz, written atomically): its arrays, its analytic arrays (``analytic/<name>``)
    and ``meta`` (JSON: springs, spring model, dt [s], wall time [s], configuration)."""
    meta = {"springs": list(result.springs), "spring_model": result.spring_model, "dt": result.dt,
            "wall_s": result.wall_s, "config": result.config}
    arrays = {k: np.asarray(getattr(result, k)) for k in _RINGING_ARRAYS}
    arrays.update({f"analytic/{k}": np.asarray(v) for k, v in result.analytic.items()})
    write_atomic(path, lambda tmp: np.savez_compressed(tmp, meta=np.array(json.dumps(meta, default=str)), **arrays))


def load_ringing(path: Path, config: ringing.RingingConfig) -> ringing.RingingResult | None:
    """The ringing result saved at ``path`` if it was run with ``config``; None if there is none, or another's."""
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            arrays = {k: z[k] for k in _RINGING_ARRAYS}
            analytic = {k.split("/", 1)[1]: z[k] for k in z.files if k.startswith("analytic/")}
    except (OSError, ValueError, KeyError):  # an older folder's file, without meta
        return None
    if meta["config"] != json.loads(json.dumps(asdict(config), default=str)):
        return None
    return ringing.RingingResult(springs=tuple(meta["springs"]), spring_model=meta["spring_model"], dt=meta["dt"],
                                 wall_s=meta["wall_s"], config=meta["config"], analytic=analytic, **arrays)


def reproduce(out: str | Path, *, scale: str = "cpu", device: str | None = None, assembly: str = "C",
              springs: tuple[int, ...] = (0, 16, 32), seed: int = 0, progress: object | None = None,
              soil: bool = True, vtk_every: int | None = None, deposit_progress: object | None = None) -> dict:
    """Run the study and write the results folder; returns the summary. ``vtk_every``: ParaView frames of the
    soil-bin runs at every ``vtk_every``-th record, into OUT/vtk/<run>/. ``progress(stage, done, total)``: the
    ringing runs' and the soil-bin runs' progress; ``deposit_progress``: the bed's deposition's
    (:func:`scenes.assemblies.deposit`), when the bed is not in ``OUT/beds/`` yet."""
    t0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ring_cfgs = {m: ringing.RingingConfig(spring_model=m) for m in ringing.SPRING_MODELS}
    sb_cfg = sb.SoilBinConfig(scale=scale, assembly=assembly, springs=springs, seed=seed)
    config = {"command": "reproduce", "scale": scale, "device": device, "seed": seed, "versions": versions(),
              "ringing": {m: asdict(c) for m, c in ring_cfgs.items()}, "soil_bin": asdict(sb_cfg),
              "soil_bin_preset": sb.SCALES[scale], "soil_material": asdict(sb_cfg.soil_material())}
    (out / "config.json").write_text(json.dumps(config, indent=2, default=str))
    ring = {}
    for m, c in ring_cfgs.items():
        path = out / f"ringing_{m}.npz"
        if (done := load_ringing(path, c)) is not None:  # an interrupted call finished it
            ring[m] = done
            continue
        ring[m] = ringing.run_ringing(c, device=device, progress=progress and (lambda d, n, ph, m=m:
                                                                               progress(f"ringing {m} {ph}", d, n)))
        save_ringing(ring[m], path)
    plot_ringing(ring, out / "fig06_ringing.png")
    study, plots = None, []
    if soil:
        study = sb.run_study(sb_cfg, device=device, cache_dir=out / "beds", checkpoint_dir=out / "checkpoints",
                             progress=progress and (lambda run, d, n: progress(f"soil bin: {run} tool", d, n)),
                             deposit_progress=deposit_progress, vtk_every=vtk_every, vtk_dir=out / "vtk")
        arrays = {}
        for name, run in study["runs"].items():
            arrays[f"{name}/time"] = run.time
            arrays[f"{name}/travel"] = run.travel
            for k, v in run.series.items():
                arrays[f"{name}/{k}"] = v
        np.savez_compressed(out / "soil_bin.npz", **arrays)
        plots = plot_soil_bin(study, out, assembly)
    wall = time.perf_counter() - t0
    summary = {
        "wall_s": wall, "device": device, "scale": scale,
        "ringing": {m: r.table() for m, r in ring.items()},
        "ringing_wall_s": {m: r.wall_s for m, r in ring.items()},
    }
    if study is not None:
        summary["soil_bin"] = study["table"]
        summary["bed"] = {"particles": study["bed"].n_particles, "spheres": int(len(study["bed"].radii)),
                          "porosity": study["bed"].porosity, "coordination": study["bed"].coordination,
                          "deposition_wall_s": study["bed"].wall_s}
        summary["soil_bin_runs"] = {k: {"dt": r.dt, "steps": r.steps, "wall_s": r.wall_s, "spheres": r.n_spheres}
                                    for k, r in study["runs"].items()}
    (out / "summary.json").write_text(json.dumps(sb.json_safe(summary), indent=2, default=float))
    report(out, config, ring, study, plots, wall)
    return summary
