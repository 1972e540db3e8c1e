"""Yade's Law2_ScGeom6D_CohFrictPhys_CohesionMoment as Warp functions shared by every contact kind.

Reference: ``shared/docs/yade-physics.md`` sections 1-3. Body 1 is the first body of a contact (for a sphere-facet
contact, the facet), the unit normal n points from 1 to 2, the overlap un > 0 when penetrating, Fn > 0 compresses.
The history of a contact (shear force, bending and twisting moments, plastic normal displacement, adhesions, the
previous normal and its flags) is a :class:`Hist`; :func:`cohfrict_law` advances it by one step.
"""

from __future__ import annotations

import warp as wp

wp.set_module_options({"enable_backward": False})

#: Hist.flags bits
ACTIVE = wp.constant(1)  # the contact exists (Yade: the interaction is real)
COHESIVE = wp.constant(2)  # cohesion is set and not broken
FRAGILE = wp.constant(4)  # the bond breaks (vs yields) at its strength

#: Material flag bits (Material.flags)
MAT_MOMENT = wp.constant(1)
MAT_FRAGILE = wp.constant(2)
MAT_COHESIVE = wp.constant(4)


@wp.struct
class Hist:
    """Per-contact history, float32 [N], [N m], [m]."""

    fs: wp.vec3f  # shear force acting on body 2 [N]
    mb: wp.vec3f  # bending (rolling) moment acting on body 2 [N m]
    mtw: wp.vec3f  # twisting moment acting on body 2 [N m]
    normal: wp.vec3f  # contact normal of the previous step
    unp: float  # plastic normal displacement [m]
    an: float  # normal adhesion [N]
    as_: float  # shear adhesion [N]
    flags: int  # ACTIVE | COHESIVE | FRAGILE


@wp.struct
class Phys:
    """Contact parameters from the two materials and contact radii (Yade's Ip2_CohFrictMat_CohFrictMat_CohFrictPhys)."""

    kn: float  # [N/m]
    ks: float  # [N/m]
    kr: float  # [N m/rad]
    ktw: float  # [N m/rad]
    tan_phi: float
    max_roll: float  # maxRollPl [m]; < 0: no cap
    max_twist: float  # maxTwistPl [m]; < 0: no cap
    moment_law: int  # both materials have the moment law
    cohesive: int  # both materials may be cohesive
    fragile: int  # either material is fragile (Yade: fragile = fragile1 || fragile2)
    an: float  # normal adhesion this contact would get [N]
    as_: float  # shear adhesion [N]


@wp.struct
class LawOut:
    """What one law evaluation produces."""

    hist: Hist
    force: wp.vec3f  # force on body 1 (body 2 gets -force), applied at the contact point [N]
    moment: wp.vec3f  # moment on body 2 (body 1 gets -moment) [N m]
    alive: int  # 0 if the law deleted the contact this step
    dissip_slide: float  # energy dissipated by sliding this step [J]
    dissip_roll: float  # energy dissipated by rolling/twisting plasticity this step [J]


@wp.func
def hmean(a: float, b: float) -> float:
    if a > 0.0 and b > 0.0:
        return 2.0 * a * b / (a + b)
    return 0.0


@wp.struct
class Materials:
    """Per-world material tables (Simulation.materials, from the Model's), each of shape (n_worlds * n_materials,)."""

    young: wp.array(dtype=float)
    """Young's modulus [Pa], float32."""
    poisson: wp.array(dtype=float)
    """Poisson's ratio (Yade's: the shear to normal stiffness ratio) [-], float32."""
    tan_friction: wp.array(dtype=float)
    """tangent of the friction angle [-], float32."""
    normal_coh: wp.array(dtype=float)
    """normal cohesion [Pa], float32."""
    shear_coh: wp.array(dtype=float)
    """shear cohesion [Pa], float32."""
    eta_roll: wp.array(dtype=float)
    """rolling plasticity coefficient [-], float32."""
    eta_twist: wp.array(dtype=float)
    """twisting plasticity coefficient [-], float32."""
    alpha_kr: wp.array(dtype=float)
    """rolling stiffness factor [-], float32."""
    alpha_ktw: wp.array(dtype=float)
    """twisting stiffness factor [-], float32."""
    flags: wp.array(dtype=int)
    """MAT_MOMENT | MAT_FRAGILE | MAT_COHESIVE, int32."""
    n_materials: int
    """materials per world."""


