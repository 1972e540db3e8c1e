"""Compare warpdem's direct shear box with its Yade twin on the same consolidated sample; writes
benchmarks/yade/shear_box_twin_report.md.

Run from the repository root, after shear_box_twin_export.py and the Yade runs (shear_box_twin.py), e.g.:

    python benchmarks/yade/shear_box_twin_compare.py ci --seeds 1 2 3 4            # warpdem runs, then the report
    python benchmarks/yade/shear_box_twin_compare.py ci --seeds 1 2 3 4 --run none  # the report from the saved runs

warpdem is rebuilt from the spec with its own API (``build_from_spec``: the rig's triangles, the ballast sphere
carrying the plate, the soil particles at their consolidated places, at rest, fresh contacts, in
``scenes.shear_box.build``'s order and materials) and sheared by ``scenes.shear_box.shear_sample`` itself (the
same probe, record interval, displacement and force definitions as ``run_shear_boxes``), after
``sim.set_cohesion_now()``: the
contacts of the first step get bonds, as Yade's ``setCohesionNow`` gives them. Realization k > 0 displaces every
particle as a whole by RandomState(k).uniform(-1e-9, 1e-9, (n_particles, 3)) m (spec order), as the Yade script's
``--perturb 1e-9 --seed k``; realization 0 is the spec as is. One simulation per normal stress, one world per
realization. The runs are saved to ``shear_box_twin_warpdem_<scale>.npz``.

Two warpdem rigs: as ``scenes.shear_box.build`` makes it (one mesh per box half, floor, plate) and, with
``per_facet``, every rig triangle its own mesh (Yade's facets; saved to ``..._<scale>_facets.npz``). ``--run split``
runs the 20 kPa stress with only the walls or only the floor and plate split (``..._<scale>_split_w2.npz``).

Statistics (both engines the same code): peak shear stress = maximum of the interval means smoothed by
``scenes.shear_box.moving_average`` over the spec's ``smooth_width`` records (run_shear_boxes' rule); the normal
stress on the plane is the spec's (measured by warpdem after consolidation; the realizations differ by 1e-9 m).
Per realization a Mohr-Coulomb fit (``scenes.analysis.mohr_coulomb``) of its three peaks gives c_k, phi_k; the
ensemble's c and phi are the means over realizations and their standard errors the standard deviation over
realizations / sqrt(n). For comparison, the least-squares fit of all realizations' peaks pooled, with the standard
errors of intercept and slope from its residuals (phi's by the delta method).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

wp.config.quiet = True

import warpdem as wd  # noqa: E402
from scenes import shear_box as sbx  # noqa: E402
from scenes import analysis  # noqa: E402
from warpdem.observers import csr_entries  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))
import shear_box_twin_export as ex  # noqa: E402

EPS = 1e-9
ACTIVE, COHESIVE = 1, 2
COUNT_EVERY = 5
"""contacts are counted at every COUNT_EVERY-th record (as the Yade script does)."""


def load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as f:
        return {k: f[k] for k in f.files}


def shifts(spec: dict[str, np.ndarray], seed: int) -> np.ndarray:
    """Realization ``seed``'s per-particle displacement (shear_box_twin.py --perturb 1e-9 --seed seed); 0 for seed 0."""
    n = int(spec["n_particles"])
    return np.zeros((n, 3)) if seed == 0 else np.random.RandomState(seed).uniform(-EPS, EPS, (n, 3))


def spec_config(spec: dict[str, np.ndarray]) -> sbx.ShearBoxConfig:
    """The export's ShearBoxConfig, checked against the spec (the shear loop reads its rate, displacement, interval)."""
    cfg = ex.config_for(str(spec["scale"]))
    for k in ("box_side", "sample_height", "shear_rate", "shear_displacement", "record_every", "smoothing"):
        if getattr(cfg, k) != float(spec[k]):
            raise AssertionError(f"config {k} {getattr(cfg, k)} differs from the spec's {float(spec[k])}")
    return cfg


def material(spec: dict[str, np.ndarray], prefix: str, density: float | None = None) -> wd.Material:
    g = {k: spec[f"{prefix}_{k}"].item() for k in ("young", "poisson", "density", "normal_cohesion",
                                                   "shear_cohesion", "eta_roll", "eta_twist", "alpha_kr",
                                                   "alpha_ktw", "moment_law", "fragile", "cohesive")}
    if density is not None:
        g["density"] = density
    return wd.Material(friction_angle=float(spec[f"{prefix}_friction_angle_deg"]), **g)


def _unique(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    v, inv = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)  # faces keep their order
    return v, inv.reshape(-1, 3)


RIG = (("lower", "lower_tri", "box"), ("floor", "floor_tri", "platen"), ("upper", "upper_tri", "box"),
       ("plate", "plate_tri", "platen"))
