"""Reference scene 3: a 3-sphere clump thrown onto a horizontal two-facet floor (Yade 2023.02a).

Run from the repository root:   yade -n -x tests/reference/clump_drop.py
Writes tests/reference/clump_drop.npz (next to this script).

Scene
-----
Material (members and floor): CohFrictMat E=1e7 Pa, poisson 0.3, density 2700, frictionAngle 30 deg,
normalCohesion=shearCohesion=0, isCohesive=False, momentRotationLaw=False, alphaKr=alphaKtw=2.
Floor: 0.4 m x 0.4 m square at z = 0 centred at the origin, two fixed facets (ids 0, 1):
    facet 0: (-.2,-.2,0), (.2,-.2,0), (.2,.2,0)      facet 1: (-.2,-.2,0), (.2,.2,0), (-.2,.2,0)
Clump: member radii (0.010, 0.008, 0.012) m; member centres in the "design" frame p_i = (0,0,0), (0.014,0,0.004),
(-0.006,0.012,0).  Construction:
  1. rotate the design offsets by q0 = rotation of 0.7 rad about unit axis (1,2,3)/sqrt(14)  (p_i' = q0 p_i),
  2. translate so that the sum-of-spheres centre of mass sum(m_i p_i')/sum(m_i) (m_i = rho 4/3 pi r_i^3) is at
     (0, 0, 0.06) m,
  3. O.bodies.appendClumped(members) (default discretization=0: Yade's sum-of-spheres mass/inertia rule).
  Yade then puts the clump body at the centre of mass and sets its orientation to the principal axes
  (`clump_ori0`, NOT q0); members are stored relative to the clump (clump.shape.members = local se3).
Initial velocities: clump.state.vel = (0.2, 0.1, 0) m/s.  Angular velocity: Yade integrates aspherical bodies
(clumps) from state.angMom; setting only state.angVel is IGNORED (angMom stays 0 and the first step resets
angVel to 0; verified).  So this script sets
    state.angMom = R(q) diag(I) R(q)^T w0  with w0 = (1, -2, 3) rad/s  (world frame),  and state.angVel = w0.
Ids: facets 0,1; clump members 2,3,4; clump body 5.
Gravity (0,0,-9.81), O.dt = 2e-5 s, 15000 steps (0.3 s), NewtonIntegrator damping 0 (main) / 0.3 ('damped_').
Engines as in cohesive_pair.py, Ip2(setCohesionNow=False, setCohesionOnNewContacts=False),
Law2(useIncrementalForm=True, always_use_moment_law=False).

Recording convention: PyRunner(iterPeriod=100, firstIterRun=99) after NewtonIntegrator -> after s = 100, 200, ...
completed steps; `step` = s, `time` = s*dt.

Keys (SI units; k = 150 records; prefix p in {'', 'damped_'})
------------------------------------------------------------
Inputs:
  yade_version; young, poisson, density, friction_angle [rad], normal_cohesion, shear_cohesion (floats),
  is_cohesive, moment_rotation_law (bool)  -- same material for floor and members
  facet_vertices (2,3,3) [m]
  member_radius (3,) [m]; member_offset_design (3,3) [m]  (p_i above); q0_design (4,) (w,x,y,z) rotation applied
  member_pos0 (3,3) [m]     global member centres as passed to appendClumped
  clump_pos0 (3,) [m]       Yade's clump position (= COM) after creation
  clump_ori0 (4,) (w,x,y,z) Yade's clump orientation after creation (principal axes -> world)
  clump_mass [kg]; clump_inertia (3,) [kg m^2] principal moments (body frame)
  member_local_pos (3,3) [m], member_local_ori (3,4) (w,x,y,z)   clump.shape.members (members' se3 in the clump
                            frame: x_i = X + q*local_pos_i)
  check_mass_sum [kg], check_inertia_principal (3,) [kg m^2]  sum-of-spheres + parallel-axes values computed here in
                            numpy (sorted ascending), for comparison with clump_mass / sorted(clump_inertia)
  clump_vel0 (3,) [m/s], clump_angvel0 (3,) [rad/s], clump_angmom0 (3,) [kg m^2/s] (what was set)
  dt, gravity (3,), n_steps, record_period, damping (main run), damped_damping
Per run p:
  p+step (k,), p+time (k,) [s]
  p+pos (k,3) [m], p+ori (k,4) (w,x,y,z), p+vel (k,3) [m/s], p+angvel (k,3) [rad/s], p+angmom (k,3) [kg m^2/s]
  p+member_pos (k,3,3) [m]
  p+n_interactions (k,) int   number of real interactions in the scene (all are member-facet)
  p+kinetic_energy (k,) [J]   utils.kineticEnergy() (includes the clump body once, members excluded)
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

OUTFILE = os.path.join(OUTDIR, 'clump_drop.npz')

MAT = dict(young=1e7, poisson=0.3, density=2700.0, frictionAngle=math.radians(30.0), normalCohesion=0.0,
           shearCohesion=0.0, isCohesive=False, momentRotationLaw=False, alphaKr=2.0, alphaKtw=2.0)
FACETS = np.array([[[-.2, -.2, 0], [.2, -.2, 0], [.2, .2, 0]],
                   [[-.2, -.2, 0], [.2, .2, 0], [-.2, .2, 0]]])
RADII = np.array([0.010, 0.008, 0.012])
OFFS = np.array([[0, 0, 0], [0.014, 0, 0.004], [-0.006, 0.012, 0]])
AXIS = np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0)
ANGLE = 0.7
CENTRE = np.array([0.0, 0.0, 0.06])
VEL0 = np.array([0.2, 0.1, 0.0])
W0 = np.array([1.0, -2.0, 3.0])
DT = 2e-5
NSTEPS = 15000
PERIOD = 100
GRAV = (0.0, 0.0, -9.81)


def rotmat(axis, ang):
    a = np.asarray(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(ang) * K + (1 - math.cos(ang)) * K @ K


Q0 = np.array([math.cos(ANGLE / 2), *(math.sin(ANGLE / 2) * AXIS)])
masses = MAT['density'] * 4.0 / 3.0 * math.pi * RADII ** 3
rot = rotmat(AXIS, ANGLE) @ OFFS.T
rot = rot.T
com = (masses[:, None] * rot).sum(0) / masses.sum()
MEMBER_POS0 = rot - com + CENTRE
# sum-of-spheres inertia with parallel axes about the COM (overlaps counted twice)
Itens = np.zeros((3, 3))
for m, r, x in zip(masses, RADII, MEMBER_POS0):
    d = x - CENTRE
    Itens += 0.4 * m * r * r * np.eye(3) + m * (d @ d * np.eye(3) - np.outer(d, d))
CHECK_I = np.sort(np.linalg.eigvalsh(Itens))
CHECK_M = masses.sum()

rec = None
CID = None


def q_wxyz(q):
    return [q[3], q[0], q[1], q[2]]


def build(damping):
    global CID
    O.reset()
    m = O.materials.append(CohFrictMat(label='mat', **MAT))
    for f in FACETS:
        O.bodies.append(utils.facet([tuple(v) for v in f], fixed=True, material=m))
    CID, mids = O.bodies.appendClumped([utils.sphere(tuple(x), r, material=m) for x, r in zip(MEMBER_POS0, RADII)])
    assert list(mids) == [2, 3, 4] and CID == 5
    c = O.bodies[CID]
    c.state.vel = tuple(VEL0)
    Rm = np.array(c.state.ori.toRotationMatrix())
    L0 = Rm @ np.diag(list(c.state.inertia)) @ Rm.T @ W0
    c.state.angMom = tuple(L0)
    c.state.angVel = tuple(W0)
    O.engines = cohfrict_engines(gravity=GRAV, damping=damping, period=PERIOD)
    O.dt = DT
    return L0


def record():
    s = O.iter + 1
    c = O.bodies[CID].state
    rec['step'].append(s)
    rec['time'].append(s * DT)
    rec['pos'].append(list(c.pos))
    rec['ori'].append(q_wxyz(c.ori))
    rec['vel'].append(list(c.vel))
    rec['angvel'].append(list(c.angVel))
    rec['angmom'].append(list(c.angMom))
    rec['member_pos'].append([list(O.bodies[i].state.pos) for i in (2, 3, 4)])
    rec['n_interactions'].append(sum(1 for I in O.interactions if I.isReal))
    rec['kinetic_energy'].append(utils.kineticEnergy())


def run(damping):
    global rec
    rec = {k: [] for k in ['step', 'time', 'pos', 'ori', 'vel', 'angvel', 'angmom', 'member_pos', 'n_interactions',
                           'kinetic_energy']}
    L0 = build(damping)
    c = O.bodies[CID]
    info = dict(clump_pos0=np.array(list(c.state.pos)), clump_ori0=np.array(q_wxyz(c.state.ori)),
                clump_mass=np.float64(c.state.mass), clump_inertia=np.array(list(c.state.inertia)),
                member_local_pos=np.array([list(c.shape.members[i][0]) for i in (2, 3, 4)]),
                member_local_ori=np.array([q_wxyz(c.shape.members[i][1]) for i in (2, 3, 4)]),
                clump_angmom0=np.array(L0))
    O.run(NSTEPS, True)
    out = {k: np.array(v) for k, v in rec.items()}
    out['step'] = out['step'].astype(np.int64)
    out['n_interactions'] = out['n_interactions'].astype(np.int64)
    return info, out


data = dict(
    yade_version=np.array(str(yade.config.version)),
    young=np.float64(MAT['young']), poisson=np.float64(MAT['poisson']), density=np.float64(MAT['density']),
    friction_angle=np.float64(MAT['frictionAngle']), normal_cohesion=np.float64(0.0),
    shear_cohesion=np.float64(0.0), is_cohesive=np.bool_(False), moment_rotation_law=np.bool_(False),
    facet_vertices=FACETS.astype(float), member_radius=RADII, member_offset_design=OFFS.astype(float), q0_design=Q0,
    member_pos0=MEMBER_POS0, check_mass_sum=np.float64(CHECK_M), check_inertia_principal=CHECK_I,
    clump_vel0=VEL0, clump_angvel0=W0, dt=np.float64(DT), gravity=np.array(GRAV), n_steps=np.int64(NSTEPS),
    record_period=np.int64(PERIOD), damping=np.float64(0.0), damped_damping=np.float64(0.3),
    set_cohesion_now=np.bool_(False), set_cohesion_on_new_contacts=np.bool_(False),
    use_incremental_form=np.bool_(True), always_use_moment_law=np.bool_(False),
)
for prefix, damp in [('', 0.0), ('damped_', 0.3)]:
    info, out = run(damp)
    if prefix == '':
        data.update(info)
        print('clump pos0', info['clump_pos0'], 'ori0', info['clump_ori0'])
        print('mass yade %.10g  sum-of-spheres %.10g' % (info['clump_mass'], CHECK_M))
        print('inertia yade (sorted)', np.sort(info['clump_inertia']), ' parallel-axes check', CHECK_I)
    for k, v in out.items():
        data[prefix + k] = v
    print('%-8s final pos %s angvel %s n_int %s KE %.4g' % (prefix or 'main', out['pos'][-1], out['angvel'][-1],
                                                           out['n_interactions'][-1], out['kinetic_energy'][-1]))
    print('   first angvel record', out['angvel'][0], 'first contact at step',
          out['step'][np.argmax(out['n_interactions'] > 0)])

np.savez_compressed(OUTFILE, **data)
print('wrote', OUTFILE, os.path.getsize(OUTFILE), 'bytes')
