"""Reference scene 4: 40 cohesive spheres settling in a facet box under gravity (Yade 2023.02a).

Run from the repository root:   yade -n -x tests/reference/cohesive_packing.py
Writes tests/reference/cohesive_packing.npz (next to this script).

Scene
-----
Box (all fixed facets, ids 0..9): floor z = 0 over x, y in [-0.03, 0.03] (ids 0, 1) and four vertical side walls
x = -0.03 (ids 2,3), x = +0.03 (ids 4,5), y = -0.03 (ids 6,7), y = +0.03 (ids 8,9), each 0.06 m wide, from z = 0 to
z = 0.12 m, two facets each (exact vertices in `facet_vertices`).
Facet material: CohFrictMat E=1e7 Pa, poisson 0.3, density 2700, frictionAngle 30 deg, normalCohesion=0,
shearCohesion=0, isCohesive=False, momentRotationLaw=False (etaRoll=etaTwist=-1 defaults), alphaKr=alphaKtw=2,
fragile=True.
Spheres (ids 10..49): n = 40, radii = RandomState(1).uniform(0.004, 0.006, 40); then, from the same generator,
jitter = uniform(-0.0009, 0.0009, (40,3)).  Centres: lattice x, y in {-0.021, -0.007, 0.007, 0.021} (16 per layer),
layers z = 0.012, 0.032, 0.052 (16, 16, 8 spheres, filled x fastest, then y, then z), plus jitter.  Spacing 0.014 m
> 0.012 + 2*0.0009 so nothing overlaps, and nothing touches a wall.  Zero initial velocities.
Sphere material: CohFrictMat E=1e7, poisson 0.3, density 2700, frictionAngle 30 deg, normalCohesion 5e3 Pa,
shearCohesion 2.5e3 Pa, fragile=True, momentRotationLaw=True, etaRoll=etaTwist=0.2, alphaKr=alphaKtw=2,
isCohesive=True.
Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=False, setCohesionOnNewContacts=True): every new
sphere-sphere contact becomes cohesive (a = C min(R1,R2)^2); sphere-facet contacts are never cohesive (facet material
isCohesive=False) and have no moment law (facet momentRotationLaw=False).
Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True, always_use_moment_law=False).
Gravity (0,0,-9.81), NewtonIntegrator damping 0.4, O.dt = 1e-5 s, 40000 steps (0.4 s).

Recording convention: PyRunner(iterPeriod=200, firstIterRun=199) after NewtonIntegrator -> after s = 200, 400, ...
completed steps; `step` = s, `time` = s*dt.  Contact counts/forces were computed during step s.

Keys (SI units; k = 200 records, n = 40 spheres)
------------------------------------------------
Inputs:
  yade_version
  facet_vertices (10,3,3) [m]  (floor = facets 0,1)
  facet_young, facet_poisson, facet_density, facet_friction_angle [rad], facet_normal_cohesion, facet_shear_cohesion,
  facet_is_cohesive, facet_moment_rotation_law, facet_fragile
  sphere_young, sphere_poisson, sphere_density, sphere_friction_angle [rad], sphere_normal_cohesion [Pa],
  sphere_shear_cohesion [Pa], sphere_eta_roll, sphere_eta_twist, sphere_alpha_kr, sphere_alpha_ktw,
  sphere_is_cohesive, sphere_moment_rotation_law, sphere_fragile
  radius (n,) [m], pos0 (n,3) [m], vel0 (n,3), sphere_mass (n,) [kg] (Yade's), seed (1), jitter (n,3) [m]
  first_sphere_id (10), floor_facet_ids (2,)
  dt, gravity (3,), damping, n_steps, record_period, set_cohesion_now, set_cohesion_on_new_contacts,
  use_incremental_form, always_use_moment_law
Histories:
  step (k,), time (k,) [s]
  pos (k,n,3) float64 [m];  vel (k,n,3) float32 [m/s] (float32 to keep the file small)
  n_ss (k,) int             real sphere-sphere interactions
  n_sf (k,) int             real sphere-facet interactions
  n_ss_cohesive (k,) int    real sphere-sphere interactions with cohesionBroken == False
  kinetic_energy (k,) [J]   utils.kineticEnergy() (translational + rotational, all bodies)
  coordination (k,)         mean coordination number Z = (2*n_ss + n_sf)/n  (a sphere-facet contact counts once,
                            for its sphere)
  coordination_ss (k,)      2*n_ss/n (sphere-sphere only)
  floor_normal_force (k,) [N]  sum over real interactions with floor facets (ids 0,1) of |phys.normalForce|
                            (compare with total weight sum(m) g = `total_weight`)
  total_weight [N]
"""
import os
import sys
import math
import numpy as np
import yade
from yade import utils
from yade.wrapper import *  # noqa

