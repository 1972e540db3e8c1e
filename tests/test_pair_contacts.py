"""A thread per candidate (``Simulation(contact_threads="pair")``, contacts.sphere_pair_kernel) against a thread per
sphere (the default), whose law and sums the Yade and closed-form tests check.

The two evaluate the same law on the same pairs; they differ only in how a sphere's contacts reach its body: the
default sums a sphere's contacts in float32 and rounds the sum to the fixed-point accumulator once, "pair" rounds
each contact. So where no sphere's list holds two contacts they must give the same bits, and elsewhere the forces
of one step must agree to the float32 rounding of a sphere's partial sums.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEVICE

import warpdem as wd
from warpdem.errors import InputError

EPS32 = float(np.finfo(np.float32).eps)
FMA_ULPS = 16
"""float32 ulps (of the largest value) that CUDA's fused multiply-adds may move a result between two kernels."""


def _cradle(n_worlds: int = 2) -> tuple[wd.Model, wd.State]:
    """A row of five equal spheres just touching along x, no gravity; the first moves at 0.2 m/s (world w at
    0.2 (1 + w) m/s). Each sphere's list holds at most its right neighbour."""
    b = wd.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=2700, friction_angle=30))
    r = 0.01
    for k in range(5):
        b.add_sphere((2 * r * k, 0.0, 0.0), r, "m")
    model, state = b.finalize(DEVICE, n_worlds=n_worlds)
    vel = state.body_vel.numpy()
    for w in range(n_worlds):
        vel[5 * w, 0] = 0.2 * (1 + w)
    state.body_vel.assign(vel)
    return model, state


def test_pair_threads_on_a_cradle_give_the_same_bits_and_conserve_momentum_and_energy() -> None:
    # References: (1) the per-sphere kernel, bit for bit (each list holds at most one contact, so both round the
    # same single contact forces); (2) closed forms: a collision of free spheres conserves momentum exactly (equal
    # and opposite contact forces, integer sums), and the elastic law (no viscous damping, no sliding in a head-on
    # row) conserves kinetic energy once the spheres have separated, up to the leapfrog's error, of the order of
    # (omega dt)^2 of the kinetic energy per contact (omega^2 = 2 kn / m for two equal spheres): the tolerance
    # allows 2 (omega dt)^2 = 4 (kn / m) dt^2 for the row's four contacts (measured: 1e-4, 23 times less).
    runs = {}
    for mode in ("sphere", "pair"):
        model, state = _cradle()
        dt = 0.05 * wd.pwave_timestep(model)
        sim = wd.Simulation(model, state, dt=dt, contact_threads=mode)
        sim.advance(24000)
        runs[mode] = sim
    for name in ("body_pos", "body_vel", "body_angvel"):
        np.testing.assert_array_equal(getattr(runs["pair"].state, name).numpy(),
                                      getattr(runs["sphere"].state, name).numpy())
    mass = runs["pair"].model.body_mass.numpy().reshape(2, 5)
    vel = runs["pair"].state.body_vel.numpy().reshape(2, 5, 3)
    v0 = np.array([0.2, 0.4])
    momentum = (mass[..., None] * vel).sum(axis=1)
    np.testing.assert_allclose(momentum[:, 0], mass[:, 0] * v0, rtol=1e-6)
    energy = 0.5 * (mass * (vel ** 2).sum(axis=2)).sum(axis=1)
    kn = 1e7 * 0.01  # Yade's kn = 2 E1 R1 E2 R2 / (E1 R1 + E2 R2) for equal spheres: E R [N/m]
    np.testing.assert_allclose(energy, 0.5 * mass[:, 0] * v0 ** 2, rtol=4 * kn / mass[0, 0] * dt ** 2)
    assert vel[:, 4, 0].min() > 0.5 * v0.min()  # the collision went down the row
    assert wd.observers.contact_count(runs["pair"]).sum() == 0  # and the spheres have separated


