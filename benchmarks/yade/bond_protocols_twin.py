"""Yade 2023.02a runs of the bed's bond protocols, the reference for warpdem's (tests/test_bond_protocols.py).

Run from the repository root:

    yade -n -x benchmarks/yade/bond_protocols_twin.py            # -> bond_protocols_yade.npz / .log
    BOND_TWIN_BED=A_dense BOND_TWIN_PROTOCOLS=touch,settled,ductile BOND_TWIN_REALIZATIONS=4 \
        yade -n -x benchmarks/yade/bond_protocols_twin.py        # -> bond_protocols_yade_A_dense.npz / .log

``BOND_TWIN_BED``: the spec ``soil_bin_twin_spec_<BED>.npz`` (default A; A_dense: the bed deposited without
friction, ``soil_bin_twin_export.py A --deposit-friction 0``); another bed than A runs part 2 only.
``BOND_TWIN_PROTOCOLS``, ``BOND_TWIN_REALIZATIONS``: a subset of the protocols, fewer realizations.

Two parts:

1. **Two spheres** (pairs): a fixed and a free sphere of radius 7 mm (CohFrictMat E = 1e7 Pa, ks/kn = 0.3,
   normalCohesion = shearCohesion = 1e5 Pa, no gravity) at centre distances from 0.98 to 1.3 times the sum of radii,
   bonded in the first step with ``interactionDetectionFactor`` = ``aabbEnlargeFactor`` = 1.5, fragile or not.
   Recorded per distance: whether the interaction exists after the first step, its normal force and plastic
   displacement ``unp``, and whether it is cohesive. This is the rule of distance bonding in 2023.02a's
   CohFrictPhys: the bond starts with unp = 0, so a gap g is a tension kn g at once (fragile: deleted when
   kn g > normalAdhesion; not fragile: yields, and with the default unpMax = 0 is deleted too).
2. **The ci bed** (assembly A, 681 spheres, GA set 11, the bin's 10 facets, no tool) of
   ``soil_bin_twin_spec_A.npz`` (the bed ``run_soil_bin`` builds, exported by soil_bin_twin_export.py), each
   protocol for ``RUN_STEPS`` steps after its bonding step, with no local damping (the soil bin's):

   - ``touch``: bonds on the first step's contacts (setCohesionNow; the soil bin's default);
   - ``distance``: the same with both detection factors DETECTION for the bonding step, then 1;
   - ``new``: bonds on the first step's contacts and on every new one (setCohesionOnNewContacts);
   - ``settled``: SETTLE_STEPS steps under gravity without bonds, NewtonIntegrator damping SETTLE_DAMPING (warpdem's
     ``SoilBinConfig.settle_time``), then bonds on that moment's contacts and damping 0;
   - ``settled_distance``: settled, then bonded with the detection factors DETECTION for one step;
   - ``ductile``: ``touch`` with bonds that yield instead of breaking (CohFrictMat fragile=False; unpMax 0).

   Each protocol on REALIZATIONS realizations of the bed (below). Recorded every RECORD steps from the bonding step (the first record is after the bonding step): real
   sphere-sphere interactions ``<protocol>_c_ss``, those still cohesive ``<protocol>_coh_ss``, the kinetic energy
   ``<protocol>_ke`` [J] (each (realization, record)); at the bonding step of realization 0 the gaps [m] of the bonds
   whose spheres do not touch (``<protocol>_bond_gaps``). The collider is forced to run at the
   bonding step (``InsertionSortCollider.verletDist`` = 0 throughout: it runs every step), so enlarged bounds find
   every pair.
"""
import os
import sys
import time

import numpy as np
import yade
from yade import utils
from yade.wrapper import *  # noqa: F401,F403

