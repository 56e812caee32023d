"""Small helpers of the scene loader: child paths, plain copies, tables of known keys, one-of
choices, and quantities read in the scene's units within the magnitudes lsc computes with."""

from __future__ import annotations

import difflib as _difflib
from collections.abc import Mapping as _Mapping

import numpy as np

from ..errors import SceneError
from ..units import UNITS, _expected, _type_name, to_system as _to_system

_MAX_DEPTH = 64
_MISSING = object()


def _p(path: str, key) -> str:
    """Child path: ``_p("vehicles[0]", "speed") == "vehicles[0].speed"``; ints index lists."""
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)


def _plain(obj, depth: int = 0):
    """Deep copy of a scene input as plain dicts and lists (numpy arrays → lists)."""
    if depth > _MAX_DEPTH:
        raise SceneError("", "the scene is nested too deeply")
    if isinstance(obj, _Mapping):
        return {k: _plain(v, depth + 1) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v, depth + 1) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _shown(value) -> str:
    return f'"{value}"' if isinstance(value, str) else _type_name(value)


def _fmt(x: float, unit: str) -> str:
    return f"{x:g} {unit}".strip()


def _table(value, path: str, allowed: tuple[str, ...], example: str) -> dict:
    """Check that ``value`` is a table (dict) holding only ``allowed`` keys."""
    if not isinstance(value, dict):
        raise SceneError(path, f"expected a table such as {example}, got {_shown(value)}")
    for key in value:
        if key not in allowed:
            if not isinstance(key, str):
                raise SceneError(path, f"keys must be text, got {key!r}; accepted keys: {', '.join(allowed)}")
            close = _difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
            hint = f'; did you mean "{close[0]}"?' if close else ";"
            raise SceneError(_p(path, key), f'unknown key "{key}"{hint} accepted keys: {", ".join(allowed)}')
    return value


def _one_of(spec: dict, kinds: tuple[str, ...], path: str, what: str) -> str:
    """The one key of ``kinds`` present in ``spec`` (SceneError if none or several)."""
    given = [k for k in kinds if k in spec]
    if len(given) == 1:
        return given[0]
    names = ", ".join(kinds[:-1]) + " or " + kinds[-1]
    if not given:
        raise SceneError(path, f"{what} needs one of {names}")
    raise SceneError(path, f"{what} takes only one of {names}, got {' and '.join(given)}")


def _choice(value, accepted: tuple[str, ...], path: str, what: str, aliases=None) -> str:
    """A text value normalised (lower case, ``_``/space → ``-``) and checked against ``accepted``."""
    if not isinstance(value, str):
        raise SceneError(path, f"{what} must be text, one of {', '.join(accepted)}; got {_shown(value)}")
    norm = value.strip().lower().replace("_", "-").replace(" ", "-")
    if aliases and norm in aliases:
        norm = aliases[norm]
    if norm in accepted:
        return norm
    pool = list(accepted) + list(aliases or ())
    close = _difflib.get_close_matches(norm, pool, n=1, cutoff=0.6)
    hint = f'; did you mean "{close[0]}"?' if close else ";"
    raise SceneError(path, f'unknown {what} "{value}"{hint} accepted: {", ".join(accepted)}')


def _qty(spec: dict, key: str, kind: str, ctx, path: str, *, default=_MISSING,
         minimum: float | None = None, strict: bool = True, hint: str | None = None,
         bounded: bool | None = None) -> float:
    """Read ``spec[key]`` as a ``kind`` quantity in the scene's units, with a lower bound.

    ``minimum`` with ``strict`` means ``> minimum``; otherwise ``>= minimum``. ``bounded``
    (default: for every kind but plain numbers) also holds the value to :data:`MAGNITUDES`.
    ``ctx``: the load's :class:`~lsc.scene.Reader` (its unit system).
    """
    p = _p(path, key)
    if key not in spec:
        if default is _MISSING:
            raise SceneError(p, f"is required: {_expected(kind, ctx.units)}")
        return default
    x = _to_system(spec[key], kind, ctx.units, p, hint=hint)
    if minimum is not None and (x <= minimum if strict else x < minimum):
        unit = UNITS[ctx.units][kind]
        op = ">" if strict else ">="
        raise SceneError(p, f"must be {op} {minimum:g}, got {_fmt(x, unit)}")
    if bounded if bounded is not None else kind != "dimensionless":
        _check_magnitude(x, p, UNITS[ctx.units][kind])
    return x



#: The magnitudes a scene's quantities may have, in its unit system (or exactly 0): a product or
#: quotient of three of them (an energy m v², a force v √(k m), a time √(m/k), ...) lies between
#: 1e-300 and 1e300, inside the range of normal floats (2.2e-308 to 1.8e308), so no result
#: overflows to inf or loses its precision to a subnormal.
MAGNITUDES = (1e-100, 1e100)


def _check_magnitude(x: float, path: str, unit: str, what: str = "", lower: bool = True) -> None:
    """SceneError at ``path`` unless ``x`` is 0 or its magnitude is within :data:`MAGNITUDES`
    (``lower=False``: only at most the upper end)."""
    lo, hi = MAGNITUDES
    if x != 0 and (abs(x) > hi or (lower and abs(x) < lo)):
        span = f"from {lo:g} to {hi:g} {unit} (or 0)" if lower else f"of at most {hi:g} {unit}"
        raise SceneError(path, f"{what}{_fmt(x, unit)} is outside the range lsc computes with: a "
                               f"magnitude {span}, so that the energies, forces and times formed from "
                               "it stay finite, normal floats")