OUTDIR = os.path.dirname(os.path.abspath(sys.argv[0]))
sys.path.insert(0, OUTDIR)
from yade_cohfrict import cohfrict_engines  # noqa: E402

OUTFILE = os.path.join(OUTDIR, 'cohesive_packing.npz')

N_SPH = 40
SEED = 1
L = 0.03
H = 0.12
FACET_MAT = dict(young=1e7, poisson=0.3, density=2700.0, frictionAngle=math.radians(30.0), normalCohesion=0.0,
                 shearCohesion=0.0, isCohesive=False, momentRotationLaw=False, alphaKr=2.0, alphaKtw=2.0,
                 fragile=True)
SPH_MAT = dict(young=1e7, poisson=0.3, density=2700.0, frictionAngle=math.radians(30.0), normalCohesion=5e3,
               shearCohesion=2.5e3, fragile=True, momentRotationLaw=True, etaRoll=0.2, etaTwist=0.2, alphaKr=2.0,
               alphaKtw=2.0, isCohesive=True)
DT = 1e-5
NSTEPS = 40000
PERIOD = 200
DAMP = 0.4
GRAV = (0.0, 0.0, -9.81)

rng = np.random.RandomState(SEED)
RADII = rng.uniform(0.004, 0.006, N_SPH)
JITTER = rng.uniform(-0.0009, 0.0009, (N_SPH, 3))
lat = [-0.021, -0.007, 0.007, 0.021]
layers = [0.012, 0.032, 0.052]
grid = [(x, y, z) for z in layers for y in lat for x in lat][:N_SPH]
POS0 = np.array(grid) + JITTER


def quad(a, b, c, d):
    return [[a, b, c], [a, c, d]]


FACETS = np.array(
    quad((-L, -L, 0), (L, -L, 0), (L, L, 0), (-L, L, 0)) +
    quad((-L, -L, 0), (-L, L, 0), (-L, L, H), (-L, -L, H)) +
    quad((L, -L, 0), (L, L, 0), (L, L, H), (L, -L, H)) +
    quad((-L, -L, 0), (L, -L, 0), (L, -L, H), (-L, -L, H)) +
    quad((-L, L, 0), (L, L, 0), (L, L, H), (-L, L, H)), dtype=float)
FIRST = len(FACETS)
FLOOR = (0, 1)

# sanity: no initial overlaps, nothing touching walls
for i in range(N_SPH):
    assert np.all(np.abs(POS0[i, :2]) + RADII[i] < L) and POS0[i, 2] - RADII[i] > 0
    for j in range(i):
        assert np.linalg.norm(POS0[i] - POS0[j]) > RADII[i] + RADII[j]

O.reset()
fm = O.materials.append(CohFrictMat(label='facetmat', **FACET_MAT))
sm = O.materials.append(CohFrictMat(label='spheremat', **SPH_MAT))
for f in FACETS:
    O.bodies.append(utils.facet([tuple(v) for v in f], fixed=True, material=fm))
ids = [O.bodies.append(utils.sphere(tuple(p), r, material=sm)) for p, r in zip(POS0, RADII)]
assert ids[0] == FIRST and ids[-1] == FIRST + N_SPH - 1
O.engines = cohfrict_engines(gravity=GRAV, damping=DAMP, period=PERIOD, cohesion_on_new_contacts=True)
O.dt = DT

rec = {k: [] for k in ['step', 'time', 'pos', 'vel', 'n_ss', 'n_sf', 'n_ss_cohesive', 'kinetic_energy',
                       'floor_normal_force']}


