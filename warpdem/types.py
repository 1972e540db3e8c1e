"""Settings of a simulation as the kernels read them (issue #40, item 2, in part): :class:`Options`, fixed when a
:class:`~warpdem.simulation.Simulation` is made (``Simulation.options``). The time step reaches the kernels once,
in float64; the contact law takes it in float32 (the same rounding as a float32 given on the host).
"""

from __future__ import annotations

import warp as wp

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
