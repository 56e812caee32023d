"""Where a reported number comes from: the scene as given (:func:`canonical_scene`, its SHA-256
:func:`scene_hash`, the CSV files it reads, the scene as TOML text :func:`to_toml`) and the
versions of ``lsc`` and its dependencies (:func:`versions`). Used by :mod:`lsc.report`.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import platform
import sys
from importlib import metadata
from pathlib import Path

from .errors import SceneError
from .scene import Scene
from .toml_text import to_toml as toml_text

__all__ = ["canonical_scene", "scene_hash", "to_toml", "versions", "CANONICAL_FORM"]

#: What :func:`scene_hash` hashes, in words (printed in the report).
CANONICAL_FORM = ("the scene as loaded (its TOML table or dict, before units are applied) "
                  "serialised as JSON: keys sorted, no spaces (separators \",\" and \":\"), "
                  "non-ASCII characters kept, encoded as UTF-8 (a Python function in the "
                  "uncertainty table as its \"module:name\")")

#: Distributions whose versions the report states (those installed; JAX and diffrax when used).
_DEPENDENCIES = ("numpy", "scipy", "pint", "matplotlib", "pandas")
_JAX = ("jax", "jaxlib", "diffrax", "equinox")


# --------------------------------------------------------------------------- provenance
def canonical_scene(scene) -> bytes:
    """The bytes :func:`scene_hash` hashes: ``scene.source`` as canonical JSON (see
    :data:`CANONICAL_FORM`). ``scene``: an :class:`lsc.Scene`, a dict or a TOML path."""
    sc = Scene.load(scene)
    if not sc.source:
        raise SceneError("", "this scene has no source (build it with lsc.Scene.load): it cannot "
                             "be reported as given")
    return json.dumps(sc.source, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      default=_json_default).encode("utf-8")


def _json_default(value) -> str:
    """A value JSON has no type for, as text that is the same in every run: a date or time as
    ISO 8601, a Python function (an ``[uncertainty]`` spec) as ``"module:name"``."""
    if isinstance(value, (datetime.date, datetime.time)):
        return value.isoformat()
    if callable(value):
        return f"{getattr(value, '__module__', '?')}:{getattr(value, '__qualname__', '?')}"
    return str(value)


def scene_hash(scene) -> str:
    """SHA-256 (hex) of :func:`canonical_scene`: the same for the same scene whether it is
    given as a TOML file, its dict or an :class:`lsc.Scene`; comments and layout do not count."""
    return hashlib.sha256(canonical_scene(scene)).hexdigest()


def _file_sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _csv_files(scene: Scene) -> list[tuple[str, Path]]:
    """``(scene path, file)`` of every CSV file the scene reads (``csv = "..."`` keys)."""
    found = []

    def walk(node, where):
        if isinstance(node, dict):
            for key, sub in node.items():
                if key == "csv" and isinstance(sub, str):
                    file = Path(sub).expanduser()
                    if not file.is_absolute() and scene.base_dir is not None:
                        file = Path(scene.base_dir) / file
                    found.append((f"{where}.csv".lstrip("."), file))
                else:
                    walk(sub, f"{where}.{key}")
        elif isinstance(node, list):
            for i, sub in enumerate(node):
                walk(sub, f"{where}[{i}]")

    walk(scene.source, "")
    return found


def to_toml(source: dict) -> str:
    """A scene's source table as TOML text (top-level keys, then each table and array of
    tables; deeper tables inline): what the scene file says, without its comments (a Python
    function of an ``[uncertainty]`` table as ``"module:name"``)."""
    return toml_text(source, default=_json_default)


def versions(method: str = "") -> dict[str, str]:
    """``name → version`` of Python, ``lsc`` and its dependencies (JAX and diffrax too when
    ``method`` is diffrax or they are loaded)."""
    from . import __version__  # lsc/__init__ imports the API, not this module
    out = {"python": platform.python_version(), "lsc": __version__}
    names = list(_DEPENDENCIES)
    if method.startswith("diffrax") or "jax" in sys.modules:
        names += _JAX
    for name in names:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            if name in _DEPENDENCIES:
                out[name] = "not installed"
    return out
