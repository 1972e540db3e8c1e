"""Forces and torques are summed in fixed point (warpdem/accumulate.py): the sum does not depend on the order in
which contributions arrive, so a run repeats to the bit on CUDA as it does on the CPU."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
import warp as wp
from conftest import DEVICE
from test_worlds import packing_scene

import warpdem as wd
from warpdem import accumulate
from warpdem.errors import InputError


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
    out, out_t = wp.zeros(n, dtype=wp.vec3f, device=DEVICE), wp.zeros(n, dtype=wp.vec3f, device=DEVICE)
    sums = acc_f.numpy()
    wp.launch(accumulate.wrench_to_float_kernel, n, inputs=[acc_f, scale, acc_t, scale, 1], outputs=[out, out_t],
              device=DEVICE)
    assert not acc_f.numpy().any() and not acc_t.numpy().any()  # read and cleared for the next step
    np.testing.assert_array_equal(out_t.numpy(), out.numpy())  # the same contributions, the same resolution
    return sums, out.numpy(), plain.numpy()


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


@pytest.mark.parametrize("contact_threads", wd.Simulation.CONTACT_THREADS)
def test_a_chaotic_run_repeats_to_the_bit(contact_threads: str) -> None:
    # Reference: the same run again. 40 cohesive spheres with rolling resistance settle on a floor for 3,000 steps
    # (contacts form and break: a chaotic system in which any last-bit difference grows). On the CPU this holds by
    # construction; on CUDA (WARPDEM_TEST_DEVICE=cuda) it holds only because the force sums are order-independent,
    # with the contacts a thread per sphere or a thread per pair.
    def run() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        model, state = packing_scene(np.zeros(3)).finalize(DEVICE, n_worlds=2)
        sim = wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True, contact_threads=contact_threads)
        rec = sim.run(3000, record_every=500, observers={"floor": wd.observers.mesh_wrench("floor"),
                                                         "ke": wd.observers.group_kinetic_energy("soil")})
        return sim.state.body_pos.numpy(), rec["floor"], rec["ke"]

    first, again = run(), run()
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)
    assert np.abs(first[0][:, 2] - 0.03).max() > 1e-3  # the spheres did move


def threaded_scene() -> wd.ModelBuilder:
    """The packing of test_worlds with two clumps dropped on it, joined by a spring-dashpot: spheres, clumps, a
    mesh and a spring, every kind of contribution to the force sums."""
    b = packing_scene(np.zeros(3))
    a = b.add_clump(np.array([[-0.006, 0.0, 0.07], [0.0, 0.0, 0.07]]), np.array([0.005, 0.004]), "soil",
                    group="soil", name="clump_a")
    c = b.add_clump(np.array([[0.01, 0.004, 0.08], [0.016, 0.004, 0.08]]), np.array([0.004, 0.005]), "soil",
                    group="soil", name="clump_c")
    b.add_spring("tie", a, (-0.003, 0.0, 0.07), c, (0.013, 0.004, 0.08), stiffness=50.0, damping=0.05)
    return b


def _assert_same_bits(sim: wd.Simulation, ref: wd.Simulation) -> None:
    """Positions, orientations, velocities and the force sums of ``sim`` equal ``ref``'s to the bit."""
    for name in ("body_pos", "body_quat", "body_vel", "body_angvel"):
        np.testing.assert_array_equal(getattr(sim.state, name).numpy(), getattr(ref.state, name).numpy())
    for name in ("body_force", "body_torque", "mesh_force", "spring_force"):
        np.testing.assert_array_equal(getattr(sim.data, name).numpy(), getattr(ref.data, name).numpy())


