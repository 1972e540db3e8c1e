"""The paper's ringing-test rig ("twin") in Yade 2023.02a, built from benchmarks/yade/ringing_twin_spec.npz.

Run from the repository root:
    yade -n -x benchmarks/yade/ringing_twin.py            # full: 4 readings x 8 spring configurations
                                                         #   -> benchmarks/yade/ringing_twin_yade.npz (+ .log)
    yade -n -x benchmarks/yade/ringing_twin.py reduced    # CI file: reading "stated", spec configurations 0 and 7
                                                         #   (4 and 32 springs), ring_time 0.6 s
                                                         #   -> benchmarks/yade/ringing_twin_yade_reduced.npz (+ .log)
    yade -n -x benchmarks/yade/ringing_twin.py test       # one configuration (stated, 4 springs), ring 0.1 s,
                                                         #   verbose checks; writes nothing
Optional extra words (any mode): readings=stated,damping_all   configs=0,3   ring_time=0.5   out=NAME
(out=NAME writes benchmarks/yade/NAME.npz and NAME.log; used to split the full set over processes; the parts are
plain dicts of the same keys and can be merged with {**np.load(a), **np.load(b)}.)

The spec (written by scenes/ringing_twin.py, whose docstring describes the rig and the readings) is the single
source of truth for every number; this script hard-codes none. Frame: x lateral (the pivot axis), y travel, z up.

Scene (ids in build order)
--------------------------
Materials: all CohFrictMat, so that one Ip2/Law2 pair handles every contact (alphaKr = alphaKtw = 2, fragile):
  tool   E tool_young, nu tool_poisson, phi tool_friction_deg, Cn = Cs = 0, isCohesive False, no moment law
  pivot  E/nu/rho/phi from pivot_ball_*, Cn = Cs = 0, isCohesive False, no moment law
  spring E spring_young_table2[config], nu spring_poisson, rho spring_density, phi spring_friction_angle,
         Cn spring_normal_cohesion, Cs spring_shear_cohesion, isCohesive True, momentRotationLaw True,
         etaRoll = etaTwist = spring_eta_roll
  load   E load_young, nu load_poisson, phi load_friction_angle, rho load_density ("stated") or load_density_20kg
         ("20kg"), Cn = Cs = 0, isCohesive False, no moment law
  (Yade takes the minimum friction angle of the two materials; a contact is cohesive only when both materials are
  isCohesive, so only spring-spring and spring-support contacts are bonded. The moment law acts only where both
  materials have momentRotationLaw, i.e. on the same contacts.)
Bodies:
  0..nf-1  the tool's facets (utils.facet, fixed=False): every triangle of lower_vertices/lower_faces, then of
           upper_vertices/upper_faces (the upper shank and the 12-sided tube around the pivot ball);
  nf       the tool clump (O.bodies.appendClumped of the facets), blockedDOFs 'xYZ';
  nf+1     pivot ball (pivot_ball_centre, pivot_ball_radius), fixed;
  nf+2..4  spring spheres 0, 1, 2 (spring_centres rows; 0 touches the shank's rear face), blockedDOFs 'xzXZ';
  nf+5     support sphere (support_centre), fixed;
  nf+6     load sphere (load_centre, load_radius), blockedDOFs 'xXYZ'.
Engines: ForceResetter; InsertionSortCollider([Bo1_Sphere_Aabb, Bo1_Facet_Aabb]);
  InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D, Ig2_Facet_Sphere_ScGeom6D],
                  [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True, setCohesionOnNewContacts=False)],
                  [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True, always_use_moment_law=True)]);
  NewtonIntegrator(gravity=spec gravity, damping=...); PyRunner recorder. O.dt = spec dt, fixed (no time stepper).
setCohesionNow bonds the contacts that exist at the first step: the column's three sphere-sphere contacts
(sphere0-sphere1, sphere1-sphere2, sphere2-support; each overlaps initial_overlap), checked after step 1.

The tool clump: mass, centre of mass and inertia (Yade API facts, verified on 2023.02a)
-------------------------------------------------------------------------------------
* Facets have no volume: utils.facet gives state.mass = 0, inertia 0. O.bodies.appendClumped computes the clump
  from the members (Clump::updateProperties: sum of member masses, mass-weighted centre, member inertias moved by
  parallel axes, eigen-decomposition -> state.ori = principal axes, state.inertia = principal moments) and stores
  each member's se3 relative to that frame. With massless members Yade 2023.02a aborts the whole process
  (assertion `M > 0' in Clump.cpp). The members' local se3 (clump.shape.members) is read-only from Python, and is
  only (re)computed by updateProperties (appendClumped / updateClumpProperties) relative to the frame it computes;
  setting state.pos/ori of the clump afterwards would move the members.
  So, before clumping, this script gives the facets point masses w_i (state.mass = w_i, state.inertia = 0) chosen
  so that sum w_i = tool_mass and sum w_i p_i = tool_mass * com (p_i: facet centres = incentres, state.pos of
  utils.facet): the minimum-norm correction of uniform weights, all > 0. Yade then puts the clump at com (checked,
  to round-off) and computes consistent member se3. Then state.mass = tool_mass and state.inertia are overwritten
  (pos and ori untouched, so the members do not move; the max member displacement over the first step is printed),
  and the facets' masses are reset to 0.
* Blocked rotations switch the clump to the "spherical" integrator. NewtonIntegrator uses the aspherical
  (angular-momentum) integrator only when NO rotational DOF is blocked (useAspherical = exactAsphericalRot &&
  isAspherical && (blockedDOFs & DOF_RXRYRZ) == 0). With 'xYZ' the clump is integrated like a sphere: in WORLD
  axes, angAccel_x = torque_x / state.inertia[0], the blocked components are zeroed, state.angVel is used directly,
  state.angMom is neither read nor updated, and ori is turned by angVel*dt about the world axis. (Checked: a clump
  with blockedDOFs 'xYZ' under a torque (1, .5, .2) N m reached angVel_x = t / inertia[0] exactly, with angMom 0;
  an angVel set directly was kept.) Hence state.inertia[0] must be the moment about the world x axis through the
  COM, and state.ori is only the reference frame of the member se3 (any frame will do).
  -> So the clump is NOT given the principal axes of the parallel-axis tensor as orientation and its principal
  moments as inertia: Yade would then take a principal moment as the moment about world x (eigh order: 0.0266 kg
  m^2, the axis closest to z, instead of 0.1667). For a body that can only turn about x the equation of motion is
  I_xx dw_x/dt = torque_x (the products of inertia only load the blocked DOFs), so state.inertia = diag(tensor)
  for both readings: "parallel_axis" -> diag(inertia_parallel_axis) (I_xx = 0.166676 kg m^2; for comparison
  1/(I^-1)_xx = 0.166479, what an engine that solves w = I^-1 L with the full tensor and then zeroes w_y, w_z
  would use), "diagonal" -> diag(inertia_diagonal) (I_xx = 2.6007 kg m^2). Only inertia[0] matters. The clump's
  orientation is Yade's principal frame of the point-mass construction (physically meaningless, but consistent
  with the member se3). angMom = R diag(I) R^T w is likewise unused; the script sets angMom = inertia * angVel
  (component-wise) for tidiness only.
* Local damping: State.isDamped exists in 2023.02a (default True); NewtonIntegrator applies its single `damping`
  coefficient (Cundall's non-viscous damping, per component, to linear and angular accelerations) only to bodies
  with isDamped True (checked: damping 0.5 halves an accelerating body's velocity gain only when isDamped).

Procedure per (reading, configuration)
--------------------------------------
1. O.reset(); build. X0, q0 = the clump's position (COM) and orientation at the start.
2. Settle for n_settle = round(settle_time / dt) steps with damping = settle_damping and isDamped True on every
   dynamic body (tool clump, spring spheres, load).
3. Damping -> local_damping_table2[config]; isDamped: spring spheres True; tool and load True only for the reading
   damping "all" (else False).
4. The hit (time 0): w = (hit_angvel_x[config], 0, 0) is added to the clump's angVel (angMom set as above); the
   clump's COM velocity gets w x (X - pivot) added, the load sphere's velocity w x (x_load - pivot) (pivot =
   pivot_ball_centre). Spring spheres are untouched.
5. Ring for n_ring = round(ring_time / dt / every) * every steps, every = round(1 / (sample_rate * dt)) = 84
   (2395.8 Hz), recording after s = 0, every, 2*every, ... completed steps since the hit (s = 0: the state at the
   hit, velocities including the hit). Settling is recorded every 4*every steps (s = 4*every, 8*every, ...).
   Recording convention as in tests/reference: a PyRunner after NewtonIntegrator fires inside the step, so positions
   and velocities are after that step's integration (velocities on the leapfrog half step) and contact forces are
   those computed during the step.
Sensor point (a point fixed in the tool): x_s = X + R(q) R(q0)^T (sensor_point - X0).
Tool rotation angle about x: theta = atan2(M[2,1], M[1,1]) with M = R(q) R(q0)^T (positive: right-handed about +x).

What the runs showed (full set; table: ringing_twin_table.py -> ringing_twin_yade_table.md)
--------------------------------------------------------------------------------------------
* Checks passed in every run: max member displacement over step 1 ~8e-11 m; 3 cohesive interactions after step 1
  (s0-s1, s1-s2, s2-support), never broken; clump centre = spec com to 1.4e-17 m; the tool hangs on the ball (6 tube
  contacts, COM moves < 0.19 mm while ringing); the load sphere stays on its plate (one contact, normal force never
  below 190 N, |Fs|/Fn <= 0.08 against tan 40 deg = 0.84: no sliding); the shank never leaves the spring column.
  Reruns give bit-identical files.
* (A first version of the spec put the load sphere on the blade at x = 0, a shared edge of two coplanar facets:
  Ig2_Facet_Sphere then makes two contacts with the same overlap, warpdem one, and the engines differed. The spec
  now carries a one-triangle load plate.)
* Damping comes from pivot friction, not local damping: with the spring spheres' local damping set to 0 the
  records are unchanged; with the pivot ball's friction set to 0 zeta falls below 0.01 (docs/fidelity.md). The
  spring spheres (3.4 g) are quasi-static, so Cundall damping of their tiny unbalanced force removes almost no
  energy; the tube slipping on the 5 deg ball (Coulomb friction) does, and the sticking pivot adds stiffness.
* The records hold small ~20 Hz (the load sphere on its contact) and ~50 Hz components on top of the 5-7 Hz mode;
  ringing_twin_table.py also analyses them after a 30 Hz low-pass.
* Run time: 60,000-90,000 steps/s (one core), ~5-6 s per run (362,270 steps), ~200 s for the full set.

Keys (SI units). Every key of the spec npz is copied unchanged (same names; see scenes/ringing_twin.py), plus:
  yade_version, mode ('full' | 'reduced' | 'custom'), run_readings (r,) str, run_configs (c,) int (spec indices),
  ring_time_used [s] (= n_ring * dt), n_settle, n_ring, record_every (= 84), record_dt [s] (= record_every * dt),
  settle_record_every (= 4 * record_every),
  contact_types (6,) str: 'tool-pivot', 'tool-spring', 'spring-spring', 'spring-support', 'tool-load', 'other'
  column_contacts (4,) str: 'shank-s0', 's0-s1', 's1-s2', 's2-support' (the column's contacts, shank to support)
Per run, prefix P = f"{reading}/{springs}/" (springs = spec springs[config], e.g. "stated/16/"):
 inputs and checks
  P+config (int, spec index), P+reading_inertia, P+reading_load_mass, P+reading_damping (str)
  P+spring_young [Pa], P+local_damping, P+hit_angvel_x [rad/s] (this configuration's values)
  P+tool_mass [kg], P+tool_inertia (3,) [kg m^2] (clump state.inertia; [0] is the moment about x, the only one
       used), P+tool_pos0 (3,) [m] (X0: Yade's clump position), P+tool_com_error [m] (|X0 - spec com|),
  P+tool_ori0 (4,) (w,x,y,z) (q0: Yade's clump orientation, see above), P+load_mass [kg], P+spring_mass [kg]
  P+member_jump_step1 [m]   max |member position after step 1 - before| (members must not jump)
  P+cohesive_after_step1 (int)  number of cohesive (cohesionBroken False) interactions after step 1 (expect 3)
  P+cohesive_pairs_step1 (n,2) int  their body ids
 settling (k_s records, every settle_record_every steps), float32
  P+settle_time (k_s,) [s] (float64), P+settle_sensor_y, P+settle_sensor_z (k_s,) [m] (sensor point),
  P+settle_com_y, P+settle_com_z (k_s,) [m] (clump COM), P+settle_load_y, P+settle_load_z (k_s,) [m]
 end of settling (= at the hit, before the hit velocities)
  P+settled_sensor_dy, P+settled_sensor_dz [m] (sensor displacement during settling),
  P+settled_com_displacement (3,) [m], P+settled_rot_x [rad], P+settled_load_centre (3,) [m],
  P+settled_load_touching (bool: the tool-load normal force is compressive),
  P+settled_column_fn (4,) [N] (normal force of the column_contacts, + = compression),
  P+settled_load_fn, P+settled_pivot_fn [N] (tool-load normal force; norm of the summed tool-pivot force)
 ringing (k records, k = n_ring / record_every + 1)
  P+step (k,) int32 (steps since the hit: 0, 84, ...), P+time (k,) [s] (= step * dt; 0 = the hit)
  float64: P+sensor_y (k,) [m]; P+load_y, P+load_z (k,) [m]
  float32: P+sensor_z (k,) [m]; P+tool_angvel_x (k,) [rad/s]; P+tool_rot_x (k,) [rad] (since the start, not since
       the hit); P+tool_com_y, P+tool_com_z (k,) [m]; P+spring_y (k,3) [m] (spheres 0,1,2);
       P+column_fn (k,2) [N] normal force of 'shank-s0' (summed over the facets touching sphere 0) and 's2-support'
       (+ = compression, negative = a bond in tension, 0 = no interaction; the two middle contacts follow these
       within a fraction of a newton, see ring_column_fn_min/max);
       P+load_fn (k,) [N] tool-load normal force (summed over facets), P+load_fs (k,) [N] norm of the summed
       tool-load shear force
  P+n_contacts (k,6) int8  interactions with nonzero normal force per contact_types entry
 summaries of the ringing (from every record)
  P+ring_column_open_fraction (fraction of records with shank-s0 force <= 0), P+ring_column_fn_min (4,),
  P+ring_column_fn_max (4,) [N], P+ring_load_fn_min, P+ring_load_fn_max [N], P+ring_load_fs_over_fn_max (compare
  with tan of the contact friction angle, min(tool, load) = 40 deg: 0.839), P+ring_pivot_fn_min,
  P+ring_pivot_fn_max [N], P+ring_com_disp_max [m] (the COM's largest distance from its position at the hit)
  P+wall_s [s] wall time of the run (build + settle + ring), P+steps_per_s (during ringing)
Also written: <out>.log, a copy of everything the script printed.
"""
import os
import sys
import math
import time
import numpy as np
import yade
from yade import utils
from yade.wrapper import *  # noqa

