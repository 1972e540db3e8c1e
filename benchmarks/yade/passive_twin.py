"""Yade twin of warpdem's PASSIVE ci soil-bin run (Yade 2023.02a), from the spec written by passive_twin_export.py.

Run from the repository root (one thread, no -j):

    yade -n -x benchmarks/yade/passive_twin.py A 16                 # -> passive_twin_yade_A_16.npz / .log
    yade -n -x benchmarks/yade/passive_twin.py A 16 --perturb 1e-9 --seed 1 --tag _p1
        (every particle displaced as a whole by RandomState(seed).uniform(-eps, eps, (n_particles, 3)) m: another
        realization of the same bed, as soil_bin_twin.py --perturb and passive_twin_export.py --seeds)
    yade -n -x benchmarks/yade/passive_twin.py test A 16            # closed-form checks without soil; writes nothing
        but passive_twin_yade_test_A_16.log

Hidden effects (default off; each changes the output name unless --tag is given: e.g. _pitch1.5, see OUT below):

    --pitch DEG         a mounting error of the tool on its pivot: the tool's geometry (facets) and its centre of
                        mass turned BACKWARDS by DEG about the pivot's x axis (scenes.sweep.pitch_matrix: the tip
                        rises, lower points move against travel), while the spring's seat on the tool and the
                        sensor's target stay where the drawing puts them (they sit on the pivot's clamp, which is
                        not turned): the spring's zero and the sensor's zero are unchanged, so the tool runs turned
                        back by DEG more than the clean one under the same loads (its blade's attack angle changes).
                        The moment of inertia about the pivot's x axis is unchanged by a rotation about x; the
                        weight's moment changes with the centre of mass. Particles that the turned lower half's
                        bounding box (grown by radius + 2 mm, scenes.soil_bin.clear_start's rule) would overlap are
                        left out. NOT warpdem's run_soil_bin(pitch=...) for a passive tool: that one turns the whole
                        body, the spring's seat with it, and the springs pull it back (a start condition: see
                        --start-rotation).
    --start-rotation DEG  warpdem's run_soil_bin(pitch=[DEG]) semantics: the whole tool (seat and sensor target
                        included) starts turned back by DEG; the springs take it from there. Particles cleared as
                        for --pitch; the sensor's reading is from the drawing pose (it includes the start rotation,
                        as warpdem's pitched reading does).
    --preload M         warpdem's stack_preload knob, its law copied: the spring gets preload P = -k M (a
                        compression) and a stop of stiffness STOP_RATIO k (spec key stop_ratio) at its rest length:
                        F = P + k u + c du/dt, plus STOP_RATIO k u where P u < 0 (u > 0 here: the tool resting on
                        the stop until the soil's load exceeds k M).
    --pivot-friction NM a Coulomb torque of NM at the hinge, warpdem's law (warpdem.integrator.integrate_hinged):
                        opposing the trial angular velocity w* = w + dt T / I_p that the step would give with every
                        other torque; where dt NM / I_p >= |w*| the tool sticks (the torque that makes w = 0 this
                        step is applied), else -NM sign(w*). Exact stick-slip for one free rotation, no
                        regularisation (warpdem has none).
    --extra-mass KG     a heavier tool. --extra-mass-at distributed (default): warpdem's extra_mass knob (mass and
                        inertia scaled together, centre of mass unchanged: I_p and the weight's moment times
                        (m + KG) / m); --extra-mass-at sensor: a point mass at the sensor point (on the clamp, so it
                        does not turn with --pitch); --extra-mass-at X,Y,Z: a point mass at that world point of the
                        drawing pose (turned with --pitch). A point mass adds KG d^2 (d its distance from the pivot
                        axis) to I_p and its own weight's moment.

Set-up: --no-support-offset reads passive_twin_spec_<A>_<n>_nooffset.npz (passive_twin_export.py
--no-support-offset: Table 2's support offsets off, the rig model's baseline) and names its outputs
passive_twin_yade_<A>_<n>_nooffset[tag]; --out-dir DIR writes the npz and log into DIR instead of beside the script
(bulk runs, e.g. passive_twin_table.py).

Diagnostics: --full-records (every recorded key, not only the compact set), --steps N (a shorter run), --every N
(records every N steps), --verlet D (the collider's verletDist; 0: collide every step), --ring-time T (test mode's
ringing, s).

Verified against warpdem (passive_twin_report.md): before the tool first meets the soil both engines' tool rotation,
displacement and spring force agree to ~1e-7 (relative), clean and with each option that has a warpdem counterpart
(--start-rotation = run_soil_bin(pitch=...), --preload = knob stack_preload, --pivot-friction = knob
pivot_friction, --extra-mass with the default "distributed" = knob extra_mass); --pitch and a point --extra-mass
have none. With --pitch the recorded rotation and displacement are the clamp's (the sensor's): the blade's attitude
is the recorded rotation less the pitch (a backward pitch is a negative rotation about +x).

Scene (everything from the spec; nothing re-derived):
- materials, bin facets and soil as soil_bin_twin.py (CohFrictMat with the float32 values warpdem's kernels read,
  Ip2 setCohesionNow=True / setCohesionOnNewContacts=False, Law2 incremental with always_use_moment_law).
- the tool: its lower and upper facets (utils.facet, ids len(bin) .. NF-1, lower first: the draught is the force on
  them) as ONE clump whose state.pos is AT THE PIVOT. Yade computes a clump's position as the members' mass-weighted
  centre and aborts on a massless clump, so before clumping the two triangles of the upper shank's top face (a
  rectangle centred on the pivot, point-symmetric about it: their incentres average to the pivot) get half the tool's
  mass each and every other facet none; the clump's position is then the pivot to round-off (checked). Then
  state.mass = the tool's mass, state.inertia = (I_p,xx, I_p,yy, I_p,zz) (the inertia tensor about the pivot: with
  blocked rotations Yade integrates rotation like a sphere's, in world axes, angAccel_x = torque_x / inertia[0];
  ringing_twin.py's docstring), blockedDOFs = 'xyzYZ' and state.vel = the pivot's (carriage) velocity: a blocked
  body keeps its velocity, so the pivot moves x += v dt with the carriage while the tool turns about x. The facets'
  masses are reset to 0.
- Gravity: NewtonIntegrator applies gravity only to free translations, so the clump (translations blocked) gets
  none; its moment about the pivot, (R (com0 - pivot0)) x m g with R the tool's rotation since the start, is added
  every step by a PyRunner(iterPeriod=1, initRun=True: without it a PeriodicEngine skips iteration 0) placed after
  InteractionLoop (after ForceResetter) and before
  NewtonIntegrator, with O.forces.addT on the clump. The same PyRunner adds the spring-dashpot's torque about the
  pivot, exactly warpdem's spring (warpdem.integrator.spring_one): anchor a = the carriage's point (spec
  spring_anchor, moving with the carriage: a(t) - pivot(t) is constant), attachment b = the tool's point (spec
  spring_attach, turning with the tool), d = b - a, u = d / |d|, stretch |d| - rest_length, rate = (v_b - v_a).u with
  v_b = v_pivot + w x (b - pivot), v_a = the carriage's velocity, F = P + k stretch + c rate (+ stop), tension
  positive, force -F u on the tool at b; and the pivot friction's torque. The spring's force on the clump's
  translation is not applied (translations are blocked: it would change nothing). Contact forces on the facets
  reach the clump through Yade's own member sums (torque about the clump's position, the pivot).
- records (PyRunner after NewtonIntegrator, iterPeriod = record_every, and one before the first step): after
  s = 0, every, 2 every, ... completed steps, as warpdem's records.

Recorded keys (k records; without --full-records only step, draught, rotation, angvel, displacement,
spring_force, ke_tool, c_ss, coh_ss, c_sf_lower, wd_drop_lower are written): ``step``, ``time``; ``draught`` = -(sum
over lower facets of O.forces.f)_y [N]; ``force_lower``, ``force_upper`` (k, 3) [N]; ``contact_torque_x`` [N m] (the
facets' contact forces and moments about the pivot, x); ``rotation`` [rad] (about +x, from the drawing pose:
atan2(M21, M11) of M = R(q) R(q0)^T, plus the start rotation); ``angvel`` [rad/s] (x); ``displacement`` [m]
(warpdem's: -(sensor_y(t) - sensor_y(drawing) - v t), the sensor a material point of the tool fixed at the start,
its reference the drawing pose's sensor point; run_soil_bin without passive_tool reads from the drawing pose as
well, since the run has no settling); ``spring_force`` [N] (the last step's, tension > 0), ``spring_length`` [m],
``spring_torque_x``, ``gravity_torque_x``, ``friction_torque_x`` [N m] (the last step's); ``pivot_y`` [m];
``ke_tool`` [J] (translation of the centre of mass + rotation about it, as warpdem's group_kinetic_energy("tool"));
``ke_soil`` [J] (utils.kineticEnergy less the tool's); ``c_ss``, ``coh_ss`` (sphere-sphere interactions and unbroken
bonds), ``c_sf_lower`` (sphere-facet interactions on the lower half), ``wd_drop_lower`` (how many of them warpdem's
merging rule would not have: a sphere on an edge or vertex shared by several lower facets gets one interaction per
facet in Yade, one merged contact in warpdem), ``z_particle_ss`` = 2 c_ss / n_particles (warpdem's
coordination_number("soil")). Plus ``wall_s``, ``yade_version``, the options, ``n_cleared``, ``tool_inertia_used``
(3,), ``tool_mass_used``, ``dt`` etc. as one json string ``meta``.
"""
import json
import math
import os
import sys
import time