def _blow_up(advance: Callable[[wd.Simulation], None], **sim_kwargs: object) -> tuple[int, str, int, int]:
    """(body, cause, step, world) of the SimulationError of tests/test_errors.py's scene: three worlds of two
    spheres, world 1's pushed deep into each other, run with a step 30x the critical one by ``advance``."""
    b = wd.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=2700, friction_angle=30))
    b.add_sphere((0, 0, 0), 0.01, "m")
    b.add_sphere((0.03, 0, 0), 0.01, "m")
    model, state = b.finalize(DEVICE, n_worlds=3)
    pos = state.body_pos.numpy()
    pos[3] = pos[2] + np.array([0.012, 0.0, 0.0])
    state.body_pos.assign(pos)
    sim = wd.Simulation(model, state, dt=30 * wd.pwave_timestep(model), force_dt=True, **sim_kwargs)
    try:
        advance(sim)
    except wd.SimulationError as e:
        return e.body, e.cause, e.step, e.world
    raise AssertionError("the run did not blow up")


def test_cpu_threads_give_the_same_bits(monkeypatch: object) -> None:
    # Reference: the same run on one thread. A step shared out between CPU threads (each thread a range of
    # spheres for the contacts, a range of bodies and their spheres for the motion, its own fixed-point
    # accumulators) must give the same positions, velocities and forces to the bit: integer sums do not depend on
    # the split. Three threads on 2 x 50 spheres (the size limit lowered so that this small scene is shared out),
    # run through advance (threads in parallel) and through step (the parts one after the other). The tracked
    # energies are float64 sums grouped by thread: equal to 1e-12 relative (float64 rounding of ~1e4 terms).
    if DEVICE != "cpu":
        return  # CUDA runs a step as one launch per kernel
    from warpdem import cpu_threads

    monkeypatch.setattr(cpu_threads, "MIN_SPHERES_PER_THREAD", 8)

    def run(threads: int, direct: bool = False) -> tuple[wd.Simulation, dict]:
        model, state = threaded_scene().finalize(DEVICE, n_worlds=2)
        sim = wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True, track_energy=True,
                            cpu_threads=threads)
        if direct:
            for _ in range(1500):
                sim.step()
            return sim, {}
        rec = sim.run(1500, record_every=300, observers={"floor": wd.observers.mesh_wrench("floor"),
                                                         "tie": wd.observers.spring_force("tie")})
        return sim, rec

    one, rec_one = run(1)
    three, rec_three = run(3)
    stepped, _ = run(3, direct=True)
    assert one.parts == 1 and three.parts == 3
    assert one.rebuild_count > 0  # the lists were rebuilt (and the contacts cut again)
    for sim in (three, stepped):
        _assert_same_bits(sim, one)
        np.testing.assert_allclose(sim.data.energy.numpy(), one.data.energy.numpy(), rtol=1e-12, atol=1e-18)
    for key in ("floor", "tie"):
        np.testing.assert_array_equal(rec_three[key], rec_one[key])
    assert np.abs(one.state.body_vel.numpy()).max() > 1e-3  # it moved
    assert one.data.energy.numpy().max() > 0.0  # and dissipated


def test_cpu_threads_resume_from_a_checkpoint_to_the_bit(monkeypatch: object, tmp_path: object) -> None:
    # Reference: the uninterrupted run on the same three threads. The contacts' cut between threads depends only on
    # the candidate lists, which the checkpoint keeps, so a resumed run groups even the energy sums as the
    # uninterrupted one: every array equal to the bit, energies included.
    if DEVICE != "cpu":
        return
    from warpdem import cpu_threads

    monkeypatch.setattr(cpu_threads, "MIN_SPHERES_PER_THREAD", 8)

    def make() -> wd.Simulation:
        model, state = threaded_scene().finalize(DEVICE, n_worlds=2)
        return wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True, track_energy=True, cpu_threads=3)

    a = make()
    a.advance(2100)  # by then the spheres' candidates have shifted the cut away from the first build's
    wd.checkpoint.save(a, tmp_path / "ck.npz")
    at_checkpoint, cut = a.rebuild_count, list(a.layout.contact_cut)
    a.advance(600)
    b = make()
    assert b.layout.contact_cut != cut
    wd.checkpoint.load(b, tmp_path / "ck.npz")
    assert b.layout.contact_cut == cut  # not the cut of b's own first build
    b.advance(600)
    assert a.parts == 3 and a.rebuild_count > at_checkpoint  # the lists were rebuilt (and cut again) after it
    for k in a.state.ARRAYS:
        np.testing.assert_array_equal(getattr(a.state, k).numpy(), getattr(b.state, k).numpy())
    np.testing.assert_array_equal(a.data.energy.numpy(), b.data.energy.numpy())


