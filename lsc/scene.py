"""Scenes: the validated input of a simulation.

A scene is loaded from a dict, a TOML file (path) or an existing :class:`Scene` by
:meth:`Scene.load` (or :func:`load_scene`). Units are applied here and only here: every number
held by a :class:`Scene` is a plain float in the scene's coherent unit system, ``"SI"`` (m, s, kg,
N) or ``"US"`` (ft, s, slug, lbf). Results are reported in that same system.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .curves import Curve
from .errors import SceneError

__all__ = [
    "Scene", "Vehicle", "Brake", "Contact", "Hysteresis", "Restitution", "UnloadingStiffness",
    "UnloadingTable", "Damping", "Failure", "SolverSettings", "load_scene", "UNITS", "STANDARD_G", "METHODS",
]

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


@dataclass(frozen=True)
class Brake:
    """Coulomb tyre friction on one vehicle: kinetic ``mu`` and static ``mu_static`` (>= mu)."""

    mu: float
    mu_static: float


@dataclass(frozen=True)
class Vehicle:
    """A rigid vehicle: ``mass`` [mass], initial ``speed`` [velocity], optional ``brake``."""

    name: str
    mass: float
    speed: float
    brake: Brake | None = None


@dataclass(frozen=True)
class Restitution:
    """Straight unloading line to the permanent set that returns ``e**2`` of the absorbed energy."""

    e: float


@dataclass(frozen=True)
class UnloadingStiffness:
    """Straight unloading line of slope ``stiffness`` [force/length] from ``(D_max, F_max)``."""

    stiffness: float


@dataclass(frozen=True, eq=False)
class UnloadingTable:
    """A measured rebound curve in time order, from its start ``(d[0], f[0])`` (``f[0] > 0``) to
    zero force (``f[-1] == 0``), deformation strictly decreasing [length, force]. It is mapped onto
    the simulated start ``(D_max, F_max)``: deformation shifted by ``D_max - d[0]``, force scaled by
    ``F_max / f[0]``."""

    d: np.ndarray
    f: np.ndarray


@dataclass(frozen=True)
class Hysteresis:
    """The paper's IF-D contact law: a loading curve and an unloading rule."""

    loading: Curve
    unloading: Restitution | UnloadingStiffness | UnloadingTable
    name = "hysteresis"


@dataclass(frozen=True)
class Damping:
    """A spring–dashpot contact law (an effect a scene names with ``law = ...``).

    ``law``: ``"kelvin"`` (``F = k D + c Ḋ``), ``"hunt-crossley"`` (``F = k D^n (1 + α Ḋ)``) or
    ``"brach"`` (``F = k D + c D Ḋ``, ``c = c1`` compressing, ``c2`` restoring); always
    ``F >= 0``. ``stiffness`` k [force/length^n], ``exponent`` n (Hunt–Crossley), ``damping``:
    Kelvin c [force·time/length], Hunt–Crossley α [time/length], Brach c1
    [force·time/length²]; ``damping_restitution``: Brach c2; or ``restitution``: the target e,
    converted by the law's own relation.
    """

    law: str
    stiffness: float
    exponent: float = 1.0
    damping: float | None = None
    damping_restitution: float | None = None
    restitution: float | None = None

    @property
    def name(self) -> str:
        """The law's name."""
        return self.law


@dataclass(frozen=True)
class Failure:
    """Bumper failure: the contact ``force`` [force] above which a bumper is deemed to fail, and an
    optional loading curve ``post_failure`` to follow after failure (IF-D law only).

    With ``post_failure`` the bumper fails where its loading curve first reaches ``force``, at
    deformation ``D_f``; loading then goes on along ``post_failure`` counted from there,
    ``F = post_failure(D - D_f)`` (the force may step at ``D_f``; see
    :meth:`~lsc.curves.Curve.splice`)."""

    force: float
    post_failure: Curve | None = None


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


@dataclass(frozen=True, eq=False)
class Scene:
    """A validated scene. Build it with :meth:`Scene.load`; all values are in ``units``."""

    name: str
    units: str
    g: float
    vehicles: tuple[Vehicle, ...]
    contacts: tuple[Contact, ...]
    solver: SolverSettings = field(default_factory=SolverSettings)
    source: dict = field(default_factory=dict)
    base_dir: Path | None = None
    #: The unit speeds and ΔVs are printed in (``[display] speed_unit``: ``"mph"``, ``"km/h"``,
    #: ``"ft/s"``, ``"m/s"``; ``None``: the scene's velocity unit). Results keep scene units.
    speed_unit: str | None = None

    @property
    def n_vehicles(self) -> int:
        """Number of vehicles N."""
        return len(self.vehicles)

    @property
    def masses(self) -> np.ndarray:
        """Vehicle masses (N,) [mass]."""
        return np.array([v.mass for v in self.vehicles])

    @property
    def speeds(self) -> np.ndarray:
        """Initial vehicle speeds (N,) [velocity]."""
        return np.array([v.speed for v in self.vehicles])

    def unit(self, kind: str) -> str:
        """The unit of a kind of quantity (``"force"``, ``"velocity"``, ...) in this scene."""
        return UNITS[self.units][kind]

    @classmethod
    def load(cls, obj, *, base_dir=None) -> "Scene":
        """Load and validate a scene from a dict, a TOML path (str or Path) or a Scene."""
        return _load(obj, base_dir=base_dir)

    def with_values(self, values: dict[str, Any]) -> "Scene":
        """A new scene with dotted-path fields replaced (``{"vehicles.0.speed": 5}``)."""
        return _with_values(self, values)


