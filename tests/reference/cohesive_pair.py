"""Reference scene 1: a cohesive sphere pair driven by imposed velocities (Yade 2023.02a).

Run from the repository root:   yade -n -x tests/reference/cohesive_pair.py
Writes tests/reference/cohesive_pair.npz (next to this script).

Scene
-----
Two spheres r = 0.01 m of one CohFrictMat (E=1e7 Pa, poisson=0.3 [= ks/kn ratio], density 2700 kg/m^3,
frictionAngle 30 deg, normalCohesion 2e4 Pa, shearCohesion 1e4 Pa, momentRotationLaw=True,
etaRoll=etaTwist=0.1, alphaKr=alphaKtw=2, fragile=True, isCohesive=True).
Body 0 ("sphere 1") at (0,0,0), blockedDOFs='xyzXYZ', v = w = 0.
Body 1 ("sphere 2") at (0.0199,0,0) (overlap 1e-4 m), blockedDOFs='xyzXYZ', imposed
v = (0.01, 0.002, 0) m/s and angVel = (0, 0.3, 0.5) rad/s (kept constant by NewtonIntegrator because all DOFs are
blocked; the body's position and orientation still advance: x += v dt).
No gravity, NewtonIntegrator damping 0, O.dt = 1e-6 s fixed.
Engines: ForceResetter, InsertionSortCollider([Bo1_Sphere_Aabb, Bo1_Facet_Aabb]),
InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D, Ig2_Facet_Sphere_ScGeom6D],
[Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True, setCohesionOnNewContacts=False)],
[Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True, always_use_moment_law=...)]),
NewtonIntegrator, PyRunner (recorder).

How the contact and its cohesion are created: nothing is created by hand.  ip2.setCohesionNow=True is set before
the first step; in the first step (O.iter == 0) the collider finds the overlapping pair, Ig2 creates the ScGeom6D and
Ip2 creates the CohFrictPhys *with cohesion* (normalAdhesion = 2e4*0.01^2 = 2 N, cohesionBroken=False), and the law
acts in that same step.  Yade resets setCohesionNow to False itself at the next step (iteration 1).
`cohesion_set_iter` = 0 records this.

Runs (one npz, three key prefixes):
  ''            main run: fragile=True, always_use_moment_law=True. Runs until the interaction disappears, then
                1000 more steps (cap 20000 steps).
  'noalways_'   same but always_use_moment_law=False (moments are only computed while cohesionBroken is False).
  'nonfragile_' fragile=False (material flag, so CohFrictPhys.fragile=False), always_use_moment_law=False, and
                phys.unpMax set explicitly to -1 (no limit on plastic normal displacement) right after the first
                step.  NOTE: Yade's default CohFrictPhys.unpMax is 0, not -1, and Ip2 does not change it; with 0 a
                non-fragile contact is deleted at the first tensile yield (see README).  Runs 20000 steps.
                `nonfragile_unpmax0_break_step` records when the contact is deleted if unpMax is left at 0.

Recording convention: PyRunner(iterPeriod=50, firstIterRun=49) placed after NewtonIntegrator, so it fires inside
steps with O.iter = 49, 99, ... i.e. after s = 50, 100, ... completed steps.  `step` = s, `time` = s*dt.
Positions/velocities are those AFTER the integration of step s (time s*dt).  Contact quantities (normalForce, ...)
and O.forces are those computed DURING step s, i.e. from the configuration at time (s-1)*dt.

Keys (all SI units; k = number of records of that run; prefix p in {'', 'noalways_', 'nonfragile_'})
-------------------------------------------------------------------------------------------------------
Inputs:
  yade_version                str
  radius (2,)  [m]            sphere radii, body 0 and 1
  pos0 (2,3)   [m]            initial positions
  vel0 (2,3)   [m/s]          imposed velocities
  angvel0 (2,3) [rad/s]       imposed angular velocities
  blocked_dofs                str 'xyzXYZ' (both bodies)
  mat_young, mat_poisson, mat_density [Pa, -, kg/m^3]   float scalars
  mat_friction_angle [rad], mat_normal_cohesion [Pa], mat_shear_cohesion [Pa]
  mat_eta_roll, mat_eta_twist, mat_alpha_kr, mat_alpha_ktw  [-]
  mat_moment_rotation_law, mat_is_cohesive  (bool scalars)
  dt [s], gravity (3,) [m/s^2], damping [-], record_period [steps], max_steps [steps], extra_steps_after_break
  set_cohesion_now, set_cohesion_on_new_contacts, use_incremental_form (bool)
  cohesion_set_iter (int)     O.iter of the step in which cohesion was assigned (0)
Per run p:
  p+fragile, p+always_use_moment_law (bool), p+unp_max (float, value set on the phys; nan = Yade default untouched)
  p+n_steps (int)             steps actually run
  p+break_step (int)          number of completed steps s such that the interaction no longer exists after step s
                              (-1 if never)
  p+cohesion_broken_step (int) first s after which phys.cohesionBroken is True while the interaction exists (-1: never)
  p+step (k,) int, p+time (k,) [s]
  p+pos (k,2,3) [m], p+vel (k,2,3) [m/s], p+angvel (k,2,3) [rad/s], p+ori (k,2,4) quaternion (w,x,y,z)
  p+exists (k,) bool          interaction (0,1) exists and is real
  p+normal_force (k,3) [N]    phys.normalForce = Fn*n, n = geom.normal (from body 0 to body 1), Fn > 0 in
                              compression.  The force applied to body 0 (id1) is -(normalForce + shearForce), to
                              body 1 (id2) +(normalForce + shearForce) (verified: force_b0 == -(Fn + Fs)).
                              Torque on body 0 = (C - x0) x force_b0 - (Mb + Mt) when the moment law is active.
  p+shear_force (k,3) [N]     phys.shearForce
  p+moment_bending (k,3), p+moment_twist (k,3) [N m]
  p+penetration_depth (k,) [m], p+normal (k,3) [-], p+contact_point (k,3) [m]   (geom, ScGeom6D)
  p+force_b0, p+torque_b0, p+force_b1, p+torque_b1 (k,3) [N], [N m]   O.forces.f / O.forces.t of bodies 0 and 1
  p+cohesion_broken (k,) float (1/0; nan if no interaction)
  p+normal_adhesion, p+shear_adhesion [N], p+kn, p+ks [N/m], p+kr, p+ktw [N m/rad],
  p+max_roll_pl, p+max_twist_pl [m], p+tan_friction (k,) [-]   phys attributes (nan when no interaction)
  nonfragile_unp (k,) [m]      phys.unp (plastic normal displacement) for the non-fragile run
All per-record phys/geom values are NaN when the interaction does not exist.
"""
import os
import sys
import math
import numpy as np
import yade
from yade import utils
from yade.wrapper import *  # noqa

