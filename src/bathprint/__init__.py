"""bathprint: simulate and learn to print soft gelling filaments in a reacting bath."""

from bathprint.core import layout
from bathprint.core.scene import Scene, builtin_scene_names, load_scene
from bathprint.core.simulation import Simulation
from bathprint.envs import register_envs
from bathprint.errors import SceneError, SimulationError
from bathprint.run import Result, simulate

register_envs()  # gymnasium.make("bathprint/CoilRadius-v0"), WriteShape-v0, BuoyantLayers-v0

__version__ = "0.1.0"

__all__ = [
    "Result",
    "Scene",
    "SceneError",
    "Simulation",
    "SimulationError",
    "builtin_scene_names",
    "layout",
    "load_scene",
    "simulate",
]