OUTDIR = os.path.dirname(os.path.abspath(sys.argv[0]))
SPEC_FILE = os.path.join(OUTDIR, 'ringing_twin_spec.npz')
SPEC = {k: v for k, v in np.load(SPEC_FILE).items()}

CONTACT_TYPES = ['tool-pivot', 'tool-spring', 'spring-spring', 'spring-support', 'tool-load', 'other']
COLUMN_CONTACTS = ['shank-s0', 's0-s1', 's1-s2', 's2-support']

# ------------------------------------------------------------------------------------------------ command line
ARGS = sys.argv[1:]
MODE = 'full'
OPTS = {}
for a in ARGS:
    if '=' in a:
        k, v = a.split('=', 1)
        OPTS[k] = v
    elif a in ('full', 'reduced', 'test'):
        MODE = a
    else:
        raise SystemExit('unknown argument %r (expected full | reduced | test | readings=.. | configs=.. | '
                         'ring_time=.. | out=..)' % a)
READING_NAMES = [str(s) for s in SPEC['reading_names']]
if MODE == 'full':
    READINGS, CONFIGS, RING_TIME, OUTNAME = READING_NAMES, list(range(len(SPEC['springs']))), \
        float(SPEC['ring_time']), 'ringing_twin_yade'
elif MODE == 'reduced':
    READINGS, CONFIGS, RING_TIME, OUTNAME = ['stated'], [0, 7], 0.6, 'ringing_twin_yade_reduced'