"""the rig's meshes as scenes.shear_box.build adds them: name, spec key, material."""


def split(per_facet: bool | tuple[str, ...]) -> tuple[str, ...]:
    """The rig meshes built one mesh per triangle: all (True), none (False) or those named."""
    return tuple(r[0] for r in RIG) if per_facet is True else () if per_facet is False else tuple(per_facet)


def mesh_names(spec: dict[str, np.ndarray], per_facet: bool | tuple[str, ...]) -> dict[str, list[str]]:
    """The warpdem mesh names of each rig mesh: itself, or (split) one mesh per triangle, the first keeping the
    name (and so the body's name)."""
    return {name: [name] + ([f"{name}_{k}" for k in range(1, len(spec[key]) if key != "plate_tri" else
                                                         spec[key].shape[1])] if name in split(per_facet) else [])
            for name, key, _ in RIG}


def build_from_spec(spec: dict[str, np.ndarray], world: int, seeds: list[int],
                    per_facet: bool | tuple[str, ...] = False) -> wd.Simulation:
    """Normal stress ``world`` of the spec as a warpdem simulation, one world per realization in ``seeds``: rig
    and materials as ``scenes.shear_box.build`` makes them (same order: lower half, floor, upper half, ballast and
    plate, then the soil), every body at rest, local damping 0 (the shear phase's), cohesion set for the first
    step. ``per_facet``: every rig triangle its own mesh (on the same bodies), as Yade's facets are: a sphere on the
    shared edge of two triangles then touches both (warpdem merges such contacts within one mesh); True for the whole
    rig, or a tuple of the rig meshes ("lower", "floor", "upper", "plate") to split."""
    b = wd.ModelBuilder(gravity=tuple(float(g) for g in spec["gravity"]))
    b.add_material("soil", material(spec, "soil"))
    b.add_material("box", material(spec, "box"))
    b.add_material("platen", material(spec, "platen"))
    b.add_material("ballast", material(spec, "ballast", float(spec["ballast_density_world"][world])))
    names = mesh_names(spec, per_facet)
    one = np.array([[0, 1, 2]])

    def add(name: str, key: str, mat: str, **kw: object) -> int:
        tri = spec[key][world] if key == "plate_tri" else spec[key]
        if name not in split(per_facet):
            return b.add_mesh(name, *_unique(tri), mat, **kw)
        body = b.add_mesh(name, tri[0], one, mat, **kw)
        for k in range(1, len(tri)):
            b.add_mesh(names[name][k], tri[k], one, mat, body=body)
        return body

    lower = add("lower", "lower_tri", "box", kind="kinematic")
    add("floor", "floor_tri", "platen", body=lower)
    add("upper", "upper_tri", "box", kind="static")
    ballast = b.add_sphere(tuple(spec["ballast_pos"][world]), float(spec["ballast_radius"]), "ballast",
                           group="plate", blocked="xyXYZ", name="ballast")
    add("plate", "plate_tri", "platen", body=ballast)
    part, rad, pos = spec["sphere_particle"], spec["sphere_radius"], spec["sphere_pos"][world]
    counts = np.bincount(part)
    single = counts[part] == 1
    assert np.all(np.diff(single.astype(int)) <= 0), "single spheres must come first (Bed.add_to's order)"
    if single.any():
        b.add_spheres(pos[single], rad[single], "soil", group="soil")
    b.add_clumps(pos[~single], rad[~single], counts[counts > 1], "soil", group="soil")
    b.set_local_damping("soil", float(spec["local_damping"]))
    b.set_local_damping("plate", float(spec["local_damping"]))
    model, state = b.finalize("cpu", n_worlds=len(seeds))
    soil = np.flatnonzero(model.host["body_group"][:model.bodies_per_world] == model.group_index("soil"))
    host = state.numpy()
    for j, k in enumerate(seeds):
        host["body_pos"][soil + j * model.bodies_per_world] += shifts(spec, k)
    state.body_pos.assign(host["body_pos"])
    sim = wd.Simulation(model, state, dt=float(spec["dt"]), always_use_moment_law=bool(spec["always_use_moment_law"]),
                        cohesion_on_new_contacts=bool(spec["set_cohesion_on_new_contacts"]),
                        unp_max=float(spec["unp_max"]))
    verify(sim, spec, world, seeds, per_facet)
    sim.set_cohesion_now()
    return sim


