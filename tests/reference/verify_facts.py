"""Small experiments behind the 'Verified behaviour of Yade 2023.02a' section of README.md.

Run from the repository root:   yade -n -x tests/reference/verify_facts.py
Prints its findings (writes no file).  It also re-checks a few things on the committed npz files, if present.
"""
import os
import sys
import math
import numpy as np
import yade
from yade import utils
from yade.wrapper import *  # noqa

HERE = os.path.dirname(os.path.abspath(sys.argv[0]))
print('yade version', yade.config.version)


def engines(ip2kw, lawkw, grav=(0, 0, 0), damp=0.0):
    return [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
            InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D(), Ig2_Facet_Sphere_ScGeom6D()],
                            [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(label='ip2', **ip2kw)],
                            [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(label='law', **lawkw)]),
            NewtonIntegrator(gravity=grav, damping=damp, label='newton')]


def mat(**kw):
    base = dict(young=1e7, poisson=0.3, density=2700.0, frictionAngle=math.radians(30), normalCohesion=2e4,
                shearCohesion=1e4, momentRotationLaw=True, etaRoll=0.1, etaTwist=0.1, alphaKr=2.0, alphaKtw=2.0)
    base.update(kw)
    return CohFrictMat(**base)


# (a) attribute names
print('\n(a) CohFrictPhys attributes:', [a for a in dir(CohFrictPhys()) if not a.startswith('_')])
p = CohFrictPhys()
print('    defaults: unp', p.unp, 'unpMax', p.unpMax, 'cohesionBroken', p.cohesionBroken, 'fragile', p.fragile,
      'cohesionDisablesFriction', p.cohesionDisablesFriction, 'maxRollPl', p.maxRollPl)

# (b) law flags
law = Law2_ScGeom6D_CohFrictPhys_CohesionMoment()
print('\n(b) Law2 always_use_moment_law default', law.always_use_moment_law, '; useIncrementalForm default',
      law.useIncrementalForm)
ip = Ip2_CohFrictMat_CohFrictMat_CohFrictPhys()
print('    Ip2 setCohesionNow default', ip.setCohesionNow, '; setCohesionOnNewContacts default',
      ip.setCohesionOnNewContacts)
m = CohFrictMat()
print('    CohFrictMat defaults:', {k: getattr(m, k) for k in ['young', 'poisson', 'density', 'frictionAngle',
                                                            'normalCohesion', 'shearCohesion', 'momentRotationLaw',
                                                            'etaRoll', 'etaTwist', 'alphaKr', 'alphaKtw', 'fragile',
                                                            'isCohesive']})

# (c) sphere-facet contact physics; facet and sphere materials deliberately different
R = 0.01
for Ef, etaf, Cf in [(1e7, 0.1, 2e4), (2e7, 0.1, 4e4)]:
    O.reset()
    fm = O.materials.append(mat(young=Ef, etaRoll=etaf, etaTwist=etaf, normalCohesion=Cf, shearCohesion=Cf / 2))
    sm = O.materials.append(mat(young=1e7, etaRoll=0.3, etaTwist=0.3))
    O.bodies.append(utils.facet([(-1, -1, 0), (1, -1, 0), (0, 1, 0)], fixed=True, material=fm))
    O.bodies.append(utils.sphere((0, 0, R - 1e-5), R, material=sm, fixed=True))
    O.engines = engines(dict(setCohesionOnNewContacts=True), dict(useIncrementalForm=True))
    O.dt = 1e-6
    O.run(1, True)
    I = O.interactions[0, 1]
    ph, g = I.phys, I.geom
    print('\n(c) facet E=%g eta=%g Cn=%g, sphere E=1e7 eta=0.3 Cn=2e4, R=%g: id1=%d id2=%d geom.refR1=%g refR2=%g'
          % (Ef, etaf, Cf, R, I.id1, I.id2, g.refR1, g.refR2))
    print('    kn=%.10g ks=%.10g kr=%.10g ktw=%.10g maxRollPl=%.6g maxTwistPl=%.6g normalAdhesion=%.6g shearAdhesion=%.6g'
          % (ph.kn, ph.ks, ph.kr, ph.ktw, ph.maxRollPl, ph.maxTwistPl, ph.normalAdhesion, ph.shearAdhesion))
    R1, R2 = 2 * R, R
    kn = 2 * (Ef * R1) * (1e7 * R2) / (Ef * R1 + 1e7 * R2)
    ks = 2 * (Ef * R1 * 0.3) * (1e7 * R2 * 0.3) / (Ef * R1 * 0.3 + 1e7 * R2 * 0.3)
    print('    formula with R1=2R: kn=%.10g ks=%.10g kr=R1R2 ks 2=%.10g maxRollPl=min(eta_f 2R, eta_s R)=%.6g '
          'an=min(Cn)R^2=%.6g' % (kn, ks, R1 * R2 * ks * 2, min(etaf * R1, 0.3 * R2), min(Cf, 2e4) * R * R))

