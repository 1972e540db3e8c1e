"""A small demonstration scene: a cohesive sphere bed deposited in a box, then cut by a moving blade.

It exercises the whole engine (meshes, cohesion on new contacts, rolling resistance, local damping during
deposition, a kinematic tool, the draught observer) in a size that runs in a minute or two on 2 CPU cores.
Particle sizes and material values are illustrative (loamy-sand-like, after Tamas and Bernon 2021: E = 10 MPa).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import warpdem as wd

from . import figures

SOIL = wd.Material(young=1e7, poisson=0.4, density=2700.0, friction_angle=30.0, normal_cohesion=5e3,
                   shear_cohesion=2.5e3, moment_law=True, eta_roll=0.1, eta_twist=0.1)
STEEL = wd.Material(young=1e9, poisson=0.3, density=7850.0, friction_angle=25.0)


def box_mesh(size: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """An open-top box [0, Lx] x [0, Ly] x [0, Lz]: floor and four walls, two triangles each. Returns (v, f)."""
    lx, ly, lz = size
    v = np.array([[0, 0, 0], [lx, 0, 0], [lx, ly, 0], [0, ly, 0], [0, 0, lz], [lx, 0, lz], [lx, ly, lz], [0, ly, lz]],
                 dtype=np.float64)
    quads = [(0, 1, 2, 3), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    f = [[a, b, c] for a, b, c, d in quads] + [[a, c, d] for a, b, c, d in quads]
    return v, np.array(f)


def loose_spheres(size: tuple[float, float, float], r_min: float, r_max: float, n: int, seed: int) -> tuple:
    """Random radii in [r_min, r_max] on a jittered lattice filling the box from the floor up (no overlaps)."""
    rng = np.random.default_rng(seed)
    pitch = 2.05 * r_max
    nx, ny = int(size[0] / pitch), int(size[1] / pitch)
    nz = int(np.ceil(n / (nx * ny)))
    ix, iy, iz = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    pts = (np.stack([ix, iy, iz], axis=-1).reshape(-1, 3)[:n] + 0.5) * pitch
    pts = pts[np.argsort(pts[:, 2], kind="stable")][:n]
    radii = rng.uniform(r_min, r_max, len(pts))
    pts += rng.uniform(-1, 1, pts.shape) * (pitch / 2 - radii[:, None]) * 0.9
    return pts, radii


def build(n_particles: int = 1000, seed: int = 0, r_min: float = 0.004, r_max: float = 0.006,
          box: tuple[float, float, float] = (0.24, 0.10, 0.12)) -> wd.ModelBuilder:
    """The demo scene before deposition: loose spheres (group "soil") in an open box (static mesh "box")."""
    b = wd.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_material("soil", SOIL)
    b.add_material("steel", STEEL)
    v, f = box_mesh(box)
    b.add_mesh("box", v, f, "steel")
    pos, rad = loose_spheres(box, r_min, r_max, n_particles, seed)
    b.add_spheres(pos, rad, "soil", group="soil")
    return b


def add_blade(b: wd.ModelBuilder, box: tuple[float, float, float], depth: float, speed: float) -> None:
    """A thin vertical blade (kinematic mesh "blade") across the box, moving along +x at ``speed`` [m/s], cutting
    to ``depth`` [m] below ``top`` (the bed's surface, given as box[2])."""
    x0, top = -0.001, box[2]  # just behind the left wall, so no sphere starts inside the blade
    y0, y1 = 0.01, box[1] - 0.01
    z0 = top - depth
    v = np.array([[x0, y0, z0], [x0, y1, z0], [x0, y1, top + 0.05], [x0, y0, top + 0.05]], dtype=np.float64)
    b.add_mesh("blade", v, np.array([[0, 1, 2], [0, 2, 3]]), "steel", kind="kinematic", velocity=(speed, 0.0, 0.0))


def write_report(out: Path, summary: dict, series: dict[str, np.ndarray], deposition: dict[str, np.ndarray],
                 speed: float, depth: float) -> Path:
    """The demo's report.md and demo_cut.png in ``out``: draught [N] against blade travel [m] with the averaging
    window (the second half of the cut) shaded, and the deposition's kinetic energy [J] against time [s]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from warpdem.files import write_text_atomic

    travel = np.asarray(series["time"]) * speed
    draught = np.asarray(series["draught_n"]).reshape(len(travel))
    half = len(travel) // 2
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6))
    a.plot(travel * 1000, draught, lw=0.8)
    a.axvspan(travel[half] * 1000, travel[-1] * 1000, color="0.9", label="averaged")
    a.axhline(summary["draught_mean_n"], color="C3", lw=1, label=f"mean {summary['draught_mean_n']:.2f} N")
    a.set(xlabel="blade travel [mm]", ylabel="draught [N]", title="cut")
    a.legend(fontsize=8)
    b.semilogy(deposition["time"], np.maximum(np.asarray(deposition["kinetic_energy"]).reshape(-1), 1e-12))
    b.set(xlabel="time [s]", ylabel="kinetic energy [J]", title="deposition")
    figures.save(fig, out / "demo_cut.png", 110)
    rel = summary["draught_sem_n"] / abs(summary["draught_mean_n"]) if summary["draught_mean_n"] else float("inf")
    meaning = (f"The draught's standard error is {100 * rel:.0f} % of its mean (from {summary['draught_n_eff']:.0f} "
               "effectively independent samples of the averaged half): ")
    meaning += ("the mean is well determined for this bed." if rel < 0.1 else
                "the cut is too short or the bed too small for a steady draught; a longer `--cut` or more "
                "`--particles` narrows it.")
    ke = np.asarray(deposition["kinetic_energy"]).reshape(-1)
    meaning += (f" The bed's kinetic energy when the cut began was {ke[-1]:.2g} J, {100 * ke[-1] / ke.max():.2g} % of "
                "its peak during deposition: a bed still settling adds its own motion to the draught (a longer "
                "`--deposit-time` settles it further).")
    text = (
        "# warpdem demo\n\n"
        f"{summary['particles']} spheres on `{summary['device']}`, dt = {summary['dt_s']:.3g} s, wall time "
        f"{summary['wall_time_s']:.1f} s. Configuration: `config.json`; values: `summary.json`; time series: "
        "`timeseries.npz` and `timeseries.csv`.\n\n"
        f"- bed height {summary['bed_height_m'] * 1000:.1f} mm, porosity {summary['porosity']:.3f}, coordination "
        f"number {summary['coordination_after_deposition']:.2f}\n"
        f"- blade {depth * 1000:.0f} mm deep at {speed} m/s: draught {summary['draught_mean_n']:.2f} ± "
        f"{summary['draught_sem_n']:.2f} N (standard error; standard deviation {summary['draught_std_n']:.2f} N) "
        "over the second half of the cut\n\n"
        f"{meaning}\n\n![cut](demo_cut.png)\n"
    )
    path = out / "report.md"
    write_text_atomic(path, text)
    return path