def load_scene(obj, *, base_dir=None) -> Scene:
    """Load and validate a scene (dict, TOML path or :class:`Scene`); see :meth:`Scene.load`."""
    return Scene.load(obj, base_dir=base_dir)


# --------------------------------------------------------------------------- loading
# (implementation below: _load, _with_values)

import difflib as _difflib
import errno as _errno
import math as _math
import os as _os
import re as _re
import stat as _stat
import tomllib as _tomllib
from collections.abc import Mapping as _Mapping

from .solvers import check_option as _check_option
from .units import _expected, _type_name, parse_number as _parse_number, to_system as _to_system, \
    unit_factor as _unit_factor

#: Solver methods accepted in ``[solver] method``.
METHODS = ("auto", "closed-form", "exact", "scipy", "diffrax", "reference")

_TOP_KEYS = ("name", "units", "g", "vehicles", "contacts", "solver", "uncertainty", "display")
_VEHICLE_KEYS = ("name", "weight", "mass", "speed", "brake")
_BRAKE_KEYS = ("mu", "mu_static")
_COLUMN_KEYS = ("deformation", "force")
_LOADING_KINDS = ("stiffness", "table", "csv", "series")
_LOADING_KEYS = _LOADING_KINDS + ("scale",) + _COLUMN_KEYS
_UNLOADING_KINDS = ("restitution", "stiffness", "table", "csv")
_UNLOADING_KEYS = _UNLOADING_KINDS + _COLUMN_KEYS
_FAILURE_KEYS = ("force", "post_failure")
_CONTACT_COMMON_KEYS = ("law", "gap", "failure")
#: The ``[solver]`` options by kind: tolerances (plain numbers), times, whole-number counts.
_SOLVER_TOLERANCES = ("rtol", "atol")
_SOLVER_TIMES = ("dt", "t_end")
_SOLVER_COUNTS = ("max_events", "max_steps", "n_samples")
_SOLVER_KEYS = ("method",) + _SOLVER_TOLERANCES + _SOLVER_TIMES + ("integrator",) + _SOLVER_COUNTS
_METHOD_ALIASES = {"closed": "closed-form", "closedform": "closed-form"}
_DISPLAY_KEYS = ("speed_unit",)
_MAX_DEPTH = 64
_MISSING = object()


class _Ctx:
    """What every part of one load needs: the unit system, gravity and the CSV folder."""

    __slots__ = ("units", "g", "base_dir")

    def __init__(self, units: str, base_dir: Path):
        self.units = units
        self.g = STANDARD_G[units]
        self.base_dir = base_dir


# ----------------------------------------------------------------- small helpers
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


