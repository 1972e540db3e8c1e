"""Which cohesion rule did the paper's shear box use? Both rules against the paper's own shear-box results.

The paper does not say whether cohesion was set on the contacts present when a test starts (Yade's setCohesionNow)
or also on every contact made later (setCohesionOnNewContacts). Tables 4-6 print, for each of the 15 GA sets, the
cohesion and internal friction angle the paper's DEM shear box gave. This runs warpdem's shear box with every set
under both rules (one batched simulation per assembly and rule) and reports which rule reproduces the paper's
columns better: mean absolute error of cohesion [kPa] and friction angle [deg], and the correlation over the sets.

    python benchmarks/cohesion_rule.py --scale ci --device cuda --out docs/runs/cohesion_rule_h100

Writes ``cohesion_rule.json`` and ``cohesion_rule.md`` into ``--out`` (refuses an existing folder's files).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import warp as wp

wp.config.quiet = True

from calibration.screening import screen  # noqa: E402
from scenes import paper  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scale", default="ci", choices=("ci", "cpu", "paper"))
    ap.add_argument("--device", default=None)
    ap.add_argument("--assemblies", default="A,B,C")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    out = Path(a.out)
    if (out / "cohesion_rule.json").exists():
        raise SystemExit(f"cohesion_rule: error: {out / 'cohesion_rule.json'} exists; choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    t = paper.table("ga_sets")
    rows = []
    for asm in a.assemblies.split(","):
        sel = np.flatnonzero(t["assembly"] == asm)
        sets = [{"friction_angle": float(t["friction_angle_deg"][i]),
                 "normal_cohesion": float(t["normal_cohesion_pa"][i]), "eta_roll": float(t["eta_roll_twist"][i])}
                for i in sel]
        for rule in (False, True):
            t0 = time.perf_counter()
            res = sorted(screen(sets, asm, a.scale, device=a.device, cohesion_on_new_contacts=rule),
                         key=lambda r: r["set"])
            wall = time.perf_counter() - t0
            for r, i in zip(res, sel, strict=True):
                rows.append({"assembly": asm, "set": int(t["set"][i]), "cohesion_on_new_contacts": rule,
                             "cohesion_kpa": r["cohesion_kpa"], "friction_angle_deg": r["friction_angle_deg"],
                             "r2": r["r2"], "paper_cohesion_kpa": float(t["shear_box_cohesion_kpa"][i]),
                             "paper_friction_angle_deg": float(t["shear_box_friction_angle_deg"][i]), "wall_s": wall})
            print(f"{asm} new-contacts={rule}: {wall:.0f} s", flush=True)
    lines = [f"# Cohesion rule of the shear box against the paper's Tables 4-6 ({a.scale} scale, device "
             f"{a.device or wp.get_device()})", "",
             "| set | assembly | paper c [kPa] | initial only c | every new c | paper phi [deg] | initial only phi "
             "| every new phi |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    by = {(r["set"], r["cohesion_on_new_contacts"]): r for r in rows}
    for s in sorted({r["set"] for r in rows}):
        f, n = by[(s, False)], by[(s, True)]
        lines.append(f"| {s} | {f['assembly']} | {f['paper_cohesion_kpa']:.2f} | {f['cohesion_kpa']:.2f} | "
                     f"{n['cohesion_kpa']:.2f} | {f['paper_friction_angle_deg']:.2f} | {f['friction_angle_deg']:.2f} | "
                     f"{n['friction_angle_deg']:.2f} |")
    summary = {}
    for rule in (False, True):
        rr = [r for r in rows if r["cohesion_on_new_contacts"] == rule]
        c, pc = np.array([r["cohesion_kpa"] for r in rr]), np.array([r["paper_cohesion_kpa"] for r in rr])
        f, pf = np.array([r["friction_angle_deg"] for r in rr]), np.array([r["paper_friction_angle_deg"] for r in rr])
        summary[str(rule)] = {"mae_cohesion_kpa": float(np.abs(c - pc).mean()),
                              "mae_friction_deg": float(np.abs(f - pf).mean()),
                              "corr_cohesion": float(np.corrcoef(c, pc)[0, 1]),
                              "corr_friction": float(np.corrcoef(f, pf)[0, 1])}
        s = summary[str(rule)]
        lines.append("")
        lines.append(f"{'every new contact' if rule else 'initial contacts only'}: MAE c {s['mae_cohesion_kpa']:.2f} "
                     f"kPa, phi {s['mae_friction_deg']:.2f} deg; correlation with the paper c {s['corr_cohesion']:.2f},"
                     f" phi {s['corr_friction']:.2f}")
    (out / "cohesion_rule.json").write_text(json.dumps({"rows": rows, "summary": summary, "scale": a.scale}, indent=1))
    (out / "cohesion_rule.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
