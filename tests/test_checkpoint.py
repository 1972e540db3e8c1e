"""Checkpoint round trip: a restored CPU run continues bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEVICE
from test_worlds import packing_scene

import warpdem as wd


def make() -> wd.Simulation:
    model, state = packing_scene(np.zeros(3)).finalize(DEVICE)
    return wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True, track_energy=True)


def test_restored_run_continues_identically(tmp_path) -> None:
    # Reference: the uninterrupted run. Everything that influences later steps (bodies, contact history, broad-phase
    # reference positions, counters, energy accumulators) is saved, and CPU runs are deterministic: exact equality.
    # A change made mid-run (local damping, as a settling stage ends) is part of the saved state.
    a = make()
    a.advance(2000)
    a.set_local_damping("soil", 0.05)
    a.advance(500)
    wd.checkpoint.save(a, tmp_path / "ck.npz")
    a.advance(1500)
    b = make()
    wd.checkpoint.load(b, tmp_path / "ck.npz")
    assert b.state.step == 2500
    np.testing.assert_array_equal(b.control.group_damping.numpy(), a.control.group_damping.numpy())
    np.testing.assert_array_equal(b.control.pivot_vel.numpy(), a.control.pivot_vel.numpy())
    b.advance(1500)
    for k in a.state.ARRAYS:
        np.testing.assert_array_equal(getattr(a.state, k).numpy(), getattr(b.state, k).numpy())
    np.testing.assert_array_equal(a.data.energy.numpy(), b.data.energy.numpy())
    np.testing.assert_array_equal(a.contacts.ss.hist.numpy(), b.contacts.ss.hist.numpy())
    assert a.state.time == b.state.time
    assert wd.observers.contact_count(a).sum() > 0


def test_setters_change_the_control_not_the_model(tmp_path) -> None:
    """The Model stays as built; a format-4 file (the Control's arrays stored as the model's) still loads."""
    a = make()
    built = a.model.group_damping.numpy().copy()
    a.advance(200)
    a.set_local_damping("soil", 0.05)
    np.testing.assert_array_equal(a.model.group_damping.numpy(), built)
    assert not np.array_equal(a.control.group_damping.numpy(), built)
    wd.checkpoint.save(a, tmp_path / "ck.npz")
    with np.load(tmp_path / "ck.npz") as f:
        data = {k: f[k] for k in f.files}
    data["format"] = np.array(4)
    data["model/body_pivot_vel"] = data.pop("control/pivot_vel")
    data["model/group_damping"] = data.pop("control/group_damping")
    _resave(tmp_path / "old.npz", data)
    a.advance(300)
    b = make()
    wd.checkpoint.load(b, tmp_path / "old.npz")
    np.testing.assert_array_equal(b.control.group_damping.numpy(), a.control.group_damping.numpy())
    b.advance(300)
    for k in a.state.ARRAYS:
        np.testing.assert_array_equal(getattr(a.state, k).numpy(), getattr(b.state, k).numpy())


def test_checkpoint_of_another_scene_is_refused(tmp_path) -> None:
    a = make()
    wd.checkpoint.save(a, tmp_path / "ck.npz")
    model, state = packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=2)
    other = wd.Simulation(model, state, dt=2e-5)
    try:
        wd.checkpoint.load(other, tmp_path / "ck.npz")
    except wd.InputError as e:
        assert "different scene" in str(e)
    else:
        raise AssertionError("loading a checkpoint of another scene must fail")


def _resave(path, data: dict, manifest: bool = True) -> None:
    """Write ``data`` as a checkpoint file, with a manifest made for it (a consistent but wrong file) or the old."""
    import json

    from warpdem.checkpoint import manifest_entry

    out = {k: v for k, v in data.items() if k != "manifest"}
    out["manifest"] = (np.array(json.dumps({k: manifest_entry(v) for k, v in out.items()})) if manifest
                       else data["manifest"])
    np.savez(path, **out)


@pytest.mark.parametrize("damage,words", [
    ("truncated", "not readable"),
    ("flipped value", "checksum differs"),
    ("body row missing", "'state/body_pos' has shape"),
    ("bogus counts", "does not fit its capacity"),
    ("partner out of range", "partners outside"),
    ("negative step", "'step' is -5"),
    ("time NaN", "'time' is nan"),
    ("NaN position", "holds NaN"),
    ("old format", "has format 2"),
    ("field missing", "missing or not in its manifest"),
])
def test_damaged_checkpoint_is_refused_by_name_and_leaves_the_run_as_it_was(tmp_path, damage: str,
                                                                           words: str) -> None:
    """Each damage gets an InputError naming the file and what is wrong (never a raw numpy/zip error, an
    out-of-bounds kernel read or a silently shifted state), and the simulation keeps its own state."""
    a = make()
    a.advance(6000)  # the spheres have fallen into contact (0.12 s)
    path = tmp_path / "ck.npz"
    wd.checkpoint.save(a, path)
    with np.load(path) as f:
        data = {k: f[k] for k in f.files}
    assert data["ss/count"].sum() > 0
    if damage == "truncated":
        raw = path.read_bytes()
        path.write_bytes(raw[: len(raw) // 3])
    elif damage == "flipped value":
        data["state/body_pos"][0, 0] += 1e-3
        _resave(path, data, manifest=False)
    elif damage == "body row missing":
        data["state/body_pos"] = data["state/body_pos"][1:]
        _resave(path, data)
    elif damage == "bogus counts":
        data["ss/count"][3] = 10**9
        _resave(path, data)
    elif damage == "partner out of range":
        first = int(np.flatnonzero(data["ss/count"])[0])
        data["ss/key_a"][data["ss/start"][first]] = 10**6
        _resave(path, data)
    elif damage == "negative step":
        data["step"] = np.array(-5)
        _resave(path, data)
    elif damage == "time NaN":
        data["time"] = np.array(np.nan)
        _resave(path, data)
    elif damage == "NaN position":
        data["state/body_pos"][2, 1] = np.nan
        _resave(path, data)
    elif damage == "old format":
        data["format"] = np.array(2)
        _resave(path, data)
    elif damage == "field missing":
        del data["sim/energy"]
        _resave(path, data, manifest=False)
    b = make()
    before = {k: getattr(b.state, k).numpy().copy() for k in b.state.ARRAYS}
    with pytest.raises(wd.InputError, match=words) as e:
        wd.checkpoint.load(b, path)
    assert "ck.npz" in str(e.value)
    assert b.state.step == 0
    for k, v in before.items():
        np.testing.assert_array_equal(getattr(b.state, k).numpy(), v)
