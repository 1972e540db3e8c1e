"""Yade twin of warpdem's rigid ci soil-bin run (Yade 2023.02a), from the spec written by soil_bin_twin_export.py.

Run from the repository root:

    yade -n -x benchmarks/yade/soil_bin_twin.py A            # -> soil_bin_twin_yade_A.npz / .log
    yade -n -x benchmarks/yade/soil_bin_twin.py C
    yade -n -x benchmarks/yade/soil_bin_twin.py A --perturb 1e-9 --seed 1 --tag _p1
        (every particle displaced as a whole by a uniform random vector in [-eps, eps]^3 m before the run: another
        realization of the same bed, to test whether a difference is systematic)
    yade -j2 -n -x benchmarks/yade/soil_bin_twin.py C --scale strip --full-every 10
        (the export of ``--scale strip``: the paper's 7 mm members; contacts counted at every 10th record only)

Scene (everything from the spec, nothing re-derived):
- materials: two CohFrictMat. Soil: the spec's float32 values as warpdem's kernels read them (E, ks/kn = poisson,
  rho, friction angle [rad], normalCohesion, shearCohesion, etaRoll = etaTwist, alphaKr = alphaKtw = 2),
  momentRotationLaw=True, fragile=True, isCohesive=True. Tool and bin walls: E = 1e9, poisson 0.3, rho 7850,
  40 deg, normalCohesion = shearCohesion = 0 (Yade's default is -1: it would give negative adhesions),
  momentRotationLaw=False, etaRoll = etaTwist = -1, fragile=True, isCohesive=True (warpdem's Material defaults).
- bodies, in this id order (soil_bin_twin_common.yade_layout): the 10 bin facets, the tool's lower facets, the
  tool's upper facets (utils.facet, fixed=True: blockedDOFs 'xyzXYZ'), then the particles in warpdem's order: a
  single sphere as utils.sphere, a clump by O.bodies.appendClumped (Yade's sum-of-spheres mass and inertia, which
  is warpdem's rule too) from the member centres warpdem simulates. Every tool facet gets state.vel = the spec's
  tool velocity (0, 0.62, 0): a blocked body keeps its velocity and NewtonIntegrator moves it by x += v dt, which is
  warpdem's kinematic mount (all DoFs blocked, velocity imposed).
- engines: ForceResetter, InsertionSortCollider([Bo1_Sphere_Aabb, Bo1_Facet_Aabb]),
  InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D, Ig2_Facet_Sphere_ScGeom6D],
  [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True, setCohesionOnNewContacts=False)],
  [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True, always_use_moment_law=True)]),
  NewtonIntegrator(gravity=spec, damping=0), PyRunner recorder (iterPeriod=record_every, firstIterRun=every-1:
  records after s = every, 2 every, ... completed steps, as warpdem's records). O.dt = the spec's dt; no time
  stepper. One thread (no -j).
- the carriage stops after the spec's n_steps (the run ends there, as warpdem's single-world run).

Recorded (per record k; ``step``, ``time``):
- ``draught`` = -(sum over lower-half facets of O.forces.f)_y [N] (the force resisting travel, warpdem's sign);
  ``force_lower``, ``force_upper``, ``force_bin`` (k, 3) [N]; ``tool_disp`` (k, 3) [m] (lower facet 0's motion).
- counts: ``c_ss`` (real sphere-sphere interactions), ``c_sf`` (real sphere-facet), ``c_sf_lower``,
  ``c_sf_upper``, ``c_sf_bin``, ``coh_ss`` / ``coh_sf`` (cohesionBroken False), ``dup_sf``: sphere-facet
  interactions of a sphere whose contact point coincides (within 1e-6 R) with another of its facet interactions of
  the same object (bin, lower, upper); ``wd_drop_sf``: the sphere-facet interactions warpdem's rule would not
  have (an edge/vertex contact whose closest point lies on a face contact of another facet of the same object, or
  coincides with another's; warpdem.contacts.suppressed, replicated in soil_bin_twin_common.warpdem_suppressed):
  Yade's edge/vertex double contacts; ``c_sf_unique``, ``c_sf_lower_unique``, ``c_sf_bin_unique``: the
  sphere-facet counts without them (counted as warpdem counts), and ``z_particle_all_dedup``,
  ``z_sphere_all_dedup``, ``z_yade_default_dedup``, ``z_yade_clumps_dedup``: the definitions involving facet
  contacts recomputed from these contacts; ``step1_wd_drop`` flags them among the first step's interactions.
- coordination numbers (soil_bin_twin_common.coordination): ``z_particle_ss`` (warpdem's observer definition),
  ``z_sphere_ss``, ``z_particle_all``, ``z_sphere_all``, ``z_yade_default``, ``z_yade_clumps`` (the numpy replica),
  and Yade's own ``utils_avg_default`` = utils.avgNumInteractions(), ``utils_avg_clumps`` =
  utils.avgNumInteractions(considerClumps=True) (the replica must equal them).
- ``ke`` = utils.kineticEnergy() [J] (soil: facets have no mass).
- first step (s = 1): ``step1_id1``, ``step1_id2``, ``step1_fn`` (normalForce, (n, 3)), ``step1_fs`` (shearForce),
  ``step1_cohesive``, ``step1_kn``, ``step1_ks``, ``step1_an``, ``step1_as``, ``step1_draught``, and the
  ``step1_*`` counts as above, ``step1_body_force`` / ``step1_body_torque`` (n_bodies, 3) (O.forces of every body:
  contact forces only; a clump's are in its members' slots); ``sphere_id`` (ns,) / ``particle_id`` (np,) map
  warpdem's order to Yade ids.
- ``clump_mass``/``clump_com``/``clump_inertia_sorted`` as Yade made them (per particle), ``wall_s``,
  ``yade_version``, ``perturb``, ``seed``.
"""
import os
import sys
import time

