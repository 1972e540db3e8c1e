"""Checkpoint round trip: a restored CPU run continues bit for bit."""

from __future__ import annotations

import numpy as np
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
    np.testing.assert_array_equal(b.model.group_damping.numpy(), a.model.group_damping.numpy())
    b.advance(1500)
    for k in a.state.ARRAYS:
        np.testing.assert_array_equal(getattr(a.state, k).numpy(), getattr(b.state, k).numpy())
    np.testing.assert_array_equal(a.energy.numpy(), b.energy.numpy())
    np.testing.assert_array_equal(a.ss.hist.numpy(), b.ss.hist.numpy())
    assert a.state.time == b.state.time
    assert wd.observers.contact_count(a).sum() > 0


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
