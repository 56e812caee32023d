"""Exact piecewise backend: two vehicles, IF-D hysteresis with piecewise-linear branches.

Inside a segment (frozen discrete state) the contact force is affine in the deformation, so the
motion and every event are in closed form (:mod:`.kernels`); braked vehicles stop and break away
exactly (:mod:`.braking`); a scene is solved segment after segment as a Result (:mod:`.single`),
and many scenes at once by one vectorised NumPy stepper (:mod:`.batch`, no braking and no
post-failure curve: such scenes are solved one by one). Results agree with 40-digit arithmetic
to about 1e-15 relative.

A post-failure curve (bumper failure) needs nothing of its own: the law follows the spliced
loading curve, whose failure point is a breakpoint where the next piece starts at its own force
(a step), and every segment starts from its own piece's ``fa + s (D0 - da)``.
"""

from __future__ import annotations

from ..base import Backend
from . import batch, single
from .arrays import arrays_of
from .batch import BATCH_STATUS, EVENT_LIMIT, NO_EVENT, solve_arrays

__all__ = ["BACKEND", "applies", "why_not", "solve", "solve_batch", "solve_arrays",
           "batch_params", "BATCH_STATUS", "EVENT_LIMIT", "NO_EVENT"]

#: The exact backend's declaration: two vehicles with the IF-D law (any loading and unloading
#: curve, gaps, braking, failure); its batch path has no braking and no post-failure curve.
BACKEND = Backend(
    name="exact", module=__name__, options=("t_end", "n_samples", "max_events"), exact=True,
    cost=1.0, vehicles=(2, 2),
    solves=frozenset({"law:ifd", "loading:linear", "loading:table", "unloading:restitution",
                      "unloading:stiffness", "unloading:table", "effect:brake", "effect:failure",
                      "effect:post-failure", "gap:open"}),
    batch=frozenset({"law:ifd", "loading:linear", "loading:table", "unloading:restitution",
                     "unloading:stiffness", "unloading:table", "effect:failure", "gap:open"}),
    batch_options=("max_events",),
    summary="exact piecewise solution of two vehicles with piecewise-linear IF-D curves")


def why_not(scene) -> str | None:
    """Why the exact backend does not apply to ``scene`` (``None`` if it does)."""
    from ...model import HybridModel

    return BACKEND.why_not(HybridModel(scene))


def applies(scene) -> bool:
    """True when the exact backend solves ``scene``."""
    return why_not(scene) is None


def solve(model, **options):
    """:func:`.single.solve` (``t_end`` [time], ``n_samples``, ``max_events``) of ``model``,
    refused with a :class:`~lsc.errors.SceneError` if it uses what this backend does not
    declare (a model, read-only once built, is checked once)."""
    if not model.__dict__.get("_exact_declared"):
        BACKEND.check(model)
        model.__dict__["_exact_declared"] = True
    return single.solve(model, **options)


def solve_batch(model, values: dict, **options) -> dict:
    """:func:`.batch.solve_batch` (``progress``, ``max_events``) of ``model`` over the swept
    ``values``, refused with a :class:`~lsc.errors.SceneError` if the scene uses what the batch
    does not declare (braking, a post-failure curve)."""
    BACKEND.check(model, batch=True)
    return batch.solve_batch(model, values, **options)


def batch_params(scenes) -> dict:
    """:func:`solve_arrays` parameters from scenes the exact backend applies to, whose loading
    curves have equal numbers of points (all extending or none) and whose unloading rules are of
    one kind (tables of equal length); ``ValueError`` otherwise."""
    scenes = list(scenes)
    if not scenes:
        raise ValueError("no scenes")
    for i, sc in enumerate(scenes):
        reason = why_not(sc)
        if reason:
            raise ValueError(f"scene {i}: the exact backend does not apply: {reason}")
    return arrays_of(scenes)
