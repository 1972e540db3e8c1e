"""Reference scene 2: a non-rotating sphere sliding (or sticking) on an inclined plane of two facets (Yade 2023.02a).

Run from the repository root:   yade -n -x tests/reference/facet_slide.py
Writes tests/reference/facet_slide.npz (next to this script).

Scene
-----
Plane: 1 m x 1 m square, centred at the origin, tilted by theta = 30 deg about the y axis so that it descends
along +x.  Upward unit normal n = (sin30, 0, cos30); in-plane unit vectors e1 = (cos30, 0, -sin30) (downslope) and
e2 = (0, 1, 0).  Corners c(a,b) = a*0.5*e1 + b*0.5*e2.  Two fixed facets (utils.facet, fixed=True):
    facet 0: c(-,-), c(+,-), c(+,+)      facet 1: c(-,-), c(+,+), c(-,+)     (diagonal c(-,-)--c(+,+))
Facet material: CohFrictMat E=1e7 Pa, poisson 0.3, density 2700, frictionAngle 40 deg, normalCohesion=0,
shearCohesion=0, isCohesive=False, momentRotationLaw=False (etaRoll=etaTwist=-1 defaults, alphaKr=alphaKtw=2).
Sphere: r = 0.01 m, CohFrictMat E=1e7, poisson 0.3, density 2700, frictionAngle 20 deg (main run) or 35 deg
('stick_' run), normalCohesion=shearCohesion=0, isCohesive=False, momentRotationLaw=False, alphaKr=alphaKtw=2.
blockedDOFs='XYZ' (rotations blocked, angVel = 0), so the sphere slides.
Initial sphere centre: in-plane point u = 0 (along e1), v = -0.25 (along e2) -> inside facet 0, 0.177 m from the
diagonal and 0.25 m from the nearest outer edge; centre = u*e1 + v*e2 + r*n (zero initial overlap), v0 = 0.
Gravity (0,0,-9.81), NewtonIntegrator damping 0, O.dt = 1e-5 s, 20000 steps (0.2 s).
Engines as in cohesive_pair.py: Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=False,
setCohesionOnNewContacts=False), Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True,
always_use_moment_law=False).  Expected: friction coefficient of the contact = tan(min(20,40)) = tan20 < tan30 -> slides
with a = g(sin30 - tan20 cos30) = 1.813 m/s^2 along e1;  stick run tan35 > tan30 -> sticks.
Facet bodies are ids 0 and 1, the sphere id 2.  In every facet-sphere interaction Yade puts the facet as id1.

Recording convention: PyRunner(iterPeriod=100, firstIterRun=99) after NewtonIntegrator -> records after s = 100, 200,
... completed steps; `step` = s, `time` = s*dt.  pos/vel are after the integration of step s; forces and contact data
were computed during step s from the configuration at time (s-1)*dt.

Keys (SI units; k = 200 records; prefix p in {'', 'stick_'})
-----------------------------------------------------------
Inputs:
  yade_version str; theta [rad]; plane_normal (3,); plane_e1 (3,); plane_e2 (3,)
  facet_vertices (2,3,3) [m]  global vertex coordinates, facet index, vertex index, xyz (ids 0 and 1)
  facet_body_pos (2,3) [m]    Yade's facet body positions (informative; vertices are what matters)
  facet_young, facet_poisson, facet_density, facet_friction_angle [rad], facet_normal_cohesion, facet_shear_cohesion,
  facet_is_cohesive (bool), facet_moment_rotation_law (bool)
  sphere_radius [m], sphere_pos0 (3,) [m], sphere_vel0 (3,), sphere_blocked_dofs str 'XYZ',
  sphere_young, sphere_poisson, sphere_density, sphere_is_cohesive, sphere_moment_rotation_law, sphere_mass [kg]
  sphere_friction_angle [rad] (main run), stick_sphere_friction_angle [rad]
  dt, gravity (3,), damping, n_steps, record_period, set_cohesion_now, set_cohesion_on_new_contacts,
  use_incremental_form, always_use_moment_law
Per run p:
  p+step (k,) int, p+time (k,) [s]
  p+pos (k,3) [m], p+vel (k,3) [m/s]      sphere state
  p+force (k,3) [N]                       O.forces.f(sphere) (contact forces only; gravity is added by NewtonIntegrator
                                          and is NOT in O.forces)
  p+contact_exists (k,2) bool             interaction (facet j, sphere) exists and is real, j = 0, 1
  p+normal_force (k,2,3) [N], p+shear_force (k,2,3) [N], p+penetration_depth (k,2) [m],
  p+contact_normal (k,2,3), p+contact_point (k,2,3)   per facet j; NaN where no contact
  p+kn, p+ks (2,) [N/m], p+tan_friction (2,)   contact stiffness/friction of the facet-j contact (first time seen;
                                          NaN if never in contact)
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

OUTFILE = os.path.join(OUTDIR, 'facet_slide.npz')

THETA = math.radians(30.0)
N = np.array([math.sin(THETA), 0.0, math.cos(THETA)])
E1 = np.array([math.cos(THETA), 0.0, -math.sin(THETA)])
E2 = np.array([0.0, 1.0, 0.0])


def corner(a, b):
    return 0.5 * a * E1 + 0.5 * b * E2


FACETS = np.array([[corner(-1, -1), corner(1, -1), corner(1, 1)],
                   [corner(-1, -1), corner(1, 1), corner(-1, 1)]])
R = 0.01
U0, V0 = 0.0, -0.25
POS0 = U0 * E1 + V0 * E2 + R * N
FACET_MAT = dict(young=1e7, poisson=0.3, density=2700.0, frictionAngle=math.radians(40.0), normalCohesion=0.0,
                 shearCohesion=0.0, isCohesive=False, momentRotationLaw=False, alphaKr=2.0, alphaKtw=2.0)
SPHERE_MAT = dict(young=1e7, poisson=0.3, density=2700.0, normalCohesion=0.0, shearCohesion=0.0, isCohesive=False,
                  momentRotationLaw=False, alphaKr=2.0, alphaKtw=2.0)
PHI_SLIDE = math.radians(20.0)
PHI_STICK = math.radians(35.0)
DT = 1e-5
NSTEPS = 20000
PERIOD = 100
GRAV = (0.0, 0.0, -9.81)

rec = None
SID = 2


def build(phi):
    O.reset()
    fm = O.materials.append(CohFrictMat(label='facetmat', **FACET_MAT))
    sm = O.materials.append(CohFrictMat(label='spheremat', frictionAngle=phi, **SPHERE_MAT))
    for f in FACETS:
        O.bodies.append(utils.facet([tuple(v) for v in f], fixed=True, material=fm))
    s = utils.sphere(tuple(POS0), R, material=sm)
    s.state.blockedDOFs = 'XYZ'
    sid = O.bodies.append(s)
    assert sid == SID
    O.engines = cohfrict_engines(gravity=GRAV, damping=0.0, period=PERIOD)
    O.dt = DT


def record():
    s = O.iter + 1
    b = O.bodies[SID]
    rec['step'].append(s)
    rec['time'].append(s * DT)
    rec['pos'].append(list(b.state.pos))
    rec['vel'].append(list(b.state.vel))
    rec['force'].append(list(O.forces.f(SID)))
    ex, fn, fs, pd, cn, cp = [], [], [], [], [], []
    for j in range(2):
        ok = O.interactions.has(j, SID) and O.interactions[j, SID].isReal
        ex.append(ok)
        if ok:
            I = O.interactions[j, SID]
            assert I.id1 == j and I.id2 == SID
            fn.append(list(I.phys.normalForce))
            fs.append(list(I.phys.shearForce))
            pd.append(I.geom.penetrationDepth)
            cn.append(list(I.geom.normal))
            cp.append(list(I.geom.contactPoint))
            if np.isnan(rec['kn'][j]):
                rec['kn'][j] = I.phys.kn
                rec['ks'][j] = I.phys.ks
                rec['tan_friction'][j] = I.phys.tangensOfFrictionAngle
        else:
            fn.append([np.nan] * 3)
            fs.append([np.nan] * 3)
            pd.append(np.nan)
            cn.append([np.nan] * 3)
            cp.append([np.nan] * 3)
    rec['contact_exists'].append(ex)
    rec['normal_force'].append(fn)
    rec['shear_force'].append(fs)
    rec['penetration_depth'].append(pd)
    rec['contact_normal'].append(cn)
    rec['contact_point'].append(cp)


def run(phi):
    global rec
    rec = {k: [] for k in ['step', 'time', 'pos', 'vel', 'force', 'contact_exists', 'normal_force', 'shear_force',
                           'penetration_depth', 'contact_normal', 'contact_point']}
    rec.update(kn=[np.nan, np.nan], ks=[np.nan, np.nan], tan_friction=[np.nan, np.nan])
    build(phi)
    O.run(NSTEPS, True)
    out = {k: np.array(v) for k, v in rec.items()}
    out['step'] = out['step'].astype(np.int64)
    out['contact_exists'] = out['contact_exists'].astype(bool)
    return out


data = dict(
    yade_version=np.array(str(yade.config.version)), theta=np.float64(THETA), plane_normal=N, plane_e1=E1,
    plane_e2=E2, facet_vertices=FACETS,
    facet_young=np.float64(FACET_MAT['young']), facet_poisson=np.float64(FACET_MAT['poisson']),
    facet_density=np.float64(FACET_MAT['density']), facet_friction_angle=np.float64(FACET_MAT['frictionAngle']),
    facet_normal_cohesion=np.float64(0.0), facet_shear_cohesion=np.float64(0.0), facet_is_cohesive=np.bool_(False),
    facet_moment_rotation_law=np.bool_(False),
    sphere_radius=np.float64(R), sphere_pos0=POS0, sphere_vel0=np.zeros(3), sphere_blocked_dofs=np.array('XYZ'),
    sphere_young=np.float64(SPHERE_MAT['young']), sphere_poisson=np.float64(SPHERE_MAT['poisson']),
    sphere_density=np.float64(SPHERE_MAT['density']), sphere_is_cohesive=np.bool_(False),
    sphere_moment_rotation_law=np.bool_(False), sphere_friction_angle=np.float64(PHI_SLIDE),
    stick_sphere_friction_angle=np.float64(PHI_STICK),
    dt=np.float64(DT), gravity=np.array(GRAV), damping=np.float64(0.0), n_steps=np.int64(NSTEPS),
    record_period=np.int64(PERIOD), set_cohesion_now=np.bool_(False), set_cohesion_on_new_contacts=np.bool_(False),
    use_incremental_form=np.bool_(True), always_use_moment_law=np.bool_(False),
)
for prefix, phi in [('', PHI_SLIDE), ('stick_', PHI_STICK)]:
    out = run(phi)
    for k, v in out.items():
        data[prefix + k] = v
    if prefix == '':
        data['facet_body_pos'] = np.array([list(O.bodies[j].state.pos) for j in range(2)])
        data['sphere_mass'] = np.float64(O.bodies[SID].state.mass)
    d = out['pos'][-1] - POS0
    print('%-7s final displacement along e1 %.6g m, normal %.3g, e2 %.3g; v_e1 %.6g; contacts ever: %s; kn %s ks %s' % (
        prefix or 'slide', d @ E1, d @ N, d @ E2, out['vel'][-1] @ E1, out['contact_exists'].any(axis=0),
        out['kn'], out['ks']))

np.savez_compressed(OUTFILE, **data)
print('wrote', OUTFILE, os.path.getsize(OUTFILE), 'bytes')
