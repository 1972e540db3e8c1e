"""Compare warpdem's rigid ci soil-bin run with its Yade twin; writes benchmarks/yade/soil_bin_twin_report.md.

Run from the repository root, after soil_bin_twin_export.py and soil_bin_twin.py (Yade), e.g.:

    python benchmarks/yade/soil_bin_twin_compare.py A C --seeds 1 2 3 4 5 6 7

``--seeds k ...``: extra realizations of the SAME bed: every particle displaced as a whole by
RandomState(k).uniform(-1e-9, 1e-9, (n_particles, 3)) m (spec order) in both engines. The Yade runs must exist
(``yade -n -x benchmarks/yade/soil_bin_twin.py X --perturb 1e-9 --seed k --tag _pk``); the warpdem runs are made here.

Three warpdem set-ups:

- ``run_soil_bin``: ``scenes.soil_bin.run_soil_bin`` itself (CPU), with the export's config and bed (a perturbed
  realization gets the bed with the shifted centres). A probe passed as its ``viewer`` hook (called with the
  Simulation before the first step, then at every record) checks that the scene it runs is the exported one
  (sphere centres, radii, particle grouping, triangles, dt, tool velocity) and counts the contacts in Yade's id
  space at every record, so both engines' coordination numbers come from the same formulas
  (soil_bin_twin_common.coordination).
- ``spec (one mesh per object)``: the scene rebuilt from the spec with warpdem's API (bin, tool lower half, tool upper
  half as one mesh each, like run_soil_bin): only its first step is used, to show the rebuild is run_soil_bin's.
- ``spec (one mesh per facet)``: the same rebuild with every triangle its own mesh (the bin's ten static, the
  tool's attached to one kinematic body), which is how Yade's facets behave: a sphere on the shared edge of two
  triangles gets a contact with each (warpdem merges contacts within one mesh, see warpdem/contacts.py). This is the
  diagnostic for the only first-step difference found (Yade's edge double contacts).

Statistics: ``scenes.analysis.steady_state`` over the records with travel >= the spec's steady_travel (mean and
standard error from the record's autocorrelation) for every run; the difference of two runs in units of the
combined standard error sqrt(se_1^2 + se_2^2); for ensembles of realizations, the mean of the run means with the
standard error from their spread (and, for comparison, from the runs' own SEs).
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
from scenes import soil_bin as sb  # noqa: E402
from scenes.assemblies import AssemblySpec, Bed  # noqa: E402
from scenes.sweep import build_sweep  # noqa: E402
from scenes import analysis  # noqa: E402
from warpdem.observers import csr_entries  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))
import soil_bin_twin_common as common  # noqa: E402
import soil_bin_twin_export as ex  # noqa: E402

ACTIVE, COHESIVE = 1, 2
EPS = 1e-9
ZKEYS = ("z_particle_ss", "z_sphere_ss", "z_particle_all", "z_sphere_all", "z_yade_default", "z_yade_clumps")


def load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as f:
        return {k: f[k] for k in f.files}


def shifts(spec: dict[str, np.ndarray], seed: int) -> np.ndarray:
    """The per-particle displacement of realization ``seed`` (as soil_bin_twin.py --perturb 1e-9 --seed seed)."""
    return np.random.RandomState(seed).uniform(-EPS, EPS, (int(spec["n_particles"]), 3))


# ------------------------------------------------------------------------------------------------ measuring
class Probe:
    """Counts a warpdem simulation's contacts in Yade's id space; as run_soil_bin's ``viewer`` hook it also checks
    the scene against the spec before the first step.

    ``facet_of_mesh``: mesh index -> (Yade facet id of each of its faces (nf,), object: 0 bin, 1 tool lower,
    2 tool upper).
    """

    def __init__(self, spec: dict[str, np.ndarray], perturbed: bool = False) -> None:
        self.spec = spec
        self.perturbed = perturbed
        self.tri = np.concatenate([spec["bin_tri"], spec["tool_lower_tri"], spec["tool_upper_tri"]])
        self.nf = len(self.tri)
        self.n_bin, self.n_low = len(spec["bin_tri"]), len(spec["tool_lower_tri"])
        self.layout = common.yade_layout(spec["sphere_particle"], self.nf)
        self.incentre0 = common.incentre(self.tri)
        self.records: list[dict[str, float]] = []
        self.check: dict[str, float] = {}

    def attach(self, sim: wd.Simulation, facet_of_mesh: dict[int, tuple[np.ndarray, int]], tool_body: int
               ) -> Probe:
        self.sim = sim
        self.facet_of_mesh = facet_of_mesh
        self.tool_body = tool_body
        self.pos0 = sim.state.body_pos.numpy()[tool_body].copy()
        self.first_soil = int(sim.model.host["sphere_body"].min())
        return self

    # -- viewer protocol (run_soil_bin)
    def __call__(self, sim: wd.Simulation) -> Probe:
        self.check = verify_scene(sim, self.spec, self.perturbed)
        n = sim.model.names["mesh"]
        nu = self.nf - self.n_bin - self.n_low
        fom = {n["bin"]: (np.arange(self.n_bin), 0), n["sweep_lower"]: (self.n_bin + np.arange(self.n_low), 1),
               n["sweep_upper"]: (self.n_bin + self.n_low + np.arange(nu), 2)}
        return self.attach(sim, fom, sim.model.names["body"]["sweep_lower"])

    def as_observer(self, _observers: dict | None = None) -> object:
        def f(sim: wd.Simulation) -> np.ndarray:
            self.records.append(self.measure(sim))
            return np.zeros(1)

        return f

    def close(self) -> None:
        pass

    def contacts(self, sim: wd.Simulation) -> dict[str, np.ndarray]:
        """Active contacts in Yade's id space (facet = id1, as in Yade): id1, id2, cohesive, kind (0 ss, 1 sf),
        obj (object of the facet, -1 for ss)."""
        ns = sim.model.n_spheres
        sid = self.layout["sphere_id"]
        ss = sim.contacts.ss.numpy()
        owner = np.repeat(np.arange(ns), ss["count"])
        idx = csr_entries(ss["start"], ss["count"])
        fl = ss["hist"]["flags"][idx]
        act = (fl & ACTIVE) != 0
        i, j = owner[act], ss["key_a"][idx][act]
        coh_ss = (fl[act] & COHESIVE) != 0
        st = sim.contacts.st.numpy()
        owner = np.repeat(np.arange(ns), st["count"])
        idx = csr_entries(st["start"], st["count"])
        fl = st["hist"]["flags"][idx]
        act = (fl & ACTIVE) != 0
        si, mesh, face = owner[act], st["key_a"][idx][act], st["key_b"][idx][act]
        fid = np.array([self.facet_of_mesh[int(k)][0][f] for k, f in zip(mesh, face, strict=True)], np.int64)
        obj = np.array([self.facet_of_mesh[int(k)][1] for k in mesh], np.int64)
        return {"id1": np.r_[sid[i], fid], "id2": np.r_[sid[j], sid[si]],
                "cohesive": np.r_[coh_ss, (fl[act] & COHESIVE) != 0],
                "kind": np.r_[np.zeros(len(i), int), np.ones(len(si), int)], "obj": np.r_[np.full(len(i), -1), obj]}

    def measure(self, sim: wd.Simulation) -> dict[str, float]:
        c = self.contacts(sim)
        st = sim.state.numpy()
        disp = st["body_pos"][self.tool_body] - self.pos0
        body_pos = np.zeros((int(self.layout["n_bodies"]), 3))
        body_pos[:self.nf] = self.incentre0 + np.where(np.arange(self.nf)[:, None] >= self.n_bin, disp, 0.0)
        body_pos[self.layout["sphere_id"]] = sim.data.sphere_pos.numpy()
        clumps = np.flatnonzero(self.layout["is_clump"])
        body_pos[self.layout["particle_id"][clumps]] = st["body_pos"][self.first_soil + clumps]
        z = common.coordination(c["id1"], c["id2"], body_pos, self.layout, self.spec["sphere_radius"], self.nf)
        sf = c["kind"] == 1
        out = {"step": sim.state.step, "tool_disp_y": float(disp[1]), "c_ss": z["c_ss"], "c_sf": z["c_sf"],
               "c_sf_bin": int((c["obj"] == 0).sum()), "c_sf_lower": int((c["obj"] == 1).sum()),
               "c_sf_upper": int((c["obj"] == 2).sum()), "coh_ss": int((c["cohesive"] & ~sf).sum()),
               "coh_sf": int((c["cohesive"] & sf).sum())}
        out.update({k: z[k] for k in ZKEYS})
        return out


def verify_scene(sim: wd.Simulation, spec: dict[str, np.ndarray], perturbed: bool) -> dict[str, float]:
    """Max differences between the scene run_soil_bin runs and the spec (0 up to float64 round-off)."""
    m = sim.model
    h = m.host
    out = {
        "sphere_pos": float(np.abs(sim.data.sphere_pos.numpy() - spec["sphere_pos"]).max()),
        "sphere_radius": float(np.abs(h["sphere_radius"] - spec["sphere_radius"]).max()),
        "dt": abs(sim.dt - float(spec["dt"])),
        "particle_grouping": float(np.any(h["sphere_body"] - h["sphere_body"].min() != spec["sphere_particle"])),
        "law_flags": float(sim.always_use_moment_law != bool(spec["always_use_moment_law"])
                           or sim.cohesion_on_new_contacts != bool(spec["set_cohesion_on_new_contacts"])
                           or sim.options.unp_max != float(spec["unp_max"])),
        "local_damping": float(np.abs(m.group_damping.numpy()).max()),
    }
    st = sim.state.numpy()
    tb = m.names["body"]["sweep_lower"]
    out["tool_velocity"] = float(np.abs(st["body_vel"][tb] - spec["tool_velocity"]).max())
    for name, key in (("bin", "bin_tri"), ("sweep_lower", "tool_lower_tri"), ("sweep_upper", "tool_upper_tri")):
        k = m.names["mesh"][name]
        world = h["mesh_vertices_local"][k][h["mesh_faces"][k]] + st["body_pos"][h["mesh_body"][k]]  # identity quats
        out[f"tri_{name}"] = float(np.abs(world - spec[key]).max())
    # a perturbed bed (shifts <= 1e-9 m) moves the tool with the bed's surface by ~1e-10 m (place_tool)
    tol_p = 2 * EPS if perturbed else 1e-15
    tol = {"sphere_pos": tol_p, "sphere_radius": 0.0, "dt": 0.0, "particle_grouping": 0.0, "law_flags": 0.0,
           "local_damping": float(spec["local_damping"]), "tool_velocity": 0.0,
           "tri_bin": 1e-15, "tri_sweep_lower": tol_p, "tri_sweep_upper": tol_p}
    bad = {k: v for k, v in out.items() if v > tol[k]}
    if bad:
        raise AssertionError(f"run_soil_bin's scene differs from the spec: {bad}")
    return out


# ------------------------------------------------------------------------------------------------ warpdem runs
def steady(t: np.ndarray, x: np.ndarray, spec: dict[str, np.ndarray]) -> analysis.SteadyState:
    trav = np.minimum(t * float(spec["speed"]), float(spec["travel"]))
    return analysis.steady_state(t, x, trav, start_travel=float(spec["steady_travel"]))


def spec_bed_and_tool(assembly: str, spec: dict[str, np.ndarray], seed: int | None = None
                      ) -> tuple[Bed, sb.SweepTool]:
    """The export's scene as run_soil_bin's inputs, read from the spec alone (a deposition repeated on another CPU
    or Warp build is another bed: chaotic dynamics amplify last-bit differences): the kept particles' bed centres
    in the export's order, and the sweep moved to the exported tip. ``seed``: the bed with realization ``seed``'s
    shifts."""
    config = ex.config_for(assembly)
    centres = np.array(spec["sphere_pos_bed"], dtype=np.float64)
    if seed is not None:
        centres += shifts(spec, seed)[spec["sphere_particle"]]
    bed = Bed(AssemblySpec(kind=assembly, radius=config.preset["radius"]), tuple(spec["bin_size"]),
              float(spec["bed_depth"]), centres, np.array(spec["sphere_radius"]),
              np.array(spec["sphere_particle"]), float(spec["bed_porosity"]), float(spec["bed_coordination"]),
              int(spec["seed"]))
    tool = build_sweep()
    return bed, tool.moved(np.asarray(spec["tool_tip"]) - tool.tip)


def run_soil_bin_twin(assembly: str, spec: dict[str, np.ndarray], seed: int | None = None) -> dict:
    """run_soil_bin itself on the export's bed and tool (seed: the bed with realization ``seed``'s shifts)."""
    config = ex.config_for(assembly)
    bed, tool = spec_bed_and_tool(assembly, spec, seed)
    probe = Probe(spec, perturbed=seed is not None)
    t0 = time.perf_counter()
    run = sb.run_soil_bin(config, [0], bed=bed, device="cpu", viewer=probe, tool=tool, place=False)
    wall = time.perf_counter() - t0
    if run.n_particles != int(spec["n_particles"]):
        raise AssertionError(f"run has {run.n_particles} particles, spec {int(spec['n_particles'])}")
    recs = {k: np.array([r[k] for r in probe.records]) for k in probe.records[0]}
    if not np.array_equal(recs["step"], np.round(run.time / run.dt).astype(int)):
        raise AssertionError("probe records do not match run_soil_bin's records")
    st = steady(run.time, run.series["draught"][:, 0], spec)
    if not math.isclose(st.mean, run.steady[0]["draught_mean"], rel_tol=1e-12):
        raise AssertionError("steady-state mean differs from run_soil_bin's own")
    return {"time": run.time, "draught": run.series["draught"][:, 0], "recs": recs, "check": probe.check,
            "wall_s": wall, "steady": st, "coordination": run.series["coordination"][:, 0],
            "ke": run.series["ke_soil"][:, 0].sum(axis=-1), "row": run.steady[0]}


def build_from_spec(spec: dict[str, np.ndarray], per_facet: bool | tuple[bool, bool], seed: int | None = None,
                    tool_velocity: object | None = None) -> tuple[wd.Simulation, Probe, list[int]]:
    """The exported scene rebuilt with warpdem's API. per_facet: every triangle its own mesh (Yade's facets), for
    (bin, tool) separately if a pair. tool_velocity: instead of the spec's (e.g. 0: the bed alone).
    Returns the simulation (cohesion set for the first step), its probe and the lower half's mesh indices."""
    def mat(prefix: str) -> wd.Material:
        g = {k: spec[f"{prefix}_{k}"].item() for k in ("young", "poisson", "density", "normal_cohesion",
                                                       "shear_cohesion", "eta_roll", "eta_twist", "alpha_kr",
                                                       "alpha_ktw", "moment_law", "fragile", "cohesive")}
        return wd.Material(friction_angle=float(spec[f"{prefix}_friction_angle_deg"]), **g)

    def unique(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # np.unique reorders vertices, not faces: face k is still triangle k
        v, inv = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)
        return v, inv.reshape(-1, 3)

    bin_pf, tool_pf = (per_facet, per_facet) if isinstance(per_facet, bool) else per_facet
    # bin_pf: True (every bin triangle its own mesh), False (one mesh), or the indices of the triangles that get
    # their own mesh (the others stay one mesh)
    split = set(range(len(spec["bin_tri"]))) if bin_pf is True else set() if bin_pf is False else set(bin_pf)
    b = wd.ModelBuilder(gravity=tuple(float(g) for g in spec["gravity"]))
    b.add_material("soil", mat("soil"))
    b.add_material("tool", mat("tool"))
    bin_tri, low, up = spec["bin_tri"], spec["tool_lower_tri"], spec["tool_upper_tri"]
    vel = tuple(float(v) for v in (spec["tool_velocity"] if tool_velocity is None else tool_velocity))
    tri_faces = np.array([[0, 1, 2]])
    nb_, nl = len(bin_tri), len(low)
    fom_names: dict[str, tuple[np.ndarray, int]] = {}
    rest = [k for k in range(nb_) if k not in split]
    if rest:  # the unsplit triangles as one mesh, faces in spec order (its face j is bin triangle rest[j])
        b.add_mesh("bin", *unique(bin_tri[rest]), "tool")
    for k in sorted(split):
        b.add_mesh(f"bin{k}", bin_tri[k], tri_faces, "tool")
        fom_names[f"bin{k}"] = (np.array([k]), 0)
    if tool_pf:
        body = b.add_mesh("lower0", low[0], tri_faces, "tool", kind="kinematic", velocity=vel, group="tool")
        for k in range(1, nl):
            b.add_mesh(f"lower{k}", low[k], tri_faces, "tool", body=body)
        for k, t in enumerate(up):
            b.add_mesh(f"upper{k}", t, tri_faces, "tool", body=body)
        fom_names.update({f"lower{k}": (np.array([nb_ + k]), 1) for k in range(nl)})
        fom_names.update({f"upper{k}": (np.array([nb_ + nl + k]), 2) for k in range(len(up))})
        lower_names = [f"lower{k}" for k in range(nl)]
    else:
        body = b.add_mesh("sweep_lower", *unique(low), "tool", kind="kinematic", velocity=vel, group="tool")
        b.add_mesh("sweep_upper", *unique(up), "tool", body=body)
        fom_names.update({"sweep_lower": (nb_ + np.arange(nl), 1),
                          "sweep_upper": (nb_ + nl + np.arange(len(up)), 2)})
        lower_names = ["sweep_lower"]
    pos = spec["sphere_pos"].copy()
    if seed is not None:
        pos += shifts(spec, seed)[spec["sphere_particle"]]
    part, rad = spec["sphere_particle"], spec["sphere_radius"]
    counts = np.bincount(part)
    single = counts[part] == 1
    assert np.all(np.diff(single.astype(int)) <= 0), "single spheres must come first (Bed.add_to's order)"
    b.add_spheres(pos[single], rad[single], "soil", group="soil")
    for p in np.flatnonzero(counts > 1):
        m = part == p
        b.add_clump(pos[m], rad[m], "soil", group="soil")
    model, state = b.finalize("cpu")
    sim = wd.Simulation(model, state, dt=float(spec["dt"]), always_use_moment_law=bool(spec["always_use_moment_law"]),
                        cohesion_on_new_contacts=bool(spec["set_cohesion_on_new_contacts"]),
                        unp_max=float(spec["unp_max"]), bounds=(spec["bounds_lo"], spec["bounds_hi"]))
    sim.set_cohesion_now()
    names = model.names["mesh"]
    if rest:
        fom_names["bin"] = (np.array(rest), 0)
    probe = Probe(spec).attach(sim, {names[k]: v for k, v in fom_names.items()}, body)
    return sim, probe, [names[k] for k in lower_names]