def _qty(spec: dict, key: str, kind: str, ctx: _Ctx, path: str, *, default=_MISSING,
         minimum: float | None = None, strict: bool = True, hint: str | None = None,
         bounded: bool | None = None) -> float:
    """Read ``spec[key]`` as a ``kind`` quantity in the scene's units, with a lower bound.

    ``minimum`` with ``strict`` means ``> minimum``; otherwise ``>= minimum``. ``bounded``
    (default: for every kind but plain numbers) also holds the value to :data:`MAGNITUDES`.
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


# ----------------------------------------------------------------- tables and curves
def _columns(spec: dict, ctx: _Ctx, path: str) -> tuple[float | None, float | None]:
    """Column unit factors of a table / csv (``deformation = "in"``, ``force = "lbf"``)."""
    fd = _unit_factor(spec["deformation"], "length", ctx.units, _p(path, "deformation")) \
        if "deformation" in spec else None
    ff = _unit_factor(spec["force"], "force", ctx.units, _p(path, "force")) if "force" in spec else None
    return fd, ff


def _cell(value, kind: str, factor: float | None, ctx: _Ctx, path: str) -> float:
    t = type(value)
    if t is float or t is int:
        fin = _expected(kind, ctx.units, "finite")
        try:
            x = float(value)
        except OverflowError:
            raise SceneError(path, f"{value!r} is too large; {fin}") from None
        if not _math.isfinite(x):
            raise SceneError(path, f"{value!r} is not a finite number; {fin}")
        x *= 1.0 if factor is None else factor
        if not _math.isfinite(x):
            raise SceneError(path, f"{value!r} is too large; {fin}")
        return x
    if isinstance(value, str) and factor is not None:
        raise SceneError(path, f"give bare numbers when the column's unit is set (by the "
                               f"\"{'deformation' if kind == 'length' else 'force'}\" key), got {_shown(value)}")
    x = _to_system(value, kind, ctx.units, path)
    return x * (1.0 if factor is None else factor)


def _check_points(points: np.ndarray, path: str, ctx: _Ctx) -> np.ndarray:
    """Hold every deformation and force of a table to at most the upper end of
    :data:`MAGNITUDES` (SceneError at the row); a tiny value is almost 0, and harmless."""
    bad = np.abs(points) > MAGNITUDES[1]
    if np.any(bad):
        i, j = (int(a) for a in np.argwhere(bad)[0])
        unit = UNITS[ctx.units]["length" if j == 0 else "force"]
        _check_magnitude(float(points[i, j]), path, unit, f"row {i}: ", lower=False)
    return points


def _points(value, path: str, factors, ctx: _Ctx) -> np.ndarray:
    """A list of ``[deformation, force]`` pairs → an (n, 2) array in scene units."""
    if not isinstance(value, list):
        raise SceneError(path, f"a table is a list of [deformation, force] pairs, got {_shown(value)}")
    fd, ff = factors
    out = np.empty((len(value), 2))
    for i, row in enumerate(value):
        if not isinstance(row, list) or len(row) != 2:
            raise SceneError(f"{path}[{i}]", f"expected a [deformation, force] pair, got {_shown(row)}")
        out[i, 0] = _cell(row[0], "length", fd, ctx, f"{path}[{i}][0]")
        out[i, 1] = _cell(row[1], "force", ff, ctx, f"{path}[{i}][1]")
    return _check_points(out, path, ctx)


def _expand(file: Path) -> Path:
    """``~`` expanded where it can be."""
    try:
        return file.expanduser()
    except RuntimeError:  # no home directory for "~user"
        return file


#: Largest scene file read [bytes] (a scene is a few kB; its tables can be long).
MAX_SCENE_BYTES = 10 * 2**20
#: Largest CSV file read [bytes] (a million rows of two numbers fit easily).
MAX_CSV_BYTES = 64 * 2**20
# A header cell holds a word (a data cell like "1_0" or "1,2e" does not make a row a header).
_HEADER_CELL = _re.compile(r"[^\W\d_]{2,}|^[^\W\d_]$")


class _TooLarge(ValueError):
    """A file that is not a regular file or is larger than the limit for its kind."""


def _read_text(file: Path, limit: int, what: str) -> str:
    """The text of a regular ``file`` of at most ``limit`` bytes (UTF-8, BOM skipped).

    Devices, pipes and folders are refused before they are opened (``/dev/zero`` never ends, a
    FIFO would block); raises :class:`_TooLarge`, or what opening and decoding raise.
    """
    st = file.stat()
    if _stat.S_ISDIR(st.st_mode):
        raise IsADirectoryError(_errno.EISDIR, "is a folder, not a file", str(file))
    if not _stat.S_ISREG(st.st_mode):
        raise _TooLarge(f"{file} is not a regular file (a device, pipe or socket); "
                        f"give the path of a {what}")
    with open(file, "rb") as fh:
        data = fh.read(limit + 1)
    if len(data) > limit:
        raise _TooLarge(f"{file} is larger than {limit // 2**20} MB, the most lsc reads from a {what}")
    return data.decode("utf-8-sig")


def _read_csv(value, path: str, factors, ctx: _Ctx) -> np.ndarray:
    """Two numeric columns (deformation, force) from a CSV file; a header row is skipped."""
    if not isinstance(value, (str, _os.PathLike)) or not str(value).strip():
        raise SceneError(path, f"expected the path of a CSV file, got {_shown(value)}")
    file = _expand(Path(value))
    if not file.is_absolute():
        file = ctx.base_dir / file
    try:
        text = _read_text(file, MAX_CSV_BYTES, "CSV file")
    except FileNotFoundError:
        raise SceneError(path, f"file not found: {file} (expected a CSV file of two columns, "
                               "deformation and force; a relative path is taken from the scene "
                               "file's folder)") from None
    except _TooLarge as e:
        raise SceneError(path, str(e)) from None
    except UnicodeDecodeError:
        raise SceneError(path, f"{file} is not a text (CSV) file") from None
    except (OSError, ValueError) as e:
        raise SceneError(path, f"cannot read {file}: {getattr(e, 'strerror', None) or e}") from None
    rows = []
    first = True
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        sep = "," if "," in line else (";" if ";" in line else None)
        cells = [c.strip().strip('"').strip("'").strip() for c in line.split(sep)]
        while cells and not cells[-1]:
            cells.pop()
        nums = [_parse_number(c) for c in cells]
        if first:
            first = False
            if all(x is None and _HEADER_CELL.search(c) for x, c in zip(nums, cells)):
                continue  # header row: no number, and words in every cell
        if len(cells) != 2:
            raise SceneError(path, f"{file}, line {lineno}: expected 2 columns (deformation, force), "
                                   f"got {len(cells)}")
        for c, x in zip(cells, nums):
            if x is None:
                raise SceneError(path, f'{file}, line {lineno}: "{c}" is not a number; expected '
                                       "two numeric columns (deformation, force), each cell a plain "
                                       "decimal number such as 1.2, -3 or 4.5e3")
            if not _math.isfinite(x):
                raise SceneError(path, f'{file}, line {lineno}: "{c}" is not a finite number; '
                                       "expected two finite numeric columns (deformation, force)")
        rows.append(nums)
    if not rows:
        raise SceneError(path, f"{file} has no data rows (expected two columns: deformation, force)")
    arr = np.array(rows, dtype=float)
    fd, ff = factors
    if fd is not None:
        arr[:, 0] *= fd
    if ff is not None:
        arr[:, 1] *= ff
    if not np.all(np.isfinite(arr)):
        raise SceneError(path, f"{file}: values too large after unit conversion")
    return _check_points(arr, path, ctx)


def _loading(spec, path: str, ctx: _Ctx) -> Curve:
    """A loading spec (``stiffness`` | ``table`` | ``csv`` | ``series``, optional ``scale``) → Curve."""
    spec = _table(spec, path, _LOADING_KEYS, "{ stiffness = 24000 }")
    kind = _one_of(spec, _LOADING_KINDS, path, "a loading curve")
    if kind not in ("table", "csv"):
        for key in _COLUMN_KEYS:
            if key in spec:
                raise SceneError(_p(path, key), f"column units apply to a table or csv, not to {kind}")
    sub = _p(path, kind)
    try:
        if kind == "stiffness":
            curve = Curve.linear(_qty(spec, "stiffness", "stiffness", ctx, path, minimum=0.0))
        elif kind == "table":
            curve = Curve.table(_points(spec["table"], sub, _columns(spec, ctx, path), ctx))
        elif kind == "csv":
            curve = Curve.table(_read_csv(spec["csv"], sub, _columns(spec, ctx, path), ctx))
        else:
            parts = spec["series"]
            if not isinstance(parts, list) or len(parts) != 2:
                n = f"{len(parts)} curves" if isinstance(parts, list) else _shown(parts)
                raise SceneError(sub, f"a series combines exactly two loading curves "
                                      f"([{{ stiffness = ... }}, {{ table = ... }}]), got {n}")
            a, b = (_loading(c, f"{sub}[{i}]", ctx) for i, c in enumerate(parts))
            curve = Curve.series(a, b)
    except SceneError:
        raise
    except ValueError as e:
        raise SceneError(sub, str(e)) from None
    if "scale" in spec:
        factor = _qty(spec, "scale", "dimensionless", ctx, path, minimum=0.0, bounded=True)
        try:
            curve = curve.scaled(factor)
        except ValueError as e:
            raise SceneError(_p(path, "scale"), str(e)) from None
        _check_points(np.column_stack([curve.d, curve.f]), _p(path, "scale"), ctx)
    return curve


def _unloading(spec, path: str, ctx: _Ctx, loading: Curve):
    """An unloading spec (``restitution`` | ``stiffness`` | ``table`` | ``csv``) → its rule."""
    spec = _table(spec, path, _UNLOADING_KEYS, "{ restitution = 0.4 }")
    kind = _one_of(spec, _UNLOADING_KINDS, path, "the unloading branch")
    if kind not in ("table", "csv"):
        for key in _COLUMN_KEYS:
            if key in spec:
                raise SceneError(_p(path, key), f"column units apply to a table or csv, not to {kind}")
    sub = _p(path, kind)
    if kind == "restitution":
        e = _qty(spec, kind, "dimensionless", ctx, path)
        if not 0.0 <= e <= 1.0:
            raise SceneError(sub, f"must be between 0 (no rebound) and 1 (elastic), got {e:g}")
        return Restitution(e)
    if kind == "stiffness":
        s = _qty(spec, kind, "stiffness", ctx, path, minimum=0.0)
        if loading.is_linear and s < loading.stiffness:
            unit = UNITS[ctx.units]["stiffness"]
            raise SceneError(sub, f"{_fmt(s, unit)} is softer than the loading stiffness "
                                  f"{_fmt(loading.stiffness, unit)}: the rebound would return more energy "
                                  f"than the crush absorbed; use a stiffness >= {loading.stiffness:g} "
                                  f"or give restitution")
        return UnloadingStiffness(s)
    read = _points if kind == "table" else _read_csv  # a csv: the same points, from a file
    pts = read(spec[kind], sub, _columns(spec, ctx, path), ctx)
    if pts.shape[0] < 2:
        raise SceneError(sub, f"an unloading table needs at least two points, got {pts.shape[0]}")
    d, f = pts[:, 0].copy(), pts[:, 1].copy()
    if not np.all(np.diff(d) < 0):
        i = int(np.argmax(~(np.diff(d) < 0))) + 1
        raise SceneError(sub, f"deformation must strictly decrease along the rebound (in time order); "
                              f"point {i} has {d[i]:g} after {d[i - 1]:g}")
    if np.any(f < 0):
        i = int(np.argmax(f < 0))
        raise SceneError(sub, f"forces must be >= 0: bumpers push, never pull (point {i} has {f[i]:g})")
    if not f[0] > 0:
        raise SceneError(sub, "the first point is the start of the rebound and needs a force > 0")
    if f[-1] != 0.0:
        raise SceneError(sub, f"the last point must have force exactly 0 (separation), got {f[-1]:g}")
    d.setflags(write=False)
    f.setflags(write=False)
    return UnloadingTable(d, f)


def _hysteresis(spec: dict, path: str, ctx: _Ctx) -> Hysteresis:
    """The IF-D law from a contact's ``loading`` and ``unloading`` keys."""
    if "loading" not in spec:
        raise SceneError(_p(path, "loading"), "is required (e.g. loading = { stiffness = 24000 })")
    loading = _loading(spec["loading"], _p(path, "loading"), ctx)
    if "unloading" not in spec:
        raise SceneError(_p(path, "unloading"),
                         "is required: { restitution = e } or { stiffness = ... } or { table = ... } "
                         "or { csv = ... }")
    unloading = _unloading(spec["unloading"], _p(path, "unloading"), ctx, loading)
    return Hysteresis(loading, unloading)


