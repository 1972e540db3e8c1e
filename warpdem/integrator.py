"""Leapfrog integration of rigid bodies (Yade's NewtonIntegrator) and the update of their spheres.

Per body, with F, T the summed contact and spring forces and torques (torques about the centre of mass):
- translation: a = F/m + g on free axes (0 on blocked ones); Cundall local damping
  a_i <- a_i (1 - lambda sgn(a_i (v_i + dt a_i / 2))); v <- v + dt a; x <- x + dt v.
- rotation, three cases:
  * spherical inertia, free: alpha = T/I, damped like a; omega <- omega + dt alpha; q rotated by |omega| dt.
  * aspherical, free: Yade's Allen-Tildesley scheme on the world angular momentum L (torque damped by
    T_i <- T_i (1 - lambda sgn(T_i omega_i))).
  * hinged (FLAG_PIVOT): the body turns about a pivot that moves at a constant velocity (a carriage): Euler's
    equations about the pivot, I_p alpha = T_p - omega x I_p omega with T_p the torque of contacts, springs and
    gravity about the pivot and I_p = I_c + m (|r|^2 1 - r r^T) (r: pivot to centre of mass), blocked rotation
    components held as below; the centre of mass then follows the pivot: x = p + R(q) r_body.
  * any rotation blocked: the free components solve I_ff alpha_f = (T - omega x I omega)_f with the world-frame
    inertia; blocked components keep their (imposed) angular velocity. (Yade's aspherical scheme would leak
    rotation into blocked axes for a body with products of inertia, e.g. a tool hinged about one axis.)
"""

from __future__ import annotations

import warp as wp

from .accumulate import add_wrench, clear_slots, read_float
from .broadphase import mesh_displacement
from .contacts import E_DAMPING, E_DRIVEN, E_SPRING_DAMPER, N_ENERGY
from .data import NO_FAULT
from .kernel_args import Bodies, BodyState, Meshes, Spheres, SphereState, Springs, Sums
from .model import ALL_DOFS, FLAG_ASPHERICAL, FLAG_PIVOT, ROT_DOFS
from .types import Options

wp.set_module_options({"enable_backward": False})

NO_FAULT_I = wp.constant(NO_FAULT)


@wp.func
def damp(a: wp.vec3d, v: wp.vec3d, dt: wp.float64, lam: wp.float64) -> wp.vec3d:
    """Cundall local damping of an acceleration (Yade's cundallDamp2nd)."""
    out = a
    for k in range(3):
        s = a[k] * (v[k] + wp.float64(0.5) * dt * a[k])
        if s > wp.float64(0.0):
            out[k] = a[k] * (wp.float64(1.0) - lam)
        elif s < wp.float64(0.0):
            out[k] = a[k] * (wp.float64(1.0) + lam)
    return out


@wp.func
def quat_integrate(q: wp.quatd, omega: wp.vec3d, dt: wp.float64) -> wp.quatd:
    """Rotate q by the angle |omega| dt about omega (world frame). For a half angle h = |omega| dt / 2 below 0.01
    rad the rotation (omega sin(h) / |omega|, cos h) comes from the Taylor series of sin(h) / h and cos h to h^6
    (the first term left out is below 3e-21: under float64 rounding), with no square root, division, sine or
    cosine; larger angles take the axis and angle. (The series' constants are written as decimals: Warp folds
    ``1.0 / 6.0`` inside a kernel in float32.)"""
    h2 = wp.dot(omega, omega) * (dt * dt * wp.float64(0.25))
    if h2 > wp.float64(0.0):
        if h2 < wp.float64(1.0e-4):
            s = wp.float64(0.5) * dt * (wp.float64(1.0) - h2 * wp.float64(0.16666666666666666) * (
                wp.float64(1.0) - h2 * wp.float64(0.05) * (wp.float64(1.0) - h2 * wp.float64(0.023809523809523808))))
            c = wp.float64(1.0) - h2 * wp.float64(0.5) * (wp.float64(1.0) - h2 * wp.float64(0.08333333333333333) * (
                wp.float64(1.0) - h2 * wp.float64(0.03333333333333333)))
            return wp.normalize(wp.quatd(omega[0] * s, omega[1] * s, omega[2] * s, c) * q)
        dq = wp.quat_from_axis_angle(wp.normalize(omega), wp.length(omega) * dt)
        return wp.normalize(dq * q)
    return q