else:  # test
    READINGS, CONFIGS, RING_TIME, OUTNAME = ['stated'], [0], 0.1, None
if 'readings' in OPTS:
    READINGS = OPTS['readings'].split(',')
    MODE = 'custom' if MODE != 'test' else MODE
if 'configs' in OPTS:
    CONFIGS = [int(c) for c in OPTS['configs'].split(',')]
    MODE = 'custom' if MODE != 'test' else MODE
if 'ring_time' in OPTS:
    RING_TIME = float(OPTS['ring_time'])
    MODE = 'custom' if MODE != 'test' else MODE
if 'out' in OPTS:
    OUTNAME = OPTS['out']
for r in READINGS:
    if r not in READING_NAMES:
        raise SystemExit('unknown reading %r, spec has %s' % (r, READING_NAMES))
VERBOSE = MODE == 'test'

LOG = []


def say(*a):
    s = ' '.join(str(x) for x in a)
    print(s)
    sys.stdout.flush()
    LOG.append(s)


# ------------------------------------------------------------------------------------------------ spec numbers
def f(key):
    return float(SPEC[key])


DT = f('dt')
GRAV = tuple(float(g) for g in SPEC['gravity'])
EVERY = int(round(1.0 / (f('sample_rate') * DT)))
SETTLE_EVERY = 4 * EVERY  # settling is recorded at a quarter of the sample rate (a check only)
N_SETTLE = int(round(f('settle_time') / DT))
N_RING = int(round(RING_TIME / DT / EVERY)) * EVERY
PIVOT = np.asarray(SPEC['pivot_ball_centre'], dtype=float)
SENSOR = np.asarray(SPEC['sensor_point'], dtype=float)
COM = np.asarray(SPEC['com'], dtype=float)


