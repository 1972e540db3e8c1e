"""The soil-bin twin at the paper's particle size: warpdem's runs and the comparison with Yade.

The ``strip`` scale (scenes.soil_bin.SCALES) is the paper-scale bed cut down: 7 mm members, a 0.25 m deep bed, a
0.6 m x 0.75 m bin, 0.45 m of travel, statistics from 0.2 m. Assembly C, GA set 11, rigid tool at 0.62 m/s,
cohesion on the first step's contacts: the set-up of the `ci` twin (soil_bin_twin_notes.md) at the size where the
paper-scale draught (150 N against the paper's 312 N) was measured. Run from the repository root:

    python benchmarks/yade/soil_bin_twin_export.py C --scale strip          # bed (cached) + spec
    yade -j2 -n -x benchmarks/yade/soil_bin_twin.py C --scale strip --full-every 10
    python benchmarks/yade/strip_twin.py run --device cuda --seeds 0 1 2 3 --out benchmarks/yade/strip_twin_warpdem
    python benchmarks/yade/strip_twin.py compare benchmarks/yade/strip_twin_warpdem        # -> strip_twin_report.md

``run``: ``scenes.soil_bin.run_soil_bin`` itself on the spec's bed (seed 0: the bed as exported; seed k: every
particle displaced as a whole by RandomState(k).uniform(-1e-9, 1e-9) m, as soil_bin_twin.py --perturb 1e-9 --seed k
does in Yade: another realization of the same bed). Writes ``warpdem_s{k}.npz`` (time, draught, coordination).
``compare``: steady-state means and standard errors (``scenes.analysis.steady_state``, travel >= 0.2 m) of every
run, the warpdem ensemble, the difference in combined standard errors, coordination 2 C_ss / N_particles at the start
and the end in both engines.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

wp.config.quiet = True

from scenes import soil_bin as sb  # noqa: E402
from scenes.assemblies import Bed  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))
import soil_bin_twin_export as ex  # noqa: E402
from soil_bin_twin_compare import load, shifts, steady  # noqa: E402

FIRST_FULL = 10
"""the record (every 72 steps) of Yade's first contact count with --full-every 10: 720 steps."""
ASSEMBLY, SCALE = "C", "strip"


def run(device: str, seeds: list[int], out: Path) -> None:
    config = ex.config_for(ASSEMBLY, SCALE)
    bed0 = sb.bed_for(config, device=device, cache_dir=ROOT / "results" / "beds")  # deposited here if not cached
    if not (HERE / ex.spec_name(ASSEMBLY, SCALE)).exists():
        ex.export(ASSEMBLY, SCALE)
    spec = load(HERE / ex.spec_name(ASSEMBLY, SCALE))
    out.mkdir(parents=True, exist_ok=True)
    for k in seeds:
        bed = bed0
        if k:
            centres = bed.centres.copy()
            centres[spec["sphere_bed_index"]] += shifts(spec, k)[spec["sphere_particle"]]
            bed = Bed(bed.spec, bed.bin_size, bed.depth, centres, bed.radii, bed.particle, bed.porosity,
                      bed.coordination, bed.seed, bed.wall_s)
        t0 = time.perf_counter()
        r = sb.run_soil_bin(config, [0], bed=bed, device=device)
        wall = time.perf_counter() - t0
        if abs(r.dt - float(spec["dt"])) > 1e-12 * float(spec["dt"]) or r.n_particles != int(spec["n_particles"]):
            raise AssertionError(f"run differs from the spec: dt {r.dt} vs {float(spec['dt'])}, "
                                 f"{r.n_particles} vs {int(spec['n_particles'])} particles")
        np.savez_compressed(out / f"warpdem_s{k}.npz", time=r.time, draught=r.series["draught"][:, 0],
                            coordination=r.series["coordination"][:, 0], wall_s=wall, device=device, seed=k)
        print(f"seed {k}: {r.steady[0]['draught_mean']:.1f} +- {r.steady[0]['draught_sem']:.1f} N, {wall:.0f} s",
              flush=True)


