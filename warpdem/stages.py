"""One step of a simulation as free stage functions (issue #40, item 3): contacts (sphere-sphere, sphere-triangle,
springs) -> motion (the force sums to float, integration, sphere kinematics) -> end of step (the meshes' forces and
displacements, the rebuild decision, step counts and faults).

Each stage function takes the Model, the kernels' argument structs (:class:`KernelArgs`, which hold the State's,
the Control's, the Data's and the Contacts' arrays), the Contacts, the Data, the Options and the CPU threads' shares
(:class:`Layout`), and a ``launch`` (:func:`launcher`): it launches its kernels, or records them to be replayed.
:func:`segments` lists a whole step's launches in order, as phases (a part per CPU thread, run at once) and serial
launches; :func:`step` runs them one after the other. :class:`~warpdem.simulation.Simulation` keeps the ways to
advance (captured graphs, CPU threads with barriers, a thread per world), the list rebuilds, the observers and
the faults.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import warp as wp

from . import accumulate
from . import kernel_args as ka
from .contacts import sphere_pair_kernel, sphere_sphere_kernel, sphere_triangle_kernel
from .data import DISP_STRIDE, NO_FAULT, Data
from .integrator import integrate_bodies_kernel, keep_first_fault, mesh_end_one, spring_kernel, update_spheres_kernel
from .laws import MaterialTables
from .model import Model, State
from .types import Contacts, Control, Options

wp.set_module_options({"enable_backward": False})

NO_FAULT_C = wp.constant(NO_FAULT)

Op = Callable[[], object]
"""a recorded launch (or a phase of them): calling it runs it."""
Launch = Callable[..., Op | None]
"""``launch(kernel, dim, **wp.launch's keywords)``: launches (returns None) or records (returns the Op); a launch of
no threads does neither (None)."""
Segment = tuple[str, object]
"""("phase", (name, [ops of each CPU thread])) or ("serial", op), in the order of the step."""


@wp.kernel
def _end_step_kernel(
    opts: Options,
    disp: wp.array(dtype=float),
    fault_parts: wp.array(dtype=int),
    flag_out: wp.array(dtype=int),
    counters: wp.array(dtype=int),
    fault: wp.array(dtype=int),
    cohesion_now: wp.array(dtype=int),
):
    """At the end of a step: decide whether to rebuild the candidate lists before the next one, count steps
    (counters: steps, rebuilds), keep the step's first body fault unless an earlier step had one, and clear the
    one-step request for cohesion (``cohesion_now``). disp: the meshes' largest displacement, then the spheres' of
    each CPU thread; fault_parts: each thread's (body, cause, step), for bodies in thread order; one slot per
    DISP_STRIDE entries in both."""
    for base in range(0, fault_parts.shape[0], DISP_STRIDE):
        if fault_parts[base] != NO_FAULT_C:
            keep_first_fault(fault_parts, base, fault, 0)
            fault_parts[base] = NO_FAULT_C
    ds = float(0.0)
    for p in range(DISP_STRIDE, disp.shape[0], DISP_STRIDE):
        ds = wp.max(ds, disp[p])
        disp[p] = 0.0
    if ds + wp.max(ds, disp[0]) > opts.skin:
        flag_out[0] = 1
        counters[1] = counters[1] + 1
    else:
        flag_out[0] = 0
    disp[0] = 0.0
    counters[0] = counters[0] + 1
    cohesion_now[0] = 0


@wp.kernel
def _mesh_end_kernel(
    meshes: ka.Meshes,
    parts: int,
    state: ka.BodyState,
    build_pos: wp.array(dtype=wp.vec3d),
    build_quat: wp.array(dtype=wp.quatd),
    sums: ka.Sums,
    disp: wp.array(dtype=float),
):
    """Per mesh instance at the end of a step: its contact force and torque sums to float32 (``mesh_force``,
    ``mesh_torque``, accumulate.take_float; read by the observers only; the force also added to
    ``mesh_force_sum``) and its displacement since the last list build into disp[0] (atomic max)."""
    mesh_end_one(wp.tid(), 0, meshes, parts, state, build_pos, build_quat, sums, disp)


class KernelArgs:
    """The argument structs of a simulation's kernels (kernel_args.py), holding its model's, state's, control's,
    data's and contacts' arrays (no copies); ``part_sums[p]``: CPU thread p's own accumulator slots (contacts,
    springs), ``whole_sums[p]``: all slots with thread p's energy terms (integration, the meshes' end of step).
    Made again whenever an array is replaced (a list that grows)."""

    def __init__(self, model: Model, state: State, control: Control, data: Data, contacts: Contacts,
                 parts: int = 1) -> None:
        m, d, c = model, data, contacts
        self.spheres = ka.spheres_of(m)
        self.meshes = ka.meshes_of(m, d)
        self.springs = ka.springs_of(m)
        self.bodies = ka.bodies_of(m, control)
        self.state = ka.body_state_of(state)
        self.kin = ka.sphere_state_of(d)
        self.ss = ka.sphere_list_of(c.ss)
        self.st = ka.triangle_list_of(c.st)
        self.part_sums = [ka.sums_of(d, p, whole=False) for p in range(parts)]
        self.whole_sums = [ka.sums_of(d, p) for p in range(parts)]


@dataclass
class Layout:
    """How a step is shared out between CPU threads (one part on CUDA): cut points into the spheres, bodies and
    contact ranges (``parts + 1`` entries each, first .. end of each part), and the step's variants."""

    parts: int
    """CPU threads sharing a step (P)."""
    sphere_cut: list[int]
    """each part's spheres (those of its bodies): sphere_cut[p] .. sphere_cut[p + 1]."""
    body_cut: list[int]
    """each part's bodies."""
    contact_cut: list[int]
    """each part's spheres for the contacts (cut by their candidates' work)."""
    entry_cut: list[int] | None
    """with ``pair_contacts``: each part's sphere-sphere list entries (None: cut evenly)."""
    pair_contacts: bool
    """a thread per sphere-sphere list entry (contact_threads "pair"), else a thread per sphere."""
    float_sums: bool
    """the bodies' force sums to float in a launch of their own (large CUDA scenes), else in the integration."""
    fold_energy: bool
    """add the energy terms of CPU threads 2 .. P into ``Data.energy`` at the end of the step."""


