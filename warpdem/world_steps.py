"""Many steps in one launch, a block of threads per world: for scenes of many small worlds (a GA population of
ringing rigs).

A step of a small world is a handful of spheres, contacts and bodies, while a launch costs the same however little
it does: a batch of 13 ringing rigs (52 spheres) spends its step in the latency of its seven launches. Here one
block runs one world's whole step, the stages in the order of :meth:`Simulation._launch_step` (sphere-sphere and
sphere-triangle contacts and springs, body motion with its fault check, sphere kinematics and the meshes' end of
step), each stage's items dealt out between the block's threads (``WORLD_LANES`` on CUDA, one on the CPU by default;
``Simulation(world_lanes=...)``) with a barrier between stages; it then decides as the end-of-step kernel does
whether its candidate lists still hold (the world's own displacements against the skin), and goes on to the next
step, up to ``target`` steps or until its lists need a rebuild. The host then rebuilds the lists of all worlds and
launches again until every world has reached ``target``.

Each stage is the same function that the one-stage kernels call per sphere, body or mesh, and a world's forces come
only from its own bodies: with the fixed-point force sums (accumulate.py) every world's positions, velocities and
forces are the bits of the stage-by-stage step, however the items of a stage are dealt out. Worlds reach ``target``
after different rebuilds, which changes nothing but the candidates' order (a rebuild keeps every contact's
history). A fault is kept per world (the first step's, lowest body) and the host reports the earliest.

Two things keep the host out of the way (on CUDA a hand-over costs more than a ringing batch's 57 steps): the
kernel can copy chosen bodies' poses at every record (``Simulation.run``'s pose observers), so one launch covers
thousands of steps; and where all the launch's blocks run at once, a world that needs a rebuild stops the others
(``stop_others``), so that one host rebuild serves all and the next launch runs them side by side again.
"""

from __future__ import annotations

import warp as wp

from .accumulate import vec3l
from .contact_law import Hist
from .contacts import LawOptions, Materials, sphere_sphere_one, sphere_triangle_one
from .data import NO_FAULT
from .integrator import integrate_body, mesh_end_one, spring_one, update_sphere

wp.set_module_options({"enable_backward": False})

NO_FAULT_W = wp.constant(NO_FAULT)
vec4l = wp.types.vector(4, wp.int64)
FAULT_SLOTS = 6
"""per world in ``world_fault``: the step's fault (body, cause, step), then the world's first (body, cause, step)."""
WORLD_LANES = 32
"""threads per world on CUDA for a world of many items (one warp, every thread taking items): a world's items of a
stage run side by side. A single GPU thread runs a step's contact law, leapfrog and kinematics one item after
another at the latency of each dependent instruction."""
WARP = 32
"""threads of a CUDA warp. Threads of one warp that take different branches run one branch after the other, so a
small world gives each item its own warp (``lane_layout``): a sphere's contacts, a spring and a body then run side
by side instead of in turn."""
MAX_ITEM_WARPS = 8
"""warps per world at most when each item has its own warp: the kernel takes up to 255 registers a thread, and
an SM's 65,536 registers hold 256 such threads."""
DISP_SLOTS = 3
"""per world in ``world_disp``: the meshes' largest displacement, the spheres' (since the last list build) [m], and
1 where another world has stopped for a rebuild (``stop_others``)."""
STAGES = ("contacts", "bodies", "spheres", "end")
"""the stages of a world's step, as timed in ``stage_cycles``: contacts and springs; body motion; sphere kinematics
and the meshes' end of step; the end-of-step decision."""


@wp.func_native("""
#if defined(__CUDA_ARCH__)
return clock64();
#else
return 0;
#endif
""")
def cycle_count() -> wp.int64:
    """The SM's clock counter on CUDA (cycles); 0 on the CPU."""
    ...


def stage_items(spw: int, bpw: int, mpw: int, kpw: int) -> int:
    """The most items of one stage of a world's step: the contacts' (a sphere's sphere and triangle candidates, a
    spring), the bodies, or the spheres' and meshes' end of step."""
    return max(spw * (2 if mpw > 0 else 1) + kpw, bpw, spw + mpw)


def lane_layout(spw: int, bpw: int, mpw: int, kpw: int) -> tuple[int, int]:
    """CUDA's default (threads per world, stride) for a world of these spheres, bodies, meshes and springs: at most
    2 * MAX_ITEM_WARPS items in every stage, an item per warp (the first thread of each of up to MAX_ITEM_WARPS
    warps takes items, stride WARP); more, one warp of WORLD_LANES threads that all take items (stride 1)."""
    items = stage_items(spw, bpw, mpw, kpw)
    if items <= 2 * MAX_ITEM_WARPS:
        return WARP * max(1, min(MAX_ITEM_WARPS, items)), WARP
    return WORLD_LANES, 1


