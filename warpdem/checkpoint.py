"""Checkpoints: save the full dynamic state of a Simulation (bodies, contact history, broad-phase reference
positions, counters, energy accumulators, the last step's spring forces and body and mesh forces and torques that
observers read, and the run's ``types.Control``: pivot velocities set by ``set_body_velocity`` and local damping set
by ``set_local_damping``) and restore it into a Simulation built from the same scene.

A restored CPU run continues bit for bit as the uninterrupted one would. Files of format 4 (the Control's arrays
stored as the model's ``body_pivot_vel`` and ``group_damping``) are read too.

The file carries a manifest (every array's shape, dtype and CRC-32); loading checks it, then checks the arrays
against the simulation (shapes, finite state, candidate lists inside their capacity, partners that exist) and
refuses with an InputError naming the file and the field, so that a damaged or foreign file never reaches a kernel.
"""

from __future__ import annotations

import json
import os
import zipfile
import zlib

import numpy as np
import warp as wp

from .errors import InputError
from .files import write_atomic

_FORMAT = 5  # 2: five energy slots (driven work), mutable model arrays; 3: manifest with checksums; 4: the last
# step's forces (what an observer reads before the next step); 5: the Control's arrays as control/...
_READS = (4, 5)
"""the formats :func:`load` reads."""
_SIM_ARRAYS = {k: "data" for k in ("energy", "counters", "cohesion_now", "fault", "spring_force", "body_force",
                                    "body_torque", "mesh_force", "mesh_torque")} | {
    k: "contacts" for k in ("build_pos", "mesh_build_pos", "mesh_build_quat")}
"""fields of Simulation.data (warpdem/data.py) and Simulation.contacts (types.Contacts) saved beside the state
and the candidate lists, as ``sim/<field>``: field -> the Simulation's attribute that holds it."""
_CONTROL_ARRAYS = ("pivot_vel", "group_damping")
"""fields of Simulation.control (types.Control), saved as ``control/<field>``."""
_FORMAT4_KEYS = {"control/pivot_vel": "model/body_pivot_vel", "control/group_damping": "model/group_damping"}
"""where a format-4 file keeps the Control's arrays."""


def _sim_array(sim: object, field: str) -> wp.array:
    """The array of :data:`_SIM_ARRAYS`' ``field`` in ``sim``."""
    return getattr(getattr(sim, _SIM_ARRAYS[field]), field)


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
        data["sim/" + k] = _sim_array(sim, k).numpy()
    for k in _CONTROL_ARRAYS:
        data["control/" + k] = getattr(sim.control, k).numpy()
    for name in ("ss", "st"):
        lst = getattr(sim.contacts, name)
        data[f"{name}/capacity"] = np.array(lst.capacity)
        for k, v in lst.numpy().items():
            data[f"{name}/{k}"] = v
    data["manifest"] = np.array(json.dumps({k: manifest_entry(v) for k, v in data.items()}))
    write_atomic(path, lambda tmp: np.savez_compressed(tmp, **data))


def manifest_entry(v: np.ndarray) -> list:
    """An array's line of a checkpoint's manifest: [shape, dtype (numpy's str), CRC-32 of its bytes]."""
    return [list(v.shape), v.dtype.str, zlib.crc32(np.ascontiguousarray(v).tobytes())]