OUTDIR = os.path.dirname(os.path.abspath(sys.argv[0]))  # __file__ is /usr/bin/yade under `yade -x`
sys.path.insert(0, OUTDIR)
from yade_cohfrict import cohfrict_engines  # noqa: E402

OUTFILE = os.path.join(OUTDIR, 'cohesive_pair.npz')

R = 0.01
POS0 = np.array([[0.0, 0.0, 0.0], [0.0199, 0.0, 0.0]])
VEL0 = np.array([[0.0, 0.0, 0.0], [0.01, 0.002, 0.0]])
ANGVEL0 = np.array([[0.0, 0.0, 0.0], [0.0, 0.3, 0.5]])
MAT = dict(young=1e7, poisson=0.3, density=2700.0, frictionAngle=math.radians(30.0), normalCohesion=2e4,
           shearCohesion=1e4, momentRotationLaw=True, etaRoll=0.1, etaTwist=0.1, alphaKr=2.0, alphaKtw=2.0,
           isCohesive=True)
DT = 1e-6
PERIOD = 50
MAX_STEPS = 20000
EXTRA = 1000

rec = None
mon = None


def build(fragile, always):
    O.reset()
    mat = O.materials.append(CohFrictMat(fragile=fragile, label='mat', **MAT))
    for i in range(2):
        b = utils.sphere(tuple(POS0[i]), R, material=mat)
        b.state.blockedDOFs = 'xyzXYZ'
        b.state.vel = tuple(VEL0[i])
        b.state.angVel = tuple(ANGVEL0[i])
        O.bodies.append(b)
    O.engines = cohfrict_engines(gravity=(0, 0, 0), damping=0.0, period=PERIOD, set_cohesion_now=True,
                                 always_use_moment_law=always,
                                 extra=[PyRunner(iterPeriod=1, command='monitor()', label='monitor')])
    O.dt = DT


