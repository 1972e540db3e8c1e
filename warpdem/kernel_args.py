"""Kernel arguments grouped as Warp structs, as MuJoCo Warp groups its Model and Data: what a stage of the step
reads of the model (bodies, spheres, meshes, springs; the materials are ``laws.MaterialTables``, the settings
``types.Options``), what it reads and
writes of the state (body poses and velocities, sphere kinematics, the candidate lists with their history) and the
sums it adds into (fixed-point wrenches, energies, their float results).

The structs hold the same ``wp.array`` objects as the Model, State and Data (no copies): :class:`Simulation` makes
them once from those and again whenever an array is replaced (a list that grows, :meth:`Simulation.recapture`).
A kernel takes a few of them by value; each stage function (``contacts.sphere_sphere_one``,
``integrator.integrate_body``, ...) takes them as they are, so a one-stage kernel and the world kernel
(world_steps.py) call it with the same few arguments. Sizes: ``ns`` spheres, ``nb`` bodies, ``nm`` mesh instances
(arrays sized by ``nm`` or the springs have at least one entry), ``P`` CPU threads sharing a step.
"""

from __future__ import annotations

import warp as wp

from .accumulate import vec3l
from .laws import Hist

wp.set_module_options({"enable_backward": False})


# ----------------------------------------------------------------------------- Model
@wp.struct
class Bodies:
    """The bodies (Model, and the Control's pivot velocities and damping): each array of shape (nb,) but
    ``group_damping``."""

    world: wp.array(dtype=int)
    """world of each body, int32."""
    group: wp.array(dtype=int)
    """damping group of each body, int32."""
    flags: wp.array(dtype=int)
    """blocked-DoF bits, FLAG_ASPHERICAL, FLAG_PIVOT (model.py), int32."""
    mass: wp.array(dtype=wp.float64)
    """mass [kg], float64."""
    inertia: wp.array(dtype=wp.vec3d)
    """principal moments of inertia [kg m^2], vec3d."""
    pivot: wp.array(dtype=wp.vec3d)
    """a hinged body's pivot from its centre of mass, principal frame [m], vec3d."""
    pivot_vel: wp.array(dtype=wp.vec3d)
    """velocity of a hinged body's pivot [m/s], vec3d (``types.Control.pivot_vel``)."""
    pivot_friction: wp.array(dtype=wp.float64)
    """dry friction torque at a hinged body's pivot [N m], float64."""
    group_damping: wp.array(dtype=float)
    """Cundall local damping per world and group [-], float32 (n_worlds * n_groups,)
    (``types.Control.group_damping``)."""
    n_groups: int
    """damping groups per world."""
    gravity: wp.vec3d
    """gravitational acceleration [m/s^2]."""


@wp.struct
class Spheres:
    """The spheres (Model), each array of shape (ns,)."""

    body: wp.array(dtype=int)
    """body owning each sphere, int32."""
    world: wp.array(dtype=int)
    """world of each sphere, int32."""
    material: wp.array(dtype=int)
    """material index within its world's table, int32."""
    radius: wp.array(dtype=wp.float64)
    """radius [m], float64."""
    offset: wp.array(dtype=wp.vec3f)
    """centre in the owning body's principal frame [m], vec3f."""


@wp.struct
class Meshes:
    """The mesh instances (Model), each array of shape (nm,) but ``tri_vertices``."""

    body: wp.array(dtype=int)
    """body carrying each mesh instance, int32."""
    material: wp.array(dtype=int)
    """material index within its world's table, int32."""
    tri_offset: wp.array(dtype=int)
    """first triangle of the instance's geometry, int32."""
    tri_vertices: wp.array(dtype=wp.vec3d)
    """triangle vertices in the body frame [m], vec3d (3 * n_triangles,)."""
    rmax: wp.array(dtype=float)
    """largest vertex distance from the body's centre of mass [m], float32 (``Data.mesh_rmax``)."""
    ids: wp.array(dtype=wp.uint64)
    """the warp.Mesh id of each instance (its vertices in the body frame), uint64."""
    world_start: wp.array(dtype=int)
    """first mesh instance of each world, int32 (n_worlds,)."""
    per_world: int
    """mesh instances per world."""


@wp.struct
class Springs:
    """The spring-dashpots (Model), each array of shape (n_springs,), at least one entry."""

    body_a: wp.array(dtype=int)
    """first body, int32."""
    body_b: wp.array(dtype=int)
    """second body, int32."""
    point_a: wp.array(dtype=wp.vec3f)
    """attachment point in body a's principal frame [m], vec3f."""
    point_b: wp.array(dtype=wp.vec3f)
    """attachment point in body b's principal frame [m], vec3f."""
    stiffness: wp.array(dtype=float)
    """[N/m], float32."""
    damping: wp.array(dtype=float)
    """[N s/m], float32."""
    rest_length: wp.array(dtype=float)
    """[m], float32."""
    preload: wp.array(dtype=float)
    """force at rest length [N], tension positive, float32."""
    progressive: wp.array(dtype=float)
    """cubic stiffness [N/m^3], float32."""
    stop_stiffness: wp.array(dtype=float)
    """[N/m] added past the stop at u = 0 on the side the preload drives, float32."""


