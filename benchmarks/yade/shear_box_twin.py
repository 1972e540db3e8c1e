"""Yade twin of warpdem's direct shear box (Yade 2023.02a), from the spec written by shear_box_twin_export.py.

Run from the repository root, one normal stress (world W = 0, 1, 2 of the spec) per process:

    yade -n -x benchmarks/yade/shear_box_twin.py ci 0      # -> shear_box_twin_yade_ci_w0.npz / .log
    yade -n -x benchmarks/yade/shear_box_twin.py ci 0 --perturb 1e-9 --seed 1 --tag _p1
        (every particle displaced as a whole by RandomState(seed).uniform(-eps, eps, (n_particles, 3)) m before the
        run: another realization of the same consolidated sample, for the scatter)
    ... --steps N   (a shorter run, for timing)

Scene (everything from the spec, nothing re-derived):
- materials, CohFrictMat with the float32 values warpdem's kernels read: soil (GA set 11: friction angle, Cn, Cs,
  etaRoll = etaTwist, alphaKr = alphaKtw = 2, momentRotationLaw=True, fragile=True, isCohesive=True); box (the box
  halves' walls and flanges: E 1e9, ks/kn 0.3, frictionless); platen (floor and loading plate: E 1e9, 0.3, 40 deg);
  ballast (the plate's dead-weight sphere: the soil's E and ks/kn, this world's density, frictionless). Rig
  materials: normalCohesion = shearCohesion = 0, etaRoll = etaTwist = -1, momentRotationLaw=False,
  isCohesive=False (warpdem's ``cohesive=False``): no bond to the rig.
- bodies, in this id order: the lower half's 16 facets and the floor's 2 (utils.facet, fixed=True: blockedDOFs
  'xyzXYZ'; given state.vel = (shear_rate, 0, 0) at the start, NewtonIntegrator moves a blocked body by x += v dt,
  warpdem's kinematic body), the upper half's 16 facets (fixed, at rest), then the loading plate: the ballast sphere
  and the plate's 2 facets as ONE clump (O.bodies.clump; warpdem attaches the plate mesh to the ballast body), its
  mass set to warpdem's plate mass, blockedDOFs 'xyXYZ' (only z free, warpdem's ``blocked="xyXYZ"``); then the soil
  in warpdem's order: utils.sphere for a single sphere, O.bodies.appendClumped for a clump (Yade's sum-of-spheres
  mass and inertia, warpdem's rule) from the member centres after consolidation. Every body starts at rest.
- engines: ForceResetter, InsertionSortCollider([Bo1_Sphere_Aabb, Bo1_Facet_Aabb]),
  InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D, Ig2_Facet_Sphere_ScGeom6D],
  [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True, setCohesionOnNewContacts=False)],
  [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True, always_use_moment_law=True)]),
  NewtonIntegrator(gravity, damping=0), a PyRunner every step (sums the facets' forces: warpdem's per-step
  ``mesh_force_sum``) that closes a record every ``interval`` steps. O.dt = the spec's dt; no time stepper; one
  thread (no -j).

Recorded (per record k, after (k+1) interval steps): ``disp`` (lower half's displacement at the interval's middle,
warpdem's definition), ``upper`` (x force of the soil on the upper half's and the plate's facets, mean over the
interval [N]: the shear force), ``lower`` (-x force on the lower half and floor), ``rise`` (plate rise since the
start [m]), ``plate_fz`` (z force of the soil on the plate, interval mean); every 5th record ``c_ss``, ``coh_ss``
(sphere-sphere contacts between different particles and the bonded ones), ``c_sf``; ``step1_*`` the same counts
after the first step (the bonds made). ``wall_s``, ``yade_version``, ``perturb``, ``seed``, ``world``.
"""
import os
import sys
import time

import numpy as np
import yade
from yade import utils
from yade.wrapper import *  # noqa: F401,F403

HERE = os.path.dirname(os.path.abspath(sys.argv[0]))
args = sys.argv[1:]
pos_args = [a for k, a in enumerate(args) if not a.startswith("--") and (k == 0 or not args[k - 1].startswith("--"))]
SCALE = pos_args[0] if pos_args else "ci"
WORLD = int(pos_args[1]) if len(pos_args) > 1 else 0


def opt(name, default, cast):
    return cast(args[args.index(name) + 1]) if name in args else default


PERTURB = opt("--perturb", 0.0, float)
SEED = opt("--seed", 0, int)
TAG = opt("--tag", "", str)
STEPS = opt("--steps", None, int)
SPEC = os.path.join(HERE, "shear_box_twin_spec_%s.npz" % SCALE)
NAME = "shear_box_twin_yade_%s_w%d%s" % (SCALE, WORLD, TAG)
OUT = os.path.join(HERE, NAME + ".npz")
LOG = open(os.path.join(HERE, NAME + ".log"), "w")


