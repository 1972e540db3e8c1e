"""The bed's bond protocols, with the bonds' strength scaled: rigid draught and bonds in the soil bin, c and phi in
the shear box (assembly C, GA set 11). What each protocol keeps of the bonds, and whether one soil gives both the
laboratory's draught (343 N at 0.62-0.68 m/s) and its shear box (c = 6.4 kPa, phi = 32.3 deg).

    python benchmarks/bond_protocols.py --part soil-bin --scale paper --device cuda --out results/bond_protocols
    python benchmarks/bond_protocols.py --part shear-box --scale ci --device cuda --out results/bond_protocols

Protocols (simulation-wide; one simulation each, one world per cohesion factor):
- ``touch``: bonds on the contacts of the deposited bed (soil bin) or of the consolidated sample at the start of
  shear (shear box): both rigs' default;
- ``settled`` (soil bin): the bed settles ``--settle`` s with set 11 (no bonds, damping 0.4), then the bonds go on
  that moment's contacts (``SoilBinConfig.settle_time``); the shear box's ``touch`` already bonds a sample at rest;
- ``settled_distance`` / ``distance``: the same with distance bonding, detection factor 1.5 at the bonding step
  (``bond_detection_factor``; benchmarks/yade/bond_protocols_report.md checks it against Yade);
- ``settled_new`` / ``new``: and cohesion on every new contact (Yade's setCohesionOnNewContacts);
- ``ductile`` / ``settled_ductile``: bonds that yield instead of breaking (``fragile=False``, Yade's unpMax = 0: a
  bond is deleted at its first tensile yield, and keeps its shear strength while it slides);
- ``dense_settled`` / ``dense_settled_ductile``: the settled protocols on a bed deposited without friction
  (``SoilBinConfig.deposit_friction`` 0: porosity 0.31 and coordination 8.1 at ci scale against 0.44 and 4.5).
Cohesion factors (``--factors``): normal and shear cohesion = factor x set 11's (22.5 kPa, 11.2 kPa), per world.

Per world. Soil bin: bonds after the bonding step, at 0.1 s (the tool has moved 7 cm: a loss beyond its path is the
bed's own collapse) and at the end; coordination (warpdem's count: 2 x soil-soil sphere contacts between different
particles / particles, each member-member contact counted, as Yade's interactions) at the start and the end; the
rigid draught's steady mean and standard error at ``--speed``. Shear box: c [kPa], phi [deg], R^2 of the
Mohr-Coulomb fit at the preset's normal stresses.

Writes OUT/bond_protocols_<part>.json after every protocol (a rerun skips the protocols it holds: a ten-minute
command limit cuts the work, not the results) and OUT/bond_protocols_<part>.md.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import warp as wp

wp.config.quiet = True

from scenes import shear_box as sbx  # noqa: E402
from scenes import soil_bin as sb  # noqa: E402

SOIL_BIN = {
    "touch": {},
    "settled": {"settle_time": None},
    "settled_distance": {"settle_time": None, "bond_detection_factor": 1.5},
    "settled_new": {"settle_time": None, "cohesion_on_new_contacts": True},
    "ductile": {"fragile": False},
    "settled_ductile": {"settle_time": None, "fragile": False},
    "dense_settled": {"settle_time": None, "deposit_friction": 0.0},
    "dense_settled_ductile": {"settle_time": None, "deposit_friction": 0.0, "fragile": False},
}
SHEAR_BOX = {
    "touch": {},
    "distance": {"bond_detection_factor": 1.5},
    "new": {"cohesion_on_new_contacts": True},
    "ductile": {"fragile": False},
}
LAB_DRAUGHT = 343.05
"""the laboratory's rigid draught [N] (Table 3's rigid mean, the workflow's draught target)."""


def soil_bin_part(a: argparse.Namespace, done: dict[str, object], save: object) -> None:
    base = sb.SoilBinConfig(scale=a.scale, assembly="C", springs=(0,), parameter_set=11,
                            travel=a.travel, steady_travel=a.steady_travel)
    mat = base.soil_material()
    for name in a.protocols:
        if name in done:
            continue
        changes = {k: (a.settle if v is None else v) for k, v in SOIL_BIN[name].items()}
        cfg = replace(base, **changes)
        bed = sb.bed_for(cfg, device=a.device, cache_dir=Path(a.out) / "beds")  # the dense protocols' own bed
        overrides = {"normal_cohesion": [f * mat.normal_cohesion for f in a.factors],
                     "shear_cohesion": [f * mat.shear_cohesion for f in a.factors]}
        t0 = time.perf_counter()
        run = sb.run_soil_bin(cfg, [0] * len(a.factors), bed=bed, device=a.device, speeds=[a.speed] * len(a.factors),
                              soil_overrides=overrides)
        k01 = int(np.argmin(np.abs(run.time - 0.1)))
        rows = []
        for w, (f, r) in enumerate(zip(a.factors, run.steady, strict=True)):
            rows.append({"factor": f, "normal_cohesion_pa": f * mat.normal_cohesion,
                         "draught_mean": r["draught_mean"], "draught_sem": r["draught_sem"],
                         "bonds_start": r["bonds_start"], "bonds_0.1s": float(run.series["bonds"][k01, w]),
                         "bonds_end": r["bonds_end"], "coordination_start": r["coordination_start"],
                         "coordination_end": r["coordination_end"]})
        done[name] = {"changes": changes, "worlds": rows, "wall_s": time.perf_counter() - t0, "steps": run.steps,
                      "dt": run.dt, "bed_particles": bed.n_particles, "bed_porosity": bed.porosity,
                      "bed_coordination": bed.coordination}
        save()
        print(f"{name}: {time.perf_counter() - t0:.0f} s", flush=True)


