"""Deterministic sums of forces and torques: fixed-point accumulators.

Every contribution to a body's force [N] or torque [N m] (a contact, a spring) is rounded to an integer multiple
of the body's resolution and added to an int64 accumulator with an integer atomic. Integer addition is
associative, so the sum does not depend on the order in which threads add: a run repeats to the bit on CUDA, and
a world gives the same bits whatever other worlds share its batch. After the contacts and springs, the sums are
converted back to float32 (:func:`take_float`: by the integration kernel itself, or before it by
:func:`wrench_to_float_kernel` in a large CUDA scene) into ``body_force``, ``body_torque``, ``mesh_force`` and
``mesh_torque``, which the observers read. On the CPU, where a step's large kernels are shared out between threads, each
thread adds into its own accumulators and the conversion sums them: the same integers in any split.

Resolutions (:func:`resolutions`): a body of mass m has the force resolution 2^floor(log2(m g0 2^-32)) [N] with
g0 = 9.81 m/s^2 (a nominal weight, whatever the model's gravity): about 2.3e-10 of its weight, far below float32's
relative precision, and room for 2^31 times its weight before the int64 overflows. A body without mass (a
kinematic tool, a wall) takes the total mass of its world instead. The torque resolution is the force resolution
times the body's radius of gyration (1 m for a body without mass), rounded to a power of two.
"""

from __future__ import annotations

import numpy as np
import warp as wp

wp.set_module_options({"enable_backward": False})

vec3l = wp.types.vector(3, wp.int64)
"""an integer 3-vector: a fixed-point force or torque."""

G0 = 9.81
"""the nominal gravity [m/s^2] that scales a body's force resolution."""
FRACTION_BITS = 32
"""a body's force resolution is its nominal weight times 2^-FRACTION_BITS (rounded down to a power of two)."""


@wp.func
def to_fixed(v: wp.vec3f, scale: wp.float64) -> vec3l:
    """v in units of the resolution (``scale`` = 1 / resolution), rounded to the nearest integer."""
    return vec3l(
        wp.int64(wp.round(wp.float64(v[0]) * scale)),
        wp.int64(wp.round(wp.float64(v[1]) * scale)),
        wp.int64(wp.round(wp.float64(v[2]) * scale)),
    )


@wp.func
def add_wrench(
    force_acc: wp.array(dtype=vec3l),
    torque_acc: wp.array(dtype=vec3l),
    force_scale: wp.array(dtype=wp.float64),
    torque_scale: wp.array(dtype=wp.float64),
    b: int,
    f: wp.vec3f,
    t: wp.vec3f,
):
    """Add force f [N] and torque t [N m] to slot b of the accumulators."""
    wp.atomic_add(force_acc, b, to_fixed(f, force_scale[b]))
    wp.atomic_add(torque_acc, b, to_fixed(t, torque_scale[b]))


@wp.func
def read_float(acc: wp.array(dtype=vec3l), scale: wp.array(dtype=wp.float64), i: int, n: int, parts: int
               ) -> wp.vec3f:
    """Slot i of ``parts`` accumulators of n slots each (acc[p * n + i], one per CPU thread), summed and converted
    to float32 (x resolution = 1 / scale[i]). Integer sums: the result does not depend on how the contributions
    were shared out. Nothing is written (:func:`clear_slots` zeroes them for the next step)."""
    r = wp.float64(1.0) / scale[i]
    a = acc[i]
    for p in range(1, parts):
        a = a + acc[p * n + i]
    return wp.vec3f(float(wp.float64(a[0]) * r), float(wp.float64(a[1]) * r), float(wp.float64(a[2]) * r))


@wp.func
def clear_slots(acc: wp.array(dtype=vec3l), i: int, n: int, parts: int):
    """Zero slot i of ``parts`` accumulators of n slots each for the next step."""
    for p in range(parts):
        acc[p * n + i] = vec3l()


@wp.func
def take_float(acc: wp.array(dtype=vec3l), scale: wp.array(dtype=wp.float64), i: int, n: int, parts: int
               ) -> wp.vec3f:
    """:func:`read_float`, then :func:`clear_slots`. (Code that reads more afterwards calls the two itself, clearing
    last: Warp's arrays may alias, so a load after a store waits for it.)"""
    out = read_float(acc, scale, i, n, parts)
    clear_slots(acc, i, n, parts)
    return out


@wp.kernel
def wrench_to_float_kernel(
    force_acc: wp.array(dtype=vec3l),
    force_scale: wp.array(dtype=wp.float64),
    torque_acc: wp.array(dtype=vec3l),
    torque_scale: wp.array(dtype=wp.float64),
    parts: int,
    force: wp.array(dtype=wp.vec3f),
    torque: wp.array(dtype=wp.vec3f),
):
    """Both sums of slot i to float32 (:func:`take_float`): force[i] [N] and torque[i] [N m]."""
    i = wp.tid()
    force[i] = take_float(force_acc, force_scale, i, force.shape[0], parts)
    torque[i] = take_float(torque_acc, torque_scale, i, torque.shape[0], parts)


@wp.kernel
def fold_energy_kernel(extra: wp.array(dtype=wp.float64), parts: int, energy: wp.array(dtype=wp.float64)):
    """energy[i] += the other CPU threads' terms extra[(p - 1) * n + i], p = 1 .. parts - 1, which are zeroed."""
    i = wp.tid()
    n = energy.shape[0]
    e = energy[i]
    for p in range(1, parts):
        e += extra[(p - 1) * n + i]
        extra[(p - 1) * n + i] = wp.float64(0.0)
    energy[i] = e


def _pow2_floor(x: np.ndarray) -> np.ndarray:
    return np.exp2(np.floor(np.log2(x)))


def resolutions(mass: np.ndarray, inertia: np.ndarray, world: np.ndarray, n_worlds: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Force [N] and torque [N m] resolutions of the bodies' accumulators, shape (n_bodies,) each (powers of two).

    Args:
        mass: body masses [kg] (n,), 0 for a body without mass. inertia: principal moments [kg m^2] (n, 3).
        world: each body's world (n,). n_worlds: number of worlds.
    """
    mass = np.asarray(mass, dtype=np.float64)
    world_mass = np.bincount(world, weights=mass, minlength=n_worlds) if len(mass) else np.zeros(n_worlds)
    ref = np.where(mass > 0.0, mass, world_mass[world] if len(mass) else 0.0)
    ref = np.where(ref > 0.0, ref, 1.0)  # a world without mass: 1 kg
    res_f = _pow2_floor(ref * G0 * 2.0**-FRACTION_BITS)
    gyration = np.sqrt(np.max(np.asarray(inertia, dtype=np.float64).reshape(len(mass), 3), axis=1)
                       / np.where(mass > 0.0, mass, 1.0)) if len(mass) else np.zeros(0)
    arm = np.where((mass > 0.0) & (gyration > 0.0), gyration, 1.0)
    return res_f, _pow2_floor(res_f * arm)
