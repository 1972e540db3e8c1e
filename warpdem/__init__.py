"""warpdem: discrete element method for soil-tool interaction on NVIDIA Warp (CPU and CUDA).

Yade's cohesive-frictional contact law with rolling and twisting resistance, spheres, clumps and triangle meshes as
free rigid bodies, springs, many independent worlds in one launch.
"""

from . import checkpoint, observers
from .builder import ModelBuilder
from .errors import InputError, SimulationError
from .materials import Material
from .model import Model, State
from .simulation import Simulation
from .timestep import check_step_count, critical_timestep, pwave_timestep, stiffness_timestep

__all__ = [
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
    "observers",
    "pwave_timestep",
    "stiffness_timestep",
]
__version__ = "0.1.0"
