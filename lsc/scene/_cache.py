"""Scenes loaded from dicts, kept by content: loading the same dict again (a loop of
``lsc.solve(scene_dict)``) returns the Scene already validated instead of parsing and
validating it again.

The key is the dict's pickle (every value with its type: ``1``, ``1.0`` and ``True`` are
different inputs, one of them may be refused; equal pickles unpickle to equal contents), the
folder relative paths would be read from, and the registered laws, vehicle effects and methods
(a scene loaded before a law was unregistered is loaded again, and refused). A scene that may
name a file (the text ``csv`` anywhere in it: a table read from a CSV file) is not kept, as the
file may change between two loads; nor is one that fails to load (its error is raised again
every time), nor one that cannot be pickled.
"""

from __future__ import annotations

import pickle
import threading
from collections import OrderedDict

from ..effects import vehicle_effect_classes
from ..laws import laws
from ..solvers import methods

__all__ = ["content_key", "cached", "keep", "clear", "SIZE"]

#: Most scenes kept (the least recently loaded one goes first).
SIZE = 64
_kept: OrderedDict = OrderedDict()
_lock = threading.Lock()


def content_key(obj, base_dir) -> tuple | None:
    """A hashable key equal for two scene dicts only when their contents, value types,
    ``base_dir`` and what the loader accepts (the registered laws, vehicle effects and
    methods: :func:`lsc.register_law` and the like change it) are; ``None`` where the scene
    cannot be kept (it may name a file, or cannot be pickled)."""
    try:
        content = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:   # (anything a value's pickling raises: the loader then judges it)
        return None
    if b"csv" in content:
        return None
    accepted = (tuple(laws().items()), tuple(vehicle_effect_classes().items()), methods())
    return str(base_dir), accepted, content


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
    """Forget every kept scene."""
    with _lock:
        _kept.clear()
