"""What a simulation holds besides its static Model and its State (issue #40, item 2):

- :class:`Options`: the settings the kernels read, fixed when a :class:`~warpdem.simulation.Simulation` is made
  (``Simulation.options``). The time step reaches the kernels once, in float64; the contact law takes it in float32
  (the same rounding as a float32 given on the host).
- :class:`Control`: what the host changes while a run goes (``Simulation.control``: set by
  ``Simulation.set_body_velocity`` and ``Simulation.set_local_damping``, saved by checkpoints); the Model is not
  changed after ``ModelBuilder.finalize``.
- :class:`Contacts`: the candidate lists with their contact history, the list statistics and what decides a
  rebuild (``Simulation.contacts``).

Sizes: ``nb`` bodies, ``ns`` spheres, ``nm`` mesh instances (arrays sized by ``nm`` have at least one entry), ``W``
worlds, ``G`` damping groups per world, ``P`` CPU threads sharing a step (1 on CUDA).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import warp as wp

if TYPE_CHECKING:
    from .broadphase import PairList
    from .model import Model

wp.set_module_options({"enable_backward": False})

DISP_STRIDE = wp.constant(16)
"""entries between two threads' slots of ``Contacts.disp`` and ``Data.fault_parts`` (64 bytes: a cache line each,
so that threads do not write into one line)."""


@wp.struct
class Options:
    """A simulation's settings (scalars, so changing them needs no recompile)."""

    dt: wp.float64
    """time step [s], float64 (the contact law and the spring dashpots' energy take float32(dt))."""
    skin: float
    """neighbour skin of the candidate lists [m], float32."""
    always_moment: int
    """1: rolling and twisting moments on non-cohesive contacts too (Yade's always_use_moment_law), int32."""
    cohesion_on_new: int
    """1: every new contact gets cohesion (Yade's setCohesionOnNewContacts), int32."""
    unp_max: float
    """Yade's unpMax [m], float32: plastic tensile displacement at which a non-fragile bond is deleted (< 0: never)."""
    bond_gap: float
    """distance bonding: Yade's interactionDetectionFactor - 1 at a bonding step [-], float32 (0: touching only)."""
    track_energy: int
    """1: add the dissipated and driven energies (``Data.energy``), int32."""
    max_speed: wp.float64
    """a body faster than this is a fault [m/s], float64."""
    lower: wp.vec3d
    """lower corner of the bounds [m], vec3d; a body outside them is a fault."""
    upper: wp.vec3d
    """upper corner of the bounds [m], vec3d."""


@dataclass
class Control:
    """The values a run may change from the host while it goes, on the model's device; made from the Model's
    initial values by :meth:`of`. (A body that is not hinged has its imposed velocity in ``State.body_vel``: a
    kinematic body keeps it, a dynamic one continues from it.)"""

    pivot_vel: wp.array
    """velocity of each hinged body's pivot (the carriage), world frame [m/s], vec3d (nb,); zero for other
    bodies."""
    group_damping: wp.array
    """Cundall local damping of each world's body groups [-], float32 (W * G,), world after world."""

    @classmethod
    def of(cls, model: Model) -> Control:
        """A Control holding copies of ``model``'s initial values (``Model.body_pivot_vel``,
        ``Model.group_damping``), so that changing it leaves the Model as built."""
        return cls(pivot_vel=wp.clone(model.body_pivot_vel), group_damping=wp.clone(model.group_damping))


@dataclass
class Contacts:
    """The candidate lists and their rebuild state, on the model's device; made by :meth:`zeros`. A list
    (broadphase.PairList) holds per sphere a block of entries (``start``, ``count`` (ns,)) with each entry's partner
    and contact history (capacity,); its capacity grows as the builds need."""

    ss: PairList
    """sphere-sphere candidates of the current lists: per sphere its partners of higher index, sorted: ``other``
    int32 (capacity,) [-], ``hist`` laws.Hist (capacity,) [SI per field]."""
    st: PairList
    """sphere-triangle candidates of the current lists: per sphere (``mesh``, ``face``) entries, int32
    (capacity,) [-] each, with their ``hist``, laws.Hist (capacity,) [SI per field]."""
    ss_new: PairList
    """the sphere-sphere lists being built at a rebuild (history carried over from ``ss``), as ``ss``: int32 and
    Hist (capacity,) [-]."""
    st_new: PairList
    """the sphere-triangle lists being built at a rebuild, as ``st``: int32 and Hist (capacity,) [-]."""
    build_pos: wp.array
    """sphere centres at the last list build [m], vec3d (ns,)."""
    mesh_build_pos: wp.array
    """mesh bodies' positions at the last list build [m], vec3d (nm,)."""
    mesh_build_quat: wp.array
    """mesh bodies' orientations at the last list build [-], quatd (x, y, z, w) (nm,)."""
    list_stats: wp.array
    """list statistics [entries]: those of the sphere-sphere and sphere-triangle lists at the last build, then the
    capacity each lacked (0: none), int32 (4,)."""
    alloc_total: wp.array
    """list entries allocated at a build (sphere-sphere, sphere-triangle) [entries], int32 (2,)."""
    disp: wp.array
    """largest mesh displacement (entry 0), then the largest sphere displacement of each CPU thread p (entry
    (1 + p) * DISP_STRIDE), since the last build [m], float32 ((1 + P) * DISP_STRIDE,)."""
    rebuild_flag: wp.array
    """1: the lists must be rebuilt before the next step [-], int32 (1,)."""

    @classmethod
    def zeros(cls, model: Model, parts: int = 1, capacity: int = 16) -> Contacts:
        """Empty lists of ``capacity`` entries (the first build sizes them) and zeroed rebuild state for ``model``
        on its device; ``parts`` (P): CPU threads that share a step."""
        from .broadphase import PairList

        dev = model.device
        ns, nm = model.n_spheres, max(model.n_meshes, 1)
        return cls(
            ss=PairList(ns, capacity, dev, two_keys=False), st=PairList(ns, capacity, dev, two_keys=True),
            ss_new=PairList(ns, capacity, dev, two_keys=False), st_new=PairList(ns, capacity, dev, two_keys=True),
            build_pos=wp.zeros(ns, dtype=wp.vec3d, device=dev), mesh_build_pos=wp.zeros(nm, dtype=wp.vec3d, device=dev),
            mesh_build_quat=wp.zeros(nm, dtype=wp.quatd, device=dev), list_stats=wp.zeros(4, dtype=int, device=dev),
            alloc_total=wp.zeros(2, dtype=int, device=dev),
            disp=wp.zeros((1 + parts) * DISP_STRIDE, dtype=float, device=dev),
            rebuild_flag=wp.zeros(1, dtype=int, device=dev),
        )