def reading_of(name):
    i = READING_NAMES.index(name)
    return dict(inertia=str(SPEC['reading_inertia'][i]), load_mass=str(SPEC['reading_load_mass'][i]),
                damping=str(SPEC['reading_damping'][i]))


def q_wxyz(q):
    return [q[3], q[0], q[1], q[2]]


def rotm(q):
    return np.array(q.toRotationMatrix())


# ------------------------------------------------------------------------------------------------ scene
def com_weights(P, target, total):
    """Positive point masses at the points P (n,3) with sum = total and centre = target: the minimum-norm
    correction of uniform weights (exact to round-off)."""
    A = (P - target).T
    u = np.ones(len(P))
    w = u - A.T @ np.linalg.solve(A @ A.T, A @ u)
    if w.min() <= 0.05:
        raise RuntimeError('point-mass weights not positive enough (min %g): com outside the facets?' % w.min())
    w *= total / w.sum()
    return w


S = {}  # the current scene's ids and reference state


def build(reading, ci):
    """O.reset() and build the rig for one reading and configuration index ci."""
    rd = reading_of(reading)
    O.reset()
    mt = O.materials.append(CohFrictMat(
        label='tool', young=f('tool_young'), poisson=f('tool_poisson'), density=7850.0,
        frictionAngle=math.radians(f('tool_friction_deg')), normalCohesion=0.0, shearCohesion=0.0,
        isCohesive=False, momentRotationLaw=False, alphaKr=2.0, alphaKtw=2.0))
    mp = O.materials.append(CohFrictMat(
        label='pivot', young=f('pivot_ball_young'), poisson=f('pivot_ball_poisson'), density=f('pivot_ball_density'),
        frictionAngle=math.radians(f('pivot_ball_friction_angle')), normalCohesion=0.0, shearCohesion=0.0,
        isCohesive=False, momentRotationLaw=False, alphaKr=2.0, alphaKtw=2.0))
    ms = O.materials.append(CohFrictMat(
        label='spring', young=float(SPEC['spring_young_table2'][ci]), poisson=f('spring_poisson'),
        density=f('spring_density'), frictionAngle=math.radians(f('spring_friction_angle')),
        normalCohesion=f('spring_normal_cohesion'), shearCohesion=f('spring_shear_cohesion'), isCohesive=True,
        momentRotationLaw=True, etaRoll=f('spring_eta_roll'), etaTwist=f('spring_eta_roll'), alphaKr=2.0,
        alphaKtw=2.0))
    load_density = f('load_density') if rd['load_mass'] == 'stated' else f('load_density_20kg')
    ml = O.materials.append(CohFrictMat(
        label='load', young=f('load_young'), poisson=f('load_poisson'), density=load_density,
        frictionAngle=math.radians(f('load_friction_angle')), normalCohesion=0.0, shearCohesion=0.0,
        isCohesive=False, momentRotationLaw=False, alphaKr=2.0, alphaKtw=2.0))

    # --- the tool: one clump of facets
    facets = []
    for vk, fk in (('lower_vertices', 'lower_faces'), ('upper_vertices', 'upper_faces')):
        V = np.asarray(SPEC[vk], dtype=float)
        for tri in np.asarray(SPEC[fk]):
            facets.append(utils.facet([tuple(V[i]) for i in tri], fixed=False, material=mt))
    P = np.array([list(b.state.pos) for b in facets])
    w = com_weights(P, COM, f('tool_mass'))
    for b, wi in zip(facets, w):
        b.state.mass = float(wi)
        b.state.inertia = (0.0, 0.0, 0.0)
    cid, mids = O.bodies.appendClumped(facets)
    mids = list(mids)
    c = O.bodies[cid]
    com_err = float(np.linalg.norm(np.array(list(c.state.pos)) - COM))
    if com_err > 1e-12:
        raise RuntimeError('clump centre %s differs from spec com %s by %g m' % (c.state.pos, COM, com_err))
    tensor = np.asarray(SPEC['inertia_parallel_axis' if rd['inertia'] == 'parallel_axis' else 'inertia_diagonal'],
                        dtype=float)
    c.state.mass = f('tool_mass')
    c.state.inertia = tuple(float(x) for x in np.diag(tensor))
    c.state.blockedDOFs = 'xYZ'
    for i in mids:  # back to the facets' own (zero) mass; the members' mass is used nowhere after clumping
        O.bodies[i].state.mass = 0.0
    # --- spheres
    pid = O.bodies.append(utils.sphere(tuple(PIVOT), f('pivot_ball_radius'), fixed=True, material=mp))
    r = f('spring_radius')
    sids = []
    for ctr in np.asarray(SPEC['spring_centres'], dtype=float):
        b = utils.sphere(tuple(ctr), r, material=ms)
        b.state.blockedDOFs = 'xzXZ'
        sids.append(O.bodies.append(b))
    supid = O.bodies.append(utils.sphere(tuple(np.asarray(SPEC['support_centre'], dtype=float)), r, fixed=True,
                                         material=ms))
    b = utils.sphere(tuple(np.asarray(SPEC['load_centre'], dtype=float)), f('load_radius'), material=ml)
    b.state.blockedDOFs = 'xXYZ'
    lid = O.bodies.append(b)

    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D(), Ig2_Facet_Sphere_ScGeom6D()],
                        [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(label='ip2', setCohesionNow=True,
                                                                  setCohesionOnNewContacts=False)],
                        [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(label='law', useIncrementalForm=True,
                                                                   always_use_moment_law=True)]),
        NewtonIntegrator(gravity=GRAV, damping=f('settle_damping'), label='newton'),
        PyRunner(iterPeriod=SETTLE_EVERY, firstIterRun=SETTLE_EVERY - 1, command='record_settle()',
                 label='recorder'),
    ]
    O.dt = DT
    for i in [cid] + sids + [lid]:
        O.bodies[i].state.isDamped = True
    S.clear()
    S.update(cid=cid, mids=mids, mset=set(mids), pid=pid, sids=sids, supid=supid, lid=lid, rd=rd, ci=ci,
             X0=np.array(list(c.state.pos)), R0=rotm(c.state.ori), q0=np.array(q_wxyz(c.state.ori)),
             com_err=com_err, load_density=load_density)
    S['sensor_local'] = S['R0'].T @ (SENSOR - S['X0'])


