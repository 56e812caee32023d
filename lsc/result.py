"""Result: events, metrics and (sampled when first asked for) time series of one crash.

Every backend hands the same raw material to :meth:`Result.build`: its rows at the event points
(the exact states at both sides of every event), the peaks it located between them, the event
list, each contact's final hysteresis record and the solver statistics; and a sampler that
computes the series when they are first read. The impacts are read off the event points, and
the metrics computed once from them by :func:`lsc.metrics.metrics` (the definitions every batch
path shares); a solve whose caller reads only metrics never samples the series.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from . import metrics as _metrics
from .errors import SimulationError
from .impacts import Impact, check_resolved, find_impacts, last_speeds
from .laws.damping_tails import damping_tails

__all__ = ["Result", "Event", "Impact", "METRICS"]

#: The scalar metrics of a result: name → (kind of unit, per "vehicle" | "contact" | "scene").
METRICS = {
    "delta_v": ("velocity", "vehicle"),
    "v_final": ("velocity", "vehicle"),
    "peak_acceleration": ("acceleration", "vehicle"),
    "peak_acceleration_g": ("dimensionless", "vehicle"),
    "duration": ("time", "scene"),
    "max_deformation": ("length", "contact"),
    "permanent_deformation": ("length", "contact"),
    "peak_force": ("force", "contact"),
    "restitution": ("dimensionless", "contact"),
    "restitution_energy": ("dimensionless", "contact"),
    "energy_absorbed": ("energy", "contact"),
    "energy_returned": ("energy", "contact"),
    "failure_time": ("time", "contact"),
}

#: Metrics of the whole run (not batch metrics): name → (kind of unit, per ...).
TOTALS = {
    "delta_v_total": ("velocity", "vehicle"),
    "duration_total": ("time", "scene"),
}

#: Where NaN is a documented value ("not applicable"), and when: name → test on the result.
_NOT_APPLICABLE = {
    "failure_time": lambda r: ~r.failed,
    "restitution": lambda r: np.array([not getattr(m, "struck", False)
                                       for m in _first_of_contact(r)], bool),
    "restitution_energy": lambda r: ~(r.energy_absorbed > 0),
}

_SERIES_KINDS = {"t": "time", "x": "length", "v": "velocity", "a": "acceleration",
                 "deformation": "length", "force": "force"}


@dataclass(frozen=True)
class Event:
    """One discrete event: ``time`` [time], ``kind`` (``"contact"``, ``"max_deformation"``,
    ``"breakpoint"``, ``"separation"``, ...) and ``index`` (the contact or vehicle it concerns)."""

    time: float
    kind: str
    index: int


def _series_property(name: str, doc: str) -> property:
    return property(lambda self: self._series[name], doc=doc)


@dataclass(eq=False)
class Result:
    """One simulated crash. Arrays are in the scene's unit system; ``units`` names each field's unit.

    Series (sampled when first read): ``t`` (n,), ``x, v, a`` (n, N), ``deformation, force``
    (n, K). ``impacts``: every
    touch → separation episode of every contact (:class:`~lsc.result.Impact`), in order of
    first touch; ``first_impact`` is the crash pulse. Headline metrics, each vehicle's and each
    contact's first impact: ``delta_v`` (N,) (speed at separation minus speed at touch),
    ``peak_acceleration`` (N,) (signed, largest magnitude), ``peak_acceleration_g``,
    ``duration`` (the scene's first impact) [time], ``peak_force`` (K,), ``restitution`` (K,)
    (velocity definition, Eq. 9, over the closing speed at touch; NaN, not applicable, for a
    contact that never touched or was pushed shut). Over the run, per contact:
    ``max_deformation, permanent_deformation, energy_absorbed, energy_returned``,
    ``restitution_energy`` (Eq. 10: ``sqrt(returned / absorbed)``; NaN where nothing was
    absorbed), ``failure_time`` (when the force first exceeded the failure force, NaN if never;
    ``failed`` says which; with a post-failure curve, when the deformation first reached the
    failure point). Totals: ``v_final`` (N,) (after the last separation), ``delta_v_total``
    (``v_final`` minus the speeds at t = 0), ``duration_total`` (first touch to last
    separation). ``events``: list of :class:`Event`. ``method``, ``tolerances`` (rtol, atol or
    dt), ``stats`` (steps, rhs evaluations, segments, wall time [s]) and ``warnings`` (what the
    backend says about its accuracy) say how it was computed. See the metrics page of the docs.
    """

    scene: object
    events: list
    method: str
    tolerances: dict
    stats: dict
    delta_v: np.ndarray = field(init=False)
    v_final: np.ndarray = field(init=False)
    peak_acceleration: np.ndarray = field(init=False)
    peak_acceleration_g: np.ndarray = field(init=False)
    duration: float = field(init=False)
    max_deformation: np.ndarray = field(init=False)
    permanent_deformation: np.ndarray = field(init=False)
    peak_force: np.ndarray = field(init=False)
    restitution: np.ndarray = field(init=False)
    restitution_energy: np.ndarray = field(init=False)
    energy_absorbed: np.ndarray = field(init=False)
    energy_returned: np.ndarray = field(init=False)
    contact_time: np.ndarray = field(init=False)
    separation_time: np.ndarray = field(init=False)
    failure_time: np.ndarray = field(init=False)
    impacts: tuple = field(init=False)
    delta_v_total: np.ndarray = field(init=False)
    duration_total: float = field(init=False)
    warnings: tuple = field(init=False)
    sampler: Callable = field(init=False, repr=False)

    t = _series_property("t", "Times (n,) [time] of the sampled series.")
    x = _series_property("x", "Positions (n, N) [length] (from where each vehicle starts).")
    v = _series_property("v", "Velocities (n, N) [velocity].")
    a = _series_property("a", "Accelerations (n, N) [acceleration].")
    deformation = _series_property("deformation", "Deformations (n, K) [length].")
    force = _series_property("force", "Contact forces (n, K) [force].")

    @classmethod
    def build(cls, scene, *, events, contacts, v_final, method, tolerances, stats,
              t=None, x=None, v=None, a=None, deformation=None, force=None,
              rows=None, sampler=None, peaks=(), failure_time=None) -> "Result":
        """Assemble a result from the event points, the peaks between them and the records.

        Either the whole series ``t, x, v, a, deformation, force`` (which then serve as the
        rows), or ``rows`` (a dict of ``t`` (n,), ``v, a`` (n, N), ``deformation, force``
        (n, K) holding both sides of every event: the ends of every segment) and ``sampler``
        (a callable returning the series as such a dict, ``x`` included; called when a series
        is first read). ``peaks``: the peaks the backend located between the rows, ``(t0, t1,
        force (K,), acceleration (N,) signed)`` and optionally ``deformation (K,)``, each
        counted in the impacts that hold ``[t0, t1]``; ``contacts``: per contact a dict with ``dmax,
        fmax, dperm, ec, er`` (max and permanent deformation, force at max deformation,
        absorbed and returned energy); ``v_final`` (N,) the velocities at the last separation;
        ``failure_time`` (K,): when each contact's force first exceeded its failure force, if
        the backend knows it (else read off the events and rows). Raises
        :class:`~lsc.SimulationError` when an impact is too short for the absolute times to
        resolve it, or a value is NaN or infinite where a number is expected.
        """
        r = cls(scene=scene, events=list(events), method=method, tolerances=dict(tolerances),
                stats=dict(stats))
        if rows is None:
            series = {name: np.asarray(val, float) for name, val in
                      (("t", t), ("x", x), ("v", v), ("a", a), ("deformation", deformation),
                       ("force", force))}
            rows, sampler = series, lambda: series
            r._series = series
        rows = {k: np.asarray(rows[k], float) for k in ("t", "v", "a", "deformation", "force")}
        _check_series(method, r.__dict__.get("_series", rows))
        r.sampler = sampler
        r.warnings = tuple(str(w) for w in r.stats.get("warnings", ())) + \
            damping_tails(scene, contacts)
        r.v_final = np.asarray(v_final, float)
        v_max = float(np.max(np.abs(rows["v"]), initial=0.0))
        r.impacts = find_impacts(rows, r.events, r.v_final, contacts, speeds=scene.speeds,
                                 g=scene.g, v_max=v_max, spans=peaks,
                                 resolution=r.resolution)
        for imp in r.impacts:
            check_resolved(imp.t_start, imp.t_end, f"contact {imp.contact}: the impact")
        if failure_time is None:
            failure_time = _failure_times(scene, r.events, rows)
        r._set_metrics(rows, contacts, np.asarray(failure_time, float), v_max)
        _check_finite(r)
        return r

    def _set_metrics(self, rows, contacts, failure_time, v_max) -> None:
        """The metrics (:func:`lsc.metrics.metrics`) from the first impact of each contact;
        the totals over the run."""
        records = {key: np.array([c[key] for c in contacts], float)
                   for key in ("dmax", "dperm", "ec", "er")}
        first = _first_record(self.impacts, len(contacts), v_max)
        out = _metrics.metrics(first, records, self.v_final, self.scene.g, failure_time,
                               float(rows["t"][-1]), last_speeds(rows, self.impacts, self.v_final),
                               resolution=self.resolution)
        for name in (*METRICS, "contact_time"):
            value = out[name]
            setattr(self, name, value if isinstance(value, np.ndarray) and value.ndim
                    else float(value))
        imps = self.impacts
        self.separation_time = np.array(
            [max((m.t_end for m in imps if m.contact == k and m.separated), default=np.nan)
             for k in range(len(contacts))], float)
        self.delta_v_total = self.v_final - np.asarray(self.scene.speeds, float)
        if imps:
            t0, t1 = min(m.t_start for m in imps), max(m.t_end for m in imps)
            check_resolved(t0, t1, "the crash")
            self.duration_total = t1 - t0
        else:
            self.duration_total = 0.0

    @cached_property
    def _series(self) -> dict:
        """The sampled series (computed by the backend's sampler on first use)."""
        series = {k: np.asarray(v, float) for k, v in self.sampler().items()}
        _check_series(self.method, series)
        return series

    @property
    def resolution(self) -> float:
        """The relative time resolution of the solve [-]: its ``rtol`` (0 for an exact one);
        closings closer than :func:`lsc.metrics.tie_window` are simultaneous."""
        return float(self.tolerances.get("rtol") or 0.0)

    @property
    def first_impact(self) -> Impact | None:
        """The first impact of the scene (the crash pulse; ``None`` if nothing touched)."""
        return self.impacts[0] if self.impacts else None

    @property
    def failed(self) -> np.ndarray:
        """Per contact (K,): True where the force exceeded the contact's failure force."""
        return np.isfinite(self.failure_time)

    # ------------------------------------------------------------------ units and export
    @property
    def units(self) -> dict[str, str]:
        """The unit of every series and metric (pint spelling; ``""`` for dimensionless)."""
        u = {name: self.scene.unit(kind) for name, kind in _SERIES_KINDS.items()}
        u.update({name: self.scene.unit(kind)
                  for name, (kind, _) in (*METRICS.items(), *TOTALS.items())})
        return u

    def metrics(self) -> dict[str, object]:
        """All scalar metrics as a dict (arrays per vehicle or contact, floats per scene)."""
        return {name: getattr(self, name) for name in METRICS}

    def to_dict(self) -> dict:
        """A JSON-ready summary: scene, method, tolerances, stats, metrics, units and events."""
        def plain(x):
            return x.tolist() if isinstance(x, np.ndarray) else x
        return {
            "scene": self.scene.name,
            "unit_system": self.scene.units,
            "method": self.method,
            "tolerances": {k: plain(v) for k, v in self.tolerances.items()},
            "stats": {k: plain(v) for k, v in self.stats.items()},
            "vehicles": [v.name for v in self.scene.vehicles],
            "metrics": {k: plain(v) for k, v in self.metrics().items()},
            "units": {k: self.units[k] for k in METRICS},
            "totals": {k: plain(getattr(self, k)) for k in TOTALS},
            "impacts": [{**asdict(m), "duration": m.duration} for m in self.impacts],
            "warnings": list(self.warnings),
            "events": [{"time": e.time, "kind": e.kind, "index": e.index} for e in self.events],
        }

    def series_columns(self) -> dict[str, np.ndarray]:
        """The time series as named columns (``"v[bullet] (ft/s)"`` ...), for CSV export."""
        u = self.units
        cols = {f"t ({u['t']})": self.t}
        names = [v.name for v in self.scene.vehicles]
        for key in ("x", "v", "a"):
            arr = getattr(self, key)
            for i, n in enumerate(names):
                cols[f"{key}[{n}] ({u[key]})"] = arr[:, i]
        for key in ("deformation", "force"):
            arr = getattr(self, key)
            for k in range(arr.shape[1]):
                cols[f"{key}[{k}] ({u[key]})"] = arr[:, k]
        return cols

    def summary(self, speed_unit: str | None = None) -> str:
        """A plain-text summary table (what ``lsc run`` prints).

        ``speed_unit`` (``"mph"``, ``"km/h"``, ``"ft/s"``, ``"m/s"``; default the scene's
        ``[display] speed_unit``, else its velocity unit) is the unit the speeds and ΔVs are
        printed in; everything else stays in the scene's units, accelerations in g beside them.
        Raises :class:`lsc.SceneError` for another unit.
        """
        from .display import speed_display
        speed_unit = speed_unit if speed_unit is not None else self.scene.speed_unit
        fv, vel = speed_display(speed_unit, self.scene.units)
        u = self.units
        s = self.scene
        lines = [f"{s.name}  —  method {self.method}, {self.scene.units} units"
                 + (f", speeds in {vel}" if speed_unit is not None else "")]
        tol = ", ".join(f"{k}={v:g}" for k, v in self.tolerances.items() if v is not None)
        if tol:
            lines[0] += f" ({tol})"
        contacts = [f"{k} ({s.vehicles[k].name}-{s.vehicles[k + 1].name})"
                    for k in range(len(s.contacts))]
        w = max(12, *(len(v.name) for v in s.vehicles), *map(len, contacts))
        lines.append("")
        total = not np.array_equal(self.delta_v, self.delta_v_total)
        lines.append(f"{'vehicle':<{w}} {'v0':>10} {'v_final':>10} {'delta_v':>10} "
                     f"{'peak a':>11} {'peak a':>8}" + (f" {'dV total':>10}" if total else ""))
        lines.append(f"{'':<{w}} {vel:>10} {vel:>10} {vel:>10} "
                     f"{u['peak_acceleration']:>11} {'g':>8}"
                     + (f" {vel:>10}" if total else ""))
        for i, veh in enumerate(s.vehicles):
            lines.append(f"{veh.name:<{w}} {veh.speed * fv:>10.4g} {self.v_final[i] * fv:>10.4f} "
                         f"{self.delta_v[i] * fv:>10.4f} {self.peak_acceleration[i]:>11.4g} "
                         f"{self.peak_acceleration_g[i]:>8.3f}"
                         + (f" {self.delta_v_total[i] * fv:>10.4f}" if total else ""))
        if total:
            lines.append("(delta_v and peak a: over the vehicle's first impact; dV total: v_final "
                         "- v0, over the whole run)")
        lines.append("")
        lines.append(f"{'contact':<{w}} {'D_max':>10} {'D_perm':>10} {'F_peak':>10} "
                     f"{'e (vel)':>8} {'e (energy)':>10}")
        lines.append(f"{'':<{w}} {u['max_deformation']:>10} {u['permanent_deformation']:>10} "
                     f"{u['peak_force']:>10} {'':>8} {'':>10}")
        for k, label in enumerate(contacts):
            lines.append(f"{label:<{w}} "
                         f"{self.max_deformation[k]:>10.5f} {self.permanent_deformation[k]:>10.5f} "
                         f"{self.peak_force[k]:>10.6g} {self.restitution[k]:>8.4f} "
                         f"{self.restitution_energy[k]:>10.4f}")
        for k, c in enumerate(s.contacts):
            if c.failure is None:
                continue
            force = f"{c.failure.force:.6g} {u['peak_force']}"
            post = ", then the post-failure curve" if c.failure.post_failure is not None else ""
            lines.append(f"bumper failure, contact {k} ({force}): "
                         + (f"failed at t = {self.failure_time[k]:.6g} {u['failure_time']}{post}"
                            if self.failed[k] else "not reached"))
        if len(self.impacts) > 1:
            lines += ["", *self._impacts_table(w, fv, vel)]
        lines.append("")
        total = (f" (whole crash {self.duration_total:.6g} {u['duration']})"
                 if self.duration_total != self.duration else "")
        lines.append(f"pulse duration {self.duration:.6g} {u['duration']}{total}; "
                     f"{len(self.events)} events; "
                     + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                 for k, v in self.stats.items() if k != "warnings"))
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def _impacts_table(self, w: int, fv: float = 1.0, vel: str | None = None) -> list[str]:
        """The summary's lines for the impacts, in order of first touch (speeds times ``fv``,
        in ``vel``; default the scene's unit)."""
        u, names, g = self.units, [v.name for v in self.scene.vehicles], self.scene.g
        labels = [f"{j}: {m.contact} ({names[m.vehicles[0]]}-{names[m.vehicles[1]]})"
                  for j, m in enumerate(self.impacts, 1)]
        w = max(w, *map(len, labels))
        vel, acc = vel or u["delta_v"], u["peak_acceleration"]
        lines = [f"{'impact':<{w}} {'t_start':>10} {'t_end':>10} {'closing':>9} "
                 f"{'dV rear':>9} {'dV front':>9} {'peak a rear':>12} {'peak a front':>12} "
                 f"{'rear':>7} {'front':>7} {'F_peak':>10} {'D_max':>9} {'e (vel)':>8}",
                 f"{'':<{w}} {u['t']:>10} {u['t']:>10} {vel:>9} {vel:>9} {vel:>9} "
                 f"{acc:>12} {acc:>12} {'g':>7} {'g':>7} {u['peak_force']:>10} "
                 f"{u['max_deformation']:>9} {'':>8}"]
        for label, m in zip(labels, self.impacts):
            end = f"{m.t_end:>10.6g}" if m.separated else f"{'(open)':>10}"
            lines.append(f"{label:<{w}} {m.t_start:>10.6g} {end} "
                         f"{m.closing_speed * fv:>9.4f} {m.delta_v[0] * fv:>+9.4f} "
                         f"{m.delta_v[1] * fv:>+9.4f} "
                         f"{m.peak_acceleration[0]:>12.4g} {m.peak_acceleration[1]:>12.4g} "
                         f"{m.peak_acceleration[0] / g:>7.3f} {m.peak_acceleration[1] / g:>7.3f} "
                         f"{m.peak_force:>10.6g} {m.max_deformation:>9.5f} "
                         f"{m.restitution:>8.4f}")
        lines.append("(the tables above report each vehicle's and contact's first impact; "
                     "e (vel) is nan where a contact was pushed shut, not struck)")
        return lines

    def to_dataframe(self):
        """The time series as a pandas DataFrame (:func:`lsc.frames.result_frame`)."""
        from .frames import result_frame
        return result_frame(self)

    def summary_frame(self):
        """The metrics as a pandas DataFrame (:func:`lsc.frames.summary_frame`)."""
        from .frames import summary_frame
        return summary_frame(self)

    def _repr_html_(self) -> str:
        from .html import result_html
        return result_html(self)

    def __repr__(self) -> str:
        return (f"<Result {self.scene.name!r} method={self.method} duration={self.duration:.6g} "
                f"delta_v={np.array2string(self.delta_v, precision=6)}>")


def _first_of_contact(r: Result) -> list:
    """Each contact's first impact (``None`` where it never touched)."""
    return [next((m for m in r.impacts if m.contact == k), None)
            for k in range(len(r.scene.contacts))]


def _first_record(impacts, K: int, v_max: float) -> dict:
    """The first-impact record (:data:`lsc.metrics.FIRST_KEYS`) of the impacts: per contact,
    its first impact's touch, separation (NaN while open), speeds and peaks."""
    nan, nan2 = float("nan"), (float("nan"),) * 2
    first = {"contact_time": [nan] * K, "v_touch": [nan2] * K, "first_end": [nan] * K,
             "v_sep": [nan2] * K, "peak_force": [0.0] * K, "peak_acc": [(0.0, 0.0)] * K}
    for m in reversed(impacts):   # (each contact's first impact last, so it stays)
        k = m.contact
        first["contact_time"][k], first["v_touch"][k] = m.t_start, m.v_start
        first["first_end"][k], first["v_sep"][k] = ((m.t_end, m.v_end) if m.separated
                                                    else (nan, nan2))
        first["peak_force"][k], first["peak_acc"][k] = m.peak_force, m.peak_acceleration
    # (in Python, then one array each: cheaper than filling arrays)
    first = {key: np.array(value, float).reshape((K, 2) if key in _PAIRED else (K,))
             for key, value in first.items()}
    first["v_max"] = np.float64(v_max)
    return first


#: The first-impact record's fields with a (rear, front) pair per contact.
_PAIRED = ("v_touch", "v_sep", "peak_acc")


def _failure_times(scene, events, rows) -> np.ndarray:
    """Per contact: when the force first exceeded the failure force (NaN: never, or none set):
    its failure event, else the first row above it (a force step at an event)."""
    out = np.full(len(scene.contacts), np.nan)
    t, force = rows["t"], rows["force"]
    for k, c in enumerate(scene.contacts):
        if c.failure is None:
            continue
        times = [ev.time for ev in events if "failure" in ev.kind.split("+") and ev.index == k]
        if times:
            out[k] = times[0]
        elif force.size and np.any(force[:, k] > c.failure.force):
            out[k] = t[np.argmax(force[:, k] > c.failure.force)]
    return out


def _check_series(method: str, series: dict) -> None:
    """Raise :class:`SimulationError` if a series (or a row at the events) is not finite."""
    present = [name for name in _SERIES_KINDS if name in series]
    flat = np.concatenate([series[name].ravel() for name in present] or [()])
    if np.isfinite(flat).all():   # the common case, in one call; else name the bad ones
        return
    bad = [name for name in present if not np.all(np.isfinite(series[name]))]
    if bad:
        raise _non_finite(method, bad)


def _non_finite(method: str, bad: list) -> SimulationError:
    return SimulationError(
        f"{method}: the solve produced non-finite values in {', '.join(bad)}; the "
        "scene's magnitudes are beyond what the computation can represent (check the "
        "speeds, masses, gaps and stiffnesses for absurd values)")


def _check_finite(r: Result) -> None:
    """Raise :class:`SimulationError` if a metric is NaN or infinite where a number is expected
    (NaN is allowed only where :data:`_NOT_APPLICABLE` documents it)."""
    if _all_finite(r):
        return
    bad = []
    for name in (*METRICS, *TOTALS):
        value = np.asarray(getattr(r, name), float)
        finite = np.isfinite(value)
        if finite.all():
            continue
        if not (finite | np.isnan(value) & _not_applicable(r, name, value.shape)).all():
            bad.append(name)
    if bad:
        raise _non_finite(r.method, bad)


def _all_finite(r: Result) -> bool:
    """Whether every metric and total is finite, ``failure_time`` NaN or finite (the common
    case, told in one pass; the documented NaN otherwise is checked one by one)."""
    # (on Python floats: a few numbers per metric, where NumPy's cost per call dominates)
    flat = []
    for name in (*METRICS, *TOTALS):
        if name != "failure_time":
            value = getattr(r, name)
            flat += value.ravel().tolist() if isinstance(value, np.ndarray) else (value,)
    return (all(map(math.isfinite, flat))
            and not any(map(math.isinf, r.failure_time.ravel().tolist())))


def _not_applicable(r: Result, name: str, shape) -> np.ndarray:
    """Where ``name`` may be NaN (not applicable) on ``r``."""
    test = _NOT_APPLICABLE.get(name)
    return np.broadcast_to(test(r), shape) if test else np.zeros(shape, bool)