def log(*a):
    s = " ".join(str(x) for x in a)
    print(s)
    LOG.write(s + "\n")
    LOG.flush()


sp = {k: v for k, v in np.load(SPEC).items()}
log("Yade", yade.config.version, "spec", SPEC, "world", WORLD, "perturb", PERTURB, "seed", SEED)
dt = float(sp["dt"])
interval = int(sp["interval"])
n_rec = int(sp["n_records"])
n_steps = n_rec * interval if STEPS is None else STEPS
radius = sp["sphere_radius"]
particle = sp["sphere_particle"]
n_part = int(sp["n_particles"])
pos = sp["sphere_pos"][WORLD].copy()
if PERTURB > 0:
    shift = np.random.RandomState(SEED).uniform(-PERTURB, PERTURB, (n_part, 3))
    pos += shift[particle]


def mat(prefix, density=None):
    g = lambda k: float(sp[prefix + "_" + k + "_f32"])  # noqa: E731
    return dict(young=g("young"), poisson=g("poisson"),
                density=float(sp[prefix + "_density"]) if density is None else density,
                frictionAngle=g("friction_angle_rad"), normalCohesion=g("normal_cohesion"),
                shearCohesion=g("shear_cohesion"), etaRoll=g("eta_roll"), etaTwist=g("eta_twist"),
                alphaKr=g("alpha_kr"), alphaKtw=g("alpha_ktw"), momentRotationLaw=bool(sp[prefix + "_moment_law"]),
                fragile=bool(sp[prefix + "_fragile"]), isCohesive=bool(sp[prefix + "_cohesive"]))


MATS = {"soil": mat("soil"), "box": mat("box"), "platen": mat("platen"),
        "ballast": mat("ballast", float(sp["ballast_density_world"][WORLD]))}
for k, v in MATS.items():
    log(k, "material", v)

O.reset()
mid = {k: O.materials.append(CohFrictMat(label=k, **v)) for k, v in MATS.items()}
lower_tri, floor_tri, upper_tri = sp["lower_tri"], sp["floor_tri"], sp["upper_tri"]
plate_tri = sp["plate_tri"][WORLD]


def facet(tri, material, fixed=True):
    return utils.facet([tuple(map(float, v)) for v in tri], fixed=fixed, material=mid[material])


LOWER_IDS = [O.bodies.append(facet(t, "box")) for t in lower_tri]
FLOOR_IDS = [O.bodies.append(facet(t, "platen")) for t in floor_tri]
UPPER_IDS = [O.bodies.append(facet(t, "box")) for t in upper_tri]
bal = utils.sphere(tuple(map(float, sp["ballast_pos"][WORLD])), float(sp["ballast_radius"]), material=mid["ballast"])
PLATE_MEMBERS = O.bodies.append([bal] + [facet(t, "platen", fixed=False) for t in plate_tri])
PLATE_IDS = PLATE_MEMBERS[1:]
PLATE = O.bodies.clump(PLATE_MEMBERS)
plate = O.bodies[PLATE]
plate.state.mass = float(sp["plate_mass"][WORLD])
plate.state.blockedDOFs = "xyXYZ"
plate.state.vel = (0, 0, 0)
log("plate clump %d: mass %.9g kg (warpdem %.9g), pos %s (ballast %s)" % (
    PLATE, plate.state.mass, float(sp["plate_mass"][WORLD]), list(plate.state.pos), list(sp["ballast_pos"][WORLD])))
N_RIG = len(O.bodies)
starts = np.r_[0, np.cumsum(np.bincount(particle))[:-1]]
counts = np.bincount(particle)
part_id = np.zeros(n_part, np.int64)
sphere_id = np.zeros(len(radius), np.int64)
for p in range(n_part):
    a, n = int(starts[p]), int(counts[p])
    if n == 1:
        part_id[p] = sphere_id[a] = O.bodies.append(utils.sphere(tuple(map(float, pos[a])), float(radius[a]),
                                                                  material=mid["soil"]))
    else:
        cid, mids = O.bodies.appendClumped([utils.sphere(tuple(map(float, pos[j])), float(radius[j]),
                                                         material=mid["soil"]) for j in range(a, a + n)])
        part_id[p] = cid
        sphere_id[a:a + n] = mids
clump_mass = np.array([O.bodies[int(i)].state.mass for i in part_id])
clump_inertia = np.array([sorted(list(O.bodies[int(i)].state.inertia)) for i in part_id])
log("soil: %d particles, %d spheres; mass Yade/warpdem - 1: max %.3e; principal inertia max rel diff %.3e" % (
    n_part, len(radius), np.abs(clump_mass / sp["particle_mass"] - 1).max(),
    np.abs(clump_inertia / np.sort(sp["particle_inertia"], axis=1) - 1).max()))
