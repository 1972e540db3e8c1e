"""Many steps in one launch, a block of threads per world: for scenes of many small worlds (a GA population of
ringing rigs).

A step of a small world is a handful of spheres, contacts and bodies, while a launch costs the same however little
it does: a batch of 13 ringing rigs (52 spheres) spends its step in the latency of its seven launches. Here one
block runs one world's whole step, the stages in the order of ``stages.segments`` (sphere-sphere and
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

from typing import Any

import warp as wp

from .contacts import sphere_sphere_one, sphere_triangle_one
from .data import NO_FAULT
from .integrator import integrate_body, keep_first_fault, mesh_end_one, spring_one, update_sphere
from .kernel_args import (
    Bodies,
    BodyState,
    Meshes,
    SphereList,
    Spheres,
    SphereState,
    Springs,
    Sums,
    TriangleList,
)
from .laws import overload_per_law
from .types import Options

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


@wp.struct
class Advance:
    """What changes between two advances of :func:`world_steps_kernel` (its first parameter, set again on the
    recorded launches)."""

    target: int
    """the step (counted from the advance's start) each world runs up to."""
    first_step: int
    """the simulation's step count when the worlds' step counts were 0 (for fault records)."""
    rec_every: int
    """recording (Simulation.run's pose observers): every rec_every-th step, 0 for none."""
    rec_shift: int
    """steps of the recording that ran before this advance's step 0."""
    rec_nb: int
    """bodies recorded per world (local indices in ``Worlds.rec_bodies``)."""


@wp.struct
class Worlds:
    """The layout of a world's block and the per-world arrays of :func:`world_steps_kernel` (Simulation's)."""

    lanes: int
    """threads per world (the launch's block size): 1 on the CPU by default."""
    stride: int
    """every stride-th thread of a block takes items (``lanes`` a multiple of it)."""
    spw: int
    """spheres per world."""
    bpw: int
    """bodies per world."""
    mpw: int
    """mesh instances per world."""
    kpw: int
    """springs per world."""
    n_worlds: int
    """worlds of the simulation."""
    stop_others: int
    """1: a world that needs a rebuild stops the others (all worlds' blocks resident at once)."""
    step: wp.array(dtype=int)
    """steps each world has run in this advance, int32 (n_worlds,)."""
    flag: wp.array(dtype=int)
    """1: the world's lists need a rebuild, int32 (n_worlds,)."""
    disp: wp.array(dtype=float)
    """per world DISP_SLOTS entries: the meshes' and spheres' largest displacements [m], another world's stop,
    float32 (n_worlds * DISP_SLOTS,)."""
    fault: wp.array(dtype=int)
    """per world FAULT_SLOTS entries: the step's fault, the world's first (body, cause, step), int32."""
    stop: wp.array(dtype=int)
    """1: a world has stopped for a rebuild (``stop_others``), int32 (1,)."""
    stage_cycles: wp.array(dtype=wp.int64)
    """CUDA clock cycles per world and stage of STAGES (zeros on the CPU), int64 (n_worlds * 4,)."""
    rec_bodies: wp.array(dtype=int)
    """local indices of the bodies whose poses are recorded, int32 (rec_nb,)."""
    rec_pos: wp.array(dtype=wp.vec3d)
    """recorded positions [m], vec3d (records * n_worlds * rec_nb,)."""
    rec_quat: wp.array(dtype=wp.quatd)
    """recorded orientations (x, y, z, w), quatd (records * n_worlds * rec_nb,)."""


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def contact_stage(w: int, slot: int, slots: int, ws: Worlds, spheres: Spheres, meshes: Meshes, springs: Springs,
                  bodies: Bodies, mats: Any, opts: Options, kin: SphereState, state: BodyState, ss: SphereList,
                  st: TriangleList, no_cohesion: wp.array(dtype=int), sums: Sums):
    """World w's contacts and springs, items slot, slot + slots, ...: its spheres' sphere-sphere candidates, then
    (with meshes) their sphere-triangle candidates, then its springs. They only add to the fixed-point sums, whose
    order does not matter."""
    spw = ws.spw
    s0 = w * spw
    contact_items = spw
    if ws.mpw > 0:
        contact_items = 2 * spw
    for q in range(slot, contact_items + ws.kpw, slots):
        if q >= contact_items:
            spring_one(w * ws.kpw + q - contact_items, springs, bodies, opts, state, sums)
        elif q < spw:
            sphere_sphere_one(s0 + q, spheres, mats, opts, kin, ss, no_cohesion, sums)
        else:
            sphere_triangle_one(s0 + q - spw, spheres, meshes, mats, opts, kin, state, st, no_cohesion, sums)


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def sphere_stage(w: int, slot: int, slots: int, ws: Worlds, spheres: Spheres, meshes: Meshes, state: BodyState,
                 kin: SphereState, sums: Sums, build_pos: wp.array(dtype=wp.vec3d),
                 mesh_build_pos: wp.array(dtype=wp.vec3d), mesh_build_quat: wp.array(dtype=wp.quatd)):
    """World w's sphere kinematics and its meshes' end of step, items slot, slot + slots, ...: the spheres'
    largest displacement since the list build [m] into ws.disp[w * DISP_SLOTS + 1], the meshes' into
    ws.disp[w * DISP_SLOTS]."""
    spw = ws.spw
    dm = w * DISP_SLOTS
    for q in range(slot, spw + ws.mpw, slots):
        if q < spw:
            update_sphere(w * spw + q, spheres, state, kin, build_pos, dm + 1, ws.disp)
        else:
            mesh_end_one(w * ws.mpw + q - spw, dm, meshes, 1, state, mesh_build_pos, mesh_build_quat, sums, ws.disp)


@wp.func(inline=True)  # inlined: no copies of its array arguments per call
def record_poses(w: int, slot: int, slots: int, j: int, adv: Advance, ws: Worlds, state: BodyState):
    """After step j of the recording (a multiple of adv.rec_every), world w's recorded bodies' poses (position
    [m], orientation) into record j / rec_every - 1 of ws.rec_pos and ws.rec_quat, items slot, slot + slots, ..."""
    b0 = w * ws.bpw
    r0 = ((j // adv.rec_every - 1) * ws.n_worlds + w) * adv.rec_nb
    for q in range(slot, adv.rec_nb, slots):
        ws.rec_pos[r0 + q] = state.pos[b0 + ws.rec_bodies[q]]
        ws.rec_quat[r0 + q] = state.quat[b0 + ws.rec_bodies[q]]


@wp.func(inline=True)
def needs_rebuild(w: int, ws: Worlds, opts: Options):
    """World w at the end of its step (stages._end_step_kernel, for one world): returns (rebuild, stopped):
    whether its candidate lists need a rebuild (its spheres' and meshes' displacements against opts.skin; no
    spheres, no lists) and whether another world has stopped for one (``stop_others``)."""
    dm = w * DISP_SLOTS
    ds = ws.disp[dm + 1]
    rebuild = ws.spw > 0 and ds + wp.max(ds, ws.disp[dm]) > opts.skin
    return rebuild, ws.disp[dm + 2] != 0.0


@wp.func(inline=True)
def file_step_end(w: int, rebuild: bool, ws: Worlds):
    """World w's end of step, by one thread: the step's fault kept as the world's first unless it has one, the
    displacements reset, the rebuild flagged (and, with ``stop_others``, the other worlds stopped)."""
    fb = w * FAULT_SLOTS
    dm = w * DISP_SLOTS
    if ws.fault[fb] != NO_FAULT_W:
        keep_first_fault(ws.fault, fb, ws.fault, fb + 3)
        ws.fault[fb] = NO_FAULT_W
    ws.disp[dm] = 0.0
    ws.disp[dm + 1] = 0.0
    if rebuild:
        ws.flag[w] = 1
        if ws.stop_others != 0:
            wp.atomic_max(ws.stop, 0, 1)


@wp.kernel
def world_steps_kernel(
    adv: Advance,
    first_world: int,  # the first world of this launch (a CPU thread's share)
    ws_in: Worlds,
    spheres_in: Spheres,
    meshes_in: Meshes,
    springs_in: Springs,
    bodies_in: Bodies,
    mats: Any,
    opts_in: Options,
    kin_in: SphereState,  # in/out
    state_in: BodyState,  # in/out
    ss_in: SphereList,  # in/out: the history
    st_in: TriangleList,  # in/out: the history
    no_cohesion: wp.array(dtype=int),
    sums_in: Sums,  # the whole accumulators (one part), the float sums, the energy terms
    build_pos: wp.array(dtype=wp.vec3d),
    mesh_build_pos: wp.array(dtype=wp.vec3d),
    mesh_build_quat: wp.array(dtype=wp.quatd),
):
    """World w's steps from ws.step[w] up to ``adv.target`` or until its candidate lists need a rebuild
    (ws.flag[w] = 1), by a block of ``ws.lanes`` threads: each stage's items (spheres, bodies, meshes, springs) dealt
    out between every ``ws.stride``-th of them, a barrier between stages. The one-step request for cohesion
    (``Data.cohesion_now``) is not read: the caller runs such a step the ordinary way; ``no_cohesion`` is a zero
    flag passed in its place.

    ``ws.stage_cycles`` (int64, shape (n_worlds * 4,), CUDA clock cycles; zeros on the CPU) adds up, per world and
    stage of ``STAGES``, the stage's time with its barrier as lane 0 sees it. (The other warps' own times did not
    split a stage reliably on an H100: threads without items showed thousands of cycles.)

    Recording (``adv.rec_every`` > 0): after every step j = world_step + 1 + ``adv.rec_shift`` that is a multiple of
    ``adv.rec_every``, the poses of the world's bodies ``ws.rec_bodies`` (local indices, (rec_nb,)) go to record
    r = j / rec_every - 1 of ``ws.rec_pos`` [m] and ``ws.rec_quat`` (x, y, z, w), each flattened from
    (records, n_worlds, rec_nb): the state the host would read after that step, without a launch per record.

    ``ws.stop_others`` = 1: a world that needs a rebuild also sets ``ws.stop`` (1,), and every world ends its advance
    after the step in which it sees it, so that the host rebuilds once for all and the next launch runs them side by
    side again (otherwise the worlds that did not stop run to ``target`` and the stopped one finishes alone
    afterwards). Only where all the launch's blocks run at once: a block that starts late would see the flag at its
    first step. A rebuild changes only the order of candidates, so this changes no bits."""
    t, lane = wp.tid()
    # Local copies of the struct arguments (``*_in``; ``mats`` keeps its name for the overloads): on CUDA the step
    # loop would otherwise load every field again from the kernel's parameters at each use and redo its index
    # arithmetic (benchmarks/README.md, "The law chosen at compile time").
    ws = ws_in
    spheres = spheres_in
    meshes = meshes_in
    springs = springs_in
    bodies = bodies_in
    opts = opts_in
    kin = kin_in
    state = state_in
    ss = ss_in
    st = st_in
    sums = sums_in
    tables = mats  # (the overloads name the argument mats)
    w = t + first_world
    k = ws.step[w]
    b0 = w * ws.bpw
    slot = lane // ws.stride  # a thread that takes items: slot ``slot`` of ``slots``
    slots = ws.lanes // ws.stride
    if lane % ws.stride != 0:
        slot = 1 << 29  # takes none
    wall = vec4l()  # cycles per stage with its barrier (lane 0's are kept)
    while k < adv.target:
        c_0 = cycle_count()
        contact_stage(w, slot, slots, ws, spheres, meshes, springs, bodies, tables, opts, kin, state, ss, st,
                      no_cohesion, sums)
        block_sync()
        c_2 = cycle_count()
        step = adv.first_step + k + 1
        for b in range(b0 + slot, b0 + ws.bpw, slots):
            integrate_body(b, bodies, opts, 1, 0, step, w * FAULT_SLOTS, state, sums, ws.fault)
        block_sync()
        c_4 = cycle_count()
        sphere_stage(w, slot, slots, ws, spheres, meshes, state, kin, sums, build_pos, mesh_build_pos,
                     mesh_build_quat)
        if ws.stop_others != 0 and lane == 0:  # another world's stop, read coherently (an atomic) for the block
            ws.disp[w * DISP_SLOTS + 2] = float(wp.atomic_add(ws.stop, 0, 0))
        if adv.rec_every > 0:  # the poses are final once the body stage's barrier has passed
            j = k + 1 + adv.rec_shift
            if j % adv.rec_every == 0:
                record_poses(w, slot, slots, j, adv, ws, state)
        k += 1
        block_sync()
        c_6 = cycle_count()
        # the end of the step: every lane takes the same decision; then lane 0 files it
        rebuild, stopped = needs_rebuild(w, ws, opts)
        block_sync()
        if lane == 0:
            file_step_end(w, rebuild, ws)
        c_7 = cycle_count()
        wall += vec4l(c_2 - c_0, c_4 - c_2, c_6 - c_4, c_7 - c_6)
        if rebuild or stopped:
            break
    if lane == 0:
        ws.step[w] = k
        for q in range(4):
            ws.stage_cycles[w * 4 + q] = ws.stage_cycles[w * 4 + q] + wall[q]


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
    if best >= 0:
        keep_first_fault(world_fault, best, fault, 0)


overload_per_law(world_steps_kernel)