NAN3 = [np.nan] * 3


def record():
    s = O.iter + 1
    r = rec
    r['step'].append(s)
    r['time'].append(s * DT)
    r['pos'].append([list(O.bodies[i].state.pos) for i in range(2)])
    r['vel'].append([list(O.bodies[i].state.vel) for i in range(2)])
    r['angvel'].append([list(O.bodies[i].state.angVel) for i in range(2)])
    oris = []
    for i in range(2):
        q = O.bodies[i].state.ori
        oris.append([q.w(), q.x(), q.y(), q.z()] if callable(getattr(q, 'w', None)) else [q[3], q[0], q[1], q[2]])
    r['ori'].append(oris)
    for i in range(2):
        r['force_b%d' % i].append(list(O.forces.f(i)))
        r['torque_b%d' % i].append(list(O.forces.t(i)))
    I = O.interactions[0, 1] if O.interactions.has(0, 1) else None
    ok = I is not None and I.isReal
    r['exists'].append(bool(ok))
    if ok:
        p, g = I.phys, I.geom
        r['normal_force'].append(list(p.normalForce))
        r['shear_force'].append(list(p.shearForce))
        r['moment_bending'].append(list(p.moment_bending))
        r['moment_twist'].append(list(p.moment_twist))
        r['penetration_depth'].append(g.penetrationDepth)
        r['normal'].append(list(g.normal))
        r['contact_point'].append(list(g.contactPoint))
        r['cohesion_broken'].append(1.0 if p.cohesionBroken else 0.0)
        for k, a in [('normal_adhesion', 'normalAdhesion'), ('shear_adhesion', 'shearAdhesion'), ('kn', 'kn'),
                     ('ks', 'ks'), ('kr', 'kr'), ('ktw', 'ktw'), ('max_roll_pl', 'maxRollPl'),
                     ('max_twist_pl', 'maxTwistPl'), ('tan_friction', 'tangensOfFrictionAngle'), ('unp', 'unp')]:
            r[k].append(getattr(p, a))
    else:
        for k in ['normal_force', 'shear_force', 'moment_bending', 'moment_twist', 'normal', 'contact_point']:
            r[k].append(NAN3)
        for k in ['penetration_depth', 'cohesion_broken', 'normal_adhesion', 'shear_adhesion', 'kn', 'ks', 'kr',
                  'ktw', 'max_roll_pl', 'max_twist_pl', 'tan_friction', 'unp']:
            r[k].append(np.nan)


def monitor():
    s = O.iter + 1
    ok = O.interactions.has(0, 1) and O.interactions[0, 1].isReal
    if ok:
        mon['ever'] = True
        if O.interactions[0, 1].phys.cohesionBroken and mon['coh_broken'] < 0:
            mon['coh_broken'] = s
    elif mon['ever'] and mon['break'] < 0:
        mon['break'] = s