HERE = os.path.dirname(os.path.abspath(sys.argv[0]))
BED = os.environ.get("BOND_TWIN_BED", "A")
STEM = "bond_protocols_yade" + ("" if BED == "A" else "_" + BED)
OUT = os.path.join(HERE, STEM + ".npz")
LOG = open(os.path.join(HERE, STEM + ".log"), "w")
DETECTION = 1.5
RUN_STEPS = 3000
RECORD = 100
SETTLE_STEPS = 12000
SETTLE_DAMPING = 0.4
PAIR_RADIUS = 0.007
PAIR_RATIOS = np.array([0.98, 0.999, 1.0005, 1.001, 1.002, 1.01, 1.1, 1.3])
PROTOCOLS = tuple(os.environ.get("BOND_TWIN_PROTOCOLS", "touch,distance,new,settled,settled_distance,ductile")
                  .split(","))
REALIZATIONS = int(os.environ.get("BOND_TWIN_REALIZATIONS", "8"))
PERTURB = 1e-9
"""realization 0 is the bed as exported; realization s > 0 displaces every sphere by a uniform random vector in
[-PERTURB, PERTURB]^3 m (numpy's default_rng(s)): another realization of the same bed, whose chaotic run shows the
spread of a count at the end (warpdem's compare draws its own realizations the same way)."""


def log(*a):
    s = " ".join(str(x) for x in a)
    print(s)
    LOG.write(s + "\n")
    LOG.flush()


def engines(detection, new_contacts, damping, gravity):
    ip2 = Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True, setCohesionOnNewContacts=new_contacts,
                                                   label="ip2")
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=detection, label="bo1"), Bo1_Facet_Aabb()],
                              verletDist=0, label="collider"),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D(interactionDetectionFactor=detection, label="ig2"),
                         Ig2_Facet_Sphere_ScGeom6D()], [ip2],
                        [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True,
                                                                   always_use_moment_law=True)]),
        NewtonIntegrator(gravity=gravity, damping=damping, label="newton"),
    ]


def detection_off():
    bo1.aabbEnlargeFactor = 1.0
    ig2.interactionDetectionFactor = 1.0


def pairs():
    out = {}
    for fragile in (True, False):
        rows = []
        for ratio in PAIR_RATIOS:
            O.reset()
            m = O.materials.append(CohFrictMat(young=1e7, poisson=0.3, frictionAngle=0.5, density=2600,
                                               normalCohesion=1e5, shearCohesion=1e5, momentRotationLaw=True,
                                               isCohesive=True, fragile=fragile))
            d = ratio * 2 * PAIR_RADIUS
            O.bodies.append([utils.sphere((0, 0, 0), PAIR_RADIUS, material=m, fixed=True),
                             utils.sphere((0, 0, d), PAIR_RADIUS, material=m)])
            engines(DETECTION, False, 0.0, (0, 0, 0))
            O.dt = 1e-7
            O.step()
            real = [i for i in O.interactions if i.isReal]
            if real:
                p = real[0].phys
                rows.append((ratio, 1, p.normalForce[2], p.unp, 0 if p.cohesionBroken else 1, p.kn,
                             p.normalAdhesion))
            else:
                rows.append((ratio, 0, 0.0, 0.0, 0, 0.0, 0.0))
            log("pair fragile", fragile, "ratio", ratio, "->", rows[-1])
        out["pairs_fragile" if fragile else "pairs_ductile"] = np.array(rows)
    out["pair_ratios"] = PAIR_RATIOS
    out["pair_columns"] = np.array("ratio exists fn_z unp cohesive kn normal_adhesion".split())
    return out


SPEC = {k: v for k, v in np.load(os.path.join(HERE, f"soil_bin_twin_spec_{BED}.npz")).items()}


def soil_material(fragile=True):
    g = lambda k: float(SPEC["soil_" + k + "_f32"])  # noqa: E731 - the float32 values warpdem's kernels read
    return CohFrictMat(young=g("young"), poisson=g("poisson"), density=float(SPEC["soil_density"]),
                       frictionAngle=g("friction_angle_rad"), normalCohesion=g("normal_cohesion"),
                       shearCohesion=g("shear_cohesion"), etaRoll=g("eta_roll"), etaTwist=g("eta_twist"),
                       alphaKr=g("alpha_kr"), alphaKtw=g("alpha_ktw"), momentRotationLaw=True, fragile=fragile,
                       isCohesive=True)


