"""ModelBuilder: a readable scripting API that turns a scene description into device arrays.

    b = ModelBuilder(gravity=(0, 0, -9.81))
    soil = b.add_material("soil", Material(young=1e7, poisson=0.4, density=2700, friction_angle=30))
    b.add_spheres(positions, radii, "soil", group="soil")
    b.add_mesh("floor", vertices, faces, "steel", kind="static")
    b.set_local_damping("soil", 0.2)
    model, state = b.finalize("cpu", n_worlds=20, overrides={"material:soil:friction_angle": angles})

Bodies are rigid: a free sphere, a clump of spheres, a triangle mesh (static, kinematic or dynamic) or a bare rigid
body (a kinematic carriage for springs). Units are SI; friction angles are in degrees at this API.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from . import laws
from . import mass as massprops
from .errors import (
    InputError,
    check_choice,
    check_finite,
    check_int,
    check_nonnegative,
    check_points,
    check_positive,
    check_vec3,
    degrees_to_radians,
)
from .laws import MATERIAL_FIELDS
from .model import ALL_DOFS, FLAG_ASPHERICAL, FLAG_PIVOT, ROT_DOFS, Model, State, dof_mask


@dataclass
class _Mesh:
    name: str
    body: int
    material: int
    vertices_local: np.ndarray  # (nv, 3) in the body's principal frame
    faces: np.ndarray  # (nf, 3)


@dataclass
class _Spring:
    name: str
    body_a: int
    point_a: np.ndarray
    body_b: int
    point_b: np.ndarray
    stiffness: float
    damping: float
    rest_length: float
    preload: float
    progressive: float = 0.0
    stop_stiffness: float = 0.0


SPRING_FIELDS = ("stiffness", "damping", "rest_length", "preload", "progressive", "stop_stiffness")
"""per-spring parameters a world may override."""
_BODY_FIELDS = ("pos", "quat", "vel", "angvel", "mass", "inertia", "density_material", "group", "blocked", "pivot")


class ModelBuilder:
    """Collects materials, bodies, meshes, springs and damping groups; :meth:`finalize` makes a Model and State."""

    def __init__(self, gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)) -> None:
        self.gravity = tuple(check_vec3("gravity", gravity).tolist())
        self.materials: list[laws.Material | laws.HertzMindlinMaterial] = []
        self.material_names: dict[str, int] = {}
        self.pair_friction: dict[tuple[int, int], float] = {}
        self.pair_adhesion: dict[tuple[int, int], float] = {}
        self.groups: dict[str, int] = {}
        self.group_damping: list[float] = []
        # bodies, stored as chunks of rows (see _push_bodies) and concatenated on demand
        self._chunks: dict[str, list[np.ndarray]] = {k: [] for k in _BODY_FIELDS}
        self._cache: dict[str, np.ndarray] = {}
        self.body_names: dict[str, int] = {}
        # spheres
        self.sphere_body: list[np.ndarray] = []
        self.sphere_offset: list[np.ndarray] = []
        self.sphere_radius: list[np.ndarray] = []
        self.sphere_material: list[np.ndarray] = []
        self.meshes: list[_Mesh] = []
        self.springs: list[_Spring] = []
        self._n_bodies = 0

    # ---------------------------------------------------------------- body storage
    def _push_bodies(self, **rows: np.ndarray) -> None:
        for k in _BODY_FIELDS:
            self._chunks[k].append(rows[k])
        self._n_bodies += len(rows["mass"])
        self._cache.clear()

    def body_array(self, key: str) -> np.ndarray:
        """All bodies' values of one field (pos, quat, vel, angvel, mass, inertia, ...), concatenated."""
        if key not in self._cache:
            chunks = self._chunks[key]
            self._cache[key] = np.concatenate(chunks) if chunks else np.zeros((0,))
        return self._cache[key]

    # ---------------------------------------------------------------- materials and groups
    def add_material(self, name: str, material: laws.Material | laws.HertzMindlinMaterial) -> int:
        """Register a material under a name; returns its index. The materials of one model all follow one contact
        law (a ``Material``: Yade's cohesive-frictional law; a ``HertzMindlinMaterial``: Hertz-Mindlin)."""
        if not isinstance(material, tuple(laws.LAWS.values())):
            raise InputError(f"material must be a warpdem.Material or warpdem.HertzMindlinMaterial, got "
                             f"{type(material).__name__}")
        if name in self.material_names:
            raise InputError(f"material name {name!r} is already used")
        if self.materials and material.LAW != laws.law_of(self.materials):
            law = laws.LAW_NAMES[laws.law_of(self.materials)]
            raise InputError(f"material {name!r} ({type(material).__name__}) follows another contact law than the "
                             f"materials already added ({law}); a model's materials all follow one law")
        self.material_names[name] = len(self.materials)
        self.materials.append(material)
        return self.material_names[name]

    def _material(self, material: str | int) -> int:
        if isinstance(material, str):
            if material not in self.material_names:
                raise InputError(f"material {material!r} is not defined; known: {sorted(self.material_names)}")
            return self.material_names[material]
        idx = check_int("material", material)
        if idx >= len(self.materials):
            raise InputError(f"material index {idx} is out of range (have {len(self.materials)})")
        return idx

    def set_pair_friction(self, a: str, b: str, friction_angle: float) -> None:
        """The friction angle [deg] (0 <= phi < 90) of every contact between materials ``a`` and ``b`` (names),
        instead of the smaller of their own (Yade's MatchMaker on Ip2_*'s frictAngle), e.g. soil on steel. Per world
        with the override ``pair:<a>:<b>:friction_angle``."""
        i, j = self._material(a), self._material(b)
        degrees_to_radians("pair friction_angle", friction_angle)
        self.pair_friction[(min(i, j), max(i, j))] = float(friction_angle)

    def set_pair_adhesion(self, a: str, b: str, adhesion: float) -> None:
        """Adhesion [Pa] (>= 0) between materials ``a`` and ``b`` (names), e.g. moist soil on steel: every new
        contact of the pair is bonded, with tensile and shear strength adhesion x min(R1, R2)^2 [N] (a facet's
        contact radius is twice its sphere's, so min(R1, R2) is the sphere's radius), whatever the simulation's
        cohesion rule; a bond that fails goes on as a frictional contact (broken for good where either material is
        fragile, yielding otherwise, as cohesion's bonds). Cohesive-frictional materials only. Per world with the
        override ``pair:<a>:<b>:adhesion``."""
        i, j = self._material(a), self._material(b)
        check_nonnegative("pair adhesion", adhesion)
        for k in (i, j):
            if self.materials[k].LAW != laws.COHFRICT:
                raise InputError(f"pair adhesion needs cohesive-frictional materials: {a!r} and {b!r}, got "
                                 f"{type(self.materials[k]).__name__}")
        self.pair_adhesion[(min(i, j), max(i, j))] = float(adhesion)

    def _group(self, group: str) -> int:
        if group not in self.groups:
            self.groups[group] = len(self.groups)
            self.group_damping.append(0.0)
        return self.groups[group]

    def set_local_damping(self, group: str, damping: float) -> None:
        """Cundall local (non-viscous) damping coefficient [-] in [0, 1) for the bodies of a group."""
        check_nonnegative("local damping", damping)
        if damping >= 1.0:
            raise InputError(f"local damping must be < 1, got {damping!r}")
        self.group_damping[self._group(group)] = float(damping)

    # ---------------------------------------------------------------- bodies
    def _add_body(
        self,
        pos: np.ndarray,
        quat: np.ndarray,
        mass: float,
        inertia: np.ndarray,
        density_material: int,
        group: str,
        blocked: str,
        velocity: object,
        angular_velocity: object,
        name: str | None,
        pivot: object | None = None,
    ) -> int:
        idx = self._n_bodies
        if pivot is None:
            piv = np.full(3, np.nan)
        else:
            piv = check_vec3("pivot", pivot)
            if dof_mask(blocked) & ALL_DOFS & ~ROT_DOFS:
                raise InputError(f"a hinged body's translation follows its pivot; blocked may only hold X, Y, Z, "
                                 f"got {blocked!r}")
        self._push_bodies(
            pos=np.asarray(pos, dtype=np.float64)[None],
            quat=np.asarray(quat, dtype=np.float64)[None],
            vel=check_vec3("velocity", velocity)[None],
            angvel=check_vec3("angular_velocity", angular_velocity)[None],
            mass=np.array([mass], dtype=np.float64),
            inertia=np.asarray(inertia, dtype=np.float64)[None],
            density_material=np.array([density_material]),
            group=np.array([self._group(group)]),
            blocked=np.array([dof_mask(blocked)]),
            pivot=piv[None],
        )
        if name is not None:
            if name in self.body_names:
                raise InputError(f"body name {name!r} is already used")
            self.body_names[name] = idx
        return idx

    def add_sphere(
        self,
        pos: object,
        radius: float,
        material: str | int,
        *,
        velocity: object = (0.0, 0.0, 0.0),
        angular_velocity: object = (0.0, 0.0, 0.0),
        group: str = "default",
        blocked: str = "",
        name: str | None = None,
    ) -> int:
        """Add a free sphere (its own rigid body). pos [m] (3,), radius [m]; returns the body index."""
        return int(
            self.add_spheres(
                np.asarray([pos], dtype=np.float64),
                [radius],
                material,
                velocities=np.asarray([velocity], dtype=np.float64),
                angular_velocities=np.asarray([angular_velocity], dtype=np.float64),
                group=group,
                blocked=blocked,
                name=name,
            )[0]
        )

    def add_spheres(
        self,
        positions: object,
        radii: object,
        material: str | int,
        *,
        velocities: object | None = None,
        angular_velocities: object | None = None,
        group: str = "default",
        blocked: str = "",
        name: str | None = None,
    ) -> np.ndarray:
        """Add many free spheres at once. positions [m] (n, 3), radii [m] (n,); returns body indices (n,).

        ``name`` (optional) names the first of them.
        """
        positions = check_points("sphere positions", positions)
        radii = np.broadcast_to(np.asarray(radii, dtype=np.float64), (len(positions),))
        check_positive("sphere radius", radii)
        mat = self._material(material)
        n = len(positions)
        vel = np.zeros((n, 3)) if velocities is None else np.broadcast_to(np.asarray(velocities, float), (n, 3))
        ang = (
            np.zeros((n, 3))
            if angular_velocities is None
            else np.broadcast_to(np.asarray(angular_velocities, float), (n, 3))
        )
        rho = self.materials[mat].density
        first = self._n_bodies
        gidx = self._group(group)
        mask = dof_mask(blocked)
        check_finite("sphere velocities", vel)
        check_finite("sphere angular velocities", ang)
        masses = rho * 4.0 / 3.0 * np.pi * radii**3
        self._push_bodies(
            pos=positions,
            quat=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
            vel=np.array(vel, dtype=np.float64),
            angvel=np.array(ang, dtype=np.float64),
            mass=masses,
            inertia=np.repeat((0.4 * masses * radii**2)[:, None], 3, axis=1),
            density_material=np.full(n, mat),
            group=np.full(n, gidx),
            blocked=np.full(n, mask),
            pivot=np.full((n, 3), np.nan),
        )
        ids = np.arange(first, first + n, dtype=np.int32)
        if name is not None:
            if name in self.body_names:
                raise InputError(f"body name {name!r} is already used")
            self.body_names[name] = first
        self.sphere_body.append(ids)
        self.sphere_offset.append(np.zeros((n, 3)))
        self.sphere_radius.append(radii.copy())
        self.sphere_material.append(np.full(n, mat, dtype=np.int32))
        return ids

    def add_clump(
        self,
        centres: object,
        radii: object,
        material: str | int,
        *,
        velocity: object = (0.0, 0.0, 0.0),
        angular_velocity: object = (0.0, 0.0, 0.0),
        group: str = "default",
        blocked: str = "",
        name: str | None = None,
    ) -> int:
        """Add a clump: a rigid body of overlapping spheres (member centres [m] (k, 3) in the world, radii [m] (k,)).

        Mass and inertia follow Yade's rule (sum of member masses, overlaps counted twice; parallel axes), and the
        body frame is the clump's principal frame. Returns the body index.
        """
        centres = check_points("clump centres", centres)
        radii = np.asarray(radii, dtype=np.float64).reshape(-1)
        if radii.shape != (len(centres),):
            raise InputError(f"clump radii must have shape ({len(centres)},), got {radii.shape}")
        check_positive("clump radius", radii)
        mat = self._material(material)
        m, com, moments, quat, offsets = self._clump_frames(centres, radii, np.array([len(radii)]), mat)
        body = self._add_body(com[0], quat[0], m[0], moments[0], mat, group, blocked, velocity, angular_velocity,
                              name)
        self.sphere_body.append(np.full(len(radii), body, dtype=np.int32))
        self.sphere_offset.append(offsets)
        self.sphere_radius.append(radii)
        self.sphere_material.append(np.full(len(radii), mat, dtype=np.int32))
        return body

    def _clump_frames(self, centres: np.ndarray, radii: np.ndarray, sizes: np.ndarray, mat: int
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Clumps' masses (c,), centres of mass (c, 3), principal moments (c, 3), quaternions (c, 4) and the member
        offsets in their principal frames (n, 3): one code path for one clump and for many, so both give the same
        bits (an elongated clump's two equal moments leave its frame to rounding)."""
        m, com, inertia = massprops.clumps_mass(centres, radii, np.full(len(radii), self.materials[mat].density), sizes)
        moments, quat = massprops.principal_axes_many(inertia)
        rot = massprops.quats_to_matrices(quat)
        owner = np.repeat(np.arange(len(sizes)), sizes)
        return m, com, moments, quat, np.einsum("ni,nij->nj", centres - com[owner], rot[owner])

    def add_clumps(
        self,
        centres: object,
        radii: object,
        sizes: object,
        material: str | int,
        *,
        group: str = "default",
    ) -> np.ndarray:
        """Add many clumps at rest at once: what :meth:`add_clump` does for each, vectorised.

        centres: member centres [m] (n, 3), clump after clump; radii [m] (n,); sizes: members per clump (c,),
        each >= 1, summing to n. Returns the body indices (c,).
        """
        centres = check_points("clump centres", centres)
        radii = np.asarray(radii, dtype=np.float64).reshape(-1)
        sizes = np.asarray(sizes, dtype=np.int64).reshape(-1)
        if radii.shape != (len(centres),):
            raise InputError(f"clump radii must have shape ({len(centres)},), got {radii.shape}")
        if len(sizes) and (sizes.min() < 1 or sizes.sum() != len(centres)):
            raise InputError(f"clump sizes must be >= 1 and sum to the {len(centres)} members, got sum "
                             f"{int(sizes.sum())}, min {int(sizes.min())}")
        check_positive("clump radius", radii)
        mat = self._material(material)
        m, com, moments, quat, offsets = self._clump_frames(centres, radii, sizes, mat)
        c = len(sizes)
        first = self._n_bodies
        self._push_bodies(
            pos=com, quat=quat, vel=np.zeros((c, 3)), angvel=np.zeros((c, 3)), mass=m, inertia=moments,
            density_material=np.full(c, mat), group=np.full(c, self._group(group)), blocked=np.full(c, dof_mask("")),
            pivot=np.full((c, 3), np.nan),
        )
        self.sphere_body.append((first + np.repeat(np.arange(c), sizes)).astype(np.int32))
        self.sphere_offset.append(offsets)
        self.sphere_radius.append(radii)
        self.sphere_material.append(np.full(len(radii), mat, dtype=np.int32))
        return np.arange(first, first + c, dtype=np.int32)

    def add_rigid_body(
        self,
        pos: object,
        *,
        mass: float = 0.0,
        inertia: object | None = None,
        velocity: object = (0.0, 0.0, 0.0),
        angular_velocity: object = (0.0, 0.0, 0.0),
        group: str = "default",
        blocked: str = "xyzXYZ",
        name: str | None = None,
        pivot: object | None = None,
    ) -> int:
        """Add a rigid body without geometry, e.g. a kinematic carriage that springs attach to.

        pos: centre of mass [m] (3,); mass [kg] (may be 0 only if every DoF is blocked); inertia: tensor about the
        centre of mass, world axes [kg m^2] (3, 3). By default every DoF is blocked and the body moves at
        ``velocity`` [m/s] and ``angular_velocity`` [rad/s]. ``pivot`` [m] (3,): see :meth:`add_mesh`.
        """
        pos = check_vec3("pos", pos)
        mask = dof_mask(blocked)
        if mask != ALL_DOFS:
            check_positive("mass", mass)
        if inertia is None:
            moments, quat = np.ones(3), np.array([0.0, 0.0, 0.0, 1.0])
            if mask & ROT_DOFS != ROT_DOFS:
                raise InputError("inertia must be given for a rigid body with free rotations")
        else:
            moments, quat = massprops.principal_axes(inertia)
        return self._add_body(pos, quat, mass, moments, -1, group, blocked, velocity, angular_velocity, name, pivot)

    def add_mesh(
        self,
        name: str,
        vertices: object,
        faces: object,
        material: str | int,
        *,
        kind: str = "static",
        body: int | None = None,
        mass: float | None = None,
        com: object | None = None,
        inertia: object | None = None,
        velocity: object = (0.0, 0.0, 0.0),
        angular_velocity: object = (0.0, 0.0, 0.0),
        group: str | None = None,
        blocked: str | None = None,
        pivot: object | None = None,
    ) -> int:
        """Add a triangle mesh (facets, both faces active) as a body, or attach it to an existing ``body``.

        Args:
            name: unique mesh name (also the body's name when a new body is made).
            vertices: [m] (nv, 3) in the world. faces: vertex indices (nf, 3).
            kind: "static" (fixed), "kinematic" (moves at the given velocity, every DoF blocked) or "dynamic"
                (a free rigid body moved by contact and spring forces; restrict it with ``blocked``).
            mass, com, inertia: of a dynamic mesh [kg], [m] (3,), tensor about com in world axes [kg m^2] (3, 3).
                If omitted they are computed by trimesh from the material's density (the mesh must be closed).
            velocity [m/s], angular_velocity [rad/s]: initial (or imposed, for blocked DoFs) velocities.
            pivot: a dynamic body hinged at this world point [m] (3,): the pivot moves at ``velocity`` (a carriage
                at constant speed), the body rotates about it (Euler's equations about the pivot, with the
                rotations in ``blocked`` held at ``angular_velocity``) and its centre of mass follows. The paper's
                tool: ``pivot=shank end, blocked="YZ"``.
        Returns the body index.
        """
        check_choice("kind", kind, ("static", "kinematic", "dynamic"))
        vertices, faces = massprops.check_faces(vertices, faces)
        mat = self._material(material)
        if any(m.name == name for m in self.meshes):
            raise InputError(f"mesh name {name!r} is already used")
        if body is None:
            grp = group or ("walls" if kind != "dynamic" else "tool")
            if kind == "dynamic":
                if mass is None:
                    m, c, inertia_c = massprops.mesh_mass(vertices, faces, self.materials[mat].density)
                else:
                    check_positive("mass", mass)
                    if com is None or inertia is None:
                        raise InputError("a dynamic mesh given a mass also needs com and inertia")
                    m, c, inertia_c = float(mass), check_vec3("com", com), np.asarray(inertia, dtype=np.float64)
                moments, quat = massprops.principal_axes(inertia_c)
                blk = blocked or ""
            elif pivot is not None:
                raise InputError(f"only a dynamic mesh can have a pivot, got kind={kind!r}")
            else:
                m, c = 0.0, vertices.mean(axis=0)
                moments, quat = np.ones(3), np.array([0.0, 0.0, 0.0, 1.0])
                blk = "xyzXYZ"
                if blocked not in (None, "xyzXYZ"):
                    raise InputError(f"a {kind} mesh has every DoF blocked, got blocked={blocked!r}")
            body = self._add_body(c, quat, m, moments, -1, grp, blk, velocity, angular_velocity, name, pivot)
        else:
            if pivot is not None:
                raise InputError("pivot belongs to the body: give it when the body is made, not to an attached mesh")
            body = check_int("body", body)
            if body >= self._n_bodies:
                raise InputError(f"body {body} does not exist (have {self._n_bodies})")
        rot = massprops.quat_to_matrix(self.body_array("quat")[body])
        local = massprops.rows_times(vertices - self.body_array("pos")[body], rot)
        self.meshes.append(_Mesh(name, body, mat, local, faces))
        return body

    def add_mesh_file(self, name: str, path: str, material: str | int, *, scale: float = 1.0, **kwargs: object) -> int:
        """Load an STL (or any format trimesh reads) and add it with :meth:`add_mesh`; ``scale`` converts to m."""
        import trimesh

        mesh = trimesh.load(path, force="mesh")
        if len(mesh.faces) == 0:
            raise InputError(f"mesh file {path!r} has no faces")
        return self.add_mesh(name, np.asarray(mesh.vertices) * scale, np.asarray(mesh.faces), material, **kwargs)

    def add_spring(
        self,
        name: str,
        body_a: int,
        point_a: object,
        body_b: int,
        point_b: object,
        *,
        stiffness: float,
        damping: float = 0.0,
        rest_length: float | None = None,
        preload: float = 0.0,
        progressive: float = 0.0,
        stop_stiffness: float = 0.0,
    ) -> int:
        """Spring-dashpot between a point of body a and a point of body b (points in the world [m], now).

        Force along the line a->b, tension positive: F = preload + stiffness*u + progressive*u^3 + damping*dL/dt
        with u = L - rest_length; stiffness [N/m], progressive [N/m^3] (0: linear; > 0 stiffens with the
        deflection either way, a Duffing spring), damping [N s/m], rest_length [m] (default: the current
        distance), preload [N].

        ``stop_stiffness`` [N/m]: a stop at the rest length, which the spring meets when its preload drives it
        there (preload > 0, in tension: the spring cannot get shorter than rest_length; preload < 0: longer).
        Past the stop, F gains stop_stiffness * u: a preloaded stack that rests on its stop until the load
        exceeds the preload. Without a preload the stop has no side and does nothing.
        """
        for label, b in (("body_a", body_a), ("body_b", body_b)):
            if check_int(label, b) >= self._n_bodies:
                raise InputError(f"{label} {b} does not exist (have {self._n_bodies})")
        if body_a == body_b:
            raise InputError(f"a spring needs two different bodies, got body_a = body_b = {body_a}")
        pa, pb = check_vec3("point_a", point_a), check_vec3("point_b", point_b)
        check_nonnegative("stiffness", stiffness)
        check_nonnegative("damping", damping)
        check_nonnegative("progressive", progressive)
        check_nonnegative("stop_stiffness", stop_stiffness)
        length = float(massprops.norm(pb - pa)) if rest_length is None else float(rest_length)
        check_nonnegative("rest_length", length)
        if any(s.name == name for s in self.springs):
            raise InputError(f"spring name {name!r} is already used")
        pos, quat = self.body_array("pos"), self.body_array("quat")
        la = massprops.rows_times(pa - pos[body_a], massprops.quat_to_matrix(quat[body_a]))
        lb = massprops.rows_times(pb - pos[body_b], massprops.quat_to_matrix(quat[body_b]))
        self.springs.append(_Spring(name, body_a, la, body_b, lb, stiffness, damping, length, float(preload),
                                    float(progressive), float(stop_stiffness)))
        return len(self.springs) - 1

    # ---------------------------------------------------------------- finalize
    def finalize(
        self, device: str | None = None, n_worlds: int = 1, overrides: dict[str, object] | None = None
    ) -> tuple[Model, State]:
        """Build the device Model and initial State, replicating the scene into ``n_worlds`` worlds.

        Args:
            device: Warp device ("cpu", "cuda", "cuda:0", None for Warp's default).
            n_worlds: number of independent copies of the scene.
            overrides: per-world parameters, name -> values of length n_worlds:
                ``material:<name>:<field>`` (fields: young, poisson, density, friction_angle [deg],
                normal_cohesion, shear_cohesion, eta_roll, eta_twist, alpha_kr, alpha_ktw),
                ``pair:<a>:<b>:friction_angle`` [deg] (a material pair's own, :meth:`set_pair_friction`),
                ``pair:<a>:<b>:adhesion`` [Pa] (:meth:`set_pair_adhesion`; negative: none in that world),
                ``spring:<name>:<stiffness|damping|rest_length|preload|progressive|stop_stiffness>``,
                ``spring:<name>:point_a`` / ``point_b`` (shape (n_worlds, 3) [m]: the attachment point in the world
                as built, like :meth:`add_spring`'s; e.g. an anchor that sits elsewhere in each world),
                ``damping:<group>``,
                ``body:<name>:velocity`` and ``body:<name>:angular_velocity`` (shape (n_worlds, 3); for a hinged
                body, the pivot's velocity), ``body:<name>:mass`` [kg] (mass and inertia tensor scaled together,
                i.e. added mass distributed like the body's own) and ``body:<name>:pivot_friction`` [N m] (a
                hinged body's dry friction torque at its pivot: Coulomb, opposing the rotation, sticking when the
                other torques cannot overcome it).
        """
        try:
            dev = wp.get_device(device)
        except Exception as exc:  # noqa: BLE001 - Warp raises several types here
            raise InputError(f"device {device!r} is not available: {exc}") from None
        n_worlds = check_int("n_worlds", n_worlds, low=1)
        if self._n_bodies == 0:
            raise InputError("the scene has no bodies")
        tables = _world_tables(self, n_worlds, overrides or {})
        return _assemble(self, dev, n_worlds, tables)


def _per_world(name: str, values: object, n_worlds: int, shape: tuple[int, ...] = ()) -> np.ndarray:
    arr = np.asarray(values, dtype=np.float64)
    if arr.shape != (n_worlds, *shape):
        raise InputError(f"override {name!r} must have shape {(n_worlds, *shape)}, got {arr.shape}")
    check_finite(f"override {name!r}", arr)
    return arr


def _world_tables(b: ModelBuilder, n_worlds: int, overrides: dict[str, object]) -> dict[str, np.ndarray]:
    """Per-world tables: materials (W, M) per field, damping (W, G), springs (W, S) per field, body velocities."""
    nb = b._n_bodies
    t: dict[str, np.ndarray] = {}
    for f in MATERIAL_FIELDS:
        # a field that is not the material's law's is 0 in the tables (its law does not read it)
        t[f] = np.tile(np.array([getattr(m, f) if f in m.FIELDS else 0.0 for m in b.materials], dtype=np.float64),
                       (n_worlds, 1))
    nm = len(b.materials)
    t["pair_friction"] = np.full((n_worlds, nm, nm), np.nan)
    for (i, j), angle in b.pair_friction.items():
        t["pair_friction"][:, i, j] = t["pair_friction"][:, j, i] = angle
    t["pair_adhesion"] = np.full((n_worlds, nm, nm), -1.0)
    for (i, j), adhesion in b.pair_adhesion.items():
        t["pair_adhesion"][:, i, j] = t["pair_adhesion"][:, j, i] = adhesion
    t["damping"] = np.tile(np.array(b.group_damping, dtype=np.float64), (n_worlds, 1))
    for f in SPRING_FIELDS:
        t["spring_" + f] = np.tile(np.array([getattr(s, f) for s in b.springs], dtype=np.float64), (n_worlds, 1))
    for end in ("a", "b"):
        t["spring_point_" + end] = np.tile(np.array([getattr(s, "point_" + end) for s in b.springs]).reshape(-1, 3),
                                           (n_worlds, 1, 1))
    t["vel"] = np.tile(b.body_array("vel").reshape(nb, 3), (n_worlds, 1, 1))
    t["angvel"] = np.tile(b.body_array("angvel").reshape(nb, 3), (n_worlds, 1, 1))
    t["mass"] = np.tile(b.body_array("mass"), (n_worlds, 1))
    t["pivot_friction"] = np.zeros((n_worlds, nb))
    spring_names = {s.name: i for i, s in enumerate(b.springs)}
    for key, values in overrides.items():
        _apply_override(b, t, key, values, n_worlds, spring_names)
    return t


def _apply_override(b: ModelBuilder, t: dict[str, np.ndarray], key: str, values: object, n_worlds: int,
                    spring_names: dict[str, int]) -> None:
    """One override ``key`` (``material:<name>:<field>``, ``pair:<a>:<b>:friction_angle|adhesion``, ...) with its
    per-world ``values`` written into the per-world tables ``t`` (``_world_tables``), checked like a user-built
    model."""
    parts = key.split(":")
    if parts[0] == "material" and len(parts) == 3:
        if parts[1] not in b.material_names:
            raise InputError(f"override {key!r}: unknown material {parts[1]!r}")
        check_choice(f"override {key!r} field", parts[2], b.materials[b.material_names[parts[1]]].FIELDS)
        col = _per_world(key, values, n_worlds)
        for v in col:  # validate each world's material like a user-built one
            b.materials[b.material_names[parts[1]]].replace(**{parts[2]: float(v)})
        t[parts[2]][:, b.material_names[parts[1]]] = col
    elif parts[0] == "pair" and len(parts) == 4 and parts[3] == "friction_angle":
        i, j = b._material(parts[1]), b._material(parts[2])
        col = _per_world(key, values, n_worlds)
        for v in col:
            degrees_to_radians(f"override {key!r}", float(v))
        t["pair_friction"][:, i, j] = t["pair_friction"][:, j, i] = col
    elif parts[0] == "pair" and len(parts) == 4 and parts[3] == "adhesion":
        i, j = b._material(parts[1]), b._material(parts[2])
        if laws.law_of(b.materials) != laws.COHFRICT:
            raise InputError(f"override {key!r}: adhesion needs cohesive-frictional materials")
        col = _per_world(key, values, n_worlds)
        t["pair_adhesion"][:, i, j] = t["pair_adhesion"][:, j, i] = np.where(col < 0.0, -1.0, col)
    elif parts[0] == "spring" and len(parts) == 3 and parts[2] in ("point_a", "point_b"):
        if parts[1] not in spring_names:
            raise InputError(f"override {key!r}: unknown spring {parts[1]!r}")
        spring = b.springs[spring_names[parts[1]]]
        body = spring.body_a if parts[2] == "point_a" else spring.body_b
        points = _per_world(key, values, n_worlds, (3,))
        rot = massprops.quat_to_matrix(b.body_array("quat")[body])
        local = massprops.rows_times(points - b.body_array("pos")[body], rot)
        t["spring_" + parts[2]][:, spring_names[parts[1]]] = local
    elif parts[0] == "spring" and len(parts) == 3:
        if parts[1] not in spring_names:
            raise InputError(f"override {key!r}: unknown spring {parts[1]!r}")
        check_choice(f"override {key!r} field", parts[2], SPRING_FIELDS)
        col = _per_world(key, values, n_worlds)
        if parts[2] != "preload":
            check_nonnegative(f"override {key!r}", col)
        t["spring_" + parts[2]][:, spring_names[parts[1]]] = col
    elif parts[0] == "damping" and len(parts) == 2:
        if parts[1] not in b.groups:
            raise InputError(f"override {key!r}: unknown group {parts[1]!r}")
        col = _per_world(key, values, n_worlds)
        if np.any((col < 0) | (col >= 1)):
            raise InputError(f"override {key!r}: local damping must be in [0, 1), got {col.tolist()}")
        t["damping"][:, b.groups[parts[1]]] = col
    elif parts[0] == "body" and len(parts) == 3 and parts[2] in ("velocity", "angular_velocity"):
        if parts[1] not in b.body_names:
            raise InputError(f"override {key!r}: unknown body {parts[1]!r}")
        t["vel" if parts[2] == "velocity" else "angvel"][:, b.body_names[parts[1]]] = _per_world(
            key, values, n_worlds, (3,)
        )
    elif parts[0] == "body" and len(parts) == 3 and parts[2] in ("mass", "pivot_friction"):
        if parts[1] not in b.body_names:
            raise InputError(f"override {key!r}: unknown body {parts[1]!r}")
        idx = b.body_names[parts[1]]
        col = _per_world(key, values, n_worlds)
        if parts[2] == "mass":
            if not b.body_array("mass")[idx] > 0:
                raise InputError(f"override {key!r}: body {parts[1]!r} has no mass to scale")
            if np.any(col <= 0):
                raise InputError(f"override {key!r}: mass must be positive, got {col.tolist()}")
        else:
            check_nonnegative(f"override {key!r}", col)
            if np.isnan(b.body_array("pivot")[idx, 0]):
                raise InputError(f"override {key!r}: body {parts[1]!r} is not hinged (it has no pivot)")
        t[parts[2]][:, idx] = col
    else:
        raise InputError(
            f"unknown override {key!r}; expected material:<name>:<field>, pair:<a>:<b>:friction_angle|adhesion, "
            "spring:<name>:<field>, "
            "spring:<name>:point_a|point_b, damping:<group> or "
            "body:<name>:velocity|angular_velocity|mass|pivot_friction"
        )


def _sphere_rows(b: ModelBuilder) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One world's spheres, in the order they were added: body (ns,), offset in the body frame [m] (ns, 3), radius
    [m] (ns,) and material (ns,)."""
    return (
        np.concatenate(b.sphere_body) if b.sphere_body else np.zeros(0, np.int32),
        np.concatenate(b.sphere_offset) if b.sphere_offset else np.zeros((0, 3)),
        np.concatenate(b.sphere_radius) if b.sphere_radius else np.zeros(0),
        np.concatenate(b.sphere_material) if b.sphere_material else np.zeros(0, np.int32),
    )


def _body_mass(b: ModelBuilder, W: int, t: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Every world's body masses [kg] (W * nb,) and principal moments of inertia [kg m^2] (W * nb, 3): the built
    ones scaled by the world's density of the body's material over the built density, and by a body:<name>:mass
    override's ratio to the built mass (mass and inertia together)."""
    nb = b._n_bodies
    mass0 = b.body_array("mass")
    inertia0 = b.body_array("inertia").reshape(nb, 3)
    dmat = b.body_array("density_material").astype(np.int64)
    base_rho = np.array([m.density for m in b.materials])
    scale = np.ones((W, nb))
    has = dmat >= 0
    if len(b.materials):
        scale[:, has] = t["density"][:, dmat[has]] / base_rho[dmat[has]]
    scale = scale * np.where(mass0 > 0, t["mass"] / np.where(mass0 > 0, mass0, 1.0), 1.0)
    return (scale * mass0).reshape(-1), (scale[:, :, None] * inertia0).reshape(-1, 3)


def _body_flags(b: ModelBuilder) -> np.ndarray:
    """One world's body flags (nb,) int32: the blocked DoFs, FLAG_ASPHERICAL, FLAG_PIVOT; InputError for a body
    without mass that has a free DoF."""
    nb = b._n_bodies
    mass0 = b.body_array("mass")
    inertia0 = b.body_array("inertia").reshape(nb, 3)
    flags = b.body_array("blocked").astype(np.int32)
    iso = np.ptp(inertia0, axis=1) <= 1e-12 * inertia0.max(axis=1)
    flags = flags | np.where(iso, 0, FLAG_ASPHERICAL).astype(np.int32)
    hinged = ~np.isnan(b.body_array("pivot").reshape(nb, 3)[:, 0])
    flags = flags | np.where(hinged, FLAG_PIVOT, 0).astype(np.int32)
    blocked_all = (flags & ALL_DOFS) == ALL_DOFS
    if np.any((mass0 <= 0) & ~blocked_all):
        raise InputError(f"body {int(np.argmax((mass0 <= 0) & ~blocked_all))} has no mass but free DoFs")
    return flags


def _body_motion(b: ModelBuilder, W: int, t: dict[str, np.ndarray], flags: np.ndarray, inertia: np.ndarray
                 ) -> dict[str, np.ndarray]:
    """Every world's initial body state and pivots (W * nb rows): pos [m], quat (x, y, z, w), vel [m/s] (of the
    centre of mass), angvel [rad/s], angmom [kg m^2/s] (world frame, 0 for a fully blocked body), pivot_vel [m/s]
    (the pivot's velocity of a hinged body, else 0) and pivot_local [m] (one world's (nb, 3): the pivot in the body
    frame, 0 for a body that is not hinged)."""
    nb = b._n_bodies
    pos0 = b.body_array("pos").reshape(nb, 3)
    pivot_world = b.body_array("pivot").reshape(nb, 3)
    hinged = ~np.isnan(pivot_world[:, 0])
    blocked_all = (flags & ALL_DOFS) == ALL_DOFS
    quat = np.tile(b.body_array("quat").reshape(nb, 4), (W, 1))
    vel = t["vel"].reshape(-1, 3).copy()
    angvel = t["angvel"].reshape(-1, 3)
    # a hinged body: `velocity` is its pivot's; the centre of mass moves at v_pivot + omega x (com - pivot)
    body_rot0 = massprops.quats_to_matrices(b.body_array("quat").reshape(nb, 4))
    pivot_local = np.where(hinged[:, None], np.einsum("nji,nj->ni", body_rot0, np.nan_to_num(pivot_world) - pos0),
                           0.0)
    hinged_all = np.tile(hinged, W)
    pivot_vel = np.where(hinged_all[:, None], vel, 0.0)
    arm = np.tile(np.nan_to_num(pivot_world) - pos0, (W, 1))
    vel[hinged_all] = pivot_vel[hinged_all] - np.cross(angvel[hinged_all], arm[hinged_all])
    # L = R diag(I) R^T omega, for every body at once
    rot = massprops.quats_to_matrices(quat)
    local = np.einsum("nji,nj->ni", rot, angvel) * inertia
    angmom = np.einsum("nij,nj->ni", rot, local) * np.tile(~blocked_all, W)[:, None]
    return {"pos": np.tile(pos0, (W, 1)), "quat": quat, "vel": vel, "angvel": angvel, "angmom": angmom,
            "pivot_vel": pivot_vel, "pivot_local": pivot_local}


def _mesh_geometry(b: ModelBuilder, dev: wp.context.Device) -> tuple[list[wp.Mesh], list[int], list[int], np.ndarray]:
    """One warp.Mesh per mesh of the builder (shared by the world replicas): the meshes, their ids, each mesh's
    first row in the triangle table, and the table: the triangles' vertices in the body frame [m] (3 * n_tri, 3)."""
    warp_meshes, geom_ids, tri_offsets, tris = [], [], [], []
    n_tri = 0
    for m in b.meshes:
        wm = wp.Mesh(
            points=wp.array(m.vertices_local.astype(np.float32), dtype=wp.vec3f, device=dev),
            indices=wp.array(m.faces.reshape(-1), dtype=wp.int32, device=dev),
        )
        warp_meshes.append(wm)
        geom_ids.append(wm.id)
        tri_offsets.append(n_tri)
        tris.append(m.vertices_local[m.faces].reshape(-1, 3))
        n_tri += len(m.faces)
    return warp_meshes, geom_ids, tri_offsets, np.concatenate(tris) if tris else np.zeros((3, 3))


_MAT_ARRAYS = {"young": "young", "poisson": "poisson", "friction": "friction_angle",
               "normal_cohesion": "normal_cohesion", "shear_cohesion": "shear_cohesion", "eta_roll": "eta_roll",
               "eta_twist": "eta_twist", "alpha_kr": "alpha_kr", "alpha_ktw": "alpha_ktw"}
"""Model's ``mat_<name>`` array -> the material field it holds (float32; the friction angle in radians)."""


def _material_and_spring_arrays(b: ModelBuilder, W: int, t: dict[str, np.ndarray], arr: object
                                ) -> dict[str, wp.array]:
    """The Model's per-world material (``mat_*``, (W * n_materials,)), damping (``group_damping``, (W * n_groups,))
    and spring (``spring_*``, (W * n_springs,)) arrays, float32 but the flags and the spring ends."""
    out = {}
    for name, f in _MAT_ARRAYS.items():
        col = t[f].reshape(-1)
        out["mat_" + name] = arr((np.radians(col) if f == "friction_angle" else col).astype(np.float32), wp.float32)
    out["mat_flags"] = arr(np.tile(np.array([m.flags for m in b.materials], dtype=np.int32), W), wp.int32)
    pair = t["pair_friction"].reshape(-1)
    out["mat_pair_tan"] = arr(np.where(np.isnan(pair), -1.0, np.tan(np.radians(pair))).astype(np.float32), wp.float32)
    out["mat_pair_adhesion"] = arr(t["pair_adhesion"].reshape(-1).astype(np.float32), wp.float32)
    out["group_damping"] = arr(t["damping"].reshape(-1).astype(np.float32), wp.float32)
    nb, nk = b._n_bodies, len(b.springs)
    off = np.repeat(np.arange(W) * nb, nk)
    for end in ("a", "b"):
        body = np.array([getattr(s, "body_" + end) for s in b.springs], dtype=np.int64)
        out["spring_body_" + end] = arr((np.tile(body, W) + off).astype(np.int32), wp.int32)
        out["spring_point_" + end] = arr(t["spring_point_" + end].reshape(-1, 3), wp.vec3f)
    for f in SPRING_FIELDS:
        out["spring_" + f] = arr(t["spring_" + f].reshape(-1).astype(np.float32), wp.float32)
    return out


def _assemble(b: ModelBuilder, dev: wp.context.Device, W: int, t: dict[str, np.ndarray]) -> tuple[Model, State]:
    """The Model and State of W worlds of the builder's scene, with the per-world tables t (_world_tables)."""
    nb = b._n_bodies
    sph_body, sph_off, sph_rad, sph_mat = _sphere_rows(b)
    ns = len(sph_rad)
    mass, inertia = _body_mass(b, W, t)
    flags = _body_flags(b)
    motion = _body_motion(b, W, t, flags, inertia)
    world_of_body = np.repeat(np.arange(W, dtype=np.int32), nb)

    def arr(a: np.ndarray, dtype: object) -> wp.array:
        return wp.array(np.ascontiguousarray(a), dtype=dtype, device=dev)

    sphere_body = (np.tile(sph_body, W) + np.repeat(np.arange(W) * nb, ns)).astype(np.int32)
    sphere_world = np.repeat(np.arange(W, dtype=np.int32), ns)
    warp_meshes, geom_ids, tri_offsets, tri_vertices = _mesh_geometry(b, dev)
    nmesh = len(b.meshes)
    mesh_body = np.array([m.body for m in b.meshes], dtype=np.int64)
    mesh_body_all = (np.tile(mesh_body, W) + np.repeat(np.arange(W) * nb, nmesh)).astype(np.int32)
    model = Model(
        device=dev,
        n_worlds=W,
        bodies_per_world=nb,
        spheres_per_world=ns,
        meshes_per_world=nmesh,
        springs_per_world=len(b.springs),
        n_materials=len(b.materials),
        n_groups=len(b.groups),
        gravity=b.gravity,
        body_world=arr(world_of_body, wp.int32),
        body_group=arr(np.tile(b.body_array("group").astype(np.int32), W), wp.int32),
        body_flags=arr(np.tile(flags, W), wp.int32),
        body_mass=arr(mass, wp.float64),
        body_inertia=arr(inertia, wp.vec3d),
        body_pivot=arr(np.tile(motion["pivot_local"], (W, 1)), wp.vec3d),
        body_pivot_vel=arr(motion["pivot_vel"], wp.vec3d),
        body_pivot_friction=arr(t["pivot_friction"].reshape(-1), wp.float64),
        sphere_body=arr(sphere_body, wp.int32),
        sphere_world=arr(sphere_world, wp.int32),
        sphere_material=arr(np.tile(sph_mat, W), wp.int32),
        sphere_radius=arr(np.tile(sph_rad, W), wp.float64),
        sphere_offset=arr(np.tile(sph_off, (W, 1)).astype(np.float32), wp.vec3f),
        mesh_body=arr(mesh_body_all, wp.int32),
        mesh_world=arr(np.repeat(np.arange(W, dtype=np.int32), nmesh), wp.int32),
        mesh_material=arr(np.tile(np.array([m.material for m in b.meshes], dtype=np.int32), W), wp.int32),
        mesh_ids=arr(np.tile(np.array(geom_ids, dtype=np.uint64), W), wp.uint64),
        mesh_tri_offset=arr(np.tile(np.array(tri_offsets, dtype=np.int32), W), wp.int32),
        tri_vertices=arr(tri_vertices, wp.vec3d),
        world_mesh_start=arr(np.arange(W, dtype=np.int32) * nmesh, wp.int32),
        **_material_and_spring_arrays(b, W, t, arr),
        names={
            "body": dict(b.body_names),
            "material": dict(b.material_names),
            "group": dict(b.groups),
            "mesh": {m.name: i for i, m in enumerate(b.meshes)},
            "spring": {s.name: i for i, s in enumerate(b.springs)},
        },
        warp_meshes=warp_meshes,
        max_radius=float(sph_rad.max()) if ns else 0.0,
        contact_law=laws.law_of(b.materials),
    )
    model.host = {
        "sphere_radius": np.tile(sph_rad, W),
        "sphere_body": sphere_body,
        "sphere_world": sphere_world,
        "body_mass": mass,
        "body_inertia": inertia,
        "body_group": np.tile(b.body_array("group").astype(np.int32), W),
        "body_flags": np.tile(flags, W),
        "body_pivot": np.tile(motion["pivot_local"], (W, 1)),
        "body_world": world_of_body,
        "mesh_body": mesh_body_all,
        "mesh_vertices_local": [m.vertices_local for m in b.meshes],
        "mesh_faces": [m.faces for m in b.meshes],
        "material_young": t["young"].reshape(-1),
        "material_density": t["density"].reshape(-1),
        "sphere_material": np.tile(sph_mat, W),
        "spring_stiffness": t["spring_stiffness"].reshape(-1),
    }
    state = State(
        body_pos=arr(motion["pos"], wp.vec3d),
        body_quat=arr(motion["quat"], wp.quatd),
        body_vel=arr(motion["vel"], wp.vec3d),
        body_angvel=arr(motion["angvel"], wp.vec3d),
        body_angmom=arr(motion["angmom"], wp.vec3d),
    )
    return model, state


def fit_poses(model: Model, spheres: object, centres: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The poses that put spheres at given centres: for each body owning one of ``spheres`` (global sphere indices
    (m,); every sphere of such a body must be among them), the centre of mass [m] and orientation that move its
    spheres' offsets (the model's, float32) onto ``centres`` [m] (m, 3) with the least squared error (Kabsch's
    rotation, a proper one). A single sphere's body keeps the identity orientation; a body whose spheres are in a
    row may turn about that row freely (one such pose is returned).

    Returns the bodies (b,), their centres of mass [m] (b, 3) and quaternions (x, y, z, w) (b, 4)."""
    spheres = np.asarray(spheres, dtype=np.int64).reshape(-1)
    centres = check_points("centres", centres)
    if len(centres) != len(spheres):
        raise InputError(f"centres must have one row per sphere ({len(spheres)}), got {len(centres)}")
    owner = model.host["sphere_body"][spheres]
    bodies, inverse, count = np.unique(owner, return_inverse=True, return_counts=True)
    full = np.bincount(model.host["sphere_body"], minlength=model.n_bodies)[bodies]
    if np.any(count != full):
        b = int(bodies[np.flatnonzero(count != full)[0]])
        raise InputError(f"spheres must hold every sphere of their bodies: body {b} has {int(full[bodies == b][0])}, "
                         f"{int(count[bodies == b][0])} given")
    offsets = model.sphere_offset.numpy()[spheres].astype(np.float64)
    o_mean = np.zeros((len(bodies), 3))
    c_mean = np.zeros((len(bodies), 3))
    np.add.at(o_mean, inverse, offsets)
    np.add.at(c_mean, inverse, centres)
    o_mean /= count[:, None]
    c_mean /= count[:, None]
    h = np.zeros((len(bodies), 3, 3))
    np.add.at(h, inverse, np.einsum("ni,nj->nij", offsets - o_mean[inverse], centres - c_mean[inverse]))
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.einsum("nji,nkj->nik", vt, u)))  # det(V U^T)
    d[d == 0] = 1.0
    rot = np.einsum("nji,nj,nkj->nik", vt, np.stack([np.ones_like(d), np.ones_like(d), d], 1), u)
    rot[count == 1] = np.eye(3)
    quat = massprops.matrices_to_quats(rot)
    return bodies, c_mean - np.einsum("nij,nj->ni", rot, o_mean), quat


def set_poses(state: State, bodies: object, pos: object, quat: object) -> None:
    """Put ``bodies`` (global indices (b,)) at rest at centres of mass ``pos`` [m] (b, 3) with orientations ``quat``
    (x, y, z, w) (b, 4): before a Simulation is made of the state."""
    bodies = np.asarray(bodies, dtype=np.int64).reshape(-1)
    host = state.numpy()
    host["body_pos"][bodies] = np.asarray(pos, dtype=np.float64).reshape(-1, 3)
    q = np.asarray(quat, dtype=np.float64).reshape(-1, 4)
    host["body_quat"][bodies] = q / np.linalg.norm(q, axis=1, keepdims=True)
    for k in ("body_vel", "body_angvel", "body_angmom"):
        host[k][bodies] = 0.0
    for k in State.ARRAYS:
        getattr(state, k).assign(host[k])


def hold_bodies(model: Model, state: State, bodies: object, group: str) -> None:
    """Hold ``bodies`` (global indices (b,)) still where they are: every degree of freedom blocked, at rest, moved
    into the body group ``group`` (which the builder must have, e.g. from ``set_local_damping(group, 0.0)``) so
    that a group's observers leave them out. For bodies parked out of reach of everything, e.g. the particles that
    one world's bed lacks when replica beds share one layout. Before a Simulation is made of the model."""
    bodies = np.asarray(bodies, dtype=np.int64).reshape(-1)
    if group not in model.names["group"]:
        raise InputError(f"group must be one of the model's body groups {sorted(model.names['group'])}, got {group!r}")
    g = model.group_index(group)
    flags = model.host["body_flags"]
    flags[bodies] |= ALL_DOFS
    model.host["body_group"][bodies] = g
    model.body_flags.assign(flags.astype(np.int32))
    model.body_group.assign(model.host["body_group"].astype(np.int32))
    host = state.numpy()
    for k in ("body_vel", "body_angvel", "body_angmom"):
        host[k][bodies] = 0.0
        getattr(state, k).assign(host[k])