def verify(sim: wd.Simulation, spec: dict[str, np.ndarray], world: int, seeds: list[int],
           per_facet: bool | tuple[str, ...] = False) -> dict[str, float]:
    """Max differences between the rebuilt scene and the spec (sphere centres from the bodies' poses and the
    float32 member offsets, radii, triangles, plate mass, dt); raises past round-off."""
    m, h = sim.model, sim.model.host
    st = sim.state.numpy()
    spw = m.spheres_per_world
    soil_sph = np.flatnonzero(np.isin(h["sphere_body"][:spw], np.flatnonzero(
        h["body_group"][:m.bodies_per_world] == m.group_index("soil"))))
    out = {"sphere_pos": 0.0, "tri": 0.0}
    off = m.sphere_offset.numpy().astype(np.float64)
    for j, k in enumerate(seeds):
        s = soil_sph + j * spw
        bb = h["sphere_body"][s]
        p = st["body_pos"][bb] + ex.quat_rotate(st["body_quat"][bb], off[s])
        want = spec["sphere_pos"][world] + shifts(spec, k)[spec["sphere_particle"]]
        out["sphere_pos"] = max(out["sphere_pos"], float(np.abs(p - want).max()))
    for name, key, _ in RIG:
        tri = []
        for mesh in mesh_names(spec, per_facet)[name]:
            k = m.names["mesh"][mesh]
            body = int(h["mesh_body"][k])
            tri.append(h["mesh_vertices_local"][k][h["mesh_faces"][k]] + st["body_pos"][body])
        want = spec[key][world] if key == "plate_tri" else spec[key]
        out["tri"] = max(out["tri"], float(np.abs(np.concatenate(tri) - want).max()))
    out["radius"] = float(np.abs(h["sphere_radius"][soil_sph] - spec["sphere_radius"]).max())
    out["plate_mass"] = abs(float(h["body_mass"][m.body_index("ballast")]) / float(spec["plate_mass"][world]) - 1)
    out["dt"] = abs(sim.dt - float(spec["dt"]))
    tol = {"sphere_pos": 1e-8, "tri": 1e-15, "radius": 0.0, "plate_mass": 1e-12, "dt": 0.0}
    bad = {k: v for k, v in out.items() if v > tol[k]}
    if bad:
        raise AssertionError(f"the rebuilt scene differs from the spec: {bad}")
    return out


def contact_counts(sim: wd.Simulation) -> np.ndarray:
    """Per world: sphere-sphere contacts between different bodies, the bonded ones, sphere-triangle contacts
    (n_worlds, 3)."""
    m = sim.model
    sb, sw = m.host["sphere_body"], m.host["sphere_world"]
    ss = sim.contacts.ss.numpy()
    owner = np.repeat(np.arange(m.n_spheres), ss["count"])
    idx = csr_entries(ss["start"], ss["count"])
    fl = ss["hist"]["flags"][idx]
    other = ss["key_a"][idx]
    act = ((fl & ACTIVE) != 0) & (sb[owner] != sb[other])
    out = np.zeros((m.n_worlds, 3), np.int64)
    out[:, 0] = np.bincount(sw[owner[act]], minlength=m.n_worlds)
    out[:, 1] = np.bincount(sw[owner[act & ((fl & COHESIVE) != 0)]], minlength=m.n_worlds)
    st = sim.contacts.st.numpy()
    owner = np.repeat(np.arange(m.n_spheres), st["count"])
    idx = csr_entries(st["start"], st["count"])
    act = (st["hist"]["flags"][idx] & ACTIVE) != 0
    out[:, 2] = np.bincount(sw[owner[act]], minlength=m.n_worlds)
    return out


class FacetProbe(sbx._Probe):
    """``scenes.shear_box._Probe`` for a rig of one mesh per triangle: each rig mesh's force is the sum over its
    triangles' meshes."""

    def __init__(self, sim: wd.Simulation, names: dict[str, list[str]]) -> None:
        m = sim.model
        self.sim = sim
        self.groups = {k: np.arange(m.n_worlds)[:, None] * m.meshes_per_world
                       + np.array([m.names["mesh"][n] for n in names[k]])[None, :] for k in names}

    def advance_mean(self, n: int) -> dict[str, np.ndarray]:
        self.sim.data.mesh_force_sum.zero_()
        self.sim.advance(n)
        total = self.sim.data.mesh_force_sum.numpy().astype(np.float64)
        return {k: total[i].sum(axis=1) / n for k, i in self.groups.items()}


def first_step(spec: dict[str, np.ndarray], world: int, per_facet: bool | tuple[str, ...] = False) -> np.ndarray:
    """Contact counts after the first step (the bonds made), realization 0."""
    sim = build_from_spec(spec, world, [0], per_facet)
    sim.step()
    return contact_counts(sim)[0]


