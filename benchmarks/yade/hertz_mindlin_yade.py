"""Yade 2023.02a reference for warpdem's Hertz-Mindlin law (tests/test_laws.py): FrictMat,
Ip2_FrictMat_FrictMat_MindlinPhys and Law2_ScGeom_MindlinPhys_Mindlin with their defaults (no damping, adhesion or
moments), Ig2_Sphere_Sphere_ScGeom and Ig2_Facet_Sphere_ScGeom, NewtonIntegrator.

    yade -n -x benchmarks/yade/hertz_mindlin_yade.py     # writes benchmarks/yade/hertz_mindlin_yade.npz

Scenes (no gravity in the collisions):
1. ``head``: two equal spheres (R = 10 mm, E = 100 MPa, v = 0.3, rho = 2600 kg/m^3, phi = 20 deg) meeting head on
   at a relative speed of 1 m/s, dt = 2 us; every step: the centre distance, both velocities, the force on sphere 2,
   the normal force.
2. ``oblique``: the same spheres, sphere 2 coming at (-1, 0.5, 0) m/s relative (tangential over normal speed 0.5,
   more than tan(phi) = 0.36: it slides, then sticks); every step also the shear force and angular velocities.
3. ``packing``: 100 spheres (radii 4-5.5 mm, seeded, none touching) dropped from a loose lattice (4 layers of 5 x 5,
   15 mm apart) into a 70 x 70 mm box of five
   facets (each wall one large triangle, so no sphere meets a facet edge), E = 10 MPa, v = 0.3, rho = 2600,
   phi = 25 deg, local damping 0.3, dt = 20 us, 0.8 s. Recorded every 500 steps: kinetic energy, mean and max
   centre height, contacts (sphere-sphere, sphere-facet), the mean sphere-sphere normal force, the vertical force on
   the box (its five facets). Run five times: the lattice as given and four times with each centre moved by a
   random 1 nm, so that the spread of the statistics between the runs (chaos) sets the tolerance of the comparison.
"""

import numpy as np
from yade import utils

OUT = "benchmarks/yade/hertz_mindlin_yade.npz"
R = 0.01
COLL = dict(young=1e8, poisson=0.3, density=2600.0, friction_deg=20.0, dt=2e-6, steps=700)
PACK = dict(young=1e7, poisson=0.3, density=2600.0, friction_deg=25.0, damping=0.3, dt=2e-5, steps=40000,
            every=500, box=0.07, n=100, rmin=0.004, rmax=0.0055, seed=7)
out = {}


def engines(damping: float, gravity: tuple) -> list:
    return [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_MindlinPhys()],
                        [Law2_ScGeom_MindlinPhys_Mindlin()]),
        NewtonIntegrator(damping=damping, gravity=gravity),
    ]