def _bonded_block(seed: int = 3) -> wd.ModelBuilder:
    """125 spheres on a 5 x 5 x 5 lattice at 1.98 radii, each moved by up to 0.03 radii (most neighbours overlap:
    up to 3 entries in a sphere's list; the normals off the axes), cohesive with the moment law, no gravity."""
    rng = np.random.default_rng(seed)
    b = wd.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=2700, friction_angle=30, normal_cohesion=1e6,
                                    shear_cohesion=1e6, moment_law=True, eta_roll=0.3, eta_twist=0.3))
    r = 0.005
    g = np.arange(5) * 1.98 * r
    pos = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3) + rng.uniform(-0.03, 0.03, (125, 3)) * r
    b.add_spheres(pos, r * rng.uniform(0.98, 1.02, len(pos)), "m")
    return b


def _expected_owner(sim: wd.Simulation) -> np.ndarray:
    """The sphere of each entry of the sphere-sphere lists from their start and count in numpy, -1 on free slots."""
    ss = sim.contacts.ss.numpy()
    expect = np.full(sim.contacts.ss.capacity, -1)
    for i, (s, c) in enumerate(zip(ss["start"], ss["count"], strict=True)):
        expect[s:s + c] = i
    return expect


def _kicked(mode: str, tmp_path: object | None = None, load: str | None = None) -> wd.Simulation:
    model, state = _bonded_block().finalize(DEVICE)
    sim = wd.Simulation(model, state, dt=0.3 * wd.pwave_timestep(model), always_use_moment_law=True,
                        contact_threads=mode)
    if load is not None:
        wd.checkpoint.load(sim, load)
        return sim
    sim.set_cohesion_now()
    rng = np.random.default_rng(7)
    state.body_vel.assign(rng.normal(0.0, 0.05, (model.n_bodies, 3)))
    state.body_angvel.assign(rng.normal(0.0, 5.0, (model.n_bodies, 3)))
    return sim


def test_pair_threads_match_sphere_threads_on_a_bonded_block(tmp_path: object) -> None:
    # Reference: the per-sphere kernel from the same state (a checkpoint of a kicked bonded block after 50 steps,
    # loaded into both: the loaded lists must index their entries' spheres for the pair kernel). One step: the
    # contact histories depend on no sum, so on the CPU they are equal to the bit; a body's force differs by the float32
    # rounding of a sphere's partial sums: at most (entries per list) x eps32 x the largest partial sum per
    # component, which in this kicked block (forces of both signs, no static load) is about the largest body force
    # of the step, and by half a fixed-point resolution per contact (~1e-10 of a sphere's weight, below that).
    # On CUDA, nvcc fuses a * b + c into one rounding (FMA) as each kernel's code lets it, so the same law inlined
    # in the two kernels rounds differently in the last bits (measured on an H100: 24 of 1992 history components,
    # at most 2.4e-7 on values of order 1, 2 ulps): there every comparison allows FMA_ULPS float32 ulps of the
    # largest value more. A wrong term of the law would differ by orders of magnitude more.
    path = str(tmp_path / "block.npz")
    sim = _kicked("sphere")
    sim.advance(50)
    wd.checkpoint.save(sim, path)
    a, b = _kicked("sphere", load=path), _kicked("pair", load=path)
    np.testing.assert_array_equal(b.contacts.ss.owner.numpy(), _expected_owner(b))
    a.step()
    b.step()
    fused = 0 if DEVICE == "cpu" else FMA_ULPS
    ha, hb = a.contacts.ss.numpy()["hist"], b.contacts.ss.numpy()["hist"]
    for field in ha.dtype.names:
        np.testing.assert_allclose(hb[field], ha[field], rtol=0.0, atol=fused * EPS32 * np.abs(ha[field]).max())
    fa, fb = a.data.body_force.numpy(), b.data.body_force.numpy()
    ta, tb = a.data.body_torque.numpy(), b.data.body_torque.numpy()
    per_list = int(a.contacts.ss.count.numpy().max())
    assert per_list == 3 and np.abs(fa).max() > 0.1
    assert np.abs(fb - fa).max() <= (per_list + fused) * EPS32 * np.abs(fa).max()
    assert np.abs(tb - ta).max() <= (per_list + fused) * EPS32 * np.abs(ta).max()
    assert np.abs(fb - fa).max() > 0.0  # the two really round differently here (else this compares nothing)