import numpy as np
import yade
from yade import utils
from yade.wrapper import *  # noqa: F401,F403

HERE = os.path.dirname(os.path.abspath(sys.argv[0]))
sys.path.insert(0, HERE)
import soil_bin_twin_common as common  # noqa: E402

args = sys.argv[1:]
ASSEMBLY = (args[0] if args and not args[0].startswith("--") else "A").upper()


def opt(name, default, cast):
    return cast(args[args.index(name) + 1]) if name in args else default


PERTURB = opt("--perturb", 0.0, float)
SEED = opt("--seed", 0, int)
TAG = opt("--tag", "", str)
STEPS = opt("--steps", None, int)  # shorter run (tests)
SCALE = opt("--scale", "ci", str)  # the export's scale: ci, or strip (the paper's members)
FULL_EVERY = opt("--full-every", 1, int)  # contacts and coordination at every FULL_EVERY-th record only (large beds)
NAME = ASSEMBLY + ("" if SCALE == "ci" else "_" + SCALE)
SPEC = os.path.join(HERE, "soil_bin_twin_spec_%s.npz" % NAME)
OUT = os.path.join(HERE, "soil_bin_twin_yade_%s%s.npz" % (NAME, TAG))
LOG = open(os.path.join(HERE, "soil_bin_twin_yade_%s%s.log" % (NAME, TAG)), "w")


def log(*a):
    s = " ".join(str(x) for x in a)
    print(s)
    LOG.write(s + "\n")
    LOG.flush()


sp = {k: v for k, v in np.load(SPEC).items()}
log("Yade", yade.config.version, "spec", SPEC, "perturb", PERTURB, "seed", SEED)
dt = float(sp["dt"])
every = int(sp["record_every"])
n_steps = int(sp["n_steps"]) if STEPS is None else STEPS
radius = sp["sphere_radius"]
particle = sp["sphere_particle"]
pos = sp["sphere_pos"].copy()
if PERTURB > 0:
    shift = np.random.RandomState(SEED).uniform(-PERTURB, PERTURB, (int(sp["n_particles"]), 3))
    pos += shift[particle]