# ----------------------------------------------------------------------------- State and Data
@wp.struct
class BodyState:
    """The bodies' state (``State``), each array of shape (nb,)."""

    pos: wp.array(dtype=wp.vec3d)
    """centre of mass [m], vec3d."""
    quat: wp.array(dtype=wp.quatd)
    """orientation, principal frame to world, quatd (x, y, z, w)."""
    vel: wp.array(dtype=wp.vec3d)
    """velocity [m/s], vec3d."""
    angvel: wp.array(dtype=wp.vec3d)
    """angular velocity, world frame [rad/s], vec3d."""
    angmom: wp.array(dtype=wp.vec3d)
    """angular momentum about the centre of mass, world frame [kg m^2/s], vec3d."""


@wp.struct
class SphereState:
    """The spheres' kinematics from their bodies (``Data``), each array of shape (ns,)."""

    pos: wp.array(dtype=wp.vec3d)
    """centre [m], vec3d."""
    vel: wp.array(dtype=wp.vec3f)
    """velocity of the centre [m/s], vec3f."""
    angvel: wp.array(dtype=wp.vec3f)
    """angular velocity (its body's) [rad/s], vec3f."""
    arm: wp.array(dtype=wp.vec3f)
    """centre minus its body's centre of mass, world frame [m], vec3f."""


@wp.struct
class SphereList:
    """The sphere-sphere candidates (``Data.ss``, broadphase.PairList): per sphere its partners of higher index."""

    start: wp.array(dtype=int)
    """first entry of each sphere, int32 (ns,)."""
    count: wp.array(dtype=int)
    """entries of each sphere, int32 (ns,)."""
    other: wp.array(dtype=int)
    """the partner sphere of each entry, int32 (capacity,)."""
    owner: wp.array(dtype=int)
    """the sphere of each entry, -1 for a free slot, int32 (capacity,); only with contact_threads "pair"."""
    hist: wp.array(dtype=Hist)
    """contact history of each entry, laws.Hist (capacity,)."""


@wp.struct
class TriangleList:
    """The sphere-triangle candidates (``Data.st``, broadphase.PairList): per sphere (mesh, face) entries."""

    start: wp.array(dtype=int)
    """first entry of each sphere, int32 (ns,)."""
    count: wp.array(dtype=int)
    """entries of each sphere, int32 (ns,)."""
    mesh: wp.array(dtype=int)
    """the mesh instance of each entry, int32 (capacity,)."""
    face: wp.array(dtype=int)
    """the triangle of each entry within its mesh's geometry, int32 (capacity,)."""
    hist: wp.array(dtype=Hist)
    """contact history of each entry, laws.Hist (capacity,)."""


@wp.struct
class Sums:
    """What a step's stages add into and the float results (``Data``, accumulate.py): the fixed-point wrench sums
    of one CPU thread's part (``P`` slots of nb or nm entries in the whole arrays, one slot in a part's), their
    scales, the energy terms, and the float forces the observers read."""

    force_acc: wp.array(dtype=vec3l)
    """force on each body in units of its resolution, vec3l (nb,) of a part or (P * nb,)."""
    torque_acc: wp.array(dtype=vec3l)
    """torque about each body's centre of mass in units of its resolution, vec3l, as ``force_acc``."""
    force_scale: wp.array(dtype=wp.float64)
    """1 / force resolution of each body [1/N], float64 (nb,)."""
    torque_scale: wp.array(dtype=wp.float64)
    """1 / torque resolution of each body [1/(N m)], float64 (nb,)."""
    mesh_force_acc: wp.array(dtype=vec3l)
    """contact force on each mesh instance, fixed point, vec3l (nm,) of a part or (P * nm,)."""
    mesh_torque_acc: wp.array(dtype=vec3l)
    """contact torque on each mesh instance, fixed point, vec3l, as ``mesh_force_acc``."""
    mesh_force_scale: wp.array(dtype=wp.float64)
    """1 / force resolution of each mesh instance [1/N], float64 (nm,)."""
    mesh_torque_scale: wp.array(dtype=wp.float64)
    """1 / torque resolution of each mesh instance [1/(N m)], float64 (nm,)."""
    energy: wp.array(dtype=wp.float64)
    """energy terms per world [J], float64 (n_worlds * N_ENERGY,): ``Data.energy`` for part 0, a slice of
    ``Data.energy_extra`` for the others."""
    body_force: wp.array(dtype=wp.vec3f)
    """contact and spring force on each body [N], vec3f (nb,)."""
    body_torque: wp.array(dtype=wp.vec3f)
    """contact and spring torque about each body's centre of mass [N m], vec3f (nb,)."""
    mesh_force: wp.array(dtype=wp.vec3f)
    """contact force on each mesh instance [N], vec3f (nm,)."""
    mesh_torque: wp.array(dtype=wp.vec3f)
    """contact torque on each mesh instance about its body's centre of mass [N m], vec3f (nm,)."""
    mesh_force_sum: wp.array(dtype=wp.vec3d)
    """``mesh_force`` added up step after step [N], vec3d (nm,)."""
    spring_force: wp.array(dtype=float)
    """force of each spring-dashpot [N], tension positive, float32 (n_springs,)."""


