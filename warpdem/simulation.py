"""Simulation: one step = broad phase (when needed) -> contacts -> springs -> integration -> checks.

    sim = Simulation(model, state, dt=1e-5)
    sim.run(10_000, record_every=100, observers={"ke": observers.kinetic_energy})

The caller picks the device through the Model. On CUDA the kernels of several steps are captured in one CUDA graph
(steps after the first in conditional nodes that stop once a step flags a list rebuild); the broad-phase rebuild
(whose hash-grid build cannot live in a conditional node) runs between graphs. On the CPU the same kernels run on
Warp's CPU backend; a large scene's step is shared out between CPU threads (cpu_threads.py) in ranges of spheres
and bodies, and its force sums are integers, so a CPU run gives the same bits whatever the number of threads.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import warp as wp

from . import broadphase as bp
from . import cpu_threads, laws, stages
from . import world_steps as world_steps_mod
from .contacts import pair_tan_kernel
from .cpu_threads import BARRIER_OK, Barrier
from .data import NO_FAULT, Data
from .errors import InputError, SimulationError, check_finite, check_positive
from .model import FLAG_PIVOT, Model, State
from .timestep import critical_timestep
from .types import Contacts, Control, Options

wp.set_module_options({"enable_backward": False})

FAULT_NAMES = {1: "nan", 2: "speed", 3: "escaped"}
_CPU_GRAPHS = tuple(int(x) for x in wp.__version__.split(".")[:2]) >= (1, 19)
"""Warp captures CPU graphs (launches and memsets replayed in C++) from 1.19 on."""
LARGE_STEP_SPHERES = 1 << 17
"""On CUDA, a scene of at least this many spheres converts its force sums to float in a launch of their own (a
streaming kernel that runs faster apart from the integration: -9 % of a 4 M-sphere bed's step when fused) and runs
one step per graph (the conditional nodes of several steps per graph cost more than the one host synchronisation
per step that they save: 3-6 % at 1-4 M spheres); a smaller scene, whose step is bound by launch latency, fuses
both (a 52-sphere ringing batch on one H100: 81 -> 67 us per step)."""
WORLD_STEPS_MIN = 32
"""With ``world_steps``, an advance of fewer steps runs stage by stage (the same bits): each advance a thread per
world costs a hand-over between CPU threads and a few small reads, more than a few steps save."""
SKIN_FACTOR = 0.2
"""The contact lists' default skin as a multiple of the mean sphere radius (``Simulation``'s ``skin``)."""
RECORD_CHUNK_STEPS = 4096
"""With ``world_steps``, :meth:`Simulation.run` hands pose records to the host at least this many steps at a time
(whole records): the progress callback and the fault check come as often."""


def _lane_layout(lanes: int | None, stride: int | None, model: Model) -> tuple[int, int]:
    """Threads per world of the world steps and the stride between the threads that take items: ``lanes`` and
    ``stride`` (checked), else the device's default (CUDA: world_steps.lane_layout; the CPU: one thread)."""
    device = model.device
    if lanes is None and stride is None:
        if device.is_cpu:
            return 1, 1
        return world_steps_mod.lane_layout(model.spheres_per_world, model.bodies_per_world, model.meshes_per_world,
                                           model.springs_per_world)
    if lanes is None:
        lanes = world_steps_mod.WORLD_LANES if device.is_cuda else 1
    if isinstance(lanes, bool) or not isinstance(lanes, int) or not 1 <= lanes <= 1024:
        raise InputError(f"world_lanes must be an integer from 1 to 1024, got {lanes!r}")
    if stride is None:
        stride = 1
    if isinstance(stride, bool) or not isinstance(stride, int) or stride < 1 or lanes % stride != 0:
        raise InputError(f"world_lane_stride must be a positive integer that divides world_lanes = {lanes}, "
                         f"got {stride!r}")
    if device.is_cpu and lanes > 1 and not wp.config.enable_cpu_blocks:
        raise InputError(f"world_lanes = {lanes} on the CPU needs wp.config.enable_cpu_blocks = True (a block's "
                         "threads run as fibers)")
    return lanes, stride


def _thread_count(threads: object) -> int:
    """The CPU threads a simulation may use: ``threads``, or by default cpu_threads.default_threads(); anything but
    a positive integer is refused by name."""
    threads = cpu_threads.default_threads() if threads is None else threads
    if isinstance(threads, bool) or not isinstance(threads, int | np.integer) or threads < 1:
        raise InputError(f"cpu_threads must be a positive integer, got {threads!r}")
    return int(threads)


def _contact_threads(contact_threads: str | None, world_steps: bool, cuda: bool) -> str:
    """How the sphere-sphere contacts are shared out (Simulation's ``contact_threads``): the choice, checked, or the
    default ("pair" on CUDA without ``world_steps``, else "sphere")."""
    if contact_threads is None:
        contact_threads = "pair" if cuda and not world_steps else "sphere"
    if contact_threads not in Simulation.CONTACT_THREADS:
        raise InputError(f"contact_threads must be one of {Simulation.CONTACT_THREADS}, got {contact_threads!r}")
    if contact_threads != "sphere" and world_steps:
        raise InputError(f"contact_threads={contact_threads!r} needs world_steps=False (a world's thread "
                         "loops over its spheres)")
    return contact_threads


def _materials_of(model: Model) -> laws.MaterialTables:
    """The kernels' material tables on the model's arrays, of the struct of the model's contact law
    (``laws.MATERIAL_TABLES``: the type selects the law the kernels run), with the friction tangent of every
    material pair taken once here (not per contact and step)."""
    materials = laws.MATERIAL_TABLES[model.contact_law]()
    pair_tan = wp.empty_like(model.mat_pair_tan)
    wp.launch(pair_tan_kernel, pair_tan.shape[0], inputs=[model.mat_friction, model.mat_pair_tan, model.n_materials],
              outputs=[pair_tan], device=model.device)
    for name, arr in (
        ("young", model.mat_young), ("poisson", model.mat_poisson), ("normal_coh", model.mat_normal_cohesion),
        ("shear_coh", model.mat_shear_cohesion), ("eta_roll", model.mat_eta_roll), ("eta_twist", model.mat_eta_twist),
        ("alpha_kr", model.mat_alpha_kr), ("alpha_ktw", model.mat_alpha_ktw), ("flags", model.mat_flags),
        ("pair_tan", pair_tan), ("pair_adh", model.mat_pair_adhesion),
    ):
        setattr(materials, name, arr)
    materials.n_materials = model.n_materials
    return materials