# ------------------------------------------------------------------------------------------------ observers
def tool_frame():
    st = O.bodies[S['cid']].state
    X = np.array(list(st.pos))
    R = rotm(st.ori)
    return X, R


def sensor():
    X, R = tool_frame()
    return X + R @ S['sensor_local']


def rot_x():
    X, R = tool_frame()
    M = R @ S['R0'].T
    return math.atan2(M[2, 1], M[1, 1])


def group(i):
    if i in S['mset']:
        return 'tool'
    if i == S['pid']:
        return 'pivot'
    if i in S['sids']:
        return 'spring'
    if i == S['supid']:
        return 'support'
    if i == S['lid']:
        return 'load'
    return 'other'


PAIR = {('pivot', 'tool'): 0, ('spring', 'tool'): 1, ('spring', 'spring'): 2, ('spring', 'support'): 3,
        ('load', 'tool'): 4}


def contacts():
    """(counts per CONTACT_TYPES with nonzero normal force, column normal forces (4,), load fn, |pivot force|,
    |load shear force|)."""
    n = np.zeros(len(CONTACT_TYPES), dtype=np.int64)
    col = np.zeros(4)
    load_fn = 0.0
    load_fs = np.zeros(3)
    piv = np.zeros(3)
    s0, s1, s2 = S['sids']
    colidx = {(s0, s1): 1, (s1, s2): 2, (s2, S['supid']): 3}
    for I in O.interactions:
        if not I.isReal:
            continue
        a, b = I.id1, I.id2
        key = tuple(sorted((group(a), group(b))))
        fnv = I.phys.normalForce
        fn = float(fnv.dot(I.geom.normal))  # + = compression (normalForce = kn un n, un > 0 in compression)
        if fnv.norm() > 0:
            n[PAIR.get(key, 5)] += 1
        if key == ('spring', 'tool') and s0 in (a, b):
            col[0] += fn
        elif tuple(sorted((a, b))) in colidx:
            col[colidx[tuple(sorted((a, b)))]] += fn
        elif key == ('load', 'tool'):
            load_fn += fn
            load_fs += np.array(list(I.phys.shearForce))
        elif key == ('pivot', 'tool'):
            piv += np.array(list(I.phys.normalForce + I.phys.shearForce))
    return n, col, load_fn, float(np.linalg.norm(piv)), float(np.linalg.norm(load_fs))