def collision(name: str, v_rel: tuple) -> None:
    O.reset()
    mat = O.materials.append(FrictMat(young=COLL["young"], poisson=COLL["poisson"], density=COLL["density"],
                                      frictionAngle=np.radians(COLL["friction_deg"])))
    gap = 1e-5
    a = O.bodies.append(utils.sphere((0, 0, 0), R, material=mat))
    b = O.bodies.append(utils.sphere((2 * R + gap, 0, 0), R, material=mat))
    O.bodies[a].state.vel = tuple(-0.5 * np.array(v_rel))
    O.bodies[b].state.vel = tuple(0.5 * np.array(v_rel))
    O.engines = engines(0.0, (0, 0, 0))
    O.dt = COLL["dt"]
    rec = {k: [] for k in ("pos1", "pos2", "vel1", "vel2", "angvel1", "angvel2", "force2", "fn", "fs", "un")}
    for _ in range(COLL["steps"]):
        O.step()
        s1, s2 = O.bodies[a].state, O.bodies[b].state
        rec["pos1"].append(tuple(s1.pos))
        rec["pos2"].append(tuple(s2.pos))
        rec["vel1"].append(tuple(s1.vel))
        rec["vel2"].append(tuple(s2.vel))
        rec["angvel1"].append(tuple(s1.angVel))
        rec["angvel2"].append(tuple(s2.angVel))
        rec["force2"].append(tuple(O.forces.f(b)))
        i = O.interactions[a, b] if O.interactions.has(a, b) else None
        real = i is not None and i.isReal
        rec["fn"].append(i.phys.normalForce.norm() if real else 0.0)
        rec["fs"].append(tuple(i.phys.shearForce) if real else (0.0, 0.0, 0.0))
        rec["un"].append(i.geom.penetrationDepth if real else np.nan)
        if real and f"{name}_kno" not in out:
            out[f"{name}_kno"], out[f"{name}_kso"] = np.array(i.phys.kno), np.array(i.phys.kso)
    for k, v in rec.items():
        out[f"{name}_{k}"] = np.array(v)
    out[f"{name}_v_rel"] = np.array(v_rel)
    mass = O.bodies[a].state.mass
    out[f"{name}_mass"] = np.array(mass)
    print(name, "mass", mass, "peak fn", max(rec["fn"]), "contact steps", int(np.sum(np.array(rec["fn"]) > 0)))


def packing_layout() -> tuple:
    rng = np.random.default_rng(PACK["seed"])
    n, box = PACK["n"], PACK["box"]
    radii = rng.uniform(PACK["rmin"], PACK["rmax"], n)
    side = 5
    pitch = box / side
    centres = []
    for k in range(n):
        layer, rest = divmod(k, side * side)
        ix, iy = divmod(rest, side)
        jitter = rng.uniform(-0.1, 0.1, 2) * pitch
        centres.append(((ix + 0.5) * pitch + jitter[0], (iy + 0.5) * pitch + jitter[1], 0.008 + layer * 0.015))
    centres = np.array(centres)
    gaps = np.linalg.norm(centres[:, None] - centres[None], axis=2) - radii[:, None] - radii[None]
    assert np.all(gaps[~np.eye(n, dtype=bool)] > 0), "spheres overlap at the start"
    assert np.all(centres[:, :2] - radii[:, None] > 0) and np.all(centres[:, :2] + radii[:, None] < box)
    assert np.all(centres[:, 2] - radii > 0), "a sphere overlaps the floor at the start"
    return centres, radii


def box_triangles() -> list:
    """Five large triangles: the floor z = 0 and the walls x = 0, x = L, y = 0, y = L, each covering the box side."""
    L, big = PACK["box"], 10 * PACK["box"]
    return [
        [(-big, -big, 0), (3 * big, -big, 0), (-big, 3 * big, 0)],
        [(0, -big, -big), (0, 3 * big, -big), (0, -big, 3 * big)],
        [(L, -big, -big), (L, 3 * big, -big), (L, -big, 3 * big)],
        [(-big, 0, -big), (3 * big, 0, -big), (-big, 0, 3 * big)],
        [(-big, L, -big), (3 * big, L, -big), (-big, L, 3 * big)],
    ]