@wp.func
def make_phys(mats: Materials, mi: int, mj: int, r1: float, r2: float) -> Phys:
    """Contact parameters for materials mi (radius r1) and mj (radius r2), indices into the per-world tables."""
    p = Phys()
    a1 = mats.young[mi] * r1
    a2 = mats.young[mj] * r2
    p.kn = 2.0 * a1 * a2 / (a1 + a2)
    b1 = a1 * mats.poisson[mi]
    b2 = a2 * mats.poisson[mj]
    p.ks = 0.0
    if b1 + b2 > 0.0:
        p.ks = 2.0 * b1 * b2 / (b1 + b2)
    p.kr = r1 * r2 * p.ks * hmean(mats.alpha_kr[mi], mats.alpha_kr[mj])
    p.ktw = r1 * r2 * p.ks * hmean(mats.alpha_ktw[mi], mats.alpha_ktw[mj])
    p.tan_phi = wp.min(mats.tan_friction[mi], mats.tan_friction[mj])  # tan(min(phi_i, phi_j)): tan is increasing
    p.max_roll = wp.min(mats.eta_roll[mi] * r1, mats.eta_roll[mj] * r2)
    p.max_twist = wp.min(mats.eta_twist[mi] * r1, mats.eta_twist[mj] * r2)
    fi = mats.flags[mi]
    fj = mats.flags[mj]
    p.moment_law = int((fi & MAT_MOMENT) != 0 and (fj & MAT_MOMENT) != 0)
    p.cohesive = int((fi & MAT_COHESIVE) != 0 and (fj & MAT_COHESIVE) != 0)
    p.fragile = int((fi & MAT_FRAGILE) != 0 or (fj & MAT_FRAGILE) != 0)
    rmin = wp.min(r1, r2)
    p.an = wp.min(mats.normal_coh[mi], mats.normal_coh[mj]) * rmin * rmin
    p.as_ = wp.min(mats.shear_coh[mi], mats.shear_coh[mj]) * rmin * rmin
    return p


@wp.func
def new_hist(p: Phys, n: wp.vec3f, give_cohesion: int) -> Hist:
    """History of a contact created this step; cohesion is given if asked and both materials are cohesive."""
    h = Hist()
    h.fs = wp.vec3f(0.0)
    h.mb = wp.vec3f(0.0)
    h.mtw = wp.vec3f(0.0)
    h.normal = n
    h.unp = 0.0
    h.an = 0.0
    h.as_ = 0.0
    h.flags = ACTIVE | FRAGILE
    if give_cohesion != 0 and p.cohesive != 0:
        h.an = p.an
        h.as_ = p.as_
        h.flags = ACTIVE | COHESIVE
        if p.fragile != 0:
            h.flags = h.flags | FRAGILE
    return h


@wp.func
def set_cohesion(h: Hist, p: Phys) -> Hist:
    """Yade's setCohesionNow on an existing contact: adhesions reset, cohesion (re)established."""
    out = h
    if p.cohesive != 0:
        out.an = p.an
        out.as_ = p.as_
        out.flags = ACTIVE | COHESIVE
        if p.fragile != 0:
            out.flags = out.flags | FRAGILE
    return out


@wp.func
def empty_hist() -> Hist:
    h = Hist()
    h.fs = wp.vec3f(0.0)
    h.mb = wp.vec3f(0.0)
    h.mtw = wp.vec3f(0.0)
    h.normal = wp.vec3f(0.0)
    h.unp = 0.0
    h.an = 0.0
    h.as_ = 0.0
    h.flags = 0
    return h


