"""What every contact law and effect shares: the mode codes, the status codes a law raises, the
field-wise select of discrete states, and :class:`Param`, the declaration of a scene key."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..units import register_kind

__all__ = ["MODE_OPEN", "MODE_LOADING", "MODE_UNLOADING", "BIG", "STATUS", "REBOUND_RESOLUTION",
           "REQUIRED", "Param", "select", "smooth_min"]

MODE_OPEN, MODE_LOADING, MODE_UNLOADING = 0, 1, 2
BIG = 1e300

#: Status codes a law may raise in its discrete state (0 = fine), with the user-facing reason.
STATUS = {
    0: "ok",
    1: ("the loading table ends before the vehicles reach a common velocity (the crash needs more "
        "deformation than the IF-D curve gives). Extend the table, or scale its forces up "
        "(lsc.analysis.calibrate_force_scale / `scale = ...` in the loading table), as the paper "
        "did for its measured crash-test curves"),
    2: ("the unloading branch would end at a negative permanent deformation (the straight line from "
        "(D_max, F_max) needed for this restitution passes below D = 0). Give the unloading as a "
        "table or a stiffness, or a lower restitution"),
    3: ("the unloading branch returns more energy than the loading branch absorbed (restitution "
        "above 1): make the unloading stiffer than the loading curve"),
    4: ("Brach's law cannot reach the requested restitution at this closing speed with its "
        "compression damping c1 (no restoring damping c2 >= 0 gives it, or the one that would "
        "is past the float range, c2 ~ k/(e v)): lower the damping or raise the restitution"),
    5: ("the post-failure loading table ends before the vehicles reach a common velocity (the "
        "crash needs more deformation after the bumper failed than failure.post_failure gives). "
        "Extend that table, or scale its forces up (`scale = ...` in failure.post_failure)"),
}

#: The narrowest rebound, relative to ``D_max``, that a backend integrating vehicle *positions*
#: resolves (law parameter ``wres``); a narrower one separates at once, its rebound dropped.
#: Such a backend holds a deformation only to the ulps of the positions, so the force on an
#: unloading line ``w`` wide and ``F_max/w`` steep is noise once ``w`` is a few ulps of ``D_max``:
#: at 4 ulps (``e ≈ 3e-8`` on a linear branch) the rebound dropped and the rebound mis-resolved
#: just above it both change a ΔV by a few 1e-8 of the closing speed, a float64 floor of those
#: backends (docs/reliability.rst). The exact backend works relative to the piece's anchor
#: (``(D - da) + wl``) and resolves any width: it sets ``wres = 0``.
REBOUND_RESOLUTION = 4 * float(np.finfo(float).eps)

#: :attr:`Param.default` of a key the scene must give.
REQUIRED = object()


@dataclass(frozen=True)
class Param:
    """One numeric scene key a contact law or an effect reads (its declaration).

    Attributes
    ----------
    key : str
        The key in the part's table (``"stiffness"``, ``"mu"``).
    kind : str or callable
        Its unit kind (a key of :data:`lsc.units.UNITS`), or ``kind(values)`` of the values read
        before it (Hunt–Crossley's stiffness is force/length^n, ``n`` its exponent).
    doc : str
        What it is, with its symbol (the scene schema's description).
    default : float, None or REQUIRED
        The value when the key is absent (``None``: absent; :data:`REQUIRED`: it must be given).
    minimum, strict : float or None, bool
        Lower bound: ``> minimum`` (``strict``) or ``>= minimum``; checked by the loader.
    bounded : bool or None
        Hold the value to :data:`lsc.scene.MAGNITUDES` (default: every kind but plain numbers).
    hint : str or None
        Added to the error when a quantity of another dimension is given.
    check : callable or None
        ``check(value)``: the error message of an extra rule on the value, or ``None``.
    schema : (float or None, bool, float or None) or None
        Bounds the scene schema states (minimum, exclusive, maximum); default
        ``(minimum, strict, None)``.
    unit : (str, str, tuple) or None
        A unit kind of the part's own: (SI unit, US unit, examples), registered on first use
        (:func:`lsc.units.register_kind`).
    """

    key: str
    kind: str | Callable[[dict], str]
    doc: str = ""
    default: Any = REQUIRED
    minimum: float | None = None
    strict: bool = True
    bounded: bool | None = None
    hint: str | None = None
    check: Callable[[float], str | None] | None = None
    schema: tuple | None = None
    unit: tuple | None = None

    def kind_for(self, values: dict) -> str:
        """The unit kind of this key, given the values read before it."""
        kind = self.kind(values) if callable(self.kind) else self.kind
        if self.unit is not None:
            register_kind(kind, *self.unit)
        return kind

    @property
    def bounds(self) -> tuple:
        """(minimum, exclusive, maximum) for the scene schema."""
        return self.schema if self.schema is not None else (self.minimum, self.strict, None)


def select(cond, a: dict, b: dict, xp) -> dict:
    """Field-wise ``where(cond, a, b)`` over two discrete states (on NumPy with a scalar ``cond``
    a plain pick of the same values, without a ``where`` per field)."""
    if xp is np and np.ndim(cond) == 0:
        src = a if cond else b
        return {k: src[k] for k in a}
    return {k: xp.where(cond, a[k], b[k]) for k in a}


def smooth_min(a, b):
    """Elementwise minimum written with ``abs`` (NumPy and JAX alike)."""
    return 0.5 * (a + b - abs(a - b))