@wp.func
def dot_q(w_b: wp.vec3d, q: wp.quatd) -> wp.quatd:
    """dq/dt for a body-frame angular velocity: q * (w_b, 0) / 2 (Yade's DotQ)."""
    return wp.float64(0.5) * (q * wp.quatd(w_b[0], w_b[1], w_b[2], wp.float64(0.0)))


@wp.func
def cw_div(a: wp.vec3d, b: wp.vec3d) -> wp.vec3d:
    return wp.vec3d(a[0] / b[0], a[1] / b[1], a[2] / b[2])


@wp.func
def rotational_energy(inertia: wp.vec3d, q: wp.quatd, omega: wp.vec3d) -> wp.float64:
    """omega^T I omega / 2 [J] of a body of principal inertia ``inertia`` [kg m^2] at orientation q."""
    w_b = wp.quat_rotate_inv(q, omega)
    return wp.float64(0.5) * (inertia[0] * w_b[0] * w_b[0] + inertia[1] * w_b[1] * w_b[1]
                              + inertia[2] * w_b[2] * w_b[2])


@wp.func
def masked_inverse(mat: wp.mat33d, flags: int) -> wp.mat33d:
    """The inverse of mat with the rows and columns of the blocked rotation components (flag bits 3..5) replaced
    by those of the identity: (masked_inverse * masked rhs) solves mat alpha = rhs with those components at 0."""
    free = int(0)
    n_free = int(0)
    for k in range(3):
        if (flags & (8 << k)) == 0:
            free = k
            n_free += 1
    if n_free == 1:  # one free axis (a hinge, a sphere turning in a plane): the identity but 1 / mat[k, k] there
        one = wp.identity(n=3, dtype=wp.float64)
        one[free, free] = wp.float64(1.0) / mat[free, free]
        return one
    m = mat
    for k in range(3):
        if (flags & (8 << k)) != 0:
            for l in range(3):
                m[k, l] = wp.float64(0.0)
                m[l, k] = wp.float64(0.0)
            m[k, k] = wp.float64(1.0)
    return wp.inverse(m)


@wp.func
def free_part(rhs: wp.vec3d, flags: int) -> wp.vec3d:
    """rhs with the blocked rotation components (flag bits 3..5) set to 0."""
    r = rhs
    for k in range(3):
        if (flags & (8 << k)) != 0:
            r[k] = wp.float64(0.0)
    return r


@wp.func
def solve_free_rotations(mat: wp.mat33d, rhs: wp.vec3d, flags: int) -> wp.vec3d:
    """Angular acceleration from mat alpha = rhs with the blocked rotation components (flag bits 3..5) held at 0."""
    return masked_inverse(mat, flags) * free_part(rhs, flags)