REC = {}


def record_settle():
    s = O.iter + 1
    xs = sensor()
    X, _ = tool_frame()
    lp = O.bodies[S['lid']].state.pos
    REC['settle_time'].append(s * DT)
    REC['settle_sensor_y'].append(xs[1])
    REC['settle_sensor_z'].append(xs[2])
    REC['settle_com_y'].append(X[1])
    REC['settle_com_z'].append(X[2])
    REC['settle_load_y'].append(lp[1])
    REC['settle_load_z'].append(lp[2])


def record_ring(step=None):
    s = (O.iter + 1 - S['hit_iter']) if step is None else step
    xs = sensor()
    X, _ = tool_frame()
    st = O.bodies[S['cid']].state
    lp = O.bodies[S['lid']].state.pos
    n, col, lfn, pfn, lfs = contacts()
    REC['step'].append(s)
    REC['sensor_y'].append(xs[1])
    REC['sensor_z'].append(xs[2])
    REC['tool_angvel_x'].append(st.angVel[0])
    REC['tool_rot_x'].append(rot_x())
    REC['tool_com_y'].append(X[1])
    REC['tool_com_z'].append(X[2])
    REC['load_y'].append(lp[1])
    REC['load_z'].append(lp[2])
    REC['spring_y'].append([O.bodies[i].state.pos[1] for i in S['sids']])
    REC['n_contacts'].append(n)
    REC['column_fn'].append(col)
    REC['load_fn'].append(lfn)
    REC['load_fs'].append(lfs)
    REC['pivot_fn'].append(pfn)
    REC['com_disp'].append(np.linalg.norm(X - S['X_hit']))