def _restitution_target(spec: dict, path: str, ctx: _Ctx) -> float:
    e = _qty(spec, "restitution", "dimensionless", ctx, path)
    if not 0 < e <= 1:
        raise SceneError(_p(path, "restitution"), "a damping law's target restitution must be in "
                         f"(0, 1] (e = 0 needs an infinite damping), got {e:g}")
    return e


#: Unit kind of each damping law's damping coefficient, and what to say when another is given.
_DAMPING_KINDS = {
    "kelvin": ("damping", "Kelvin's c multiplies the closing rate: F = k D + c dD/dt"),
    "hunt-crossley": ("slowness", "Hunt–Crossley's α multiplies the closing rate in "
                                  "F = k D^n (1 + α dD/dt): it is not a Kelvin damping c"),
    "brach": ("damping_per_length", "Brach's c multiplies D dD/dt in F = k D + c D dD/dt"),
}


def _damping_law(law: str):
    """The builder of a spring–dashpot law from a contact's keys."""
    def build(spec: dict, path: str, ctx: _Ctx) -> Damping:
        n = 1.0
        if law == "hunt-crossley":
            n = _qty(spec, "exponent", "dimensionless", ctx, path, default=1.0, minimum=0.0)
        if law == "hunt-crossley" and n != 1.0:
            kind = _stiffness_kind(n)
            k = _qty(spec, "stiffness", kind, ctx, path, minimum=0.0)
        else:
            k = _qty(spec, "stiffness", "stiffness", ctx, path, minimum=0.0)
        dkind, dhint = _DAMPING_KINDS[law]
        if law == "brach":
            c1 = _qty(spec, "damping", dkind, ctx, path, default=0.0, minimum=0.0, strict=False,
                      hint=dhint)
            if _not_exactly_one(spec, law):
                raise SceneError(path, "Brach's law needs exactly one of damping_restitution (c2) "
                                       "or restitution (the target e, which sets c2)")
            if "restitution" in spec:
                return Damping(law, k, n, c1, None, _restitution_target(spec, path, ctx))
            c2 = _qty(spec, "damping_restitution", dkind, ctx, path, minimum=0.0, strict=False,
                      hint=dhint)
            return Damping(law, k, n, c1, c2, None)
        if _not_exactly_one(spec, law):
            raise SceneError(path, f"the {law} law needs exactly one of damping or restitution "
                                   "(the target e, converted by the law's own relation)")
        if "restitution" in spec:
            return Damping(law, k, n, None, None, _restitution_target(spec, path, ctx))
        return Damping(law, k, n, _qty(spec, "damping", dkind, ctx, path, minimum=0.0,
                                       strict=False, hint=dhint), None, None)
    return build