import numpy as np
import yade
from yade import O, utils
from yade.minieigenHP import Vector3
from yade.wrapper import (
    Bo1_Facet_Aabb,
    Bo1_Sphere_Aabb,
    CohFrictMat,
    ForceResetter,
    Ig2_Facet_Sphere_ScGeom6D,
    Ig2_Sphere_Sphere_ScGeom6D,
    InsertionSortCollider,
    InteractionLoop,
    Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
    Law2_ScGeom6D_CohFrictPhys_CohesionMoment,
    NewtonIntegrator,
    PyRunner,
)

HERE = os.path.dirname(os.path.abspath(sys.argv[0]))
sys.path.insert(0, HERE)
import soil_bin_twin_common as common  # noqa: E402

args = sys.argv[1:]
VALUED = ("--perturb", "--seed", "--tag", "--steps", "--pitch", "--start-rotation", "--preload", "--pivot-friction",
          "--extra-mass", "--extra-mass-at", "--ring-time", "--verlet", "--every", "--out-dir")
words = [a for k, a in enumerate(args) if not a.startswith("--") and (k == 0 or args[k - 1] not in VALUED)]
TEST = bool(words) and words[0] == "test"
if TEST:
    words = words[1:]
ASSEMBLY = (words[0] if words else "A").upper()
SPRINGS = int(words[1]) if len(words) > 1 else 16


