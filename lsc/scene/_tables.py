"""Force–deformation tables of a scene: inline ``[deformation, force]`` pairs, CSV files, and the
loading curves and unloading rules of the IF-D law built from them."""

from __future__ import annotations

import errno as _errno
import math as _math
import os as _os
import re as _re
import stat as _stat
from pathlib import Path

import numpy as np

from ..curves import Curve
from ..errors import SceneError
from ..laws import REQUIRED, Restitution, UnloadingStiffness, UnloadingTable
from ..units import STANDARD_G, UNITS, _expected, parse_number as _parse_number, to_system as _to_system, \
    unit_factor as _unit_factor
from ._read import _MISSING, MAGNITUDES, _check_magnitude, _fmt, _one_of, _p, _qty, _shown, _table

_COLUMN_KEYS = ("deformation", "force")
_LOADING_KINDS = ("stiffness", "table", "csv", "series")
_LOADING_KEYS = _LOADING_KINDS + ("scale",) + _COLUMN_KEYS
_UNLOADING_KINDS = ("restitution", "stiffness", "table", "csv")
_UNLOADING_KEYS = _UNLOADING_KINDS + _COLUMN_KEYS


def _columns(spec: dict, ctx: Reader, path: str) -> tuple[float | None, float | None]:
    """Column unit factors of a table / csv (``deformation = "in"``, ``force = "lbf"``)."""
    fd = _unit_factor(spec["deformation"], "length", ctx.units, _p(path, "deformation")) \
        if "deformation" in spec else None
    ff = _unit_factor(spec["force"], "force", ctx.units, _p(path, "force")) if "force" in spec else None
    return fd, ff


def _cell(value, kind: str, factor: float | None, ctx: Reader, path: str) -> float:
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


def _check_points(points: np.ndarray, path: str, ctx: Reader) -> np.ndarray:
    """Hold every deformation and force of a table to at most the upper end of
    :data:`MAGNITUDES` (SceneError at the row); a tiny value is almost 0, and harmless."""
    bad = np.abs(points) > MAGNITUDES[1]
    if np.any(bad):
        i, j = (int(a) for a in np.argwhere(bad)[0])
        unit = UNITS[ctx.units]["length" if j == 0 else "force"]
        _check_magnitude(float(points[i, j]), path, unit, f"row {i}: ", lower=False)
    return points


def _points(value, path: str, factors, ctx: Reader) -> np.ndarray:
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


def _read_csv(value, path: str, factors, ctx: Reader) -> np.ndarray:
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


def _kind(spec, path: str, keys: tuple, kinds: tuple, what: str, example: str):
    """(the table, the one of ``kinds`` it gives, that key's path) of a curve's table at
    ``path``; column units only beside a table or a csv."""
    spec = _table(spec, path, keys, example)
    kind = _one_of(spec, kinds, path, what)
    if kind not in ("table", "csv"):
        for key in _COLUMN_KEYS:
            if key in spec:
                raise SceneError(_p(path, key), f"column units apply to a table or csv, not to {kind}")
    return spec, kind, _p(path, kind)


def _loading(spec, path: str, ctx: Reader) -> Curve:
    """A loading spec (``stiffness`` | ``table`` | ``csv`` | ``series``, optional ``scale``) → Curve."""
    return _scaled_loading(spec, path, ctx)[0]


def _scaled_loading(spec, path: str, ctx: Reader) -> tuple[Curve, float]:
    """A loading spec → (its Curve, the ``scale`` applied to its forces, 1 if none)."""
    spec, kind, sub = _kind(spec, path, _LOADING_KEYS, _LOADING_KINDS, "a loading curve",
                            "{ stiffness = 24000 }")
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
    factor = 1.0
    if "scale" in spec:
        factor = _qty(spec, "scale", "dimensionless", ctx, path, minimum=0.0, bounded=True)
        try:
            curve = curve.scaled(factor)
        except ValueError as e:
            raise SceneError(_p(path, "scale"), str(e)) from None
        _check_points(np.column_stack([curve.d, curve.f]), _p(path, "scale"), ctx)
    return curve, factor


def _unloading(spec, path: str, ctx: Reader, loading: Curve):
    """An unloading spec (``restitution`` | ``stiffness`` | ``table`` | ``csv``) → its rule."""
    spec, kind, sub = _kind(spec, path, _UNLOADING_KEYS, _UNLOADING_KINDS,
                            "the unloading branch", "{ restitution = 0.4 }")
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


class Reader:
    """What every part of one load needs: the unit system, gravity and the CSV folder; and how
    the contact laws and effects read their keys (:meth:`param`, :meth:`table`,
    :meth:`loading`, :meth:`unloading`)."""

    __slots__ = ("units", "g", "base_dir")

    def __init__(self, units: str, base_dir: Path):
        self.units = units
        self.g = STANDARD_G[units]
        self.base_dir = base_dir

    def param(self, spec: dict, param, path: str, values: dict):
        """The value of a declared key (:class:`lsc.laws.Param`) of the table ``spec`` at
        ``path``, in the scene's units (``values``: the part's keys read before it)."""
        default = param.default
        if default is REQUIRED:
            default = _MISSING
        elif callable(default):
            default = default(values)
        x = _qty(spec, param.key, param.kind_for(values), self, path, default=default,
                 minimum=param.minimum, strict=param.strict, hint=param.hint,
                 bounded=param.bounded)
        message = param.check(x) if param.check is not None and x is not None else None
        if message:
            raise SceneError(_p(path, param.key), message)
        return x

    def table(self, value, path: str, allowed: tuple[str, ...], example: str) -> dict:
        """``value`` checked to be a table holding only ``allowed`` keys."""
        return _table(value, path, allowed, example)

    def loading(self, spec, path: str) -> tuple[Curve, float]:
        """A loading curve and the scale applied to its forces."""
        return _scaled_loading(spec, path, self)

    def unloading(self, spec, path: str, loading: Curve):
        """An unloading rule after the ``loading`` curve."""
        return _unloading(spec, path, self, loading)
