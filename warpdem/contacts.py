"""Narrow phase and contact law: one kernel per contact kind, one thread per sphere over its candidate list (and,
for sphere-sphere contacts, optionally one thread per list entry: ``sphere_pair_kernel``).

Sphere-sphere (Yade's Ig2_Sphere_Sphere_ScGeom6D): n = (x2 - x1)/|x2 - x1|, un = R1 + R2 - |x2 - x1|, contact point
C = x1 + (R1 - un/2) n, relative velocity with Yade's anti-ratcheting factor.

Sphere-triangle (Yade's Ig2_Facet_Sphere_ScGeom6D, facet = body 1 with contact radius 2R): the closest point of the
triangle (face, edge or vertex) in the mesh's body frame; n from the facet to the sphere centre; C = x - (R - un/2) n.
Unlike Yade, a sphere meeting the shared edge or vertex of neighbouring triangles of one mesh gets ONE contact: an
edge or vertex contact is dropped when a triangle sharing that feature touches the sphere with its face, and edge or
vertex contacts at the same point are merged (the lowest triangle keeps it). When the face owning a contact changes
(a sphere rolling across a diagonal), the new contact inherits the old one's history if their normals agree.

Forces and torques are accumulated into per-body arrays (atomics); torques are about the body's centre of mass.

``mats`` (annotated ``Any``) is a law's material tables (``laws.MATERIAL_TABLES``): each kernel taking them is
generic and compiled once per law (``laws.overload_per_law``), the law selected by the tables' type.
"""

from __future__ import annotations

from typing import Any

import warp as wp

from .accumulate import add_wrench
from .broadphase import sphere_in_body_frame
from .geometry import closest_point_triangle
from .kernel_args import BodyState, Meshes, SphereList, Spheres, SphereState, Sums, TriangleList
from .laws import (
    ACTIVE,
    Hist,
    LawOut,
    contact_law,
    elastic_energy,
    empty_hist,
    new_hist,
    overload_per_law,
    pair_phys,
    set_cohesion,
    stiffness,
)
from .types import Options

wp.set_module_options({"enable_backward": False})

# energy accumulator slots per world (see observers.ENERGY_TERMS)
E_DAMPING = wp.constant(0)
E_SLIDING = wp.constant(1)
E_ROLLING = wp.constant(2)
E_SPRING_DAMPER = wp.constant(3)
E_DRIVEN = wp.constant(4)  # work done by drivers (kinematic bodies, imposed velocities, carried pivots)
N_ENERGY = wp.constant(5)  # slots per world in the energy accumulator


@wp.kernel
def pair_tan_kernel(friction: wp.array(dtype=float), pair_tan: wp.array(dtype=float), n_materials: int,
                    out: wp.array(dtype=float)):
    """out[(w, i, j)] = the tangent of material pair (i, j)'s friction angle in world w, for one entry of the
    (n_worlds * n_materials * n_materials,) pair tables: the pair's own tangent pair_tan [-] where set (>= 0),
    else tan of the smaller of the two materials' angles friction [rad] (float32, taken once here, not per
    contact and step)."""
    k = wp.tid()
    n = n_materials
    w = k / (n * n)
    i = (k / n) % n
    j = k % n
    t = pair_tan[k]
    if t < 0.0:
        t = wp.min(wp.tan(friction[w * n + i]), wp.tan(friction[w * n + j]))
    out[k] = t


@wp.func
def phys_of(mats: Any, world: int, mi: int, mj: int, r1: float, r2: float):
    """The contact parameters of materials mi and mj of ``world`` (contact radii r1, r2 [m]), by their law."""
    n = mats.n_materials
    off = world * n
    return pair_phys(mats, off + mi, off + mj, (off + mi) * n + mj, r1, r2)