def packing(run: int, centres: np.ndarray, radii: np.ndarray) -> dict:
    O.reset()
    mat = O.materials.append(FrictMat(young=PACK["young"], poisson=PACK["poisson"], density=PACK["density"],
                                      frictionAngle=np.radians(PACK["friction_deg"])))
    facets = [O.bodies.append(utils.facet(t, material=mat)) for t in box_triangles()]
    ids = [O.bodies.append(utils.sphere(tuple(c), r, material=mat)) for c, r in zip(centres, radii)]
    O.engines = engines(PACK["damping"], (0, 0, -9.81))
    O.dt = PACK["dt"]
    rec = {k: [] for k in ("time", "ke", "z_mean", "z_max", "n_ss", "n_sf", "fn_ss_mean", "box_fz")}
    for _ in range(PACK["steps"] // PACK["every"]):
        O.run(PACK["every"], True)
        z = np.array([O.bodies[i].state.pos[2] for i in ids])
        ke = sum(0.5 * O.bodies[i].state.mass * O.bodies[i].state.vel.squaredNorm()
                 + 0.5 * O.bodies[i].state.inertia[0] * O.bodies[i].state.angVel.squaredNorm() for i in ids)
        n_ss = n_sf = 0
        fn_ss = []
        for i in O.interactions:
            if not i.isReal:
                continue
            if i.id1 in facets or i.id2 in facets:
                n_sf += 1
            else:
                n_ss += 1
                fn_ss.append(i.phys.normalForce.norm())
        rec["time"].append(O.time)
        rec["ke"].append(ke)
        rec["z_mean"].append(z.mean())
        rec["z_max"].append(z.max())
        rec["n_ss"].append(n_ss)
        rec["n_sf"].append(n_sf)
        rec["fn_ss_mean"].append(np.mean(fn_ss) if fn_ss else 0.0)
        rec["box_fz"].append(sum(O.forces.f(f)[2] for f in facets))
    print("packing", run, {k: v[-1] for k, v in rec.items()})
    return {k: np.array(v) for k, v in rec.items()}


def facet_pair() -> None:
    """One sphere (R = 10 mm) pressed 0.1 mm into a facet (material of the collisions), one step: the pair
    physics of a sphere-facet contact (Yade's facet radius 2R), the tangent stiffnesses the law stores and the step
    GlobalStiffnessTimeStepper (safety 0.8) takes from them."""
    O.reset()
    mat = O.materials.append(FrictMat(young=COLL["young"], poisson=COLL["poisson"], density=COLL["density"],
                                      frictionAngle=np.radians(COLL["friction_deg"])))
    f = O.bodies.append(utils.facet([(-1, -1, 0), (1, -1, 0), (0, 1, 0)], material=mat))
    s = O.bodies.append(utils.sphere((0, 0, R - 1e-4), R, material=mat))
    O.engines = engines(0.0, (0, 0, 0))
    O.engines = O.engines[:-1] + [GlobalStiffnessTimeStepper(timestepSafetyCoefficient=0.8, timeStepUpdateInterval=1,
                                                              active=True)] + O.engines[-1:]
    O.dt = COLL["dt"]
    O.step()
    out["facet_gsts_dt"] = np.array(O.dt)  # GlobalStiffnessTimeStepper's step from this step's contact stiffness
    i = O.interactions[f, s]
    for k in ("kno", "kso", "kn", "ks"):
        out[f"facet_{k}"] = np.array(getattr(i.phys, k))
    out["facet_fn"] = np.array(i.phys.normalForce.norm())
    out["facet_un"] = np.array(i.geom.penetrationDepth)
    print("facet", {k: float(out[f"facet_{k}"]) for k in ("kno", "kso", "kn", "ks", "fn", "un", "gsts_dt")})


facet_pair()
collision("head", (-1.0, 0.0, 0.0))
collision("oblique", (-1.0, 0.5, 0.0))
for k, v in COLL.items():
    out[f"coll_{k}"] = np.array(v)
out["coll_radius"] = np.array(R)

centres, radii = packing_layout()
out["pack_centres"] = centres
out["pack_radii"] = radii
out["pack_triangles"] = np.array(box_triangles(), dtype=float)
for k, v in PACK.items():
    out[f"pack_{k}"] = np.array(v)
rng = np.random.default_rng(123)
runs = [packing(0, centres, radii)]
for run in (1, 2, 3, 4):
    runs.append(packing(run, centres + rng.normal(0.0, 1e-9, centres.shape), radii))
for k in runs[0]:
    out[f"pack_{k}"] = np.stack([r[k] for r in runs])
np.savez_compressed(OUT, **out)
print("wrote", OUT)