def run_spec(spec: dict[str, np.ndarray], per_facet: bool | tuple[bool, bool], seed: int | None = None,
             tool_velocity: object | None = None, n_steps: int | None = None) -> dict:
    sim, probe, lower = build_from_spec(spec, per_facet, seed, tool_velocity)
    every, n = int(spec["record_every"]), int(spec["n_steps"]) if n_steps is None else n_steps
    t0 = time.perf_counter()
    out = sim.run(n, record_every=every, observers={
        "draught": lambda s: -float(s.data.mesh_force.numpy()[lower, 1].sum()), "probe": probe.as_observer(),
        "ke": lambda s: float(wd.observers.group_kinetic_energy("soil")(s)[0].sum())})
    wall = time.perf_counter() - t0
    t = out["time"]
    recs = {k: np.array([r[k] for r in probe.records]) for k in probe.records[0]}
    return {"time": t, "draught": out["draught"], "recs": recs, "wall_s": wall, "ke": out["ke"],
            "steady": steady(t, out["draught"], spec) if n_steps is None else None}


def first_step(spec: dict[str, np.ndarray], assembly: str | None = None, per_facet: bool = False) -> dict:
    """One step after set_cohesion_now: run_soil_bin's scene (assembly given: soil_bin_twin_export.build, which is
    run_soil_bin's prologue) or the spec rebuild. Counts, per-body contact forces, draught."""
    if assembly is not None:
        s = ex.build(assembly)
        sim = s["sim"]
        probe = Probe(spec)(sim)
        sim.set_cohesion_now()
        lower = [sim.model.names["mesh"]["sweep_lower"]]
    else:
        sim, probe, lower = build_from_spec(spec, per_facet)
    sim.step()
    out = probe.measure(sim)
    out["body_force"] = sim.data.body_force.numpy().astype(np.float64)
    out["body_torque"] = sim.data.body_torque.numpy().astype(np.float64)
    out["draught"] = -float(sim.data.mesh_force.numpy()[lower, 1].sum())
    out["first_soil"] = probe.first_soil
    return out