def _not_exactly_one(spec: dict, law: str) -> bool:
    """Whether ``spec`` holds none or both of the law's :data:`_DAMPING_CHOICES` (none or both)."""
    a, b = _DAMPING_CHOICES[law]
    return (a in spec) == (b in spec)


def _stiffness_kind(n: float) -> str:
    """A unit kind for force/length^n (Hunt–Crossley stiffness), registered on first use."""
    from .units import KIND_EXAMPLES

    kind = f"stiffness^{n:g}"
    if kind not in UNITS["SI"]:
        UNITS["SI"][kind] = f"N/m^{n:g}"
        UNITS["US"][kind] = f"lbf/ft^{n:g}"
        KIND_EXAMPLES[kind] = (f"60000 lbf/ft^{n:g}", f"5e6 N/m^{n:g}")
    return kind


_DAMPING_KEYS = ("stiffness", "damping", "restitution")
#: The two keys of which each damping law takes exactly one (the other damping keys are optional).
_DAMPING_CHOICES = {"kelvin": ("damping", "restitution"),
                    "hunt-crossley": ("damping", "restitution"),
                    "brach": ("damping_restitution", "restitution")}

#: Contact laws this loader builds: name → (law-specific keys, builder(spec, path, ctx)).
_CONTACT_LAWS = {
    "hysteresis": (("loading", "unloading"), _hysteresis),
    "kelvin": (_DAMPING_KEYS, _damping_law("kelvin")),
    "hunt-crossley": (_DAMPING_KEYS + ("exponent",), _damping_law("hunt-crossley")),
    "brach": (_DAMPING_KEYS + ("damping_restitution",), _damping_law("brach")),
}
_LAW_ALIASES = {"if-d": "hysteresis", "ifd": "hysteresis"}
#: Laws of DESIGN.md section 1 that this loader does not build yet.
_PLANNED_LAWS = ()


def _law_name(value, path: str) -> str:
    accepted = ", ".join(f'"{n}"' for n in _CONTACT_LAWS) + ' (alias "if-d")'
    if isinstance(value, str):
        norm = value.strip().lower().replace("_", "-").replace(" ", "-")
        norm = _LAW_ALIASES.get(norm, norm)
        if norm in _CONTACT_LAWS:
            return norm
        if norm in _PLANNED_LAWS:
            raise SceneError(path, f'the "{value}" contact law is not supported yet; accepted: {accepted}')
        close = _difflib.get_close_matches(norm, list(_CONTACT_LAWS) + list(_LAW_ALIASES), n=1, cutoff=0.6)
        hint = f'; did you mean "{close[0]}"?' if close else ";"
        raise SceneError(path, f'unknown contact law "{value}"{hint} accepted: {accepted}')
    raise SceneError(path, f"the contact law is a name, one of {accepted}; got {_shown(value)}")