def opt(name, default, cast):
    return cast(args[args.index(name) + 1]) if name in args else default


PERTURB = opt("--perturb", 0.0, float)
SEED = opt("--seed", 0, int)
STEPS = opt("--steps", None, int)
PITCH = opt("--pitch", 0.0, float)
START = opt("--start-rotation", 0.0, float)
PRELOAD = opt("--preload", 0.0, float)
PIVOT_FRICTION = opt("--pivot-friction", 0.0, float)
EXTRA_MASS = opt("--extra-mass", 0.0, float)
EXTRA_AT = opt("--extra-mass-at", "distributed", str)
RING_TIME = opt("--ring-time", 1.2, float)
FULL = "--full-records" in args  # every key below; default: the compact set COMPACT (small files)
VERLET = opt("--verlet", None, float)  # the collider's verletDist (default Yade's -0.5; 0: collide every step)
EFFECTS = "".join(s for s in (
    f"_pitch{PITCH:g}" if PITCH else "", f"_start{START:g}" if START else "",
    f"_preload{PRELOAD:g}" if PRELOAD else "", f"_fric{PIVOT_FRICTION:g}" if PIVOT_FRICTION else "",
    f"_mass{EXTRA_MASS:g}" + ("" if EXTRA_AT == "distributed" else "@" + EXTRA_AT.replace(",", "_"))
    if EXTRA_MASS else ""))
TAG = opt("--tag", EFFECTS, str)
NO_OFFSET = "--no-support-offset" in args  # the spec without Table 2's support offsets (export --no-support-offset)
NAME = f"{ASSEMBLY}_{SPRINGS}" + ("_nooffset" if NO_OFFSET else "")
SPEC = os.path.join(HERE, f"passive_twin_spec_{NAME}.npz")
OUT_DIR = opt("--out-dir", HERE, str)  # where the npz and log go (default: beside the script)
if not os.path.isdir(OUT_DIR):
    os.makedirs(OUT_DIR)
OUT = os.path.join(OUT_DIR, f"passive_twin_yade_{'test_' if TEST else ''}{NAME}{TAG}.npz")
LOG = open(OUT[:-4] + ".log", "w")


def log(*a):
    s = " ".join(str(x) for x in a)
    print(s)
    sys.stdout.flush()
    LOG.write(s + "\n")
    LOG.flush()


sp = {k: v for k, v in np.load(SPEC).items()}
log("Yade", yade.config.version, "spec", SPEC, "test" if TEST else "run", "perturb", PERTURB, "seed", SEED,
    "pitch", PITCH, "start-rotation", START, "preload", PRELOAD, "pivot-friction", PIVOT_FRICTION, "extra-mass",
    EXTRA_MASS, EXTRA_AT)
DT = float(sp["dt"])
EVERY = opt("--every", int(sp["record_every"]), int)  # records every EVERY steps (default warpdem's)
GRAV = np.asarray(sp["gravity"], dtype=float)
PIVOT0 = np.asarray(sp["tool_pivot"], dtype=float)
V_PIVOT = np.asarray(sp["pivot_velocity"], dtype=float)
V_CARR = np.asarray(sp["carriage_velocity"], dtype=float)
SENSOR0 = np.asarray(sp["sensor_point"], dtype=float)
ANCHOR_REL = np.asarray(sp["spring_anchor"], dtype=float) - PIVOT0  # constant: carriage and pivot move together
K = float(sp["spring_stiffness"])
C_DASH = float(sp["spring_damping"])
REST = float(sp["spring_rest_length"])
K3 = float(sp["spring_progressive"])
STOP_RATIO = float(sp["stop_ratio"])


def pitch_matrix(angle):
    """scenes.sweep.pitch_matrix: a backward pitch by angle [deg] = a rotation about +x by -angle."""
    t = math.radians(-float(angle))
    c, s = math.cos(t), math.sin(t)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rotm(q):
    return np.array(q.toRotationMatrix())


def mat(prefix):
    def g(k):
        return float(sp[prefix + "_" + k + "_f32"])

    return dict(young=g("young"), poisson=g("poisson"), density=float(sp[prefix + "_density"]),
                frictionAngle=g("friction_angle_rad"), normalCohesion=g("normal_cohesion"),
                shearCohesion=g("shear_cohesion"), etaRoll=g("eta_roll"), etaTwist=g("eta_twist"),
                alphaKr=g("alpha_kr"), alphaKtw=g("alpha_ktw"), momentRotationLaw=bool(sp[prefix + "_moment_law"]),
                fragile=bool(sp[prefix + "_fragile"]), isCohesive=bool(sp[prefix + "_cohesive"]))