# ------------------------------------------------------------------------------------------------ comparing
def force_check(w1: dict, y: dict, spec: dict, drop_yade_doubles: bool) -> dict[str, float]:
    """Step 1 contact force per particle: warpdem's body force vs the sum of Yade's member forces (optionally less
    the forces of Yade's interactions that warpdem's merging rule drops); torque of single spheres."""
    part = spec["sphere_particle"]
    n = int(spec["n_particles"])
    f_body = y["step1_body_force"].copy()
    if drop_yade_doubles:
        for k in np.flatnonzero(y["step1_wd_drop"]):  # facet = id1, sphere = id2: the sphere got +(Fn + Fs)
            f_body[y["step1_id2"][k]] -= y["step1_fn"][k] + y["step1_fs"][k]
    fy = np.zeros((n, 3))
    np.add.at(fy, part, f_body[y["sphere_id"]])
    fw = w1["body_force"][w1["first_soil"]:w1["first_soil"] + n]
    single = np.bincount(part, minlength=n) == 1
    ty = y["step1_body_torque"][y["particle_id"]]
    tw = w1["body_torque"][w1["first_soil"]:w1["first_soil"] + n]
    return {"f_max_diff": float(np.abs(fw - fy).max()), "f_scale": float(np.abs(fy).max()),
            "t_max_diff": float(np.abs(tw[single] - ty[single]).max()) if single.any() else 0.0,
            "worst_particle": int(np.argmax(np.abs(fw - fy).max(axis=1)))}