def record():
    s = O.iter + 1
    rec['step'].append(s)
    rec['time'].append(s * DT)
    rec['pos'].append([list(O.bodies[i].state.pos) for i in ids])
    rec['vel'].append([list(O.bodies[i].state.vel) for i in ids])
    nss = nsf = ncoh = 0
    ffloor = 0.0
    for I in O.interactions:
        if not I.isReal:
            continue
        if I.id1 >= FIRST and I.id2 >= FIRST:
            nss += 1
            if not I.phys.cohesionBroken:
                ncoh += 1
        else:
            nsf += 1
            if I.id1 in FLOOR or I.id2 in FLOOR:
                ffloor += I.phys.normalForce.norm()
    rec['n_ss'].append(nss)
    rec['n_sf'].append(nsf)
    rec['n_ss_cohesive'].append(ncoh)
    rec['kinetic_energy'].append(utils.kineticEnergy())
    rec['floor_normal_force'].append(ffloor)


O.run(NSTEPS, True)

data = {k: np.array(v) for k, v in rec.items()}
data['vel'] = data['vel'].astype(np.float32)
for k in ['step', 'n_ss', 'n_sf', 'n_ss_cohesive']:
    data[k] = data[k].astype(np.int64)
data['coordination'] = (2.0 * data['n_ss'] + data['n_sf']) / N_SPH
data['coordination_ss'] = 2.0 * data['n_ss'] / N_SPH
masses = np.array([O.bodies[i].state.mass for i in ids])
data.update(
    yade_version=np.array(str(yade.config.version)), facet_vertices=FACETS,
    facet_young=np.float64(FACET_MAT['young']), facet_poisson=np.float64(FACET_MAT['poisson']),
    facet_density=np.float64(FACET_MAT['density']), facet_friction_angle=np.float64(FACET_MAT['frictionAngle']),
    facet_normal_cohesion=np.float64(0.0), facet_shear_cohesion=np.float64(0.0), facet_is_cohesive=np.bool_(False),
    facet_moment_rotation_law=np.bool_(False), facet_fragile=np.bool_(True),
    sphere_young=np.float64(SPH_MAT['young']), sphere_poisson=np.float64(SPH_MAT['poisson']),
    sphere_density=np.float64(SPH_MAT['density']), sphere_friction_angle=np.float64(SPH_MAT['frictionAngle']),
    sphere_normal_cohesion=np.float64(SPH_MAT['normalCohesion']),
    sphere_shear_cohesion=np.float64(SPH_MAT['shearCohesion']), sphere_eta_roll=np.float64(SPH_MAT['etaRoll']),
    sphere_eta_twist=np.float64(SPH_MAT['etaTwist']), sphere_alpha_kr=np.float64(SPH_MAT['alphaKr']),
    sphere_alpha_ktw=np.float64(SPH_MAT['alphaKtw']), sphere_is_cohesive=np.bool_(True),
    sphere_moment_rotation_law=np.bool_(True), sphere_fragile=np.bool_(True),
    radius=RADII, pos0=POS0, vel0=np.zeros((N_SPH, 3)), sphere_mass=masses, seed=np.int64(SEED), jitter=JITTER,
    first_sphere_id=np.int64(FIRST), floor_facet_ids=np.array(FLOOR, dtype=np.int64),
    dt=np.float64(DT), gravity=np.array(GRAV), damping=np.float64(DAMP), n_steps=np.int64(NSTEPS),
    record_period=np.int64(PERIOD), set_cohesion_now=np.bool_(False), set_cohesion_on_new_contacts=np.bool_(True),
    use_incremental_form=np.bool_(True), always_use_moment_law=np.bool_(False),
    total_weight=np.float64(masses.sum() * 9.81),
)
np.savez_compressed(OUTFILE, **data)
for i in range(0, len(data['step']), 20):
    print('t=%.3f KE=%.3e n_ss=%d (coh %d) n_sf=%d Z=%.2f Ffloor=%.4f (W=%.4f) zmax=%.4f' % (
        data['time'][i], data['kinetic_energy'][i], data['n_ss'][i], data['n_ss_cohesive'][i], data['n_sf'][i],
        data['coordination'][i], data['floor_normal_force'][i], data['total_weight'],
        (data['pos'][i, :, 2] + RADII).max()))
i = -1
print('final: KE=%.3e n_ss=%d (coh %d) n_sf=%d Z=%.2f Ffloor=%.4f' % (
    data['kinetic_energy'][i], data['n_ss'][i], data['n_ss_cohesive'][i], data['n_sf'][i], data['coordination'][i],
    data['floor_normal_force'][i]))
print('wrote', OUTFILE, os.path.getsize(OUTFILE), 'bytes')