S = {}  # the current scene


def build(soil=True, dashpot=C_DASH, preload=PRELOAD, friction=PIVOT_FRICTION, pitch=PITCH, start=START,
          extra=EXTRA_MASS, extra_at=EXTRA_AT):
    """O.reset() and the scene (module docstring); ``start`` [deg]: the whole tool turned back at the start."""
    O.reset()
    tm = O.materials.append(CohFrictMat(label="tool", **mat("tool")))
    smat = O.materials.append(CohFrictMat(label="soil", **mat("soil")))
    bin_tri, low_tri, up_tri = sp["bin_tri"], sp["tool_lower_tri"], sp["tool_upper_tri"]
    nf = len(bin_tri) + len(low_tri) + len(up_tri)
    geo = pitch_matrix(pitch + start)  # the tool's geometry and centre of mass
    seat = pitch_matrix(start)  # the spring's seat and the sensor's target (not turned by a mounting error)

    def turn(rot, p):
        return (np.asarray(p, dtype=float) - PIVOT0) @ rot.T + PIVOT0

    tri_tool = turn(geo, np.concatenate([low_tri, up_tri]).reshape(-1, 3)).reshape(-1, 3, 3)
    for k, tri in enumerate(bin_tri):
        assert O.bodies.append(utils.facet([tuple(map(float, v)) for v in tri], fixed=True, material=tm)) == k
    facets = [utils.facet([tuple(map(float, v)) for v in tri], fixed=False, material=tm) for tri in tri_tool]
    # point masses: the two triangles of the upper shank's top face (z = the pivot's; point-symmetric about it)
    z_top = np.asarray(up_tri)[:, :, 2].max()
    top = [len(low_tri) + j for j, t in enumerate(up_tri) if np.all(np.abs(t[:, 2] - z_top) < 1e-12)]
    assert len(top) == 2, top
    m_tool = float(sp["tool_mass"])
    for j, b in enumerate(facets):
        b.state.mass = 0.5 * m_tool if j in top else 0.0
        b.state.inertia = (0.0, 0.0, 0.0)
    cid, mids = O.bodies.appendClumped(facets)
    mids = list(mids)
    assert mids == list(range(len(bin_tri), nf)), (mids[:3], nf)
    c = O.bodies[cid]
    err = float(np.linalg.norm(np.array(list(c.state.pos)) - PIVOT0))
    if err > 1e-12:
        raise RuntimeError(f"clump position {c.state.pos} differs from the pivot {PIVOT0} by {err:g} m")
    for i in mids:
        O.bodies[i].state.mass = 0.0
    # mass properties about the pivot (world axes at the drawing pose, then turned by `geo`)
    com = turn(geo, sp["tool_com"])
    i_p = geo @ np.asarray(sp["tool_inertia_pivot"], dtype=float) @ geo.T
    mass = m_tool
    point = None
    if extra > 0:
        if extra_at == "distributed":  # warpdem's knob: mass and inertia scaled together, com unchanged
            i_p = i_p * (m_tool + extra) / m_tool
            mass = m_tool + extra
        else:
            point = seat @ (SENSOR0 - PIVOT0) + PIVOT0 if extra_at == "sensor" else turn(
                geo, [float(x) for x in extra_at.split(",")])
            d = point - PIVOT0
            i_p = i_p + extra * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    c.state.mass = mass
    c.state.inertia = tuple(float(i_p[k, k]) for k in range(3))
    c.state.blockedDOFs = "xyzYZ"
    c.state.vel = tuple(float(v) for v in V_PIVOT)
    c.state.isDamped = False
    n_cleared = 0
    S["n_particles"] = 0
    if soil:
        radius, particle = sp["sphere_radius"], sp["sphere_particle"]
        pos = sp["sphere_pos"].copy()
        if PERTURB > 0:
            pos += np.random.RandomState(SEED).uniform(-PERTURB, PERTURB, (int(sp["n_particles"]), 3))[particle]
        keep = np.ones(int(sp["n_particles"]), bool)
        if pitch or start:  # scenes.soil_bin.clear_start on the turned lower half (the spec's bed is cleared already)
            lv = tri_tool[:len(low_tri)].reshape(-1, 3)
            lo, hi = lv.min(axis=0), lv.max(axis=0)
            grow = (radius + 0.002)[:, None]
            inside = np.all((pos > lo - grow) & (pos < hi + grow), axis=1)
            np.logical_and.at(keep, particle, ~inside)
            n_cleared = int((~keep).sum())
        starts = np.r_[0, np.cumsum(np.bincount(particle))[:-1]]
        counts = np.bincount(particle)
        for p in np.flatnonzero(keep):
            a, n = int(starts[p]), int(counts[p])
            if n == 1:
                O.bodies.append(utils.sphere(tuple(map(float, pos[a])), float(radius[a]), material=smat))
            else:
                O.bodies.appendClumped([utils.sphere(tuple(map(float, pos[j])), float(radius[j]), material=smat)
                                        for j in range(a, a + n)])
        S["n_particles"] = int(keep.sum())
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], label="collider"),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D(), Ig2_Facet_Sphere_ScGeom6D()],
                        [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(
                            label="ip2", setCohesionNow=bool(sp["set_cohesion_now"]),
                            setCohesionOnNewContacts=bool(sp["set_cohesion_on_new_contacts"]))],
                        [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(
                            label="law", useIncrementalForm=bool(sp["use_incremental_form"]),
                            always_use_moment_law=bool(sp["always_use_moment_law"]))]),
        PyRunner(iterPeriod=1, initRun=True, command="tool_loads()", label="loads"),
        NewtonIntegrator(gravity=tuple(float(g) for g in GRAV), damping=float(sp["local_damping"]), label="newton"),
        PyRunner(iterPeriod=EVERY, firstIterRun=EVERY - 1, command="record()", label="recorder"),
    ]
    O.dt = DT
    if VERLET is not None:
        O.engines[1].verletDist = VERLET
    S.update(cid=cid, mids=mids, low=list(range(len(bin_tri), len(bin_tri) + len(low_tri))),
             up=list(range(len(bin_tri) + len(low_tri), nf)), bins=list(range(len(bin_tri))), nf=nf,
             tri_low0=tri_tool[:len(low_tri)], R0=rotm(c.state.ori), theta_start=-math.radians(start),
             com_rel=com - PIVOT0, mass=mass, i_p=i_p,
             point=None if point is None else point - PIVOT0, extra=extra if point is not None else 0.0,
             attach_rel=seat @ (np.asarray(sp["spring_attach"], dtype=float) - PIVOT0),
             sensor_rel=seat @ (SENSOR0 - PIVOT0), k=K, c=dashpot, p=-K * preload,
             stop=STOP_RATIO * K if preload > 0 else 0.0, friction=friction, last={}, n_cleared=n_cleared,
             rec={k: [] for k in KEYS})
    cleared = f" ({n_cleared} cleared for the turned tool)" if n_cleared else ""
    log(f"clump at the pivot to {err:.1e} m; mass {mass:.4f} kg, inertia about the pivot (x, y, z) "
        f"{np.array2string(np.diag(i_p), precision=6)} kg m^2, centre of mass "
        f"{np.array2string(com - PIVOT0, precision=6)} m from the pivot; spring k {K:.1f} N/m, c {dashpot:.3f} N s/m, "
        f"rest {REST:.9f} m, preload {S['p']:.2f} N, stop {S['stop']:.1f} N/m; pivot friction {friction:.3f} N m; "
        f"{S['n_particles'] if soil else 'no'} particles{cleared}")