@wp.func
def rotate_hist(v: wp.vec3f, orth: wp.vec3f, twist: wp.vec3f) -> wp.vec3f:
    """Yade's ScGeom::rotate: transport a tangential vector to the new contact plane (two small rotations)."""
    r = v - wp.cross(v, orth)
    return r - wp.cross(r, twist)


@wp.func
def cohfrict_law(
    h: Hist,
    p: Phys,
    is_new: int,
    n: wp.vec3f,
    un: float,
    v12: wp.vec3f,
    ang_sum: wp.vec3f,
    rel_angvel: wp.vec3f,
    dt: float,
    always_moment: int,
    unp_max: float,
) -> LawOut:
    """One step of Law2_ScGeom6D_CohFrictPhys_CohesionMoment (incremental moments).

    Args:
        h: history (for a new contact, from :func:`new_hist`).
        p: contact parameters.
        is_new: 1 if the contact was created this step (no rotation of the history).
        n: current unit normal (1 -> 2). un: overlap [m].
        v12: velocity of 2 relative to 1 at the contact point [m/s] (Yade's getIncidentVel).
        ang_sum: omega1 + omega2 [rad/s] (for the twist part of the transport).
        rel_angvel: omega2 - omega1 [rad/s].
        dt: time step [s]. always_moment: apply moments on non-cohesive contacts too.
        unp_max: a non-fragile contact is deleted when its plastic tensile displacement -unp exceeds this [m]
            (Yade's unpMax: 0 by default, so it breaks at its first tensile yield; < 0 means never).
    """
    out = LawOut()
    out.hist = h
    out.force = wp.vec3f(0.0)
    out.moment = wp.vec3f(0.0)
    out.alive = 1
    out.dissip_slide = 0.0
    out.dissip_roll = 0.0

    fn = p.kn * (un - h.unp)
    fragile = (h.flags & FRAGILE) != 0
    if -fn > h.an:
        if fragile:
            out.alive = 0
            out.hist = empty_hist()
            return out
        # non-fragile: normal plasticity in tension
        fn = -h.an
        out.hist.unp = un + h.an / p.kn
        if unp_max >= 0.0 and -out.hist.unp > unp_max:
            out.alive = 0
            out.hist = empty_hist()
            return out
    fn_out = fn

    # transport the history to the current tangent plane (nothing to transport for a new contact)
    orth = wp.vec3f(0.0)
    twist = wp.vec3f(0.0)
    if is_new == 0:
        orth = wp.cross(h.normal, n)
        twist = (0.5 * dt * wp.dot(h.normal, ang_sum)) * h.normal
    fs = rotate_hist(h.fs, orth, twist)
    if is_new != 0:
        fs = wp.vec3f(0.0)
    dus = (v12 - wp.dot(n, v12) * n) * dt
    fs = fs - p.ks * dus

    # Coulomb limit with shear adhesion; fragile bonds break when exceeded
    fs_norm = wp.length(fs)
    max_fs = wp.max(0.0, out.hist.as_ + fn * p.tan_phi)
    if fs_norm > max_fs:
        if fragile and (out.hist.flags & COHESIVE) != 0:
            out.hist.flags = out.hist.flags & ~COHESIVE
            out.hist.an = 0.0
            out.hist.as_ = 0.0
            max_fs = wp.max(0.0, fn * p.tan_phi)
        trial = fs
        fs = fs * (max_fs / fs_norm)
        if p.ks > 0.0:
            d = wp.dot(trial - fs, fs) / p.ks
            if d > 0.0:
                out.dissip_slide = d
        if fn < 0.0:
            fn_out = 0.0
    out.hist.fs = fs
    out.force = -fn_out * n - fs

    # rolling and twisting moments, incremental form, with plastic caps
    mb = h.mb
    mtw = h.mtw
    if p.moment_law != 0 and ((out.hist.flags & COHESIVE) != 0 or always_moment != 0):
        rel_twist = wp.dot(n, rel_angvel) * n
        rel_bend = rel_angvel - rel_twist
        mb = rotate_hist(h.mb, orth, twist) - p.kr * dt * rel_bend
        mtw = rotate_hist(h.mtw, orth, twist) - p.ktw * dt * rel_twist
        fabs = wp.abs(fn_out)
        if p.max_roll >= 0.0:
            roll_max = p.max_roll * fabs
            mbn = wp.length(mb)
            if mbn > roll_max:
                if p.kr > 0.0:
                    out.dissip_roll += (mbn - roll_max) * roll_max / p.kr
                if mbn > 0.0:
                    mb = mb * (roll_max / mbn)
        if p.max_twist >= 0.0:
            tw_max = p.max_twist * fabs
            mtn = wp.length(mtw)
            if mtn > tw_max:
                if p.ktw > 0.0:
                    out.dissip_roll += (mtn - tw_max) * tw_max / p.ktw
                if mtn > 0.0:
                    mtw = mtw * (tw_max / mtn)
        out.moment = mb + mtw
    out.hist.mb = mb
    out.hist.mtw = mtw
    out.hist.normal = n
    return out


