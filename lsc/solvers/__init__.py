"""Backends and the ``auto`` dispatch.

Each backend module solves a :class:`~lsc.model.HybridModel`; :func:`solve` picks one by name.
``auto`` takes the cheapest exact backend that applies: the closed form for two vehicles with
linear loading and a straight unloading line, the exact piecewise solve for other two-vehicle
hysteresis scenes (piecewise-linear loading and unloading), the event-driven SciPy solve otherwise.
"""

from __future__ import annotations

from ..errors import SceneError

__all__ = ["METHODS", "pick", "run", "options_of"]

#: Accepted values of ``method``.
METHODS = ("auto", "closed-form", "exact", "scipy", "diffrax", "reference")

# Options each backend accepts (anything else is a SceneError, never silently ignored).
_OPTIONS = {
    "closed-form": {"t_end", "n_samples"},
    "exact": {"t_end", "n_samples", "max_events"},
    "scipy": {"rtol", "atol", "integrator", "t_end", "max_events", "n_samples", "first_step",
              "max_steps"},
    "reference": {"dt", "t_end", "n_samples", "max_steps"},
    "diffrax": {"rtol", "atol", "integrator", "t_end", "max_events", "max_steps", "n_samples"},
}


def options_of(method: str) -> set[str]:
    """The options backend ``method`` accepts (empty for an unknown one)."""
    return set(_OPTIONS.get(method, ()))


def pick(scene, method: str) -> str:
    """The backend ``method`` resolves to for ``scene`` (``auto`` → cheapest exact one)."""
    if method not in METHODS:
        raise SceneError("solver.method", f"unknown method {method!r}; accepted: "
                         + ", ".join(repr(m) for m in METHODS))
    if method != "auto":
        return method
    from . import closed_form, exact
    if closed_form.applies(scene):
        return "closed-form"
    return "exact" if exact.applies(scene) else "scipy"


def run(model, method: str, options: dict):
    """Solve ``model`` with backend ``method`` (already resolved) and its ``options``."""
    if method not in _OPTIONS:
        raise SceneError("solver.method", f"method {method!r} is not available yet; "
                         "accepted now: " + ", ".join(repr(m) for m in ("auto", *_OPTIONS)))
    unknown = set(options) - _OPTIONS[method]
    if unknown:
        name = sorted(unknown)[0]
        raise SceneError(f"solver.{name}", f"option {name!r} does not apply to method "
                         f"{method!r}; it accepts: {', '.join(sorted(_OPTIONS[method]))}")
    if method == "closed-form":
        from .closed_form import solve
    elif method == "exact":
        from .exact import solve
    elif method == "scipy":
        from .scipy_ode import solve
    elif method == "diffrax":
        try:
            from .diffrax_ode import solve
        except ModuleNotFoundError as exc:  # the [jax] extra is not installed
            raise SceneError("solver.method", f"method 'diffrax' needs JAX and diffrax ({exc}); "
                             "install them with: pip install 'lsc[jax]'") from exc
    else:
        from .reference import solve
    return solve(model, **options)