bin_tri, low_tri, up_tri = sp["bin_tri"], sp["tool_lower_tri"], sp["tool_upper_tri"]
NF = len(bin_tri) + len(low_tri) + len(up_tri)
layout = common.yade_layout(particle, NF)
ALL_TRI = np.concatenate([sp["bin_tri"], sp["tool_lower_tri"], sp["tool_upper_tri"]])
group_of_facet = np.r_[np.zeros(len(bin_tri), int), np.ones(len(low_tri), int), np.full(len(up_tri), 2)]
BIN_IDS = list(range(len(bin_tri)))
LOW_IDS = list(range(len(bin_tri), len(bin_tri) + len(low_tri)))
UP_IDS = list(range(len(bin_tri) + len(low_tri), NF))


def mat(prefix, f32=True):
    g = (lambda k: float(sp[prefix + "_" + k + "_f32"])) if f32 else (lambda k: float(sp[prefix + "_" + k]))
    return dict(young=g("young"), poisson=g("poisson"), density=float(sp[prefix + "_density"]),
                frictionAngle=g("friction_angle_rad"), normalCohesion=g("normal_cohesion"),
                shearCohesion=g("shear_cohesion"), etaRoll=g("eta_roll"), etaTwist=g("eta_twist"),
                alphaKr=g("alpha_kr"), alphaKtw=g("alpha_ktw"), momentRotationLaw=bool(sp[prefix + "_moment_law"]),
                fragile=bool(sp[prefix + "_fragile"]), isCohesive=bool(sp[prefix + "_cohesive"]))


SOIL_MAT, TOOL_MAT = mat("soil"), mat("tool")
log("soil material", SOIL_MAT)
log("tool material", TOOL_MAT)

O.reset()
tm = O.materials.append(CohFrictMat(label="tool", **TOOL_MAT))
smat = O.materials.append(CohFrictMat(label="soil", **SOIL_MAT))
vel = tuple(float(v) for v in sp["tool_velocity"])
for k, tri in enumerate(np.concatenate([bin_tri, low_tri, up_tri])):
    fid = O.bodies.append(utils.facet([tuple(map(float, v)) for v in tri], fixed=True, material=tm))
    assert fid == k
    if k >= len(bin_tri):
        O.bodies[fid].state.vel = vel
starts = np.r_[0, np.cumsum(np.bincount(particle))[:-1]]
counts = np.bincount(particle)
for p in range(int(sp["n_particles"])):
    a, n = int(starts[p]), int(counts[p])
    if n == 1:
        bid = O.bodies.append(utils.sphere(tuple(map(float, pos[a])), float(radius[a]), material=smat))
        assert bid == layout["particle_id"][p] == layout["sphere_id"][a]
    else:
        cid, mids = O.bodies.appendClumped([utils.sphere(tuple(map(float, pos[j])), float(radius[j]), material=smat)
                                            for j in range(a, a + n)])
        assert cid == layout["particle_id"][p] and list(mids) == list(layout["sphere_id"][a:a + n])
assert len(O.bodies) == int(layout["n_bodies"])
pid = layout["particle_id"]
clump_mass = np.array([O.bodies[int(i)].state.mass for i in pid])
clump_com = np.array([list(O.bodies[int(i)].state.pos) for i in pid])
clump_inertia = np.array([sorted(list(O.bodies[int(i)].state.inertia)) for i in pid])
log("particle mass Yade/warpdem - 1: max %.3e; COM max |diff| %.3e m; principal inertia max rel diff %.3e" % (
    np.abs(clump_mass / sp["particle_mass"] - 1).max(), np.abs(clump_com - sp["particle_com"]).max(),
    np.abs(clump_inertia / np.sort(sp["particle_inertia"], axis=1) - 1).max()))

