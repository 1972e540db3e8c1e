"""Compare warpdem's passive ci soil-bin runs with their Yade twin; writes benchmarks/yade/passive_twin_report.md.

Run from the repository root, after passive_twin_export.py (which holds warpdem's runs: no warpdem run is made here)
and the Yade runs (passive_twin.py), e.g.:

    python benchmarks/yade/passive_twin_compare.py A --springs 16 32 --seeds 1 2 3 4 5 6 7 8

Statistics: ``scenes.analysis.steady_state`` over the records with travel >= the spec's steady_travel (mean, std and
the standard error from the record's autocorrelation), for every run of either engine; realization k (seed k) is the
bed with every particle displaced by RandomState(k).uniform(-1e-9, 1e-9) m in both engines. Ensembles: the mean of
the runs' means, its SE the larger of std(means) / sqrt(n) and sqrt(sum SE^2) / n (as soil_bin_twin_compare.py).
Agreement: the difference of the two ensembles in units of the combined SE sqrt(se_w^2 + se_y^2).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from scenes import analysis

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
QUANT = (("draught", "draught [N]", 1.0, "{:.1f}"), ("displacement", "displacement [mm]", 1e3, "{:.3f}"),
         ("rotation", "rotation [deg]", 180.0 / math.pi, "{:.3f}"), ("spring_force", "spring force [N]", 1.0,
                                                                      "{:.1f}"))


def load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as f:
        return {k: f[k] for k in f.files}


def steady(t: np.ndarray, x: np.ndarray, spec: dict[str, np.ndarray]) -> analysis.SteadyState:
    trav = np.minimum(t * float(spec["speed"]), float(spec["travel"]))
    return analysis.steady_state(t, np.asarray(x, dtype=np.float64), trav, start_travel=float(spec["steady_travel"]))


def ensemble(rows: list[analysis.SteadyState]) -> dict[str, float]:
    m = np.array([r.mean for r in rows])
    se = np.array([r.sem for r in rows])
    n = len(m)
    spread = float(m.std(ddof=1) / math.sqrt(n)) if n > 1 else float(se[0])
    runs = float(np.sqrt((se**2).sum()) / n)
    sd = np.array([r.std for r in rows])
    return {"mean": float(m.mean()), "se": max(spread, runs), "se_spread": spread, "se_runs": runs, "n": n,
            "std_in_run": float(sd.mean()), "std_in_run_se": float(sd.std(ddof=1) / math.sqrt(n)) if n > 1 else 0.0}


def pm_std(e: dict[str, float], scale: float, fmt: str) -> str:
    """The std within a run: mean +- SE over the realizations."""
    return f"{fmt.format(scale * e['std_in_run'])} +- {fmt.format(scale * e['std_in_run_se'])}"


def z_std(a: dict[str, float], b: dict[str, float]) -> float:
    return (a["std_in_run"] - b["std_in_run"]) / math.hypot(a["std_in_run_se"], b["std_in_run_se"])


def first_divergence(w: np.ndarray, y: np.ndarray, tol: float) -> int:
    """The first record index where |w - y| > tol (len if none)."""
    bad = np.flatnonzero(np.abs(np.asarray(w, np.float64) - np.asarray(y, np.float64)) > tol)
    return int(bad[0]) if len(bad) else len(w)


def compare(assembly: str, springs: int, seeds: list[int]) -> tuple[list[str], dict]:
    name = f"{assembly}_{springs}"
    spec = load(HERE / f"passive_twin_spec_{name}.npz")
    wseeds = [int(s) for s in spec["warp_seeds"]]
    t = spec["warp_time"]
    facet = "facet_draught" in spec
    real: dict[str, dict[int | None, dict[str, analysis.SteadyState]]] = {"warpdem": {}, "Yade": {}}
    if facet:
        real["warpdem per facet"] = {}
    yruns: dict[int | None, dict[str, np.ndarray]] = {}
    for k in [None] + list(seeds):
        if (-1 if k is None else k) not in wseeds:
            raise SystemExit(f"{name}: warpdem realization {k} is not in the spec (export with --seeds)")
        i = wseeds.index(-1 if k is None else k)
        path = HERE / f"passive_twin_yade_{name}{'' if k is None else f'_p{k}'}.npz"
        if not path.exists():
            raise SystemExit(f"missing {path.name}: run yade -n -x benchmarks/yade/passive_twin.py {assembly} "
                             f"{springs}" + ("" if k is None else f" --perturb 1e-9 --seed {k} --tag _p{k}"))
        y = load(path)
        if not np.array_equal(y["step"], spec["warp_step"]):
            raise SystemExit(f"{path.name}: records are not warpdem's")
        yruns[k] = y
        real["warpdem"][k] = {q: steady(t, spec[f"warp_{q}"][i], spec) for q, *_ in QUANT}
        real["Yade"][k] = {q: steady(y["step"] * float(spec["dt"]), y[q], spec) for q, *_ in QUANT}
        if facet:
            real["warpdem per facet"][k] = {q: steady(t, spec[f"facet_{q}"][i], spec) for q, *_ in QUANT}
    ens = {e: {q: ensemble([r[q] for r in rr.values()]) for q, *_ in QUANT} for e, rr in real.items()}
    L = [f"## Assembly {assembly}, {springs} springs\n"]
    L.append(f"Spring k = {float(spec['spring_stiffness']):.0f} N/m (DIN 2093), dashpot c = "
             f"{float(spec['spring_damping']):.2f} N s/m (Table 2's zeta {float(spec['measured_damping']):.4f}), rest "
             f"length {float(spec['spring_rest_length']):.9f} m, support offset "
             f"{1e3 * float(spec['support_offset']):+.1f} mm (the stack starts compressed by it: "
             f"{float(spec['spring_stiffness']) * abs(float(spec['support_offset'])):.0f} N); tool "
             f"{float(spec['tool_mass']):.3f} kg, I_p = {float(spec['tool_ip_xx']):.5f} kg m^2 about the pivot's x "
             f"axis, centre of mass {1e3 * (float(spec['tool_pivot'][2]) - float(spec['tool_com'][2])):.1f} mm below "
             f"the pivot, sensor lever "
             f"{1e3 * float(spec['lever']):.0f} mm; closed-form ringing frequency without soil "
             f"{float(spec['ring_freq_hz']):.3f} Hz; dt = {float(spec['dt']):.6e} s, {int(spec['n_steps'])} steps, "
             f"records every {int(spec['record_every'])} steps, steady part from {float(spec['steady_travel'])} m of "
             f"travel.\n")
    L.append("### Ensembles (main bed + seeds " + ", ".join(str(s) for s in seeds) + ")\n")
    L.append("| quantity | warpdem mean +- SE | Yade mean +- SE | diff / comb. SE | warpdem std within a run | "
             "Yade std within a run | std diff / comb. SE | warpdem per facet mean +- SE | per facet - Yade / comb. "
             "SE | per facet std within a run | per facet std - Yade's / comb. SE |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|")
    summary = {"assembly": assembly, "springs": springs}
    for q, label, scale, fmt in QUANT:
        w, y = ens["warpdem"][q], ens["Yade"][q]
        comb = math.hypot(w["se"], y["se"])
        z = (w["mean"] - y["mean"]) / comb
        f_cells = " | | |"
        zf = math.nan
        if facet:
            pf = ens["warpdem per facet"][q]
            zf = (pf["mean"] - y["mean"]) / math.hypot(pf["se"], y["se"])
            f_cells = (f" {fmt.format(scale * pf['mean'])} +- {fmt.format(scale * pf['se'])} | {zf:+.2f} | "
                       f"{pm_std(pf, scale, fmt)} | {z_std(pf, y):+.2f} |")
            summary[q + "_facet"] = (pf, zf)
        summary[q] = (w, y, z)
        L.append(f"| {label} | {fmt.format(scale * w['mean'])} +- {fmt.format(scale * w['se'])} (n = {w['n']}) | "
                 f"{fmt.format(scale * y['mean'])} +- {fmt.format(scale * y['se'])} | {z:+.2f} | "
                 f"{pm_std(w, scale, fmt)} | {pm_std(y, scale, fmt)} | {z_std(w, y):+.2f} |" + f_cells)
    L.append("")
    L.append("Every realization (steady mean +- SE; draught [N], displacement [mm], rotation [deg]):\n")
    engines = list(real)
    L.append("| realization | " + " | ".join(f"{e} {q}" for q in ("draught", "displacement", "rotation")
                                           for e in engines) + " |")
    L.append("|---" * (1 + 3 * len(engines)) + "|")
    for k in real["Yade"]:
        cells = []
        for q, _, scale, fmt in QUANT[:3]:
            cells += [f"{fmt.format(scale * real[e][k][q].mean)} +- {fmt.format(scale * real[e][k][q].sem)}"
                      for e in engines]
        L.append(f"| {'main' if k is None else f'seed {k}'} | " + " | ".join(cells) + " |")
    L.append("")
    # the two engines before the first tool-soil contact, and Yade's facet double contacts
    y0 = yruns[None]
    i0 = wseeds.index(-1)
    first_contact = int(np.flatnonzero(y0["c_sf_lower"] > 0)[0]) if np.any(y0["c_sf_lower"] > 0) else len(t)
    div = first_divergence(spec["warp_rotation"][i0], y0["rotation"], 1e-6)
    pre = slice(0, div)
    drot = np.abs(spec["warp_rotation"][i0][pre].astype(np.float64) - y0["rotation"][pre]).max()
    dsf = np.abs(spec["warp_spring_force"][i0][pre].astype(np.float64) - y0["spring_force"][pre]).max()
    if facet:
        dpre = np.abs(spec["facet_rotation"][i0][pre].astype(np.float64)
                      - spec["warp_rotation"][i0][pre].astype(np.float64)).max()
        L.append(f"The per-facet rebuild (passive_twin_export.per_facet_run: the same calls as build_scene, every "
                 f"sweep triangle its own mesh on the hinged body) follows run_soil_bin's rotation to {dpre:.1e} rad "
                 f"up to step {int(y0['step'][max(div - 1, 0)])} (the same tool dynamics).\n")
    L.append(f"Main bed: the tool first swings forward under the support offset's compression, free of the soil, in "
             f"both engines; up to step {int(y0['step'][max(div - 1, 0)])} (record {div - 1}) the rotations differ by "
             f"at most {drot:.1e} rad and the spring forces by {dsf:.1e} N (warpdem's records are float32). They "
             f"differ by more than 1e-6 rad from record {div} (step {int(y0['step'][min(div, len(t) - 1)])}) on, "
             f"after the first tool-soil contact between those records (Yade's first recorded lower-half "
             f"interactions: record {first_contact}).\n")
    rows = [yr for yr in yruns.values()]
    travel = np.minimum(y0["step"] * float(spec["dt"]) * float(spec["speed"]), float(spec["travel"]))
    mask = travel >= float(spec["steady_travel"])
    c_low = np.mean([r["c_sf_lower"][mask].mean() for r in rows])
    drop = np.mean([r["wd_drop_lower"][mask].mean() for r in rows])
    frac = np.mean([(r["wd_drop_lower"][mask] > 0).mean() for r in rows])
    L.append(f"Yade's facet interactions on the tool's lower half, steady part, mean over the Yade runs: {c_low:.2f} "
             f"per record, of which {drop:.2f} are ones warpdem's merging rule would not have (a sphere on an edge "
             f"or vertex shared by several facets: Yade makes one interaction per facet, each with the full "
             f"stiffness; warpdem one merged contact); {100 * frac:.0f} % of the records have at least one.\n")
    ke_w = np.mean([steady(t, spec["warp_ke_tool"][wseeds.index(-1 if k is None else k)], spec).mean
                    for k in yruns])
    ke_y = np.mean([steady(r["step"] * float(spec["dt"]), r["ke_tool"], spec).mean for r in rows])
    L.append(f"Tool kinetic energy, steady mean over the realizations: warpdem {ke_w:.3f} J, Yade {ke_y:.3f} J. "
             f"Yade wall time per run {np.mean([json.loads(str(r['meta']))['wall_s'] for r in rows]):.1f} s (one "
             f"thread, Python loads every step and recorder), warpdem's run_soil_bin "
             f"{np.mean(spec['warp_wall_s']):.1f} s.\n")
    test_log = HERE / f"passive_twin_yade_test_{name}.log"
    if test_log.exists():
        keep = [ln for ln in test_log.read_text().splitlines() if ln.startswith(("closed form", "statics", "Yade, no"))]
        L.append(f"Closed-form checks without soil (`yade -n -x benchmarks/yade/passive_twin.py test {assembly} "
                 f"{springs}`, {test_log.name}):\n")
        L += [f"- {ln}" for ln in keep]
        L.append("")
    return L, summary


def effects_section(assembly: str, springs: int) -> list[str]:
    """The hidden-effect options against warpdem's own knobs (passive_twin_export.py --effects-check and the Yade
    runs ``--steps 250 <options> --tag _fx_<case>``), over the records while the tool swings free of the soil."""
    name = f"{assembly}_{springs}"
    path = HERE / f"passive_twin_effects_{name}.npz"
    if not path.exists():
        return []
    w = load(path)
    opts = json.loads(str(w["yade_options"]))
    L = [f"### Hidden-effect options against warpdem's own knobs ({assembly}, {springs} springs)\n",
         "run_soil_bin with the knob (or pitch) beside the Yade script with the option, the same bed, over steps "
         "25-150 (records 1-6: the tool swings free of the soil, which evolves identically in both engines until "
         "the first tool contact, near step 180 in the clean run, earlier where the tool swings further). Max "
         "relative difference over those records:\n",
         "| case | warpdem | Yade options | rotation | displacement | spring force | rotation at step 150 w / y "
         "[deg] |", "|---|---|---|---|---|---|---|"]
    knob = {"clean": "-", "start1": "pitch=[1.0]", "preload1mm": "stack_preload 1e-3", "friction0.5":
            "pivot_friction 0.5", "mass2": "extra_mass 2.0"}
    for case, o in opts.items():
        yp = HERE / f"passive_twin_yade_{name}_fx_{case}.npz"
        if not yp.exists():
            L.append(f"| {case} | {knob.get(case, '')} | `{o}` | (no Yade run: yade -n -x benchmarks/yade/"
                     f"passive_twin.py {assembly} {springs} --steps 250 {o} --tag _fx_{case}) | | | |")
            continue
        y = load(yp)
        sel = slice(1, 7)
        if not np.array_equal(y["step"][sel], w["step"][sel]):
            raise SystemExit(f"{yp.name}: records are not the check's")

        def rel(q: str, y: dict = y, case: str = case, sel: slice = sel) -> float:
            a, b = np.asarray(w[f"{case}_{q}"][sel], np.float64), np.asarray(y[q][sel], np.float64)
            return float(np.max(np.abs(a - b) / np.maximum(np.abs(a), 1e-30)))

        L.append(f"| {case} | {knob.get(case, '')} | `{o}` | {rel('rotation'):.1e} | {rel('displacement'):.1e} | "
                 f"{rel('spring_force'):.1e} | {math.degrees(float(w[f'{case}_rotation'][6])):.5f} / "
                 f"{math.degrees(float(y['rotation'][6])):.5f} |")
    L.append("")
    return L


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("assemblies", nargs="*", default=["A"])
    ap.add_argument("--springs", nargs="+", type=int, default=[16, 32])
    ap.add_argument("--seeds", nargs="*", type=int, default=[])
    ap.add_argument("--out", default=str(HERE / "passive_twin_report.md"))
    a = ap.parse_args()
    body, sums = [], []
    for asm in a.assemblies:
        for n in a.springs:
            lines, s = compare(asm.upper(), n, a.seeds)
            body += lines + effects_section(asm.upper(), n)
            sums.append(s)
    head = ["# Passive soil-bin Yade twin: warpdem vs Yade 2023.02a (passive tool, linear spring, ci scale, GA set 11, "
            "0.62 m/s)\n",
            "Generated by `python benchmarks/yade/passive_twin_compare.py " + " ".join(sys.argv[1:]) + "`; inputs "
            "`passive_twin_spec_<A>_<springs>.npz` (passive_twin_export.py: the scene and warpdem's own run_soil_bin "
            "records) and `passive_twin_yade_<A>_<springs>[_pk].npz` (passive_twin.py under Yade). Set-up: the "
            "docstrings of those scripts; the bed and tool pose are the rigid twin's (soil_bin_twin_spec_A.npz).\n",
            "## Summary\n",
            "Steady part (travel >= 0.15 m), ensembles of the main bed and its perturbed realizations; mean +- SE, "
            "and the difference warpdem - Yade in combined standard errors.\n",
            "| assembly | springs | draught warpdem [N] | draught Yade [N] | diff/SE | displacement warpdem [mm] | "
            "displacement Yade [mm] | diff/SE | displacement std w / y [mm] | rotation warpdem [deg] | rotation Yade "
            "[deg] | diff/SE | draught warpdem per facet [N], - Yade / SE | displacement per facet [mm], - Yade / SE |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in sums:
        d, x, r = s["draught"], s["displacement"], s["rotation"]
        head.append(f"| {s['assembly']} | {s['springs']} | {d[0]['mean']:.1f} +- {d[0]['se']:.1f} (n = {d[0]['n']}) | "
                    f"{d[1]['mean']:.1f} +- {d[1]['se']:.1f} | {d[2]:+.2f} | {1e3 * x[0]['mean']:.3f} +- "
                    f"{1e3 * x[0]['se']:.3f} | {1e3 * x[1]['mean']:.3f} +- {1e3 * x[1]['se']:.3f} | {x[2]:+.2f} | "
                    f"{1e3 * x[0]['std_in_run']:.3f} / {1e3 * x[1]['std_in_run']:.3f} | "
                    f"{math.degrees(r[0]['mean']):.3f} +- {math.degrees(r[0]['se']):.3f} | "
                    f"{math.degrees(r[1]['mean']):.3f} +- {math.degrees(r[1]['se']):.3f} | {r[2]:+.2f} | "
                    + (f"{s['draught_facet'][0]['mean']:.1f} +- {s['draught_facet'][0]['se']:.1f}, "
                       f"{s['draught_facet'][1]:+.2f} | {1e3 * s['displacement_facet'][0]['mean']:.3f} +- "
                       f"{1e3 * s['displacement_facet'][0]['se']:.3f}, {s['displacement_facet'][1]:+.2f} |"
                       if "draught_facet" in s else " | |"))
    head.append("")
    notes = (HERE / "passive_twin_notes.md")
    tail = [f"See `{notes.name}` for the set-up, where the twin cannot match warpdem exactly, and how to re-run."] \
        if notes.exists() else []
    Path(a.out).write_text("\n".join(head + body + tail) + "\n")
    print("\n".join(head + body))
    print("wrote", a.out)


if __name__ == "__main__":
    main()
