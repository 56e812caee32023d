"""Helpers shared by the analyses: quantities with units, dotted paths, scene checks."""

from __future__ import annotations

import numpy as np

from ..errors import SceneError
from ..units import to_system

__all__ = ["quantity", "path_kind", "split_path", "check_contact", "check_brent", "check_keywords"]

from ..sweep import check_keywords  # noqa: E402  (one check for sweep and every analysis)

# The kind of quantity (a key of lsc.scene.UNITS) held at a dotted path, by its last names.
_KINDS = {
    ("speed",): "velocity", ("mass",): "mass", ("weight",): "force", ("gap",): "length",
    ("loading", "stiffness"): "stiffness", ("unloading", "stiffness"): "stiffness",
    ("unloading", "restitution"): "dimensionless", ("loading", "scale"): "dimensionless",
    ("failure", "force"): "force", ("brake", "mu"): "dimensionless",
    ("brake", "mu_static"): "dimensionless", ("g",): "acceleration",
    ("stiffness",): "stiffness", ("force",): "force", ("restitution",): "dimensionless",
    ("scale",): "dimensionless",
}


def split_path(path: str) -> list[str]:
    """``"vehicles[0].speed"`` / ``"vehicles.0.speed"`` → ``["vehicles", "0", "speed"]``."""
    return str(path).strip().replace("[", ".").replace("]", "").split(".")


def path_kind(path: str) -> str | None:
    """The kind of quantity at a dotted scene path (``"velocity"``, ...), ``None`` if unknown."""
    parts = [p for p in split_path(path) if not p.isdigit()]
    for n in (2, 1):
        kind = _KINDS.get(tuple(parts[-n:]))
        if kind is not None:
            return kind
    return None


def quantity(value, kind: str, scene, path: str) -> float:
    """A number (scene units) or a string with units (``"5000 lbf"``) → float in scene units."""
    return to_system(value, kind, scene.units, path)


def path_quantity(value, scene, path: str) -> float:
    """A value for a dotted path, converted by the path's kind when it is a string with units."""
    if isinstance(value, str) or hasattr(value, "units"):
        kind = path_kind(path)
        if kind is None:
            raise SceneError(path, "values with units are accepted for speeds, masses, weights, gaps, "
                                   "stiffnesses, forces and g; give a plain number in the scene's units")
        return quantity(value, kind, scene, path)
    x = float(value)
    if not np.isfinite(x):
        raise SceneError(path, f"{value!r} is not a finite number")
    return x


def check_contact(scene, contact) -> int:
    """``contact`` as a valid contact index of ``scene`` (SceneError otherwise)."""
    K = len(scene.contacts)
    if isinstance(contact, bool) or not isinstance(contact, (int, np.integer)) or not 0 <= contact < K:
        raise SceneError("contact", f"the scene has {K} contact{'s' if K > 1 else ''}: give an "
                                    f"index 0..{K - 1}, got {contact!r}")
    return int(contact)


def read_path(scene, path: str) -> float:
    """The current value at a numeric dotted path of the scene's source (scene units)."""
    node = scene.source
    for part in split_path(path):
        try:
            node = node[int(part)] if isinstance(node, list) else node[part]
        except (KeyError, IndexError, ValueError, TypeError):
            raise SceneError(path, "no such field in the scene") from None
    return path_quantity(node, scene, path)


def check_brent(xtol, rtol, maxiter) -> None:
    """Brent's method settings of an analysis: ``xtol`` a positive finite number [the searched
    quantity's unit], ``rtol`` finite and at least 4 machine epsilons (Brent's own floor),
    ``maxiter`` a positive integer; a ``SceneError`` naming the argument otherwise."""
    floor = 4 * np.finfo(float).eps
    if isinstance(xtol, bool) or not isinstance(xtol, (int, float, np.number)) \
            or not (np.isfinite(xtol) and xtol > 0):
        raise SceneError("xtol", f"xtol must be a positive finite number, got {xtol!r}")
    if isinstance(rtol, bool) or not isinstance(rtol, (int, float, np.number)) \
            or not (np.isfinite(rtol) and rtol >= floor):
        raise SceneError("rtol", f"rtol must be a finite number >= {floor:.6g} (4 machine "
                                 f"epsilons), got {rtol!r}")
    if isinstance(maxiter, bool) or not isinstance(maxiter, (int, np.integer)) or maxiter < 1:
        raise SceneError("maxiter", f"maxiter must be a positive integer, got {maxiter!r}")


class SummaryHTML:
    """Mixin for the analyses' results: Jupyter shows their :meth:`summary` table as HTML
    (:func:`lsc.html.summary_html`)."""

    def _repr_html_(self) -> str:
        from ..html import summary_html
        return summary_html(self)
