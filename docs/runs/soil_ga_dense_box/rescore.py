"""Re-run the shear box of every individual of the dense-bed soil calibration at other normal stresses.

The soil bin's draught does not depend on the shear box's normal stresses, so each archived individual keeps its
draught and gets its box observables, errors and fitness again from a new batched shear box. The result is an
archive under the simulation key that ``warpdem calibrate soil ... --box-stresses`` makes, which that calibration
reads with ``--archive`` (its individuals are then not simulated again), and the trade-off over the new box.

    python docs/runs/soil_ga_dense_box/rescore.py --device cuda --stresses 20,40,80 --out results/rescored

Args (command line): --archive (default: docs/runs/soil_ga_dense_h100/archive.json), --stresses [kPa],
--device, --out (a new folder, or one holding a partial run at the same stresses, which goes on: archive.json,
tradeoff.md, tradeoff.png, rescore.json), --chunk (individuals per batched box; default all),
--limit (only the first N records, for a quick check), --report-only (no simulation: the report of the
individuals the partial run holds).
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from calibration import report
from calibration.archive import Archive, Record
from calibration.problems import SoilProblem

HERE = Path(__file__).resolve().parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--archive", default=str(HERE.parent / "soil_ga_dense_h100" / "archive.json"))
    ap.add_argument("--stresses", default="20,40,80", help="normal stresses [kPa], comma-separated")
    ap.add_argument("--device", default="cuda")
    ap.add_argument("--out", required=True)
    ap.add_argument("--chunk", type=int, default=0)
    ap.add_argument("--limit", type=int, default=0)
    ap.add_argument("--box-scale", default=None, help="override the archive's box scale (a quick CPU check)")
    ap.add_argument("--report-only", action="store_true",
                    help="no simulation: the report of the individuals whose boxes the partial run holds")
    args = ap.parse_args()
    out = Path(args.out)
    partial = out / "partial.json"  # the boxes run so far: the same command goes on from them
    if out.exists() and not partial.exists():
        raise SystemExit(f"--out: {out} exists and holds no partial run; choose a new folder")
    out.mkdir(parents=True, exist_ok=True)
    old = Archive.load(args.archive)
    key = old.simulation_key
    stresses = tuple(1e3 * float(s) for s in args.stresses.split(","))
    problem = SoilProblem(assembly=key["assembly"], scale=key["scale"], speed=key["speed"], seed=key["seed"],
                          deposit_friction=key["deposit_friction"], box_scale=args.box_scale or key["box_scale"],
                          box_changes={"normal_stresses": stresses}, device=args.device)
    recs = [r for r in old.records if not r.failure][: args.limit or None]
    values = np.array([r.gene_vector(old.gene_names) for r in recs])
    chunk = args.chunk or len(recs)
    done = json.loads(partial.read_text()) if partial.exists() else {"stresses": args.stresses, "boxes": []}
    if done["stresses"] != args.stresses:
        raise SystemExit(f"--stresses: {out} holds a partial run at {done['stresses']}, got {args.stresses}")
    boxes = done["boxes"]
    if args.report_only:
        recs = recs[: len(boxes)]
    t0 = time.perf_counter()
    for lo in range(len(boxes), len(recs), chunk):  # the box's sample is deposited with the first chunk
        hi = min(lo + chunk, len(recs))
        boxes += problem.box_observables(values[lo:hi], labels=[r.index for r in recs[lo:hi]])
        partial.write_text(json.dumps(done))
        print(f"boxes {len(boxes)}/{len(recs)}: {time.perf_counter() - t0:.1f} s", flush=True)
    new = Archive(old.gene_names, problem.simulation_key())
    new.n_batches = old.n_batches
    for r, res in zip(recs, boxes, strict=True):
        obs = {**r.observables, **res}
        errs = problem.errors(obs)
        new.add(Record(**{**asdict(r), "observables": obs, "errors": errs, "fitness": problem.fitness_of(errs)}))
    new.save(out / "archive.json")
    rows, lines = report.soil_tradeoff(problem, new.records)
    best = new.best()
    (out / "tradeoff.md").write_text(
        f"Shear box at {args.stresses} kPa ({problem.box_scale} scale), {len(recs)} individuals of {args.archive}\n\n"
        f"Best: index {best.index}, genes {best.genes}, observables {best.observables}, fitness {best.fitness:.4g}; "
        f"accepted: {sum(problem.accepted(r.errors) for r in new.records)}\n\n"
        + report.markdown_table(rows) + "\n\n" + "\n".join(lines) + "\n")
    report.tradeoff_plot(problem, new.records, out / "tradeoff.png")
    if not args.report_only:
        (out / "rescore.json").write_text(json.dumps({
            "device": args.device, "stresses_kpa": args.stresses, "box_scale": problem.box_scale, "n": len(recs),
            "wall_s": time.perf_counter() - t0}, indent=1))
    print((out / "tradeoff.md").read_text())


if __name__ == "__main__":
    main()
