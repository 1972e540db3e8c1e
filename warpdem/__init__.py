"""warpdem: discrete element method for soil-tool interaction on NVIDIA Warp (CPU and CUDA).

Yade's cohesive-frictional contact law with rolling and twisting resistance (or Yade's Hertz-Mindlin law:
``warpdem.laws``), spheres, clumps and triangle meshes as free rigid bodies, springs, many independent worlds in one
launch.
"""

import os
import sys

import warp as wp

from . import checkpoint, observers
from .builder import ModelBuilder
from .errors import InputError, SimulationError
from .laws import HertzMindlinMaterial, Material
from .model import Model, State
from .simulation import Simulation
from .timestep import check_step_count, critical_timestep, pwave_timestep, stiffness_timestep


def init_quietly() -> None:
    """Initialise Warp without its banner and module-load lines, and without the "Could not find or load the NVIDIA
    CUDA driver" line that Warp's native code writes straight to file descriptor 2 while it initialises on a machine
    without a GPU. Errors still print."""
    wp.config.quiet = True  # Warp < 1.19
    if hasattr(wp, "LOG_ERROR"):
        wp.config.log_level = wp.LOG_ERROR
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            wp.init()
    finally:
        os.dup2(saved, 2)
        os.close(saved)


__all__ = [
    "HertzMindlinMaterial",
    "InputError",
    "Material",
    "Model",
    "ModelBuilder",
    "Simulation",
    "SimulationError",
    "State",
    "check_step_count",
    "checkpoint",
    "critical_timestep",
    "init_quietly",
    "observers",
    "pwave_timestep",
    "stiffness_timestep",
]
__version__ = "0.1.0"
