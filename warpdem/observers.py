"""Observers: quantities read off a running simulation, each a plain function ``f(sim) -> array``.

Use them directly or pass them to :meth:`Simulation.run` (``observers={"ke": kinetic_energy}``) to record a time
series. Per-world results have a leading axis of length n_worlds.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import warp as wp

from . import kernel_args
from .contacts import (
    E_DAMPING,
    E_DRIVEN,
    E_ROLLING,
    E_SLIDING,
    E_SPRING_DAMPER,
    sphere_sphere_elastic_kernel,
    sphere_sphere_stiffness_kernel,
    sphere_triangle_elastic_kernel,
    sphere_triangle_stiffness_kernel,
)
from .laws import ACTIVE, COHESIVE, Hist
from .mass import quats_to_matrices
from .model import ALL_DOFS

wp.set_module_options({"enable_backward": False})

#: names of the accumulated dissipation terms, in the order of Simulation.data.energy's slots
ENERGY_TERMS = {"damping": E_DAMPING, "sliding": E_SLIDING, "rolling": E_ROLLING, "spring_damper": E_SPRING_DAMPER}


KE_CHUNK = wp.constant(256)
"""bodies per partial sum of the kinetic energy: each thread adds its chunk's bodies in order and numpy adds the
chunks, so the sum does not depend on the threads' schedule (the same bits on every run)."""