def test_cpu_threads_must_be_a_positive_integer(monkeypatch: object) -> None:
    # Reference: the error path of README (a named InputError naming the parameter and its value).
    model, state = packing_scene(np.zeros(3)).finalize(DEVICE)
    for bad, world_steps in ((0, False), (-2, False), (1.5, False), ("2", False), (0, True), ("2", True)):
        try:
            wd.Simulation(model, state, dt=2e-5, cpu_threads=bad, world_steps=world_steps)
        except wd.InputError as exc:
            assert "cpu_threads" in str(exc) and repr(bad) in str(exc)
        else:
            assert DEVICE != "cpu", bad  # ignored on CUDA
    monkeypatch.setenv("WARPDEM_CPU_THREADS", "zero")
    try:
        wd.Simulation(model, state, dt=2e-5)
    except wd.InputError as exc:
        assert "WARPDEM_CPU_THREADS" in str(exc) and "'zero'" in str(exc)
    else:
        assert DEVICE != "cpu"


def test_cpu_threads_report_the_fault_one_thread_reports(monkeypatch: object) -> None:
    # Reference: the same blow-up on one thread. Three worlds of two spheres, world 1's pushed deep into each other
    # with a step 30x the critical one (tests/test_errors.py's scene); on three threads (one world each) the error
    # names the same body, cause and step as on one.
    if DEVICE != "cpu":
        return
    from warpdem import cpu_threads

    monkeypatch.setattr(cpu_threads, "MIN_SPHERES_PER_THREAD", 1)

    def fault(threads: int) -> tuple[int, str, int, int]:
        def advance(sim: wd.Simulation) -> None:
            assert sim.parts == threads
            sim.advance(200)

        return _blow_up(advance, cpu_threads=threads)

    one = fault(1)
    assert one[3] == 1
    assert fault(3) == one


def test_several_steps_per_graph_give_the_steps_of_one_at_a_time() -> None:
    # Reference: the same run one step at a time (graph_steps=1: the step's launches replayed from Python, the
    # host reading the rebuild flag before every step). The several-steps path (what advance runs on CUDA: a
    # captured graph whose steps after the first run in conditional nodes that skip once a step flags a rebuild,
    # the host then rebuilding and going on) must give the same states, forces, step and rebuild counts to the bit.
    # On the CPU it is driven directly (there, advance uses one Warp CPU graph per step); the scene (spheres, clumps,
    # a mesh, a spring, falling: 49 rebuilds in 2,500 steps) makes the graphs end early and change length.
    def make(graph_steps: int) -> wd.Simulation:
        model, state = threaded_scene().finalize(DEVICE, n_worlds=2)
        return wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model), cohesion_on_new_contacts=True,
                             graph_steps=graph_steps)

    one = make(1)
    one.advance(2500)
    many = make(64)
    for n in (1700, 1, 799):  # a fault check every 64 steps and at the end of each call, as advance does
        many._advance_graphs(n)
    assert one.rebuild_count > 10
    assert many.state.step == one.state.step == 2500 and many.state.time == one.state.time
    np.testing.assert_array_equal(many.data.counters.numpy(), one.data.counters.numpy())
    _assert_same_bits(many, one)
    assert len(many._graphs) > 1  # graphs of several lengths were captured