def _cpu_graph(ops: list[Callable[[], object]]) -> Callable[[], object]:
    """Recorded CPU launches captured as one Warp CPU graph; returns its replay."""
    with wp.ScopedCapture(device="cpu", force_module_load=False) as capture:
        for op in ops:
            op()
    graph = capture.graph

    def replay() -> None:
        wp.capture_launch(graph)

    kernels = [getattr(getattr(op, "__self__", None), "kernel", None) for op in ops]
    replay.__name__ = "graph of " + ", ".join(k.key.split(".")[-1] if k else "op" for k in kernels)
    return replay


class Simulation:
    """Time stepping of a Model/State pair. What the setters change (pivot velocities, local damping) is the
    simulation's own ``control`` (types.Control, made from the Model's initial values); the Model is not changed.

    Args:
        model, state: from :meth:`ModelBuilder.finalize`.
        dt: time step [s]; refused above the P-wave critical step unless ``force_dt``.
        skin: neighbour skin [m] (default :data:`SKIN_FACTOR` x the mean sphere radius).
        always_use_moment_law: apply rolling/twisting moments on non-cohesive contacts too (Yade's flag).
        cohesion_on_new_contacts: every new contact gets cohesion (Yade's setCohesionOnNewContacts).
            These two (True) and ``bond_detection_factor`` (other than 1) need cohesive-frictional materials: with
            Hertz-Mindlin materials (``HertzMindlinMaterial``, no cohesion, no moment law) they raise an InputError
            naming the parameter and its value.
        unp_max: plastic tensile displacement [m] at which a non-fragile bond is deleted (Yade's unpMax, default 0:
            at its first tensile yield); negative: never.
        bond_detection_factor: distance bonding (Yade's ``interactionDetectionFactor`` and ``aabbEnlargeFactor`` at
            the bonding step, set back to 1 after it): at a step that gives cohesion (:meth:`set_cohesion_now`),
            sphere pairs whose centres are within this factor times the sum of their radii get a contact and a bond,
            touching or not (>= 1; 1: touching pairs only). As in Yade 2023.02a's CohFrictPhys, the bond starts
            with no plastic displacement, so a gap g is a tension k_n g at once: a fragile bond with k_n g > a_n
            breaks in that step, a non-fragile one yields (and is deleted unless ``unp_max`` < 0). Sphere-facet
            contacts are not affected (Yade's facet geometry has no such factor).
        track_energy: accumulate dissipation by damping, sliding, rolling and spring dashpots (costs atomics).
        max_speed: a body faster than this [m/s] stops the run as unstable.
        bounds: (lower (3,), upper (3,)) [m]; a body leaving it stops the run (default: the initial bounding box
            grown by its size plus 1 m on every side).
        capacity_factor: candidate-list capacity as a multiple of the first build's needs.
        graph_steps: the host checks for faults and list capacity every ``graph_steps`` steps of :meth:`advance`
            (:meth:`step` checks after every step); on CUDA a captured graph holds up to this many steps (the
            largest power of two, at most 256); 1: no captured graphs (each step's launches replayed).
        cpu_threads: on the CPU, threads that share a step (default: ``WARPDEM_CPU_THREADS`` or the cores this
            process may use); each gets at least cpu_threads.MIN_SPHERES_PER_THREAD spheres, so a small scene runs
            on one. Positions, velocities and forces do not depend on it; the tracked energies may differ in their
            last bits (their float64 sums are grouped by thread). Ignored on CUDA.
        world_steps: run :meth:`advance` a thread per world, many steps per launch (``warpdem.world_steps``): for
            many small worlds (a GA population of small rigs), whose steps are bound by launch latency. The same
            positions, velocities and forces; the lists are rebuilt at other steps (``rebuild_count`` differs), and
            faults and list capacity are checked at the end of each advance (of at least WORLD_STEPS_MIN steps;
            shorter ones run stage by stage). On the CPU the worlds are shared out between ``cpu_threads``
            threads.
        world_lanes: with ``world_steps``, threads per world (a block; each stage's items are dealt out between
            them); on the CPU more than one needs ``wp.config.enable_cpu_blocks`` (Warp runs a block's threads as
            fibers there). The same positions, velocities and forces whatever the number.
        world_lane_stride: with ``world_steps``, every ``world_lane_stride``-th thread of a world's block takes
            items (it divides ``world_lanes``; default 1). Both left out: on CUDA ``world_steps.lane_layout`` (a
            small world gives each item a warp of its own; a larger one, one warp of 32 threads), on the CPU one
            thread.
        contact_threads: how the sphere-sphere contacts are shared out between threads. "pair" (the default on
            CUDA without ``world_steps``): a thread per candidate (``contacts.sphere_pair_kernel``), each contact
            adding its own wrench to both bodies. "sphere" (the default on the CPU, and the only choice with
            ``world_steps``): a thread per sphere over its candidates, which sums its own contacts in float32
            before adding them to its body. Results differ by that float32 rounding of a sphere's sum (the same
            bits where no sphere has two contacts in its list); both are deterministic. On an H100 "pair" does
            12-27 % more sphere-steps per second on deposited beds of 0.1-4 M spheres; on the 2-core CPU "sphere"
            does 7.5-8.7 % more on the cpu-scale bed and its copies, 7-29 k spheres (medians of 3 runs;
            benchmarks/README.md).
    """

    CONTACT_THREADS = ("sphere", "pair")

    def __init__(
        self,
        model: Model,
        state: State,
        dt: float,
        *,
        skin: float | None = None,
        force_dt: bool = False,
        always_use_moment_law: bool = False,
        cohesion_on_new_contacts: bool = False,
        unp_max: float = 0.0,
        bond_detection_factor: float = 1.0,
        track_energy: bool = False,
        max_speed: float = 50.0,
        bounds: tuple[object, object] | None = None,
        capacity_factor: float = 2.0,
        graph_steps: int = 200,
        cpu_threads: int | None = None,
        world_steps: bool = False,
        world_lanes: int | None = None,
        world_lane_stride: int | None = None,
        contact_threads: str | None = None,
    ) -> None:
        check_positive("dt", dt)
        self.contact_threads = _contact_threads(contact_threads, world_steps, model.device.is_cuda)
        check_positive("max_speed", max_speed)
        laws.check_settings(model.contact_law, always_use_moment_law=always_use_moment_law,
                            cohesion_on_new_contacts=cohesion_on_new_contacts,
                            bond_detection_factor=bond_detection_factor)
        self.model = model
        self.state = state
        self.control = Control.of(model)  # what the setters change (types.py); the model stays as built
        self.device = model.device
        self.dt = float(dt)
        self.dt_critical = critical_timestep(model)
        if self.dt > self.dt_critical and not force_dt:
            raise InputError(
                f"dt = {dt:.4g} s exceeds the critical time step {self.dt_critical:.4g} s "
                "(P-wave of the smallest sphere, or the stiffest spring); pass force_dt=True to run anyway"
            )
        radii = model.host["sphere_radius"]
        self.skin = float(skin) if skin is not None else (SKIN_FACTOR * float(radii.mean()) if len(radii) else 1e-3)
        check_positive("skin", self.skin)
        self.always_use_moment_law = bool(always_use_moment_law)
        self.cohesion_on_new_contacts = bool(cohesion_on_new_contacts)
        self.track_energy = bool(track_energy)
        self.max_speed = float(max_speed)
        self.graph_steps = int(graph_steps)
        self._capacity_factor = float(capacity_factor)
        dev = self.device
        self.world_steps = bool(world_steps)
        self.world_lanes, self.world_lane_stride = _lane_layout(world_lanes, world_lane_stride, model)
        threads = _thread_count(cpu_threads) if dev.is_cpu else 1
        self._share_out(1 if self.world_steps else threads)
        self.data = Data.zeros(model, self.parts)  # the per-step arrays (data.py)
        self.contacts = Contacts.zeros(model, self.parts)  # the candidate lists and their rebuild state (types.py)
        if self.contact_threads == "pair":
            self.contacts.ss.enable_owners()
        if self.world_steps:
            self._share_worlds(threads)
            self._make_world_arrays()
        self.materials = _materials_of(model)
        if not (math.isfinite(bond_detection_factor) and 1.0 <= bond_detection_factor <= 3.0):
            raise InputError(f"bond_detection_factor must be in [1, 3] (a centre distance over the radii's sum), "
                             f"got {bond_detection_factor!r}")
        self.bond_detection_factor = float(bond_detection_factor)

        self._args: stages.KernelArgs | None = None  # the kernels' argument structs (made when first needed)
        stages.update_spheres(self.model, self._kernel_args(), self.contacts)
        self._set_bounds(bounds)
        self.options = self._make_options(unp_max)  # the settings the kernels read (types.py)
        self._make_grid()
        # the float sums in a launch of their own and one step per graph (LARGE_STEP_SPHERES; the same bits either
        # way, so a test may set it before the first step)
        self.large_step = not dev.is_cpu and model.n_spheres >= LARGE_STEP_SPHERES
        self._graphs: dict[int, object] = {}  # captured graphs (CUDA, or a CPU thread) by steps per graph
        self._world_ops: list[object] | None = None  # the recorded world_steps launches
        self._step_ops: list[Callable[[], object]] | None = None  # a step's recorded launches (CPU threads)
        # CPU threads: a barrier between a step's phases, and each thread's step as one CPU graph (_advance_threads)
        self._barrier = Barrier(self.parts) if dev.is_cpu and self.parts > 1 and BARRIER_OK else None
        self._lane_graphs: list[Callable[[], object]] | None = None
        self._chunk = 1 << 30  # steps in the next captured graph (capped; see advance)
        self._rebuild_checked()

    def _make_world_arrays(self) -> None:
        """With ``world_steps``: each world's step count, rebuild request, displacements and faults, the stop
        flag, the stage clocks and the pose records of world_steps_kernel (world_steps.py)."""
        dev = self.device
        nw = self.model.n_worlds
        self._world_step = wp.zeros(nw, dtype=int, device=dev)
        self._world_flag = wp.zeros(nw, dtype=int, device=dev)
        self._world_disp = wp.zeros(nw * world_steps_mod.DISP_SLOTS, dtype=float, device=dev)
        self._world_fault = wp.array(np.full(nw * world_steps_mod.FAULT_SLOTS, NO_FAULT, np.int32), dtype=int,
                                     device=dev)
        self._no_cohesion = wp.zeros(1, dtype=int, device=dev)
        # a world that needs a rebuild stops the others (world_steps_kernel's stop_others) where the launch's
        # blocks all run at once: on CUDA, a block per SM at most (a world's block holds up to 256 threads of
        # up to 255 registers). On the CPU the worlds of a thread run one after another.
        self._world_stop = wp.zeros(1, dtype=int, device=dev)
        self.world_stop_others = bool(dev.is_cuda and nw <= dev.sm_count)
        # CUDA clock cycles per world and stage of world_steps.STAGES with its barrier, summed over advances
        # (zeros on the CPU): shape (n_worlds, 4) flattened (world_steps_kernel)
        self.world_stage_cycles = wp.zeros(nw * len(world_steps_mod.STAGES), dtype=wp.int64, device=dev)
        # poses recorded inside world_steps_kernel for Simulation.run's pose observers (grown on demand)
        self._rec_bodies = wp.zeros(1, dtype=int, device=dev)
        self._rec_bodies_host = np.zeros(0, dtype=np.int32)
        self._rec_pos = wp.zeros(1, dtype=wp.vec3d, device=dev)
        self._rec_quat = wp.zeros(1, dtype=wp.quatd, device=dev)

    def _make_options(self, unp_max: float) -> Options:
        """The settings the kernels read (types.Options), from this simulation's (bounds set before)."""
        o = Options()
        o.dt, o.skin, o.track_energy = wp.float64(self.dt), self.skin, int(self.track_energy)
        o.always_moment, o.cohesion_on_new = int(self.always_use_moment_law), int(self.cohesion_on_new_contacts)
        o.unp_max, o.bond_gap = float(unp_max), self.bond_detection_factor - 1.0
        o.max_speed, o.lower, o.upper = wp.float64(self.max_speed), wp.vec3d(*self.bounds[0]), wp.vec3d(*self.bounds[1])
        return o

    def _make_grid(self) -> None:
        """The broad phase's hash grid (None without spheres) and its cell size [m] (the largest sphere diameter
        plus the skin); the first build sizes the candidate lists."""
        model = self.model
        ns = model.n_spheres
        self._cell = 2.0 * model.max_radius + self.skin if ns else 1.0
        dim = int(min(256, max(8, round((max(ns, 1) / max(model.n_worlds, 1)) ** (1 / 3) * 2))))
        self.grid = wp.HashGrid(dim, dim, dim, device=self.device, dtype=wp.float64) if ns else None
        if self.grid is not None:
            self.grid.reserve(ns, with_groups=True)

    # ------------------------------------------------------------------ helpers
    def _share_out(self, threads: int) -> None:
        """The CPU threads' shares of a step (``parts``), as cut points into the bodies and their spheres: spheres
        are stored in body order (ModelBuilder adds a body's spheres with it, world after world), so a thread sums
        the forces of its bodies, moves them and updates their spheres in one phase. The contacts are cut
        separately, by their work (:meth:`_balance_contacts`)."""
        m = self.model
        ns, nb = m.n_spheres, m.n_bodies
        parts = max(1, min(threads, ns // cpu_threads.MIN_SPHERES_PER_THREAD))
        body_of = m.host["sphere_body"]
        if parts > 1 and np.any(np.diff(body_of) < 0):
            parts = 1  # not a ModelBuilder's order: one thread
        before = np.concatenate([[0], np.cumsum(np.bincount(body_of, minlength=nb))])  # spheres before body b
        self._body_cut = cpu_threads.split(before, ns, parts)
        self._sphere_cut = [int(before[b]) for b in self._body_cut]
        self._contact_cut = list(self._sphere_cut)
        self._entry_cut: list[int] | None = None  # contact_threads "pair": each part's list entries
        self.parts = parts

    def _share_worlds(self, threads: int) -> None:
        """World-serial steps (``world_steps``): the worlds cut into ranges, one per CPU thread (worlds share no
        force sums, so no thread's sums meet another's); one range on CUDA."""
        nw = self.model.n_worlds
        k = max(1, min(threads, nw))
        self._world_cut = [round(j * nw / k) for j in range(k + 1)]

    def _balance_contacts(self) -> None:
        """Cut the spheres so that each CPU thread gets about the same number of contact candidates (plus one per
        sphere), from the lists just built (recording the step again, ~0.4 ms against a rebuild's ~9 ms at 7 k
        spheres). The cut depends only on the lists, which a checkpoint keeps: a resumed run cuts as the
        uninterrupted one did."""
        c = self.contacts
        work = 1 + c.ss.count.numpy().astype(np.int64) + c.st.count.numpy()
        before = np.concatenate([[0], np.cumsum(work)])
        cut = cpu_threads.split(before, int(before[-1]), self.parts)
        entry_cut = None
        if self.contact_threads == "pair":  # the same spheres' entries: a CPU build's blocks are in sphere order
            # (a CUDA-written checkpoint's are not: its entries are cut unevenly until the next rebuild)
            start = np.r_[c.ss.start.numpy(), c.ss.capacity]
            entry_cut = [0, *np.maximum.accumulate(start[cut[1:-1]]).tolist(), c.ss.capacity]
        if cut != self._contact_cut or entry_cut != self._entry_cut:
            self._contact_cut, self._entry_cut = cut, entry_cut
            self.recapture()

    def _set_bounds(self, bounds: tuple[object, object] | None) -> None:
        if bounds is None:
            pts = [self.state.body_pos.numpy()]
            if self.model.n_spheres:
                pts.append(self.data.sphere_pos.numpy())
            allp = np.concatenate(pts)
            lo, hi = allp.min(axis=0), allp.max(axis=0)
            grow = (hi - lo).max() + 1.0
            lo, hi = lo - grow, hi + grow
        else:
            lo, hi = np.asarray(bounds[0], float), np.asarray(bounds[1], float)
            if lo.shape != (3,) or hi.shape != (3,) or np.any(lo >= hi):
                raise InputError(f"bounds must be (lower (3,), upper (3,)) with lower < upper, got {bounds!r}")
        self.bounds = (lo, hi)

    def _kernel_args(self) -> stages.KernelArgs:
        """The kernels' argument structs (stages.KernelArgs), made from the model, state, control, data and
        contacts once and again after :meth:`recapture` (an array replaced)."""
        if self._args is None:
            self._args = stages.KernelArgs(self.model, self.state, self.control, self.data, self.contacts,
                                           self.parts)
        return self._args

    @property
    def layout(self) -> stages.Layout:
        """The CPU threads' shares of a step now (stages.Layout; the contacts' cut changes as the lists do)."""
        return stages.Layout(parts=self.parts, sphere_cut=self._sphere_cut, body_cut=self._body_cut,
                             contact_cut=self._contact_cut, entry_cut=self._entry_cut,
                             pair_contacts=self.contact_threads == "pair", float_sums=self.large_step,
                             fold_energy=self.parts > 1 and self.track_energy)

    # ------------------------------------------------------------------ broad phase
    def _rebuild(self) -> None:
        """Rebuild both candidate lists (broadphase.build), on the CPU threads' contact ranges."""
        if self.model.n_spheres == 0:
            return
        cut = self._contact_cut
        bp.build(self.grid, self._cell, self.skin, self.model, self.state, self.data, self.contacts,
                 [(cut[p], cut[p + 1]) for p in range(self.parts)])

    def _rebuild_checked(self) -> None:
        """Host-side rebuild that grows the lists until everything fits (not capturable)."""
        c = self.contacts
        for _ in range(8):
            c.list_stats.zero_()
            self._rebuild()
            stats = c.list_stats.numpy()
            if stats[2] == 0 and stats[3] == 0:
                self._grow_if_needed(stats)
                if self.parts > 1:
                    self._balance_contacts()
                return
            for lst, new, need in ((c.ss, c.ss_new, stats[2]), (c.st, c.st_new, stats[3])):
                if need > 0:
                    cap = int(need * self._capacity_factor) + 64
                    lst.grow(cap)
                    new.grow(cap)
                    self.recapture()  # the arrays moved
        raise SimulationError("candidate lists could not be sized", cause="capacity")

    def _rebuild_if_flagged(self) -> None:
        """Rebuild (host side, growing lists as needed) if the last step flagged it; one flag read per step."""
        if self.contacts.rebuild_flag.numpy()[0]:
            self._rebuild_checked()

    def _grow_if_needed(self, stats: np.ndarray) -> bool:
        """Grow a list whose last build used more than 3/4 of its capacity; returns True if anything grew."""
        c = self.contacts
        grew = False
        for lst, new, used in ((c.ss, c.ss_new, stats[0]), (c.st, c.st_new, stats[1])):
            if used > 0.75 * lst.capacity:
                cap = int(used * self._capacity_factor) + 64
                lst.grow(cap)
                new.grow(cap)
                grew = True
        if grew:
            self.recapture()
        return grew

    # ------------------------------------------------------------------ the step
    def _launch_step(self, record: bool = False, lanes: bool = False) -> list:
        """The kernels of one step (capturable): contacts, springs, integration, checks, and at the end the
        decision whether the candidate lists must be rebuilt before the next one (``rebuild_flag``).

        ``record``: nothing runs; returns the step as a list of calls to replay (recorded launches, whose
        arguments are packed once: on the CPU that packing costs more than a small scene's kernels). With several
        CPU threads (``parts``), the contacts and the integration are phases (cpu_threads.Parallel) whose parts
        cover ranges of spheres and bodies; run directly, the parts run one after the other. ``lanes`` (with
        ``record``): the step as one list of launches per CPU thread, with barriers between (:meth:`_lanes`).
        The launches are the stage functions' (stages.segments)."""
        segments = stages.segments(self.model, self._kernel_args(), self.contacts, self.data, self.options,
                                   self.materials, self.layout, stages.launcher(record))
        if lanes:
            return self._lanes(segments)
        ops: list[Callable[[], object]] = []
        for kind, item in segments:
            if kind == "serial":
                ops.append(item)
                continue
            name, parts = item
            parts = [part for part in parts if part]
            if len(parts) > 1:
                if _CPU_GRAPHS:  # each thread replays its launches as one CPU graph (no Python per launch)
                    parts = [[_cpu_graph(part)] for part in parts]
                ops.append(cpu_threads.Parallel(name, parts))
            elif parts:
                ops.extend(parts[0])
        return ops

    def _lanes(self, segments: list[tuple[str, object]]) -> list[list[Callable[[], object]]]:
        """A step's recorded launches as one list per CPU thread: each thread its part of every phase, the serial
        launches on thread 0, and a barrier (cpu_threads.Barrier) wherever one thread's launches read what
        another's wrote: between a phase and what follows it, and at the end of the step."""
        lanes: list[list[Callable[[], object]]] = [[] for _ in range(self.parts)]
        wait = self._barrier.record()

        def barrier() -> None:
            for lane in lanes:
                lane.append(wait)

        previous = None
        for kind, item in segments:
            if kind == "phase":
                if previous is not None:  # a phase reads what every earlier launch wrote
                    barrier()
                for lane, part in zip(lanes, item[1], strict=True):
                    lane.extend(part)
            else:
                if previous == "phase":  # a serial launch reads what the phase's threads wrote
                    barrier()
                lanes[0].append(item)
            previous = kind
        for lane in lanes:
            lane.append(wait)
        return lanes

    def _check(self) -> None:
        """Raise SimulationError on a recorded fault or list overflow; grow lists that are nearly full."""
        fault = self.data.fault.numpy()
        if fault[0] != NO_FAULT:
            self._raise_fault(fault)
        stats = self.contacts.list_stats.numpy()
        if stats[2] or stats[3]:
            raise SimulationError(
                f"contact candidate list overflow during a captured chunk before step {self.state.step} "
                f"(needed {max(stats[2], stats[3])} entries): contacts may have been missed; restart from a "
                "checkpoint with a larger capacity_factor",
                step=self.state.step, cause="capacity",
            )
        self._grow_if_needed(stats)

    def _raise_fault(self, fault: np.ndarray) -> None:
        body, cause, step = int(fault[0]), FAULT_NAMES.get(int(fault[1]), "?"), int(fault[2])
        x = self.state.body_pos.numpy()[body]
        v = self.state.body_vel.numpy()[body]
        world = body // self.model.bodies_per_world
        hint = {
            "nan": "a NaN appeared (time step too large for the contact or spring stiffness, or a degenerate input)",
            "speed": f"speed {np.linalg.norm(v):.3g} m/s > max_speed {self.max_speed} m/s: energy blow-up, "
            f"likely dt = {self.dt:.3g} s too large (critical {self.dt_critical:.3g} s) or an overlap too deep",
            "escaped": "the body left the simulation bounds (flew off, or fell through a wall)",
        }[cause]
        raise SimulationError(
            f"simulation unstable at step {step}: body {body} (world {world}) at x = {np.round(x, 6).tolist()} m, "
            f"v = {np.round(v, 6).tolist()} m/s; {hint}",
            step=step, body=body, cause=cause, world=world,
        )

    # ------------------------------------------------------------------ public API
    def step(self) -> None:
        """Advance one time step (plain launches), rebuilding the candidate lists first if the last step asked."""
        self._rebuild_if_flagged()
        self._launch_step()
        self.state.step += 1
        self.state.time += self.dt
        if self.device.is_cpu:
            self._check()

    def set_local_damping(self, group: str, damping: object) -> None:
        """Change a group's Cundall local damping [-] now: one value for every world or (n_worlds,) values."""
        m = self.model
        if group not in m.names["group"]:
            raise InputError(f"group must be one of {sorted(m.names['group'])}, got {group!r}")
        values = np.broadcast_to(np.asarray(damping, dtype=np.float64), (m.n_worlds,))
        if np.any(~np.isfinite(values)) or np.any((values < 0) | (values >= 1)):
            raise InputError(f"local damping must be in [0, 1), got {values.tolist()}")
        damping = self.control.group_damping
        table = damping.numpy().reshape(m.n_worlds, m.n_groups)
        table[:, m.names["group"][group]] = values
        damping.assign(wp.array(table.reshape(-1).astype(np.float32), dtype=float, device=m.device))

    def set_body_velocity(self, name: str, velocity: object, worlds: object | None = None) -> None:
        """Set a named body's velocity [m/s] now: (3,) or (n_worlds, 3) values, in every world or in ``worlds``.

        A kinematic body then moves at it and a dynamic one continues from it; for a hinged body it is the velocity
        of its pivot (the carriage).
        """
        m = self.model
        if name not in m.names["body"]:
            raise InputError(f"body must be one of {sorted(m.names['body'])}, got {name!r}")
        w = np.arange(m.n_worlds) if worlds is None else np.asarray(worlds, dtype=np.int64).reshape(-1)
        idx = w * m.bodies_per_world + m.names["body"][name]
        values = np.broadcast_to(np.asarray(velocity, dtype=np.float64), (len(idx), 3))
        check_finite("velocity", values)
        hinged = (m.host["body_flags"][idx[0]] & FLAG_PIVOT) != 0 if len(idx) else False
        target = self.control.pivot_vel if hinged else self.state.body_vel
        table = target.numpy().copy()
        table[idx] = values
        target.assign(table)

    def set_cohesion_now(self) -> None:
        """Give cohesion to every existing contact of cohesive materials at the next step (Yade's setCohesionNow);
        with ``bond_detection_factor`` > 1 also to the sphere pairs within its reach, whose candidates the lists
        then hold (rebuilt here with a skin that covers the reach). Refused (InputError) for Hertz-Mindlin
        materials, which have no cohesion."""
        if self.model.contact_law == laws.HERTZ_MINDLIN:
            raise InputError("set_cohesion_now() needs cohesive-frictional materials: the Hertz-Mindlin law has no "
                             "cohesion")
        self.data.cohesion_now.fill_(1)
        reach = self.options.bond_gap * 2.0 * self.model.max_radius
        if reach > self.skin:
            skin, self.skin = self.skin, reach * (1.0 + 1e-6)
            try:
                self._rebuild_checked()
            finally:
                self.skin = skin

    def advance(self, n_steps: int) -> None:
        """Advance ``n_steps`` steps; every ``graph_steps`` steps, and after the last, check for faults (a fault
        names the step where it happened) and list capacity.

        On CUDA several steps run per graph launch (:meth:`_advance_graphs`), in scenes of fewer than
        LARGE_STEP_SPHERES spheres. Shared between CPU threads, each thread replays its share of a step as one CPU
        graph with barriers between the phases, step after step, until a rebuild is flagged
        (:meth:`_advance_threads`). Otherwise the host reads the rebuild flag before each step and rebuilds when
        asked, and the step is one captured graph (CUDA; the CPU with one thread: a Warp CPU graph, replayed in C++
        with no Python per launch). (A CPU graph of several steps costs ~4 ms of recording per step, more than it
        saves.)"""
        if self.world_steps and n_steps >= WORLD_STEPS_MIN:
            self._advance_worlds(n_steps)
            return
        if not self.device.is_cpu and self.graph_steps > 1 and not self.large_step:
            self._advance_graphs(n_steps)
            return
        if self._barrier is not None and _CPU_GRAPHS and self.graph_steps > 1:
            self._advance_threads(n_steps)
            return
        graph = (not self.device.is_cpu or (self.parts == 1 and _CPU_GRAPHS)) and self.graph_steps > 1
        every = max(self.graph_steps, 1)
        spheres = self.model.n_spheres > 0
        for k in range(n_steps):
            if spheres:
                self._rebuild_if_flagged()
            if graph:
                wp.capture_launch(self._steps_graph(1))
            else:
                if self._step_ops is None:
                    self._step_ops = self._launch_step(record=True)
                for op in self._step_ops:
                    op()
            self.state.step += 1
            self.state.time += self.dt
            if (k + 1) % every == 0 or k == n_steps - 1:
                self._check()

    def refresh(self) -> None:
        """After the state, the control or the candidate lists were replaced from outside (checkpoint.load): forget
        the captured step (:meth:`recapture`), cut the contacts between the CPU threads again from the lists, and
        compute the spheres' kinematics from the bodies' state."""
        self.recapture()
        if self.parts > 1:
            self._balance_contacts()
        stages.update_spheres(self.model, self._kernel_args(), self.contacts)

    def rebuild_lists(self) -> None:
        """Rebuild the candidate lists now (as when a step flags it), growing them until every candidate fits."""
        self._rebuild_checked()

    def step_ops(self) -> list[Callable[[], object]]:
        """One step's launches, recorded, in order (for profiling: calling each in turn runs a step; valid until
        the lists are rebuilt or grow). The caller rebuilds the lists when ``contacts.rebuild_flag`` asks
        (:meth:`rebuild_lists`) and counts the steps."""
        return self._launch_step(record=True)

    def recapture(self) -> None:
        """Forget the captured graphs and recorded launches of the step (its arrays moved or were replaced, or the
        CPU threads' shares changed): the next step captures or records them again."""
        self._graphs = {}
        self._step_ops = None
        self._world_ops = None
        self._lane_graphs = None
        self._args = None

    def _advance_threads(self, n_steps: int) -> None:
        """:meth:`advance` shared between CPU threads: each thread replays its share of a step (its parts of the
        phases, barriers between them; :meth:`_lanes`) as one CPU graph, step after step, until ``n_steps`` have
        run, a step has flagged a list rebuild, or ``graph_steps`` steps call for the host's check. Every thread
        reads the rebuild flag after the step's last barrier, so all stop after the same step; the host then
        rebuilds and hands over again: one hand-over per rebuild interval instead of two per step."""
        c = self.contacts
        flag = c.rebuild_flag.numpy()  # a view of the CPU array
        every = max(self.graph_steps, 1)
        spheres = self.model.n_spheres > 0
        left, since_check = n_steps, 0
        barrier = self._barrier
        while left > 0:
            if spheres:
                self._rebuild_if_flagged()
            if self._lane_graphs is None:
                self._lane_graphs = [_cpu_graph(lane) for lane in self._launch_step(record=True, lanes=True)]
            chunk = min(left, every - since_check)
            done = [0] * self.parts

            def run(p: int, graph: Callable[[], object], chunk: int = chunk, done: list[int] = done,
                    barrier: Barrier = barrier) -> None:
                n = 0
                try:
                    while n < chunk and not (spheres and n > 0 and flag[0]) and not barrier.broken:
                        graph()
                        n += 1
                except BaseException:  # a thread that raises (or is interrupted) releases the others at once
                    barrier.break_()
                    raise
                finally:
                    done[p] = n

            barrier.reset()
            cpu_threads.run_locked([[lambda p=p, g=g: run(p, g)] for p, g in enumerate(self._lane_graphs)])
            if barrier.broken or len(set(done)) != 1:
                raise SimulationError(f"the CPU threads of a step lost each other (steps run by each: {done})",
                                      cause="threads")
            left, since_check = self._count_ran(done[0], left, since_check)

    def _steps_graph(self, n: int) -> object:
        """The captured graph of ``n`` steps (cached until arrays move): step 1, then steps 2 .. n each in a
        conditional node that runs it only while no rebuild is flagged."""
        graph = self._graphs.get(n)
        if graph is None:
            spheres = self.model.n_spheres > 0
            with wp.ScopedCapture(device=self.device) as capture:
                self._launch_step()
                for _ in range(n - 1):
                    if spheres:
                        wp.capture_if(self.contacts.rebuild_flag, on_false=self._launch_step)
                    else:
                        self._launch_step()
            graph = self._graphs[n] = capture.graph
        return graph

    def _advance_graphs(self, n_steps: int) -> None:
        """:meth:`advance` on CUDA, several steps per graph launch: the first step unconditionally, each further
        one in a conditional node that skips it once a step has flagged a list rebuild (``rebuild_flag``). The host
        then reads how many steps ran, rebuilds the lists (growing them as needed) and goes on: the same steps and
        rebuilds as one step at a time, with one host synchronisation per rebuild instead of one per step. The
        number of steps per graph follows the rebuild interval (powers of two up to ``graph_steps``)."""
        d = self.data
        spheres = self.model.n_spheres > 0
        cap = 1 << (min(self.graph_steps, 256).bit_length() - 1)  # steps per graph: a power of two <= graph_steps
        device_steps = int(d.counters.numpy()[0]) if spheres else 0
        left, since_check = n_steps, 0
        while left > 0:
            if spheres:
                self._rebuild_if_flagged()
            n = 1 << (min(self._chunk, cap, left).bit_length() - 1)
            wp.capture_launch(self._steps_graph(n))
            done = n
            if spheres and n > 1:  # steps after a flagged rebuild were skipped (a graph's first step always runs)
                now = int(d.counters.numpy()[0])
                done, device_steps = now - device_steps, now
                # the next graph: as long as this rebuild interval (rounded up), or twice as long if none ended it
                self._chunk = 2 * n if done == n else 1 << max(done - 1, 0).bit_length()
            elif spheres:
                device_steps += 1
                if self._chunk <= 1:  # grow again, as a graph that no rebuild ended would
                    self._chunk = 2
            left, since_check = self._count_ran(done, left, since_check)

    def _count_ran(self, done: int, left: int, since_check: int) -> tuple[int, int]:
        """Count ``done`` steps that ran (of ``left`` still to run) into the state's step and time, the time by
        repeated addition as step by step; check for faults and list capacity once ``graph_steps`` steps have run
        since the last check (``since_check``) or none are left. Returns (steps left, steps since the last check)."""
        self.state.step += done
        for _ in range(done):
            self.state.time += self.dt
        left -= done
        since_check += done
        if since_check >= max(self.graph_steps, 1) or left == 0:
            self._check()
            since_check = 0
        return left, since_check

    def _advance_worlds(self, n_steps: int, record: tuple[int, int] = (0, 0)) -> None:
        """:meth:`advance` a thread per world (world_steps.py): each launch takes every world as far as ``n_steps``
        steps or until its lists need a rebuild; the host rebuilds and launches again until all have arrived. A step
        that must give cohesion (:meth:`set_cohesion_now`) runs first, the ordinary way. ``record``: (every, bodies
        per world) for :meth:`_advance_recorded`, (0, 0) for none."""
        d, m = self.data, self.model
        c = self.contacts
        spheres = m.n_spheres > 0
        if spheres:
            self._rebuild_if_flagged()
        shift = 0  # steps of a recording run before the world kernel's first
        if n_steps > 0 and d.cohesion_now.numpy()[0]:
            self.step()
            n_steps -= 1
            shift = 1
            if spheres:
                self._rebuild_if_flagged()
        if n_steps <= 0:
            self._check()
            return
        self._world_step.zero_()
        self._world_flag.zero_()
        self._world_stop.zero_()
        rebuilds = 0
        while True:
            self._launch_worlds(n_steps, (*record, shift))
            if int(self._world_step.numpy().min()) >= n_steps:
                break
            self._rebuild_checked()  # some world stopped: its lists no longer hold (or another's did)
            self._world_flag.zero_()
            self._world_stop.zero_()
            rebuilds += 1
        wp.launch(world_steps_mod.world_end_kernel, 1, inputs=[n_steps, rebuilds, m.n_worlds, self._world_flag,
                                                              self._world_fault],
                  outputs=[d.counters, c.rebuild_flag, d.fault], device=self.device)
        self.state.step += n_steps
        for _ in range(n_steps):
            self.state.time += self.dt
        self._check()

    def _advance_recorded(self, records: int, every: int, bodies: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Advance ``records * every`` steps a thread per world, the poses of each world's ``bodies`` (local
        indices (nb,)) recorded inside world_steps_kernel after every ``every``-th step: positions [m]
        (records, n_worlds, nb, 3) and quaternions (x, y, z, w) (records, n_worlds, nb, 4), the bits the host would
        read after those steps, with one hand-over to the host for all of them (on CUDA a record's host reads and
        launches cost more than its 57 steps of a ringing batch do)."""
        m = self.model
        nb = len(bodies)
        size = records * m.n_worlds * nb
        if self._rec_pos.shape[0] < size:
            self._rec_pos = wp.zeros(size, dtype=wp.vec3d, device=self.device)
            self._rec_quat = wp.zeros(size, dtype=wp.quatd, device=self.device)
            self._world_ops = None  # the launches hold the arrays
        if not np.array_equal(self._rec_bodies_host, bodies):
            self._rec_bodies_host = np.array(bodies, dtype=np.int32)
            self._rec_bodies = wp.array(self._rec_bodies_host, dtype=int, device=self.device)
            self._world_ops = None
        self._advance_worlds(records * every, (every, nb))
        shape = (records, m.n_worlds, nb)
        return self._rec_pos.numpy()[:size].reshape(*shape, 3), self._rec_quat.numpy()[:size].reshape(*shape, 4)

    def _launch_worlds(self, target: int, record: tuple[int, int, int] = (0, 0, 0)) -> None:
        """One launch of world_steps_kernel per CPU thread's range of worlds (one on CUDA), recorded once (until
        arrays move, :meth:`recapture`): only the target, the step count and the recording (every, bodies per
        world, shift; world_steps_kernel) change between advances."""
        if self._world_ops is None:
            self._world_ops = self._record_worlds()
        adv = world_steps_mod.Advance()
        adv.target, adv.first_step = target, self.state.step
        adv.rec_every, adv.rec_nb, adv.rec_shift = record
        for op in self._world_ops:
            op.set_param_at_index(0, adv)  # world_steps_kernel's first parameter
        if len(self._world_ops) > 1:
            cpu_threads.Parallel("worlds", [[op.launch] for op in self._world_ops])()
        else:
            self._world_ops[0].launch()

    def _record_worlds(self) -> list[object]:
        """The world_steps_kernel launches of :meth:`_launch_worlds`, recorded (their Advance set before each)."""
        m, c = self.model, self.contacts
        ws = world_steps_mod.Worlds()
        ws.lanes, ws.stride = self.world_lanes, self.world_lane_stride
        ws.spw, ws.bpw, ws.mpw, ws.kpw = (m.spheres_per_world, m.bodies_per_world, m.meshes_per_world,
                                          m.springs_per_world)
        ws.n_worlds, ws.stop_others = m.n_worlds, int(self.world_stop_others)
        ws.step, ws.flag, ws.disp, ws.fault = self._world_step, self._world_flag, self._world_disp, self._world_fault
        ws.stop, ws.stage_cycles = self._world_stop, self.world_stage_cycles
        ws.rec_bodies, ws.rec_pos, ws.rec_quat = self._rec_bodies, self._rec_pos, self._rec_quat
        a = self._kernel_args()
        cut = self._world_cut
        return [wp.launch(
            world_steps_mod.world_steps_kernel, (cut[j + 1] - cut[j], self.world_lanes), block_dim=self.world_lanes,
            record_cmd=True,
            inputs=[world_steps_mod.Advance(), cut[j], ws, a.spheres, a.meshes, a.springs, a.bodies, self.materials,
                    self.options],
            outputs=[a.kin, a.state, a.ss, a.st, self._no_cohesion, a.whole_sums[0], c.build_pos, c.mesh_build_pos,
                     c.mesh_build_quat],
            device=self.device,
        ) for j in range(len(cut) - 1)]

    def run(
        self,
        n_steps: int,
        *,
        record_every: int = 0,
        observers: dict[str, Callable[[Simulation], object]] | None = None,
        progress: Callable[[int, int], None] | None = None,
    ) -> dict[str, np.ndarray]:
        """Run ``n_steps`` steps, calling each observer every ``record_every`` steps (and at the start).

        With ``world_steps``, observers that read only one body's pose (they have ``body``, a body name, and
        ``of_poses(pos (records, n_worlds, 3), quat (records, n_worlds, 4))``, as
        :func:`warpdem.observers.body_point`) are given the poses recorded inside the world kernel,
        RECORD_CHUNK_STEPS steps or more per hand-over to the host instead of one record's: the same values to the
        bit.

        Returns a time series: {"time": (k,), "step": (k,), name: stacked observer values}.
        """
        observers = observers or {}
        series: dict[str, list] = {"time": [], "step": [], **{k: [] for k in observers}}

        def record() -> None:
            series["time"].append(self.state.time)
            series["step"].append(self.state.step)
            for k, f in observers.items():
                series[k].append(np.asarray(f(self)))

        if record_every and observers:
            record()
        done = 0
        chunk = record_every if record_every else n_steps
        poses = self._pose_recording(observers, record_every)
        while done < n_steps:
            records = 0 if poses is None else min(-(-RECORD_CHUNK_STEPS // record_every),
                                                  (n_steps - done) // record_every)
            if records * record_every >= WORLD_STEPS_MIN:  # whole records, recorded by the world kernel
                bodies, column = poses
                t, step = self.state.time, self.state.step
                pos, quat = self._advance_recorded(records, record_every, bodies)
                values = {k: f.of_poses(pos[:, :, column[k]], quat[:, :, column[k]]) for k, f in observers.items()}
                for r in range(records):
                    for _ in range(record_every):  # the additions of advance(): the same bits
                        t += self.dt
                    series["time"].append(t)
                    series["step"].append(step + (r + 1) * record_every)
                    for k in observers:
                        series[k].append(values[k][r])
                done += records * record_every
                if progress is not None:
                    progress(done, n_steps)
                continue
            k = min(chunk, n_steps - done)
            self.advance(k)
            done += k
            if record_every and observers:
                record()
            if progress is not None:
                progress(done, n_steps)
        return {k: np.asarray(v) for k, v in series.items()}

    def _pose_recording(self, observers: dict[str, Callable[[Simulation], object]], record_every: int
                        ) -> tuple[np.ndarray, dict[str, int]] | None:
        """For :meth:`run`: (the local indices of the bodies whose poses the observers read (nb,), each observer's
        column among them) when every observer reads one body's pose and the world kernel can record them
        (``world_steps``, records at least two steps apart); None otherwise."""
        if not (self.world_steps and record_every >= 2 and observers):
            return None
        if not all(hasattr(f, "of_poses") and hasattr(f, "body") for f in observers.values()):
            return None
        names = sorted({f.body for f in observers.values()})
        index = self.model.names["body"]
        bodies = np.array([index[n] for n in names], dtype=np.int32)
        return bodies, {k: names.index(f.body) for k, f in observers.items()}

    @property
    def rebuild_count(self) -> int:
        """Number of broad-phase rebuilds since the start (excluding the initial build)."""
        return int(self.data.counters.numpy()[1])

    def critical_ratio(self) -> float:
        """dt / critical time step."""
        return self.dt / self.dt_critical if math.isfinite(self.dt_critical) else 0.0