def steady_mean(x: np.ndarray, steps: np.ndarray, spec: dict) -> float:
    trav = np.minimum(steps * float(spec["dt"]) * float(spec["speed"]), float(spec["travel"]))
    return float(np.mean(np.asarray(x, float)[trav >= float(spec["steady_travel"])]))


def at_travel(x: np.ndarray, steps: np.ndarray, spec: dict, travel: float) -> float:
    trav = steps * float(spec["dt"]) * float(spec["speed"])
    return float(np.asarray(x, float)[np.argmin(np.abs(trav - travel))])


def ensemble(means: list[float], sems: list[float]) -> dict[str, float]:
    m, s = np.asarray(means), np.asarray(sems)
    spread = float(m.std(ddof=1) / math.sqrt(len(m))) if len(m) > 1 else math.nan
    within = float(math.sqrt(np.sum(s**2)) / len(m))
    return {"mean": float(m.mean()), "se_spread": spread, "se_runs": within, "n": len(m),
            "se": float(np.nanmax([spread, within])), "std_of_means": float(m.std(ddof=1)) if len(m) > 1 else 0.0}


def ztest(a: dict, b: dict) -> tuple[float, float, float]:
    d = a["mean"] - b["mean"]
    c = math.hypot(a["se"], b["se"])
    return d, c, d / c


VARIANTS = (("per facet (bin + tool)", (True, True)), ("per facet (bin only)", (True, False)),
            ("per facet (tool only)", (False, True)))