@wp.func
def integrate_hinged(
    flags: int,
    m: wp.float64,
    inertia: wp.vec3d,
    pivot_local: wp.vec3d,
    pivot_vel: wp.vec3d,
    friction: wp.float64,
    gravity: wp.vec3d,
    dt: wp.float64,
    lam: wp.float64,
    f: wp.vec3d,
    t: wp.vec3d,
    x: wp.vec3d,
    q: wp.quatd,
    omega: wp.vec3d,
):
    """One leapfrog step of a body hinged at a pivot moving at constant velocity, from its position x [m],
    orientation q and angular velocity omega [rad/s]; returns the new (position, velocity, angular velocity,
    orientation, angular momentum) and the work of local damping and pivot friction [J].

    Pivot friction: a torque of magnitude ``friction`` opposing the trial angular velocity omega + dt alpha; when
    it would reverse that velocity within the step the body sticks (omega = 0), which is exact stick-slip for one
    free rotation."""
    rot = wp.quat_to_matrix(q)
    arm = rot * pivot_local  # centre of mass -> pivot
    p = x + arm
    rc = -arm  # pivot -> centre of mass
    t_p = t + wp.cross(rc, f + m * gravity)
    i_c = rot * wp.diag(inertia) * wp.transpose(rot)
    i_p = i_c + m * (wp.dot(rc, rc) * wp.identity(n=3, dtype=wp.float64) - wp.outer(rc, rc))
    i_p_inv = masked_inverse(i_p, flags)
    alpha = i_p_inv * free_part(t_p - wp.cross(omega, i_p * omega), flags)
    alpha_d = damp(alpha, omega, dt, lam)
    work = wp.abs(wp.dot(i_p * (alpha - alpha_d), omega)) * dt
    omega_trial = omega + dt * alpha_d
    omega_new = omega_trial
    if friction > wp.float64(0.0):
        speed = wp.length(omega_trial)
        if speed > wp.float64(0.0):
            u = omega_trial / speed
            d_omega = dt * (i_p_inv * free_part(friction * u, flags))
            if wp.dot(d_omega, u) >= speed:
                omega_new = wp.vec3d(wp.float64(0.0), wp.float64(0.0), wp.float64(0.0))  # sticks
            else:
                omega_new = omega_trial - d_omega
            work += friction * wp.length(omega_new) * dt
    q_new = quat_integrate(q, omega_new, dt)
    arm_new = wp.quat_rotate(q_new, pivot_local)
    l_new = wp.quat_rotate(q_new, wp.cw_mul(inertia, wp.quat_rotate_inv(q_new, omega_new)))
    return (p + dt * pivot_vel - arm_new, pivot_vel - wp.cross(omega_new, arm_new), omega_new, q_new, l_new, work)


@wp.func
def check_body(
    b: int,
    x: wp.vec3d,
    v: wp.vec3d,
    omega: wp.vec3d,
    max_speed: wp.float64,
    lower: wp.vec3d,
    upper: wp.vec3d,
    step: int,
    base: int,
    fault: wp.array(dtype=int),
):
    """If body b (at x [m], velocity v [m/s], angular velocity omega [rad/s]) is NaN, faster than max_speed [m/s]
    or outside [lower, upper] [m], record it unless a body of lower index failed: fault[base:base + 3] = (body,
    cause (1 NaN, 2 speed, 3 bounds), step)."""
    cause = int(0)
    s = x[0] + x[1] + x[2] + v[0] + v[1] + v[2] + omega[0] + omega[1] + omega[2]
    if wp.isnan(s) or wp.isinf(s):
        cause = 1
    elif wp.length(v) > max_speed:
        cause = 2
    else:
        for k in range(3):
            if x[k] < lower[k] or x[k] > upper[k]:
                cause = 3
    if cause != 0:
        old = wp.atomic_min(fault, base, b)
        if b < old:
            fault[base + 1] = cause
            fault[base + 2] = step


@wp.func
def keep_first_fault(src: wp.array(dtype=int), s: int, dst: wp.array(dtype=int), d: int):
    """Copy the fault record (body, cause, step) src[s:s + 3] to dst[d:d + 3] unless dst already holds one (dst[d]
    is not NO_FAULT): the first fault is kept."""
    if dst[d] == NO_FAULT_I:
        dst[d] = src[s]
        dst[d + 1] = src[s + 1]
        dst[d + 2] = src[s + 2]