def run_world(spec: dict[str, np.ndarray], world: int, seeds: list[int], n_records: int | None = None,
              progress: bool = False, per_facet: bool | tuple[str, ...] = False) -> dict[str, np.ndarray]:
    """Shear normal stress ``world``, one warpdem world per realization; ``shear_sample``'s records (k, n_seeds) [N, m]
    and the contact counts at every COUNT_EVERY-th record."""
    cfg = spec_config(spec)
    if n_records is not None:
        cfg = cfg.replace(shear_displacement=n_records * cfg.record_every)
    sim = build_from_spec(spec, world, seeds, per_facet)
    probe = FacetProbe(sim, mesh_names(spec, per_facet)) if split(per_facet) else sbx._Probe(sim)
    counts: list[np.ndarray] = []
    t_start = time.perf_counter()

    def hook(_phase: str, done: float, total: float) -> None:
        k = len(counts) + 1
        counts.append(contact_counts(sim) if k % COUNT_EVERY == 0 else np.full((len(seeds), 3), -1))
        if progress and k % 15 == 0:
            print(f"    world {world}: {done:.4f} / {total:.4f} s simulated, {time.perf_counter() - t_start:.0f} s",
                  flush=True)

    t0 = time.perf_counter()
    rec = sbx.shear_sample(sim, probe, cfg, hook)
    wall = time.perf_counter() - t0
    expect = int(spec["n_records"]) if n_records is None else n_records
    if len(rec["disp"]) != expect or sim.state.step != expect * int(spec["interval"]):
        raise AssertionError(f"{len(rec['disp'])} records / {sim.state.step} steps, expected {expect} x "
                             f"{int(spec['interval'])}")
    return {"disp": rec["disp"], "upper": rec["upper"], "lower": rec["lower"], "rise": rec["rise"],
            "counts": np.array(counts), "wall_s": np.float64(wall), "seeds": np.array(seeds)}


# ------------------------------------------------------------------------------------------------ statistics
def peak(force: np.ndarray, spec: dict[str, np.ndarray]) -> tuple[float, int]:
    """Peak shear stress [Pa] of one curve of interval-mean forces [N] (run_shear_boxes' rule) and its record."""
    smooth = sbx.moving_average(np.asarray(force, float) / float(spec["box_side"]) ** 2, int(spec["smooth_width"]))
    i = int(np.argmax(smooth))
    return float(smooth[i]), i