# ------------------------------------------------------------------------------------------------ one run
def run_one(reading, ci):
    t_wall = time.time()
    for k in ['settle_time', 'settle_sensor_y', 'settle_sensor_z', 'settle_com_y', 'settle_com_z', 'settle_load_y',
              'settle_load_z', 'step', 'sensor_y', 'sensor_z', 'tool_angvel_x', 'load_y', 'load_z', 'spring_y',
              'n_contacts', 'column_fn', 'load_fn', 'load_fs', 'pivot_fn', 'com_disp', 'tool_rot_x', 'tool_com_y',
              'tool_com_z']:
        REC[k] = []
    build(reading, ci)
    springs = int(SPEC['springs'][ci])
    tag = '%s/%d' % (reading, springs)
    c = O.bodies[S['cid']]
    out = {}
    out['config'] = np.int64(ci)
    for k, v in S['rd'].items():
        out['reading_' + k] = np.array(v)
    out['spring_young'] = np.float64(SPEC['spring_young_table2'][ci])
    out['local_damping'] = np.float64(SPEC['local_damping_table2'][ci])
    out['hit_angvel_x'] = np.float64(SPEC['hit_angvel_x'][ci])
    out['tool_mass'] = np.float64(c.state.mass)
    out['tool_inertia'] = np.array(list(c.state.inertia))
    out['tool_pos0'] = S['X0'].copy()
    out['tool_com_error'] = np.float64(S['com_err'])
    out['tool_ori0'] = S['q0'].copy()
    out['load_mass'] = np.float64(O.bodies[S['lid']].state.mass)
    out['spring_mass'] = np.float64(O.bodies[S['sids'][0]].state.mass)

    # --- step 1: cohesion and member consistency
    before = np.array([list(O.bodies[i].state.pos) for i in S['mids']])
    O.run(1, True)
    after = np.array([list(O.bodies[i].state.pos) for i in S['mids']])
    jump = float(np.abs(after - before).max())
    coh = [(I.id1, I.id2) for I in O.interactions if I.isReal and not I.phys.cohesionBroken]
    out['member_jump_step1'] = np.float64(jump)
    out['cohesive_after_step1'] = np.int64(len(coh))
    out['cohesive_pairs_step1'] = np.array(coh, dtype=np.int64).reshape(-1, 2)
    names = {i: group(i) + ('%d' % S['sids'].index(i) if i in S['sids'] else '') for i in
             S['sids'] + [S['supid']]}
    say('%-22s step 1: max member displacement %.3e m; cohesive interactions %d: %s; clump COM error %.2e m; '
        'inertia %s, mass %.4f, load mass %.3f kg' % (tag, jump, len(coh),
                                                      ', '.join('%s-%s' % (names.get(a, a), names.get(b, b))
                                                                for a, b in coh), S['com_err'],
                                                      np.array(list(c.state.inertia)), c.state.mass,
                                                      out['load_mass']))
    if len(coh) != 3:
        say('WARNING: expected 3 cohesive interactions after step 1, found %d' % len(coh))

    # --- settle
    t0 = time.time()
    O.run(N_SETTLE - 1, True)
    t_settle = time.time() - t0
    X, R = tool_frame()
    xs = sensor()
    xs0 = SENSOR  # the sensor point at the start (x_s(0) = sensor_point by construction)
    n, col, lfn, pfn, lfs = contacts()
    lp = np.array(list(O.bodies[S['lid']].state.pos))
    out['settled_sensor_dy'] = np.float64(xs[1] - xs0[1])
    out['settled_sensor_dz'] = np.float64(xs[2] - xs0[2])
    out['settled_com_displacement'] = X - S['X0']
    out['settled_rot_x'] = np.float64(rot_x())
    out['settled_load_centre'] = lp
    out['settled_load_touching'] = np.bool_(lfn > 0)
    out['settled_column_fn'] = col
    out['settled_load_fn'] = np.float64(lfn)
    out['settled_pivot_fn'] = np.float64(pfn)
    out['settle_time'] = np.array(REC['settle_time'])
    for k in ['settle_sensor_y', 'settle_sensor_z', 'settle_com_y', 'settle_com_z', 'settle_load_y', 'settle_load_z']:
        out[k] = np.array(REC[k], dtype=np.float32)
    say('%-22s settled (%.2f s wall, %.0f steps/s): sensor dy %+.3e dz %+.3e m, COM disp %s m, rot_x %+.3e rad, '
        'load %s (moved %s mm), load touching %s (fn %.1f N), column fn %s N, pivot |F| %.1f N, contacts %s' % (
            tag, t_settle, (N_SETTLE - 1) / t_settle, out['settled_sensor_dy'], out['settled_sensor_dz'],
            np.array2string(X - S['X0'], precision=3), out['settled_rot_x'],
            np.array2string(lp, precision=5), np.array2string(1e3 * (lp - SPEC['load_centre']), precision=3),
            bool(lfn > 0), lfn, np.array2string(col, precision=2), pfn, list(n)))
    if VERBOSE:
        ts, ys, zs = np.array(REC['settle_time']), np.array(REC['settle_sensor_y']), np.array(REC['settle_sensor_z'])
        for j in range(0, len(ts), max(1, len(ts) // 15)):
            say('    settle t=%.4f s sensor y %.6e z %.6e  com y %.6e z %.6e  load z %.6e' % (
                ts[j], ys[j], zs[j], REC['settle_com_y'][j], REC['settle_com_z'][j], REC['settle_load_z'][j]))

    # --- damping of the reading, then the hit
    newton = O.engines[3]
    newton.damping = float(SPEC['local_damping_table2'][ci])
    all_damped = S['rd']['damping'] == 'all'
    O.bodies[S['cid']].state.isDamped = all_damped
    O.bodies[S['lid']].state.isDamped = all_damped
    for i in S['sids']:
        O.bodies[i].state.isDamped = True
    wv = Vector3(float(SPEC['hit_angvel_x'][ci]), 0.0, 0.0)
    st = c.state
    st.angVel = st.angVel + wv
    st.angMom = Vector3(*[st.inertia[k] * st.angVel[k] for k in range(3)])  # unused by Yade here (see docstring)
    st.vel = st.vel + wv.cross(st.pos - Vector3(*PIVOT))
    ls = O.bodies[S['lid']].state
    ls.vel = ls.vel + wv.cross(ls.pos - Vector3(*PIVOT))
    S['hit_iter'] = O.iter
    S['X_hit'] = tool_frame()[0]
    record_ring(step=0)
    O.engines = O.engines[:-1] + [PyRunner(iterPeriod=EVERY, firstIterRun=O.iter + EVERY - 1,
                                           command='record_ring()', label='recorder')]
    t0 = time.time()
    O.run(N_RING, True)
    t_ring = time.time() - t0
    out['step'] = np.array(REC['step'], dtype=np.int32)
    out['n_contacts'] = np.array(REC['n_contacts'], dtype=np.int8)
    for k in ['sensor_y', 'load_y', 'load_z']:
        out[k] = np.array(REC[k], dtype=np.float64)
    for k in ['sensor_z', 'tool_angvel_x', 'tool_rot_x', 'tool_com_y', 'tool_com_z', 'spring_y', 'load_fn', 'load_fs']:
        out[k] = np.array(REC[k], dtype=np.float32)
    cf = np.array(REC['column_fn'])  # (k, 4); the file keeps the two ends of the column (the middle ones follow them)
    out['column_fn'] = cf[:, [0, 3]].astype(np.float32)
    pivot_fn, com_disp = np.array(REC['pivot_fn']), np.array(REC['com_disp'])
    expect = np.arange(0, N_RING + 1, EVERY)
    if out['step'].shape != expect.shape or not (out['step'] == expect).all():
        raise RuntimeError('recorded steps are not 0, %d, ..., %d' % (EVERY, N_RING))
    out['time'] = out['step'].astype(np.int64) * DT
    out['wall_s'] = np.float64(time.time() - t_wall)
    out['steps_per_s'] = np.float64(N_RING / t_ring)
    y = out['sensor_y'] - out['sensor_y'][0]
    out['ring_column_open_fraction'] = np.float64(np.mean(cf[:, 0] <= 0))
    out['ring_column_fn_min'] = cf.min(0).astype(np.float64)
    out['ring_load_fn_min'] = np.float64(out['load_fn'].min())
    out['ring_load_fn_max'] = np.float64(out['load_fn'].max())
    out['ring_load_fs_over_fn_max'] = np.float64(np.max(np.array(REC['load_fs']) / np.array(REC['load_fn'])))
    out['ring_pivot_fn_min'] = np.float64(pivot_fn.min())
    out['ring_pivot_fn_max'] = np.float64(pivot_fn.max())
    out['ring_com_disp_max'] = np.float64(com_disp.max())
    say('%-22s rang %.2f s (%.2f s wall, %.0f steps/s, run wall %.1f s): sensor y swing max %+.3e min %+.3e m, '
        'last 0.1 s p-p %.3e m; load z range %.3e m; load fn %.1f..%.1f N; pivot |F| %.1f..%.1f N; COM moved <= '
        '%.2e m; load |Fs|/Fn <= %.3f; column fn min %s N, shank-s0 open in %.1f %% of records; min contacts %s' % (
            tag, N_RING * DT, t_ring, out['steps_per_s'], out['wall_s'], y.max(), y.min(),
            np.ptp(y[-max(2, int(0.1 / (EVERY * DT))):]), np.ptp(out['load_z']), out['load_fn'].min(),
            out['load_fn'].max(), pivot_fn.min(), pivot_fn.max(), com_disp.max(), out['ring_load_fs_over_fn_max'],
            np.array2string(cf.min(0), precision=2), 100 * out['ring_column_open_fraction'],
            list(out['n_contacts'].min(0))))
    out['ring_column_fn_max'] = cf.max(0).astype(np.float64)
    if VERBOSE:
        for j in range(0, len(y), max(1, len(y) // 25)):
            say('    ring t=%.4f s sensor dy %+.4e  angvel_x %+.4e  load y %.6e z %.6e  column fn %s  load fn %.1f'
                % (out['time'][j], y[j], out['tool_angvel_x'][j], out['load_y'][j], out['load_z'][j],
                   np.array2string(cf[j], precision=2), out['load_fn'][j]))
    return tag, out


# ------------------------------------------------------------------------------------------------ main
say('ringing_twin.py: Yade %s, mode %s, readings %s, configs %s (springs %s), ring_time %g s, dt %g s, '
    'n_settle %d, n_ring %d, record every %d steps (%.2f Hz)' % (
        yade.config.version, MODE, READINGS, CONFIGS, [int(SPEC['springs'][i]) for i in CONFIGS], RING_TIME, DT,
        N_SETTLE, N_RING, EVERY, 1.0 / (EVERY * DT)))
data = dict(SPEC)
data.update(yade_version=np.array(str(yade.config.version)), mode=np.array(MODE),
            run_readings=np.array(READINGS), run_configs=np.array(CONFIGS, dtype=np.int64),
            ring_time_used=np.float64(N_RING * DT), n_settle=np.int64(N_SETTLE), n_ring=np.int64(N_RING),
            record_every=np.int64(EVERY), record_dt=np.float64(EVERY * DT),
            settle_record_every=np.int64(SETTLE_EVERY), contact_types=np.array(CONTACT_TYPES),
            column_contacts=np.array(COLUMN_CONTACTS))
T_ALL = time.time()
for reading in READINGS:
    for ci in CONFIGS:
        tag, out = run_one(reading, ci)
        for k, v in out.items():
            data[tag + '/' + k] = v
say('total wall time %.1f s' % (time.time() - T_ALL))
if OUTNAME:
    outfile = os.path.join(OUTDIR, OUTNAME + '.npz')
    np.savez_compressed(outfile, **data)
    say('wrote %s (%d bytes)' % (outfile, os.path.getsize(outfile)))
    with open(os.path.join(OUTDIR, OUTNAME + '.log'), 'w') as fh:
        fh.write('\n'.join(LOG) + '\n')