@wp.func(inline=True)  # inlined: the same code as before the split
def add_dissipation(energy: wp.array(dtype=wp.float64), w: int, law: LawOut):
    """Add a contact law step's sliding and rolling dissipation [J] to world w's energy terms."""
    wp.atomic_add(energy, w * N_ENERGY + E_SLIDING, wp.float64(law.dissip_slide))
    wp.atomic_add(energy, w * N_ENERGY + E_ROLLING, wp.float64(law.dissip_roll))


@wp.struct
class PairWrench:
    """What one sphere-sphere pair gives the two bodies this step (:func:`sphere_pair`)."""

    alive: int  # 0: not in contact, or the law deleted the contact this step
    force: wp.vec3f  # force on sphere i's body [N] (sphere j's body gets -force)
    torque_i: wp.vec3f  # torque on sphere i's body about its centre of mass [N m]
    torque_j: wp.vec3f  # torque on sphere j's body about its centre of mass [N m]


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def sphere_pair(
    k: int,
    j: int,
    w: int,
    mi: int,
    xi: wp.vec3d,
    r1d: wp.float64,
    vi: wp.vec3f,
    wi: wp.vec3f,
    arm_i0: wp.vec3f,
    now: int,
    spheres: Spheres,
    mats: Any,
    opts: Options,
    kin: SphereState,
    hist: wp.array(dtype=Hist),  # in/out
    energy: wp.array(dtype=wp.float64),  # out
) -> PairWrench:
    """Candidate k of sphere i (world w, material mi, centre xi [m], radius r1d [m], velocity vi [m/s], angular
    velocity wi [rad/s], arm_i0 [m] from its body's centre of mass) against sphere j: the contact law, its history
    hist[k] and dissipated energies; the wrench each body gets."""
    out = PairWrench()
    out.alive = int(0)
    d = kin.pos[j] - xi
    dist = wp.length(d)
    r2d = spheres.radius[j]
    r1 = float(r1d)
    r2 = float(r2d)
    un = float(r1d + r2d - dist)
    active = hist[k].flags & ACTIVE  # the whole history only for a contact (most candidates are none)
    # a new contact needs an overlap, or at a bonding step a gap within bond_gap (r1 + r2) (Yade's
    # interactionDetectionFactor); the law then sees the gap as tension (a NaN overlap goes on to the fault check)
    reach = float(0.0)
    if now != 0:
        reach = opts.bond_gap * (r1 + r2)
    if not (active == 0 and un < -reach):
        h = hist[k]
        n = wp.vec3f(d / dist)
        p = phys_of(mats, w, mi, spheres.material[j], r1, r2)
        is_new = int(0)
        if active == 0:
            h = new_hist(p, n, wp.max(wp.max(opts.cohesion_on_new, now), p.adhesive))
            is_new = int(1)
        elif now != 0:
            h = set_cohesion(h, p)
        wj = kin.angvel[j]
        alpha = (r1 + r2) / (r1 + r2 - un)
        v12 = alpha * (kin.vel[j] - vi) - wp.cross(r1 * wi + r2 * wj, n)
        law = contact_law(mats, h, p, is_new, n, un, v12, wi + wj, wj - wi, float(opts.dt), opts.always_moment,
                          opts.unp_max)
        hist[k] = law.hist
        if law.alive != 0:
            arm_i = arm_i0 + (r1 - 0.5 * un) * n
            arm_j = kin.arm[j] - (r2 - 0.5 * un) * n
            out.alive = int(1)
            out.force = law.force
            out.torque_i = wp.cross(arm_i, law.force) - law.moment
            out.torque_j = wp.cross(arm_j, -law.force) + law.moment
            if opts.track_energy != 0:
                add_dissipation(energy, w, law)
    return out


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def sphere_sphere_one(
    i: int,
    spheres: Spheres,
    mats: Any,
    opts: Options,
    kin: SphereState,
    ss: SphereList,  # in/out: the history
    cohesion_now: wp.array(dtype=int),
    sums: Sums,  # out: the fixed-point wrench sums (a part's) and the energy terms
):
    """Sphere i against its sphere candidates (one thread of sphere_sphere_kernel, or a world's loop): its own
    force and torque summed in float32 over its contacts, then added once."""
    n_i = ss.count[i]
    if n_i == 0:
        return
    bi = spheres.body[i]
    w = spheres.world[i]
    xi = kin.pos[i]
    r1d = spheres.radius[i]
    vi = kin.vel[i]
    wi = kin.angvel[i]
    mi = spheres.material[i]
    arm_i0 = kin.arm[i]
    f_i = wp.vec3f(0.0)
    t_i = wp.vec3f(0.0)
    now = cohesion_now[0]
    for k in range(ss.start[i], ss.start[i] + n_i):
        j = ss.other[k]
        c = sphere_pair(k, j, w, mi, xi, r1d, vi, wi, arm_i0, now, spheres, mats, opts, kin, ss.hist, sums.energy)
        if c.alive != 0:
            f_i += c.force
            t_i += c.torque_i
            add_wrench(sums.force_acc, sums.torque_acc, sums.force_scale, sums.torque_scale, spheres.body[j],
                       -c.force, c.torque_j)
    add_wrench(sums.force_acc, sums.torque_acc, sums.force_scale, sums.torque_scale, bi, f_i, t_i)