@wp.kernel
def _kinetic_energy_kernel(
    body_group: wp.array(dtype=int),
    body_mass: wp.array(dtype=wp.float64),
    body_inertia: wp.array(dtype=wp.vec3d),
    body_quat: wp.array(dtype=wp.quatd),
    body_vel: wp.array(dtype=wp.vec3d),
    body_angvel: wp.array(dtype=wp.vec3d),
    bodies_per_world: int,
    n_chunks: int,
    n_groups: int,
    out: wp.array(dtype=wp.float64),
):
    """out[((world * n_chunks + chunk) * n_groups + group) * 2 + {0: translational, 1: rotational}]: energy [J]
    (paper eq. 6) of the chunk's bodies of that group, added in body order."""
    t = wp.tid()
    g = t % n_groups
    chunk = (t // n_groups) % n_chunks
    first = (t // (n_groups * n_chunks)) * bodies_per_world
    tr = wp.float64(0.0)
    rot = wp.float64(0.0)
    for k in range(chunk * KE_CHUNK, wp.min((chunk + 1) * KE_CHUNK, bodies_per_world)):
        b = first + k
        m = body_mass[b]
        if m <= wp.float64(0.0) or body_group[b] != g:
            continue
        v = body_vel[b]
        tr += wp.float64(0.5) * m * wp.dot(v, v)
        w_b = wp.quat_rotate_inv(body_quat[b], body_angvel[b])
        inertia = body_inertia[b]
        rot += wp.float64(0.5) * (inertia[0] * w_b[0] * w_b[0] + inertia[1] * w_b[1] * w_b[1]
                                  + inertia[2] * w_b[2] * w_b[2])
    out[2 * t] = tr
    out[2 * t + 1] = rot


def kinetic_energy_table(sim: object) -> np.ndarray:
    """Kinetic energy [J] per world, group and kind, shape (n_worlds, n_groups, 2): [..., 0] translational
    (m v^2 / 2), [..., 1] rotational (omega^T I omega / 2), for bodies with mass (the paper's eq. 6)."""
    m, s = sim.model, sim.state
    n_chunks = max(1, -(-m.bodies_per_world // KE_CHUNK))
    n = m.n_worlds * n_chunks * m.n_groups
    out = wp.zeros(2 * n, dtype=wp.float64, device=m.device)
    if m.n_bodies:
        wp.launch(
            _kinetic_energy_kernel, n,
            inputs=[m.body_group, m.body_mass, m.body_inertia, s.body_quat, s.body_vel, s.body_angvel,
                    m.bodies_per_world, n_chunks, m.n_groups],
            outputs=[out], device=m.device,
        )
    return out.numpy().reshape(m.n_worlds, n_chunks, m.n_groups, 2).sum(axis=1)


def kinetic_energy(sim: object) -> np.ndarray:
    """Total kinetic energy per world [J], shape (n_worlds,)."""
    return kinetic_energy_table(sim).sum(axis=(1, 2))


def group_kinetic_energy(group: str) -> Callable[[object], np.ndarray]:
    """Observer: (translational, rotational) kinetic energy [J] of one body group per world, shape (n_worlds, 2)."""

    def f(sim: object) -> np.ndarray:
        return kinetic_energy_table(sim)[:, sim.model.group_index(group), :]

    return f


def gravity_potential(sim: object) -> np.ndarray:
    """Potential energy of gravity per world, -sum m g . x [J], shape (n_worlds,) (free bodies only)."""
    m = sim.model
    mass = m.host["body_mass"]
    free = (m.host["body_flags"] & ALL_DOFS) != ALL_DOFS
    pot = -(mass * free) * (sim.state.body_pos.numpy() @ np.asarray(m.gravity))
    return np.bincount(m.host["body_world"], weights=pot, minlength=m.n_worlds)


def spring_elastic_energy(sim: object) -> np.ndarray:
    """Elastic energy of the springs per world [J], shape (n_worlds,): P u + k u^2 / 2 + k3 u^4 / 4, u = L - L0,
    plus k_stop u^2 / 2 past a stop (P u < 0)."""
    m = sim.model
    if m.n_springs == 0:
        return np.zeros(m.n_worlds)
    f = sim.data.spring_force.numpy().astype(np.float64)
    k = m.spring_stiffness.numpy().astype(np.float64)
    k3 = m.spring_progressive.numpy().astype(np.float64)
    p = m.spring_preload.numpy().astype(np.float64)
    ks = m.spring_stop_stiffness.numpy().astype(np.float64)
    # u from the force of the last step (dashpot part neglected): f = P + k u + k3 u^3 (+ k_stop u past the stop),
    # monotonic in u: Newton (the piecewise-linear stop converges in one step once u is on its side)
    u = np.where(k > 0, (f - p) / np.where(k > 0, k, 1.0), 0.0)
    for _ in range(50):
        stop = np.where(p * u < 0, ks, 0.0)
        slope = k + stop + 3.0 * k3 * u**2
        u = np.where(slope > 0, u - (p + (k + stop) * u + k3 * u**3 - f) / np.where(slope > 0, slope, 1.0), u)
    e = p * u + 0.5 * (k + np.where(p * u < 0, ks, 0.0)) * u**2 + 0.25 * k3 * u**4
    return np.bincount(np.repeat(np.arange(m.n_worlds), m.springs_per_world), weights=e, minlength=m.n_worlds)


def contact_elastic_energy(sim: object) -> np.ndarray:
    """Elastic energy stored in all contacts per world [J], shape (n_worlds,)."""
    m, d, c = sim.model, sim.data, sim.contacts
    out = wp.zeros(m.n_worlds, dtype=wp.float64, device=m.device)
    if m.n_spheres:
        spheres, kin = kernel_args.spheres_of(m), kernel_args.sphere_state_of(d)
        wp.launch(sphere_sphere_elastic_kernel, m.n_spheres,
                  inputs=[spheres, sim.materials, kin, kernel_args.sphere_list_of(c.ss)], outputs=[out],
                  device=m.device)
    if m.n_spheres and m.n_meshes:
        wp.launch(sphere_triangle_elastic_kernel, m.n_spheres,
                  inputs=[spheres, kernel_args.meshes_of(m, d), sim.materials, kin,
                          kernel_args.body_state_of(sim.state), kernel_args.triangle_list_of(c.st)],
                  outputs=[out], device=m.device)
    return out.numpy()


def dissipated_energy(sim: object) -> dict[str, np.ndarray]:
    """Energy dissipated since the start per world [J], by term (needs ``track_energy=True``)."""
    e = sim.data.energy.numpy().reshape(sim.model.n_worlds, -1)
    return {name: e[:, slot].copy() for name, slot in ENERGY_TERMS.items()}


def driven_work(sim: object) -> np.ndarray:
    """Work done on the scene by its drivers since the start per world [J], shape (n_worlds,) (needs
    ``track_energy=True``): kinematic bodies (against contact and spring forces), imposed velocities of blocked
    degrees of freedom, and carried pivots of hinged bodies (the pivot reaction times the carriage velocity).
    A velocity changed from the host (``Simulation.set_body_velocity``) is outside it."""
    return sim.data.energy.numpy().reshape(sim.model.n_worlds, -1)[:, E_DRIVEN].copy()


def energy_balance(sim: object) -> dict[str, np.ndarray]:
    """All energy terms per world [J] and their sum ``total`` = kinetic + elastic + gravity + dissipated - work of
    the drivers (:func:`driven_work`), which stays constant; shape (n_worlds,) each."""
    terms = {
        "kinetic": kinetic_energy(sim),
        "contact_elastic": contact_elastic_energy(sim),
        "spring_elastic": spring_elastic_energy(sim),
        "gravity": gravity_potential(sim),
    }
    terms.update({"dissipated_" + k: v for k, v in dissipated_energy(sim).items()})
    terms["driven_work"] = driven_work(sim)
    terms["total"] = sum(v for k, v in terms.items() if k != "driven_work") - terms["driven_work"]
    return terms


def csr_entries(start: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Indices of every entry of a CSR list (row i holds start[i] .. start[i] + count[i] - 1), row by row."""
    start, count = np.asarray(start, np.int64), np.asarray(count, np.int64)
    first_of_row = np.cumsum(count) - count
    return np.repeat(start - first_of_row, count) + np.arange(int(count.sum()), dtype=np.int64)


def contact_table(sim: object) -> dict[str, np.ndarray]:
    """Active contacts on the host: body1/body2 (body indices), world, normal (k, 3), radius1/radius2 [m],
    kn/ks [N/m], kr/ktw [N m/rad] (the contact law's, ``laws.stiffness``: Hertz-Mindlin's tangent stiffnesses at the
    current overlap), kind (0 sphere-sphere, 1 sphere-triangle), sphere indices, shear force [N]; each (k,)."""
    m = sim.model
    ss = sim.contacts.ss.numpy()
    rad = m.host["sphere_radius"]
    rows = {k: [] for k in ("body1", "body2", "world", "normal", "radius1", "radius2", "kind", "sphere", "fs",
                            "material1", "material2", "k")}
    owner = np.repeat(np.arange(m.n_spheres), ss["count"])
    idx = csr_entries(ss["start"], ss["count"])
    h = ss["hist"][idx] if len(idx) else ss["hist"][:0]
    act = (h["flags"] & ACTIVE) != 0 if len(idx) else np.zeros(0, bool)
    i, j = owner[act], ss["key_a"][idx][act]
    rows["body1"].append(m.host["sphere_body"][i])
    rows["body2"].append(m.host["sphere_body"][j])
    rows["world"].append(m.host["sphere_world"][i])
    rows["normal"].append(np.asarray(h["normal"][act]).reshape(-1, 3))
    rows["radius1"].append(rad[i])
    rows["radius2"].append(rad[j])
    rows["kind"].append(np.zeros(len(i), int))
    rows["sphere"].append(i)
    rows["fs"].append(np.asarray(h["fs"][act]).reshape(-1, 3))
    rows["material1"].append(m.host["sphere_material"][i])
    rows["material2"].append(m.host["sphere_material"][j])
    rows["k"].append(_stiffness(sim, sphere_sphere_stiffness_kernel, sim.contacts.ss)[idx][act])
    if m.n_meshes:
        st = sim.contacts.st.numpy()
        owner = np.repeat(np.arange(m.n_spheres), st["count"])
        idx = csr_entries(st["start"], st["count"])
        h = st["hist"][idx]
        act = (h["flags"] & ACTIVE) != 0
        i, mesh = owner[act], st["key_a"][idx][act]
        rows["body1"].append(m.host["mesh_body"][mesh])
        rows["body2"].append(m.host["sphere_body"][i])
        rows["world"].append(m.host["sphere_world"][i])
        rows["normal"].append(np.asarray(h["normal"][act]).reshape(-1, 3))
        rows["radius1"].append(2 * rad[i])
        rows["radius2"].append(rad[i])
        rows["kind"].append(np.ones(len(i), int))
        rows["sphere"].append(i)
        rows["fs"].append(np.asarray(h["fs"][act]).reshape(-1, 3))
        mesh_mat = sim.model.mesh_material.numpy()
        rows["material1"].append(mesh_mat[mesh])
        rows["material2"].append(m.host["sphere_material"][i])
        rows["k"].append(_stiffness(sim, sphere_triangle_stiffness_kernel, sim.contacts.st)[idx][act])
    out = {k: np.concatenate(v) if v else np.zeros(0) for k, v in rows.items()}
    out["normal"] = out["normal"].reshape(-1, 3)
    # the stiffnesses of the contact law (laws.stiffness, on the device, from the float32 tables as the kernels)
    k = out.pop("k").astype(np.float64).reshape(-1, 4)
    for col, name in enumerate(("kn", "ks", "kr", "ktw")):
        out[name] = k[:, col]
    return out


def _stiffness(sim: object, kernel: object, pairs: object) -> np.ndarray:
    """(kn, ks, kr, ktw) of each entry of a candidate list (``kernel``: contacts.sphere_sphere_stiffness_kernel or
    sphere_triangle_stiffness_kernel), float32 (capacity, 4); zeros where an entry is not a contact."""
    m, d = sim.model, sim.data
    out = wp.zeros(max(pairs.key_a.shape[0], 1), dtype=wp.vec4f, device=m.device)
    if m.n_spheres:
        spheres, kin = kernel_args.spheres_of(m), kernel_args.sphere_state_of(d)
        if kernel is sphere_sphere_stiffness_kernel:
            inputs = [spheres, sim.materials, kin, kernel_args.sphere_list_of(pairs)]
        else:
            inputs = [spheres, kernel_args.meshes_of(m, d), sim.materials, kin, kernel_args.body_state_of(sim.state),
                      kernel_args.triangle_list_of(pairs)]
        wp.launch(kernel, m.n_spheres, inputs=inputs, outputs=[out], device=m.device)
    return out.numpy()


@wp.kernel
def _active_contacts_kernel(
    sphere_body: wp.array(dtype=int),
    sphere_world: wp.array(dtype=int),
    body_group: wp.array(dtype=int),
    group: int,
    start: wp.array(dtype=int),
    count: wp.array(dtype=int),
    key_a: wp.array(dtype=int),
    hist: wp.array(dtype=Hist),
    flag: int,
    out: wp.array(dtype=int),
):
    """out[world] += the entries of sphere i's candidate list whose history has ``flag`` (ACTIVE: contacts,
    COHESIVE: unbroken bonds); group >= 0 (sphere-sphere lists only): only those between two different bodies of
    that group."""
    i = wp.tid()
    bi = sphere_body[i]
    if group >= 0 and body_group[bi] != group:
        return
    n = int(0)
    for k in range(start[i], start[i] + count[i]):
        if (hist[k].flags & flag) != 0:
            if group < 0:
                n += 1
            else:
                bj = sphere_body[key_a[k]]
                if bj != bi and body_group[bj] == group:
                    n += 1
    if n > 0:
        wp.atomic_add(out, sphere_world[i], n)


def _count_active(sim: object, pairs: object, group: int, flag: int = ACTIVE) -> np.ndarray:
    """Active contacts (or, with ``flag`` COHESIVE, unbroken bonds) of one candidate list per world, counted on the
    device, shape (n_worlds,)."""
    m = sim.model
    out = wp.zeros(m.n_worlds, dtype=int, device=m.device)
    if m.n_spheres:
        wp.launch(_active_contacts_kernel, m.n_spheres,
                  inputs=[m.sphere_body, m.sphere_world, m.body_group, int(group), pairs.start, pairs.count,
                          pairs.key_a, pairs.hist, int(flag)], outputs=[out], device=m.device)
    return out.numpy().astype(np.int64)


def contact_count(sim: object) -> np.ndarray:
    """Number of active contacts per world, shape (n_worlds, 2): [sphere-sphere, sphere-triangle]."""
    ss = _count_active(sim, sim.contacts.ss, -1)
    st = _count_active(sim, sim.contacts.st, -1) if sim.model.n_meshes else np.zeros_like(ss)
    return np.stack([ss, st], axis=1)


def coordination_number(group: str | None = None) -> Callable[[object], np.ndarray]:
    """Observer: mean coordination number per world, shape (n_worlds,): 2 x (sphere-sphere contacts between
    different bodies of the group) / (number of bodies of the group). A clump counts as one particle; each
    member-member contact counts (as Yade counts interactions). Counted on the device (one small copy)."""

    def f(sim: object) -> np.ndarray:
        m = sim.model
        groups = m.host["body_group"]
        g = m.group_index(group) if group is not None else -1
        members = groups == g if group is not None else np.isin(np.arange(m.n_bodies), m.host["sphere_body"])
        n_bodies = np.bincount(m.host["body_world"][members], minlength=m.n_worlds)
        return 2.0 * _count_active(sim, sim.contacts.ss, g) / np.maximum(n_bodies, 1)

    return f


def cohesive_bonds(group: str) -> Callable[[object], np.ndarray]:
    """Observer: unbroken cohesive bonds (sphere-sphere contacts between different bodies of the group whose
    cohesion is set and not broken) per world, shape (n_worlds,). Counted on the device (one small copy)."""

    def f(sim: object) -> np.ndarray:
        return _count_active(sim, sim.contacts.ss, sim.model.group_index(group), COHESIVE).astype(np.float64)

    return f


def mesh_wrench(mesh: str, world: int | None = None) -> Callable[[object], np.ndarray]:
    """Observer: contact force [N] and torque about its body's centre of mass [N m] on one mesh (e.g. the lower half
    of a tool: its force along travel is the draught), shape (n_worlds, 2, 3), or (2, 3) for one world."""

    def f(sim: object) -> np.ndarray:
        m = sim.model
        idx = np.arange(m.n_worlds) * m.meshes_per_world + m.names["mesh"][mesh]
        out = np.stack([sim.data.mesh_force.numpy()[idx], sim.data.mesh_torque.numpy()[idx]], axis=1).astype(np.float64)
        return out if world is None else out[world]

    return f


def spring_force(name: str) -> Callable[[object], np.ndarray]:
    """Observer: force of a named spring in the last step [N] (tension positive: it pulls its two points together),
    spring + dashpot, shape (n_worlds,)."""

    def f(sim: object) -> np.ndarray:
        m = sim.model
        idx = np.arange(m.n_worlds) * m.springs_per_world + m.names["spring"][name]
        return sim.data.spring_force.numpy()[idx].astype(np.float64)

    return f


@wp.kernel
def _gather_poses_kernel(
    first: int,
    stride: int,
    body_pos: wp.array(dtype=wp.vec3d),
    body_quat: wp.array(dtype=wp.quatd),
    pos: wp.array(dtype=wp.vec3d),
    quat: wp.array(dtype=wp.quatd),
):
    """pos[w], quat[w] = the pose of body first + w * stride (one body of each world)."""
    w = wp.tid()
    pos[w] = body_pos[first + w * stride]
    quat[w] = body_quat[first + w * stride]


GATHER_MIN_BODIES = 4096
"""from this many bodies on, :func:`body_poses` gathers on the device rather than copying every body's pose."""


def body_poses(sim: object, body: str, gather: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Position [m] (n_worlds, 3) and orientation quaternion (x, y, z, w) (n_worlds, 4) of a named body in each
    world. ``gather`` (default: on CUDA in a scene of at least GATHER_MIN_BODIES bodies): gathered on the device,
    a copy of n_worlds poses instead of every body's (a soil bin's hundreds of thousands); otherwise read from the
    whole arrays (on the CPU numpy views, no copy; a small CUDA scene's copy costs less than a launch)."""
    m = sim.model
    if gather is None:
        gather = m.device.is_cuda and m.n_bodies >= GATHER_MIN_BODIES
    if not gather:
        idx = np.arange(m.n_worlds) * m.bodies_per_world + m.names["body"][body]
        return sim.state.body_pos.numpy()[idx], sim.state.body_quat.numpy()[idx]
    pos = wp.empty(m.n_worlds, dtype=wp.vec3d, device=m.device)
    quat = wp.empty(m.n_worlds, dtype=wp.quatd, device=m.device)
    wp.launch(_gather_poses_kernel, m.n_worlds, inputs=[m.names["body"][body], m.bodies_per_world,
                                                        sim.state.body_pos, sim.state.body_quat],
              outputs=[pos, quat], device=m.device)
    return pos.numpy(), quat.numpy()


class BodyPoint:
    """Observer: world position [m] of a point fixed to a named body, shape (n_worlds, 3) (:func:`body_point`).
    It reads only the body's pose, so a ``world_steps`` simulation records the poses inside its kernel and calls
    :meth:`of_poses` (``Simulation.run``)."""

    def __init__(self, body: str, point: object) -> None:
        self.body = body
        self.point = np.asarray(point, dtype=np.float64)
        self.local: np.ndarray | None = None  # the point in each body's frame (n_worlds, 3), from the first pose

    def __call__(self, sim: object) -> np.ndarray:
        return self.of_poses(*body_poses(sim, self.body))

    def of_poses(self, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """The point [m] (..., n_worlds, 3) of the body at positions ``pos`` [m] (..., n_worlds, 3) and
        orientations ``quat`` (x, y, z, w) (..., n_worlds, 4); leading axes (records) are taken in one pass."""
        pos, quat = np.asarray(pos, dtype=np.float64), np.asarray(quat, dtype=np.float64)
        n = pos.shape[-2]
        rot = quats_to_matrices(quat.reshape(-1, 4))
        flat = pos.reshape(-1, 3)
        if self.local is None:
            self.local = np.einsum("nji,nj->ni", rot[:n], self.point - flat[:n])
        local = np.tile(self.local, (len(flat) // n, 1))
        return (flat + np.einsum("nij,nj->ni", rot, local)).reshape(pos.shape)


def body_point(body: str, point: object) -> BodyPoint:
    """Observer: world position [m] of a point fixed to a named body, shape (n_worlds, 3). ``point`` is given in
    the world at the initial pose [m] (3,), or per world (n_worlds, 3) where the worlds start in other poses;
    subtract the first record to get its displacement."""
    return BodyPoint(body, point)
