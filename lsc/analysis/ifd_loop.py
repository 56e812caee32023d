"""The dynamic IF-D loop of a crash test (the paper's Fig. 3): contact force against deformation.

:func:`ifd_loop` builds it from measured channels in one of two ways:

- ``source="channels"``: a load-cell channel (``force``) against a displacement channel
  (``deformation``), as matched by :meth:`~lsc.analysis.channels.Channels.match` (or ``mapping``);
- ``source="accelerations"``: from both vehicles' accelerations (``accel_<rear>``, ``accel_<front>``
  of the scene's contact): the deformation by double integration (trapezoidal rule) of
  ``D'' = a_rear - a_front`` from ``D(0) = 0``, ``D'(0) = v0`` (the closing speed at first contact,
  the scene's initial one unless ``closing_speed`` is given), and the force from Newton's law on
  the vehicles, ``F = (m_front a_front - m_rear a_rear) / 2`` (the two vehicles' estimates
  averaged; exact for a two-vehicle crash without braking).

``"auto"`` (default) uses the force and displacement channels where both are present. Time zero
of the channels is first contact; a displacement channel is taken as it reads (zero at first
contact: remove a sensor offset with ``read_channels(..., offset="pre-trigger")``). The loading
table starts at ``(0, 0)`` (first contact), then the samples with positive deformation.

The loop is split at its maximum deformation into the **loading** branch (time zero to the
maximum) and the **unloading** branch (the maximum to the first zero of the force, located by
linear interpolation, or extrapolation from the two samples before where the record ends with
the pulse), each a table a scene takes as it is: ``loading = {"table": ...}``
(``[[0, 0], ..., [D_max, F_max]]``, deformation strictly increasing from 0) and
``unloading = {"table": ...}`` (``[[D_max, F_max], ..., [D_perm, 0]]``, deformation strictly
decreasing, last force 0), in the scene's unit system. Measured noise makes a deformation
channel go back and forth: each branch keeps only the samples that extend it (a new largest
deformation on loading, a new smallest on unloading), and negative forces are set to zero (bumpers
push, never pull); :attr:`IFDLoop.notes` says how many samples this touched.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..scene import UNITS, Scene
from .compare import _delta_v

__all__ = ["IFDLoop", "ifd_loop", "SOURCES"]

#: Accepted ``source`` values.
SOURCES = ("auto", "channels", "accelerations")


@dataclass(frozen=True)
class IFDLoop:
    """A dynamic IF-D loop in the unit system ``units`` (``"SI"``/``"US"``).

    ``t`` [s], ``deformation`` and ``force``: the loop in time order from first contact;
    ``loading`` (n, 2) and ``unloading`` (m, 2): the branch tables ``[deformation, force]``;
    ``max_deformation``, ``max_force``; ``permanent_set``: the deformation where the force
    returns to zero; ``source``: how it was built; ``notes``: samples dropped or set to zero.
    """

    t: np.ndarray
    deformation: np.ndarray
    force: np.ndarray
    loading: np.ndarray
    unloading: np.ndarray
    units: str
    source: str
    notes: tuple = ()

    @property
    def max_deformation(self) -> float:
        return float(self.loading[-1, 0])

    @property
    def max_force(self) -> float:
        return float(self.loading[-1, 1])

    @property
    def permanent_set(self) -> float:
        return float(self.unloading[-1, 0])

    def loading_spec(self) -> dict:
        """``{"table": [[D, F], ...]}``: a scene's ``contacts[k].loading``."""
        return {"table": self.loading.tolist()}

    def unloading_spec(self) -> dict:
        """``{"table": [[D, F], ...]}``: a scene's ``contacts[k].unloading``."""
        return {"table": self.unloading.tolist()}

    def figure(self, ax=None):
        """Force against deformation, loading and unloading branches (matplotlib imported here)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
        u = UNITS[self.units]
        ax.plot(self.deformation, self.force, color="0.7", lw=0.8, label="loop")
        ax.plot(self.loading[:, 0], self.loading[:, 1], color="C3", label="loading")
        ax.plot(self.unloading[:, 0], self.unloading[:, 1], color="C0", label="unloading")
        ax.set_xlabel(f"deformation [{u['length']}]")
        ax.set_ylabel(f"force [{u['force']}]")
        ax.grid(alpha=0.3)
        ax.legend()
        return ax.figure


def ifd_loop(channels, scene=None, *, contact: int = 0, source: str = "auto", mapping: dict | None = None,
             closing_speed: float | None = None, units: str | None = None, window=None) -> IFDLoop:
    """The dynamic IF-D loop of ``channels`` with its loading and unloading tables.

    Parameters
    ----------
    channels : Channels
        Measured channels, time zero at first contact.
    scene : dict, path or Scene, optional
        Names the channels (``force``, ``deformation``, ``accel_<vehicle>``) and gives the unit
        system; needed for ``source="accelerations"`` (masses, closing speed).
    contact : int
        The scene's contact (``force`` / ``deformation`` for 0, ``force_2`` ... for later ones).
    source : ``"auto"``, ``"channels"`` or ``"accelerations"``
        See the module docstring.
    mapping : dict, optional
        ``{role: channel name}`` (roles ``force``, ``deformation``, ``accel_<vehicle>``).
    closing_speed : float, optional
        Closing speed at first contact (scene units) for ``"accelerations"``.
    units : ``"SI"`` or ``"US"``, optional
        Unit system of the tables (default: the scene's, else SI).
    window : (float, float), optional
        Time interval [s] of the loop (default: time zero to the end of the record).

    Raises
    ------
    lsc.SceneError
        A missing channel or scene, a loop without positive force or deformation, a force that
        does not return to zero within the window.
    """
    if source not in SOURCES:
        raise SceneError("source", f"one of {', '.join(SOURCES)}, got {source!r}")
    sc = Scene.load(scene) if scene is not None else None
    system = units or (sc.units if sc is not None else "SI")
    if system not in UNITS:
        raise SceneError("units", f"one of {', '.join(UNITS)}, got {system!r}")
    roles = _roles(channels, sc, contact, mapping)
    t, inside = _window(channels, window)
    if source == "auto":
        source = "channels" if {"force", "deformation"} <= set(roles) else "accelerations"
    if source == "channels":
        d, f = _from_channels(roles, inside, system, channels.source)
    else:
        d, f = _from_accelerations(roles, sc, contact, t, inside, system, closing_speed, channels.source)
    return _split(t, d, f, system, source, channels.source)


def _roles(channels, sc, contact, mapping) -> dict:
    """``{"force", "deformation", "accel_rear", "accel_front"}`` → Channel, those present."""
    if sc is None:
        names = {"force": "force", "deformation": "deformation", **(mapping or {})}
        return {r: channels[n] for r, n in names.items() if n in channels or r in (mapping or {})}
    found = channels.match(sc, mapping)
    suffix = "" if contact == 0 else f"_{contact + 1}"
    out = {r: found[r + suffix] for r in ("force", "deformation") if r + suffix in found}
    if 0 <= contact < len(sc.contacts):
        rear, front = sc.vehicles[contact].name, sc.vehicles[contact + 1].name
        for role, name in (("accel_rear", rear), ("accel_front", front)):
            if f"accel_{name}" in found:
                out[role] = found[f"accel_{name}"]
    else:
        raise SceneError("contact", f"the scene has {len(sc.contacts)} contact(s): give 0..{len(sc.contacts) - 1}")
    return out


def _window(channels, window):
    t = channels.t
    t0, t1 = (0.0, float(t[-1])) if window is None else (float(w) for w in window)
    if not (float(t[0]) - 1e-12 <= t0 < t1 <= float(t[-1]) + 1e-12) or t0 < -1e-12:
        raise SceneError("window", f"the window ({t0:g}, {t1:g}) s must start at or after time zero "
                                   f"and lie inside the record ({float(t[0]):g}, {float(t[-1]):g}) s")
    inside = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
    if np.count_nonzero(inside) < 3:
        raise SceneError("window", "fewer than 3 samples in the window")
    return t[inside], inside


def _need(roles: dict, names, what: str, where: str):
    missing = [n for n in names if n not in roles]
    if missing:
        raise SceneError(where, f"{what} needs the channels {', '.join(missing)} (name them so, or "
                                f"pass mapping={{role: channel}}); found: {', '.join(roles) or '(none)'}")
    return [roles[n] for n in names]


def _from_channels(roles, inside, system, where):
    force, deform = _need(roles, ("force", "deformation"), "a loop from a load cell and a displacement", where)
    return deform.to(system)[inside], force.to(system)[inside]


def _from_accelerations(roles, sc, contact, t, inside, system, closing_speed, where):
    if sc is None:
        raise SceneError("scene", "a loop from accelerations needs the scene (masses, closing speed)")
    rear, front = _need(roles, ("accel_rear", "accel_front"), "a loop from accelerations", where)
    factor = _system_factor(sc.units, system)
    a_rear, a_front = rear.to(system)[inside], front.to(system)[inside]
    m_rear, m_front = sc.masses[contact] * factor["mass"], sc.masses[contact + 1] * factor["mass"]
    v0 = (sc.speeds[contact] - sc.speeds[contact + 1]) if closing_speed is None else float(closing_speed)
    v0 *= factor["velocity"]
    closing = v0 + _delta_v(t, a_rear - a_front)
    d = _delta_v(t, closing)                       # the same trapezoidal integral, once more
    return d, 0.5 * (m_front * a_front - m_rear * a_rear)


def _system_factor(src: str, dst: str) -> dict:
    from ..units import unit_factor

    return {k: unit_factor(UNITS[src][k], k, dst, "units") for k in ("mass", "velocity")}


def _split(t, d, f, system, source, where) -> IFDLoop:
    i_max = int(np.argmax(d))
    if not d[i_max] > 0 or not np.max(f) > 0:
        raise SceneError(where, "no IF-D loop: the deformation or the force is never positive in the window")
    negative = int(np.count_nonzero(f < 0))
    end = _first_zero(d, f, i_max)
    f = np.maximum(f, 0.0)
    loading, dropped_l = _records(d[:i_max + 1], f[:i_max + 1], increasing=True)
    if end is None:
        raise SceneError(where, f"the force does not return to zero after the maximum deformation "
                                f"(t = {t[i_max]:.6g} s) before the end of the window: no unloading branch")
    j, d_zero = end
    if not f[i_max] > 0:
        raise SceneError(where, "the force is zero at the maximum deformation: no unloading branch")
    unloading, dropped_u = _records(np.append(d[i_max:j], d_zero), np.append(f[i_max:j], 0.0), increasing=False)
    notes = tuple(s for s in (
        f"{negative} negative force sample(s) set to 0" if negative else "",
        f"{dropped_l} loading sample(s) that did not increase the deformation left out" if dropped_l else "",
        f"{dropped_u} unloading sample(s) that did not decrease the deformation left out" if dropped_u else "")
        if s)
    return IFDLoop(t, d, f, loading, unloading, system, source, notes)


def _records(d, f, *, increasing: bool):
    """The points whose deformation goes beyond every earlier one (first and last kept): a strictly
    monotone table, and how many points were left out."""
    sign = 1.0 if increasing else -1.0
    keep = np.zeros(d.size, bool)
    best = 0.0 if increasing else -np.inf       # loading: from D = 0
    for i, x in enumerate(sign * d):
        if x > best:
            keep[i], best = True, x
    if not keep[-1]:                   # the branch's end point (max deformation / zero force) stays
        last = np.nonzero(keep)[0]
        keep[last[sign * d[last] >= sign * d[-1]]] = False
        keep[-1] = True
    table = np.column_stack([d[keep], f[keep]])
    left_out = d.size - np.count_nonzero(keep)
    if increasing:                              # first contact: zero force at zero deformation
        table = np.vstack([[0.0, 0.0], table])
        left_out -= int(d[0] <= 0.0)            # the first sample is that point
    return table, int(left_out)


def _first_zero(d, f, i_max):
    """``(j, D at the zero)``: the first sample ``j`` after ``i_max`` with force <= 0 and the
    deformation where the force reaches zero: between samples ``j - 1`` and ``j``, linearly
    interpolated where the force crosses zero there, extrapolated from the two samples before
    where it is exactly zero at ``j`` (a record that ends with the pulse); ``None`` if none."""
    zero = np.nonzero(f[i_max + 1:] <= 0.0)[0]
    if zero.size == 0:
        return None
    j = i_max + 1 + int(zero[0])
    falling = f[j - 2] - f[j - 1] if j - 2 > i_max else 0.0
    w = f[j - 1] / (f[j - 1] - f[j]) if f[j] < 0 or falling <= 0 else min(1.0, f[j - 1] / falling)
    return j, float(d[j - 1] + w * (d[j] - d[j - 1]))
