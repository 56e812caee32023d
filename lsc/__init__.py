"""lsc — low-speed collinear bumper-to-bumper crash simulation.

``lsc.solve(scene)`` simulates one crash; ``lsc.Scene.load`` validates a scene. See the
documentation for the scene format, the physics and the backends.
"""

from .api import solve
from .errors import SceneError, SimulationError
from .impacts import Impact
from .result import Event, Result
from .scene import Scene, load_scene
from .sweep import SweepResult, sweep

__all__ = ["solve", "sweep", "SweepResult", "Scene", "load_scene", "Result", "Event", "Impact", "SceneError", "SimulationError"]
__version__ = "0.1.0"
