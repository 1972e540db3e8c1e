"""Candidate causes of the paper-scale rigid draught gap (warpdem ~150 N with GA set 11 against the paper's DEM
311.9-350.1 N), measured one at a time on ONE deposited bed: the rigid tool at 0.68 m/s, assembly C, GA set 11.

    python benchmarks/paper_gap.py --scale paper --device cuda --bed results/beds/bed_paper_C_<key>.npz \
        --out results/paper_gap [--variants baseline,no_cohesion,cohesion_on_new]

Variants (each a change of the baseline, everything else equal):
- baseline: cohesion on the bed's initial contacts only (Yade's setCohesionNow), as ``warpdem soil-bin``;
- no_cohesion: normal and shear cohesion 0 (brackets the bonds' share of the draught);
- cohesion_on_new: cohesion also on every contact made during the run (Yade's setCohesionOnNewContacts; the shear
  box's rule);
- radius_10mm, radius_14mm, radius_20mm: member spheres of 10, 14 or 20 mm instead of the scale's 7 mm (a bed of
  their own, deposited with the same seed into OUT/beds; the paper takes its sizes from Tamas and Bernon 2021
  without printing them);
- radius_14mm_cohesion_on_new: both changes together;
- settled: the bed settles 1.0 s with the run's soil set (no bonds, damping 0.4) before the bonds and the tool
  (``SoilBinConfig.settle_time``); settled_cohesion_on_new: and cohesion on every new contact.
The per-world variants run as the worlds of one simulation; a variant that changes a simulation-wide option runs
alone. Writes OUT/paper_gap.json (steady means with standard errors, run times) and prints a table.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

from scenes import soil_bin as sb
from scenes.assemblies import Bed

VARIANTS = {
    "baseline": ({}, {}),
    "no_cohesion": ({}, {"normal_cohesion": 0.0, "shear_cohesion": 0.0}),
    "cohesion_on_new": ({"cohesion_on_new_contacts": True}, {}),
    "radius_10mm": ({"member_radius": 0.010}, {}),
    "radius_14mm": ({"member_radius": 0.014}, {}),
    "radius_20mm": ({"member_radius": 0.020}, {}),
    "settled": ({"settle_time": 1.0}, {}),
    "settled_cohesion_on_new": ({"settle_time": 1.0, "cohesion_on_new_contacts": True}, {}),
    "radius_14mm_cohesion_on_new": ({"member_radius": 0.014, "cohesion_on_new_contacts": True}, {}),
}
"""name -> (SoilBinConfig changes, per-world soil overrides)."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", default="paper", choices=sorted(sb.SCALES))
    ap.add_argument("--device", default=None)
    ap.add_argument("--bed", default=None, help="a saved bed (.npz); default: deposit (seed 0) into OUT/beds")
    ap.add_argument("--speed", type=float, default=0.68)
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--out", default="results/paper_gap")
    a = ap.parse_args()
    names = [v for v in a.variants.split(",") if v]
    for v in names:
        if v not in VARIANTS:
            raise SystemExit(f"--variants: unknown {v!r}; known {sorted(VARIANTS)}")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    base = sb.SoilBinConfig(scale=a.scale, assembly="C", springs=(0,), parameter_set=11)
    bed = Bed.load(a.bed) if a.bed else sb.bed_for(base, device=a.device, cache_dir=out / "beds")
    mat = base.soil_material()
    # group the variants by their simulation-wide changes: one simulation per group, one world per variant
    groups: dict[str, list[str]] = {}
    for v in names:
        groups.setdefault(json.dumps(VARIANTS[v][0], sort_keys=True), []).append(v)
    rows = {}
    for key, members in groups.items():
        cfg = replace(base, **json.loads(key))
        run_bed = bed if cfg.member_radius is None else sb.bed_for(cfg, device=a.device, cache_dir=out / "beds")
        fields = sorted({f for v in members for f in VARIANTS[v][1]})
        overrides = {f: [VARIANTS[v][1].get(f, getattr(mat, f)) for v in members] for f in fields} or None
        t0 = time.perf_counter()
        run = sb.run_soil_bin(cfg, [0] * len(members), bed=run_bed, device=a.device,
                              speeds=[a.speed] * len(members), soil_overrides=overrides)
        for v, r in zip(members, run.steady, strict=True):
            rows[v] = {"draught_mean": r["draught_mean"], "draught_sem": r["draught_sem"],
                       "draught_std": r["draught_std"], "coordination_start": r["coordination_start"],
                       "coordination_end": r["coordination_end"], "wall_s": time.perf_counter() - t0,
                       "worlds_in_simulation": len(members), "steps": run.steps, "dt": run.dt,
                       "bed_particles": run_bed.n_particles, "bed_spheres": int(len(run_bed.radii)),
                       "bed_porosity": run_bed.porosity, "member_radius": run_bed.spec.radius}
    summary = {"scale": a.scale, "device": a.device, "speed": a.speed, "bed": a.bed,
               "bed_particles": bed.n_particles, "bed_porosity": bed.porosity, "variants": rows}
    (out / "paper_gap.json").write_text(json.dumps(summary, indent=2))
    for v, r in rows.items():
        print(f"{v:18s} {r['draught_mean']:7.1f} N (SE {r['draught_sem']:.1f})  coordination "
              f"{r['coordination_start']:.2f} -> {r['coordination_end']:.2f}  ({r['wall_s']:.0f} s)")


if __name__ == "__main__":
    main()