# ----------------------------------------------------------------------------- made on the host
def bodies_of(model: object, control: object) -> Bodies:
    """The :class:`Bodies` of a Model with a run's ``types.Control``."""
    a = Bodies()
    a.world, a.group, a.flags = model.body_world, model.body_group, model.body_flags
    a.mass, a.inertia = model.body_mass, model.body_inertia
    a.pivot, a.pivot_vel, a.pivot_friction = model.body_pivot, control.pivot_vel, model.body_pivot_friction
    a.group_damping, a.n_groups, a.gravity = control.group_damping, model.n_groups, wp.vec3d(*model.gravity)
    return a


def spheres_of(model: object) -> Spheres:
    """The :class:`Spheres` of a Model."""
    a = Spheres()
    a.body, a.world, a.material = model.sphere_body, model.sphere_world, model.sphere_material
    a.radius, a.offset = model.sphere_radius, model.sphere_offset
    return a


def meshes_of(model: object, data: object) -> Meshes:
    """The :class:`Meshes` of a Model (and the extents ``data.mesh_rmax``)."""
    a = Meshes()
    a.body, a.material, a.tri_offset = model.mesh_body, model.mesh_material, model.mesh_tri_offset
    a.tri_vertices, a.rmax = model.tri_vertices, data.mesh_rmax
    a.ids, a.world_start, a.per_world = model.mesh_ids, model.world_mesh_start, model.meshes_per_world
    return a


def springs_of(model: object) -> Springs:
    """The :class:`Springs` of a Model."""
    a = Springs()
    for name in ("body_a", "body_b", "point_a", "point_b", "stiffness", "damping", "rest_length", "preload",
                 "progressive", "stop_stiffness"):
        setattr(a, name, getattr(model, "spring_" + name))
    return a


def body_state_of(state: object) -> BodyState:
    """The :class:`BodyState` of a State."""
    a = BodyState()
    a.pos, a.quat, a.vel, a.angvel, a.angmom = (state.body_pos, state.body_quat, state.body_vel, state.body_angvel,
                                                state.body_angmom)
    return a


def sphere_state_of(data: object) -> SphereState:
    """The :class:`SphereState` of a Data."""
    a = SphereState()
    a.pos, a.vel, a.angvel, a.arm = data.sphere_pos, data.sphere_vel, data.sphere_angvel, data.sphere_arm
    return a


def sphere_list_of(pairs: object) -> SphereList:
    """The :class:`SphereList` of a sphere-sphere broadphase.PairList."""
    a = SphereList()
    a.start, a.count, a.other, a.hist = pairs.start, pairs.count, pairs.key_a, pairs.hist
    if pairs.owner is not None:
        a.owner = pairs.owner
    return a


def triangle_list_of(pairs: object) -> TriangleList:
    """The :class:`TriangleList` of a sphere-triangle broadphase.PairList."""
    a = TriangleList()
    a.start, a.count, a.mesh, a.face, a.hist = pairs.start, pairs.count, pairs.key_a, pairs.key_b, pairs.hist
    return a


def sums_of(data: object, part: int = 0, whole: bool = True) -> Sums:
    """The :class:`Sums` of a Data for CPU thread ``part``: its energy terms, and the whole
    accumulators (``whole``: for the integration and the meshes' end of step, which sum every part's slots) or
    only its own slots (for the contacts and springs, which add into them)."""
    a = Sums()
    nb = data.force_scale.shape[0]
    nm = data.mesh_force_scale.shape[0]
    ne = data.energy.shape[0]
    if whole or data.force_acc.shape[0] == nb:  # all parts, or the only one (no slices of an empty array)
        a.force_acc, a.torque_acc = data.force_acc, data.torque_acc
        a.mesh_force_acc, a.mesh_torque_acc = data.mesh_force_acc, data.mesh_torque_acc
    else:
        a.force_acc = data.force_acc[part * nb:(part + 1) * nb]
        a.torque_acc = data.torque_acc[part * nb:(part + 1) * nb]
        a.mesh_force_acc = data.mesh_force_acc[part * nm:(part + 1) * nm]
        a.mesh_torque_acc = data.mesh_torque_acc[part * nm:(part + 1) * nm]
    a.force_scale, a.torque_scale = data.force_scale, data.torque_scale
    a.mesh_force_scale, a.mesh_torque_scale = data.mesh_force_scale, data.mesh_torque_scale
    a.energy = data.energy if part == 0 else data.energy_extra[(part - 1) * ne:part * ne]
    a.body_force, a.body_torque = data.body_force, data.body_torque
    a.mesh_force, a.mesh_torque, a.mesh_force_sum = data.mesh_force, data.mesh_torque, data.mesh_force_sum
    a.spring_force = data.spring_force
    return a
