"""Calibration throughput: one GA population evaluated as one batched simulation vs one individual at a time.

    python benchmarks/calibration_batch.py --device cpu  --problems ringing-linear draught-ci --population 20
    python benchmarks/calibration_batch.py --device cuda --problems ringing-paper draught-cpu --population 20

Problems (their full rigs, as ``warpdem calibrate`` runs them):

- ``ringing-paper``: the ringing rig of 16 springs with the paper's spring spheres (genes E, local damping), its full
  procedure (0.25 s settling, 2 s of ringing) at the fixed step of the stiffest allowed spring (E = 5e8 Pa); the
  paper reports ~1 h per such simulation in Yade;
- ``ringing-linear``: the same with the linear spring-dashpot (genes k, damping ratio);
- ``draught-<scale>``: the rigid sweep through a deposited assembly-C bed at that soil-bin scale (``ci``, ``cpu``,
  ``paper``), 0.62 m/s (genes friction angle, cohesion, eta); the paper reports ~4 h per simulation.

The population is drawn uniformly in the GA's coordinates (seeded). "batch" times one ``evaluate`` of the whole
population (one simulation, one world per individual); "sequential" times ``evaluate`` of each individual alone,
one after another (``--sequential N`` times only the first N and extrapolates, said in the output). Bed deposition
and kernel compilation are done before timing. Each line of ``--out`` (JSON lines) is one measurement.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

PAPER_HOURS = {"ringing": 1.0, "draught": 4.0}
"""the paper's wall time per simulation (section 2.2): ringing ~1 h, soil ~4 h."""


def make(name: str, device: str):  # noqa: ANN201
    from calibration.problems import DraughtProblem, RingingProblem

    if name == "ringing-paper":
        return RingingProblem(springs=16, spring_model="paper", device=device)
    if name == "ringing-linear":
        return RingingProblem(springs=16, spring_model="linear", device=device)
    if name.startswith("draught-"):
        return DraughtProblem(assembly="C", scale=name.split("-", 1)[1], device=device,
                              cache_dir=str(Path("results") / "beds"))
    raise SystemExit(f"unknown problem {name!r}")


def population(problem, n: int, seed: int) -> np.ndarray:  # noqa: ANN001
    rng = np.random.default_rng(seed)
    cols = []
    for g in problem.gene_list:
        lo, hi = g.ga_range
        cols.append(g.from_ga(rng.uniform(lo, hi, n)))
    return np.stack(cols, axis=1)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--problems", nargs="+", default=["ringing-linear", "draught-ci"])
    ap.add_argument("--population", type=int, default=20)
    ap.add_argument("--sequential", type=int, default=None, help="time only this many sequential runs")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=None, help="append JSON lines here")
    args = ap.parse_args()
    import warp as wp

    wp.config.quiet = True
    wp.init()
    dev = wp.get_device(args.device)
    for name in args.problems:
        p = make(name, args.device)
        kind = "ringing" if name.startswith("ringing") else "draught"
        pop = population(p, args.population, args.seed)
        if kind == "draught":
            p.bed()  # deposition, not timed
        p.evaluate(pop[:1])  # compile kernels, not timed
        t = time.perf_counter()
        batch = p.evaluate(pop)
        t_batch = time.perf_counter() - t
        n_seq = min(args.sequential or args.population, args.population)
        t = time.perf_counter()
        seq = [p.evaluate(pop[k:k + 1])[0] for k in range(n_seq)]
        t_seq = (time.perf_counter() - t) * args.population / n_seq
        same = all(np.allclose([b[k] for k in b], [s[k] for k in b], rtol=1e-5, equal_nan=True)
                   for b, s in zip(batch, seq, strict=False))
        row = {"problem": name, "device": args.device, "device_name": dev.name, "population": args.population,
               "batch_s": t_batch, "sequential_s": t_seq, "sequential_timed": n_seq, "speedup": t_seq / t_batch,
               "sims_per_hour_batch": 3600 * args.population / t_batch,
               "sims_per_hour_sequential": 3600 * args.population / t_seq,
               "paper_sims_per_hour": 1.0 / PAPER_HOURS[kind],
               "vs_paper_batch": 3600 * args.population / t_batch * PAPER_HOURS[kind],
               "batch_equals_sequential": bool(same), "python": platform.python_version(),
               "warp": wp.config.version, "date": time.strftime("%Y-%m-%d")}
        if kind == "draught":
            row["particles_per_world"] = int(p.bed().n_particles)
        print(json.dumps(row), flush=True)
        if args.out:
            with open(args.out, "a") as f:
                f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
