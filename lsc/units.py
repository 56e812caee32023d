"""The units boundary: quantities given with units → plain floats in a scene's unit system.

Scenes give quantities as bare numbers (already in the scene's system, see
:data:`UNITS`) or as strings with units (``"10 ft/s"``, ``"16 km/h"``, ``"3500 lbf"``,
``"24000 lbf/ft"``, ``"1.2 in"``). Only this module talks to pint; its registry is created on first
use (creating it takes a fraction of a second) and conversion factors are cached per unit string,
so converting ``"12 ft/s"`` after ``"10 ft/s"`` costs a regex match and a multiplication.
"""

from __future__ import annotations

import math
import numbers
import re
from typing import Any

from .errors import SceneError

__all__ = ["to_system", "unit_factor", "registry", "parse_number", "KIND_EXAMPLES", "QUANTITY_FORM",
           "UNITS", "STANDARD_G", "register_kind"]

_REGISTRY = None

#: Unit of each kind of quantity in each unit system (pint spelling).
UNITS: dict[str, dict[str, str]] = {
    "SI": {"length": "m", "time": "s", "mass": "kg", "force": "N", "velocity": "m/s",
           "acceleration": "m/s^2", "stiffness": "N/m", "energy": "J", "damping": "N*s/m",
           "slowness": "s/m", "damping_per_length": "N*s/m^2",
           "dimensionless": ""},
    "US": {"length": "ft", "time": "s", "mass": "slug", "force": "lbf", "velocity": "ft/s",
           "acceleration": "ft/s^2", "stiffness": "lbf/ft", "energy": "ft*lbf",
           "damping": "lbf*s/ft", "slowness": "s/ft", "damping_per_length": "lbf*s/ft^2",
           "dimensionless": ""},
}

#: Standard gravity in each unit system (used for weight → mass unless the scene sets ``g``).
STANDARD_G = {"SI": 9.80665, "US": 32.174}

#: Examples shown in error messages for each kind of quantity.
KIND_EXAMPLES: dict[str, tuple[str, ...]] = {
    "length": ("1.2 in", "30 mm"),
    "time": ("0.2 s", "5 ms"),
    "mass": ("108.7 slug", "1600 kg"),
    "force": ("3500 lbf", "15 kN"),
    "velocity": ("10 ft/s", "16 km/h"),
    "acceleration": ("32.2 ft/s^2", "9.81 m/s^2"),
    "stiffness": ("24000 lbf/ft", "350 kN/m"),
    "energy": ("500 ft*lbf", "700 J"),
    "damping": ("300 lbf*s/ft", "4 kN*s/m"),
    "slowness": ("0.2 s/ft", "0.6 s/m"),
    "damping_per_length": ("20000 lbf*s/ft^2", "1 MN*s/m^2"),
    "dimensionless": ("0.4",),
}

#: A plain decimal number: digits with an optional point and exponent (``1.2``, ``-3``, ``4.5e3``),
#: or nan / inf (refused later as not finite). Stricter than float(), which also reads ``"1_0"``
#: as 10 and non-ASCII digits.
_NUMBER_TEXT = r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|nan|inf(?:inity)?)"
_PLAIN_NUMBER = re.compile(_NUMBER_TEXT, re.IGNORECASE)
# A quantity: a plain number, then the unit expression (checked by _UNIT_TEXT).
_NUMBER = re.compile(rf"\s*({_NUMBER_TEXT})\s*(.*?)\s*$", re.IGNORECASE)
# A unit expression and nothing else: unit names joined by *, /, · or a space, each with an
# optional power (``lbf*s/ft^2``, ``m/s²``, ``N·s/m``, ``%``); text after it (``"# note"``,
# ``"± 1"``, a second number) does not match. Parenthesised powers match here and are refused by
# _safe, with its own message.
_UNIT_NAME = r"(?:[^\W\d_]|[°%])[\w°⁻]*(?:\s*(?:\^|\*\*)\s*[+-]?[\w.()^]+)?"
_UNIT_TEXT = re.compile(rf"\*?\s*{_UNIT_NAME}(?:(?:\s*[*/·⋅]\s*|\s+){_UNIT_NAME})*")

#: The accepted form of a quantity written as text, for error messages.
QUANTITY_FORM = "exactly a number and a unit, with nothing after the unit"


def parse_number(text: str) -> float | None:
    """The float of ``text`` if it is a plain decimal number (see :data:`_NUMBER_TEXT`), else None.

    Shared by quantity strings and CSV cells: ``"1_0"``, ``"0x10"`` and ``"١٠"`` are not numbers.
    """
    text = text.strip()
    return float(text) if _PLAIN_NUMBER.fullmatch(text) else None


