"""Derivatives of the metrics of a diffrax solve with respect to its parameters: forward-mode
automatic differentiation (``jax.jacfwd``) through the compiled segment loop, every step and every
event (:func:`metrics_jacobian`; used by :func:`lsc.analysis.sensitivity`).

An event time depends on the parameters; the loop locates each event by Newton's method on the
step's interpolant and polishes it with one Newton step on the integrator's own solution, so the
tangent that comes out of the polish is the implicit function theorem's
``dt*/dp = -(∂g/∂p) / ġ``: the derivative of where the event *is*, not of where the search
happened to stop.
"""

from __future__ import annotations

import numpy as np

from .compiled import Compiled, bucket, f64, structure

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from ...errors import SimulationError  # noqa: E402
from ...result import METRICS  # noqa: E402
from .core import SegmentLoop, check_settings, status_message  # noqa: E402

__all__ = ["metrics_jacobian", "DIFFERENTIATED"]

#: The metrics :func:`metrics_jacobian` differentiates: every Result metric but
#: ``peak_acceleration_g`` (the caller divides by ``g``) and ``failure_time`` (no derivative
#: where a contact does not fail).
DIFFERENTIATED = tuple(m for m in METRICS if m not in ("peak_acceleration_g", "failure_time"))

_JACOBIANS: dict = {}


def _jacobian(model, integrator: str, max_steps: int, max_events: int) -> Compiled:
    """The compiled Jacobian function of this scene structure and these static options (a
    :class:`~.core.SegmentLoop` that ``jvp`` can go through), built once per structure."""
    key = (structure(model), integrator, int(max_steps), int(max_events))
    fn = _JACOBIANS.get(key)
    if fn is None:
        loop = SegmentLoop(model, integrator, max_steps, max_events, differentiable=True)

        def jac(p, T, rtol, atol, t_end, horizon, g):
            def run(theta):
                q = jax.tree_util.tree_map(lambda a, t: a + jnp.tensordot(theta, t, axes=1), p, T)
                out = loop.run_metrics(q, rtol, atol, t_end, horizon, g)
                mets = {k: out[k] for k in DIFFERENTIATED if k in out}
                aux = {k: out[k] for k in ("status", "status_contact", "t", "steps", "segments")}
                return mets, (mets, aux)
            P = jax.tree_util.tree_leaves(T)[0].shape[0]
            return jax.jacfwd(run, has_aux=True)(jnp.zeros(P))

        fn = _JACOBIANS[key] = Compiled(jac)
    return fn


def metrics_jacobian(model, tangents, *, params=None, integrator: str = "Dopri8",
                     rtol: float = 1e-12, atol=None, max_steps: int = 4096,
                     max_events: int = 256):
    """The metrics of ``model`` (:data:`DIFFERENTIATED`) and their derivatives along each of the
    ``tangents`` (a list of pytrees shaped as ``model.params``: ``∂ params / ∂ parameter``).

    ``params``: the parameters to differentiate at (default ``model.params``, of the same
    structure). Solver options as :func:`~.single.solve` (``max_steps`` per segment). Returns
    ``(values, derivatives, stats)``: metric name → array; metric name → array of the metric's
    shape plus one axis over the tangents; ``compile_time``, ``wall_time`` [s], ``steps``,
    ``segments``. Raises :class:`~lsc.errors.SimulationError` with the single solve's message
    where the solve fails.
    """
    check_settings(integrator, rtol, atol, max_steps, max_events)
    fn = _jacobian(model, integrator, max_steps, max_events)
    p = jax.tree_util.tree_map(f64, model.params if params is None else params)
    n = len(tangents)
    # pad to a bucket of tangent directions (zeros): another choice of parameters of this scene
    # structure reuses the compiled code (an extra direction costs little next to a compile)
    zero = jax.tree_util.tree_map(lambda a: np.zeros(np.shape(a)), model.params)
    padded = list(tangents) + [zero] * (bucket(n, 8) - n)
    T = jax.tree_util.tree_map(lambda *xs: np.stack([np.asarray(x, float) for x in xs]), *padded)
    horizon = float(model.horizon())
    args = (f64(rtol), f64(np.nan if atol is None else atol), f64(np.nan),
            f64(horizon if np.isfinite(horizon) else np.nan), f64(model.scene.g))
    (jac, (prim, aux)), compile_time, wall = fn(p, T, *args)
    status = int(aux["status"])
    if status:
        raise SimulationError(status_message(status, int(aux["status_contact"]), float(aux["t"]),
                                             integrator))
    values = {k: np.asarray(v, float) for k, v in prim.items()}
    derivatives = {k: np.array(v, float)[..., :n] for k, v in jac.items()}
    stats = {"compile_time": compile_time, "wall_time": wall, "steps": int(aux["steps"]),
             "segments": int(aux["segments"])}
    return values, derivatives, stats