body_particle = np.full(len(O.bodies), -1, np.int64)
body_particle[sphere_id] = particle  # a sphere's particle (soil), -1 for the rig

O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], label="collider"),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D(), Ig2_Facet_Sphere_ScGeom6D()],
                    [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(label="ip2", setCohesionNow=True,
                                                              setCohesionOnNewContacts=bool(
                                                                  sp["set_cohesion_on_new_contacts"]))],
                    [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(label="law",
                                                               useIncrementalForm=bool(sp["use_incremental_form"]),
                                                               always_use_moment_law=bool(
                                                                   sp["always_use_moment_law"]))]),
    NewtonIntegrator(gravity=tuple(float(g) for g in sp["gravity"]), damping=float(sp["local_damping"]),
                     label="newton"),
    PyRunner(iterPeriod=1, initRun=True, command="accumulate()", label="recorder"),
]
O.dt = dt
law.unpMax = float(sp["unp_max"])
v_shear = float(sp["shear_rate"])
for b in LOWER_IDS + FLOOR_IDS:
    O.bodies[b].state.vel = (v_shear, 0, 0)
x0 = O.bodies[LOWER_IDS[0]].state.pos[0]
z0 = plate.state.pos[2]

acc = {"upper": 0.0, "lower": 0.0, "plate_fz": 0.0, "n": 0}
rec = {k: [] for k in ("step", "disp", "upper", "lower", "rise", "plate_fz", "c_ss", "coh_ss", "c_sf")}
F = O.forces.f


def counts():
    c_ss = coh = c_sf = 0
    for I in O.interactions:
        if not I.isReal:
            continue
        if I.id1 < N_RIG or I.id2 < N_RIG:
            c_sf += 1
        elif body_particle[I.id1] != body_particle[I.id2]:
            c_ss += 1
            coh += not I.phys.cohesionBroken
    return c_ss, coh, c_sf


def accumulate():
    acc["upper"] += sum(F(i)[0] for i in UPPER_IDS) + sum(F(i)[0] for i in PLATE_IDS)
    acc["lower"] -= sum(F(i)[0] for i in LOWER_IDS) + sum(F(i)[0] for i in FLOOR_IDS)
    acc["plate_fz"] += sum(F(i)[2] for i in PLATE_IDS)
    acc["n"] += 1
    if acc["n"] < interval:
        return
    s = O.iter + 1
    k = s // interval
    assert s == k * interval, (s, interval)
    rec["step"].append(s)
    rec["disp"].append(O.bodies[LOWER_IDS[0]].state.pos[0] - x0 - 0.5 * interval * dt * v_shear)
    for key in ("upper", "lower", "plate_fz"):
        rec[key].append(acc[key] / acc["n"])
        acc[key] = 0.0
    acc["n"] = 0
    rec["rise"].append(plate.state.pos[2] - z0)
    c = counts() if k % 5 == 0 else (-1, -1, -1)
    for key, v in zip(("c_ss", "coh_ss", "c_sf"), c):
        rec[key].append(v)
    if k % 5 == 0:
        log("record %3d step %6d disp %.3f mm tau %.3f kPa (lower %.3f) rise %.4f mm ss %d (bonded %d) sf %d" % (
            k, s, 1e3 * rec["disp"][-1], rec["upper"][-1] / float(sp["box_side"]) ** 2 / 1e3,
            rec["lower"][-1] / float(sp["box_side"]) ** 2 / 1e3, 1e3 * rec["rise"][-1], c[0], c[1], c[2]))


t0 = time.time()
O.run(1, True)
step1 = counts()
log("step 1: ss contacts %d, bonded %d, soil-rig contacts %d; setCohesionNow now %s" % (step1 + (ip2.setCohesionNow,)))
O.run(n_steps - 1, True)
wall = time.time() - t0
data = {k: np.array(v) for k, v in rec.items()}
data.update(step1_c_ss=np.int64(step1[0]), step1_coh_ss=np.int64(step1[1]), step1_c_sf=np.int64(step1[2]),
            wall_s=np.float64(wall), n_steps=np.int64(n_steps), yade_version=np.array(str(yade.config.version)),
            perturb=np.float64(PERTURB), seed=np.int64(SEED), world=np.int64(WORLD), dt=np.float64(dt),
            interval=np.int64(interval), clump_mass=clump_mass, plate_mass=np.float64(plate.state.mass))
np.savez_compressed(OUT, **data)
log("wall %.1f s for %d steps (%d records, %.2f us per sphere-step); wrote %s" % (
    wall, n_steps, len(rec["step"]), 1e6 * wall / n_steps / len(radius), OUT))