# unit string → (dimensionality as a sorted tuple, pint Unit); filled on first use of each string
_UNIT_CACHE: dict[str, tuple[tuple, Any]] = {}
# (unit string, target unit string) → multiplicative factor
_FACTOR_CACHE: dict[tuple[str, str], float] = {}
# kind → dimensionality (sorted tuple)
_KIND_DIMS: dict[str, tuple] = {}


def registry():
    """The module's :class:`pint.UnitRegistry`, created on first call."""
    global _REGISTRY
    if _REGISTRY is None:
        import pint

        try:  # pint's on-disk cache of parsed definitions: ~10x faster creation after the first
            _REGISTRY = pint.UnitRegistry(cache_folder=":auto:")
        except Exception:  # a read-only or missing cache folder: build it from the definitions
            _REGISTRY = pint.UnitRegistry()
    return _REGISTRY


def register_kind(kind: str, si: str, us: str, examples: tuple[str, ...]) -> str:
    """Add a kind of quantity (a contact law's or effect's own unit, such as force/length^n):
    its unit in SI and in US units (pint spelling) and examples for error messages; a kind
    already known is left as it is. Returns ``kind``."""
    if kind not in UNITS["SI"]:
        UNITS["SI"][kind] = si
        UNITS["US"][kind] = us
        KIND_EXAMPLES[kind] = tuple(examples)
    return kind


def _target(kind: str, system: str) -> str:
    return UNITS[system][kind]


def _unit(unit: str) -> tuple[tuple, Any]:
    """Dimensionality and pint unit of a unit expression (cached); raises on a bad expression."""
    hit = _UNIT_CACHE.get(unit)
    if hit is None:
        u = registry().parse_units(unit)
        dim = tuple(sorted(dict(u.dimensionality).items()))
        hit = (dim, u)
        if len(_UNIT_CACHE) < 10_000:
            _UNIT_CACHE[unit] = hit
    return hit


_POWER = re.compile(r"(\^|\*\*)\s*([^\s*/^]*)")
_EXPONENT = re.compile(r"[+-]?\d{1,2}(\.\d{1,3})?")
_NEXT_POWER = re.compile(r"\s*(\^|\*\*)")


def _safe(unit: str) -> bool:
    """Reject unit expressions that pint would spend unbounded time on (``"ft^(9^9^9)"``):
    short, no parentheses, each exponent a small literal, no chained powers."""
    if len(unit) > 60 or "(" in unit or ")" in unit:
        return False
    for m in _POWER.finditer(unit):
        if not _EXPONENT.fullmatch(m.group(2)) or _NEXT_POWER.match(unit, m.end()):
            return False
    return True


def _kind_dim(kind: str) -> tuple:
    dim = _KIND_DIMS.get(kind)
    if dim is None:
        dim = _unit(_target(kind, "SI"))[0]
        _KIND_DIMS[kind] = dim
    return dim


def _describe(dim: tuple) -> str:
    """'a force', 'a length', ... or 'has dimension ...' for a dimensionality."""
    for kind in KIND_EXAMPLES:
        if _kind_dim(kind) == dim:
            return "a plain number" if kind == "dimensionless" else _a(kind)
    text = " * ".join(f"{k}^{v}" if v != 1 else k for k, v in dim)
    return f"of dimension {text}"


#: Names of the kinds whose key in :data:`UNITS` is not plain English.
_KIND_NAMES = {"slowness": "time per length", "damping_per_length": "damping per length"}


def _a(kind: str) -> str:
    name = _KIND_NAMES.get(kind, kind)
    return f"an {name}" if name[0] in "aeiou" else f"a {name}"


def _expected(kind: str, system: str, adjective: str = "") -> str:
    ex = ", ".join(f'"{e}"' for e in KIND_EXAMPLES[kind])
    if kind == "dimensionless":
        return f"expected a {adjective + ' ' if adjective else ''}plain number (e.g. {ex})"
    what = f"a {adjective} {_KIND_NAMES.get(kind, kind)}" if adjective else _a(kind)
    return f"expected {what} (e.g. {ex} or a bare number in {_target(kind, system)})"