"""warpdem rebuilt from the spec with one mesh per triangle (Yade's facets) for the bin, the tool, or both."""
FLOOR = (0, 5)
"""the bin floor's two triangles (bin_mesh: floor quad first; first triangles of the five quads, then the second)."""
FLOOR_WALLS = (("per facet (floor only)", (FLOOR, False)),
               ("per facet (walls only)", ((1, 2, 3, 4, 6, 7, 8, 9), False)))


def bed_alone(spec: dict[str, np.ndarray]) -> dict:
    """The same scene with the tool at rest (spec rebuild, one mesh per object): does the bed keep its bonds? With
    warpdem's energy balance (kinetic, elastic, gravity, dissipation) at every record."""
    sim0, probe, _ = build_from_spec(spec, False, tool_velocity=(0.0, 0.0, 0.0))
    sim = wd.Simulation(sim0.model, sim0.state, dt=float(spec["dt"]),
                        always_use_moment_law=bool(spec["always_use_moment_law"]), track_energy=True,
                        bounds=(spec["bounds_lo"], spec["bounds_hi"]))
    sim.set_cohesion_now()
    probe.attach(sim, probe.facet_of_mesh, probe.tool_body)

    def energy(s: wd.Simulation) -> np.ndarray:
        e = wd.observers.energy_balance(s)
        return np.array([e[k][0] for k in ("kinetic", "contact_elastic", "gravity", "dissipated_sliding",
                                           "dissipated_rolling", "total")])

    out = sim.run(int(spec["n_steps"]), record_every=int(spec["record_every"]),
                  observers={"probe": probe.as_observer(), "energy": energy})
    recs = {k: np.array([r[k] for r in probe.records]) for k in probe.records[0]}
    return {"time": out["time"], "recs": recs, "energy": out["energy"], "ke": out["energy"][:, 0]}