def wall_material():
    g = lambda k: float(SPEC["tool_" + k + "_f32"])  # noqa: E731
    return CohFrictMat(young=g("young"), poisson=g("poisson"), density=float(SPEC["tool_density"]),
                       frictionAngle=g("friction_angle_rad"), normalCohesion=0.0, shearCohesion=0.0,
                       etaRoll=-1.0, etaTwist=-1.0, momentRotationLaw=False, fragile=True, isCohesive=True)


def counts(n_spheres, first):
    c = coh = 0
    for i in O.interactions:
        if not i.isReal or i.id1 < first or i.id2 < first:
            continue
        c += 1
        coh += 0 if i.phys.cohesionBroken else 1
    return c, coh


def bed(protocol, seed):
    O.reset()
    wm = O.materials.append(wall_material())
    sm = O.materials.append(soil_material(fragile=protocol != "ductile"))
    for tri in SPEC["bin_tri"]:
        O.bodies.append(utils.facet([tuple(map(float, v)) for v in tri], fixed=True, material=wm))
    first = len(O.bodies)
    pos, rad = SPEC["sphere_pos"].copy(), SPEC["sphere_radius"]
    if seed > 0:
        pos += np.random.default_rng(seed).uniform(-PERTURB, PERTURB, pos.shape)
    for x, r in zip(pos, rad):
        O.bodies.append(utils.sphere(tuple(map(float, x)), float(r), material=sm))
    O.dt = float(SPEC["dt"])
    gravity = tuple(float(g) for g in SPEC["gravity"])
    settled = protocol.startswith("settled")
    detection = DETECTION if protocol.endswith("distance") else 1.0
    engines(1.0 if settled else detection, protocol == "new", SETTLE_DAMPING if settled else 0.0, gravity)
    if settled:
        ip2.setCohesionNow = False
        O.run(SETTLE_STEPS, True)
        log(protocol, "settled", SETTLE_STEPS, "steps: contacts", counts(len(rad), first)[0], "ke",
            utils.kineticEnergy())
        newton.damping = 0.0
        bo1.aabbEnlargeFactor = detection
        ig2.interactionDetectionFactor = detection
        ip2.setCohesionNow = True
    n0 = collider.numAction
    O.step()  # the bonding step
    ran = collider.numAction - n0
    detection_off()
    gaps = []
    for i in O.interactions:
        if i.isReal and i.id1 >= first and i.id2 >= first and not i.phys.cohesionBroken:
            if i.geom.penetrationDepth < 0:
                gaps.append(-i.geom.penetrationDepth)
    rec = [(O.iter, *counts(len(rad), first), utils.kineticEnergy())]
    log(protocol, "realization", seed, "bonding step", O.iter, "collider ran", ran, "c_ss, coh_ss", rec[0][1:3], "bonds with a gap",
        len(gaps), "largest gap", max(gaps) if gaps else 0.0)
    t0 = time.time()
    for _ in range(RUN_STEPS // RECORD):
        O.run(RECORD, True)
        rec.append((O.iter, *counts(len(rad), first), utils.kineticEnergy()))
    log(protocol, "end", rec[-1], "wall", round(time.time() - t0, 1), "s")
    r = np.array(rec, dtype=float)
    return r, np.array(gaps)


log("Yade", yade.config.version)
res = pairs() if BED == "A" else {}
for proto in PROTOCOLS:
    runs = [bed(proto, seed) for seed in range(REALIZATIONS)]
    recs = np.stack([r for r, _ in runs])  # (realization, record, 4)
    res.update({proto + "_step": recs[0, :, 0], proto + "_c_ss": recs[:, :, 1], proto + "_coh_ss": recs[:, :, 2],
                proto + "_ke": recs[:, :, 3], proto + "_bond_gaps": runs[0][1]})
res.update(yade_version=np.array(str(yade.config.version)), detection=DETECTION, run_steps=RUN_STEPS,
           record=RECORD, settle_steps=SETTLE_STEPS, settle_damping=SETTLE_DAMPING, n_spheres=len(SPEC["sphere_radius"]),
           protocols=np.array(PROTOCOLS), realizations=REALIZATIONS, perturb=PERTURB, bed=np.array(BED))
np.savez(OUT, **res)
log("wrote", OUT)