@wp.func(inline=True)
def add_energy(sums: Sums, w: int, term: int, e: wp.float64):
    """Add e [J] to world w's energy term ``term`` (E_DAMPING, E_DRIVEN, ...) in sums.energy."""
    wp.atomic_add(sums.energy, w * N_ENERGY + term, e)


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def body_wrench(b: int, sums: Sums, parts: int, float_sums: int):
    """Body b's summed force [N] and torque about its centre of mass [N m] (float32) this step: read from
    ``sums.body_force``, ``sums.body_torque`` where ``float_sums`` != 0 (converted by
    accumulate.wrench_to_float_kernel), else from the fixed-point accumulators of ``parts`` CPU threads."""
    if float_sums != 0:
        return sums.body_force[b], sums.body_torque[b]
    n = sums.body_force.shape[0]
    return read_float(sums.force_acc, sums.force_scale, b, n, parts), read_float(sums.torque_acc, sums.torque_scale,
                                                                                 b, n, parts)


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def move_driven(b: int, w: int, inertia: wp.vec3d, dt: wp.float64, track_energy: int, f: wp.vec3d, t: wp.vec3d,
                x: wp.vec3d, q: wp.quatd, v: wp.vec3d, omega: wp.vec3d, state: BodyState, sums: Sums) -> wp.vec3d:
    """A body whose every DoF is blocked: it moves at its imposed velocity v [m/s] and angular velocity omega
    [rad/s]; writes its position and orientation and returns the new position [m]. The driver's work [J]: against
    the contact and spring forces f [N] and torques t [N m], plus the change of the body's own rotational kinetic
    energy (gravity on such a body is not in the balance)."""
    q_new = quat_integrate(q, omega, dt)
    if track_energy != 0:
        work = -(wp.dot(f, v) + wp.dot(t, omega)) * dt
        work += rotational_energy(inertia, q_new, omega) - rotational_energy(inertia, q, omega)
        add_energy(sums, w, E_DRIVEN, work)
    x = x + dt * v
    state.pos[b] = x
    state.quat[b] = q_new
    return x


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def move_hinged(b: int, w: int, flags: int, m: wp.float64, inertia: wp.vec3d, lam: wp.float64, gravity: wp.vec3d,
                dt: wp.float64, track_energy: int, f: wp.vec3d, t: wp.vec3d, x: wp.vec3d, q: wp.quatd, v: wp.vec3d,
                omega: wp.vec3d, bodies: Bodies, state: BodyState, sums: Sums):
    """A hinged body (FLAG_PIVOT; :func:`integrate_hinged`): writes its state and returns its new (position [m],
    velocity [m/s], angular velocity [rad/s]); the work of local damping and pivot friction and the carriage's
    work (the pivot reaction m a - f - m g times the pivot's velocity) go to the energy terms [J]."""
    friction = bodies.pivot_friction[b]
    pivot_vel = bodies.pivot_vel[b]
    x, v_new, omega, q_new, l_new, work = integrate_hinged(flags, m, inertia, bodies.pivot[b], pivot_vel, friction,
                                                           gravity, dt, lam, f, t, x, q, omega)
    state.pos[b] = x
    state.vel[b] = v_new
    state.angvel[b] = omega
    state.angmom[b] = l_new
    state.quat[b] = q_new
    if track_energy != 0:
        if lam > wp.float64(0.0) or friction > wp.float64(0.0):
            add_energy(sums, w, E_DAMPING, work)
        reaction = m * (v_new - v) - (f + m * gravity) * dt
        add_energy(sums, w, E_DRIVEN, wp.dot(reaction, pivot_vel))
    return x, v_new, omega


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def rotate_constrained(b: int, w: int, flags: int, inertia: wp.vec3d, lam: wp.float64, dt: wp.float64,
                       track_energy: int, t: wp.vec3d, q: wp.quatd, omega: wp.vec3d, state: BodyState,
                       sums: Sums) -> wp.vec3d:
    """A body with some (not all) rotations blocked: the free components solve I_ff alpha_f = (t - omega x I
    omega)_f with the world-frame inertia [kg m^2], blocked ones keep omega [rad/s]; the driver's torque on the
    blocked axes times their velocity and local damping's work go to the energy terms [J]. Writes the rotation
    state; returns the new angular velocity [rad/s]."""
    iw = inertia[0] * wp.identity(n=3, dtype=wp.float64)  # isotropic: the same in every frame
    if (flags & FLAG_ASPHERICAL) != 0:
        r = wp.quat_to_matrix(q)
        iw = r * wp.diag(inertia) * wp.transpose(r)
    alpha = solve_free_rotations(iw, t - wp.cross(omega, iw * omega), flags)
    if track_energy != 0:
        # the driver's torque on the blocked axes, iw alpha - (t - omega x iw omega), times their velocity
        c = iw * alpha - (t - wp.cross(omega, iw * omega))
        e = wp.float64(0.0)
        for k in range(3):
            if (flags & (1 << (k + 3))) != 0:
                e += c[k] * omega[k] * dt
        add_energy(sums, w, E_DRIVEN, e)
    alpha_d = damp(alpha, omega, dt, lam)
    if track_energy != 0 and lam > wp.float64(0.0):
        add_energy(sums, w, E_DAMPING, wp.abs(wp.dot(iw * (alpha - alpha_d), omega)) * dt)
    omega = omega + dt * alpha_d
    state.angvel[b] = omega
    state.angmom[b] = iw * omega
    state.quat[b] = quat_integrate(q, omega, dt)
    return omega


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def rotate_spherical(b: int, w: int, inertia: wp.vec3d, lam: wp.float64, dt: wp.float64, track_energy: int,
                     t: wp.vec3d, q: wp.quatd, omega: wp.vec3d, state: BodyState, sums: Sums) -> wp.vec3d:
    """A free body of spherical inertia inertia[0] [kg m^2]: alpha = t / I, damped like a; writes the rotation
    state and returns the new angular velocity [rad/s]."""
    alpha = damp(t / inertia[0], omega, dt, lam)
    if track_energy != 0 and lam > wp.float64(0.0):
        e = wp.float64(0.0)
        for k in range(3):
            e += inertia[0] * wp.abs(alpha[k] - t[k] / inertia[0]) * wp.abs(omega[k]) * dt
        add_energy(sums, w, E_DAMPING, e)
    omega = omega + dt * alpha
    state.angvel[b] = omega
    state.angmom[b] = inertia[0] * omega
    state.quat[b] = quat_integrate(q, omega, dt)
    return omega


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def rotate_aspherical(b: int, w: int, inertia: wp.vec3d, lam: wp.float64, dt: wp.float64, track_energy: int,
                      t: wp.vec3d, q: wp.quatd, omega: wp.vec3d, state: BodyState, sums: Sums) -> wp.vec3d:
    """A free aspherical body (principal moments inertia [kg m^2]): Yade's leapfrogAsphericalRotate on the world
    angular momentum state.angmom[b] [kg m^2/s], with the torque t [N m] damped first (cundallDamp1st); writes the
    rotation state and returns the new angular velocity [rad/s]."""
    t_d = t
    for k in range(3):
        s = t[k] * omega[k]
        if s > wp.float64(0.0):
            t_d[k] = t[k] * (wp.float64(1.0) - lam)
        elif s < wp.float64(0.0):
            t_d[k] = t[k] * (wp.float64(1.0) + lam)
    if track_energy != 0 and lam > wp.float64(0.0):
        add_energy(sums, w, E_DAMPING, wp.abs(wp.dot(t - t_d, omega)) * dt)
    l_mom = state.angmom[b]
    l_n = l_mom + wp.float64(0.5) * dt * t_d
    w_b_n = cw_div(wp.quat_rotate_inv(q, l_n), inertia)
    q_half = q + wp.float64(0.5) * dt * dot_q(w_b_n, q)
    l_mom = l_mom + dt * t_d
    w_b_half = cw_div(wp.quat_rotate_inv(q, l_mom), inertia)
    q_new = wp.normalize(q + dt * dot_q(w_b_half, q_half))
    omega = wp.quat_rotate(q_new, w_b_half)
    state.angmom[b] = l_mom
    state.angvel[b] = omega
    state.quat[b] = q_new
    return omega


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def rotate_free(b: int, w: int, flags: int, inertia: wp.vec3d, lam: wp.float64, dt: wp.float64, track_energy: int,
                t: wp.vec3d, q: wp.quatd, omega: wp.vec3d, driven: wp.float64, state: BodyState,
                sums: Sums) -> wp.vec3d:
    """The rotation of a body that is neither fully blocked nor hinged (see the module docstring), after its
    translation, whose driver's work [J] is ``driven`` (added to E_DRIVEN here, with the blocked rotation's where all
    rotations are blocked); returns the new angular velocity [rad/s]."""
    rot_blocked = flags & ROT_DOFS
    if rot_blocked == ROT_DOFS:
        q_new = quat_integrate(q, omega, dt)
        if track_energy != 0:
            driven += -wp.dot(t, omega) * dt + rotational_energy(inertia, q_new, omega) - rotational_energy(
                inertia, q, omega)
            add_energy(sums, w, E_DRIVEN, driven)
        state.quat[b] = q_new
        return omega
    if track_energy != 0 and (flags & 7) != 0:  # a blocked translation
        add_energy(sums, w, E_DRIVEN, driven)
    if rot_blocked != 0:
        return rotate_constrained(b, w, flags, inertia, lam, dt, track_energy, t, q, omega, state, sums)
    if (flags & FLAG_ASPHERICAL) == 0:
        return rotate_spherical(b, w, inertia, lam, dt, track_energy, t, q, omega, state, sums)
    return rotate_aspherical(b, w, inertia, lam, dt, track_energy, t, q, omega, state, sums)


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def move_free(b: int, w: int, flags: int, m: wp.float64, inertia: wp.vec3d, lam: wp.float64, gravity: wp.vec3d,
              dt: wp.float64, track_energy: int, f: wp.vec3d, t: wp.vec3d, x: wp.vec3d, q: wp.quatd, v: wp.vec3d,
              omega: wp.vec3d, state: BodyState, sums: Sums):
    """A body that is neither fully blocked nor hinged: a = f / m + g on the free axes (the driver holds the
    imposed velocity on the blocked ones), Cundall local damping, v += dt a, x += dt v, then its rotation
    (:func:`rotate_free`); writes its state and returns its new (position [m], velocity [m/s], angular velocity
    [rad/s])."""
    a = f / m + gravity
    driven = wp.float64(0.0)
    for k in range(3):
        if (flags & (1 << k)) != 0:
            a[k] = wp.float64(0.0)
            driven -= (f[k] + m * gravity[k]) * v[k] * dt  # the driver holds the imposed velocity
    a_d = damp(a, v, dt, lam)
    if track_energy != 0 and lam > wp.float64(0.0):
        e = wp.float64(0.0)
        for k in range(3):
            e += m * wp.abs(a_d[k] - a[k]) * wp.abs(v[k] + wp.float64(0.5) * dt * a[k]) * dt
        add_energy(sums, w, E_DAMPING, e)
    v = v + dt * a_d
    x = x + dt * v
    omega = rotate_free(b, w, flags, inertia, lam, dt, track_energy, t, q, omega, driven, state, sums)
    state.vel[b] = v
    state.pos[b] = x
    return x, v, omega


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def integrate_body(
    b: int,
    bodies: Bodies,
    opts: Options,
    parts: int,  # CPU threads whose accumulators are summed
    float_sums: int,  # 1: the sums were converted to ``sums.body_force``, ``sums.body_torque`` before
    step: int,
    fault_base: int,
    state: BodyState,  # in/out
    sums: Sums,  # in: the whole accumulators (cleared); out: the float sums, the energy terms (a part's)
    fault: wp.array(dtype=int),  # out
):
    """Body b's motion for one step (one thread of integrate_bodies_kernel, or a world's loop); ``step``: the step
    being completed, for a fault record. Each path reads what it needs before it writes anything, and the force
    sums are cleared last (Warp's arrays may alias, so a load after a store waits for it)."""
    dt = opts.dt
    flags = bodies.flags[b]
    w = bodies.world[b]
    m = bodies.mass[b]
    inertia = bodies.inertia[b]
    lam = wp.float64(bodies.group_damping[w * bodies.n_groups + bodies.group[b]])
    x = state.pos[b]
    q = state.quat[b]
    v = state.vel[b]
    omega = state.angvel[b]
    force, torque = body_wrench(b, sums, parts, float_sums)
    f = wp.vec3d(force)
    t = wp.vec3d(torque)
    if (flags & ALL_DOFS) == ALL_DOFS:  # fully prescribed motion
        x = move_driven(b, w, inertia, dt, opts.track_energy, f, t, x, q, v, omega, state, sums)
    elif (flags & FLAG_PIVOT) != 0:
        x, v, omega = move_hinged(b, w, flags, m, inertia, lam, bodies.gravity, dt, opts.track_energy, f, t, x, q, v,
                                  omega, bodies, state, sums)
    else:
        x, v, omega = move_free(b, w, flags, m, inertia, lam, bodies.gravity, dt, opts.track_energy, f, t, x, q, v,
                                omega, state, sums)
    if float_sums == 0:
        n = sums.body_force.shape[0]
        clear_slots(sums.force_acc, b, n, parts)
        clear_slots(sums.torque_acc, b, n, parts)
        sums.body_force[b] = force
        sums.body_torque[b] = torque
    check_body(b, x, v, omega, opts.max_speed, opts.lower, opts.upper, step, fault_base, fault)


