"""Scenes loaded from dicts, kept by content: loading the same dict again (a loop of
``lsc.solve(scene_dict)``) returns the Scene already validated, and with it the model built on
it (:func:`lsc.api.model_of`), instead of parsing, validating and building them again.

The key is the dict's whole content, every value with its type (``1``, ``1.0`` and ``True`` are
different inputs: one of them may be refused), and the folder relative paths would be read
from. A scene that names a file (a ``csv`` table) is not kept: the file may change between two
loads. A scene that fails to load is not kept either (its error is raised again every time).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Mapping

import numpy as np

__all__ = ["content_key", "cached", "keep", "clear", "SIZE"]

#: Most scenes kept (the least recently loaded one goes first).
SIZE = 64
_MAX_DEPTH = 64
_SCALARS = (str, int, float, bool, type(None))
_kept: OrderedDict = OrderedDict()
_lock = threading.Lock()


class _Uncachable(Exception):
    """The input holds something a content key cannot stand for (a file, an unknown object)."""


def content_key(obj, base_dir) -> tuple | None:
    """A hashable key equal for two scene dicts exactly when their contents, value types and
    ``base_dir`` are; ``None`` where the scene cannot be kept (it names a file, or holds a value
    of another kind, which the loader refuses or converts)."""
    try:
        return (str(base_dir), _key(obj, 0))
    except _Uncachable:
        return None


def _key(obj, depth: int):
    if depth > _MAX_DEPTH:
        raise _Uncachable
    kind = type(obj)
    if kind is float:   # (repr: -0.0 is not 0.0, and every float keeps all its digits)
        return (float, repr(obj))
    if kind in _SCALARS:
        return (kind, obj)
    if isinstance(obj, Mapping):
        if "csv" in obj:
            raise _Uncachable
        return (dict, tuple((_key(k, depth + 1), _key(v, depth + 1)) for k, v in obj.items()))
    if kind is list or kind is tuple:
        return (list, tuple(_key(v, depth + 1) for v in obj))
    if kind is np.ndarray and obj.dtype.kind in "iuf":
        return (np.ndarray, obj.dtype.str, obj.shape, obj.tobytes())
    raise _Uncachable


def cached(key):
    """The Scene kept under ``key`` (None: none)."""
    if key is None:
        return None
    with _lock:
        scene = _kept.get(key)
        if scene is not None:
            _kept.move_to_end(key)
        return scene


def keep(key, scene) -> None:
    """Keep ``scene`` under ``key`` (nothing where ``key`` is None)."""
    if key is None:
        return
    with _lock:
        _kept[key] = scene
        while len(_kept) > SIZE:
            _kept.popitem(last=False)


def clear() -> None:
    """Forget every kept scene (and the models built on them)."""
    with _lock:
        _kept.clear()
