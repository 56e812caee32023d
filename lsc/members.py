"""A study's members: the swept values read and checked (numbers, or strings with units read
by the loader), given as equal-length arrays (:class:`Arrays`) or as the axes of a grid
(:class:`Grid`), built a chunk at a time (:func:`lsc.sweep`)."""

from __future__ import annotations

import math
import numbers

import numpy as np

from . import parameters
from .errors import SceneError
from .scene import Scene

__all__ = ["Arrays", "Grid", "members"]


def _check_path(scene: Scene, path: str) -> None:
    """Raise the loader's error if ``path`` names no field of the scene (checked on a probe)."""
    try:
        scene.with_values({path: 1.0})
    except SceneError as e:
        if "unknown key" in str(e) or "no such field" in str(e):
            raise SceneError(path, str(e.message if hasattr(e, "message") else e)) from None


def _sweep_values(path: str, vals, in_memory: bool = True) -> np.ndarray:
    """The values of one swept path as a 1-D array: floats, or objects (floats and strings with
    units). A generator or iterator is refused (it may not end, and it is used up once): give a
    list, a tuple or an array; so is a boolean (not a number) and anything but a real number or a
    string. ``in_memory``: the results are to be held (at most :data:`MAX_MEMBERS`)."""
    if (isinstance(vals, (str, bytes, dict, set, frozenset)) or hasattr(vals, "__next__")
            or not (hasattr(vals, "__len__") or hasattr(vals, "__array__"))):
        raise SceneError(path, "sweep values must be a list, tuple or 1-D array of numbers (or "
                               f"strings with units), got a {type(vals).__name__}"
                         + (" (make it a list first: list(...))" if hasattr(vals, "__next__")
                            else ""))
    if isinstance(vals, np.ndarray) and vals.dtype.kind in "iuf":
        arr = vals
    else:
        arr = np.asarray(vals, dtype=object)
        if arr.ndim == 1:
            for v in arr:
                if isinstance(v, (bool, np.bool_)) or not isinstance(v, (str, numbers.Real)):
                    raise SceneError(path, "sweep values must be numbers (or strings with "
                                           f"units), got {v!r}")
            if not any(isinstance(v, str) for v in arr):
                arr = arr.astype(float)
    if arr.ndim != 1 or arr.size == 0:
        raise SceneError(path, "sweep values must be a non-empty 1-D list or array")
    if in_memory:
        from .sweep import check_members
        check_members(arr.size, path)
    return arr


def _to_numbers(scene: Scene, path: str, arr: np.ndarray) -> np.ndarray:
    """Values with units (strings) converted to scene units through the loader, once per value."""
    if arr.dtype != object:
        return arr.astype(float)
    out = np.empty(arr.size)
    cache = {}
    for j, v in enumerate(arr):
        if not isinstance(v, str):
            out[j] = float(v)
            continue
        if v not in cache:
            probe = scene.with_values({path: v})
            cache[v] = parameters.read_back(probe, path)
        out[j] = cache[v]
    return out


class Arrays:
    """Members given as equal-length arrays: dotted path → (n,) floats [scene units]."""

    def __init__(self, values: dict):
        self.values = values
        self.n = len(next(iter(values.values())))

    def chunk(self, start: int, stop: int) -> dict:
        """The members ``start:stop``."""
        return {p: v[start:stop] for p, v in self.values.items()}


class Grid:
    """Members of a grid (the product of ``axes``, C order), built a chunk at a time."""

    def __init__(self, axes: dict):
        self.axes = axes
        self.shape = tuple(a.size for a in axes.values())
        self.n = math.prod(self.shape)

    def chunk(self, start: int, stop: int) -> dict:
        """The members ``start:stop`` (the same values as ``numpy.meshgrid(indexing="ij")``)."""
        index = np.unravel_index(np.arange(start, stop), self.shape)
        return {p: a[i] for (p, a), i in zip(self.axes.items(), index)}


def members(base: Scene, params, grid: bool, in_memory: bool):
    """The sweep's members (:class:`Arrays` or :class:`Grid`) and its shape."""
    if not isinstance(params, dict) or not params:
        raise SceneError("params", "a sweep needs a dict of dotted scene paths to arrays of values")
    raw = {}
    for path, vals in params.items():
        _check_path(base, str(path))
        raw[path] = _to_numbers(base, path, _sweep_values(str(path), vals, in_memory))
    if grid:
        if in_memory:
            from .sweep import check_members
            check_members(math.prod(a.size for a in raw.values()), "params")
        g = Grid(raw)
        return g, g.shape
    sizes = {p: a.size for p, a in raw.items()}
    if len(set(sizes.values())) != 1:
        raise SceneError("params", f"sweep arrays must have equal lengths (or pass grid=True), got "
                         + ", ".join(f"{p}: {n}" for p, n in sizes.items()))
    return Arrays(raw), (next(iter(sizes.values())),)
