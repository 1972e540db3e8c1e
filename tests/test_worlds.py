"""Batched worlds equal solo runs; contact forces do not depend on where the scene sits (float64 positions)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEVICE, square

import warpdem as wd


def packing_scene(offset: np.ndarray, seed: int = 1) -> wd.ModelBuilder:
    rng = np.random.default_rng(seed)
    pts = []
    while len(pts) < 40:
        p = rng.uniform(-0.025, 0.025, 3)
        if all(np.linalg.norm(p - q) > 0.011 for q in pts):
            pts.append(p)
    pos = np.array(pts) + np.array([0, 0, 0.03]) + offset
    b = wd.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_material("soil", wd.Material(young=1e7, poisson=0.3, density=2700, friction_angle=30, normal_cohesion=3e3,
                                       shear_cohesion=1.5e3, moment_law=True, eta_roll=0.2, eta_twist=0.2))
    b.add_material("wall", wd.Material(young=1e7, poisson=0.3, density=2700, friction_angle=30))
    b.add_spheres(pos, rng.uniform(0.004, 0.0055, 40), "soil", group="soil", name="first")
    v, f = square(tuple(offset), 0.06)
    b.add_mesh("floor", v, f, "wall")
    b.set_local_damping("soil", 0.3)
    return b


@pytest.mark.parametrize("contact_threads", wd.Simulation.CONTACT_THREADS)
def test_world_in_batch_equals_solo_run(contact_threads: str) -> None:
    # Reference: the same scene run alone with world 2's parameters. Worlds never interact, every sphere's contacts
    # are summed in partner order and the body sums are fixed-point integers, so the result must be identical (bit
    # for bit), with the contacts a thread per sphere or a thread per pair (whose list entries lie elsewhere in
    # the batch than alone).
    angles = np.array([20.0, 30.0, 40.0])
    damping = np.array([0.1, 0.3, 0.5])
    over = {"material:soil:friction_angle": angles, "damping:soil": damping}
    model, state = packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=3, overrides=over)
    batch = wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True, contact_threads=contact_threads)
    batch.advance(1500)
    solo_over = {k: v[2:3] for k, v in over.items()}
    model1, state1 = packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=1, overrides=solo_over)
    solo = wd.Simulation(model1, state1, dt=2e-5, cohesion_on_new_contacts=True, contact_threads=contact_threads)
    solo.advance(1500)
    nb = model.bodies_per_world
    np.testing.assert_array_equal(state.body_pos.numpy()[2 * nb : 3 * nb], state1.body_pos.numpy())
    np.testing.assert_array_equal(batch.data.body_force.numpy()[2 * nb : 3 * nb], solo.data.body_force.numpy())
    # and the worlds really differ (the parameters reached the kernels)
    assert not np.allclose(state.body_pos.numpy()[:nb], state.body_pos.numpy()[nb : 2 * nb])


def test_same_packing_at_origin_and_2m_gives_same_forces() -> None:
    # Reference: translation invariance. With float64 positions the overlaps (~1e-6 m) are resolved to ~1e-16 m
    # at 2 m, so contact forces agree to float32 precision (1e-4 of the largest force after 4000 steps of impact
    # and settling). With float32
    # positions the overlap resolution at 2 m would be ~2e-7 m, i.e. errors of tens of percent.
    results = []
    for offset in (np.zeros(3), np.array([2.0, -2.0, 2.0])):
        model, state = packing_scene(offset).finalize(DEVICE)
        sim = wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True)
        sim.advance(4000)
        assert wd.observers.contact_count(sim).sum() > 5
        results.append((sim.data.body_force.numpy().astype(np.float64), state.body_pos.numpy() - offset))
    f0, f1 = results[0][0], results[1][0]
    scale = np.abs(f0).max()
    assert scale > 0
    np.testing.assert_allclose(f1, f0, rtol=0, atol=1e-4 * scale)
    # positions: 1e-9 m on the CPU (deterministic); on CUDA the order of float32 atomic force sums varies between
    # runs, so two runs differ by round-off noise even at the same place (1.1e-9 m measured on an H200): 1e-8 m.
    tol_x = 1e-9 if str(model.device).startswith("cpu") else 1e-8
    np.testing.assert_allclose(results[1][1], results[0][1], rtol=0, atol=tol_x)
