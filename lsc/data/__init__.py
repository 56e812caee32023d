"""The packaged scenes: ``lsc run``'s default and the paper's scenes, as TOML files.

``names()`` lists them, ``path(name)`` finds one, ``load(name)`` loads it as an
:class:`lsc.Scene`. ``STUDIES`` holds each paper scene's swept field and values, ready for
:func:`lsc.sweep`; ``paper_scene(name, value)`` is one member of such a study::

    lsc.sweep(lsc.data.load("study2_stiffness"), lsc.data.STUDIES["study2_stiffness"])
    lsc.solve(lsc.data.paper_scene("table1", 1e-4))        # Table 1's dt = 1e-4 row
"""

from __future__ import annotations

import difflib
from pathlib import Path

__all__ = ["names", "path", "load", "paper_scene", "STUDIES"]

_HERE = Path(__file__).resolve().parent

#: Packaged scene → ``{dotted path: values}`` that the paper swept (values in the scene's units).
STUDIES: dict[str, dict[str, tuple]] = {
    "table1": {"solver.dt": (1e-3, 5e-4, 1e-4, 5e-5, 1e-5, 5e-6)},
    "study1_restitution": {"contacts.0.unloading.restitution": (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)},
    "study2_stiffness": {"contacts.0.loading.stiffness":
                         (12000, 24000, 36000, 48000, 60000, 72000)},
    "study3_speed": {"vehicles.0.speed": (2, 4, 6, 8, 10, 12)},
    "table3": {"vehicles.0.speed": (4, 5, 6)},
}


def names() -> list[str]:
    """The names of the packaged scenes (``"default"``, ``"table1"``, ...)."""
    return sorted(p.stem for p in _HERE.glob("*.toml"))


def path(name: str) -> Path:
    """The file of the packaged scene ``name`` (raises :class:`lsc.SceneError` if there is none)."""
    file = _HERE / f"{name}.toml"
    if not isinstance(name, str) or "/" in name or "\\" in name or not file.is_file():
        from ..errors import SceneError
        close = difflib.get_close_matches(str(name), names(), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise SceneError("", f"no packaged scene {name!r}{hint} (packaged: {', '.join(names())})")
    return file


def load(name: str):
    """The packaged scene ``name`` as an :class:`lsc.Scene`."""
    from ..scene import Scene
    return Scene.load(path(name))


def paper_scene(name: str, value=None):
    """The paper scene ``name``; with ``value``, its swept field (see ``STUDIES``) set to it."""
    scene = load(name)
    if value is None:
        return scene
    (field,) = STUDIES[name]
    return scene.with_values({field: value})