@wp.kernel
def integrate_bodies_kernel(
    first: int,  # the first body of this launch (a CPU thread's share)
    bodies: Bodies,
    opts: Options,
    parts: int,
    float_sums: int,
    counters: wp.array(dtype=int),
    fault_base: int,
    state: BodyState,
    sums: Sums,
    fault: wp.array(dtype=int),
):
    """The motion of each body in one launch: its force and torque sums to float32 (accumulate.take_float, also
    written to ``sums.body_force``, ``sums.body_torque`` for the observers; the accumulators are cleared; with
    ``float_sums`` != 0 they were converted before, by accumulate.wrench_to_float_kernel, and are read), one leapfrog
    step (see the module docstring), then the fault check (:func:`check_body`, into fault[fault_base:+3], the step
    being completed as counted at its end)."""
    integrate_body(wp.tid() + first, bodies, opts, parts, float_sums, counters[0] + 1, fault_base, state, sums, fault)


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def update_sphere(
    i: int,
    spheres: Spheres,
    state: BodyState,  # in
    kin: SphereState,  # out
    # the broad phase's displacement check (disp_slot < 0: none):
    build_pos: wp.array(dtype=wp.vec3d),
    disp_slot: int,
    disp_out: wp.array(dtype=float),
):
    """Sphere i from its body (one thread of update_spheres_kernel, or a world's loop)."""
    b = spheres.body[i]
    arm = wp.quat_rotate(state.quat[b], wp.vec3d(spheres.offset[i]))
    x = state.pos[b] + arm
    kin.pos[i] = x
    if disp_slot >= 0:
        wp.atomic_max(disp_out, disp_slot, float(wp.length(x - build_pos[i])))
    omega = state.angvel[b]
    kin.vel[i] = wp.vec3f(state.vel[b] + wp.cross(omega, arm))
    kin.angvel[i] = wp.vec3f(omega)
    kin.arm[i] = wp.vec3f(arm)


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def mesh_end_one(
    m: int,
    slot: int,
    meshes: Meshes,
    parts: int,
    state: BodyState,  # in
    build_pos: wp.array(dtype=wp.vec3d),
    build_quat: wp.array(dtype=wp.quatd),
    sums: Sums,  # in: the whole mesh accumulators (cleared); out: the mesh forces
    disp: wp.array(dtype=float),
):
    """Mesh instance m at the end of a step (one thread of stages._mesh_end_kernel, or a world's loop): its force into
    sums.mesh_force[m] and added to sums.mesh_force_sum[m], its torque into sums.mesh_torque[m], its displacement
    into disp[slot]."""
    n = sums.mesh_force.shape[0]
    f = read_float(sums.mesh_force_acc, sums.mesh_force_scale, m, n, parts)
    t = read_float(sums.mesh_torque_acc, sums.mesh_torque_scale, m, n, parts)
    f_sum = sums.mesh_force_sum[m]
    d = mesh_displacement(m, meshes.body, meshes.rmax, state.pos, state.quat, build_pos, build_quat)
    clear_slots(sums.mesh_force_acc, m, n, parts)
    clear_slots(sums.mesh_torque_acc, m, n, parts)
    sums.mesh_force[m] = f
    sums.mesh_force_sum[m] = f_sum + wp.vec3d(f)
    sums.mesh_torque[m] = t
    wp.atomic_max(disp, slot, d)