# (d) fragile flag combination
print('\n(d) fragile combination (material1, material2) -> CohFrictPhys.fragile')
for f1, f2 in [(True, True), (True, False), (False, True), (False, False)]:
    O.reset()
    m1 = O.materials.append(mat(fragile=f1))
    m2 = O.materials.append(mat(fragile=f2))
    O.bodies.append(utils.sphere((0, 0, 0), R, material=m1, fixed=True))
    O.bodies.append(utils.sphere((0.0199, 0, 0), R, material=m2, fixed=True))
    O.engines = engines(dict(setCohesionNow=True), dict(useIncrementalForm=True))
    O.dt = 1e-6
    O.run(1, True)
    print('    ', f1, f2, '->', O.interactions[0, 1].phys.fragile)


# (e) rolling-moment cap in a cohesive contact going through Fn = 0 into tension
def pair(vel2, angvel2, fragile=True, always=False, unpmax=None):
    O.reset()
    m1 = O.materials.append(mat(fragile=fragile))
    for x, v, w in [((0, 0, 0), (0, 0, 0), (0, 0, 0)), ((0.0199, 0, 0), vel2, angvel2)]:
        b = utils.sphere(x, R, material=m1)
        b.state.blockedDOFs = 'xyzXYZ'
        b.state.vel = v
        b.state.angVel = w
        O.bodies.append(b)
    O.engines = engines(dict(setCohesionNow=True), dict(useIncrementalForm=True, always_use_moment_law=always))
    O.dt = 1e-6
    O.run(1, True)
    if unpmax is not None:
        O.interactions[0, 1].phys.unpMax = unpmax


print('\n(e) pure normal pull-apart (v=0.01 m/s) + bending spin (0,0.3,0): |Mb| vs maxRollPl*|Fn|')
pair((0.01, 0, 0), (0, 0.3, 0))
while True:
    O.run(100, True)
    if not (O.interactions.has(0, 1) and O.interactions[0, 1].isReal):
        print('    contact deleted after step', O.iter)
        break
    ph = O.interactions[0, 1].phys
    fn = ph.normalForce.dot(O.interactions[0, 1].geom.normal)
    if O.iter % 2000 == 1 or abs(fn) < 0.35:
        print('    step %5d Fn=%+.4f |Mb|=%.4e maxRollPl*|Fn|=%.4e |Fs|=%.4f cohesionBroken=%d' % (
            O.iter, fn, ph.moment_bending.norm(), ph.maxRollPl * abs(fn), ph.shearForce.norm(), ph.cohesionBroken))

print('\n    non-fragile, default unpMax (=0) vs unpMax=-1, pure normal pull (v=0.01 m/s), no spin:')
for um in [None, -1.0]:
    pair((0.01, 0, 0), (0, 0, 0), fragile=False, unpmax=um)
    O.run(14000, True)
    ex = O.interactions.has(0, 1) and O.interactions[0, 1].isReal
    print('    unpMax=%s: after 14000 steps exists=%s' % ('default' if um is None else um, ex),
          '' if not ex else 'Fn=%.4f unp=%.4e' % (O.interactions[0, 1].phys.normalForce.dot(
              O.interactions[0, 1].geom.normal), O.interactions[0, 1].phys.unp))

# (f) blocked bodies
print('\n(f) blocked bodies: body 0 fixed, body 1 blockedDOFs=xyzXYZ with imposed vel (0,0.002,0), angVel (0,0,0.5)')
pair((0, 0.002, 0), (0, 0, 0.5))
O.run(99, True)
I = O.interactions[0, 1]
print('    after 100 steps: body0 pos', O.bodies[0].state.pos, 'vel', O.bodies[0].state.vel)
print('    body1 vel', O.bodies[1].state.vel, 'angVel', O.bodies[1].state.angVel, '(unchanged)')
print('    O.forces.f(0)', O.forces.f(0), ' O.forces.t(0)', O.forces.t(0))
print('    O.forces.f(1)', O.forces.f(1), ' O.forces.t(1)', O.forces.t(1))
print('    phys.shearForce', I.phys.shearForce, ' |Fs|/ks =', I.phys.shearForce.norm() / I.phys.ks,
      ' expected |alpha*0.002 - 0.5*R| * 100 dt (alpha=(R1+R2)/(R1+R2-un); the creation step counts):',
      abs(0.002 * 0.02 / 0.0199 - 0.5 * R) * 100e-6)
print('    t0 expected (C-x0) x f0 - Mb with Mb = -kr*0.5*100dt e_z:',
      np.cross(np.array(I.geom.contactPoint) - np.array(O.bodies[0].state.pos), np.array(O.forces.f(0)))
      - np.array([0, 0, -I.phys.kr * 0.5 * 100e-6]), ' phys.moment_bending', I.phys.moment_bending)