def test_several_steps_per_graph_name_the_faulty_step() -> None:
    # Reference: the same blow-up one step at a time (the scene of test_cpu_threads_report_the_fault_one_thread_
    # reports): the fault recorded on the device inside a graph of several steps names the same body, cause, step.
    def fault(graph_steps: int) -> tuple[int, str, int, int]:
        def advance(sim: wd.Simulation) -> None:
            sim._advance_graphs(200) if graph_steps > 1 else sim.advance(200)

        return _blow_up(advance, graph_steps=graph_steps)

    one = fault(1)
    assert one[3] == 1
    assert fault(32) == one


def test_large_scene_motion_gives_the_bits_of_the_fused_one() -> None:
    # Reference: the same run with the fused motion kernel (force sums converted inside the integration). A scene
    # of LARGE_STEP_SPHERES spheres or more on CUDA converts its sums in a launch of their own and runs one step per
    # graph: the same arithmetic, so the same bits. Forced here on a small scene (on the CPU too).
    def run(large: bool) -> wd.Simulation:
        model, state = threaded_scene().finalize(DEVICE, n_worlds=2)
        sim = wd.Simulation(model, state, dt=2e-5, cohesion_on_new_contacts=True)
        sim.large_step = large
        sim.advance(800)
        return sim

    fused, split = run(False), run(True)
    _assert_same_bits(split, fused)
    assert np.abs(fused.state.body_vel.numpy()).max() > 1e-3  # it moved


def test_world_steps_give_the_bits_of_the_staged_step() -> None:
    # Reference: the same run stage by stage, one step at a time (graph_steps=1), contacts a thread per sphere (the
    # functions a world's thread calls; nvcc fuses a pair kernel's multiply-adds otherwise). With world_steps a thread
    # runs a world's whole steps (contacts, spring, motion, sphere update, the mesh's end of step, the world's own
    # rebuild check) until its lists need a rebuild; the host then rebuilds all worlds' lists and goes on. Three worlds
    # of different friction and damping (so they ask for rebuilds at different steps), spheres, clumps, a mesh and a
    # spring, falling and colliding, and a step that turns every contact cohesive midway: the same states and force sums
    # to the bit, at the same step and time. Only the rebuilds differ (each world's own, not any world's).
    over = {"material:soil:friction_angle": np.array([20.0, 30.0, 40.0]),
            "damping:soil": np.array([0.1, 0.3, 0.5])}

    def run(world_steps: bool) -> wd.Simulation:
        model, state = threaded_scene().finalize(DEVICE, n_worlds=3, overrides=over)
        sim = wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model), graph_steps=1,
                            world_steps=world_steps, contact_threads="sphere", track_energy=True)
        for n in (1200, 1, 57):
            sim.advance(n)
        sim.set_cohesion_now()
        sim.advance(1242)
        return sim

    staged, worlds = run(False), run(True)
    assert staged.rebuild_count > 10 and worlds.rebuild_count > 10
    assert worlds.state.step == staged.state.step == 2500 and worlds.state.time == staged.state.time
    _assert_same_bits(worlds, staged)
    # each world's energy terms get their contributions in the staged order (its spheres, then its bodies) on the
    # CPU; on CUDA they are float64 atomics added in whatever order the threads (the staged kernels' or a world's
    # lanes) reach them: 2,500 steps of a few additions each, every one rounding the running total by at most
    # 1.1e-16 of it, so within 1e-10 of the largest term
    if DEVICE == "cpu":
        np.testing.assert_array_equal(worlds.data.energy.numpy(), staged.data.energy.numpy())
    else:
        e_w, e_s = worlds.data.energy.numpy(), staged.data.energy.numpy()
        np.testing.assert_allclose(e_w, e_s, rtol=0, atol=1e-10 * np.abs(e_s).max())
    assert np.count_nonzero(staged.data.energy.numpy()) >= 6
    assert np.abs(staged.state.body_vel.numpy()).max() > 1e-2  # it moved