@wp.kernel
def sphere_sphere_kernel(
    first: int,  # the first sphere of this launch (a CPU thread's share)
    spheres: Spheres,
    mats: Any,
    opts: Options,
    kin: SphereState,
    ss: SphereList,
    cohesion_now: wp.array(dtype=int),
    sums: Sums,
):
    sphere_sphere_one(wp.tid() + first, spheres, mats, opts, kin, ss, cohesion_now, sums)


@wp.kernel
def sphere_pair_kernel(
    first: int,  # the first list entry of this launch (a CPU thread's share)
    spheres: Spheres,
    mats: Any,
    opts: Options,
    kin: SphereState,
    ss: SphereList,  # with ``owner``
    cohesion_now: wp.array(dtype=int),
    sums: Sums,
):
    """One thread per entry k of the sphere-sphere list (owner[k] = its sphere i, -1 for a free slot): the same
    law as sphere_sphere_kernel, but each contact adds its own wrench to both bodies, so a sphere's contacts are not
    summed in float32 first (the results differ from sphere_sphere_kernel's by that rounding)."""
    k = wp.tid() + first
    i = ss.owner[k]
    if i < 0:
        return
    w = spheres.world[i]
    c = sphere_pair(k, ss.other[k], w, spheres.material[i], kin.pos[i], spheres.radius[i], kin.vel[i],
                    kin.angvel[i], kin.arm[i], cohesion_now[0], spheres, mats, opts, kin, ss.hist, sums.energy)
    if c.alive != 0:
        add_wrench(sums.force_acc, sums.torque_acc, sums.force_scale, sums.torque_scale, spheres.body[i], c.force,
                   c.torque_i)
        add_wrench(sums.force_acc, sums.torque_acc, sums.force_scale, sums.torque_scale, spheres.body[ss.other[k]],
                   -c.force, c.torque_j)


# ----------------------------------------------------------------------------- sphere-triangle
@wp.struct
class TriGeom:
    """Sphere-triangle geometry in the mesh body's frame."""

    normal: wp.vec3f  # from the triangle to the sphere centre
    point: wp.vec3d  # closest point of the triangle
    un: float  # overlap [m]
    feature: int  # 0 face, 1 edge, 2 vertex


@wp.func
def tri_geom(p: wp.vec3d, r: wp.float64, tri_vertices: wp.array(dtype=wp.vec3d), t: int) -> TriGeom:
    """Geometry in float64 (a 2 m wall triangle and a micrometre overlap), returned as float32 normal and overlap."""
    a = tri_vertices[3 * t]
    b = tri_vertices[3 * t + 1]
    c = tri_vertices[3 * t + 2]
    cp = closest_point_triangle(p, a, b, c)
    g = TriGeom()
    g.point = wp.vec3d(cp[0], cp[1], cp[2])
    g.feature = int(cp[3])
    if g.feature == 0:
        nf = wp.normalize(wp.cross(b - a, c - a))
        s = wp.dot(p - a, nf)
        if s < wp.float64(0.0):
            nf = -nf
            s = -s
        g.normal = wp.vec3f(nf)
        g.un = float(r - s)
    else:
        dv = p - g.point
        dl = wp.length(dv)
        g.normal = wp.vec3f(dv / wp.max(dl, wp.float64(1.0e-30)))
        g.un = float(r - dl)
    return g