print('    utils.sphere(fixed=True).state.blockedDOFs =', repr(utils.sphere((0, 0, 0), 1, fixed=True).state.blockedDOFs))

# (g) clump mass / inertia
print('\n(g) clump of radii (0.010,0.008,0.012) at (0,0,0),(0.014,0,0.004),(-0.006,0.012,0), rho=2700')
O.reset()
mm = O.materials.append(mat())
radii = [0.010, 0.008, 0.012]
cen = np.array([[0, 0, 0], [0.014, 0, 0.004], [-0.006, 0.012, 0]])
cid, mids = O.bodies.appendClumped([utils.sphere(tuple(c), r, material=mm) for c, r in zip(cen, radii)])
c = O.bodies[cid].state
ms = np.array([2700 * 4 / 3 * math.pi * r ** 3 for r in radii])
com = (ms[:, None] * cen).sum(0) / ms.sum()
It = sum(0.4 * m_ * r * r * np.eye(3) + m_ * ((x - com) @ (x - com) * np.eye(3) - np.outer(x - com, x - com))
         for m_, r, x in zip(ms, radii, cen))
print('    Yade mass %.12g, sum of sphere masses %.12g' % (c.mass, ms.sum()))
print('    Yade pos', c.pos, ' mass-weighted centre', com)
print('    Yade inertia', c.inertia, ' eigenvalues of parallel-axes tensor', np.linalg.eigvalsh(It))
R_ = np.array(c.ori.toRotationMatrix())
print('    R diag(I) R^T == parallel-axes tensor:', np.allclose(R_ @ np.diag(list(c.inertia)) @ R_.T, It, rtol=1e-9,
                                                               atol=1e-15))
# overlap counted twice? two fully coincident spheres
O.reset()
mm = O.materials.append(mat())
cid2, _ = O.bodies.appendClumped([utils.sphere((0, 0, 0), 0.01, material=mm), utils.sphere((0.001, 0, 0), 0.01,
                                                                                           material=mm)])
print('    two heavily overlapping r=0.01 spheres: clump mass %.10g = 2 x sphere mass %.10g'
      % (O.bodies[cid2].state.mass, 2 * 2700 * 4 / 3 * math.pi * 1e-6))
# angVel vs angMom for clumps
O.reset()
mm = O.materials.append(mat())
cid, mids = O.bodies.appendClumped([utils.sphere(tuple(c_), r, material=mm) for c_, r in zip(cen, radii)])
O.engines = [ForceResetter(), NewtonIntegrator(gravity=(0, 0, 0), damping=0)]
O.dt = 2e-5
O.bodies[cid].state.angVel = (1, -2, 3)
print('    clump: set only angVel=(1,-2,3): angMom =', O.bodies[cid].state.angMom)
O.run(1, True)
print('    ... after one step angVel =', O.bodies[cid].state.angVel, ' angMom =', O.bodies[cid].state.angMom)
# single sphere: angVel is used directly
O.reset()
O.bodies.append(utils.sphere((0, 0, 0), 0.01))
O.engines = [ForceResetter(), NewtonIntegrator(gravity=(0, 0, 0), damping=0)]
O.bodies[0].state.angVel = (1, -2, 3)
O.run(1, True)
print('    single sphere: set angVel=(1,-2,3): after one step angVel =', O.bodies[0].state.angVel,
      'angMom =', O.bodies[0].state.angMom)

# checks on committed data
f = os.path.join(HERE, 'cohesive_pair.npz')
if os.path.exists(f):
    d = np.load(f)
    print('\n(npz) cohesive_pair checks')
    for p in ['', 'noalways_']:
        ex = d[p + 'exists']
        C, x0 = d[p + 'contact_point'][ex], d[p + 'pos'][ex, 0]
        f0 = d[p + 'force_b0'][ex]
        fn, fs = d[p + 'normal_force'][ex], d[p + 'shear_force'][ex]
        M = d[p + 'moment_bending'][ex] + d[p + 'moment_twist'][ex]
        cb = d[p + 'cohesion_broken'][ex] > 0.5
        t_expect = np.cross(C - x0, f0) - (M if p == '' else np.where(cb[:, None], 0.0, M))
        print('   %-9s max|f0 + Fn + Fs| = %.2e   max|t0 - ((C-x0)xf0 - M_applied)| = %.2e' % (
            p or 'main', np.abs(f0 + fn + fs).max(), np.abs(d[p + 'torque_b0'][ex] - t_expect).max()))
        nf = np.einsum('ij,ij->i', fn, d[p + 'normal'][ex])
        mb = np.linalg.norm(d[p + 'moment_bending'][ex], axis=1)
        act = ~cb if p == 'noalways_' else np.ones_like(cb)
        print('              max(|Mb| - maxRollPl|Fn|) over contacts where the moment law is active = %.2e' % (
            (mb - d[p + 'max_roll_pl'][ex] * np.abs(nf))[act].max()))
