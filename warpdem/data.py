"""Data: what a step computes besides the State, in one documented place.

A :class:`~warpdem.simulation.Simulation` holds a static :class:`~warpdem.model.Model`, the bodies'
:class:`~warpdem.model.State` (pose, velocities: what a step advances) and a :class:`Data`: the per-step work
arrays that the kernels write and read within a step (sphere kinematics, force and torque sums, spring forces,
energies) and the device-side bookkeeping of the step counts, the one-step cohesion request and the fault checks
(the candidate lists, their contact history and what decides a rebuild are ``types.Contacts``). Observers,
checkpoints and viewers read these fields; every field's shape, dtype and unit is listed below. Sizes: ``ns``
spheres, ``nb`` bodies, ``nm`` mesh instances (arrays sized by ``nm`` or the springs have at least one entry),
``W`` worlds, all worlds together; ``P`` CPU threads sharing a step (1 on CUDA).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from . import accumulate
from .contacts import N_ENERGY
from .model import Model
from .types import DISP_STRIDE

NO_FAULT = 2**31 - 1
"""``fault[0]`` while no body has failed (the failing body with the lowest index wins: atomic min)."""


@dataclass
class Data:
    """The per-step arrays of a simulation (see the module docstring); made by :meth:`zeros`."""

    # sphere kinematics, from the bodies' state (update_spheres_kernel)
    sphere_pos: wp.array
    """sphere centres in the world [m], vec3d (ns,)."""
    sphere_vel: wp.array
    """velocity of each sphere's centre [m/s], vec3f (ns,)."""
    sphere_angvel: wp.array
    """angular velocity of each sphere (its body's) [rad/s], vec3f (ns,)."""
    sphere_arm: wp.array
    """sphere centre minus its body's centre of mass, world frame [m], vec3f (ns,)."""

    # force and torque sums (accumulate.py): fixed-point accumulators, their scales, and the float results
    force_acc: wp.array
    """force on each body in units of its resolution, accumulate.vec3l (P * nb,): P = the CPU threads sharing a
    step (1 on CUDA), each adding into its own nb slots."""
    torque_acc: wp.array
    """torque about each body's centre of mass in units of its resolution, accumulate.vec3l (P * nb,)."""
    force_scale: wp.array
    """1 / force resolution of each body [1/N], float64 (nb,)."""
    torque_scale: wp.array
    """1 / torque resolution of each body [1/(N m)], float64 (nb,)."""
    mesh_force_acc: wp.array
    """contact force on each mesh instance, fixed point, accumulate.vec3l (P * nm,)."""
    mesh_torque_acc: wp.array
    """contact torque on each mesh instance about its body's centre of mass, fixed point, accumulate.vec3l
    (P * nm,)."""
    mesh_force_scale: wp.array
    """1 / force resolution of each mesh instance (its body's) [1/N], float64 (nm,)."""
    mesh_torque_scale: wp.array
    """1 / torque resolution of each mesh instance (its body's) [1/(N m)], float64 (nm,)."""
    body_force: wp.array
    """contact and spring force on each body [N], world frame, vec3f (nb,) (gravity is added by the integrator)."""
    body_torque: wp.array
    """contact and spring torque about each body's centre of mass [N m], world frame, vec3f (nb,)."""
    mesh_force: wp.array
    """contact force of the spheres on each mesh instance [N], world frame, vec3f (nm,)."""
    mesh_torque: wp.array
    """their torque about the mesh body's centre of mass [N m], world frame, vec3f (nm,)."""
    mesh_force_sum: wp.array
    """``mesh_force`` added up step after step [N], float64 vec3d (nm,): zero it, advance n steps, and it holds n
    times the mean force over them (the same numbers as reading ``mesh_force`` after each step and adding them in
    float64). Not kept in checkpoints."""

    # springs and energies
    spring_force: wp.array
    """force of each spring-dashpot [N], tension positive, float32 (n_springs,)."""
    energy: wp.array
    """energy dissipated or supplied per world since the start [J], float64 (W * N_ENERGY,), slots in
    observers.ENERGY_TERMS (with ``track_energy``)."""
    energy_extra: wp.array
    """the energy terms of CPU threads 2 .. P within a step [J], float64 ((P - 1) * W * N_ENERGY,), at least one
    entry; added into ``energy`` at the end of the step."""

    mesh_rmax: wp.array
    """each mesh instance's largest vertex distance from its body's centre of mass [m], float32 (nm,)."""

    # device-side bookkeeping
    cohesion_now: wp.array
    """1: the next step sets cohesion on every contact (Yade's setCohesionNow), int32 (1,)."""
    counters: wp.array
    """steps and list rebuilds done on the device, int32 (2,)."""
    fault: wp.array
    """first failure: body (NO_FAULT: none), cause, step, int32 (3,)."""
    fault_parts: wp.array
    """each CPU thread's failure of the current step (body, cause, step at entry p * DISP_STRIDE), moved into
    ``fault`` at the end of the step, int32 (P * DISP_STRIDE,)."""

    @classmethod
    def zeros(cls, model: Model, parts: int = 1) -> Data:
        """Zeroed arrays for ``model`` on its device; the scales are set by accumulate.resolutions, the mesh
        extents from the model's geometry; ``parts`` (P): CPU threads
        that share a step, each with its own accumulators."""
        dev = model.device
        ns, nb, nm = model.n_spheres, model.n_bodies, model.n_meshes
        res_f, res_t = accumulate.resolutions(model.body_mass.numpy(), model.body_inertia.numpy(),
                                              model.body_world.numpy(), model.n_worlds)
        mesh_body = model.mesh_body.numpy() if nm else np.zeros(1, dtype=np.int64)
        rmax = [float(np.linalg.norm(v, axis=1).max()) for v in model.host["mesh_vertices_local"]]

        def zeros(n: int, dtype: object) -> wp.array:
            return wp.zeros(n, dtype=dtype, device=dev)

        def f64(values: np.ndarray) -> wp.array:
            return wp.array(values, dtype=wp.float64, device=dev)

        return cls(
            sphere_pos=zeros(ns, wp.vec3d), sphere_vel=zeros(ns, wp.vec3f), sphere_angvel=zeros(ns, wp.vec3f),
            sphere_arm=zeros(ns, wp.vec3f),
            force_acc=zeros(parts * nb, accumulate.vec3l), torque_acc=zeros(parts * nb, accumulate.vec3l),
            force_scale=f64(1.0 / res_f), torque_scale=f64(1.0 / res_t),
            mesh_force_acc=zeros(parts * max(nm, 1), accumulate.vec3l),
            mesh_torque_acc=zeros(parts * max(nm, 1), accumulate.vec3l),
            mesh_force_scale=f64(1.0 / res_f[mesh_body] if nb else np.ones(1)),
            mesh_torque_scale=f64(1.0 / res_t[mesh_body] if nb else np.ones(1)),
            body_force=zeros(nb, wp.vec3f), body_torque=zeros(nb, wp.vec3f),
            mesh_force=zeros(max(nm, 1), wp.vec3f), mesh_torque=zeros(max(nm, 1), wp.vec3f),
            mesh_force_sum=zeros(max(nm, 1), wp.vec3d),
            spring_force=zeros(max(model.n_springs, 1), float),
            energy=zeros(model.n_worlds * N_ENERGY, wp.float64),
            energy_extra=zeros(max(parts - 1, 1) * model.n_worlds * N_ENERGY, wp.float64),
            mesh_rmax=wp.array(np.tile(np.array(rmax, dtype=np.float32), model.n_worlds) if nm else [0.0],
                               dtype=float, device=dev),
            cohesion_now=zeros(1, int), counters=zeros(2, int),
            fault=wp.array([NO_FAULT, 0, 0], dtype=int, device=dev),
            fault_parts=wp.array(np.tile(np.r_[NO_FAULT, np.zeros(DISP_STRIDE - 1)], parts).astype(np.int32),
                                 dtype=int, device=dev),
        )