def _contact(spec, k: int, ctx: _Ctx) -> Contact:
    path = f"contacts[{k}]"
    if not isinstance(spec, dict):
        raise SceneError(path, f"expected a table such as {{ loading = {{ stiffness = 24000 }}, "
                               f"unloading = {{ restitution = 0.4 }} }}, got {_shown(spec)}")
    law = _law_name(spec["law"], _p(path, "law")) if "law" in spec else "hysteresis"
    keys, build = _CONTACT_LAWS[law]
    _table(spec, path, _CONTACT_COMMON_KEYS + keys, "")
    model = build(spec, path, ctx)
    gap = _qty(spec, "gap", "length", ctx, path, default=0.0, minimum=0.0, strict=False)
    failure = None
    if "failure" in spec:
        fp = _p(path, "failure")
        fspec = _table(spec["failure"], fp, _FAILURE_KEYS, '{ force = "5000 lbf" }')
        force = _qty(fspec, "force", "force", ctx, fp, minimum=0.0)
        post = None
        if "post_failure" in fspec:
            pp = _p(fp, "post_failure")
            if not isinstance(model, Hysteresis):
                raise SceneError(pp, f'a post-failure loading curve applies to the IF-D law (the '
                                     f'default, law = "hysteresis"), not to law = "{model.name}"; '
                                     f'remove it (the failure force alone is reported)')
            post = _loading(fspec["post_failure"], pp, ctx)
            try:
                model.loading.splice(force, post)
            except ValueError as e:
                raise SceneError(pp, str(e)) from None
        failure = Failure(force, post)
    return Contact(model, gap, failure)


# ----------------------------------------------------------------- vehicles, solver
def _vehicle(spec, i: int, ctx: _Ctx) -> Vehicle:
    path = f"vehicles[{i}]"
    spec = _table(spec, path, _VEHICLE_KEYS, "{ weight = 3500, speed = 10 }")
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
    brake = None
    if "brake" in spec:
        bp = _p(path, "brake")
        bspec = _table(spec["brake"], bp, _BRAKE_KEYS, "{ mu = 0.7, mu_static = 0.8 }")
        mu = _qty(bspec, "mu", "dimensionless", ctx, bp, minimum=0.0, bounded=True)
        mu_s = _qty(bspec, "mu_static", "dimensionless", ctx, bp, default=mu, bounded=True)
        if mu_s < mu:
            raise SceneError(_p(bp, "mu_static"), f"must be >= mu ({mu:g}), got {mu_s:g}")
        brake = Brake(mu, mu_s)
    return Vehicle(name, mass, speed, brake)