def frame():
    """(pivot now, rotation since the start, angular velocity x)."""
    st = O.bodies[S["cid"]].state
    return np.array(list(st.pos)), rotm(st.ori) @ S["R0"].T, float(st.angVel[0])


def tool_loads():
    """Gravity's moment, the spring-dashpot and the pivot friction, as torques about the pivot (module docstring)."""
    p, R, w = frame()
    omega = np.array([w, 0.0, 0.0])
    tg = np.cross(R @ S["com_rel"], S["mass"] * GRAV)
    if S["point"] is not None:
        tg = tg + np.cross(R @ S["point"], S["extra"] * GRAV)
    rb = R @ S["attach_rel"]
    d = rb - ANCHOR_REL  # b - a (both relative to the pivot)
    length = float(np.linalg.norm(d))
    u = d / length if length > 0 else np.array([0.0, 0.0, 1.0])
    rate = float(np.dot(V_PIVOT + np.cross(omega, rb) - V_CARR, u))
    stretch = length - REST
    f = S["p"] + S["k"] * stretch + K3 * stretch**3 + S["c"] * rate
    if S["p"] * stretch < 0.0:
        f += S["stop"] * stretch
    ts = np.cross(rb, -f * u)
    t = tg + ts
    tf = 0.0
    if S["friction"] > 0:  # warpdem's stick-slip on the trial angular velocity of this step
        tc = 0.0
        for i in S["mids"]:  # sync=True: the member sums of this step (OpenMP build)
            fi, ti = O.forces.f(i, True), O.forces.t(i, True)
            r = np.array(list(O.bodies[i].state.pos)) - p
            tc += ti[0] + r[1] * fi[2] - r[2] * fi[1]
        i_x = S["i_p"][0, 0]
        trial = w + DT * (tc + t[0]) / i_x
        if trial != 0.0:
            if DT * S["friction"] / i_x >= abs(trial):
                tf = -trial * i_x / DT
            else:
                tf = -math.copysign(S["friction"], trial)
    O.forces.addT(S["cid"], Vector3(float(t[0] + tf), float(t[1]), float(t[2])))
    S["last"] = dict(spring_force=f, spring_length=length, spring_torque_x=float(ts[0]),
                     gravity_torque_x=float(tg[0]), friction_torque_x=tf)