def _read(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """The checkpoint's arrays, each checked against the manifest."""
    where = f"checkpoint {str(path)!r}"
    try:
        with np.load(path, allow_pickle=False) as f:
            data = {k: f[k] for k in f.files}
    except (OSError, EOFError, ValueError, zipfile.BadZipFile) as e:
        raise InputError(f"{where} is not readable ({type(e).__name__}: {e})") from None
    fmt = int(data["format"]) if "format" in data and data["format"].shape == () else -1
    if fmt not in _READS:
        raise InputError(f"{where} has format {fmt}; this warpdem reads formats {list(_READS)} (run again from the "
                         "start)")
    try:
        manifest = json.loads(str(data.pop("manifest")))
    except (KeyError, ValueError):
        raise InputError(f"{where} has no readable manifest") from None
    if set(manifest) != set(data):
        raise InputError(f"{where}: fields {sorted(set(manifest) ^ set(data))} are missing or not in its manifest")
    for k, v in data.items():
        if manifest_entry(v) != manifest[k]:
            shape, dtype, _ = manifest[k]
            what = (f"shape {list(v.shape)}, dtype {v.dtype.str} (manifest {shape}, {dtype})"
                    if [list(v.shape), v.dtype.str] != [shape, dtype] else "checksum differs from its manifest")
            raise InputError(f"{where}: field {k!r} is damaged: {what}")
    if fmt == 4:
        for new, old in _FORMAT4_KEYS.items():
            if old in data:
                data[new] = data.pop(old)
    return data


def _check(sim: object, data: dict[str, np.ndarray], where: str) -> None:
    """Refuse a checkpoint whose arrays cannot belong to ``sim``'s scene (see the module docstring)."""
    def expect(key: str, shape: tuple[int, ...]) -> np.ndarray:
        v = data.get(key)
        if v is None or v.shape != tuple(shape):
            raise InputError(f"{where}: field {key!r} has shape {None if v is None else list(v.shape)}, the scene "
                             f"needs {list(shape)}")
        return v

    for k in ("time", "step", "dt"):
        expect(k, ())
    if not (np.isfinite(data["time"]) and data["time"] >= 0):
        raise InputError(f"{where}: field 'time' is {float(data['time'])!r} s; it must be finite and >= 0")
    if int(data["step"]) < 0:
        raise InputError(f"{where}: field 'step' is {int(data['step'])}; it must be >= 0")
    for k in sim.state.ARRAYS:
        got = expect("state/" + k, _host_shape(getattr(sim.state, k)))
        if got.dtype.kind == "f" and not np.all(np.isfinite(got)):
            raise InputError(f"{where}: field 'state/{k}' holds NaN or inf")
    for k in _SIM_ARRAYS:
        expect("sim/" + k, _host_shape(_sim_array(sim, k)))
    for k in _CONTROL_ARRAYS:
        expect("control/" + k, _host_shape(getattr(sim.control, k)))
    m = sim.model
    for name, partners in (("ss", (m.n_spheres,)), ("st", (m.n_meshes, _max_faces(sim)))):
        expect(f"{name}/capacity", ())
        cap = int(data[f"{name}/capacity"])
        start, count = expect(f"{name}/start", (m.n_spheres,)), expect(f"{name}/count", (m.n_spheres,))
        if cap < 1 or np.any(start < 0) or np.any(count < 0) or np.any(start.astype(np.int64) + count > cap):
            raise InputError(f"{where}: {name} candidate list does not fit its capacity {cap} (start/count out of "
                             "range)")
        used = np.repeat(start, count) + np.concatenate([np.arange(c) for c in count]) if count.sum() else \
            np.zeros(0, np.int64)
        for key, n in zip(("key_a", "key_b"), partners, strict=False):
            keys = expect(f"{name}/{key}", (cap,))
            if len(used) and (keys[used].min() < 0 or keys[used].max() >= n):
                raise InputError(f"{where}: {name}/{key} names partners outside [0, {n})")
        expect(f"{name}/hist", (cap,))


def _host_shape(a: wp.array) -> tuple[int, ...]:
    """The shape ``a.numpy()`` would have (vector and matrix elements add their own axes), without the copy."""
    return tuple(a.shape) + tuple(getattr(a.dtype, "_shape_", ()))


def _max_faces(sim: object) -> int:
    faces = sim.model.host.get("mesh_faces", [])
    return max((len(f) for f in faces), default=0)


def load(sim: object, path: str | os.PathLike) -> None:
    """Restore a checkpoint written by :func:`save` into ``sim`` (built from the same scene, same device or not).
    A damaged file, or one of another scene, raises InputError naming the file and the field; ``sim`` is left as
    it was."""
    data = _read(path)
    if "signature" not in data or not np.array_equal(data["signature"], _signature(sim)):
        raise InputError(
            f"checkpoint {str(path)!r} was written for a different scene: sizes {data['signature'].tolist()} "
            f"vs {_signature(sim).tolist()} (worlds, bodies, spheres, meshes, springs, materials)"
        )
    if float(data["dt"]) != sim.dt:
        raise InputError(f"checkpoint dt = {float(data['dt'])} s differs from the simulation's dt = {sim.dt} s")
    _check(sim, data, f"checkpoint {str(path)!r}")
    for k in sim.state.ARRAYS:
        getattr(sim.state, k).assign(data["state/" + k])
    sim.state.time = float(data["time"])
    sim.state.step = int(data["step"])
    for k in _SIM_ARRAYS:
        _sim_array(sim, k).assign(data["sim/" + k])
    for k in _CONTROL_ARRAYS:
        getattr(sim.control, k).assign(data["control/" + k])
    for name in ("ss", "st"):
        lst, scratch = getattr(sim.contacts, name), getattr(sim.contacts, name + "_new")
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
        lst.index_owners()
    sim.refresh()