@wp.func_native("WP_TILE_SYNC();")
def block_sync():
    """A barrier for the threads of a block: CUDA's __syncthreads(); on the CPU a fiber switch where a block has
    several threads (``wp.config.enable_cpu_blocks``), nothing where it has one."""
    ...


@wp.kernel
def world_steps_kernel(
    first_world: int,  # the first world of this launch (a CPU thread's share)
    lanes: int,  # threads per world (the launch's block size): 1 on the CPU
    stride: int,  # every stride-th thread of the block takes items (lanes a multiple of it)
    target: int,
    first_step: int,  # the simulation's step count when world_step was 0
    skin: float,
    dt: wp.float64,
    spw: int,  # spheres, bodies, meshes and springs per world
    bpw: int,
    mpw: int,
    kpw: int,
    rec_every: int,  # recording (Simulation.run's pose observers): every rec_every-th step, 0 for none
    rec_shift: int,  # steps of the recording that ran before this advance's world_step 0
    rec_nb: int,  # bodies recorded per world (local indices in rec_bodies)
    n_worlds: int,
    stop_others: int,  # 1: a world that needs a rebuild stops the others (all worlds' blocks resident at once)
    # Model:
    sphere_body: wp.array(dtype=int),
    sphere_world: wp.array(dtype=int),
    sphere_material: wp.array(dtype=int),
    sphere_radius: wp.array(dtype=wp.float64),
    sphere_offset: wp.array(dtype=wp.vec3f),
    mesh_body: wp.array(dtype=int),
    mesh_material: wp.array(dtype=int),
    mesh_tri_offset: wp.array(dtype=int),
    mesh_rmax: wp.array(dtype=float),
    tri_vertices: wp.array(dtype=wp.vec3d),
    spring_body_a: wp.array(dtype=int),
    spring_body_b: wp.array(dtype=int),
    spring_point_a: wp.array(dtype=wp.vec3f),
    spring_point_b: wp.array(dtype=wp.vec3f),
    spring_stiffness: wp.array(dtype=float),
    spring_damping: wp.array(dtype=float),
    spring_rest_length: wp.array(dtype=float),
    spring_preload: wp.array(dtype=float),
    spring_progressive: wp.array(dtype=float),
    spring_stop_stiffness: wp.array(dtype=float),
    body_world: wp.array(dtype=int),
    body_group: wp.array(dtype=int),
    body_flags: wp.array(dtype=int),
    body_mass: wp.array(dtype=wp.float64),
    body_inertia: wp.array(dtype=wp.vec3d),
    body_pivot: wp.array(dtype=wp.vec3d),
    body_pivot_vel: wp.array(dtype=wp.vec3d),
    body_pivot_friction: wp.array(dtype=wp.float64),
    group_damping: wp.array(dtype=float),
    n_groups: int,
    gravity: wp.vec3d,
    mats: Materials,
    opts: LawOptions,
    max_speed: wp.float64,
    lower: wp.vec3d,
    upper: wp.vec3d,
    # Data in/out:
    sphere_pos: wp.array(dtype=wp.vec3d),
    sphere_vel: wp.array(dtype=wp.vec3f),
    sphere_angvel: wp.array(dtype=wp.vec3f),
    sphere_arm: wp.array(dtype=wp.vec3f),
    build_pos: wp.array(dtype=wp.vec3d),
    mesh_build_pos: wp.array(dtype=wp.vec3d),
    mesh_build_quat: wp.array(dtype=wp.quatd),
    ss_start: wp.array(dtype=int),
    ss_count: wp.array(dtype=int),
    ss_other: wp.array(dtype=int),
    ss_hist: wp.array(dtype=Hist),
    st_start: wp.array(dtype=int),
    st_count: wp.array(dtype=int),
    st_mesh: wp.array(dtype=int),
    st_face: wp.array(dtype=int),
    st_hist: wp.array(dtype=Hist),
    no_cohesion: wp.array(dtype=int),
    body_pos: wp.array(dtype=wp.vec3d),
    body_quat: wp.array(dtype=wp.quatd),
    body_vel: wp.array(dtype=wp.vec3d),
    body_angvel: wp.array(dtype=wp.vec3d),
    body_angmom: wp.array(dtype=wp.vec3d),
    force_acc: wp.array(dtype=vec3l),
    torque_acc: wp.array(dtype=vec3l),
    force_scale: wp.array(dtype=wp.float64),
    torque_scale: wp.array(dtype=wp.float64),
    mesh_force_acc: wp.array(dtype=vec3l),
    mesh_torque_acc: wp.array(dtype=vec3l),
    mesh_force_scale: wp.array(dtype=wp.float64),
    mesh_torque_scale: wp.array(dtype=wp.float64),
    energy: wp.array(dtype=wp.float64),
    # Data out:
    body_force: wp.array(dtype=wp.vec3f),
    body_torque: wp.array(dtype=wp.vec3f),
    mesh_force: wp.array(dtype=wp.vec3f),
    mesh_torque: wp.array(dtype=wp.vec3f),
    mesh_force_sum: wp.array(dtype=wp.vec3d),
    spring_force: wp.array(dtype=float),
    world_step: wp.array(dtype=int),
    world_flag: wp.array(dtype=int),
    world_disp: wp.array(dtype=float),
    world_fault: wp.array(dtype=int),
    world_stop: wp.array(dtype=int),
    stage_cycles: wp.array(dtype=wp.int64),
    rec_bodies: wp.array(dtype=int),
    rec_pos: wp.array(dtype=wp.vec3d),
    rec_quat: wp.array(dtype=wp.quatd),
):
    """World w's steps from world_step[w] up to ``target`` or until its candidate lists need a rebuild
    (world_flag[w] = 1), by a block of ``lanes`` threads: each stage's items (spheres, bodies, meshes, springs) dealt
    out between every ``stride``-th of them, a barrier between stages. The one-step request for cohesion
    (``Data.cohesion_now``) is not read: the caller runs such a step the ordinary way; ``no_cohesion`` is a zero
    flag passed in its place.

    ``stage_cycles`` (int64, shape (n_worlds * 4,), CUDA clock cycles; zeros on the CPU) adds up, per world and
    stage of ``STAGES``, the stage's time with its barrier as lane 0 sees it. (The other warps' own times did not
    split a stage reliably on an H100: threads without items showed thousands of cycles.)

    Recording (``rec_every`` > 0): after every step j = world_step + 1 + ``rec_shift`` that is a multiple of
    ``rec_every``, the poses of the world's bodies ``rec_bodies`` (local indices, (rec_nb,)) go to record
    r = j / rec_every - 1 of ``rec_pos`` [m] and ``rec_quat`` (x, y, z, w), each flattened from
    (records, n_worlds, rec_nb): the state the host would read after that step, without a launch per record.

    ``stop_others`` = 1: a world that needs a rebuild also sets ``world_stop`` (1,), and every world ends its advance
    after the step in which it sees it, so that the host rebuilds once for all and the next launch runs them side by
    side again (otherwise the worlds that did not stop run to ``target`` and the stopped one finishes alone
    afterwards). Only where all the launch's blocks run at once: a block that starts late would see the flag at its
    first step. A rebuild changes only the order of candidates, so this changes no bits."""
    t, lane = wp.tid()
    w = t + first_world
    k = world_step[w]
    s0 = w * spw
    b0 = w * bpw
    m0 = w * mpw
    c0 = w * kpw
    fb = w * FAULT_SLOTS
    dm = w * DISP_SLOTS
    contact_items = spw
    if mpw > 0:
        contact_items = 2 * spw
    slot = lane // stride  # a thread that takes items: slot ``slot`` of ``slots``
    slots = lanes // stride
    if lane % stride != 0:
        slot = 1 << 29  # takes none
    wall = vec4l()  # cycles per stage with its barrier (lane 0's are kept)
    while k < target:
        c_0 = cycle_count()
        # contacts and springs: they only add to the fixed-point sums, whose order does not matter
        for q in range(slot, contact_items + kpw, slots):
            if q >= contact_items:
                spring_one(
                    c0 + q - contact_items, spring_body_a, spring_body_b, spring_point_a, spring_point_b,
                    spring_stiffness, spring_damping, spring_rest_length, spring_preload, spring_progressive,
                    spring_stop_stiffness, body_world, opts.dt, opts.track_energy, body_pos, body_quat, body_vel,
                    body_angvel, force_acc, torque_acc, force_scale, torque_scale, spring_force, energy)
            elif q < spw:
                sphere_sphere_one(
                    s0 + q, sphere_body, sphere_world, sphere_material, sphere_radius, mats, opts, sphere_pos,
                    sphere_vel, sphere_angvel, sphere_arm, ss_start, ss_count, ss_other, no_cohesion, ss_hist,
                    force_acc, torque_acc, force_scale, torque_scale, energy)
            else:
                sphere_triangle_one(
                    s0 + q - spw, sphere_body, sphere_world, sphere_material, sphere_radius, mesh_body,
                    mesh_material, mesh_tri_offset, tri_vertices, mats, opts, sphere_pos, sphere_vel, sphere_angvel,
                    sphere_arm, body_pos, body_quat, body_vel, body_angvel, st_start, st_count, st_mesh, st_face,
                    no_cohesion, st_hist, force_acc, torque_acc, force_scale, torque_scale, mesh_force_acc,
                    mesh_torque_acc, mesh_force_scale, mesh_torque_scale, energy)
        block_sync()
        c_2 = cycle_count()
        step = first_step + k + 1
        for b in range(b0 + slot, b0 + bpw, slots):
            integrate_body(
                b, body_world, body_group, body_flags, body_mass, body_inertia, body_pivot, body_pivot_vel,
                body_pivot_friction, group_damping, n_groups, gravity, dt, opts.track_energy,
                force_scale, torque_scale, 1, 0, max_speed, lower, upper, step, fb, force_acc, torque_acc, body_pos,
                body_quat, body_vel, body_angvel, body_angmom, energy, body_force, body_torque, world_fault)
        block_sync()
        c_4 = cycle_count()
        for q in range(slot, spw + mpw, slots):
            if q < spw:
                update_sphere(s0 + q, sphere_body, sphere_offset, body_pos, body_quat, body_vel, body_angvel,
                              sphere_pos, sphere_vel, sphere_angvel, sphere_arm, build_pos, dm + 1, world_disp)
            else:
                mesh_end_one(m0 + q - spw, dm, mesh_body, mesh_rmax, mesh_force_scale, mesh_torque_scale, 1,
                             body_pos, body_quat, mesh_build_pos, mesh_build_quat, mesh_force_acc, mesh_torque_acc,
                             mesh_force, mesh_torque, mesh_force_sum, world_disp)
        if stop_others != 0 and lane == 0:  # another world's stop, read coherently (an atomic) for the whole block
            world_disp[dm + 2] = float(wp.atomic_add(world_stop, 0, 0))
        if rec_every > 0:  # the poses are final once the body stage's barrier has passed
            j = k + 1 + rec_shift
            if j % rec_every == 0:
                r0 = ((j // rec_every - 1) * n_worlds + w) * rec_nb
                for q in range(slot, rec_nb, slots):
                    rec_pos[r0 + q] = body_pos[b0 + rec_bodies[q]]
                    rec_quat[r0 + q] = body_quat[b0 + rec_bodies[q]]
        k += 1
        block_sync()
        c_6 = cycle_count()
        # the end of the step, for this world (simulation._end_step_kernel): every lane reads the displacements
        # and takes the same decision; then lane 0 resets them and files the step's fault
        ds = world_disp[dm + 1]
        rebuild = spw > 0 and ds + wp.max(ds, world_disp[dm]) > skin  # no spheres: no lists to rebuild
        stopped = world_disp[dm + 2] != 0.0
        block_sync()
        if lane == 0:
            if world_fault[fb] != NO_FAULT_W:
                if world_fault[fb + 3] == NO_FAULT_W:
                    world_fault[fb + 3] = world_fault[fb]
                    world_fault[fb + 4] = world_fault[fb + 1]
                    world_fault[fb + 5] = world_fault[fb + 2]
                world_fault[fb] = NO_FAULT_W
            world_disp[dm] = 0.0
            world_disp[dm + 1] = 0.0
            if rebuild:
                world_flag[w] = 1
                if stop_others != 0:
                    wp.atomic_max(world_stop, 0, 1)
        c_7 = cycle_count()
        wall += vec4l(c_2 - c_0, c_4 - c_2, c_6 - c_4, c_7 - c_6)
        if rebuild or stopped:
            break
    if lane == 0:
        world_step[w] = k
        for q in range(4):
            stage_cycles[w * 4 + q] = stage_cycles[w * 4 + q] + wall[q]


@wp.kernel
def world_end_kernel(
    n_steps: int,
    rebuilds: int,
    n_worlds: int,
    world_flag: wp.array(dtype=int),
    world_fault: wp.array(dtype=int),
    counters: wp.array(dtype=int),
    rebuild_flag: wp.array(dtype=int),
    fault: wp.array(dtype=int),
):
    """After an advance of ``n_steps`` by world_steps_kernel with ``rebuilds`` host rebuilds (one thread): count the
    steps and rebuilds (``Data.counters``), ask for a rebuild before the next step if a world's last step needs one,
    and keep the worlds' earliest first fault (the lowest body at that step) unless an earlier one is kept."""
    last = int(0)
    best = int(-1)
    for w in range(n_worlds):
        if world_flag[w] != 0:
            last = 1
        b = w * FAULT_SLOTS + 3
        if world_fault[b] != NO_FAULT_W:
            if best < 0:
                best = b
            elif world_fault[b + 2] < world_fault[best + 2]:
                best = b
    counters[0] = counters[0] + n_steps
    counters[1] = counters[1] + rebuilds + last
    rebuild_flag[0] = last
    if best >= 0 and fault[0] == NO_FAULT_W:
        fault[0] = world_fault[best]
        fault[1] = world_fault[best + 1]
        fault[2] = world_fault[best + 2]
