"""Compare draught calibrations of one population run in different ways (one GPU in process, Ray workers on one or
several GPUs): wall times, GPU utilisation of each GPU during each run, and whether every individual's observables
are the same bits.

    python benchmarks/ray_compare.py RUNS_DIR [--util util.csv --marks marks.txt]

RUNS_DIR holds one calibration folder per run (``warpdem calibrate draught --out RUNS_DIR/<name>``); the first folder
in name order is the reference. ``util.csv``: ``nvidia-smi --query-gpu=timestamp,index,utilization.gpu,memory.used
--format=csv,noheader,nounits -lms 500``; ``marks.txt``: lines ``<unix time> <name>_start|<name>_end``
(benchmarks/ray_gpus.sh writes both).
"""

from __future__ import annotations

import argparse
import json
from datetime import datetime
from pathlib import Path

import numpy as np


def load_run(folder: Path) -> dict[str, object]:
    """result.json and the archive's observables by genes (key: the genes' float64 values as hex)."""
    result = json.loads((folder / "result.json").read_text())
    archive = json.loads((folder / "archive.json").read_text())
    obs = {tuple(float(v).hex() for v in r["genes"].values()): r["observables"] for r in archive["records"]}
    return {"result": result, "observables": obs}


def gpu_utilisation(util_csv: Path, marks: Path) -> dict[str, dict[int, tuple[float, float, float]]]:
    """Per run (from the marks) and per GPU index: mean and max utilisation [%] and max memory used [MiB]."""
    times: dict[str, list[float]] = {}
    for line in marks.read_text().split("\n"):
        if line.strip():
            t, label = line.split()
            name, edge = label.rsplit("_", 1)
            times.setdefault(name, [0.0, 0.0])[0 if edge == "start" else 1] = float(t)
    rows = []
    for line in util_csv.read_text().split("\n"):
        parts = [p.strip() for p in line.split(",")]
        if len(parts) != 4:
            continue
        try:
            t = datetime.strptime(parts[0], "%Y/%m/%d %H:%M:%S.%f").timestamp()
            rows.append((t, int(parts[1]), float(parts[2]), float(parts[3])))
        except ValueError:
            continue
    a = np.array(rows) if rows else np.zeros((0, 4))
    out: dict[str, dict[int, tuple[float, float, float]]] = {}
    for name, (t0, t1) in times.items():
        sel = a[(a[:, 0] >= t0) & (a[:, 0] <= t1)]
        out[name] = {int(g): (float(sel[sel[:, 1] == g, 2].mean()), float(sel[sel[:, 1] == g, 2].max()),
                              float(sel[sel[:, 1] == g, 3].max()))
                     for g in np.unique(sel[:, 1])}
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", type=Path)
    ap.add_argument("--util", type=Path, default=None)
    ap.add_argument("--marks", type=Path, default=None)
    args = ap.parse_args()
    runs = {p.name: load_run(p) for p in sorted(args.runs.iterdir()) if (p / "result.json").exists()}
    if not runs:
        raise SystemExit(f"no calibration folders with result.json in {str(args.runs)!r}")
    util = gpu_utilisation(args.util, args.marks) if args.util and args.marks else {}
    ref_name, ref = next(iter(runs.items()))
    summary = {}
    for name, run in runs.items():
        res = run["result"]
        gens = [(h["stage"], h["generation"], h["simulated"], round(h["simulation_s"], 2)) for h in res["history"]]
        shared = set(run["observables"]) & set(ref["observables"])
        same = sum(run["observables"][k] == ref["observables"][k] for k in shared)
        worst = max((abs(run["observables"][k]["draught_mean_n"] - ref["observables"][k]["draught_mean_n"])
                     for k in shared), default=float("nan"))
        summary[name] = {"wall_s": res["wall_s"], "simulation_s": sum(g[3] for g in gens),
                         "n_simulated": res["n_simulated"], "generations": gens,
                         "workers": res.get("workers"), "best_draught_n": res["best"]["draught_mean_n"],
                         f"same_bits_as_{ref_name}": f"{same} of {len(shared)} shared individuals",
                         "max_abs_diff_draught_n": worst,
                         "gpu_utilisation": {str(g): {"mean_pct": u[0], "max_pct": u[1], "max_mem_mib": u[2]}
                                             for g, u in util.get(name, {}).items()}}
        print(f"{name}: wall {res['wall_s']:.1f} s, simulation {summary[name]['simulation_s']:.1f} s, "
              f"{res['n_simulated']} individuals; {summary[name][f'same_bits_as_{ref_name}']} the same bits as "
              f"{ref_name} (max |diff| {worst:.3g} N); GPU use "
              + ", ".join(f"GPU {g}: mean {u[0]:.0f} % max {u[1]:.0f} %, {u[2]:.0f} MiB"
                          for g, u in util.get(name, {}).items()))
    (args.runs / "comparison.json").write_text(json.dumps(summary, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