@wp.func
def elastic_energy(h: Hist, p: Phys, un: float) -> float:
    """Elastic energy stored in a contact [J]: (Fn^2/kn + Fs^2/ks + Mb^2/kr + Mtw^2/ktw)/2."""
    fn = p.kn * (un - h.unp)
    e = 0.5 * fn * fn / p.kn
    if p.ks > 0.0:
        e += 0.5 * wp.dot(h.fs, h.fs) / p.ks
    if p.kr > 0.0:
        e += 0.5 * wp.dot(h.mb, h.mb) / p.kr
    if p.ktw > 0.0:
        e += 0.5 * wp.dot(h.mtw, h.mtw) / p.ktw
    return e


@wp.func
def closest_point_triangle(p: wp.vec3d, a: wp.vec3d, b: wp.vec3d, c: wp.vec3d) -> wp.vec4d:
    """Closest point of triangle abc to p, in float64 (Ericson, Real-Time Collision Detection 5.1.5).

    Returns (x, y, z, feature) with feature 0 = face interior, 1 = edge, 2 = vertex.
    """
    zero = wp.float64(0.0)
    ab = b - a
    ac = c - a
    ap = p - a
    d1 = wp.dot(ab, ap)
    d2 = wp.dot(ac, ap)
    if d1 <= zero and d2 <= zero:
        return wp.vec4d(a[0], a[1], a[2], wp.float64(2.0))
    bp = p - b
    d3 = wp.dot(ab, bp)
    d4 = wp.dot(ac, bp)
    if d3 >= zero and d4 <= d3:
        return wp.vec4d(b[0], b[1], b[2], wp.float64(2.0))
    vc = d1 * d4 - d3 * d2
    if vc <= zero and d1 >= zero and d3 <= zero:
        v = d1 / (d1 - d3)
        q = a + v * ab
        return wp.vec4d(q[0], q[1], q[2], wp.float64(1.0))
    cp = p - c
    d5 = wp.dot(ab, cp)
    d6 = wp.dot(ac, cp)
    if d6 >= zero and d5 <= d6:
        return wp.vec4d(c[0], c[1], c[2], wp.float64(2.0))
    vb = d5 * d2 - d1 * d6
    if vb <= zero and d2 >= zero and d6 <= zero:
        w = d2 / (d2 - d6)
        q = a + w * ac
        return wp.vec4d(q[0], q[1], q[2], wp.float64(1.0))
    va = d3 * d6 - d5 * d4
    if va <= zero and (d4 - d3) >= zero and (d5 - d6) >= zero:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        q = b + w * (c - b)
        return wp.vec4d(q[0], q[1], q[2], wp.float64(1.0))
    denom = wp.float64(1.0) / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    q = a + ab * v + ac * w
    return wp.vec4d(q[0], q[1], q[2], zero)
