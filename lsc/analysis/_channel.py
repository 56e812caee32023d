"""Measured channels: :class:`Channel` (values with a unit and a kind) and :class:`Channels`
(channels on one uniform time base [s]), and the units a channel may have. Read and written by
:mod:`lsc.analysis.channels` (the public module).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import SceneError
from ..units import unit_factor

__all__ = ["Channel", "Channels", "KINDS", "STEP_TOLERANCE", "scene_roles", "kind_of", "time_factor"]

#: Channel kind → the lsc unit kind its values convert to.
KINDS = {"acceleration": "acceleration", "force": "force", "displacement": "length", "velocity": "velocity"}

#: A sample time may stray this fraction of a sample period from the uniform grid.
STEP_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Channel:
    """One measured channel: ``values`` in ``unit`` (pint spelling), its ``kind`` (a key of
    :data:`KINDS`), the file it came from (``source``) and a free-text ``label``."""

    name: str
    values: np.ndarray
    unit: str
    kind: str
    source: str = ""
    label: str = ""

    def to(self, system: str) -> np.ndarray:
        """The values in a unit system's unit of the kind (``"SI"``: m/s², N, m, m/s; ``"US"``: ft...)."""
        return self.values * unit_factor(_pint_unit(self.unit), KINDS[self.kind], system, self.source or self.name)


@dataclass(frozen=True)
class Channels:
    """A uniform time base ``t`` [s] (0 = time zero of the test) and named :class:`Channel` s."""

    t: np.ndarray
    channels: dict = field(default_factory=dict)
    source: str = ""
    cfc: object = None

    def __getitem__(self, name: str) -> Channel:
        """The channel of this name (or, failing that, of this label)."""
        if name in self.channels:
            return self.channels[name]
        try:
            return next(c for c in self.channels.values() if c.label and c.label == name)
        except StopIteration:
            raise SceneError(self.source, f"no channel named {name!r}; the channels are: "
                                          f"{', '.join(self.channels) or '(none)'}") from None

    def __contains__(self, name) -> bool:
        return name in self.channels

    def __iter__(self):
        return iter(self.channels.values())

    def __len__(self) -> int:
        return len(self.channels)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.channels)

    @property
    def dt(self) -> float:
        """Sample period [s]."""
        return float(self.t[1] - self.t[0])

    @property
    def sample_rate(self) -> float:
        """Sample rate [Hz]."""
        return 1.0 / self.dt

    @property
    def pre_trigger(self) -> int:
        """Number of samples before time zero."""
        return int(np.count_nonzero(self.t < -0.5 * self.dt))

    def filtered(self, cfc, names=None) -> "Channels":
        """The channels (or those ``names``) filtered by the J211 CFC filter of class ``cfc``."""
        from .filters import cfc_filter

        names = self.names if names is None else tuple(names)
        out = dict(self.channels)
        for name in names:
            ch = self[name]
            out[name] = replace(ch, values=cfc_filter(ch.values, cfc, self.sample_rate))
        return replace(self, channels=out, cfc=cfc)

    def match(self, scene, mapping: dict | None = None) -> dict[str, Channel]:
        """The channels that belong to ``scene``: ``{role: Channel}``, roles as in the module
        docstring; ``mapping`` ({role: channel name}) overrides matching by name."""
        roles = scene_roles(scene)
        found = {}
        for role, kind in roles.items():
            ch = self._find(role)
            if ch is not None:
                found[role] = _checked_kind(ch, role, kind)
        for role, name in (mapping or {}).items():
            if role not in roles:
                raise SceneError(f"mapping.{role}", f"{role!r} is not a channel role of this scene; "
                                                    f"the roles are: {', '.join(roles)}")
            found[role] = _checked_kind(self[name], role, roles[role])
        return found

    def _find(self, role: str) -> Channel | None:
        key = _normal(role)
        for ch in self.channels.values():
            if _normal(ch.name) == key or (ch.label and _normal(ch.label) == key):
                return ch
        return None

    def to_frame(self):
        """A pandas DataFrame: ``time [s]`` and one ``name [unit]`` column per channel."""
        import pandas as pd

        data = {"time [s]": self.t}
        data.update({f"{c.name} [{c.unit}]": c.values for c in self.channels.values()})
        return pd.DataFrame(data)


def scene_roles(scene) -> dict[str, str]:
    """``{role: kind}`` of the channels a scene can be compared with."""
    from ..scene import Scene

    scene = Scene.load(scene)
    roles = {}
    for v in scene.vehicles:
        roles[f"accel_{v.name}"] = "acceleration"
        roles[f"velocity_{v.name}"] = "velocity"
    for k in range(len(scene.contacts)):
        suffix = "" if k == 0 else f"_{k + 1}"
        roles[f"force{suffix}"] = "force"
        roles[f"deformation{suffix}"] = "displacement"
    return roles


def _normal(name: str) -> str:
    return re.sub(r"[\s_]+", "_", name.strip().lower())


def _checked_kind(ch: Channel, role: str, kind: str) -> Channel:
    if ch.kind != kind:
        raise SceneError(ch.source or ch.name, f"channel {ch.name!r} ({ch.unit}) is {_a(ch.kind)}, "
                                               f"but {role!r} needs {_a(kind)}")
    return ch


def _a(kind: str) -> str:
    return f"an {kind}" if kind[0] in "aeiou" else f"a {kind}"


# ---------------------------------------------------------------------------------- units

def _pint_unit(unit: str) -> str:
    """A channel unit in pint's spelling: ``g`` (and ``G``, ``gn``) is standard gravity."""
    unit = unit.strip().replace("²", "^2").replace("**", "^")
    return re.sub(r"(?<![\w.])(g|G|gn)(?![\w])", "g_0", unit)


def kind_of(unit: str, where: str) -> str:
    """The channel kind of ``unit``; SceneError at ``where`` if unknown or of another dimension."""
    for kind, unit_kind in KINDS.items():
        try:
            unit_factor(_pint_unit(unit), unit_kind, "SI", where)
            return kind
        except SceneError:
            continue
    raise SceneError(where, f'unknown or unsupported unit "{unit}": a channel is an acceleration '
                            f'("g", "m/s^2"), a force ("N", "kN", "lbf"), a displacement ("mm", "in") '
                            f'or a velocity ("m/s", "km/h", "mph")')


def time_factor(unit: str, where: str) -> float:
    """Seconds per ``unit`` of time; SceneError at ``where`` if it is not one."""
    return unit_factor(unit, "time", "SI", where)