O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], label="collider"),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D(), Ig2_Facet_Sphere_ScGeom6D()],
                    [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(label="ip2", setCohesionNow=bool(sp["set_cohesion_now"]),
                                                              setCohesionOnNewContacts=bool(
                                                                  sp["set_cohesion_on_new_contacts"]))],
                    [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(label="law",
                                                               useIncrementalForm=bool(sp["use_incremental_form"]),
                                                               always_use_moment_law=bool(
                                                                   sp["always_use_moment_law"]))]),
    NewtonIntegrator(gravity=tuple(float(g) for g in sp["gravity"]), damping=float(sp["local_damping"]),
                     label="newton"),
    PyRunner(iterPeriod=every, firstIterRun=every - 1, command="record()", label="recorder"),
]
O.dt = dt
tool_pos0 = np.array(list(O.bodies[LOW_IDS[0]].state.pos))
sphere_ids = layout["sphere_id"]
r_of_body = np.zeros(int(layout["n_bodies"]))
r_of_body[sphere_ids] = radius

KEYS = ["step", "time", "draught", "force_lower", "force_upper", "force_bin", "tool_disp", "c_ss", "c_sf",
        "c_sf_lower", "c_sf_upper", "c_sf_bin", "coh_ss", "coh_sf", "dup_sf", "wd_drop_sf", "c_sf_unique",
        "c_sf_lower_unique", "c_sf_bin_unique", "z_particle_ss", "z_sphere_ss", "z_particle_all", "z_sphere_all",
        "z_yade_default", "z_yade_clumps", "z_particle_all_dedup", "z_sphere_all_dedup", "z_yade_default_dedup",
        "z_yade_clumps_dedup", "utils_avg_default", "utils_avg_clumps", "ke"]
rec = {k: [] for k in KEYS}


def facet_sum(ids):
    f = np.zeros(3)
    for i in ids:
        f += np.array(list(O.forces.f(i)))
    return f