def shear_box_part(a: argparse.Namespace, done: dict[str, object], save: object) -> None:
    base = sbx.preset(a.scale, "C", ga_set=11)
    bed = sbx.make_bed(base, a.device)
    for name in a.protocols:
        if name in done:
            continue
        changes = SHEAR_BOX[name]
        configs = [base.replace(normal_cohesion=f * base.normal_cohesion, shear_cohesion=f * base.shear_cohesion,
                                label=f"x{f:g}", **changes) for f in a.factors]
        t0 = time.perf_counter()
        results = sbx.run_shear_boxes(configs, a.device, bed=bed)
        rows = [{"factor": f, "normal_cohesion_pa": c.normal_cohesion, "cohesion_kpa": r.fit.cohesion / 1e3,
                 "friction_angle_deg": r.fit.friction_angle_deg, "r2": r.fit.r2,
                 "peak_kpa": (r.peak_shear_stress / 1e3).tolist()}
                for f, c, r in zip(a.factors, configs, results, strict=True)]
        done[name] = {"changes": changes, "worlds": rows, "wall_s": time.perf_counter() - t0,
                      "normal_stresses_kpa": [s / 1e3 for s in base.normal_stresses],
                      "member_radius_m": base.assembly.radius, "spheres_per_world": int(len(bed.radii))}
        save()
        print(f"{name}: {time.perf_counter() - t0:.0f} s", flush=True)


def markdown(part: str, meta: dict[str, object], done: dict[str, dict]) -> str:
    lines = [f"# Bond protocols: {part}", "", "```", json.dumps(meta), "```", ""]
    if part == "soil-bin":
        lines += ["| protocol | factor | Cn [kPa] | bonds after bonding | at 0.1 s | at the end | coordination "
                  "start -> end | draught [N] (SE) | of the lab's 343 N |", "| --- | ---: | ---: | ---: | ---: | ---: "
                  "| --- | ---: | ---: |"]
        for name, d in done.items():
            for r in d["worlds"]:
                kept = 100 * r["bonds_0.1s"] / max(r["bonds_start"], 1)
                lines.append(f"| {name} | {r['factor']:g} | {r['normal_cohesion_pa'] / 1e3:.1f} | "
                             f"{r['bonds_start']:.0f} | {r['bonds_0.1s']:.0f} ({kept:.0f} %) "
                             f"| {r['bonds_end']:.0f} | {r['coordination_start']:.2f} -> {r['coordination_end']:.2f} | "
                             f"{r['draught_mean']:.1f} ({r['draught_sem']:.1f}) | "
                             f"{100 * r['draught_mean'] / LAB_DRAUGHT:.0f} % |")
    else:
        lines += ["| protocol | factor | Cn [kPa] | c [kPa] (lab 6.4) | phi [deg] (lab 32.3) | R^2 | peaks [kPa] |",
                  "| --- | ---: | ---: | ---: | ---: | ---: | --- |"]
        for name, d in done.items():
            for r in d["worlds"]:
                lines.append(f"| {name} | {r['factor']:g} | {r['normal_cohesion_pa'] / 1e3:.1f} | "
                             f"{r['cohesion_kpa']:.2f} | {r['friction_angle_deg']:.1f} | {r['r2']:.3f} | "
                             + ", ".join(f"{p:.1f}" for p in r["peak_kpa"]) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--part", required=True, choices=("soil-bin", "shear-box"))
    ap.add_argument("--scale", default=None, help="soil bin: paper (default); shear box: ci (default), cpu, paper")
    ap.add_argument("--device", default=None)
    ap.add_argument("--protocols", default=None, help="comma-separated (default: all of the part's)")
    ap.add_argument("--factors", default="1,3,10", help="cohesion factors on set 11's, one world each")
    ap.add_argument("--speed", type=float, default=0.68, help="soil bin: carriage speed [m/s]")
    ap.add_argument("--travel", type=float, default=None, help="soil bin: travel [m] (default the scale's)")
    ap.add_argument("--steady-travel", type=float, default=None, help="soil bin: steady part from [m]")
    ap.add_argument("--settle", type=float, default=1.0, help="soil bin: settling time of the settled protocols [s]")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    table = SOIL_BIN if a.part == "soil-bin" else SHEAR_BOX
    a.scale = a.scale or ("paper" if a.part == "soil-bin" else "ci")
    a.protocols = a.protocols.split(",") if a.protocols else list(table)
    for p in a.protocols:
        if p not in table:
            raise SystemExit(f"bond_protocols: error: --protocols {p!r} is not one of {sorted(table)}")
    a.factors = [float(f) for f in a.factors.split(",")]
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"bond_protocols_{a.part}.json"
    meta = {"part": a.part, "scale": a.scale, "device": a.device, "factors": a.factors, "assembly": "C",
            "ga_set": 11, "speed": a.speed, "travel": a.travel, "steady_travel": a.steady_travel, "settle": a.settle,
            "warp": wp.__version__}
    done: dict[str, object] = {}
    if path.exists():
        old = json.loads(path.read_text())
        if {k: old["meta"][k] for k in ("part", "scale", "factors", "speed", "travel", "settle")} != \
                {k: meta[k] for k in ("part", "scale", "factors", "speed", "travel", "settle")}:
            raise SystemExit(f"bond_protocols: error: {path} holds another study; choose another --out")
        done = old["protocols"]

    def save() -> None:
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"meta": meta, "protocols": done}, indent=1))
        tmp.replace(path)
        (out / f"bond_protocols_{a.part}.md").write_text(markdown(a.part, meta, done))

    (soil_bin_part if a.part == "soil-bin" else shear_box_part)(a, done, save)
    save()
    print(markdown(a.part, meta, done))


if __name__ == "__main__":
    main()
