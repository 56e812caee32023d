"""Display units: the speeds of printed summaries in the unit a reader thinks in (mph, km/h).

Only what is printed changes; results, CSV and JSON keep the scene's unit system. Conversion
factors come from the project's pint registry (:func:`lsc.units.to_system`), so 1 ft/s is
exactly 3600/5280 mph.
"""

from __future__ import annotations

from .errors import SceneError
from .units import _NUMBER, UNITS, to_system

__all__ = ["SPEED_UNITS", "speed_display", "velocity_display", "unit_of"]

#: The speed units ``--speed-unit`` accepts.
SPEED_UNITS = ("mph", "km/h", "ft/s", "m/s")


def speed_display(unit: str | None, system: str, path: str = "speed_unit") -> tuple[float, str]:
    """``(factor, unit)``: multiply a speed in ``system``'s velocity unit by ``factor`` to print
    it in ``unit`` (one of :data:`SPEED_UNITS`); ``None`` → ``(1.0, the scene's unit)``.
    Raises :class:`SceneError` at ``path`` for another unit, naming the accepted ones."""
    if unit is None:
        return 1.0, UNITS[system]["velocity"]
    if unit not in SPEED_UNITS:
        raise SceneError(path, f"unknown speed unit {unit!r}; accepted: "
                               + ", ".join(SPEED_UNITS))
    return velocity_display(unit, system, path)


def velocity_display(unit: str, system: str, path: str) -> tuple[float, str]:
    """``(factor, unit)`` for any velocity unit pint reads (``"mi/hr"``); :class:`SceneError`
    at ``path`` otherwise."""
    return 1.0 / to_system(f"1 {unit}", "velocity", system, path), unit


def unit_of(quantity) -> str | None:
    """The unit of a quantity given as text (``"1 mph"`` → ``"mph"``); ``None`` for a bare
    number, a number as text or a pint quantity."""
    if isinstance(quantity, str):
        m = _NUMBER.fullmatch(quantity)
        if m and m.group(2):
            return m.group(2).lstrip("*").strip()
    return None