@wp.func(inline=True)  # inlined: no copies of its struct arguments per call
def entry_geom(k: int, p_world: wp.vec3d, r: wp.float64, st: TriangleList, meshes: Meshes, bodies: BodyState
               ) -> TriGeom:
    """The geometry of entry k of a sphere-triangle list for a sphere at p_world [m] of radius r [m]."""
    m = st.mesh[k]
    b = meshes.body[m]
    p = sphere_in_body_frame(p_world, bodies.pos[b], bodies.quat[b])
    return tri_geom(p, r, meshes.tri_vertices, meshes.tri_offset[m] + st.face[k])


@wp.func(inline=True)  # inlined: no copies of its struct arguments per call
def suppressed(k: int, g: TriGeom, k0: int, k1: int, p_world: wp.vec3d, r: wp.float64, st: TriangleList,
               meshes: Meshes, bodies: BodyState) -> int:
    """1 if entry k's edge/vertex contact belongs to a neighbour's face contact or duplicates a lower entry."""
    if g.feature == 0:
        return 0
    tol = wp.float64(1.0e-5) * r
    mesh = st.mesh
    face = st.face
    tri_vertices = meshes.tri_vertices
    for k2 in range(k0, k1):
        if k2 == k or mesh[k2] != mesh[k]:
            continue
        g2 = entry_geom(k2, p_world, r, st, meshes, bodies)
        if g2.un < 0.0:
            continue
        if g2.feature == 0:
            # does our closest point (an edge or vertex) lie on the touching triangle k2?
            cp = closest_point_triangle(
                g.point,
                tri_vertices[3 * (meshes.tri_offset[mesh[k2]] + face[k2])],
                tri_vertices[3 * (meshes.tri_offset[mesh[k2]] + face[k2]) + 1],
                tri_vertices[3 * (meshes.tri_offset[mesh[k2]] + face[k2]) + 2],
            )
            if wp.length(wp.vec3d(cp[0], cp[1], cp[2]) - g.point) <= tol:
                return 1
        elif k2 < k and wp.length(g2.point - g.point) <= tol:
            return 1
    return 0


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def sphere_triangle_one(
    i: int,
    spheres: Spheres,
    meshes: Meshes,
    mats: Any,
    opts: Options,
    kin: SphereState,
    bodies: BodyState,
    st: TriangleList,  # in/out: the history
    cohesion_now: wp.array(dtype=int),
    sums: Sums,  # out: the fixed-point wrench sums of bodies and meshes (a part's) and the energy terms
):
    """Sphere i against its triangle candidates (one thread of sphere_triangle_kernel, or a world's loop)."""
    n_i = st.count[i]
    if n_i == 0:
        return
    k0 = st.start[i]
    k1 = k0 + n_i
    x = kin.pos[i]
    rd = spheres.radius[i]
    r = float(rd)
    w = spheres.world[i]
    vs = kin.vel[i]
    ws = kin.angvel[i]
    now = cohesion_now[0]
    f_s = wp.vec3f(0.0)
    t_s = wp.vec3f(0.0)
    # pass 1: contacts that exist now (inheriting history where the owning face changed) get the law
    for k in range(k0, k1):
        g = entry_geom(k, x, rd, st, meshes, bodies)
        active = st.hist[k].flags & ACTIVE
        if active == 0 and g.un < 0.0:
            continue
        h = st.hist[k]
        if suppressed(k, g, k0, k1, x, rd, st, meshes, bodies) == 1:
            continue
        m = st.mesh[k]
        b = meshes.body[m]
        q = bodies.quat[b]
        n = wp.vec3f(wp.quat_rotate(q, wp.vec3d(g.normal)))
        # facet = body 1 with contact radius 2R (Yade)
        p = phys_of(mats, w, meshes.material[m], spheres.material[i], 2.0 * r, r)
        is_new = int(0)
        if active == 0:
            is_new = int(1)
            h = new_hist(p, n, wp.max(wp.max(opts.cohesion_on_new, now), p.adhesive))
            # inherit from a contact of the same mesh that existed last step and no longer does
            for k2 in range(k0, k1):
                h2 = st.hist[k2]
                if k2 != k and st.mesh[k2] == m and (h2.flags & ACTIVE) != 0 and wp.dot(h2.normal, n) > 0.99:
                    g2 = entry_geom(k2, x, rd, st, meshes, bodies)
                    if suppressed(k2, g2, k0, k1, x, rd, st, meshes, bodies) == 1:
                        h = h2
                        is_new = int(0)
        elif now != 0:
            h = set_cohesion(h, p)
        arm_s = -(r - 0.5 * g.un) * n  # C - x_sphere
        arm_m = wp.vec3f(x - bodies.pos[b]) + arm_s  # C - X_mesh_body
        vm = wp.vec3f(bodies.vel[b])
        wm = wp.vec3f(bodies.angvel[b])
        v12 = (vs + wp.cross(ws, arm_s)) - (vm + wp.cross(wm, arm_m))
        out = contact_law(mats, h, p, is_new, n, g.un, v12, wm + ws, ws - wm, float(opts.dt), opts.always_moment,
                           opts.unp_max)
        st.hist[k] = out.hist
        if out.alive == 0:
            continue
        tm = wp.cross(arm_m, out.force) - out.moment
        add_wrench(sums.force_acc, sums.torque_acc, sums.force_scale, sums.torque_scale, b, out.force, tm)
        add_wrench(sums.mesh_force_acc, sums.mesh_torque_acc, sums.mesh_force_scale, sums.mesh_torque_scale, m,
                   out.force, tm)
        f_s -= out.force
        t_s += wp.cross(kin.arm[i] + arm_s, -out.force) + out.moment
        if opts.track_energy != 0:
            add_dissipation(sums.energy, w, out)
    # pass 2: clear the history of entries that are not contacts any more
    for k in range(k0, k1):
        if (st.hist[k].flags & ACTIVE) == 0:
            continue
        g = entry_geom(k, x, rd, st, meshes, bodies)
        if suppressed(k, g, k0, k1, x, rd, st, meshes, bodies) == 1:
            st.hist[k] = empty_hist()
    add_wrench(sums.force_acc, sums.torque_acc, sums.force_scale, sums.torque_scale, spheres.body[i], f_s, t_s)