@wp.kernel
def update_spheres_kernel(
    first: int,  # the first sphere of this launch (a CPU thread's share)
    spheres: Spheres,
    state: BodyState,
    kin: SphereState,
    build_pos: wp.array(dtype=wp.vec3d),
    disp_slot: int,
    disp_out: wp.array(dtype=float),
):
    """Sphere centres and velocities from their bodies: x = X + R(q) p, v = V + Omega x (x - X); and the largest
    distance of a sphere from its position at the last list build [m] into disp_out[disp_slot] (atomic max)."""
    update_sphere(wp.tid() + first, spheres, state, kin, build_pos, disp_slot, disp_out)


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def spring_one(
    s: int,
    springs: Springs,
    bodies: Bodies,
    opts: Options,
    state: BodyState,  # in
    sums: Sums,  # out: the fixed-point wrench sums (a part's), the spring forces, the energy terms
):
    """Spring s (one thread of spring_kernel, or a world's loop)."""
    a = springs.body_a[s]
    b = springs.body_b[s]
    ra = wp.quat_rotate(state.quat[a], wp.vec3d(springs.point_a[s]))
    rb = wp.quat_rotate(state.quat[b], wp.vec3d(springs.point_b[s]))
    d = (state.pos[b] + rb) - (state.pos[a] + ra)
    length = wp.length(d)
    u = wp.vec3f(0.0, 0.0, 1.0)
    if length > wp.float64(0.0):
        u = wp.vec3f(d / length)
    va = state.vel[a] + wp.cross(state.angvel[a], ra)
    vb = state.vel[b] + wp.cross(state.angvel[b], rb)
    rate = wp.dot(wp.vec3f(vb - va), u)
    u_len = float(length) - springs.rest_length[s]
    preload = springs.preload[s]
    damping = springs.damping[s]
    f = preload + springs.stiffness[s] * u_len + springs.progressive[s] * u_len * u_len * u_len + damping * rate
    if preload * u_len < 0.0:
        f = f + springs.stop_stiffness[s] * u_len
    sums.spring_force[s] = f
    fa = f * u
    add_wrench(sums.force_acc, sums.torque_acc, sums.force_scale, sums.torque_scale, a, fa,
               wp.cross(wp.vec3f(ra), fa))
    add_wrench(sums.force_acc, sums.torque_acc, sums.force_scale, sums.torque_scale, b, -fa,
               wp.cross(wp.vec3f(rb), -fa))
    if opts.track_energy != 0:
        wp.atomic_add(sums.energy, bodies.world[a] * N_ENERGY + E_SPRING_DAMPER,
                      wp.float64(damping * rate * rate * float(opts.dt)))


@wp.kernel
def spring_kernel(springs: Springs, bodies: Bodies, opts: Options, state: BodyState, sums: Sums):
    """Spring-dashpot: F = preload + k u + k3 u^3 + c dL/dt, u = L - L0, along a->b (tension > 0 pulls a and b
    together); past a stop at u = 0 on the side the preload drives (preload u < 0), F gains k_stop u."""
    spring_one(wp.tid(), springs, bodies, opts, state, sums)