@pytest.mark.parametrize("stride", [1, 2])
def test_world_steps_by_a_block_of_threads_give_the_bits_of_the_staged_step(stride: int) -> None:
    # Reference: the same run stage by stage (graph_steps=1), contacts a thread per sphere. With world_lanes=4 each
    # world is a block of 4 threads (on the CPU, Warp's fibers with wp.config.enable_cpu_blocks): each stage's spheres,
    # springs, bodies and meshes dealt out between every stride-th of them (stride 2: threads 0 and 2 take items, as
    # CUDA's first thread of each warp does), a barrier between stages, lane 0 ending the step. A barrier left out or a
    # lane taking another branch shows as other bits (or a hang). Energies are float64 sums whose order follows the
    # lanes: equal to float64 rounding (see the test above).
    over = {"material:soil:friction_angle": np.array([20.0, 30.0, 40.0]),
            "damping:soil": np.array([0.1, 0.3, 0.5])}

    def run(world_steps: bool) -> wd.Simulation:
        model, state = threaded_scene().finalize(DEVICE, n_worlds=3, overrides=over)
        sim = wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model), graph_steps=1,
                            world_steps=world_steps, world_lanes=4 if world_steps else None,
                            world_lane_stride=stride if world_steps else None, contact_threads="sphere",
                            track_energy=True)
        for n in (600, 57):
            sim.advance(n)
        sim.set_cohesion_now()
        sim.advance(643)
        return sim

    blocks = wp.config.enable_cpu_blocks
    wp.config.enable_cpu_blocks = True
    try:
        staged, worlds = run(False), run(True)
    finally:
        wp.config.enable_cpu_blocks = blocks
    assert worlds.world_lanes == 4 and worlds.world_lane_stride == stride and worlds.rebuild_count > 5
    assert worlds.state.step == staged.state.step == 1300
    _assert_same_bits(worlds, staged)
    e_w, e_s = worlds.data.energy.numpy(), staged.data.energy.numpy()
    np.testing.assert_allclose(e_w, e_s, rtol=0, atol=1e-10 * np.abs(e_s).max())
    assert np.abs(staged.state.body_vel.numpy()).max() > 1e-2  # it moved


@pytest.mark.parametrize("stop_others", [False, True])
def test_pose_records_of_the_world_kernel_give_the_bits_of_host_reads(monkeypatch: object, stop_others: bool) -> None:
    # Reference: the same run with its observers called by the host after each record (wrapped, so that the run
    # cannot tell they read only poses). With world_steps, Simulation.run has the world kernel copy the observed
    # bodies' poses at every record and calls the observers on the copies, several records per hand-over: the same
    # times, steps and observer values to the bit, across list rebuilds, hand-overs (RECORD_CHUNK_STEPS made small
    # here), a cohesion step that runs staged at the start of a recorded advance (the kernel's records then count
    # it), and a run that is not a whole number of records (the last part recorded by the host). With stop_others
    # (CUDA's default where every world's block runs at once; forced here) a world that needs a rebuild stops the
    # others too: more rebuilds, the same bits.
    from warpdem import simulation

    monkeypatch.setattr(simulation, "RECORD_CHUNK_STEPS", 100)
    over = {"material:soil:friction_angle": np.array([20.0, 30.0, 40.0]),
            "damping:soil": np.array([0.1, 0.3, 0.5])}

    def run(wrap: bool) -> tuple[wd.Simulation, list[dict[str, np.ndarray]]]:
        model, state = threaded_scene().finalize(DEVICE, n_worlds=3, overrides=over)
        sim = wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model), world_steps=True)
        sim.world_stop_others = stop_others and not wrap  # read when the world launches are recorded
        obs = {"a": wd.observers.body_point("clump_a", (-0.003, 0.0, 0.07)),
               "c": wd.observers.body_point("clump_c", (0.013, 0.004, 0.08)),
               "a_com": wd.observers.body_point("clump_a", (-0.003, 0.0, 0.068))}
        if wrap:
            obs = {k: (lambda s_, f=f: f(s_)) for k, f in obs.items()}
        outs = [sim.run(1200, record_every=7, observers=obs)]
        rebuilds = sim.rebuild_count
        sim.set_cohesion_now()
        outs.append(sim.run(1003, record_every=9, observers=obs))
        assert sim.rebuild_count > rebuilds > 5
        return sim, outs

    (host, ref), (kernel, got) = run(True), run(False)
    if DEVICE == "cpu":
        assert kernel.world_stop_others == stop_others and not host.world_stop_others
        # stopping the others adds rebuilds (on the CPU a world's thread runs its worlds one after another)
        assert (kernel.rebuild_count > host.rebuild_count) == stop_others
    assert kernel._rec_bodies_host.tolist() == sorted(kernel.model.names["body"][n] for n in ("clump_a", "clump_c"))
    assert host._rec_bodies_host.size == 0  # the wrapped observers were read by the host
    for a, b in zip(got, ref, strict=True):
        assert sorted(a) == sorted(b) == sorted(["time", "step", "a", "c", "a_com"])
        for k in a:
            np.testing.assert_array_equal(a[k], b[k])
    assert len(got[0]["step"]) == 1 + 1200 // 7 + 1 and len(got[1]["step"]) == 1 + 1003 // 9 + 1
    assert np.ptp(got[1]["a"][:, :, 2]) > 1e-3  # the clumps moved while recorded
    _assert_same_bits(kernel, host)