@wp.kernel
def sphere_triangle_kernel(
    first: int,  # the first sphere of this launch (a CPU thread's share)
    spheres: Spheres,
    meshes: Meshes,
    mats: Any,
    opts: Options,
    kin: SphereState,
    bodies: BodyState,
    st: TriangleList,
    cohesion_now: wp.array(dtype=int),
    sums: Sums,
):
    sphere_triangle_one(wp.tid() + first, spheres, meshes, mats, opts, kin, bodies, st, cohesion_now, sums)


# ----------------------------------------------------------------------------- per contact: energy, stiffness
@wp.func(inline=True)  # inlined: the same code as before the split
def sphere_entry(i: int, k: int, spheres: Spheres, mats: Any, kin: SphereState, ss: SphereList):
    """Entry k of sphere i's sphere-sphere list: returns (the contact's parameters by its law, its overlap un
    [m])."""
    radius = spheres.radius
    j = ss.other[k]
    un = float(radius[i] + radius[j] - wp.length(kin.pos[j] - kin.pos[i]))
    return phys_of(mats, spheres.world[i], spheres.material[i], spheres.material[j], float(radius[i]),
                   float(radius[j])), un


@wp.func(inline=True)  # inlined: the same code as before the split
def triangle_entry(i: int, k: int, spheres: Spheres, meshes: Meshes, mats: Any, kin: SphereState,
                   bodies: BodyState, st: TriangleList):
    """Entry k of sphere i's sphere-triangle list: returns (the contact's parameters by its law, its overlap un
    [m])."""
    rd = spheres.radius[i]
    r = float(rd)
    g = entry_geom(k, kin.pos[i], rd, st, meshes, bodies)
    return phys_of(mats, spheres.world[i], meshes.material[st.mesh[k]], spheres.material[i], 2.0 * r, r), g.un


