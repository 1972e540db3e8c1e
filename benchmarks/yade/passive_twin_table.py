"""Table-3-format data sets from the passive Yade twin, with and without one hidden effect, for testing warpdem's
diagnosis (``calibration.rig_models.SoilBinRigModel`` on ``calibration.measured`` directories).

Every data set: the Yade twin (passive_twin.py) WITHOUT Table 2's support offsets (the rig model's baseline,
``SoilBinConfig(support_offset=False)``: specs ``passive_twin_spec_A_<n>_nooffset.npz`` from
``passive_twin_export.py A --springs ... --no-support-offset``), assembly A, GA set 11, 0.62 m/s, the rigid twin's bed
and tool pose, linear spring with DIN 2093 rates and Table 2's dashpot, for the 8 spring counts of Table 2 and 9
realizations each (the main bed and ``--perturb 1e-9 --seed k``, k = 1..8). Reductions are taken against the rigid
Yade twin (soil_bin_twin.py, same bed, 0.62 m/s), ensemble of its main bed and seeds 1..15 (16 realizations).

Run from the repository root (the project's Python for ``collect``/``report``; ``rigid``/``run`` call ``yade``),
one process at a time:

    python benchmarks/yade/passive_twin_table.py rigid --raw /tmp/ptt      # rigid twin, main + 15 seeds (Yade)
        -> benchmarks/yade/passive_twin_table_rigid.json (runs soil_bin_twin.py from a copy in RAW/rigid, so that
           nothing is written into the repository but the json)
    python benchmarks/yade/passive_twin_table.py run clean --raw /tmp/ptt  # 72 Yade runs -> RAW/clean/*.npz, .log
    python benchmarks/yade/passive_twin_table.py collect clean --raw /tmp/ptt
        -> benchmarks/yade/passive_twin_table_clean/summary.csv, ensemble.json
    python benchmarks/yade/passive_twin_table.py summary clean    # summary.csv again from ensemble.json
    python benchmarks/yade/passive_twin_table.py report
        -> benchmarks/yade/passive_twin_table_report.md

Statistics: ``passive_twin_compare.steady`` (scenes.analysis.steady_state over travel >= 0.15 m) per run; the
ensemble mean over the realizations and its SE over realizations, std(means, ddof=1) / sqrt(n). summary.csv's
``displacement_std`` is the displacement's std within a run (the sensor signal's fluctuation), averaged over the
realizations; ``reduction`` = 100 (rigid - passive) / rigid of the ensemble means, its SE propagated from both
(scenes.soil_bin.reduction). Displacement: the sensor's, + backwards (against travel), from the drawing pose.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))
import passive_twin_compare as pcmp  # noqa: E402

ASSEMBLY = "A"
SPRINGS = (4, 8, 12, 16, 20, 24, 28, 32)
SEEDS = (1, 2, 3, 4, 5, 6, 7, 8)
RIGID_SEEDS = tuple(range(1, 16))
SPEED = 0.62
EFFECTS: dict[str, tuple[str, str]] = {  # name: (passive_twin.py options, the hidden effect in words)
    "clean": ("", "none (the clean twin)"),
    "pitch": ("--pitch 3", "mounting (pitch) error: the tool's geometry and centre of mass turned BACK by 3 deg about "
                           "the pivot, the spring seat and the sensor target not (passive_twin.py --pitch 3)"),
    "preload": ("--preload 1.5e-3", "stack preload: every stack compressed by 1.5 mm at assembly against a stop at "
                                    "the drawing pose (P = -k x 1.5 mm; passive_twin.py --preload 1.5e-3)"),
    "friction": ("--pivot-friction 10", "pivot friction: Coulomb torque 10 N m at the hinge, exact stick-slip "
                                        "(passive_twin.py --pivot-friction 10)"),
    "friction20": ("--pivot-friction 20", "pivot friction: Coulomb torque 20 N m at the hinge, exact stick-slip "
                                          "(passive_twin.py --pivot-friction 20; a stronger variant of 'friction')"),
    "mass": ("--extra-mass 3", "extra mass: 3 kg added to the tool, distributed (mass and inertia about the pivot "
                               "scaled together, centre of mass unchanged; passive_twin.py --extra-mass 3)"),
}
def out_dir(effect: str) -> Path:
    return HERE / f"passive_twin_table_{effect}"


def spec_path(n: int) -> Path:
    return HERE / f"passive_twin_spec_{ASSEMBLY}_{n}_nooffset.npz"


def yade_name(n: int, seed: int | None) -> str:
    return f"passive_twin_yade_{ASSEMBLY}_{n}_nooffset{'' if seed is None else f'_p{seed}'}.npz"


def yade_cmd(n: int, seed: int | None, options: str, raw: Path) -> list[str]:
    cmd = ["yade", "-n", "-x", str(HERE / "passive_twin.py"), ASSEMBLY, str(n), "--no-support-offset"]
    cmd += options.split()
    cmd += ["--tag", "" if seed is None else f"_p{seed}", "--out-dir", str(raw)]
    if seed is not None:
        cmd += ["--perturb", "1e-9", "--seed", str(seed)]
    return cmd


# ------------------------------------------------------------------------------------------------ runs
def run_effect(effect: str, raw: Path, springs: tuple[int, ...], seeds: tuple[int, ...]) -> None:
    """Yade runs of one data set into RAW/<effect>/ (a run whose npz exists is skipped: resumable); realizations
    outer, spring counts inner (the main bed of every count first)."""
    d = raw / effect
    d.mkdir(parents=True, exist_ok=True)
    options = EFFECTS[effect][0]
    t_all = time.time()
    with open(d / "runs.txt", "a") as runlog:
        for seed in (None, *seeds):
            for n in springs:
                if (d / yade_name(n, seed)).exists():
                    continue
                cmd = yade_cmd(n, seed, options, d)
                t0 = time.time()
                p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
                line = (f"{effect} n={n} seed={seed} rc={p.returncode} {time.time() - t0:.1f} s: "
                        + " ".join(cmd[3:]).replace(str(HERE) + "/", "").replace(str(d), "RAW"))
                print(line, flush=True)
                runlog.write(line + "\n")
                runlog.flush()
                if p.returncode != 0:
                    print(p.stdout[-2000:], p.stderr[-3000:], flush=True)
                    raise SystemExit(f"Yade failed: {line}")
    print(f"{effect}: done in {time.time() - t_all:.0f} s", flush=True)


def run_rigid(raw: Path, seeds: tuple[int, ...]) -> None:
    """The rigid Yade twin (soil_bin_twin.py A, main bed and ``seeds``) from a copy in RAW/rigid (its outputs go
    beside the script); the steady draught of every realization -> passive_twin_table_rigid.json."""
    d = raw / "rigid"
    d.mkdir(parents=True, exist_ok=True)
    for f in ("soil_bin_twin.py", "soil_bin_twin_common.py", f"soil_bin_twin_spec_{ASSEMBLY}.npz"):
        shutil.copy(HERE / f, d / f)
    spec = pcmp.load(HERE / f"soil_bin_twin_spec_{ASSEMBLY}.npz")
    rows = []
    for seed in (None, *seeds):
        tag = "" if seed is None else f"_p{seed}"
        path = d / f"soil_bin_twin_yade_{ASSEMBLY}{tag}.npz"
        if not path.exists():
            cmd = ["yade", "-n", "-x", str(d / "soil_bin_twin.py"), ASSEMBLY]
            if seed is not None:
                cmd += ["--perturb", "1e-9", "--seed", str(seed), "--tag", tag]
            t0 = time.time()
            p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
            print(f"rigid seed={seed} rc={p.returncode} {time.time() - t0:.1f} s", flush=True)
            if p.returncode != 0:
                print(p.stdout[-2000:], p.stderr[-3000:])
                raise SystemExit("rigid Yade run failed")
        y = pcmp.load(path)
        st = pcmp.steady(y["time"], y["draught"], spec)
        rows.append({"realization": "main" if seed is None else f"seed {seed}", "draught_mean": st.mean,
                     "draught_std": st.std, "draught_sem": st.sem, "wall_s": float(y["wall_s"])})
        print(f"  rigid {rows[-1]['realization']}: {st.mean:.2f} +- {st.sem:.2f} N", flush=True)
    main = pcmp.load(HERE / f"soil_bin_twin_yade_{ASSEMBLY}.npz")
    same = bool(np.array_equal(main["draught"], pcmp.load(d / f"soil_bin_twin_yade_{ASSEMBLY}.npz")["draught"]))
    out = {"engine": "Yade 2023.02a, benchmarks/yade/soil_bin_twin.py (rigid sweep), soil_bin_twin_spec_A.npz, "
                     "0.62 m/s; realization k: --perturb 1e-9 --seed k",
           "main_rerun_bit_identical_to_committed": same, "realizations": rows}
    for label, k in (("main+p1..p15", len(rows)), ("main+p1..p8", 9)):
        m = np.array([r["draught_mean"] for r in rows[:k]])
        se = float(m.std(ddof=1) / math.sqrt(k))
        se_runs = float(np.sqrt(sum(r["draught_sem"] ** 2 for r in rows[:k])) / k)
        out[f"ensemble_{label}"] = {"n": k, "draught_mean": float(m.mean()), "draught_se": se,
                                    "draught_se_runs": se_runs, "draught_se_conservative": max(se, se_runs)}
    path = HERE / "passive_twin_table_rigid.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"main rerun bit-identical to the committed soil_bin_twin_yade_{ASSEMBLY}.npz: {same}; wrote {path}")
    for label in ("main+p1..p15", "main+p1..p8"):
        e = out[f"ensemble_{label}"]
        print(f"  rigid ensemble {label}: {e['draught_mean']:.2f} +- {e['draught_se']:.2f} N")


# ------------------------------------------------------------------------------------------------ collection
def rigid_reference() -> dict[str, float]:
    r = json.loads((HERE / "passive_twin_table_rigid.json").read_text())
    e = r["ensemble_main+p1..p15"]
    return {"mean": e["draught_mean"], "se": e["draught_se"], "se_conservative": e["draught_se_conservative"],
            "n": e["n"]}


def realization_row(y: dict[str, np.ndarray], spec: dict[str, np.ndarray]) -> dict[str, float]:
    t = y["step"] * float(spec["dt"])
    out: dict[str, float] = {}
    for q, scale in (("draught", 1.0), ("displacement", 1e3), ("rotation", 180.0 / math.pi), ("spring_force", 1.0)):
        st = pcmp.steady(t, y[q], spec)
        out[f"{q}_mean"] = scale * st.mean
        out[f"{q}_std"] = scale * st.std
        out[f"{q}_sem"] = scale * st.sem
    meta = json.loads(str(y["meta"]))
    out["wall_s"] = float(meta["wall_s"])
    out["n_cleared"] = int(meta["n_cleared"])
    return out


def precontact(n: int, y: dict[str, np.ndarray], spec: dict[str, np.ndarray]) -> dict[str, float]:
    """warpdem's main-bed run (in the spec) against Yade's clean main-bed run before the tool meets the soil."""
    w_rot, w_sf = spec["warp_rotation"][0].astype(np.float64), spec["warp_spring_force"][0].astype(np.float64)
    w_x = spec["warp_displacement"][0].astype(np.float64)
    if not np.array_equal(y["step"], spec["warp_step"]):
        raise SystemExit("Yade's records are not warpdem's")
    div = pcmp.first_divergence(w_rot, y["rotation"], 1e-6)
    first = int(np.flatnonzero(y["c_sf_lower"] > 0)[0]) if np.any(y["c_sf_lower"] > 0) else len(w_rot)
    w_d = spec["warp_draught"][0]
    first_w = int(np.flatnonzero(np.abs(w_d) > 0.01)[0]) if np.any(np.abs(w_d) > 0.01) else len(w_rot)
    pre = slice(0, div)
    return {"springs": n, "records_agreeing": div, "last_step_agreeing": int(y["step"][max(div - 1, 0)]),
            "first_yade_lower_contact_record": first, "first_warpdem_draught_record": first_w,
            "max_rotation_diff_rad": float(np.abs(w_rot[pre] - y["rotation"][pre]).max()),
            "max_displacement_diff_m": float(np.abs(w_x[pre] - y["displacement"][pre]).max()),
            "max_spring_force_diff_n": float(np.abs(w_sf[pre] - y["spring_force"][pre]).max()),
            "max_spring_force_n": float(np.abs(w_sf[pre]).max()),
            "rotation_at_last_agreeing_deg": math.degrees(float(y["rotation"][max(div - 1, 0)])),
            "warpdem_steady_draught_main": float(spec["warp_steady_draught"][0, 0]),
            "warpdem_steady_displacement_main_mm": 1e3 * float(spec["warp_steady_displacement"][0, 0])}


def collect(effect: str, raw: Path) -> Path:
    d = raw / effect
    rigid = rigid_reference()
    rows, per, checks = [], {}, []
    for n in SPRINGS:
        spec = pcmp.load(spec_path(n))
        reals = []
        for seed in (None, *SEEDS):
            path = d / yade_name(n, seed)
            if not path.exists():
                raise SystemExit(f"missing {path}: run `passive_twin_table.py run {effect}` first")
            y = pcmp.load(path)
            r = realization_row(y, spec)
            r["realization"] = "main" if seed is None else f"seed {seed}"
            reals.append(r)
            if effect == "clean" and seed is None and "warp_rotation" in spec:
                checks.append(precontact(n, y, spec))
        k = len(reals)
        ens: dict[str, float] = {"n": k}
        for key in ("draught_mean", "draught_std", "displacement_mean", "displacement_std", "rotation_mean",
                    "spring_force_mean"):
            v = np.array([r[key] for r in reals])
            ens[key] = float(v.mean())
            ens[key + "_se"] = float(v.std(ddof=1) / math.sqrt(k))
        for key in ("draught", "displacement", "rotation", "spring_force"):
            # the runs' autocorrelation-based SEs combined, and the larger of the two (passive_twin_compare.ensemble)
            ens[f"{key}_mean_se_runs"] = float(np.sqrt(sum(r[f"{key}_sem"] ** 2 for r in reals)) / k)
            ens[f"{key}_mean_se_conservative"] = max(ens[f"{key}_mean_se"], ens[f"{key}_mean_se_runs"])
        red = 100.0 * (rigid["mean"] - ens["draught_mean"]) / rigid["mean"]

        def red_se(se: float, se_rigid: float, passive: float = ens["draught_mean"]) -> float:
            return 100.0 * math.hypot(se, passive / rigid["mean"] * se_rigid) / rigid["mean"]

        ens.update(reduction=red, reduction_se=red_se(ens["draught_mean_se"], rigid["se"]),
                   reduction_se_conservative=red_se(ens["draught_mean_se_conservative"], rigid["se_conservative"]),
                   rigid_draught_mean=rigid["mean"], rigid_draught_mean_se=rigid["se"],
                   rigid_draught_mean_se_conservative=rigid["se_conservative"],
                   wall_s_mean=float(np.mean([r["wall_s"] for r in reals])))
        per[str(n)] = {"ensemble": ens, "realizations": reals}
        rows.append((n, ens))
    od = out_dir(effect)
    od.mkdir(exist_ok=True)
    options, words = EFFECTS[effect]
    meta = {"effect": effect, "hidden_effect": words, "yade_options": "--no-support-offset " + options,
            "engine": "Yade 2023.02a", "assembly": ASSEMBLY, "speed_m_s": SPEED,
            "units": {"draught": "N", "displacement": "mm", "rotation": "deg", "spring_force": "N (tension > 0)",
                      "reduction": "%"},
            "se_note": "ensemble *_se: std over the realizations' steady means (ddof=1) / sqrt(n) (the SE over "
                       "realizations); *_se_runs: sqrt(sum of the runs' autocorrelation SEs^2) / n; "
                       "*_se_conservative: the larger of the two (passive_twin_compare.ensemble's rule); "
                       "reduction_se(_conservative): propagated from the passive ensemble SE (conservative) and the "
                       "rigid ensemble SE (over its 16 realizations). All realizations share one bed (1e-9 m "
                       "perturbations), so the SE over realizations holds the chaotic scatter only, not a "
                       "bed-to-bed scatter.",
            "rigid_reference": rigid, "springs": per}
    if checks:
        meta["precontact_check_vs_warpdem"] = checks
    (od / "ensemble.json").write_text(json.dumps(meta, indent=1) + "\n")
    print(f"wrote {od / 'ensemble.json'}")
    write_summary(effect)
    return od


def write_summary(effect: str) -> Path:
    """summary.csv of a data set from its ensemble.json: the ensemble means and their conservative standard errors
    (the larger of the SE over the realizations and the runs' own; ``calibration.measured``'s ``*_se`` columns)."""
    od = out_dir(effect)
    meta = json.loads((od / "ensemble.json").read_text())
    rigid = meta["rigid_reference"]
    options, words = EFFECTS[effect]
    head = [
        f"# Yade twin data set '{effect}' in Table 3's format (calibration/measured.py), for testing warpdem's "
        "diagnosis (SoilBinRigModel).",
        f"# Hidden effect: {words}.",
        "# Engine: Yade 2023.02a, benchmarks/yade/passive_twin.py --no-support-offset" + (f" {options}" if options
                                                                                          else "")
        + " (passive tool hinged at its pivot, linear spring, DIN 2093 rate, Table 2's dashpot, NO support offset).",
        "# Bed: the rigid twin's (soil_bin_twin_spec_A.npz: assembly A, ci scale, 681 spheres, GA set 11), "
        "the rigid twin's tool pose; specs passive_twin_spec_A_<n>_nooffset.npz.",
        "# Realizations: 9 per row (the main bed and --perturb 1e-9 --seed k, k = 1..8); values are ensemble means "
        "of the runs' steady means (travel >= 0.15 m of 0.30 m); *_se: their conservative standard errors (the "
        "larger of the SE over realizations and the runs' own autocorrelation SEs combined; ensemble.json has both).",
        "# displacement_std: the displacement's std within a run, averaged over the realizations. Displacement at "
        "the sensor, + backwards (against travel), from the drawing pose.",
        f"# reduction: 100 (rigid - passive) / rigid against the rigid Yade twin (soil_bin_twin.py, same bed, "
        f"0.62 m/s), ensemble of main + seeds 1..15: {rigid['mean']:.2f} +- {rigid['se']:.2f} N "
        "(passive_twin_table_rigid.json); one rigid reference for every row, so the rows' reduction errors share "
        "its part.",
        f"# Generated by benchmarks/yade/passive_twin_table.py collect {effect} (or summary {effect})",
    ]
    lines = head + ["springs,speed [m/s],reduction [%],reduction_se [%],displacement_mean [mm],"
                    "displacement_mean_se [mm],displacement_std [mm],draught_mean [N],draught_mean_se [N],"
                    "rigid_draught_mean [N],rigid_draught_mean_se [N]"]
    for n in SPRINGS:
        e = meta["springs"][str(n)]["ensemble"]
        lines.append(f"{n},{SPEED:.2f},{e['reduction']:.3f},{e['reduction_se_conservative']:.3f},"
                     f"{e['displacement_mean']:.4f},{e['displacement_mean_se_conservative']:.4f},"
                     f"{e['displacement_std']:.4f},{e['draught_mean']:.2f},{e['draught_mean_se_conservative']:.2f},"
                     f"{e['rigid_draught_mean']:.2f},{e['rigid_draught_mean_se_conservative']:.2f}")
    (od / "summary.csv").write_text("\n".join(lines) + "\n")
    print(f"wrote {od / 'summary.csv'}")
    print("\n".join(lines[len(head):]))
    return od


# ------------------------------------------------------------------------------------------------ report
def load_set(effect: str) -> dict | None:
    p = out_dir(effect) / "ensemble.json"
    return json.loads(p.read_text()) if p.exists() else None


def report(out: Path) -> None:
    clean = load_set("clean")
    if clean is None:
        raise SystemExit("no clean data set")
    L = ["# Passive Yade twin: Table-3-format data sets with hidden effects\n",
         "Generated by `python benchmarks/yade/passive_twin_table.py report` from the data sets' ensemble.json "
         "(passive_twin_table.py's docstring: set-up and statistics; commands and runtimes: "
         "passive_twin_table_notes below).\n"]
    r = clean["rigid_reference"]
    L.append(f"Rigid reference (reductions): Yade rigid twin, main + seeds 1..15, {r['mean']:.2f} +- {r['se']:.2f} N "
             f"(n = {r['n']}).\n")
    L.append("## Clean data set (no hidden effect, no support offset)\n")
    L.append("| springs | reduction [%] | displacement mean [mm] | displacement std in run [mm] | draught [N] | "
             "rotation [deg] | spring force [N] | Yade s/run |")
    L.append("|---|---|---|---|---|---|---|---|")
    for n, s in clean["springs"].items():
        e = s["ensemble"]
        L.append(f"| {n} | {e['reduction']:.1f} +- {e['reduction_se']:.1f} | {e['displacement_mean']:.3f} +- "
                 f"{e['displacement_mean_se']:.3f} | {e['displacement_std']:.3f} +- {e['displacement_std_se']:.3f} | "
                 f"{e['draught_mean']:.1f} +- {e['draught_mean_se']:.1f} | {e['rotation_mean']:.3f} +- "
                 f"{e['rotation_mean_se']:.3f} | {e['spring_force_mean']:.1f} +- {e['spring_force_mean_se']:.1f} | "
                 f"{e['wall_s_mean']:.1f} |")
    L.append("")
    if "precontact_check_vs_warpdem" in clean:
        L.append("### Clean, main bed: Yade against warpdem's run_soil_bin before the tool meets the soil\n")
        L.append("warpdem's run: passive_twin_export.py --no-support-offset (run_soil_bin, main bed, records in the "
                 "spec). Records up to the first one where the rotations differ by more than 1e-6 rad:\n")
        L.append("| springs | records agreeing (up to step) | first record with a tool-soil force: warpdem's "
                 "draught / Yade's lower-half interactions | max rotation "
                 "diff [rad] | max displacement diff [m] | max spring force diff [N] (of max |F|) | warpdem main: "
                 "steady draught [N] / displacement [mm] | Yade main: draught / displacement |")
        L.append("|---|---|---|---|---|---|---|---|")
        for c in clean["precontact_check_vs_warpdem"]:
            y = clean["springs"][str(c["springs"])]["realizations"][0]
            L.append(f"| {c['springs']} | {c['records_agreeing']} ({c['last_step_agreeing']}) | "
                     f"{c['first_warpdem_draught_record']} / {c['first_yade_lower_contact_record']} | "
                     f"{c['max_rotation_diff_rad']:.1e} | "
                     f"{c['max_displacement_diff_m']:.1e} | {c['max_spring_force_diff_n']:.1e} "
                     f"({c['max_spring_force_n']:.1f}) | {c['warpdem_steady_draught_main']:.1f} / "
                     f"{c['warpdem_steady_displacement_main_mm']:.3f} | {y['draught_mean']:.1f} / "
                     f"{y['displacement_mean']:.3f} |")
        L.append("")
    for effect in EFFECTS:
        if effect == "clean":
            continue
        s = load_set(effect)
        if s is None:
            L.append(f"## {effect}: not generated\n")
            continue
        L.append(f"## {effect}: {s['hidden_effect']}\n")
        L.append("Each cell: the data set's ensemble mean +- SE over realizations, then (data set - clean) / combined "
                 "SE over realizations and, in brackets, / combined conservative SE (the larger of the SE over "
                 "realizations and the runs' autocorrelation SEs combined; none for the std).\n")
        L.append("| springs | reduction [%] | diff/SE | displacement mean [mm] | diff/SE | displacement std [mm] | "
                 "diff/SE | draught [N] | diff/SE |")
        L.append("|---|---|---|---|---|---|---|---|---|")
        shown = {"reduction": 0, "displacement_mean": 0}
        big = {"reduction": 0, "displacement_mean": 0}  # |diff| >= 3 x the clean set's SE (the choice's criterion)
        cons = {"reduction": 0, "displacement_mean": 0}  # |diff| >= 3 combined conservative SE
        for n, sp in s["springs"].items():
            e, c = sp["ensemble"], clean["springs"][n]["ensemble"]
            cells = []
            for key, fmt in (("reduction", "{:.1f}"), ("displacement_mean", "{:.3f}"),
                             ("displacement_std", "{:.3f}"), ("draught_mean", "{:.1f}")):
                se_k = key + "_se"
                zs = []
                for suffix in ("", "_conservative"):
                    if key == "reduction":  # same rigid reference: its SE cancels in the difference
                        se_a = 100 * e["draught_mean_se" + suffix] / e["rigid_draught_mean"]
                        se_b = 100 * c["draught_mean_se" + suffix] / c["rigid_draught_mean"]
                    elif key + "_se" + suffix in e:
                        se_a, se_b = e[key + "_se" + suffix], c[key + "_se" + suffix]
                    else:
                        continue
                    zs.append((e[key] - c[key]) / math.hypot(se_a, se_b))
                    if suffix and key in cons and abs(zs[-1]) >= 3:
                        cons[key] += 1
                    if not suffix:
                        if key in shown and abs(zs[0]) >= 3:
                            shown[key] += 1
                        if key in big and abs(e[key] - c[key]) >= 3 * se_b:
                            big[key] += 1
                z_txt = f"{zs[0]:+.2f}" + (f" ({zs[1]:+.2f})" if len(zs) > 1 else "")
                cells += [f"{fmt.format(e[key])} +- {fmt.format(e[se_k])}", z_txt]
            L.append(f"| {n} | " + " | ".join(cells) + " |")
        L.append("")
        L.append(f"|diff| >= 3 combined SE (over realizations) in {shown['displacement_mean']} of 8 spring counts "
                 "(displacement mean), "
                 f"{shown['reduction']} of 8 (reduction; the rigid reference's SE cancels in the difference, so "
                 f"only the passive draughts' SEs count); |diff| >= 3 x the clean set's SE in "
                 f"{big['displacement_mean']} of 8 (displacement mean), {big['reduction']} of 8 (reduction); "
                 f"|diff| >= 3 combined conservative SE in {cons['displacement_mean']} of 8 (displacement mean), "
                 f"{cons['reduction']} of 8 (reduction).\n")
    notes = HERE / "passive_twin_table_notes.md"
    if notes.exists():
        L.append(notes.read_text())
    out.write_text("\n".join(L) + "\n")
    print("\n".join(L))
    print("wrote", out)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("what", choices=("rigid", "run", "collect", "summary", "report"))
    ap.add_argument("effect", nargs="?", default="clean", choices=tuple(EFFECTS))
    ap.add_argument("--raw", default="/tmp/passive_twin_table", help="where the Yade runs' npz and logs go")
    ap.add_argument("--springs", nargs="+", type=int, default=list(SPRINGS))
    ap.add_argument("--seeds", nargs="*", type=int, default=None)
    ap.add_argument("--out", default=str(HERE / "passive_twin_table_report.md"))
    a = ap.parse_args()
    raw = Path(a.raw)
    if a.what == "rigid":
        run_rigid(raw, tuple(RIGID_SEEDS if a.seeds is None else a.seeds))
    elif a.what == "run":
        run_effect(a.effect, raw, tuple(a.springs), tuple(SEEDS if a.seeds is None else a.seeds))
    elif a.what == "collect":
        collect(a.effect, raw)
    elif a.what == "summary":
        write_summary(a.effect)
    else:
        report(Path(a.out))


if __name__ == "__main__":
    main()