def launcher(record: bool) -> Launch:
    """A ``launch`` for the stage functions: wp.launch, or (``record``) a recorded launch returned to be
    replayed (its arguments packed once: on the CPU that packing costs more than a small scene's kernels)."""

    def launch(kernel: object, dim: int, **kw: object) -> Op | None:
        if dim <= 0:
            return None
        if record:
            return wp.launch(kernel, dim, record_cmd=True, **kw).launch
        wp.launch(kernel, dim, **kw)
        return None

    return launch


def update_spheres(model: Model, args: KernelArgs, contacts: Contacts, launch: Launch | None = None,
                   first: int = 0, dim: int | None = None, disp_slot: int = -1) -> Op | None:
    """Sphere kinematics (``Data.sphere_pos``, ...) from the bodies' state, for spheres first .. first + dim
    (default: all); with ``disp_slot`` >= 0, their largest displacement since the last list build [m] into
    ``contacts.disp[disp_slot]``. ``launch``: default, launched now."""
    launch = launch or launcher(False)
    dim = model.n_spheres - first if dim is None else dim
    if dim <= 0:
        return None
    return launch(update_spheres_kernel, dim, inputs=[first, args.spheres, args.state],
                  outputs=[args.kin, contacts.build_pos, disp_slot, contacts.disp], device=model.device)