def _factor(unit: str, kind: str, system: str, shown: str, path: str, hint: str | None) -> float:
    """Factor from ``unit`` to the ``kind``'s unit in ``system`` (cached); SceneError if wrong."""
    target = _target(kind, system)
    key = (unit, target)
    f = _FACTOR_CACHE.get(key)
    if f is not None:
        return f
    try:
        if not _safe(unit):
            raise ValueError(unit)
        dim, u = _unit(unit)
    except Exception:  # pint raises many kinds of errors on malformed expressions
        raise SceneError(path, f'could not read "{shown}" as a quantity: unknown or unsupported unit "{unit}"; '
                               f'{_expected(kind, system)}') from None
    if dim != _kind_dim(kind):
        msg = f'"{shown}" is {_describe(dim)}, {_expected(kind, system)}'
        if hint and (kind != "force" or dim == _kind_dim("mass")):
            msg += f"; {hint}"
        elif kind == "force" and dim == _kind_dim("mass"):
            msg += '; "lb" is a pound of mass, a pound of force is "lbf"'
        raise SceneError(path, msg)
    try:
        q = registry().Quantity(1.0, u).to(target)
        f = float(q.magnitude)
    except Exception:  # offset units and the like
        raise SceneError(path, f'cannot convert "{shown}" to {target or "a plain number"}') from None
    if not (math.isfinite(f) and f > 0):
        raise SceneError(path, f'cannot convert "{shown}" to {target or "a plain number"}')
    if len(_FACTOR_CACHE) < 10_000:
        _FACTOR_CACHE[key] = f
    return f


def _is_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and type(value).__name__ != "bool_"


def _check_finite(x: float, value, path: str, kind: str, system: str) -> float:
    if not math.isfinite(x):
        if isinstance(value, str):
            raise SceneError(path, f'"{value}" is too large; {_expected(kind, system, "finite")}')
        raise SceneError(path, f"{value!r} is not a finite number; "
                               f"{_expected(kind, system, 'finite')}")
    return x


def to_system(value, kind: str, system: str, path: str, *, hint: str | None = None) -> float:
    """Convert a scene quantity to a float in ``system`` (``"SI"`` or ``"US"``).

    ``value`` is a bare number (taken to be in the system's unit of ``kind`` already), a string
    ``"<number> <unit>"`` (``"10 ft/s"``; ``"10"`` alone is a bare number) or a pint quantity.
    ``kind`` is a key of :data:`UNITS` (``"velocity"``, ``"force"``, ...).
    Raises :class:`SceneError` at ``path`` for booleans, non-numbers, NaN/inf, unknown units and
    quantities of the wrong dimension (``hint`` is added when a mass is given for a force).
    """
    if _is_number(value):
        try:
            x = float(value)
        except (OverflowError, ValueError):
            raise SceneError(path, f"{value!r} is too large; "
                                   f"{_expected(kind, system, 'finite')}") from None
        if not math.isfinite(x):
            raise SceneError(path, f"{value!r} is not a finite number; "
                                   f"{_expected(kind, system, 'finite')}")
        return x
    if isinstance(value, str):
        m = _NUMBER.fullmatch(value)
        if m is None or (m.group(2) and not _UNIT_TEXT.fullmatch(m.group(2))):
            raise SceneError(path, f'could not read "{value}" as a quantity: write {QUANTITY_FORM}; '
                                   f'{_expected(kind, system)}')
        x = float(m.group(1))
        unit = m.group(2)
        if not math.isfinite(x):
            raise SceneError(path, f'"{value}" is not a finite number; '
                                   f'{_expected(kind, system, "finite")}')
        if unit:
            if unit[0] == "*":  # "10 * ft/s"
                unit = unit[1:].strip()
            x = x * _factor(unit, kind, system, value.strip(), path, hint)
        return _check_finite(x, value, path, kind, system)
    if hasattr(value, "magnitude") and hasattr(value, "units"):  # a pint Quantity
        try:
            mag = float(value.magnitude)
            unit = str(value.units)
        except Exception:
            raise SceneError(path, f"cannot read {value!r} as a number") from None
        if not math.isfinite(mag):
            raise SceneError(path, f"{value!r} is not a finite number; "
                                   f"{_expected(kind, system, 'finite')}")
        value = f"{value}"
        unit = "" if unit == "dimensionless" else unit
        x = mag * _factor(unit, kind, system, f"{mag:g} {unit}".strip(), path, hint)
        return _check_finite(x, value, path, kind, system)
    raise SceneError(path, f"{_type_name(value)} is not a quantity; {_expected(kind, system)}")


def unit_factor(unit, kind: str, system: str, path: str) -> float:
    """Factor that converts numbers given in ``unit`` (e.g. ``"in"``) to ``kind`` in ``system``.

    Used for the column units of tables (``deformation = "in"``, ``force = "lbf"``).
    """
    if not isinstance(unit, str) or not unit.strip():
        raise SceneError(path, f"a column unit is a unit name such as "
                               f'"{KIND_EXAMPLES[kind][0].split(" ", 1)[-1]}", got {_type_name(unit)}')
    unit = unit.strip()
    if re.match(r"[+-]?[\d.]", unit):  # "1e-3 m" style: a scaled unit
        return to_system(unit, kind, system, path)
    return to_system("1 " + unit, kind, system, path)


def _type_name(value) -> str:
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if value is None:
        return "nothing (None)"
    if isinstance(value, str):
        return f'the text "{value}"'
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, (list, tuple)):
        return "a list"
    return f"{type(value).__name__} {value!r}"