def test_world_lanes_are_checked_by_name() -> None:
    model, state = threaded_scene().finalize(DEVICE, n_worlds=2)
    for bad in (0, 2000, 1.5, True):
        with pytest.raises(InputError, match="world_lanes"):
            wd.Simulation(model, state, dt=1e-5, world_steps=True, world_lanes=bad)
    for bad in (0, 3, 1.5, True):
        with pytest.raises(InputError, match="world_lane_stride"):
            wd.Simulation(model, state, dt=1e-5, world_steps=True, world_lanes=1, world_lane_stride=bad)
    if DEVICE == "cpu" and not wp.config.enable_cpu_blocks:
        with pytest.raises(InputError, match="enable_cpu_blocks"):
            wd.Simulation(model, state, dt=1e-5, world_steps=True, world_lanes=2)


def test_world_steps_name_the_faulty_step() -> None:
    # Reference: the same blow-up one step at a time: the first fault of the earliest step, named by body, cause,
    # step and world, whether each world ran its own steps or all ran stage by stage.
    one = _blow_up(lambda sim: sim.advance(200), graph_steps=1)
    assert one[3] == 1
    assert _blow_up(lambda sim: sim.advance(200), world_steps=True) == one


@pytest.mark.parametrize("world_steps", [False, True])
def test_mesh_force_sum_adds_each_steps_mesh_force(world_steps: bool) -> None:
    # Reference: the same run one step at a time, mesh_force read after every step and added on the host in
    # float64 (what the shear box did before the device kept the sum). The device's running sum over an advance
    # of many steps (several CUDA steps per graph; on the CPU, or with world_steps, whole steps per launch) must be
    # that sum to the bit: the same float32 forces, added in step order in float64.
    def run() -> wd.Simulation:
        model, state = threaded_scene().finalize(DEVICE, n_worlds=3)
        sim = wd.Simulation(model, state, dt=0.5 * wd.pwave_timestep(model), world_steps=world_steps)
        sim.advance(2000)  # the packing falls onto the floor (a mesh) and presses on it
        sim.data.mesh_force_sum.zero_()
        return sim

    one, many = run(), run()
    total = np.zeros(one.data.mesh_force_sum.shape + (3,))
    for _ in range(240):
        one.advance(1)
        total += one.data.mesh_force.numpy()
    many.advance(240)
    _assert_same_bits(many, one)
    np.testing.assert_array_equal(many.data.mesh_force_sum.numpy(), total)
    np.testing.assert_array_equal(one.data.mesh_force_sum.numpy(), total)
    assert np.abs(total).max() > 0.0  # the mesh carries load