def contact_stage(model: Model, args: KernelArgs, contacts: Contacts, data: Data, options: Options,
                  materials: MaterialTables, layout: Layout, launch: Launch) -> list[list[Op | None]]:
    """The contact forces of every candidate and the springs', added into the fixed-point sums (each part into
    its own slots; the springs into part 0's, after its contacts): one list of launches per part. The
    accumulators are zero here (the previous step's sums to float cleared them)."""
    m, c, a, dev, P = model, contacts, args, model.device, layout.parts
    ns, cc = m.n_spheres, layout.contact_cut
    parts: list[list[Op | None]] = []
    for p in range(P):
        first, dim = cc[p], cc[p + 1] - cc[p]
        sums = a.part_sums[p]
        part = []
        if ns and layout.pair_contacts:  # a thread per list entry
            ec = layout.entry_cut if layout.entry_cut and layout.entry_cut[-1] == c.ss.capacity else \
                [q * c.ss.capacity // P for q in range(P + 1)]
            e0, e1 = ec[p], ec[p + 1]
            part.append(launch(
                sphere_pair_kernel, e1 - e0,
                inputs=[e0, a.spheres, materials, options, a.kin, a.ss, data.cohesion_now],
                outputs=[sums], device=dev))
        elif ns:
            part.append(launch(
                sphere_sphere_kernel, dim,
                inputs=[first, a.spheres, materials, options, a.kin, a.ss, data.cohesion_now],
                outputs=[sums], device=dev))
        if ns and m.n_meshes:
            part.append(launch(
                sphere_triangle_kernel, dim,
                inputs=[first, a.spheres, a.meshes, materials, options, a.kin, a.state, a.st, data.cohesion_now],
                outputs=[sums], device=dev))
        parts.append(part)
    if m.n_springs:
        parts[0].append(launch(spring_kernel, m.n_springs, inputs=[a.springs, a.bodies, options, a.state],
                               outputs=[a.part_sums[0]], device=dev))
    return parts


def motion_stage(model: Model, args: KernelArgs, contacts: Contacts, data: Data, options: Options, layout: Layout,
                 launch: Launch) -> tuple[Op | None, list[list[Op | None]]]:
    """The bodies moved: (with ``layout.float_sums``, the launch that takes their force sums to float first, to run
    before the parts; else None) and each part's launches, which sum its bodies' forces, move and check them and
    update their spheres."""
    m, d, a, dev, P = model, data, args, model.device, layout.parts
    sc, bc = layout.sphere_cut, layout.body_cut
    float_sums = int(layout.float_sums)
    first = None
    if float_sums:
        first = launch(accumulate.wrench_to_float_kernel, m.n_bodies,
                       inputs=[d.force_acc, d.force_scale, d.torque_acc, d.torque_scale, P],
                       outputs=[d.body_force, d.body_torque], device=dev)
    parts = [[
        launch(integrate_bodies_kernel, bc[p + 1] - bc[p],
               inputs=[bc[p], a.bodies, options, P, float_sums, d.counters, p * DISP_STRIDE, a.state],
               outputs=[a.whole_sums[p], d.fault_parts], device=dev),
        update_spheres(m, a, contacts, launch, sc[p], sc[p + 1] - sc[p], disp_slot=(1 + p) * DISP_STRIDE),
    ] for p in range(P)]
    return first, parts


def end_stage(model: Model, args: KernelArgs, contacts: Contacts, data: Data, options: Options, layout: Layout,
              launch: Launch) -> list[Op | None]:
    """The end of the step, in order: the meshes' sums to float (for the observers) and their displacement, the
    decision whether the lists must be rebuilt before the next step (``contacts.rebuild_flag``: when the
    displacements since the last build could hide a contact), the step count and faults, and the energy terms of
    CPU threads 2 .. P folded in."""
    m, c, d, a, dev, P = model, contacts, data, args, model.device, layout.parts
    ops = []
    if m.n_meshes:
        ops.append(launch(_mesh_end_kernel, m.n_meshes,
                          inputs=[a.meshes, P, a.state, c.mesh_build_pos, c.mesh_build_quat],
                          outputs=[a.whole_sums[0], c.disp], device=dev))
    ops.append(launch(_end_step_kernel, 1, inputs=[options, c.disp, d.fault_parts],
                      outputs=[c.rebuild_flag, d.counters, d.fault, d.cohesion_now], device=dev))
    if layout.fold_energy:
        ops.append(launch(accumulate.fold_energy_kernel, d.energy.shape[0], inputs=[d.energy_extra, P],
                          outputs=[d.energy], device=dev))
    return ops


def segments(model: Model, args: KernelArgs, contacts: Contacts, data: Data, options: Options,
             materials: MaterialTables, layout: Layout, launch: Launch) -> list[Segment]:
    """A whole step's launches (or recorded launches) in order: the contacts phase, the motion phase (after the
    float sums' launch where there is one), the end of the step. Launches of no threads are left out."""
    out: list[Segment] = []

    def serial(op: Op | None) -> None:
        if op is not None:
            out.append(("serial", op))

    def phase(name: str, parts: list[list[Op | None]]) -> None:
        out.append(("phase", (name, [[op for op in part if op is not None] for part in parts])))

    phase("contacts", contact_stage(model, args, contacts, data, options, materials, layout, launch))
    first, motion = motion_stage(model, args, contacts, data, options, layout, launch)
    serial(first)
    phase("motion", motion)
    for op in end_stage(model, args, contacts, data, options, layout, launch):
        serial(op)
    return out


def step(model: Model, state: State, control: Control, contacts: Contacts, data: Data, options: Options,
         materials: MaterialTables, layout: Layout, args: KernelArgs | None = None) -> None:
    """Launch one step's kernels (capturable), each part of a phase after the other: the lists must hold (no
    rebuild flagged), and the caller counts the step in ``state.step`` and ``state.time``. ``args``: the argument
    structs of these arrays (made here if None)."""
    if args is None:
        args = KernelArgs(model, state, control, data, contacts, layout.parts)
    segments(model, args, contacts, data, options, materials, layout, launcher(False))
