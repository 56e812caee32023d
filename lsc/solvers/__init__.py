"""The backends, their registry and the ``auto`` dispatch.

Each backend declares itself in a :class:`~lsc.solvers.base.Backend` named ``BACKEND`` in its
module (see :mod:`lsc.solvers.base`); the registry maps method names to those modules and
imports them on first use. ``auto`` reads the declarations: the cheapest exact backend that
declares everything the scene uses (the closed form, then the exact piecewise solve), otherwise
the event-driven SciPy solve; for a large batch with no exact batch path, the batched
integrator (diffrax) when it is installed.
"""

from __future__ import annotations

import importlib

from ..errors import SceneError
from .base import MAX_SAMPLES, OPTIONS, Backend, Option, check_option

__all__ = ["METHODS", "ALL_OPTIONS", "MAX_SAMPLES", "OPTIONS", "Backend", "Option", "backend",
           "backends", "register", "methods", "pick", "run", "options_of", "check_option",
           "solvers_for", "LARGE_BATCH"]

# Method name -> the module that declares it (``BACKEND``), in the order ``auto`` and messages
# list them. Extensions add theirs with :func:`register`.
_DECLARED: dict[str, object] = {
    "closed-form": "lsc.solvers.closed_form",
    "exact": "lsc.solvers.exact",
    "exact-chain": "lsc.solvers.exact_chain",
    "scipy": "lsc.solvers.scipy_ode",
    "diffrax": "lsc.solvers.diffrax_ode",
    "reference": "lsc.solvers.reference",
}

#: The built-in values of ``method`` (:func:`methods` adds registered ones).
METHODS = ("auto", *_DECLARED)
#: Every option that some backend accepts (:data:`lsc.solvers.base.OPTIONS`); any other name is
#: an error for every method, ``auto`` included.
ALL_OPTIONS = frozenset(OPTIONS)
#: ``auto`` sends a batch of at least this many members with no exact batch path to the batched
#: integrator, when installed (its compilation, about 20 s, is then repaid).
LARGE_BATCH = 1000
#: The general integrator ``auto`` falls back on.
_FALLBACK = "scipy"
#: The batched integrator ``auto`` uses for large batches.
_BATCHED = "diffrax"


def methods() -> tuple[str, ...]:
    """Every accepted value of ``method``: ``"auto"`` and each registered backend."""
    return ("auto", *_DECLARED)


def register(declaration: Backend | str, name: str | None = None) -> None:
    """Add a backend: its :class:`Backend` declaration, or the name of the module that holds it
    as ``BACKEND`` (then give its method ``name``; the module is imported on first use)."""
    if isinstance(declaration, Backend):
        _DECLARED[declaration.name] = declaration
    else:
        if not name:
            raise ValueError("register(module, name): give the method name of the backend")
        _DECLARED[name] = str(declaration)


def unregister(name: str) -> None:
    """Remove a backend added with :func:`register` (built-in ones stay)."""
    if name not in METHODS:
        _DECLARED.pop(name, None)


def backend(name: str) -> Backend:
    """The declaration of backend ``name`` (its module imported now, if not yet)."""
    if name not in _DECLARED:
        raise SceneError("solver.method", f"unknown method {name!r}; accepted: "
                         + ", ".join(repr(m) for m in methods()))
    decl = _DECLARED[name]
    if isinstance(decl, str):
        decl = importlib.import_module(decl).BACKEND
        _DECLARED[name] = decl
    return decl


def backends() -> list[Backend]:
    """Every registered backend's declaration, in registry order."""
    return [backend(n) for n in _DECLARED]


def options_of(method: str) -> set[str]:
    """The options backend ``method`` accepts (empty for an unknown one)."""
    return set(backend(method).options) if method in _DECLARED else set()


def _model(scene_or_model):
    from ..model import HybridModel

    return scene_or_model if isinstance(scene_or_model, HybridModel) else HybridModel(scene_or_model)


def solvers_for(scene_or_model) -> list[str]:
    """The backends (names) whose declarations cover everything ``scene_or_model`` uses."""
    model = _model(scene_or_model)
    return [b.name for b in backends() if not b.missing(model)]


def pick(scene_or_model, method: str, members: int | None = None) -> str:
    """The backend ``method`` resolves to for a scene (or model): itself, or for ``auto`` the
    cheapest available exact backend that declares everything the scene uses, else SciPy. With
    ``members`` (a batch of that many), ``auto`` prefers exact backends whose batch path solves
    the scene, and for :data:`LARGE_BATCH` members or more with none, the batched integrator
    when installed."""
    if method not in _DECLARED and method != "auto":
        raise SceneError("solver.method", f"unknown method {method!r}; accepted: "
                         + ", ".join(repr(m) for m in methods()))
    if method != "auto":
        return method
    model = _model(scene_or_model)
    exact = sorted((b for b in backends()
                    if b.exact and b.auto and b.available() and not b.missing(model)),
                   key=lambda b: b.cost)
    if members is not None:
        batched = [b for b in exact if not b.missing(model, batch=True)]
        if batched:
            return batched[0].name
        if not exact and members >= LARGE_BATCH:
            b = backend(_BATCHED)
            if b.available() and not b.missing(model, batch=True):
                return b.name
    return exact[0].name if exact else _FALLBACK


def run(model, method: str, options: dict):
    """Solve ``model`` with backend ``method`` (already resolved) and its ``options``: checked
    against the backend's declaration, then solved."""
    return backend(method).solve(model, **options)
