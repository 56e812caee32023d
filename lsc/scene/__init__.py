"""Scenes: the validated input of a simulation.

A scene is loaded from a dict, a TOML file (path) or an existing :class:`Scene` by
:meth:`Scene.load` (or :func:`load_scene`). Units are applied here and only here: every number
held by a :class:`Scene` is a plain float in the scene's coherent unit system, ``"SI"`` (m, s, kg,
N) or ``"US"`` (ft, s, slug, lbf). Results are reported in that same system.

The loader reads each contact law and effect through its own declaration (its scene keys, units
and bounds: :mod:`lsc.laws`, :mod:`lsc.effects`); the package's modules: ``_read`` (paths,
tables of keys, quantities), ``_tables`` (force–deformation tables and CSV files, the
:class:`Reader` the parts read their keys with), ``_parts`` (vehicles, contacts, solver
settings) and ``_scene`` (the scene, its scene-wide checks, copies with values replaced).
"""

from __future__ import annotations

from ..effects import Brake, Failure
from ..laws import Damping, Hysteresis, Restitution, UnloadingStiffness, UnloadingTable
from ..solvers import METHODS
from ..units import STANDARD_G, UNITS
from ._parts import Contact, SolverSettings, Vehicle
from ._read import MAGNITUDES
from ._scene import G_RANGE, GAP_RATIO, Scene, load_scene
from ._tables import MAX_CSV_BYTES, MAX_SCENE_BYTES, Reader

__all__ = [
    "Scene", "Vehicle", "Brake", "Contact", "Hysteresis", "Restitution", "UnloadingStiffness",
    "UnloadingTable", "Damping", "Failure", "SolverSettings", "load_scene", "UNITS", "STANDARD_G",
    "METHODS", "MAGNITUDES", "GAP_RATIO", "G_RANGE", "MAX_CSV_BYTES", "MAX_SCENE_BYTES", "Reader"]
