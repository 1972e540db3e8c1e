"""Forces and torques are summed in fixed point (warpdem/accumulate.py): the sum does not depend on the order in
which contributions arrive, so a run repeats to the bit on CUDA as it does on the CPU."""

from __future__ import annotations

import math

import numpy as np
import warp as wp
from conftest import DEVICE
from test_worlds import packing_scene

import warpdem as wd
from warpdem import accumulate


@wp.kernel
def _add_in_order(order: wp.array(dtype=int), body: wp.array(dtype=int), force: wp.array(dtype=wp.vec3f),
                  force_acc: wp.array(dtype=accumulate.vec3l), torque_acc: wp.array(dtype=accumulate.vec3l),
                  force_scale: wp.array(dtype=wp.float64), torque_scale: wp.array(dtype=wp.float64),
                  plain: wp.array(dtype=wp.vec3f)):
    t = wp.tid()
    k = order[t]
    accumulate.add_wrench(force_acc, torque_acc, force_scale, torque_scale, body[k], force[k], force[k])
    wp.atomic_add(plain, body[k], force[k])  # what the engine did before: float32 atomics


def _sums(order: np.ndarray, body: np.ndarray, force: np.ndarray, res: np.ndarray) -> tuple[np.ndarray, ...]:
    n = len(res)
    acc_f, acc_t = wp.zeros(n, dtype=accumulate.vec3l, device=DEVICE), wp.zeros(n, dtype=accumulate.vec3l,
                                                                                  device=DEVICE)
    scale = wp.array(1.0 / res, dtype=wp.float64, device=DEVICE)
    plain = wp.zeros(n, dtype=wp.vec3f, device=DEVICE)
    wp.launch(_add_in_order, len(order), inputs=[wp.array(order, dtype=int, device=DEVICE),
                                                  wp.array(body, dtype=int, device=DEVICE),
                                                  wp.array(force, dtype=wp.vec3f, device=DEVICE),
                                                  acc_f, acc_t, scale, scale, plain], device=DEVICE)
    out = wp.zeros(n, dtype=wp.vec3f, device=DEVICE)
    wp.launch(accumulate.to_float_kernel, n, inputs=[acc_f, scale], outputs=[out], device=DEVICE)
    return acc_f.numpy(), out.numpy(), plain.numpy()


def test_fixed_point_sums_do_not_depend_on_the_order_of_the_contributions() -> None:
    # Reference: the exact sum (math.fsum of the float32 contributions in float64). 20,000 contributions of
    # magnitudes 1e-4 to 1e3 N onto 5 bodies, added in three orders (on the CPU the launch's order is the
    # index order, so permuting the contributions is what a GPU's thread schedule does): the integer sums are
    # equal to the bit; each is within n x resolution / 2 of the exact sum (every contribution rounds by at most
    # half a resolution) plus float32's rounding of the result. The float32 sums of the same contributions
    # differ between the orders (the test would see an order dependence).
    rng = np.random.default_rng(0)
    n, nb = 20_000, 5
    body = rng.integers(0, nb, n)
    force = (rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-4, 3, (n, 1))).astype(np.float32)
    res, _ = accumulate.resolutions(np.array([1e-3, 0.01, 1.0, 20.0, 0.0]), np.full((nb, 3), 1e-6),
                                    np.zeros(nb, dtype=int), 1)
    orders = [np.arange(n), np.arange(n)[::-1], rng.permutation(n)]
    runs = [_sums(o, body, force, res) for o in orders]
    for acc, _, _ in runs[1:]:
        np.testing.assert_array_equal(acc, runs[0][0])
    assert any(not np.array_equal(plain, runs[0][2]) for _, _, plain in runs[1:])
    for b in range(nb):
        mine = force[body == b].astype(np.float64)
        exact = np.array([math.fsum(mine[:, c]) for c in range(3)])
        bound = len(mine) * res[b] / 2 + np.abs(exact) * 2.0**-23
        assert np.all(np.abs(runs[0][1][b] - exact) <= bound), (b, runs[0][1][b], exact)


def test_resolutions_are_powers_of_two_set_by_each_bodys_weight() -> None:
    # Reference: the rule in accumulate.py's docstring, by hand: 2^floor(log2(m g0 2^-32)); a body without mass
    # takes its world's total mass; torques scale by the radius of gyration.
    mass = np.array([0.0014, 2.5, 0.0, 3.0])
    inertia = np.array([[2e-8] * 3, [0.1, 0.2, 0.4], [0.0] * 3, [1.0] * 3])
    world = np.array([0, 0, 0, 1])
    res_f, res_t = accumulate.resolutions(mass, inertia, world, 2)
    ref = np.array([0.0014, 2.5, 2.5014, 3.0]) * 9.81 * 2.0**-32
    np.testing.assert_array_equal(res_f, 2.0 ** np.floor(np.log2(ref)))
    assert np.all((res_f <= ref) & (res_f > ref / 2))
    gyr = np.sqrt(np.array([2e-8 / 0.0014, 0.4 / 2.5, 1.0, 1.0 / 3.0]))
    np.testing.assert_array_equal(res_t, 2.0 ** np.floor(np.log2(res_f * gyr)))


def test_a_chaotic_run_repeats_to_the_bit() -> None:
    # Reference: the same run again. 40 cohesive spheres with rolling resistance settle on a floor for 3,000 steps
    # (contacts form and break: a chaotic system in which any last-bit difference grows). On the CPU this holds by
    # construction; on CUDA (WARPDEM_TEST_DEVICE=cuda) it holds only because the force sums are order-independent.
    def run() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        model, state = packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=2)
        sim = wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True)
        rec = sim.run(3000, record_every=500, observers={"floor": wd.observers.mesh_wrench("floor"),
                                                         "ke": wd.observers.group_kinetic_energy("soil")})
        return sim.state.body_pos.numpy(), rec["floor"], rec["ke"]

    first, again = run(), run()
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)
    assert np.abs(first[0][:, 2] - 0.03).max() > 1e-3  # the spheres did move