@wp.kernel
def sphere_sphere_elastic_kernel(
    spheres: Spheres, mats: Any, kin: SphereState, ss: SphereList, out: wp.array(dtype=wp.float64)
):
    """The elastic energy of sphere i's active sphere-sphere contacts [J] added into out[its world]."""
    i = wp.tid()
    for k in range(ss.start[i], ss.start[i] + ss.count[i]):
        if (ss.hist[k].flags & ACTIVE) != 0:
            p, un = sphere_entry(i, k, spheres, mats, kin, ss)
            wp.atomic_add(out, spheres.world[i], wp.float64(elastic_energy(mats, ss.hist[k], p, un)))


@wp.kernel
def sphere_triangle_elastic_kernel(spheres: Spheres, meshes: Meshes, mats: Any, kin: SphereState,
                                   bodies: BodyState, st: TriangleList, out: wp.array(dtype=wp.float64)):
    """The elastic energy of sphere i's active sphere-triangle contacts [J] added into out[its world]."""
    i = wp.tid()
    for k in range(st.start[i], st.start[i] + st.count[i]):
        if (st.hist[k].flags & ACTIVE) != 0:
            p, un = triangle_entry(i, k, spheres, meshes, mats, kin, bodies, st)
            wp.atomic_add(out, spheres.world[i], wp.float64(elastic_energy(mats, st.hist[k], p, un)))


@wp.kernel
def sphere_sphere_stiffness_kernel(
    spheres: Spheres, mats: Any, kin: SphereState, ss: SphereList, out: wp.array(dtype=wp.vec4f)
):
    """out[k] = (kn [N/m], ks [N/m], kr [N m/rad], ktw [N m/rad]) of entry k of sphere i's sphere-sphere list, by
    the contact law (zeros for an entry that is not a contact)."""
    i = wp.tid()
    for k in range(ss.start[i], ss.start[i] + ss.count[i]):
        out[k] = wp.vec4f(0.0)
        if (ss.hist[k].flags & ACTIVE) != 0:
            p, un = sphere_entry(i, k, spheres, mats, kin, ss)
            out[k] = stiffness(mats, ss.hist[k], p, un)


@wp.kernel
def sphere_triangle_stiffness_kernel(spheres: Spheres, meshes: Meshes, mats: Any, kin: SphereState,
                                     bodies: BodyState, st: TriangleList, out: wp.array(dtype=wp.vec4f)):
    """out[k] = (kn, ks, kr, ktw) of entry k of sphere i's sphere-triangle list (as sphere_sphere_stiffness_kernel)."""
    i = wp.tid()
    for k in range(st.start[i], st.start[i] + st.count[i]):
        out[k] = wp.vec4f(0.0)
        if (st.hist[k].flags & ACTIVE) != 0:
            p, un = triangle_entry(i, k, spheres, meshes, mats, kin, bodies, st)
            out[k] = stiffness(mats, st.hist[k], p, un)


overload_per_law(sphere_sphere_kernel, sphere_pair_kernel, sphere_triangle_kernel, sphere_sphere_elastic_kernel,
                 sphere_triangle_elastic_kernel, sphere_sphere_stiffness_kernel, sphere_triangle_stiffness_kernel)