def fits(peaks: np.ndarray, sigma: np.ndarray) -> dict[str, object]:
    """peaks (n_real, n_sigma) [Pa]: per-realization fits, their ensemble, and the pooled fit with residual SEs."""
    per = [analysis.mohr_coulomb(sigma, p) for p in peaks]
    c = np.array([f.cohesion for f in per])
    phi = np.array([f.friction_angle_deg for f in per])
    n = len(per)
    out: dict[str, object] = {"c_k": c, "phi_k": phi, "r2_k": np.array([f.r2 for f in per]), "n": n,
                              "c": float(c.mean()), "phi": float(phi.mean()),
                              "c_se": float(c.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan,
                              "phi_se": float(phi.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan}
    x = np.tile(sigma, n)
    y = peaks.reshape(-1)
    a = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    dof = len(y) - 2
    s2 = float(np.sum((y - a @ coef) ** 2) / dof) if dof > 0 else math.nan
    cov = s2 * np.linalg.inv(a.T @ a)
    slope = float(coef[1])
    out.update(pooled_c=float(coef[0]), pooled_phi=math.degrees(math.atan(slope)),
               pooled_c_se=math.sqrt(cov[0, 0]), pooled_phi_se=math.degrees(math.sqrt(cov[1, 1]) / (1 + slope**2)),
               pooled_dof=dof)
    return out


def engine_peaks(curves: dict[int, np.ndarray], spec: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """curves: world -> (k, n_real) interval-mean shear forces. Returns peaks (n_real, W) [Pa] and the peak
    displacements (n_real, W) [m]."""
    worlds = sorted(curves)
    n_real = curves[worlds[0]].shape[1]
    p = np.zeros((n_real, len(worlds)))
    d = np.zeros_like(p)
    for j, w in enumerate(worlds):
        for r in range(n_real):
            p[r, j], i = peak(curves[w][:, r], spec)
            d[r, j] = (i + 0.5) * float(spec["record_every"]) * float(spec["box_side"])
    return p, d


def load_yade(scale: str, worlds: list[int], seeds: list[int]) -> dict[str, object] | None:
    """The Yade runs (realization 0: no tag; k: tag _pk); None if any is missing."""
    curves, lower, rise, walls, step1, counts = {}, {}, {}, {}, {}, {}
    for w in worlds:
        cols, lows, rises, ws, cs = [], [], [], [], []
        for k in seeds:
            path = HERE / f"shear_box_twin_yade_{scale}_w{w}{'' if k == 0 else f'_p{k}'}.npz"
            if not path.exists():
                print(f"  missing {path.name}")
                return None
            y = load(path)
            cols.append(y["upper"])
            lows.append(y["lower"])
            rises.append(y["rise"])
            ws.append(float(y["wall_s"]))
            cs.append(np.stack([y["c_ss"], y["coh_ss"], y["c_sf"]], 1))
            if k == 0:
                step1[w] = np.array([int(y["step1_c_ss"]), int(y["step1_coh_ss"]), int(y["step1_c_sf"])])
        curves[w], lower[w], rise[w] = np.stack(cols, 1), np.stack(lows, 1), np.stack(rises, 1)
        walls[w], counts[w] = np.array(ws), np.stack(cs, 1)
    return {"upper": curves, "lower": lower, "rise": rise, "wall_s": walls, "step1": step1, "counts": counts}


# ------------------------------------------------------------------------------------------------ report
def fmt_pm(m: float, s: float, scale: float = 1.0, nd: int = 2) -> str:
    return f"{m * scale:.{nd}f} +- {s * scale:.{nd}f}"


def _ensemble_row(pk: np.ndarray, j: int) -> tuple[float, float]:
    n = pk.shape[0]
    return float(pk[:, j].mean()), float(pk[:, j].std(ddof=1) / math.sqrt(n))


def done_when(a: dict, b: dict) -> list[str]:
    """The done-when test of fit ``a`` against ``b``: c and phi within two combined SE, or 10 %."""
    out = []
    for key, unit, scale in (("c", "kPa", 1e-3), ("phi", "deg", 1.0)):
        d, se = a[key] - b[key], math.hypot(a[key + "_se"], b[key + "_se"])
        ok = abs(d) <= 2 * se or abs(d) <= 0.1 * abs(b[key])
        out.append(f"{key}: {d * scale:+.3f} {unit}, combined SE {se * scale:.3f} {unit} ({d / se:+.2f} SE; "
                   f"{100 * d / b[key]:+.1f} % of Yade's): **{'holds' if ok else 'fails'}**")
    return out


def _soil(spec: dict[str, np.ndarray]) -> str:
    """The sample's soil in words: GA set 11, or a calibration's soil (``export.SOIL_VARIANTS``)."""
    scale = str(spec["scale"])
    if scale not in ex.SOIL_VARIANTS:
        return f"GA set {int(spec['ga_set'])}"
    bonds = "fragile" if spec["soil_fragile"] else "yielding"
    return (f"the soil of `{ex.SOIL_VARIANTS[scale][1].relative_to(ex.ROOT)}` (contact friction "
            f"{float(spec['soil_friction_angle_deg']):.2f} deg, normal cohesion "
            f"{float(spec['soil_normal_cohesion']):.4g} Pa, eta {float(spec['soil_eta_roll']):.4g}, {bonds} bonds)")


def report(spec: dict[str, np.ndarray], variants: dict[str, dict], yade: dict | None, seeds: list[int]) -> str:
    """variants: name -> {"runs": world -> run_world output, "step1": world -> counts}."""
    scale = str(spec["scale"])
    first = next(iter(variants.values()))
    worlds = sorted(first["runs"])
    sigma = np.asarray(spec["normal_stress_plane"], float)[worlds]
    n = len(seeds)
    engines: dict[str, dict] = {}
    for name, v in variants.items():
        pk, dsp = engine_peaks({w: v["runs"][w]["upper"] for w in worlds}, spec)
        engines[name] = {"peaks": pk, "disp": dsp, "fit": fits(pk, sigma), "runs": v["runs"], "step1": v["step1"]}
    if yade is not None:
        pk, dsp = engine_peaks({w: yade["upper"][w] for w in worlds}, spec)
        engines["Yade"] = {"peaks": pk, "disp": dsp, "fit": fits(pk, sigma), "step1": yade["step1"],
                           "runs": {w: {"upper": yade["upper"][w], "lower": yade["lower"][w], "rise": yade["rise"][w],
                                        "counts": yade["counts"][w], "wall_s": yade["wall_s"][w]} for w in worlds}}
    rec_mm = 1e3 * float(spec["record_every"]) * float(spec["box_side"])
    lines = [
        f"# Direct shear box: warpdem against Yade 2023.02a on the same sample ({scale} scale)", "",
        "Generated by `benchmarks/yade/shear_box_twin_compare.py` (set-up and findings: `shear_box_twin_notes.md`). "
        f"Assembly C, {_soil(spec)}, {int(spec['n_particles'])} particles "
        f"({int(spec['n_clumps'])} three-sphere clumps), {int(spec['n_spheres'])} spheres, member radius "
        f"{1e3 * float(spec['ballast_radius']):.2f} mm +- 20 %, L = {1e3 * float(spec['box_side']):.0f} mm, "
        f"H = {1e3 * float(spec['sample_height']):.0f} mm, {1e3 * float(spec['shear_rate']):.0f} mm/s, "
        f"{1e3 * float(spec['shear_displacement']) * float(spec['box_side']):.0f} mm of shear "
        f"({int(spec['n_records'])} records of {int(spec['interval'])} steps, {rec_mm:.1f} mm), "
        f"dt = {float(spec['dt']):.6e} s. Realizations: {n} per engine and normal stress (0 = the spec as is; k = "
        "every particle shifted by <= 1e-9 m, seed k). Machine: 2-core CPU (AMD EPYC), warpdem on Warp's CPU "
        "backend, Yade 2023.02a with one thread.", "",
        "Engines: **warpdem** = the rig as `scenes.shear_box.build` makes it (one mesh per box half, floor, plate); "
        "**warpdem per facet** = the same with every rig triangle its own mesh (Yade's facets: a sphere on the edge "
        "shared by two triangles of one wall touches both); **Yade** = the twin (`shear_box_twin.py`).", "",
        "## Peak shear stress per normal stress [kPa]", "",
        "Ensemble mean +- SE over the realizations (SE = standard deviation / sqrt(n)); in brackets the difference "
        "from Yade in combined SE. Native = `run_shear_boxes` itself (the export's run: contact histories of the "
        "consolidation kept, one realization).", "",
        "| sigma applied | sigma on the plane | warpdem native | " + " | ".join(engines) + " |",
        "|---|---|---|" + "---|" * len(engines)]
    for j, w in enumerate(worlds):
        row = [f"{float(spec['normal_stress'][w]) / 1e3:.1f}", f"{sigma[j] / 1e3:.2f}",
               f"{float(spec['native_peak'][w]) / 1e3:.3f}"]
        for name, e in engines.items():
            m, se = _ensemble_row(e["peaks"], j)
            cell = fmt_pm(m, se, 1e-3, 3)
            if name != "Yade" and "Yade" in engines:
                ym, yse = _ensemble_row(engines["Yade"]["peaks"], j)
                cell += f" ({(m - ym) / math.hypot(se, yse):+.2f})"
            row.append(cell)
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "Every realization's peak [kPa] (where it is, mm of shear):", "", "```"]
    for j, w in enumerate(worlds):
        for i, (name, e) in enumerate(engines.items()):
            head = f"sigma {float(spec['normal_stress'][w]) / 1e3:4.1f} kPa" if i == 0 else " " * 14
            lines.append(f"{head}  {name:19s}" + " ".join(
                f"{p / 1e3:6.3f}({1e3 * d:4.1f})" for p, d in zip(e["peaks"][:, j], e["disp"][:, j], strict=True)))
    lines += ["```", "", "## Mohr-Coulomb cohesion and friction angle", "",
              "Ensemble: mean over the realizations of each realization's three-point fit, SE = standard deviation "
              "/ sqrt(n). Pooled: one least-squares fit of all realizations' peaks, SE from its residuals (the "
              "scatter about the line, not between realizations).", "",
              "| source | c [kPa] | phi [deg] | c pooled [kPa] | phi pooled [deg] |", "|---|---|---|---|---|",
              f"| warpdem native (`run_shear_boxes`, 1 realization) | {float(spec['native_cohesion']) / 1e3:.3f} | "
              f"{float(spec['native_phi']):.2f} | - | - |"]
    for name, e in engines.items():
        f = e["fit"]
        lines.append(f"| {name}, {f['n']} realizations | {fmt_pm(f['c'], f['c_se'], 1e-3, 3)} | "
                     f"{fmt_pm(f['phi'], f['phi_se'])} | {fmt_pm(f['pooled_c'], f['pooled_c_se'], 1e-3, 3)} | "
                     f"{fmt_pm(f['pooled_phi'], f['pooled_phi_se'])} |")
    ga = sbx.ga_set(int(spec["ga_set"]))
    c_lab, phi_lab = sbx.lab_strength()
    if scale not in ex.SOIL_VARIANTS:
        lines.append(f"| the paper's DEM, GA set {int(spec['ga_set'])} (Table 6; its own sample, size and box) | "
                     f"{float(ga['shear_box_cohesion_kpa']):.2f} | {float(ga['shear_box_friction_angle_deg']):.2f} | "
                     "- | - |")
    lines += [f"| laboratory, {sbx.LAB_MOISTURE} % d.b. (section 2.3) | {c_lab:.1f} | {phi_lab:.1f} | - | - |", ""]
    for name, e in engines.items():
        f = e["fit"]
        lines.append(f"- {name} per realization (c kPa, phi deg): " + ", ".join(
            f"({c / 1e3:.3f}, {p:.2f})" for c, p in zip(f["c_k"], f["phi_k"], strict=True)))
    if "Yade" in engines:
        lines += ["", "## Done-when: c and phi within two combined SE (or 10 %) of Yade's", ""]
        for name, e in engines.items():
            if name != "Yade":
                lines += [f"- {name}, {t}" for t in done_when(e["fit"], engines["Yade"]["fit"])]
    if "Yade" in engines:
        lines += ["", "## The first records (realization 0, before chaos separates the runs)", "",
                  "Largest relative difference from Yade's interval-mean shear force over the first 5 records "
                  f"({5 * rec_mm:.0f} mm) and over the first 25 ({25 * rec_mm:.0f} mm):", ""]
        for w in worlds:
            y = engines["Yade"]["runs"][w]["upper"][:, 0]
            parts = []
            for name, e in engines.items():
                if name != "Yade":
                    r = np.abs(e["runs"][w]["upper"][:, 0] / y - 1)
                    parts.append(f"{name} {r[:5].max():.1e}, {r[:25].max():.1e}")
            lines.append(f"- sigma {float(spec['normal_stress'][w]) / 1e3:.0f} kPa: " + "; ".join(parts))
    lines += ["", "## Contacts", "",
              "After the first step (the bonds made; realization 0): [sphere-sphere contacts between particles, "
              "bonded, soil-rig contacts]:", ""]
    for w in worlds:
        lines.append(f"- sigma {float(spec['normal_stress'][w]) / 1e3:.0f} kPa: " + "; ".join(
            f"{name} {np.asarray(e['step1'][w]).tolist()}" for name, e in engines.items()))
    lines += ["", "Bonds left (mean over the realizations) at 5, 10 and 15 mm of shear:", ""]
    for w in worlds:
        parts = []
        for name, e in engines.items():
            c = e["runs"][w]["counts"]
            ks = [min(int(round(x / rec_mm)) - 1, len(c) - 1) for x in (5.0, 10.0, 15.0)]
            parts.append(f"{name} " + ", ".join(f"{c[k, :, 1].mean():.0f}" for k in ks))
        lines.append(f"- sigma {float(spec['normal_stress'][w]) / 1e3:.0f} kPa: " + "; ".join(parts))
    lines += ["", "## Balance, dilation, wall times", ""]
    for w in worlds:
        parts = []
        for name, e in engines.items():
            r = e["runs"][w]
            bal = float(r["lower"][-20:].mean() / r["upper"][-20:].mean())
            wall = np.asarray(r["wall_s"], float)
            t = (f"{float(wall.mean()):.0f} s per run, 1 thread" if name == "Yade" else
                 f"{float(wall):.0f} s for {n} worlds, 2 threads")
            parts.append(f"{name}: lower/upper {bal:.3f}, rise {1e3 * float(r['rise'][-1].mean()):.2f} mm, {t}")
        lines.append(f"- sigma {float(spec['normal_stress'][w]) / 1e3:.0f} kPa: " + "; ".join(parts))
    lines += ["", "(lower/upper: the soil's x force on the lower half over that on the upper half and plate, last 20 "
              "records; rise: plate rise at 15 mm, mean over the realizations.)", "",
              f"warpdem native run (export): consolidation {float(spec['consolidation_time']):.3f} s simulated "
              f"({int(spec['consolidation_steps'])} steps), `run_shear_boxes` {float(spec['native_run_s']):.0f} s "
              f"for the 3 worlds (consolidation and shear), deposition {float(spec['bed_wall_s']):.0f} s.", ""]
    return "\n".join(lines)


SPLIT_WORLD = 2
"""the normal stress of the split diagnostic (20 kPa: the largest difference)."""
SPLITS = (("walls", ("lower", "upper")), ("floor and plate", ("floor", "plate")))
"""the split diagnostic's variants: which rig meshes are built one mesh per triangle."""


def split_path(scale: str) -> Path:
    return HERE / f"shear_box_twin_warpdem_{scale}_split_w{SPLIT_WORLD}.npz"


def run_split(spec: dict[str, np.ndarray], seeds: list[int]) -> None:
    """Normal stress SPLIT_WORLD with only some rig meshes split per triangle (SPLITS); saved to split_path."""
    out = {"seeds": np.array(seeds)}
    for name, pf in SPLITS:
        key = name.replace(" ", "_")
        out[f"{key}_step1"] = first_step(spec, SPLIT_WORLD, pf)
        r = run_world(spec, SPLIT_WORLD, seeds, per_facet=pf)
        out[f"{key}_upper"], out[f"{key}_wall_s"] = r["upper"], r["wall_s"]
        print(f"  split {name}: step 1 {out[f'{key}_step1'].tolist()}, {float(r['wall_s']):.0f} s", flush=True)
    np.savez_compressed(split_path(str(spec["scale"])), **out)


def split_section(spec: dict[str, np.ndarray], d: dict[str, np.ndarray], variants: dict[str, dict], yade: dict,
                  seeds: list[int]) -> str:
    """The split diagnostic beside the full variants, at SPLIT_WORLD."""
    w = SPLIT_WORLD
    if [int(k) for k in d["seeds"]] != seeds:
        return ""

    def stat(curves: np.ndarray) -> str:
        pk = np.array([peak(curves[:, r], spec)[0] for r in range(curves.shape[1])])
        return fmt_pm(pk.mean(), pk.std(ddof=1) / math.sqrt(len(pk)), 1e-3, 3)

    rows = [(name, v["step1"][w][2], stat(v["runs"][w]["upper"])) for name, v in variants.items()]
    rows[1:1] = [(f"warpdem, {name} split per triangle", d[f"{name.replace(' ', '_')}_step1"][2],
                  stat(d[f"{name.replace(' ', '_')}_upper"])) for name, _ in SPLITS]
    rows.append(("Yade", yade["step1"][w][2], stat(yade["upper"][w])))
    lines = ["", f"## Which double contacts ({float(spec['normal_stress'][w]) / 1e3:.0f} kPa)", "",
             "The rig with only some meshes split into one mesh per triangle (the others as built):", "",
             "| rig | soil-rig contacts after step 1 | peak [kPa] |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    return "\n".join(lines) + "\n"


def saved_path(scale: str, per_facet: bool) -> Path:
    return HERE / f"shear_box_twin_warpdem_{scale}{'_facets' if per_facet else ''}.npz"


def load_saved(scale: str, worlds: list[int], seeds: list[int], per_facet: bool) -> dict | None:
    path = saved_path(scale, per_facet)
    if not path.exists():
        return None
    d = load(path)
    runs, step1 = {}, {}
    for w in worlds:
        have = [int(k) for k in d[f"w{w}_seeds"]]
        if any(k not in have for k in seeds):
            return None
        keep = [have.index(k) for k in seeds]
        runs[w] = {k: d[f"w{w}_{k}"][:, keep] for k in ("upper", "lower", "rise", "counts")}
        runs[w]["disp"] = d[f"w{w}_disp"][:, keep]
        runs[w]["wall_s"] = d[f"w{w}_wall_s"]
        step1[w] = d[f"w{w}_step1"]
    return {"runs": runs, "step1": step1}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("scale", nargs="?", default="ci")
    ap.add_argument("--seeds", type=int, nargs="*", default=[])
    ap.add_argument("--run", choices=("both", "warpdem", "per-facet", "split", "none"), default="both",
                    help="which warpdem variants to run now (the others are read from their saved runs): the rig as "
                         "scenes.shear_box builds it, one mesh per rig triangle, both, or none (the report only); "
                         "split: the diagnostic of SPLIT_WORLD with only the walls or only the floor and plate split")
    a = ap.parse_args()
    spec = load(ex.spec_path(a.scale))
    seeds = [0] + [k for k in a.seeds if k != 0]
    worlds = list(range(len(spec["normal_stress"])))
    variants: dict[str, dict] = {}
    for per_facet, name in ((False, "warpdem"), (True, "warpdem per facet")):
        if a.run not in ("both", "per-facet" if per_facet else "warpdem"):
            v = load_saved(a.scale, worlds, seeds, per_facet)
            if v is not None:
                variants[name] = v
            continue
        runs, step1 = {}, {}
        for w in worlds:
            t0 = time.perf_counter()
            step1[w] = first_step(spec, w, per_facet)
            runs[w] = run_world(spec, w, seeds, progress=True, per_facet=per_facet)
            print(f"  {name} world {w}: {len(seeds)} realizations in {time.perf_counter() - t0:.0f} s; step 1 "
                  f"{step1[w].tolist()}", flush=True)
        out = {}
        for w in worlds:
            out.update({f"w{w}_{k}": v for k, v in runs[w].items()})
            out[f"w{w}_step1"] = step1[w]
        np.savez_compressed(saved_path(a.scale, per_facet), **out)
        variants[name] = {"runs": runs, "step1": step1}
    if a.run == "split":
        run_split(spec, seeds)
    yade = load_yade(a.scale, worlds, seeds)
    text = report(spec, variants, yade, seeds)
    path = split_path(a.scale)
    if path.exists() and yade is not None:
        text += split_section(spec, load(path), variants, yade, seeds)
    path = HERE / ("shear_box_twin_report.md" if a.scale == "ci" else f"shear_box_twin_report_{a.scale}.md")
    path.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
