"""The ``warpdem`` command.

    warpdem demo [--device cpu|cuda] [--particles N] [--out DIR]

``demo`` deposits a small cohesive sphere bed under gravity, then drags a blade through it, and writes a results
folder: config.json (parameters, versions, device, seed), timeseries.npz and .csv, summary.json and report.md.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np


def _progress(label: str) -> object:
    start = time.time()

    last = [-1]

    def show(done: int, total: int) -> None:
        frac = done / total
        if int(100 * frac) == last[0] and done != total:
            return
        last[0] = int(100 * frac)
        bar = "#" * int(30 * frac)
        sys.stderr.write(f"\r{label:<12} [{bar:<30}] {100 * frac:5.1f} %  {time.time() - start:6.1f} s")
        if done == total:
            sys.stderr.write("\n")
        sys.stderr.flush()

    return show


def _default_device() -> str:
    import warp as wp

    return "cuda" if wp.is_cuda_available() else "cpu"


def run_demo(args: argparse.Namespace) -> int:
    import warp as wp

    wp.config.quiet = True
    import warpdem as wd
    from scenes import demo

    device = args.device or _default_device()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    box = (0.24, 0.10, 0.12)
    config = {
        "command": "demo", "device": device, "particles": args.particles, "seed": args.seed, "box_m": box,
        "soil": demo.SOIL.__dict__, "tool": demo.STEEL.__dict__, "deposit_s": args.deposit_time,
        "blade_speed_m_s": args.speed, "blade_depth_m": args.depth, "cut_length_m": args.cut,
        "versions": {"warpdem": wd.__version__, "warp": wp.config.version, "numpy": np.__version__,
                     "python": platform.python_version()},
    }
    t0 = time.time()
    # 1. deposition with local damping, cohesion on every new contact
    b = demo.build(args.particles, args.seed, box=box)
    b.set_local_damping("soil", 0.3)
    model, state = b.finalize(device)
    dt = 0.3 * wd.pwave_timestep(model)
    sim = wd.Simulation(model, state, dt=dt, cohesion_on_new_contacts=True)
    steps = int(args.deposit_time / dt)
    dep = sim.run(steps, record_every=max(steps // 50, 1), observers={"kinetic_energy": wd.observers.kinetic_energy},
                  progress=_progress("deposition"))
    z = sim.sphere_pos.numpy()[:, 2]
    r = model.host["sphere_radius"]
    top = float(np.percentile(z + r, 95))
    solid = float(np.sum(4 / 3 * np.pi * r**3))
    porosity = 1 - solid / (box[0] * box[1] * top)
    coord = float(wd.observers.coordination_number("soil")(sim)[0])
    # 2. cut: the settled bodies continue in a scene with the blade added (contacts re-form, with cohesion)
    b2 = demo.build(args.particles, args.seed, box=box)
    demo.add_blade(b2, (box[0], box[1], top), args.depth, args.speed)
    model2, state2 = b2.finalize(device)
    for k in ("body_pos", "body_vel", "body_angvel", "body_quat", "body_angmom"):
        arr = getattr(state2, k).numpy()
        arr[: model.n_bodies] = getattr(state, k).numpy()
        getattr(state2, k).assign(arr)
    sim2 = wd.Simulation(model2, state2, dt=dt, cohesion_on_new_contacts=True)
    steps = int(args.cut / args.speed / dt)
    draught = wd.observers.mesh_wrench("blade", world=0)
    ts = sim2.run(steps, record_every=max(steps // 200, 1),
                  observers={"draught_n": lambda s: -draught(s)[0, 0], "kinetic_energy_j": wd.observers.kinetic_energy,
                             "coordination": wd.observers.coordination_number("soil")},
                  progress=_progress("cutting"))
    wall = time.time() - t0
    half = len(ts["time"]) // 2
    summary = {
        "particles": int(model.n_spheres), "dt_s": dt, "bed_height_m": top, "porosity": porosity,
        "coordination_after_deposition": coord, "draught_mean_n": float(np.mean(ts["draught_n"][half:])),
        "draught_std_n": float(np.std(ts["draught_n"][half:])), "wall_time_s": wall, "device": device,
        "particle_steps_per_s": model.n_spheres * (sim.state.step + sim2.state.step) / wall,
    }
    np.savez_compressed(out / "timeseries.npz", deposition_time=dep["time"],
                        deposition_kinetic_energy=dep["kinetic_energy"], **{k: v for k, v in ts.items()})
    cols = ["time", "draught_n", "kinetic_energy_j", "coordination"]
    np.savetxt(out / "timeseries.csv", np.column_stack([np.asarray(ts[c]).reshape(len(ts["time"]), -1)[:, 0]
                                                         for c in cols]), delimiter=",", header=",".join(cols))
    (out / "config.json").write_text(json.dumps(config, indent=2, default=str))
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    (out / "report.md").write_text(
        "# warpdem demo\n\n"
        f"{summary['particles']} spheres on `{device}`, dt = {dt:.3g} s, wall time {wall:.1f} s.\n\n"
        f"- bed height {top * 1000:.1f} mm, porosity {porosity:.3f}, coordination number {coord:.2f}\n"
        f"- blade {args.depth * 1000:.0f} mm deep at {args.speed} m/s: draught {summary['draught_mean_n']:.2f} "
        f"± {summary['draught_std_n']:.2f} N over the second half of the cut\n"
    )
    print(json.dumps(summary, indent=2))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="warpdem", description="DEM of soil-tool interaction on NVIDIA Warp")
    sub = parser.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="deposit a small cohesive bed and cut it with a blade")
    d.add_argument("--device", default=None, help="Warp device (default: cuda if available, else cpu)")
    d.add_argument("--particles", type=int, default=1500)
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--deposit-time", type=float, default=0.5, help="simulated deposition time [s]")
    d.add_argument("--speed", type=float, default=0.5, help="blade speed [m/s]")
    d.add_argument("--depth", type=float, default=0.03, help="cutting depth [m]")
    d.add_argument("--cut", type=float, default=0.06, help="cut length [m]")
    d.add_argument("--out", default="results/demo", help="results folder")
    args = parser.parse_args(argv)
    if args.command == "demo":
        return run_demo(args)
    return 2


if __name__ == "__main__":
    raise SystemExit(main())