def _solver(spec, ctx: _Ctx) -> SolverSettings:
    path = "solver"
    spec = _table(spec, path, _SOLVER_KEYS, '{ method = "auto" }')
    method = _choice(spec.get("method", "auto"), METHODS, _p(path, "method"), "solver method",
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


# ----------------------------------------------------------------- the scene
def _units_name(value) -> str:
    if isinstance(value, str):
        up = value.strip().upper()
        if up in UNITS:
            return up
    close = _difflib.get_close_matches(value.strip().upper(), list(UNITS), n=1, cutoff=0.5) \
        if isinstance(value, str) else []
    hint = f'; did you mean "{close[0]}"?' if close else ";"
    raise SceneError("units", f"unknown unit system {_shown(value)}{hint} accepted: "
                              f'"SI" (m, s, kg, N) or "US" (ft, s, slug, lbf)')


#: The accepted values of ``g``, relative to standard gravity: from the Moon's (0.17) with room
#: to spare, to a hundred times Earth's.
G_RANGE = (0.01, 100.0)


def _gravity(src: dict, ctx: _Ctx) -> float:
    """The scene's ``g`` [acceleration], checked before any weight is divided by it."""
    g = _qty(src, "g", "acceleration", ctx, "", minimum=0.0, bounded=False)
    lo, hi = (r * STANDARD_G[ctx.units] for r in G_RANGE)
    if not lo <= g <= hi:
        unit = UNITS[ctx.units]["acceleration"]
        raise SceneError("g", f"must be the local acceleration of gravity, between {G_RANGE[0]:g} and "
                              f"{G_RANGE[1]:g} times standard gravity ({_fmt(lo, unit)} to "
                              f"{_fmt(hi, unit)}), got {_fmt(g, unit)}")
    return g


#: Largest gap, relative to the largest crush its contact can reach: ε × gap (the rounding of
#: positions and of absolute times once the gap has closed, relative to the crush and the pulse)
#: stays below 1e-8 of it.
GAP_RATIO = 1e-8 / float(np.finfo(float).eps)


def _check_relative_speeds(vehicles: tuple[Vehicle, ...], ctx: _Ctx) -> None:
    """The speeds may not all differ by less than the smallest magnitude of :data:`MAGNITUDES`:
    every closing speed, crush and energy of the crash would be below it."""
    u = np.array([v.speed for v in vehicles])
    spread = float(u.max() - u.min())
    if 0 < spread < MAGNITUDES[0]:
        unit = UNITS[ctx.units]["velocity"]
        raise SceneError("vehicles[0].speed", f"the speeds differ by only {_fmt(spread, unit)}: the "
                         f"closing speeds must reach {_fmt(MAGNITUDES[0], unit)} for the energies and "
                         "crushes of the crash to be normal floats")


def _relative_energy(vehicles: tuple[Vehicle, ...]) -> float:
    """Kinetic energy in the centre-of-mass frame [energy]: the most any contact can absorb."""
    m = np.array([v.mass for v in vehicles])
    u = np.array([v.speed for v in vehicles])
    u = u - np.dot(m, u) / m.sum()
    return float(0.5 * np.dot(m, u * u))


def _crush_bound(law, energy: float) -> float:
    """The crush at which ``law``'s loading branch has absorbed ``energy`` [length]: the most the
    contact can be crushed (damping only adds force while compressing); inf if it never does."""
    if isinstance(law, Damping):
        n = law.exponent
        return float(((n + 1.0) * energy / law.stiffness) ** (1.0 / (n + 1.0)))
    curve = law.loading
    if curve.is_linear:
        return float(np.sqrt(2.0 * energy / curve.stiffness))
    hi = float(curve.d[-1])
    if not curve.extends:
        return hi if curve.cum_energy[-1] <= energy else _bisect_energy(curve, energy, hi)
    while not curve.energy(hi) >= energy:
        if hi > MAGNITUDES[1] ** 2:
            return _math.inf
        hi *= 2.0
    return _bisect_energy(curve, energy, hi)


def _bisect_energy(curve: Curve, energy: float, hi: float) -> float:
    lo = 0.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        lo, hi = (mid, hi) if curve.energy(mid) < energy else (lo, mid)
    return hi


def _check_gaps(vehicles: tuple[Vehicle, ...], contacts: tuple[Contact, ...], ctx: _Ctx) -> None:
    """Refuse a gap so wide that, once it has closed, the rounding of positions and times (ε x gap)
    hides the crush (and the pulse): at most :data:`GAP_RATIO` times the largest crush."""
    energy = _relative_energy(vehicles)
    if not energy > 0:
        return  # closing only through braking: no crush scale to hold the gap to
    unit = UNITS[ctx.units]["length"]
    for k, c in enumerate(contacts):
        crush = _crush_bound(c.law, energy)
        if c.gap > GAP_RATIO * crush:
            raise SceneError(f"contacts[{k}].gap", f"{_fmt(c.gap, unit)} is too wide for this crash to "
                             f"be represented: the contact can be crushed by at most {_fmt(crush, unit)} "
                             f"(all the kinetic energy of the relative motion), and after a gap of more "
                             f"than {GAP_RATIO:.3g} times that (here {_fmt(GAP_RATIO * crush, unit)}) the "
                             "rounding of positions and times exceeds 1e-8 of the crush and of the pulse; "
                             "start the vehicles closer")


def _check_closing(vehicles: tuple[Vehicle, ...], ctx: _Ctx) -> None:
    """Without brakes, speeds never change before a contact closes: some pair must close."""
    if any(v.brake is not None for v in vehicles):
        return
    if any(a.speed - b.speed > 0 for a, b in zip(vehicles, vehicles[1:])):
        return
    unit = UNITS[ctx.units]["velocity"]
    if len(vehicles) == 2:
        a, b = vehicles
        raise SceneError(
            "vehicles[0].speed",
            f"the vehicles are not closing and never will: vehicle 1 ({a.name}, {_fmt(a.speed, unit)}) is "
            f"the rear one and must be faster than vehicle 2 ({b.name}, {_fmt(b.speed, unit)}); "
            "vehicles are listed rear to front")
    raise SceneError(
        "vehicles[0].speed",
        "the vehicles are not closing and never will: no vehicle is faster than the one in front of it "
        f"(speeds {', '.join(_fmt(v.speed, unit) for v in vehicles)}); vehicles are listed rear to front")


def _build(src: dict, base_dir: Path, default_name: str, source: dict) -> Scene:
    """Validate a plain scene dict and build the Scene."""
    _table(src, "", _TOP_KEYS, '{ units = "US", vehicles = [...], contacts = [...] }')
    name = src.get("name", default_name)
    if not isinstance(name, str):
        raise SceneError("name", f"a name is text, got {_shown(name)}")
    ctx = _Ctx(_units_name(src.get("units", "SI")), base_dir)
    if "g" in src:
        ctx.g = _gravity(src, ctx)
    vs = src.get("vehicles", _MISSING)
    if vs is _MISSING:
        raise SceneError("vehicles", "is required: a list of at least two vehicles, rear to front")
    if not isinstance(vs, list) or len(vs) < 2:
        got = f"{len(vs)}" if isinstance(vs, list) else _shown(vs)
        raise SceneError("vehicles", f"a scene needs a list of at least two vehicles (rear to front), got {got}")
    vehicles = tuple(_vehicle(v, i, ctx) for i, v in enumerate(vs))
    cs = src.get("contacts", _MISSING)
    need = len(vehicles) - 1
    if cs is _MISSING:
        raise SceneError("contacts", f"is required: {need} contact{'s' if need > 1 else ''} "
                                     f"(contacts[k] joins vehicles[k] and vehicles[k+1])")
    if not isinstance(cs, list) or len(cs) != need:
        got = f"{len(cs)}" if isinstance(cs, list) else _shown(cs)
        raise SceneError("contacts", f"{len(vehicles)} vehicles need {need} contact{'s' if need > 1 else ''} "
                                     f"(contacts[k] joins vehicles[k] and vehicles[k+1]), got {got}")
    contacts = tuple(_contact(c, k, ctx) for k, c in enumerate(cs))
    solver = _solver(src["solver"], ctx) if "solver" in src else SolverSettings()
    if "uncertainty" in src and not isinstance(src["uncertainty"], _Mapping):
        raise SceneError("uncertainty", "a table of dotted scene paths to distributions "
                         "(used by lsc.analysis.monte_carlo / `lsc mc`), got "
                         f"{_shown(src['uncertainty'])}")
    speed_unit = _display(src["display"], ctx) if "display" in src else None
    _check_closing(vehicles, ctx)
    _check_relative_speeds(vehicles, ctx)
    _check_gaps(vehicles, contacts, ctx)
    return Scene(name, ctx.units, ctx.g, vehicles, contacts, solver, source, base_dir, speed_unit)


def _display(value, ctx) -> str:
    """The ``[display]`` table: ``speed_unit``, one of :data:`lsc.display.SPEED_UNITS`."""
    from .display import SPEED_UNITS, speed_display
    _table(value, "display", _DISPLAY_KEYS, '{ speed_unit = "mph" }')
    unit = value.get("speed_unit")
    if not isinstance(unit, str):
        raise SceneError("display.speed_unit", f"a unit name, one of {', '.join(SPEED_UNITS)}; got "
                                               f"{_shown(unit)}")
    speed_display(unit, ctx.units, "display.speed_unit")
    return unit


def _load(obj, *, base_dir=None) -> Scene:
    """Load and validate a scene from a dict, a TOML path or a Scene (see :meth:`Scene.load`).

    Relative CSV paths are resolved against ``base_dir``: by default the TOML file's folder, or
    the current directory for a dict.
    """
    if isinstance(obj, Scene):
        return obj
    if isinstance(obj, (str, _os.PathLike)):
        file = _expand(Path(obj))
        try:
            text = _read_text(file, MAX_SCENE_BYTES, "scene file")
        except FileNotFoundError:
            extra = " (a string is read as a file path; parse TOML text with tomllib and pass the dict)" \
                if isinstance(obj, str) and ("\n" in obj or "=" in obj) else ""
            raise SceneError("", f"scene file not found: {file}{extra}") from None
        except _TooLarge as e:
            raise SceneError("", str(e)) from None
        except (OSError, ValueError) as e:
            raise SceneError("", f"cannot read scene file {file}: {getattr(e, 'strerror', None) or e}") from None
        try:
            src = _tomllib.loads(text)
        except _tomllib.TOMLDecodeError as e:
            raise SceneError("", f"{file} is not valid TOML: {e}") from None
        bd = Path(base_dir) if base_dir is not None else file.parent
        return _build(src, bd.absolute(), file.stem, src)
    if isinstance(obj, _Mapping):
        src = _plain(obj)
        bd = Path(base_dir) if base_dir is not None else Path.cwd()
        return _build(src, bd.absolute(), "scene", src)
    raise SceneError("", f"a scene is a dict, a TOML file path or an lsc.Scene, got {type(obj).__name__}")


# Sub-tables with_values may create when a path goes through one that is absent.
_CREATABLE = {"brake", "failure", "solver", "post_failure", "loading", "unloading"}


def _split_key(key) -> list[str]:
    if not isinstance(key, str) or not key.strip():
        raise SceneError(str(key), 'a value path is text such as "vehicles.0.speed"')
    return key.strip().replace("[", ".").replace("]", "").split(".")


def _alternatives(parts: list[str]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The exclusive keys of the table at ``parts[:-1]``, and keys that only go with some of them."""
    parent = parts[-2] if len(parts) >= 2 else ""
    if len(parts) == 3 and parts[0] == "vehicles":
        return ("weight", "mass"), ()
    if parent == "unloading":
        return _UNLOADING_KINDS, _COLUMN_KEYS
    if parent in ("loading", "post_failure") or (len(parts) >= 3 and parts[-3] == "series"):
        return _LOADING_KINDS, _COLUMN_KEYS
    return (), ()


def _set(root: dict, key: str, value) -> None:
    parts = _split_key(key)
    node = root
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        where = ".".join(parts[:i]) or "the scene"
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise SceneError(key, f"no such field: {where} is a list of {len(node)}, "
                                      f"index it with 0..{len(node) - 1}, got \"{part}\"")
            if last:
                node[int(part)] = value
            else:
                node = node[int(part)]
        elif isinstance(node, dict):
            if not part:
                raise SceneError(key, "empty name in the value path")
            if last:
                group, columns = _alternatives(parts)
                if part in group:
                    for other in group:
                        if other != part:
                            node.pop(other, None)
                    if part not in ("table", "csv"):
                        for other in columns:
                            node.pop(other, None)
                node[part] = value
            elif part in node:
                node = node[part]
            elif part in _CREATABLE:
                node = node.setdefault(part, {})
            else:
                raise SceneError(key, f'no such field: {where} has no "{part}"')
        else:
            raise SceneError(key, f"no such field: {where} is a value, not a table or a list")


def _with_values(scene: Scene, values) -> Scene:
    """A copy of ``scene`` with fields at dotted paths replaced, re-validated.

    ``values`` maps paths (``"vehicles.0.speed"``, ``"contacts.0.unloading.restitution"``; integers
    index lists; ``"vehicles[0].speed"`` works too) to numbers (scene units) or unit strings.
    Setting one of a set of exclusive keys (``mass`` for ``weight``, ``stiffness`` for
    ``restitution``) removes the others. Relative CSV paths keep the scene's ``base_dir``.
    """
    if not isinstance(values, _Mapping):
        raise SceneError("", f"values must be a dict of dotted paths to values, got {type(values).__name__}")
    if not scene.source:
        raise SceneError("", "with_values needs a scene made by Scene.load (this one has no source)")
    src = _plain(scene.source)
    for key, value in values.items():
        _set(src, key, _plain(value))
    base = scene.base_dir if scene.base_dir is not None else Path.cwd()
    return _build(src, Path(base), scene.name, src)