def _gathering(contact_threads: str, threads: int) -> wd.Simulation:
    """The block of :func:`_bonded_block` spread out to 2.5 radii (no sphere touches or lists another), every sphere
    moving towards the centre at 0.3 m/s: the spheres meet, their lists fill, and bonds form (cohesion on new
    contacts)."""
    model, state = _bonded_block().finalize(DEVICE)
    pos = state.body_pos.numpy()
    centre = pos.mean(axis=0)
    pos = centre + (pos - centre) * 2.5 / 1.98
    state.body_pos.assign(pos)
    d = centre - pos
    state.body_vel.assign(0.3 * d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12))
    return wd.Simulation(model, state, dt=0.3 * wd.pwave_timestep(model), cohesion_on_new_contacts=True,
                         always_use_moment_law=True, capacity_factor=1.0, contact_threads=contact_threads,
                         cpu_threads=threads)


def test_pair_entries_index_their_spheres_through_rebuilds_growth_and_loads(monkeypatch: object,
                                                                            tmp_path: object) -> None:
    # Reference: the CSR expansion of the lists' start and count in numpy (owner[k] = i on sphere i's entries,
    # -1 on free slots), after a run whose lists were rebuilt and grew (capacity factor 1: the first build's
    # needs, which the gathering spheres outgrow), and after loading checkpoints whose lists differ from the
    # simulation's: the first one's (smaller capacity, other entries) into the grown run, the grown run's into a
    # fresh simulation. On the CPU, two threads share the step (the size limit lowered): their parts cover the
    # entries and give the same bits as one thread (integer sums).
    from warpdem import cpu_threads

    monkeypatch.setattr(cpu_threads, "MIN_SPHERES_PER_THREAD", 8)
    first, grown = str(tmp_path / "first.npz"), str(tmp_path / "grown.npz")
    sims = []
    for threads in (1, 2):
        sim = _gathering("pair", threads)
        cap0 = sim.contacts.ss.capacity
        wd.checkpoint.save(sim, first)
        sim.advance(1500)
        sims.append(sim)
    sim = sims[-1]
    assert sim.rebuild_count > 0 and sim.contacts.ss.capacity > cap0
    assert wd.observers.contact_count(sim).sum() > 100  # the spheres did gather
    np.testing.assert_array_equal(sim.contacts.ss.owner.numpy(), _expected_owner(sim))
    if DEVICE == "cpu":
        assert sims[1].parts == 2
        for name in ("body_pos", "body_vel", "body_angvel"):
            np.testing.assert_array_equal(getattr(sims[1].state, name).numpy(), getattr(sims[0].state, name).numpy())
    wd.checkpoint.save(sim, grown)
    wd.checkpoint.load(sim, first)
    assert sim.contacts.ss.capacity == cap0
    np.testing.assert_array_equal(sim.contacts.ss.owner.numpy(), _expected_owner(sim))
    fresh = _gathering("pair", 1)
    wd.checkpoint.load(fresh, grown)
    assert fresh.contacts.ss.count.numpy().sum() > cap0
    np.testing.assert_array_equal(fresh.contacts.ss.owner.numpy(), _expected_owner(fresh))


@pytest.mark.parametrize("kwargs, word", [
    ({"contact_threads": "edge"}, "contact_threads must be one of"),
    ({"contact_threads": "pair", "world_steps": True}, "needs world_steps=False"),
])
def test_contact_threads_refuses_bad_input(kwargs: dict, word: str) -> None:
    model, state = _cradle(1)
    with pytest.raises(InputError, match=word):
        wd.Simulation(model, state, dt=0.2 * wd.pwave_timestep(model), **kwargs)