def snapshot(s, detail=False):
    """Everything recorded at one step (s completed steps)."""
    out = {"step": s, "time": s * dt}
    fl, fu, fb = facet_sum(LOW_IDS), facet_sum(UP_IDS), facet_sum(BIN_IDS)
    out.update(draught=-fl[1], force_lower=fl, force_upper=fu, force_bin=fb,
               tool_disp=np.array(list(O.bodies[LOW_IDS[0]].state.pos)) - tool_pos0)
    id1, id2, coh, cps, det = [], [], [], [], {k: [] for k in ("fn", "fs", "kn", "ks", "an", "as")}
    for I in O.interactions:
        if not I.isReal:
            continue
        id1.append(I.id1)
        id2.append(I.id2)
        coh.append(not I.phys.cohesionBroken)
        cps.append(list(I.geom.contactPoint) if (I.id1 < NF or I.id2 < NF) else [0.0, 0.0, 0.0])
        if detail:
            det["fn"].append(list(I.phys.normalForce))
            det["fs"].append(list(I.phys.shearForce))
            det["kn"].append(I.phys.kn)
            det["ks"].append(I.phys.ks)
            det["an"].append(I.phys.normalAdhesion)
            det["as"].append(I.phys.shearAdhesion)
    id1, id2, coh, cps = np.array(id1, np.int64), np.array(id2, np.int64), np.array(coh, bool), np.array(cps)
    sf = (id1 < NF) | (id2 < NF)
    fac = np.where(id1 < NF, id1, id2)
    sph = np.where(id1 < NF, id2, id1)
    grp = np.where(sf, group_of_facet[np.minimum(fac, NF - 1)], -1)
    out.update(c_ss=int((~sf).sum()), c_sf=int(sf.sum()), c_sf_bin=int((grp == 0).sum()),
               c_sf_lower=int((grp == 1).sum()), c_sf_upper=int((grp == 2).sum()), coh_ss=int((coh & ~sf).sum()),
               coh_sf=int((coh & sf).sum()))
    # edge/vertex double contacts: (a) a sphere's facet contacts of one object (bin, lower, upper) at the same
    # contact point; (b) every contact warpdem's rule would drop (warpdem.contacts.suppressed, replicated in
    # soil_bin_twin_common.warpdem_suppressed on the facets' current world triangles)
    dup = 0
    drop = np.zeros(len(id1), bool)
    idx = np.flatnonzero(sf)
    keyed = {}
    for k in idx:
        keyed.setdefault((int(sph[k]), int(grp[k])), []).append(k)
    shift = np.array(list(O.bodies[LOW_IDS[0]].state.pos)) - tool_pos0
    for (b, g), ks in keyed.items():
        if len(ks) < 2:
            continue
        tol = 1e-6 * r_of_body[b]
        for a_ in range(len(ks)):
            if any(np.linalg.norm(cps[ks[a_]] - cps[ks[b_]]) <= tol for b_ in range(len(ks)) if b_ != a_):
                dup += 1
        order = sorted(ks, key=lambda k: int(fac[k]))  # warpdem keeps the lowest face of coincident contacts
        tris = ALL_TRI[[int(fac[k]) for k in order]] + (shift if g > 0 else 0.0)
        sup = common.warpdem_suppressed(np.array(list(O.bodies[int(b)].state.pos)), r_of_body[b], tris)
        drop[np.array(order)[sup]] = True
    out["dup_sf"] = dup
    out["wd_drop_sf"] = int(drop.sum())
    out["c_sf_unique"] = int((sf & ~drop).sum())
    out["c_sf_lower_unique"] = int(((grp == 1) & ~drop).sum())
    out["c_sf_bin_unique"] = int(((grp == 0) & ~drop).sum())
    if detail:
        out["drop"] = drop
    body_pos = np.array([list(b.state.pos) for b in O.bodies])
    z = common.coordination(id1, id2, body_pos, layout, radius, NF)
    for k in ("z_particle_ss", "z_sphere_ss", "z_particle_all", "z_sphere_all", "z_yade_default", "z_yade_clumps"):
        out[k] = z[k]
    z = common.coordination(id1[~drop], id2[~drop], body_pos, layout, radius, NF)
    for k in ("z_particle_all", "z_sphere_all", "z_yade_default", "z_yade_clumps"):
        out[k + "_dedup"] = z[k]
    out["utils_avg_default"] = utils.avgNumInteractions()
    out["utils_avg_clumps"] = utils.avgNumInteractions(considerClumps=True)
    out["ke"] = utils.kineticEnergy()
    if detail:
        out["body_force"] = np.array([list(O.forces.f(b.id)) for b in O.bodies])
        out["body_torque"] = np.array([list(O.forces.t(b.id)) for b in O.bodies])
        out["pairs"] = (id1, id2, coh)
        out["detail"] = {k: np.array(v) for k, v in det.items()}
    return out


INT_KEYS = ("step", "c_ss", "c_sf", "c_sf_lower", "c_sf_upper", "c_sf_bin", "coh_ss", "coh_sf", "dup_sf",
            "c_sf_unique", "c_sf_lower_unique", "c_sf_bin_unique", "wd_drop_sf")


def light(s):
    """The forces only (contact counts -1, coordination NaN): the records between two full snapshots."""
    fl, fu, fb = facet_sum(LOW_IDS), facet_sum(UP_IDS), facet_sum(BIN_IDS)
    out = {k: (-1 if k in INT_KEYS else float("nan")) for k in KEYS}
    out.update(step=s, time=s * dt, draught=-fl[1], force_lower=fl, force_upper=fu, force_bin=fb,
               tool_disp=np.array(list(O.bodies[LOW_IDS[0]].state.pos)) - tool_pos0, ke=utils.kineticEnergy())
    return out


