"""The scene: a validated :class:`Scene`, loaded from a dict, a TOML file or a Scene, its
scene-wide checks (closing speeds, gaps against the crush), and copies with values replaced."""

from __future__ import annotations

import difflib as _difflib
import math as _math
import os as _os
import tomllib as _tomllib
from collections.abc import Mapping as _Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..curves import Curve
from ..display import SPEED_UNITS, speed_display
from ..errors import SceneError
from ..laws import Damping
from ..units import STANDARD_G, UNITS
from ._cache import cached as _cached, content_key as _content_key, keep as _keep
from ._parts import Contact, SolverSettings, Vehicle, _contact, _solver, _vehicle
from ._read import _MISSING, MAGNITUDES, _fmt, _plain, _qty, _shown, _table
from ._tables import (_COLUMN_KEYS, _LOADING_KINDS, _UNLOADING_KINDS, MAX_SCENE_BYTES, Reader,
                      _expand, _read_text, _TooLarge)

_TOP_KEYS = ("name", "units", "g", "vehicles", "contacts", "solver", "uncertainty", "display")
_DISPLAY_KEYS = ("speed_unit",)


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


def _gravity(src: dict, ctx: Reader) -> float:
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


def _check_relative_speeds(vehicles: tuple[Vehicle, ...], ctx: Reader) -> None:
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


def _check_gaps(vehicles: tuple[Vehicle, ...], contacts: tuple[Contact, ...], ctx: Reader) -> None:
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


def _check_closing(vehicles: tuple[Vehicle, ...], ctx: Reader) -> None:
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
    ctx = Reader(_units_name(src.get("units", "SI")), base_dir)
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
        bd = (Path(base_dir) if base_dir is not None else Path.cwd()).absolute()
        key = _content_key(obj, bd)   # (the same content loaded before: that Scene)
        scene = _cached(key)
        if scene is None:
            src = _plain(obj)
            scene = _build(src, bd, "scene", src)
            _keep(key, scene)
        return scene
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
