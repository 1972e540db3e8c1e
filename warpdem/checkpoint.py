"""Checkpoints: save the full dynamic state of a Simulation (bodies, contact history, broad-phase reference
positions, counters, energy accumulators, and the model values a run may change while it goes: pivot velocities
set by ``set_body_velocity`` and local damping set by ``set_local_damping``) and restore it into a Simulation built
from the same scene.

A restored CPU run continues bit for bit as the uninterrupted one would.
"""

from __future__ import annotations

import os

import numpy as np
import warp as wp

from .errors import InputError

_FORMAT = 2  # 2: five energy slots (driven work), mutable model arrays
_SIM_ARRAYS = ("energy", "counters", "build_pos", "mesh_build_pos", "mesh_build_quat", "cohesion_now", "fault")
_MODEL_ARRAYS = ("body_pivot_vel", "group_damping")
"""model arrays that the Simulation's setters change during a run."""


def _signature(sim: object) -> np.ndarray:
    m = sim.model
    return np.array([m.n_worlds, m.n_bodies, m.n_spheres, m.n_meshes, m.n_springs, m.n_materials], dtype=np.int64)


def save(sim: object, path: str | os.PathLike) -> None:
    """Write a checkpoint (``.npz``) of ``sim``'s state at the current step."""
    data: dict[str, np.ndarray] = {"format": np.array(_FORMAT), "signature": _signature(sim)}
    for k, v in sim.state.numpy().items():
        data["state/" + k] = v
    data["time"] = np.array(sim.state.time)
    data["step"] = np.array(sim.state.step)
    data["dt"] = np.array(sim.dt)
    for k in _SIM_ARRAYS:
        data["sim/" + k] = getattr(sim, k).numpy()
    for k in _MODEL_ARRAYS:
        data["model/" + k] = getattr(sim.model, k).numpy()
    for name in ("ss", "st"):
        lst = getattr(sim, name)
        data[f"{name}/capacity"] = np.array(lst.capacity)
        for k, v in lst.numpy().items():
            data[f"{name}/{k}"] = v
    tmp = str(path) + ".tmp.npz"
    np.savez_compressed(tmp, **data)
    os.replace(tmp, path)


def load(sim: object, path: str | os.PathLike) -> None:
    """Restore a checkpoint written by :func:`save` into ``sim`` (built from the same scene, same device or not)."""
    with np.load(path) as f:
        data = {k: f[k] for k in f.files}
    if int(data.get("format", -1)) != _FORMAT:
        raise InputError(f"checkpoint {str(path)!r} has an unknown format")
    if not np.array_equal(data["signature"], _signature(sim)):
        raise InputError(
            f"checkpoint {str(path)!r} was written for a different scene: sizes {data['signature'].tolist()} "
            f"vs {_signature(sim).tolist()} (worlds, bodies, spheres, meshes, springs, materials)"
        )
    if float(data["dt"]) != sim.dt:
        raise InputError(f"checkpoint dt = {float(data['dt'])} s differs from the simulation's dt = {sim.dt} s")
    for k in sim.state.ARRAYS:
        getattr(sim.state, k).assign(data["state/" + k])
    sim.state.time = float(data["time"])
    sim.state.step = int(data["step"])
    for k in _SIM_ARRAYS:
        getattr(sim, k).assign(data["sim/" + k])
    for k in _MODEL_ARRAYS:
        getattr(sim.model, k).assign(data["model/" + k])
    for name in ("ss", "st"):
        lst, scratch = getattr(sim, name), getattr(sim, name + "_new")
        cap = int(data[f"{name}/capacity"])
        if cap != lst.capacity:
            lst.grow(cap)
            scratch.grow(cap)
        lst.start.assign(data[f"{name}/start"])
        lst.count.assign(data[f"{name}/count"])
        lst.key_a.assign(data[f"{name}/key_a"])
        if lst.two_keys:
            lst.key_b.assign(data[f"{name}/key_b"])
        lst.hist.assign(wp.array(data[f"{name}/hist"], dtype=lst.hist.dtype, device=lst.device))
    sim._graph = None
    sim._update_spheres()
