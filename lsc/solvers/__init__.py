"""Backends and the ``auto`` dispatch.

Each backend module solves a :class:`~lsc.model.HybridModel`; :func:`solve` picks one by name.
``auto`` takes the cheapest exact backend that applies: the closed form for two vehicles with
linear loading and a straight unloading line, the exact piecewise solve for other two-vehicle
hysteresis scenes (piecewise-linear loading and unloading), the event-driven SciPy solve otherwise.
"""

from __future__ import annotations

import difflib

import numpy as np

from ..errors import SceneError

__all__ = ["METHODS", "ALL_OPTIONS", "MAX_SAMPLES", "pick", "run", "options_of", "check_option"]

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


#: Every option that some backend accepts; any other name is an error for every method, ``auto``
#: included.
ALL_OPTIONS = frozenset().union(*_OPTIONS.values())
#: Most points in a Result's sampled series (``n_samples``): a million rows of every series.
MAX_SAMPLES = 1_000_000

_POSITIVE = ("atol", "dt", "t_end", "first_step")
_COUNTS = ("max_events", "max_steps", "n_samples")


def check_option(name: str, value) -> None:
    """Refuse, with a :class:`SceneError` at ``solver.<name>``, an option no backend knows or a
    value outside its range: ``rtol`` in (0, 1); ``atol``, ``dt`` [s], ``t_end`` [s],
    ``first_step`` [s] positive and finite (``atol = None``: the backend's default);
    ``max_events``, ``max_steps`` whole numbers >= 1; ``n_samples`` in 1..:data:`MAX_SAMPLES`;
    ``integrator`` a name."""
    path = f"solver.{name}"
    if name not in ALL_OPTIONS:
        close = difflib.get_close_matches(str(name), sorted(ALL_OPTIONS), n=1, cutoff=0.6)
        hint = f"; did you mean {close[0]!r}?" if close else ";"
        raise SceneError(path, f"unknown option {name!r}{hint} accepted options: "
                         f"{', '.join(sorted(ALL_OPTIONS))}")
    if value is None and name == "atol":
        return
    if name == "integrator":
        if not isinstance(value, str):
            raise SceneError(path, f"integrator must be a name, got {value!r}")
        return
    if name in _COUNTS:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise SceneError(path, f"{name} must be a positive integer, got {value!r}")
        if name == "n_samples" and value > MAX_SAMPLES:
            raise SceneError(path, f"n_samples must be at most {MAX_SAMPLES:,} (points in each "
                             f"sampled series), got {value:,}")
        return
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not np.isfinite(value) or value <= 0:
        raise SceneError(path, f"{name} must be a positive finite number, got {value!r}")
    if name == "rtol" and not value < 1:
        raise SceneError(path, f"rtol must be a positive finite number below 1 (a relative "
                         f"tolerance, such as 1e-10), got {value!r}")


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
