"""lsc — low-speed collinear bumper-to-bumper crash simulation.

``lsc.solve(scene)`` simulates one crash; ``lsc.Scene.load`` validates a scene. See the
documentation for the scene format, the physics and the backends. The subpackages
``lsc.analysis``, ``lsc.plots`` and ``lsc.data`` are attributes too, loaded on first use (so
``import lsc`` imports no JAX, diffrax or matplotlib).
"""

from importlib import import_module as _import_module

from .api import solve
from .errors import SceneError, SimulationError
from .impacts import Impact
from .result import Event, Result
from .scene import Scene, load_scene
from .sweep import SweepResult, sweep

__all__ = ["solve", "sweep", "SweepResult", "Scene", "load_scene", "Result", "Event", "Impact", "SceneError", "SimulationError"]
__version__ = "0.1.0"

#: Subpackages imported on first attribute access (PEP 562), not by ``import lsc``.
_LAZY = ("analysis", "plots", "data")


def __getattr__(name: str):
    """``lsc.analysis``, ``lsc.plots``, ``lsc.data``: imported when first asked for."""
    if name in _LAZY:
        return _import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