KEYS = ["step", "time", "draught", "force_lower", "force_upper", "contact_torque_x", "rotation",
        "angvel", "displacement", "spring_force", "spring_length", "spring_torque_x", "gravity_torque_x",
        "friction_torque_x", "pivot_y", "ke_tool", "ke_soil", "c_ss", "coh_ss", "c_sf_lower", "wd_drop_lower",
        "z_particle_ss"]


def snapshot(s, counts=True):
    p, R, w = frame()
    out = {"step": s, "time": s * DT}
    fs = {}
    tc = 0.0
    for key, ids in (("force_lower", S["low"]), ("force_upper", S["up"])):
        f = np.zeros(3)
        for i in ids:
            fi = np.array(list(O.forces.f(i)))
            f += fi
            r = np.array(list(O.bodies[i].state.pos)) - p
            tc += O.forces.t(i)[0] + r[1] * fi[2] - r[2] * fi[1]
        fs[key] = f
    out.update(fs, draught=-fs["force_lower"][1], contact_torque_x=tc)
    out["rotation"] = math.atan2(R[2, 1], R[1, 1]) + S["theta_start"]
    out["angvel"] = w
    sensor = p + R @ S["sensor_rel"]
    out["displacement"] = -(sensor[1] - SENSOR0[1] - float(V_CARR[1]) * s * DT)
    last = S["last"] or dict(spring_force=0.0, spring_length=float(np.linalg.norm(S["attach_rel"] - ANCHOR_REL)),
                             spring_torque_x=0.0, gravity_torque_x=0.0, friction_torque_x=0.0)
    out.update(last)
    out["pivot_y"] = p[1]
    rc = R @ S["com_rel"]
    v_com = V_PIVOT + np.cross([w, 0.0, 0.0], rc)
    i_cx = S["i_p"][0, 0] - S["mass"] * (rc[1] ** 2 + rc[2] ** 2)
    ke_tool = 0.5 * S["mass"] * float(v_com @ v_com) + 0.5 * i_cx * w * w
    if S["point"] is not None:
        rp = R @ S["point"]
        vp = V_PIVOT + np.cross([w, 0.0, 0.0], rp)
        ke_tool += 0.5 * S["extra"] * float(vp @ vp)
    out["ke_tool"] = ke_tool
    # utils.kineticEnergy counts the clump with Yade's own state (its translation at the pivot's velocity)
    st = O.bodies[S["cid"]].state
    ke_clump = 0.5 * st.mass * st.vel.squaredNorm() + 0.5 * st.inertia[0] * w * w
    out["ke_soil"] = utils.kineticEnergy() - ke_clump
    c_ss = coh = c_low = drop = 0
    if counts:
        nf, low = S["nf"], set(S["low"])
        per_sphere = {}
        for I in O.interactions:
            if not I.isReal:
                continue
            if I.id1 >= nf and I.id2 >= nf:
                c_ss += 1
                coh += int(not I.phys.cohesionBroken)
            elif I.id1 in low or I.id2 in low:
                c_low += 1
                fac, sph = (I.id1, I.id2) if I.id1 in low else (I.id2, I.id1)
                per_sphere.setdefault(sph, []).append(fac)
        # Yade's facet interactions on the lower half that warpdem's merging rule would not have (one mesh:
        # soil_bin_twin_common.warpdem_suppressed on the current world triangles, lowest face first)
        for sph, facs in per_sphere.items():
            if len(facs) < 2:
                continue
            facs = sorted(facs)
            tris = (S["tri_low0"][[f - S["low"][0] for f in facs]] - PIVOT0) @ R.T + p
            b = O.bodies[sph]
            drop += int(common.warpdem_suppressed(np.array(list(b.state.pos)), b.shape.radius, tris).sum())
    out.update(c_ss=c_ss, coh_ss=coh, c_sf_lower=c_low, wd_drop_lower=drop,
               z_particle_ss=2.0 * c_ss / S["n_particles"] if S.get("n_particles") else 0.0)
    return out


