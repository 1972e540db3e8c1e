"""The step as free stage functions (warpdem/stages.py): stages.step, driven by hand, gives the bits of
Simulation.step."""

from __future__ import annotations

import numpy as np
from conftest import DEVICE
from test_worlds import packing_scene

import warpdem as wd
from warpdem import stages


def test_free_step_gives_the_bits_of_simulation_step() -> None:
    def make() -> wd.Simulation:
        model, state = packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=2)
        return wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True, track_energy=True,
                             contact_threads="pair")

    a, b = make(), make()
    layout = stages.Layout(parts=1, sphere_cut=[0, b.model.n_spheres], body_cut=[0, b.model.n_bodies],
                           contact_cut=[0, b.model.n_spheres], entry_cut=None, pair_contacts=True,
                           float_sums=False, fold_energy=False)
    assert b.parts == 1 and b.contact_threads == "pair"
    for _ in range(600):
        a.step()
        if b.contacts.rebuild_flag.numpy()[0]:
            b.rebuild_lists()
        stages.step(b.model, b.state, b.control, b.contacts, b.data, b.options, b.materials, layout)
    assert a.rebuild_count > 0
    for k in a.state.ARRAYS:
        np.testing.assert_array_equal(getattr(a.state, k).numpy(), getattr(b.state, k).numpy())
    np.testing.assert_array_equal(a.data.energy.numpy(), b.data.energy.numpy())
    np.testing.assert_array_equal(a.contacts.ss.hist.numpy(), b.contacts.ss.hist.numpy())
