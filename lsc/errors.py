"""Exceptions raised by lsc."""

from __future__ import annotations


class SceneError(ValueError):
    """Invalid scene input.

    ``path`` names the offending field in dotted/indexed form (``"vehicles[1].weight"``);
    the message says what was wrong and what is accepted.
    """

    def __init__(self, path: str, message: str):
        self.path = path
        self.message = message
        super().__init__(f"{path}: {message}" if path else message)


class SimulationError(RuntimeError):
    """Physics that cannot be completed (with the reason and the remedy in the message)."""
