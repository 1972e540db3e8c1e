"""Model (static description on the device) and State (dynamic variables) of a warpdem simulation.

Every array lives on the caller's device. Entities of all worlds are stored world after world: entity ``e`` of world
``w`` has index ``w * n_per_world + e``, so a batch of worlds is the same scene repeated with per-world parameters.
Positions are float64 (a 2 m bin with micrometre overlaps needs it); forces and contact history are float32.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import warp as wp

# Body flag bits: blocked degrees of freedom (world axes) x, y, z, rx, ry, rz, then properties.
DOF_BITS = {"x": 1, "y": 2, "z": 4, "X": 8, "Y": 16, "Z": 32}
FLAG_ASPHERICAL = 64
FLAG_PIVOT = 128
ALL_DOFS = 63
ROT_DOFS = 56


def dof_mask(blocked: str) -> int:
    """Bit mask of blocked degrees of freedom from Yade's notation, e.g. "xyzXYZ" blocks everything."""
    mask = 0
    for c in blocked:
        if c not in DOF_BITS:
            from .errors import InputError

            raise InputError(f"blocked must only contain the letters x, y, z, X, Y, Z, got {blocked!r}")
        mask |= DOF_BITS[c]
    return mask


@dataclass
class Model:
    """Static description of a (batched) scene, on one device. Produced by :meth:`ModelBuilder.finalize` and not
    changed after it (what a run changes is in ``types.Control``).

    Sizes: ``n_worlds`` worlds, each with ``bodies_per_world`` bodies, ``spheres_per_world`` spheres,
    ``meshes_per_world`` mesh instances and ``springs_per_world`` springs; the arrays hold all worlds.
    """

    device: wp.context.Device
    n_worlds: int
    bodies_per_world: int
    spheres_per_world: int
    meshes_per_world: int
    springs_per_world: int
    n_materials: int
    n_groups: int
    gravity: tuple[float, float, float]
    """gravitational acceleration [m/s^2], the same in every world."""

    # Bodies (n_bodies,)
    body_world: wp.array
    """world index of each body, int32 (n_bodies,)."""
    body_group: wp.array
    """damping/observer group of each body, int32 (n_bodies,)."""
    body_flags: wp.array
    """blocked-DoF bits 0..5 (x, y, z, rx, ry, rz), FLAG_ASPHERICAL and FLAG_PIVOT, int32 (n_bodies,)."""
    body_mass: wp.array
    """mass [kg], float64 (n_bodies,); 0 for bodies with every translation blocked and no mass given."""
    body_inertia: wp.array
    """principal moments of inertia [kg m^2], vec3d (n_bodies,)."""
    body_pivot: wp.array
    """pivot of a hinged body (FLAG_PIVOT) in its principal frame, relative to the centre of mass [m], vec3d
    (n_bodies,); zero for other bodies."""
    body_pivot_vel: wp.array
    """initial velocity of a hinged body's pivot (the carriage), world frame [m/s], vec3d (n_bodies,) (a run's
    current one: ``types.Control.pivot_vel``)."""
    body_pivot_friction: wp.array
    """dry (Coulomb) friction torque at a hinged body's pivot [N m], float64 (n_bodies,); 0: frictionless."""

    # Spheres (n_spheres,)
    sphere_body: wp.array
    """body owning each sphere, int32 (n_spheres,)."""
    sphere_world: wp.array
    """world of each sphere, int32 (n_spheres,)."""
    sphere_material: wp.array
    """material index (0..n_materials-1) of each sphere, int32 (n_spheres,)."""
    sphere_radius: wp.array
    """radius [m], float64 (n_spheres,) (contact overlaps are differences of float64 lengths)."""
    sphere_offset: wp.array
    """centre in the owning body's principal frame [m], vec3f (n_spheres,)."""

    # Mesh instances (n_meshes,) and triangles of the distinct geometries
    mesh_body: wp.array
    mesh_world: wp.array
    mesh_material: wp.array
    mesh_ids: wp.array
    """warp mesh id (uint64) of each instance; the warp mesh holds the vertices in the body frame."""
    mesh_tri_offset: wp.array
    """offset of the instance's geometry in the triangle arrays, int32 (n_meshes,)."""
    tri_vertices: wp.array
    """triangle vertices in the body frame [m], vec3d (n_triangles, 3) flattened as (3*n_triangles,)."""
    world_mesh_start: wp.array
    """first mesh instance of each world, int32 (n_worlds,)."""

    # Materials per world (n_worlds * n_materials,)
    mat_young: wp.array
    mat_poisson: wp.array
    mat_friction: wp.array
    """friction angle [rad] (a Simulation takes its tangent once, when it is made)."""
    mat_normal_cohesion: wp.array
    mat_shear_cohesion: wp.array
    mat_eta_roll: wp.array
    mat_eta_twist: wp.array
    mat_alpha_kr: wp.array
    mat_alpha_ktw: wp.array
    mat_flags: wp.array
    """bits: 1 moment law, 2 fragile, 4 cohesive; int32."""
    mat_pair_tan: wp.array
    """tan of a material pair's own friction angle [-], float32 (n_worlds * n_materials * n_materials,); -1: the
    smaller of the two materials' angles (``ModelBuilder.set_pair_friction``)."""
    mat_pair_adhesion: wp.array
    """a material pair's adhesion [Pa], float32 (n_worlds * n_materials * n_materials,): every new contact of the
    pair is bonded with tensile and shear strength adhesion x min(R1, R2)^2 (``ModelBuilder.set_pair_adhesion``);
    -1: none (the pair's cohesion follows its materials)."""

    # Local damping per world and group (n_worlds * n_groups,)
    group_damping: wp.array
    """initial Cundall local damping [-] per world and group, float32 (n_worlds * n_groups,) (a run's current one:
    ``types.Control.group_damping``)."""

    # Springs (n_springs,)
    spring_body_a: wp.array
    spring_body_b: wp.array
    spring_point_a: wp.array
    """attachment point in body a's principal frame [m], vec3f."""
    spring_point_b: wp.array
    spring_stiffness: wp.array
    """[N/m], float32."""
    spring_damping: wp.array
    """[N s/m], float32."""
    spring_rest_length: wp.array
    """[m], float32."""
    spring_preload: wp.array
    """force at rest length [N], tension positive, float32."""
    spring_progressive: wp.array
    """cubic stiffness [N/m^3]: F = preload + k u + progressive u^3 + c du/dt, float32."""
    spring_stop_stiffness: wp.array
    """[N/m]: added to k past the stop at u = 0 on the side the preload drives (preload * u < 0), float32."""

    # Host-side descriptions (numpy), for observers, checkpoints and readers
    names: dict[str, dict[str, int]] = field(default_factory=dict)
    """per entity kind ("body", "material", "group", "mesh", "spring"), name -> index within one world."""
    host: dict[str, np.ndarray] = field(default_factory=dict)
    """numpy copies of static arrays (radius, sphere_body, body_mass, ...), for observers and I/O."""
    warp_meshes: list = field(default_factory=list)
    """the warp.Mesh objects (kept alive here)."""
    max_radius: float = 0.0
    """largest sphere radius [m]."""
    contact_law: int = 0
    """the contact law of every material: ``laws.COHFRICT`` (0) or ``laws.HERTZ_MINDLIN`` (1)."""

    @property
    def n_bodies(self) -> int:
        return self.n_worlds * self.bodies_per_world

    @property
    def n_spheres(self) -> int:
        return self.n_worlds * self.spheres_per_world

    @property
    def n_meshes(self) -> int:
        return self.n_worlds * self.meshes_per_world

    @property
    def n_springs(self) -> int:
        return self.n_worlds * self.springs_per_world

    def body_index(self, name: str, world: int = 0) -> int:
        """Global index of the named body in a world."""
        return world * self.bodies_per_world + self.names["body"][name]

    def group_index(self, name: str) -> int:
        """Index of the named body group."""
        return self.names["group"][name]


@dataclass
class State:
    """Dynamic variables of all bodies (leapfrog: velocities at the half step), on the model's device.

    Attributes:
        body_pos: centre of mass [m], vec3d (n_bodies,).
        body_quat: orientation, principal frame to world, quatd (x, y, z, w) (n_bodies,).
        body_vel: velocity [m/s], vec3d (n_bodies,).
        body_angvel: angular velocity in the world frame [rad/s], vec3d (n_bodies,).
        body_angmom: angular momentum about the centre of mass, world frame [kg m^2/s], vec3d (n_bodies,).
        time: simulated time [s]; step: number of steps done.
    """

    body_pos: wp.array
    body_quat: wp.array
    body_vel: wp.array
    body_angvel: wp.array
    body_angmom: wp.array
    time: float = 0.0
    step: int = 0

    ARRAYS = ("body_pos", "body_quat", "body_vel", "body_angvel", "body_angmom")

    def numpy(self) -> dict[str, np.ndarray]:
        """Host copies of the state arrays."""
        return {k: getattr(self, k).numpy() for k in self.ARRAYS}