def compare(assembly: str, seeds: list[int], variants: tuple = VARIANTS) -> tuple[list[str], dict]:
    spec = load(HERE / f"soil_bin_twin_spec_{assembly}.npz")
    assert np.all(spec["bin_tri"][list(FLOOR)][..., 2] == 0.0), "FLOOR must be the z = 0 triangles"
    y = load(HERE / f"soil_bin_twin_yade_{assembly}.npz")
    dt, speed = float(spec["dt"]), float(spec["speed"])
    print(f"[{assembly}] warpdem run_soil_bin ...", flush=True)
    w = run_soil_bin_twin(assembly, spec)
    w1 = first_step(spec, assembly)
    w1_spec = first_step(spec, per_facet=False)
    w1_facet = first_step(spec, per_facet=True)
    ys = steady(y["step"] * dt, y["draught"], spec)
    ws = w["steady"]
    # realizations: None = the exported bed as is, k = every particle shifted by seed k's displacement
    real: dict[str, dict] = {"warpdem run_soil_bin": {}, "Yade 2023.02a": {}}
    real.update({f"warpdem {name}": {} for name, _ in variants})
    for k in [None, *seeds]:
        print(f"[{assembly}] realization {k} ...", flush=True)
        if k is None:
            yy = y
        else:
            p = HERE / f"soil_bin_twin_yade_{assembly}_p{k}.npz"
            if not p.exists():
                raise FileNotFoundError(f"{p} (run: yade -n -x benchmarks/yade/soil_bin_twin.py {assembly} "
                                        f"--perturb 1e-9 --seed {k} --tag _p{k})")
            yy = load(p)
        real["Yade 2023.02a"][k] = {"steady": steady(yy["step"] * dt, yy["draught"], spec), "recs": yy,
                                    "ke": yy["ke"], "draught": yy["draught"]}
        real["warpdem run_soil_bin"][k] = w if k is None else run_soil_bin_twin(assembly, spec, k)
        for name, pf in variants:
            real[f"warpdem {name}"][k] = run_spec(spec, pf, k)
    alone = bed_alone(spec)
    ens = {e: ensemble([r["steady"].mean for r in rr.values()], [r["steady"].sem for r in rr.values()])
           for e, rr in real.items()}

    def ens_of(e: str, key: str) -> tuple[float, float]:
        v = np.array([steady_mean(r["recs"][key], r["recs"]["step"], spec) for r in real[e].values()])
        return float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else math.nan

    comb = math.hypot(ws.sem, ys.sem)
    diff = ws.mean - ys.mean
    chk = force_check(w1, y, spec, False)
    chk_d = force_check(w1, y, spec, True)
    chk_f = force_check(w1_facet, y, spec, False)
    R = w["recs"]
    n_part, n_sph = int(spec["n_particles"]), int(spec["n_spheres"])
    L = [f"## Assembly {assembly}: {n_part} particles, {n_sph} spheres, {int(spec['n_clumps'])} clumps\n"]
    L.append(f"dt = {dt:.6e} s (warpdem's min(0.3 P-wave, 0.5 critical), both engines), {int(spec['n_steps'])} "
             f"steps, a record every {int(spec['record_every'])} steps ({float(spec['sample_rate']):.0f} Hz), travel "
             f"{float(spec['travel'])} m at {speed} m/s (the carriage stops at the last step), steady part from "
             f"{float(spec['steady_travel'])} m of travel ({ws.n} records).\n")
    L.append("Scene check (run_soil_bin's scene vs the exported spec, max |diff|): "
             + ", ".join(f"{k} {v:.1e}" for k, v in w["check"].items())
             + f". Yade's particle masses / centres of mass / principal inertia vs warpdem's: max rel. diff "
               f"{np.abs(y['clump_mass'] / spec['particle_mass'] - 1).max():.1e} / "
               f"{np.abs(y['clump_com'] - spec['particle_com']).max():.1e} m / "
               f"{np.abs(y['clump_inertia_sorted'] / np.sort(spec['particle_inertia'], axis=1) - 1).max():.1e}.\n")
    L.append("### Mean draught over the steady part [N]\n")
    L.append(f"**Main runs (the exported bed as is): warpdem run_soil_bin {ws.mean:.2f} +- {ws.sem:.2f} N, Yade "
             f"{ys.mean:.2f} +- {ys.sem:.2f} N (mean +- SE); difference {diff:+.2f} N = {diff / comb:+.2f} combined "
             f"SE ({comb:.2f} N): {'within' if abs(diff) <= 2 * comb else 'BEYOND'} two combined standard "
             f"errors.**\n")
    names = list(real)
    L.append("Every realization (mean +- SE [N]; seed k: every particle displaced by RandomState(k).uniform(-1e-9, "
             "1e-9) m in both engines):\n")
    L.append("| realization | " + " | ".join(names) + " |")
    L.append("|---" * (len(names) + 1) + "|")
    for k in real["Yade 2023.02a"]:
        L.append(f"| {'main' if k is None else f'seed {k}'} | " + " | ".join(
            f"{real[e][k]['steady'].mean:.1f} +- {real[e][k]['steady'].sem:.1f}" for e in names) + " |")
    L.append("")
    if seeds:
        L.append("Ensembles (SE of the ensemble mean = the larger of std(means)/sqrt(n) and sqrt(sum SE^2)/n); "
                 "z_particle_ss and the soil's kinetic energy: steady means, mean +- SE over the realizations:\n")
        L.append("| engine | n | mean draught [N] | std of means | SE (spread) | SE (runs' SEs) | vs Yade "
                 "[combined SE] | z_particle_ss | soil KE [J] |")
        L.append("|---|---|---|---|---|---|---|---|---|")
        for e in names:
            d_, c_, z_ = ztest(ens[e], ens["Yade 2023.02a"])
            zm, zs = ens_of(e, "z_particle_ss")
            kv = np.array([steady_mean(r["ke"], r["recs"]["step"], spec) for r in real[e].values()])
            L.append(f"| {e} | {ens[e]['n']} | {ens[e]['mean']:.2f} | {ens[e]['std_of_means']:.2f} | "
                     f"{ens[e]['se_spread']:.2f} | {ens[e]['se_runs']:.2f} | "
                     f"{'' if e.startswith('Yade') else f'{d_:+.1f} N = {z_:+.2f}'} | {zm:.3f} +- {zs:.3f} | "
                     f"{kv.mean():.2f} +- {kv.std(ddof=1) / math.sqrt(len(kv)):.2f} |")
        L.append("")
    L.append("### First step (contacts from the initial overlaps; cohesion assigned)\n")
    L.append("| quantity | warpdem run_soil_bin | warpdem from spec (one mesh per object) | warpdem one mesh per "
             "facet | Yade |")
    L.append("|---|---|---|---|---|")
    for k, label in (("c_ss", "sphere-sphere contacts"), ("coh_ss", "  of which cohesive (bonds)"),
                     ("c_sf", "sphere-facet contacts"), ("coh_sf", "  of which flagged cohesive (zero adhesion)"),
                     ("c_sf_bin", "  bin walls"), ("c_sf_lower", "  tool lower half"),
                     ("c_sf_upper", "  tool upper half")):
        L.append(f"| {label} | {w1[k]} | {w1_spec[k]} | {w1_facet[k]} | {int(y['step1_' + k])} |")
    L.append(f"| Yade facet interactions warpdem's merging rule drops | | | | {int(y['step1_wd_drop_sf'])} |")
    L.append(f"| draught [N] | {w1['draught']:.4f} | {w1_spec['draught']:.4f} | {w1_facet['draught']:.4f} | "
             f"{float(y['step1_draught']):.4f} |")
    for k in ZKEYS:
        L.append(f"| {k} | {w1[k]:.4f} | {w1_spec[k]:.4f} | {w1_facet[k]:.4f} | {float(y['step1_' + k]):.4f} |")
    L.append(f"| Yade utils.avgNumInteractions() | | | | {float(y['step1_utils_avg_default']):.4f} |")
    L.append(f"| Yade utils.avgNumInteractions(considerClumps=True) | | | | "
             f"{float(y['step1_utils_avg_clumps']):.4f} |")
    L.append("")
    spec_same = np.abs(w1_spec["body_force"] - w1["body_force"]).max()
    L.append(f"Contact force per particle after step 1 (warpdem's body force vs the sum of Yade's member forces; "
             f"forces up to {chk['f_scale']:.2f} N): run_soil_bin vs Yade max |diff| {chk['f_max_diff']:.2e} N "
             f"(particle {chk['worst_particle']}); the same with the forces of Yade's {int(y['step1_wd_drop_sf'])} "
             f"interaction(s) that warpdem's rule drops removed from Yade's: {chk_d['f_max_diff']:.2e} N; warpdem "
             f"with one mesh per facet vs Yade: {chk_f['f_max_diff']:.2e} N. Torques of single spheres: max |diff| "
             f"{chk['t_max_diff']:.2e} N m. The spec rebuild (one mesh per object) gives run_soil_bin's forces to "
             f"{spec_same:.1e} N.\n")
    L.append("### Contacts and coordination numbers over the run (same formulas, contacts in Yade's id space)\n")
    L.append("Main runs. 'Yade, as warpdem counts' removes from Yade's contact list the facet interactions warpdem's "
             "merging rule would not have (edge/vertex contacts on a facet whose point lies on another touching facet "
             "of the same object, or coincides with another contact of the same object).\n")
    yst, wst = y["step"], R["step"]
    L.append("| quantity | warpdem steady mean | Yade steady mean | Yade, as warpdem counts | warpdem at 0.05 m | "
             "Yade at 0.05 m | warpdem at 0.1 m | Yade at 0.1 m | warpdem end | Yade end |")
    L.append("|---|---|---|---|---|---|---|---|---|---|")
    rows = [("c_ss", "c_ss", None), ("coh_ss", "coh_ss", None), ("c_sf", "c_sf", "c_sf_unique"),
            ("c_sf_bin", "c_sf_bin", "c_sf_bin_unique"), ("c_sf_lower", "c_sf_lower", "c_sf_lower_unique"),
            ("coh_sf", "coh_sf", None)]
    rows += [(k, k, None if "ss" in k else k + "_dedup") for k in ZKEYS]
    for k, ky, kd in rows:
        wx, yx = R[k], y[ky]
        dd = f"{steady_mean(y[kd], yst, spec):.3f}" if kd else "="
        L.append(f"| {k} | {steady_mean(wx, wst, spec):.3f} | {steady_mean(yx, yst, spec):.3f} | {dd} | "
                 f"{at_travel(wx, wst, spec, 0.05):.3f} | {at_travel(yx, yst, spec, 0.05):.3f} | "
                 f"{at_travel(wx, wst, spec, 0.1):.3f} | {at_travel(yx, yst, spec, 0.1):.3f} | "
                 f"{float(wx[-1]):.3f} | {float(yx[-1]):.3f} |")
    L.append(f"| Yade interactions warpdem's rule drops | 0 | {steady_mean(y['wd_drop_sf'], yst, spec):.3f} | | | "
             f"{at_travel(y['wd_drop_sf'], yst, spec, 0.05):.0f} | | {at_travel(y['wd_drop_sf'], yst, spec, 0.1):.0f}"
             f" | | {float(y['wd_drop_sf'][-1]):.0f} |")
    L.append("")
    if seeds:
        L.append("Steady-state coordination numbers over all realizations (mean +- SE of the run means):\n")
        L.append("| definition | warpdem run_soil_bin | Yade | Yade, as warpdem counts | warpdem - Yade (as warpdem "
                 "counts) [combined SE] | warpdem per facet (bin + tool) | per facet - Yade [combined SE] | warpdem "
                 "per facet (bin only) |")
        L.append("|---|---|---|---|---|---|---|---|")
        for k in ZKEYS:
            def f2(e: str, key: str) -> str:
                m_, s_ = ens_of(e, key)
                return f"{m_:.3f} +- {s_:.3f}"

            def zs(e1: str, k1: str, e2: str, k2: str) -> str:
                (m1, s1), (m2, s2) = ens_of(e1, k1), ens_of(e2, k2)
                return f"{m1 - m2:+.3f} = {(m1 - m2) / math.hypot(s1, s2):+.1f}"
            kd = k if "ss" in k else k + "_dedup"
            L.append(f"| {k} | {f2('warpdem run_soil_bin', k)} | {f2('Yade 2023.02a', k)} | "
                     f"{'=' if 'ss' in k else f2('Yade 2023.02a', kd)} | "
                     f"{zs('warpdem run_soil_bin', k, 'Yade 2023.02a', kd)} | "
                     f"{f2('warpdem per facet (bin + tool)', k)} | "
                     f"{zs('warpdem per facet (bin + tool)', k, 'Yade 2023.02a', k)} | "
                     f"{f2('warpdem per facet (bin only)', k)} |")
        L.append("")
    L.append(f"warpdem's own observer coordination_number('soil') equals z_particle_ss (max |diff| "
             f"{np.abs(w['coordination'] - R['z_particle_ss']).max():.1e}); Yade's utils.avgNumInteractions() and "
             f"utils.avgNumInteractions(considerClumps=True) equal the replicas z_yade_default / z_yade_clumps (max "
             f"|diff| {np.abs(y['utils_avg_default'] - y['z_yade_default']).max():.1e} / "
             f"{np.abs(y['utils_avg_clumps'] - y['z_yade_clumps']).max():.1e}).\n")
    L.append("### The bed's own evolution\n")
    L.append(f"Soil kinetic energy [J] at 0.05 / 0.1 m of travel and steady mean: warpdem "
             f"{at_travel(w['ke'], wst, spec, 0.05):.3f} / {at_travel(w['ke'], wst, spec, 0.1):.3f} / "
             f"{steady_mean(w['ke'], wst, spec):.3f}; Yade {at_travel(y['ke'], yst, spec, 0.05):.3f} / "
             f"{at_travel(y['ke'], yst, spec, 0.1):.3f} / {steady_mean(y['ke'], yst, spec):.3f}. Bonds left at "
             f"0.05 m of travel: warpdem {at_travel(R['coh_ss'], wst, spec, 0.05):.0f}, Yade "
             f"{at_travel(y['coh_ss'], yst, spec, 0.05):.0f} of {int(y['step1_coh_ss'])}; lower-half tool contacts "
             f"then: warpdem {at_travel(R['c_sf_lower'], wst, spec, 0.05):.0f}, Yade "
             f"{at_travel(y['c_sf_lower'], yst, spec, 0.05):.0f} (Yade, as warpdem counts: "
             f"{at_travel(y['c_sf_lower_unique'], yst, spec, 0.05):.0f}).\n")
    A_ = alone["recs"]
    ta = alone["time"]
    pts = [0.05, 0.1, 0.2, float(spec["travel"])]
    L.append("The same scene with the tool at rest (warpdem, spec rebuild), at the times the moving tool reaches "
             + ", ".join(f"{p_} m" for p_ in pts) + ": bonds "
             + " / ".join(f"{A_['coh_ss'][np.argmin(np.abs(ta * speed - p_))]}" for p_ in pts)
             + f" of {int(y['step1_coh_ss'])}, soil kinetic energy "
             + " / ".join(f"{alone['ke'][np.argmin(np.abs(ta * speed - p_))]:.2f}" for p_ in pts)
             + " J, z_particle_ss " + " / ".join(f"{A_['z_particle_ss'][np.argmin(np.abs(ta * speed - p_))]:.2f}"
                                                  for p_ in pts) + ".")
    en = alone["energy"]
    k1 = int(np.argmin(np.abs(ta * speed - 0.1)))
    mass = float(spec["particle_mass"].sum())
    L.append(f"warpdem's energy balance of that run (energy_balance, track_energy=True), from the start to the time of "
             f"0.1 m of travel: gravity potential {en[k1, 2] - en[0, 2]:+.2f} J (a mean drop of the soil's "
             f"{float(spec['particle_mass'].sum()):.1f} kg by {-(en[k1, 2] - en[0, 2]) / (mass * 9.81) * 1e3:.1f} mm), "
             f"kinetic {en[k1, 0]:.2f} J, dissipated by sliding {en[k1, 3]:.2f} J and rolling {en[k1, 4]:.2f} J; "
             f"the balance's total drifts by {en[k1, 5] - en[0, 5]:+.3f} J. The bed collapses under its own weight "
             f"and the released energy becomes the kinetic energy of an undamped granular gas, breaking the bonds; "
             f"the tool is not needed for it.\n")
    dw = np.diff(R["coh_ss"][1:]).max(initial=0)
    dy = np.diff(y["coh_ss"]).max(initial=0)
    L.append(f"Cohesion only on the initial contacts, in both engines: the bond count never increases after the first "
             f"step (largest record-to-record increase: warpdem {dw}, Yade {dy}; first record {R['coh_ss'][1]} / "
             f"{y['coh_ss'][0]} bonds after {int(y['step'][0])} steps, from {w1['coh_ss']} / {int(y['step1_coh_ss'])}"
             f" after step 1).\n")
    L.append(f"Wall times of the main runs (one CPU thread each): warpdem run_soil_bin {w['wall_s']:.1f} s, warpdem "
             f"one mesh per facet {real['warpdem per facet (bin + tool)'][None]['wall_s']:.1f} s, Yade "
             f"{float(y['wall_s']):.1f} s (Yade's includes its Python recorder).\n")
    np.savez_compressed(
        HERE / f"soil_bin_twin_series_{assembly}.npz", warp_time=w["time"], yade_step=yst,
        bed_alone_ke=alone["ke"], bed_alone_coh_ss=A_["coh_ss"], bed_alone_z=A_["z_particle_ss"],
        **{f"warp_{k}": R[k] for k in R}, **{f"yade_{k}": y[k] for k in ("c_ss", "coh_ss", "c_sf", "c_sf_lower",
                                                                          "wd_drop_sf", "ke") + ZKEYS},
        **{f"draught__{e.replace(' ', '_')}__{'main' if k is None else k}": r["draught"]
           for e, rr in real.items() for k, r in rr.items()})
    summary = {"assembly": assembly, "w": ws, "y": ys, "diff": diff, "comb": comb, "ens": ens, "w1": w1,
               "yade": y, "R": R, "spec": spec, "ens_of": ens_of, "chk": chk, "chk_d": chk_d}
    print("\n".join(L))
    return L, summary


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("assemblies", nargs="*", default=["A"])
    ap.add_argument("--seeds", nargs="*", type=int, default=[])
    ap.add_argument("--floor-walls", action="store_true",
                    help="also run warpdem with only the bin floor's / only the bin walls' triangles as own meshes")
    ap.add_argument("--out", default=str(HERE / "soil_bin_twin_report.md"))
    a = ap.parse_args()
    body, sums = [], []
    for asm in a.assemblies:
        lines, s = compare(asm.upper(), a.seeds, VARIANTS + (FLOOR_WALLS if a.floor_walls else ()))
        body += lines
        sums.append(s)
    head = ["# Soil-bin Yade twin: warpdem vs Yade 2023.02a (rigid tool, ci scale, GA set 11, 0.62 m/s)\n",
            "Generated by `python benchmarks/yade/soil_bin_twin_compare.py " + " ".join(sys.argv[1:]) + "`; inputs "
            "`soil_bin_twin_spec_{A,C}.npz` (soil_bin_twin_export.py) and `soil_bin_twin_yade_{A,C}[_pk].npz` "
            "(soil_bin_twin.py under Yade). Set-up of both engines: see the docstrings of those scripts and "
            "`soil_bin_twin_notes.md`.\n",
            "## Summary\n",
            "Draught: mean +- SE over the steady part. 'Ensemble': all realizations of the same bed (see below). "
            "Z: z_particle_ss = warpdem's coordination_number('soil') definition, counted identically in both "
            "engines (start = after the first step; steady = mean over the steady part, ensemble mean).\n",
            "| assembly | warpdem main | Yade main | diff / comb. SE | warpdem ensemble | Yade ensemble | diff / comb. "
            "SE | warpdem per facet (bin + tool) ensemble, vs Yade | Z start w / y | Z steady w / y (ensembles), "
            "diff / comb. SE | Z steady, warpdem per facet, vs Yade |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in sums:
        e, y = s["ens"], s["yade"]
        ew, ey, ef = e["warpdem run_soil_bin"], e["Yade 2023.02a"], e["warpdem per facet (bin + tool)"]
        zw, zws = s["ens_of"]("warpdem run_soil_bin", "z_particle_ss")
        zy, zys = s["ens_of"]("Yade 2023.02a", "z_particle_ss")
        zf, zfs = s["ens_of"]("warpdem per facet (bin + tool)", "z_particle_ss")
        head.append(f"| {s['assembly']} | {s['w'].mean:.1f} +- {s['w'].sem:.1f} | {s['y'].mean:.1f} +- "
                    f"{s['y'].sem:.1f} | {s['diff'] / s['comb']:+.2f} | {ew['mean']:.1f} +- {ew['se']:.1f} (n = "
                    f"{ew['n']}) | {ey['mean']:.1f} +- {ey['se']:.1f} | {ztest(ew, ey)[2]:+.2f} | {ef['mean']:.1f} +- "
                    f"{ef['se']:.1f}, {ztest(ef, ey)[2]:+.2f} | {s['w1']['z_particle_ss']:.3f} / "
                    f"{float(y['step1_z_particle_ss']):.3f} | {zw:.3f} +- {zws:.3f} / {zy:.3f} +- {zys:.3f}, "
                    f"{(zw - zy) / math.hypot(zws, zys):+.1f} | {zf:.3f} +- {zfs:.3f}, "
                    f"{(zf - zy) / math.hypot(zfs, zys):+.1f} |")
    head.append("")
    Path(a.out).write_text("\n".join(head + body) + "\n")
    print("wrote", a.out)


if __name__ == "__main__":
    main()