def record():
    s = O.iter + 1
    snap = snapshot(s, counts=not S.get("no_counts"))
    for k in KEYS:
        S["rec"][k].append(snap[k])
    if S.get("verbose") and (s // EVERY) % 20 == 0:
        log(f"step {s:5d} t={s * DT:.4f} draught={snap['draught']:8.2f} N rotation="
            f"{math.degrees(snap['rotation']):+.4f} deg disp={1e3 * snap['displacement']:+.4f} mm spring="
            f"{snap['spring_force']:8.2f} N ss={snap['c_ss']} (coh {snap['coh_ss']}) lower {snap['c_sf_lower']} "
            f"(warpdem would drop {snap['wd_drop_lower']})")


COMPACT = ("step", "draught", "rotation", "angvel", "displacement", "spring_force", "ke_tool", "c_ss",
           "coh_ss", "c_sf_lower", "wd_drop_lower")


def records():
    """The records as arrays: counts int32, step int64, time float64, the rest float32 (small files); without
    --full-records only the COMPACT keys."""
    out = {k: np.array(v) for k, v in S["rec"].items() if FULL or k in COMPACT}
    for k in out:
        if k in ("c_ss", "coh_ss", "c_sf_lower", "wd_drop_lower"):
            out[k] = out[k].astype(np.int32)
        elif k == "step":
            out[k] = out[k].astype(np.int64)
        elif k != "time":
            out[k] = out[k].astype(np.float32)
    return out


# ------------------------------------------------------------------------------------------------ closed forms
def statics(preload=0.0, pitch=0.0, extra=0.0, extra_at="distributed"):
    """The statics without soil of the twin's own loads (no small-rotation approximation): the moment M(theta)
    about +x of spring and weight at a rotation theta [rad] about +x from the drawing pose; returns its root
    theta_eq (the rest pose) and the stiffness -dM/dtheta there [N m/rad]."""
    m, com = float(sp["tool_mass"]), pitch_matrix(pitch) @ (np.asarray(sp["tool_com"]) - PIVOT0)
    pt = None
    if extra and extra_at == "distributed":
        m += extra
    elif extra:
        pt = SENSOR0 - PIVOT0 if extra_at == "sensor" else pitch_matrix(pitch) @ (
            np.array([float(x) for x in extra_at.split(",")]) - PIVOT0)
    p_, stop = -K * preload, STOP_RATIO * K if preload > 0 else 0.0

    def moment(th):
        c, s = math.cos(th), math.sin(th)
        R = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
        t = np.cross(R @ com, m * GRAV)[0]
        if pt is not None:
            t += np.cross(R @ pt, extra * GRAV)[0]
        rb = R @ (np.asarray(sp["spring_attach"]) - PIVOT0)
        d = rb - ANCHOR_REL
        L = np.linalg.norm(d)
        u = d / L
        st = L - REST
        f = p_ + K * st + K3 * st**3
        if p_ * st < 0:
            f += stop * st
        return t + np.cross(rb, -f * u)[0]

    lo, hi = -0.3, 0.3
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if moment(mid) > 0 else (lo, mid)
    th = 0.5 * (lo + hi)
    h = 1e-6
    return th, -(moment(th + h) - moment(th - h)) / (2 * h)


def ring_analysis(t, th, rest):
    """Frequency [Hz] from the mean period between upward crossings of the rest pose ``rest`` (linear
    interpolation; while the swing is above 1e-4 of the first) and the damping ratio from the logarithmic decrement
    of the first two maxima."""
    x = th - rest
    live = np.abs(x) > 1e-4 * np.abs(x).max()
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0) & live[:-1])
    tc = t[up] - x[up] * (t[up + 1] - t[up]) / (x[up + 1] - x[up])
    f = (len(tc) - 1) / (tc[-1] - tc[0]) if len(tc) > 2 else float("nan")
    pk = np.flatnonzero((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:])) + 1
    pk = pk[x[pk] > 0]
    if len(pk) >= 2:  # the first two maxima (the largest swings: least biased by the rest pose's error)
        delta = math.log(x[pk[0]] / x[pk[1]])
        zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    else:
        zeta = float("nan")
    return f, zeta, x, pk


def ring(start_deg, dashpot, friction=0.0, preload=0.0, ring_time=RING_TIME):
    """No soil: the tool released at rest from a backward start rotation [deg]; records every step."""
    build(soil=False, dashpot=dashpot, friction=friction, preload=preload, pitch=0.0, start=start_deg, extra=0.0)
    S["no_counts"] = True
    O.engines[-1].iterPeriod = 1
    O.engines[-1].firstIterRun = 0
    O.run(int(round(ring_time / DT)), True)
    r = records()
    return r["step"] * DT, r["rotation"], r