def run(fragile, always, unp_max=None, stop_after_break=True, max_steps=MAX_STEPS):
    global rec, mon
    rec = {k: [] for k in ['step', 'time', 'pos', 'vel', 'angvel', 'ori', 'force_b0', 'torque_b0', 'force_b1',
                           'torque_b1', 'exists', 'normal_force', 'shear_force', 'moment_bending', 'moment_twist',
                           'penetration_depth', 'normal', 'contact_point', 'cohesion_broken', 'normal_adhesion',
                           'shear_adhesion', 'kn', 'ks', 'kr', 'ktw', 'max_roll_pl', 'max_twist_pl', 'tan_friction',
                           'unp']}
    mon = {'ever': False, 'break': -1, 'coh_broken': -1}
    build(fragile, always)
    O.run(1, True)  # first step: contact created with cohesion (iteration 0)
    I = O.interactions[0, 1]
    assert I.isReal and not I.phys.cohesionBroken and abs(I.phys.normalAdhesion - 2.0) < 1e-12
    if unp_max is not None:
        I.phys.unpMax = unp_max
    O.run(1, True)
    assert not ip2.setCohesionNow, 'Yade did not reset setCohesionNow'
    while O.iter < max_steps:
        if stop_after_break and mon['break'] >= 0 and O.iter >= mon['break'] + EXTRA:
            break
        O.run(PERIOD - (O.iter % PERIOD) if O.iter % PERIOD else PERIOD, True)
    out = {k: np.array(v) for k, v in rec.items()}
    out['exists'] = out['exists'].astype(bool)
    out['step'] = out['step'].astype(np.int64)
    out['n_steps'] = np.int64(O.iter)
    out['break_step'] = np.int64(mon['break'])
    out['cohesion_broken_step'] = np.int64(mon['coh_broken'])
    out['fragile'] = np.bool_(fragile)
    out['always_use_moment_law'] = np.bool_(always)
    out['unp_max'] = np.float64(np.nan if unp_max is None else unp_max)
    return out


data = dict(
    yade_version=np.array(str(yade.config.version)),
    radius=np.array([R, R]), pos0=POS0, vel0=VEL0, angvel0=ANGVEL0, blocked_dofs=np.array('xyzXYZ'),
    mat_young=np.float64(MAT['young']), mat_poisson=np.float64(MAT['poisson']),
    mat_density=np.float64(MAT['density']), mat_friction_angle=np.float64(MAT['frictionAngle']),
    mat_normal_cohesion=np.float64(MAT['normalCohesion']), mat_shear_cohesion=np.float64(MAT['shearCohesion']),
    mat_eta_roll=np.float64(MAT['etaRoll']), mat_eta_twist=np.float64(MAT['etaTwist']),
    mat_alpha_kr=np.float64(MAT['alphaKr']), mat_alpha_ktw=np.float64(MAT['alphaKtw']),
    mat_moment_rotation_law=np.bool_(True), mat_is_cohesive=np.bool_(True),
    dt=np.float64(DT), gravity=np.zeros(3), damping=np.float64(0.0), record_period=np.int64(PERIOD),
    max_steps=np.int64(MAX_STEPS), extra_steps_after_break=np.int64(EXTRA),
    set_cohesion_now=np.bool_(True), set_cohesion_on_new_contacts=np.bool_(False),
    use_incremental_form=np.bool_(True), cohesion_set_iter=np.int64(0),
)

runs = [('', dict(fragile=True, always=True)),
        ('noalways_', dict(fragile=True, always=False)),
        ('nonfragile_', dict(fragile=False, always=False, unp_max=-1.0, stop_after_break=False))]
for prefix, kw in runs:
    out = run(**kw)
    if prefix != 'nonfragile_':
        out.pop('unp')
    for k, v in out.items():
        data[prefix + k] = v
    print('%-12s steps=%d break_step=%d cohesion_broken_step=%d' % (prefix or 'main', out['n_steps'],
                                                                    out['break_step'], out['cohesion_broken_step']))

# extra experiment: non-fragile with Yade's default unpMax (0): when is the contact deleted?
out = run(fragile=False, always=False, unp_max=None, stop_after_break=True)
data['nonfragile_unpmax0_break_step'] = np.int64(out['break_step'])
data['nonfragile_unpmax0_cohesion_broken_step'] = np.int64(out['cohesion_broken_step'])
print('nonfragile unpMax=0 (default): break_step=%d' % out['break_step'])

np.savez_compressed(OUTFILE, **data)
print('wrote', OUTFILE, os.path.getsize(OUTFILE), 'bytes')
