"""What a simulation holds besides its static Model and its State (issue #40, item 2):

- :class:`Options`: the settings the kernels read, fixed when a :class:`~warpdem.simulation.Simulation` is made
  (``Simulation.options``). The time step reaches the kernels once, in float64; the contact law takes it in float32
  (the same rounding as a float32 given on the host).
- :class:`Control`: what the host changes while a run goes (``Simulation.control``: set by
  ``Simulation.set_body_velocity`` and ``Simulation.set_local_damping``, saved by checkpoints); the Model is not
  changed after ``ModelBuilder.finalize``.

Sizes: ``nb`` bodies, ``W`` worlds, ``G`` damping groups per world.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import warp as wp

if TYPE_CHECKING:
    from .model import Model

wp.set_module_options({"enable_backward": False})


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