def test():
    t_all = time.time()
    i_p = float(sp["tool_ip_xx"])
    a = float(sp["lever"])
    zc = float(sp["tool_com"][2] - sp["tool_pivot"][2])
    m = float(sp["tool_mass"])
    k_rot = K * a * a - m * abs(GRAV[2]) * zc
    f_cf = math.sqrt(k_rot / i_p) / (2 * math.pi)
    zeta_t2 = float(sp["measured_damping"])
    log(f"closed form (scenes.soil_bin.dashpot_for / scenes.passive_tool): k_rot = k a^2 - m g (z_com - z_pivot) = "
        f"{K:.1f} * {a:.3f}^2 - {m:.3f} * {abs(GRAV[2]):.2f} * ({zc:.5f}) = {k_rot:.3f} N m/rad (spec "
        f"{float(sp['k_rot']):.3f}); I_p = {i_p:.6f} kg m^2; f = sqrt(k_rot / I_p) / (2 pi) = {f_cf:.4f} Hz (spec "
        f"{float(sp['ring_freq_hz']):.4f}); damped f sqrt(1 - zeta^2) = {f_cf * math.sqrt(1 - zeta_t2**2):.4f} Hz "
        f"with Table 2's zeta {zeta_t2:.5f}; dashpot 2 zeta sqrt(k_rot I_p) / a^2 = "
        f"{2 * zeta_t2 * math.sqrt(k_rot * i_p) / a**2:.3f} N s/m (spec, float32: {C_DASH:.3f})")
    th_eq, k_eq = statics()
    f_eq = math.sqrt(k_eq / i_p) / (2 * math.pi)
    log(f"statics of the twin's loads (support offset {1e3 * float(sp['support_offset']):+.1f} mm): rest rotation "
        f"{math.degrees(th_eq):+.5f} deg about +x (sensor {-1e3 * a * th_eq:+.4f} mm backward), stiffness -dM/dtheta "
        f"there {k_eq:.3f} N m/rad -> {f_eq:.4f} Hz")
    start = -math.degrees(th_eq) + 0.3  # released 0.3 deg behind its rest pose
    t, th, _ = ring(start, 0.0)
    f0, z0, x, pk = ring_analysis(t, th, th_eq)
    log(f"Yade, no soil, no dashpot, released 0.3 deg behind rest: f = {f0:.4f} Hz (closed form {f_cf:.4f} Hz: "
        f"{100 * (f0 / f_cf - 1):+.3f} %; statics {f_eq:.4f} Hz: {100 * (f0 / f_eq - 1):+.3f} %), zeta {z0:.2e}, "
        f"mean rotation {math.degrees(th[len(th) // 2:].mean()):+.5f} deg (rest {math.degrees(th_eq):+.5f})")
    t, th, _ = ring(start, C_DASH)
    f1 = ring_analysis(t, th, th_eq)[0]
    z1 = ring_analysis(t, th, th[-len(th) // 10:].mean())[1]  # decrement about where it came to rest
    fd = f_cf * math.sqrt(1 - zeta_t2**2)
    fd_eq = f_eq * math.sqrt(1 - zeta_t2**2)
    log(f"Yade, no soil, with the dashpot: f = {f1:.4f} Hz (closed form {fd:.4f} Hz: {100 * (f1 / fd - 1):+.3f} %; "
        f"statics {fd_eq:.4f} Hz: {100 * (f1 / fd_eq - 1):+.3f} %), zeta {z1:.5f} (Table 2 {zeta_t2:.5f}: "
        f"{100 * (z1 / zeta_t2 - 1):+.2f} %)")
    tf = 0.5  # N m
    t, th, r = ring(start, 0.0, friction=tf)
    x = th - th_eq
    pk = np.flatnonzero((np.abs(x[1:-1]) > np.abs(x[:-2])) & (np.abs(x[1:-1]) >= np.abs(x[2:])) &
                        (np.abs(x[1:-1]) > 1e-9)) + 1
    drops = -np.diff(np.abs(x[pk]))[:4]
    stuck = int(np.sum(np.abs(r["angvel"][-1000:]) < 1e-12))
    log(f"Yade, no soil, pivot friction {tf:.2f} N m: amplitude loss per half swing "
        f"{np.array2string(np.degrees(drops), precision=5)} deg (Coulomb oscillator: 2 T_f / k = "
        f"{math.degrees(2 * tf / k_eq):.5f} deg); stops at {math.degrees(x[-1]):+.5f} deg from rest (within +-T_f/k = "
        f"{math.degrees(tf / k_eq):.5f} deg), |angular velocity| < 1e-12 rad/s in {stuck} of the last 1000 steps")
    th_p, _ = statics(preload=1e-3)
    t, th, r = ring(-math.degrees(th_p), C_DASH, preload=1e-3, ring_time=0.3)
    log(f"Yade, no soil, preload 1 mm: statics rest {math.degrees(th_p):+.5f} deg; Yade after 0.3 s "
        f"{math.degrees(th[-1]):+.5f} deg, spring force {r['spring_force'][-1]:.1f} N (preload {-K * 1e-3:.1f} N, "
        f"stop {STOP_RATIO * K:.3g} N/m)")
    log(f"test wall {time.time() - t_all:.1f} s")


if TEST:
    test()
else:
    build()
    S["verbose"] = True
    n_steps = int(sp["n_steps"]) if STEPS is None else STEPS
    t0 = time.time()
    snap = snapshot(0)
    for k in KEYS:
        S["rec"][k].append(snap[k])
    O.run(1, True)
    n_ss = sum(1 for I in O.interactions if I.isReal and I.id1 >= S["nf"] and I.id2 >= S["nf"])
    n_coh = sum(1 for I in O.interactions if I.isReal and not I.phys.cohesionBroken)
    log(f"step 1: {n_ss} sphere-sphere interactions; {n_coh} cohesive (all kinds)")
    O.run(n_steps - 1, True)
    wall = time.time() - t0
    data = records()
    meta = dict(wall_s=wall, n_steps=n_steps, yade_version=str(yade.config.version), perturb=PERTURB, seed=SEED,
                pitch_deg=PITCH, start_rotation_deg=START, preload=PRELOAD, pivot_friction=PIVOT_FRICTION,
                extra_mass=EXTRA_MASS, extra_mass_at=EXTRA_AT, n_cleared=S["n_cleared"],
                n_particles=S["n_particles"], tool_mass_used=S["mass"],
                tool_inertia_used=[float(x) for x in np.diag(S["i_p"])], dt=DT, record_every=EVERY,
                speed=float(sp["speed"]), springs=SPRINGS)
    data["meta"] = np.array(json.dumps(meta))  # the scalars as one json entry (small files)
    np.savez_compressed(OUT, **data)
    log(f"wall {wall:.1f} s for {n_steps} steps ({len(data['step'])} records); wrote {OUT}")