def record():
    s = O.iter + 1
    full = (s // every) % FULL_EVERY == 0
    snap = snapshot(s) if full else light(s)
    for k in KEYS:
        rec[k].append(snap[k])
    if full and (FULL_EVERY > 1 or (s // every) % 20 == 0):
        log("step %5d t=%.4f travel=%.4f draught=%8.2f N  ss=%d (coh %d) sf=%d (lower %d, dup %d) Zp=%.3f "
            "Zyade=%.3f/%.3f KE=%.3e" % (s, s * dt, snap["tool_disp"][1], snap["draught"], snap["c_ss"],
                                         snap["coh_ss"], snap["c_sf"], snap["c_sf_lower"], snap["dup_sf"],
                                         snap["z_particle_ss"], snap["utils_avg_default"], snap["utils_avg_clumps"],
                                         snap["ke"]))


t0 = time.time()
O.run(1, True)
s1 = snapshot(1, detail=True)
id1, id2, coh = s1["pairs"]
log("step 1: ss=%d (cohesive %d) sf=%d (cohesive %d; bin %d, lower %d, upper %d, dup %d) draught=%.4f N "
    "Zp=%.4f Zs=%.4f Yade avgNumInteractions()=%.4f (replica %.4f) considerClumps=%.4f (replica %.4f)" % (
        s1["c_ss"], s1["coh_ss"], s1["c_sf"], s1["coh_sf"], s1["c_sf_bin"], s1["c_sf_lower"], s1["c_sf_upper"],
        s1["dup_sf"], s1["draught"], s1["z_particle_ss"], s1["z_sphere_ss"], s1["utils_avg_default"],
        s1["z_yade_default"], s1["utils_avg_clumps"], s1["z_yade_clumps"]))
O.run(n_steps - 1, True)
wall = time.time() - t0
log("ip2.setCohesionNow after the run:", ip2.setCohesionNow)
for b in UP_IDS + LOW_IDS:  # the carriage stops after its travel
    O.bodies[b].state.vel = (0, 0, 0)
data = {k: np.array(v) for k, v in rec.items()}
for k in INT_KEYS:
    data[k] = data[k].astype(np.int64)
for k in ("c_ss", "c_sf", "c_sf_lower", "c_sf_upper", "c_sf_bin", "coh_ss", "coh_sf", "dup_sf", "c_sf_unique",
          "c_sf_lower_unique", "c_sf_bin_unique", "wd_drop_sf", "z_particle_all_dedup", "z_sphere_all_dedup",
          "z_yade_default_dedup", "z_yade_clumps_dedup", "draught", "z_particle_ss", "z_sphere_ss", "z_particle_all",
          "z_sphere_all", "z_yade_default", "z_yade_clumps", "utils_avg_default", "utils_avg_clumps", "ke"):
    data["step1_" + k] = np.array(s1[k])
data.update(step1_id1=id1, step1_id2=id2, step1_cohesive=coh, step1_wd_drop=s1["drop"],
            step1_force_lower=s1["force_lower"],
            step1_body_force=s1["body_force"], step1_body_torque=s1["body_torque"],
            **{"step1_" + k: v for k, v in s1["detail"].items()})
data.update(sphere_id=sphere_ids, particle_id=pid, n_facets=np.int64(NF), clump_mass=clump_mass,
            clump_com=clump_com, clump_inertia_sorted=clump_inertia, wall_s=np.float64(wall),
            n_steps=np.int64(n_steps), yade_version=np.array(str(yade.config.version)),
            perturb=np.float64(PERTURB), seed=np.int64(SEED), dt=np.float64(dt), record_every=np.int64(every),
            speed=np.float64(sp["speed"]))
np.savez_compressed(OUT, **data)
err_d = np.nanmax(np.abs(data["z_yade_default"] - data["utils_avg_default"]))
err_c = np.nanmax(np.abs(data["z_yade_clumps"] - data["utils_avg_clumps"]))
log("replica of avgNumInteractions: max |diff| default %.2e, considerClumps %.2e" % (err_d, err_c))
log("wall %.1f s for %d steps (%d records); wrote %s" % (wall, n_steps, len(data["step"]), OUT))