def compare(folder: Path, report: Path) -> str:
    spec = load(HERE / ex.spec_name(ASSEMBLY, SCALE))
    rows, wd_means, wd_ses = [], [], []
    for f in sorted(folder.glob("warpdem_s*.npz")):
        d = load(f)
        st = steady(d["time"], d["draught"], spec)
        wd_means.append(st.mean)
        wd_ses.append(st.sem)
        trav = np.minimum(d["time"] * float(spec["speed"]), float(spec["travel"]))
        zs = float(np.mean(d["coordination"][trav >= float(spec["steady_travel"])]))
        rows.append((f"warpdem, realization {int(d['seed'])} ({d['device']}, {float(d['wall_s']):.0f} s)", st.mean,
                     st.sem, float(d["coordination"][FIRST_FULL]), zs))
    yade = []
    for f in sorted(HERE.glob(f"soil_bin_twin_yade_{ASSEMBLY}_{SCALE}*.npz")):
        y = load(f)
        t = y["step"] * float(y["dt"])
        st = steady(t, y["draught"], spec)
        z = y["z_particle_ss"]
        ok = np.isfinite(z)
        trav = np.minimum(t * float(spec["speed"]), float(spec["travel"]))
        zs = float(np.mean(z[ok & (trav >= float(spec["steady_travel"]))]))
        yade.append((st.mean, st.sem))
        tag = f.stem.removeprefix(f"soil_bin_twin_yade_{ASSEMBLY}_{SCALE}").strip("_") or "main"
        rows.append((f"Yade {y['yade_version']}, {tag} (-j2, {float(y['wall_s']):.0f} s)", st.mean, st.sem,
                     float(z[ok][0]), zs))
    m = np.array(wd_means)
    se_spread = float(m.std(ddof=1) / math.sqrt(len(m))) if len(m) > 1 else math.nan
    se_runs = float(math.sqrt(np.sum(np.square(wd_ses))) / len(m))
    wd_se = float(np.nanmax([se_spread, se_runs]))
    lines = [f"# Soil-bin twin at the paper's particle size (`strip` scale, assembly {ASSEMBLY}, GA set 11, "
             f"{float(spec['speed'])} m/s)", "",
             f"Generated by `python benchmarks/yade/strip_twin.py compare {folder}`. Bed: {int(spec['n_particles'])} "
             f"particles, {int(spec['n_spheres'])} spheres (members {1e3 * float(np.median(spec['sphere_radius'])):.1f} mm), "
             f"porosity {float(spec['bed_porosity']):.3f}; dt {float(spec['dt']):.4e} s, {int(spec['n_steps'])} "
             f"steps; statistics over travel >= {float(spec['steady_travel'])} m.", "",
             f"| run | draught [N] | SE [N] | coordination 2 C_ss / N_particles after "
             f"{FIRST_FULL * int(spec['record_every'])} steps | the same, mean over the steady part |",
             "| --- | --- | --- | --- | --- |"]
    lines += [f"| {n} | {a:.1f} | {b:.1f} | {c:.2f} | {e:.2f} |" for n, a, b, c, e in rows]
    lines += ["", f"warpdem ensemble ({len(m)} realizations): {m.mean():.1f} N, SE {wd_se:.1f} N (spread "
              f"{se_spread:.1f}, runs' own {se_runs:.1f})."]
    for k, (a, b) in enumerate(yade):
        c = math.hypot(wd_se, b)
        lines.append(f"Yade run {k + 1}: {a:.1f} +- {b:.1f} N; warpdem - Yade = {m.mean() - a:+.1f} N = "
                     f"{(m.mean() - a) / c:+.2f} combined SE.")
    text = "\n".join(lines) + "\n"
    report.write_text(text)
    (report.with_suffix(".json")).write_text(json.dumps({"warpdem_mean": float(m.mean()), "warpdem_se": wd_se,
                                                     "yade": yade, "rows": rows}, indent=1))
    return text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--device", default="cuda")
    r.add_argument("--seeds", nargs="+", type=int, default=[0])
    r.add_argument("--out", default="benchmarks/yade/strip_twin_warpdem")
    c = sub.add_parser("compare")
    c.add_argument("folder", nargs="?", default="benchmarks/yade/strip_twin_warpdem")
    c.add_argument("--report", default=str(HERE / "strip_twin_report.md"))
    a = ap.parse_args()
    if a.cmd == "run":
        run(a.device, a.seeds, Path(a.out))
    else:
        print(compare(Path(a.folder), Path(a.report)))


if __name__ == "__main__":
    main()
