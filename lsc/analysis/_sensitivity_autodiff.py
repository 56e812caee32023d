"""The autodiff path of :func:`lsc.analysis.sensitivity`: each parameter's tangent, the derivative
of the model's numbers with respect to it (:func:`_tangent`), and the derivatives of the metrics
through the diffrax solve (:func:`_by_diffrax`, with
:func:`lsc.solvers.diffrax_ode.metrics_jacobian`)."""

from __future__ import annotations

import numpy as np

from ..errors import SceneError
from ..parameters import batch_params, tangent
from ..scene import Scene
from ._sensitivity_params import _Param

__all__: list[str] = []


# ---------------------------------------------------------------------------- tangents
def _tangent(model, sc: Scene, prm: _Param):
    """``∂ model.params / ∂ prm`` as a pytree of NumPy arrays (model.params' structure): the
    derivative of the parameter layer's construction (:func:`lsc.parameters.tangent`)."""
    return tangent(model, prm.path, prm.value)


# ---------------------------------------------------------------------------- diffrax (autodiff)
#: Below this restitution the IF-D unloading line is too narrow (``e² D_max``) for its derivative
#: in ``e`` to be accurate, and at ``e = 0`` there is none (the contact separates at once): the
#: derivative with respect to ``e`` is taken at this ``e`` (ΔV and the pulse of a two-vehicle
#: crash are linear in ``e``; the peaks do not depend on it).
_E_MIN = 1e-3


def _by_diffrax(sc, model, prms, *, integrator, rtol, atol, max_steps, max_events):
    """Values and derivatives of the metrics (and stats, and how they were computed) by
    forward-mode autodiff through the diffrax solve of ``model`` (the scene ``sc``), along the
    parameters ``prms``."""
    from ..solvers import diffrax_ode as dx

    dx.check_settings(integrator, rtol, atol, max_steps, max_events)
    for law in model.laws:
        why = getattr(law, "autodiff_refused", lambda: None)()
        if why:
            raise SceneError("method", why)
    tangents = [_tangent(model, sc, prm) for prm in prms]
    opts = dict(integrator=integrator, rtol=rtol, atol=atol, max_steps=max_steps,
                max_events=max_events)
    values, derivs, stats = dx.metrics_jacobian(model, tangents, **opts)
    stats.update({"integrator": integrator, "rtol": rtol})
    # e near 0: see _E_MIN (the other derivatives stay those of the scene as given)
    low = [j for j, q in enumerate(prms)
           if q.path.endswith(".unloading.restitution") and q.value < _E_MIN]
    if low:
        p2 = _member(batch_params(model, {prms[j].path: np.array([_E_MIN]) for j in low}))
        _, derivs2, stats2 = dx.metrics_jacobian(model, tangents, params=p2, **opts)
        for k in derivs:
            derivs[k][..., low] = derivs2[k][..., low]
        stats["wall_time"] += stats2["wall_time"]
        stats["one_sided"] = [prms[j].path for j in low]
    how = f"forward-mode autodiff through the diffrax solve ({integrator}, rtol {rtol:g})"
    return values, derivs, stats, how


def _member(tree):
    """The one member of a batch of model parameters (:func:`lsc.parameters.batch_params`)."""
    if isinstance(tree, dict):
        return {k: _member(v) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_member(v) for v in tree]
    return tree[0]