_MODEL_BITS = """
import hashlib, numpy as np
from scenes.sweep import build_sweep
from warpdem import mass
rng = np.random.default_rng(7)
a = rng.normal(size=(500, 3, 3))
a = a + a.transpose(0, 2, 1) + 8 * np.eye(3)
w, v = mass.symmetric_eigen(a)
sweep = build_sweep()
moments, quat = mass.principal_axes(sweep.inertia)
rot = mass.quat_to_matrix(quat)
local = mass.rows_times(sweep.lower.vertices - sweep.com, rot)
quats = np.array([mass.matrix_to_quat(m) for m in v])
mats = np.array([mass.quat_to_matrix(q) for q in rng.normal(size=(500, 4))])
norms = mass.norm(rng.normal(size=(500, 3)))
print(hashlib.sha256(b"".join(np.ascontiguousarray(x).tobytes()
                              for x in (w, v, moments, quat, local, quats, mats, norms))).hexdigest())
"""


def _blas_kernels() -> list[str]:
    """OpenBLAS core types this CPU can run: Prescott (SSE3) always, Haswell with AVX2, SkylakeX with AVX-512."""
    try:
        flags = set(open("/proc/cpuinfo").read().split())
    except OSError:
        flags = set()
    return ["Prescott"] + [k for k, f in (("Haswell", "avx2"), ("SkylakeX", "avx512f")) if f in flags]


def test_principal_axes_match_lapack_and_keep_their_bits_whatever_blas_kernel_runs() -> None:
    """The principal axes (``mass.symmetric_eigen``, Jacobi rotations in element-wise arithmetic) against LAPACK's
    ``eigh``: eigenvalues within 8 ulp of the largest, residual |A v - v w| and orthonormality within 1e-14 (a
    backward-stable solver's bound at this size), a right-handed frame; degenerate tensors (a two-sphere clump's
    equal moments, a sphere's three) included. Then the model's numbers that LAPACK / BLAS computed before (eigen-
    decompositions, a body's principal frame, its mesh in that frame) are hashed in fresh interpreters under each
    OpenBLAS kernel this CPU runs: the same bits under all of them (LAPACK's differed in the last bits between the
    Prescott and Haswell kernels, and so did every run with a body in it)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    from warpdem.mass import symmetric_eigen

    rng = np.random.default_rng(3)
    g = rng.normal(size=(300, 3, 3))
    rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    a = np.concatenate([g @ g.transpose(0, 2, 1) + 1e-3 * np.eye(3),
                        np.stack([np.diag([1.0, 1.0, 2.0]), rot @ np.diag([1.0, 1.0, 2.0]) @ rot.T, 5.0 * np.eye(3),
                                  rot @ np.diag([1e-9, 1.0, 1.0]) @ rot.T])])
    w, v = symmetric_eigen(a)
    scale = np.abs(a).max(axis=(1, 2))
    assert np.all(np.abs(w - np.linalg.eigh(a)[0]) <= 8 * np.finfo(float).eps * scale[:, None])
    assert np.all(np.abs(np.einsum("cij,cjk->cik", a, v) - v * w[:, None, :]) <= 1e-14 * scale[:, None, None])
    assert np.all(np.abs(np.einsum("cji,cjk->cik", v, v) - np.eye(3)) <= 1e-14)
    assert np.all(np.abs(np.linalg.det(v) - 1.0) <= 1e-14)
    one_w, one_v = symmetric_eigen(a[7])
    assert np.array_equal(one_w[0], w[7]) and np.array_equal(one_v[0], v[7])  # alone as in a batch

    root = Path(__file__).resolve().parents[1]
    hashes = {}
    for kernel in _blas_kernels():
        path = os.pathsep.join(p for p in (str(root), os.environ.get("PYTHONPATH", "")) if p)
        env = {**os.environ, "OPENBLAS_CORETYPE": kernel, "PYTHONPATH": path}
        out = subprocess.run([sys.executable, "-c", _MODEL_BITS], env=env, capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        hashes[kernel] = out.stdout.strip()
    assert len(set(hashes.values())) == 1, hashes
