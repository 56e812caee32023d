"""The parts of a scene: its vehicles (with their effects), its contacts (each with its law and
effects) and its solver settings, each read from its table through the declarations of the laws
(:mod:`lsc.laws`) and effects (:mod:`lsc.effects`)."""

from __future__ import annotations

import difflib as _difflib
from dataclasses import dataclass, field
from typing import Any

from ..effects import Brake, Failure, FailureEffect, vehicle_effect_classes
from ..errors import SceneError
from ..laws import aliases as _law_aliases
from ..laws import law_class, laws
from ..solvers import METHODS, check_option as _check_option, methods as _methods
from ..units import UNITS
from ._read import _check_magnitude, _choice, _p, _qty, _shown, _table
from ._tables import Reader


@dataclass(frozen=True)
class Vehicle:
    """A rigid vehicle: ``mass`` [mass], initial ``speed`` [velocity], optional ``brake`` and other
    vehicle ``effects``."""

    name: str
    mass: float
    speed: float
    brake: Brake | None = None
    #: Other registered vehicle effects: (table key, its description) pairs.
    effects: tuple = ()


@dataclass(frozen=True)
class Contact:
    """The contact between vehicles ``k`` (rear) and ``k+1`` (front): its ``law``, the initial
    ``gap`` [length] and an optional ``failure`` effect."""

    law: Any
    gap: float = 0.0
    failure: Failure | None = None


@dataclass(frozen=True)
class SolverSettings:
    """The scene's ``[solver]`` table: ``method`` and its options (``rtol``, ``atol``, ``dt``, ...)."""

    method: str = "auto"
    options: dict = field(default_factory=dict)


_VEHICLE_KEYS = ("name", "weight", "mass", "speed")
_FAILURE_KEYS = FailureEffect.table_keys
_CONTACT_COMMON_KEYS = ("law", "gap", "failure")
#: The ``[solver]`` options by kind: tolerances (plain numbers), times, whole-number counts.
_SOLVER_TOLERANCES = ("rtol", "atol")
_SOLVER_TIMES = ("dt", "t_end")
_SOLVER_COUNTS = ("max_events", "max_steps", "n_samples")
_SOLVER_KEYS = ("method",) + _SOLVER_TOLERANCES + _SOLVER_TIMES + ("integrator",) + _SOLVER_COUNTS
_METHOD_ALIASES = {"closed": "closed-form", "closedform": "closed-form"}
#: Laws of DESIGN.md section 1 that this loader does not build yet.
_PLANNED_LAWS = ()


def vehicle_keys() -> tuple[str, ...]:
    """The keys of a vehicle's table: its own and every registered vehicle effect's table."""
    return _VEHICLE_KEYS + tuple(vehicle_effect_classes())


def law_keys(name: str) -> tuple[str, ...]:
    """The keys of a contact table with law ``name`` besides the common ones."""
    cls = law_class(name)
    return tuple(getattr(cls, "table_keys", None) or cls.keys())


def _law_name(value, path: str) -> str:
    accepted = ", ".join(f'"{n}"' for n in laws()) + ' (alias "if-d")'
    if isinstance(value, str):
        norm = value.strip().lower().replace("_", "-").replace(" ", "-")
        norm = _law_aliases().get(norm, norm)
        if norm in laws():
            return norm
        if norm in _PLANNED_LAWS:
            raise SceneError(path, f'the "{value}" contact law is not supported yet; accepted: {accepted}')
        close = _difflib.get_close_matches(norm, list(laws()) + list(_law_aliases()), n=1, cutoff=0.6)
        hint = f'; did you mean "{close[0]}"?' if close else ";"
        raise SceneError(path, f'unknown contact law "{value}"{hint} accepted: {accepted}')
    raise SceneError(path, f"the contact law is a name, one of {accepted}; got {_shown(value)}")


def _contact(spec, k: int, ctx: Reader) -> Contact:
    path = f"contacts[{k}]"
    if not isinstance(spec, dict):
        raise SceneError(path, f"expected a table such as {{ loading = {{ stiffness = 24000 }}, "
                               f"unloading = {{ restitution = 0.4 }} }}, got {_shown(spec)}")
    law = _law_name(spec["law"], _p(path, "law")) if "law" in spec else "hysteresis"
    _table(spec, path, _CONTACT_COMMON_KEYS + law_keys(law), "")
    model = law_class(law).read(spec, path, ctx)
    gap = _qty(spec, "gap", "length", ctx, path, default=0.0, minimum=0.0, strict=False)
    failure = None
    if "failure" in spec:
        failure = FailureEffect.read(spec["failure"], _p(path, "failure"), ctx, model)
    return Contact(model, gap, failure)


# ----------------------------------------------------------------- vehicles, solver
def _vehicle(spec, i: int, ctx: Reader) -> Vehicle:
    path = f"vehicles[{i}]"
    spec = _table(spec, path, vehicle_keys(), "{ weight = 3500, speed = 10 }")
    name = spec.get("name", f"vehicle {i + 1}")
    if not isinstance(name, str):
        raise SceneError(_p(path, "name"), f"a name is text, got {_shown(name)}")
    if "weight" in spec and "mass" in spec:
        raise SceneError(path, "give either weight or mass, not both")
    if "weight" in spec:
        hint = f'a weight is a force: write it in "lbf" (pound-force), or give mass = "{spec["weight"]}" instead'
        weight = _qty(spec, "weight", "force", ctx, path, minimum=0.0, hint=hint)
        mass = weight / ctx.g
        _check_magnitude(mass, _p(path, "weight"), UNITS[ctx.units]["mass"], "the mass weight / g = ")
    elif "mass" in spec:
        mass = _qty(spec, "mass", "mass", ctx, path, minimum=0.0)
    else:
        raise SceneError(path, "a vehicle needs its weight (or its mass)")
    speed = _qty(spec, "speed", "velocity", ctx, path, bounded=False)
    # a tiny speed is harmless (it is almost 0); the closing speeds are held in _check_closing
    _check_magnitude(speed, _p(path, "speed"), UNITS[ctx.units]["velocity"], lower=False)
    effects = {table: cls.read(spec[table], _p(path, table), ctx)
               for table, cls in vehicle_effect_classes().items() if table in spec}
    brake = effects.pop("brake", None)
    return Vehicle(name, mass, speed, brake, tuple(effects.items()))


def _solver(spec, ctx: Reader) -> SolverSettings:
    path = "solver"
    spec = _table(spec, path, _SOLVER_KEYS, '{ method = "auto" }')
    method = _choice(spec.get("method", "auto"), _methods(), _p(path, "method"), "solver method",
                     aliases=_METHOD_ALIASES)
    options = {}
    for key in _SOLVER_TOLERANCES:
        if key in spec:
            options[key] = _qty(spec, key, "dimensionless", ctx, path, minimum=0.0)
    for key in _SOLVER_TIMES:
        if key in spec:
            options[key] = _qty(spec, key, "time", ctx, path, minimum=0.0)
    if "integrator" in spec:
        name = spec["integrator"]
        if not isinstance(name, str) or not name.strip():
            raise SceneError(_p(path, "integrator"), f"an integrator is a name (e.g. \"DOP853\"), got {_shown(name)}")
        options["integrator"] = name.strip()
    for key in _SOLVER_COUNTS:
        if key in spec:
            n = _qty(spec, key, "dimensionless", ctx, path, minimum=0.0)
            if n != int(n):
                raise SceneError(_p(path, key), f"must be a whole number >= 1, got {n:g}")
            options[key] = int(n)
    for key, value in options.items():
        _check_option(key, value)
    return SolverSettings(method, options)
