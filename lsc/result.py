"""Result: time series, events and metrics of one simulated crash, in the scene's units.

Every backend hands the same raw material to :meth:`Result.build`: sampled series (which include
every event point, so peaks reached at events are exact), the event list, each contact's final
hysteresis record and the solver statistics. Metrics are computed here, once, from that.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from .errors import SimulationError
from .impacts import Impact, check_resolved, find_impacts

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


@dataclass(eq=False)
class Result:
    """One simulated crash. Arrays are in the scene's unit system; ``units`` names each field's unit.

    Series: ``t`` (n,), ``x, v, a`` (n, N), ``deformation, force`` (n, K). ``impacts``: every
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
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    deformation: np.ndarray
    force: np.ndarray
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

    @classmethod
    def build(cls, scene, *, t, x, v, a, deformation, force, events, contacts, v_final,
              method, tolerances, stats) -> "Result":
        """Assemble a result from sampled series and each contact's record.

        ``contacts`` is a list of dicts with ``dmax, fmax, dperm, ec, er`` (max and permanent
        deformation, force at max deformation, absorbed and returned energy) per contact;
        ``v_final`` (N,) the velocities at the last separation (after the crash). Raises
        :class:`~lsc.SimulationError` when an impact is too short for the absolute times to
        resolve it, or a value is NaN or infinite where a number is expected.
        """
        r = cls(scene=scene, t=np.asarray(t, float), x=np.asarray(x, float),
                v=np.asarray(v, float), a=np.asarray(a, float),
                deformation=np.asarray(deformation, float), force=np.asarray(force, float),
                events=list(events), method=method, tolerances=dict(tolerances),
                stats=dict(stats))
        r.warnings = tuple(str(w) for w in r.stats.get("warnings", ()))
        r.v_final = np.asarray(v_final, float)
        r.max_deformation = np.array([c["dmax"] for c in contacts], float)
        r.permanent_deformation = np.array([c["dperm"] for c in contacts], float)
        r.energy_absorbed = np.array([c["ec"] for c in contacts], float)
        r.energy_returned = np.array([c["er"] for c in contacts], float)
        with np.errstate(invalid="ignore", divide="ignore"):
            # NaN (not applicable) for a contact that never absorbed any energy (never touched)
            r.restitution_energy = np.sqrt(r.energy_returned / r.energy_absorbed)
        r.impacts = find_impacts(r, r.v_final, contacts)
        for imp in r.impacts:
            check_resolved(imp.t_start, imp.t_end, f"contact {imp.contact}: the impact")
        r._headline()
        r.failure_time = _failure_times(r)
        _check_finite(r)
        return r

    def _headline(self) -> None:
        """The headline metrics from the impacts: each vehicle's and each contact's first
        impact (for a two-vehicle scene the first impact of the scene); totals over the run."""
        N, K = self.v.shape[1], self.deformation.shape[1]
        imps = self.impacts
        first_of_vehicle = [next((m for m in imps if i in m.vehicles), None) for i in range(N)]
        first_of_contact = _first_of_contact(self)
        self.delta_v = np.array([0.0 if m is None else m.delta_v[m.vehicles.index(i)]
                                 for i, m in enumerate(first_of_vehicle)])
        self.peak_acceleration = np.array(
            [0.0 if m is None else m.peak_acceleration[m.vehicles.index(i)]
             for i, m in enumerate(first_of_vehicle)])
        self.peak_acceleration_g = self.peak_acceleration / self.scene.g
        self.peak_force = np.array([0.0 if m is None else m.peak_force for m in first_of_contact])
        self.restitution = np.array([np.nan if m is None else m.restitution
                                     for m in first_of_contact])
        self.contact_time = np.array([np.nan if m is None else m.t_start for m in first_of_contact])
        last = [max((m.t_end for m in imps if m.contact == k and m.separated), default=np.nan)
                for k in range(K)]
        self.separation_time = np.array(last, float)
        self.duration = imps[0].duration if imps else 0.0
        self.delta_v_total = self.v_final - np.asarray(self.scene.speeds, float)
        if imps:
            t0, t1 = min(m.t_start for m in imps), max(m.t_end for m in imps)
            check_resolved(t0, t1, "the crash")
            self.duration_total = t1 - t0
        else:
            self.duration_total = 0.0

    def _raise_peaks(self, spans) -> None:
        """Raise the impacts' peaks to those located between samples (on a dense output, or in
        closed form) by the backend: ``spans`` is a list of ``(t0, t1, force (K,) [force],
        acceleration (N,) [acceleration], signed)``, each applied to the impacts that hold
        ``[t0, t1]``."""
        if not spans:
            return
        t0 = np.array([s[0] for s in spans], float)
        t1 = np.array([s[1] for s in spans], float)
        F = np.array([s[2] for s in spans], float)
        A = np.array([s[3] for s in spans], float)
        new = []
        for m in self.impacts:
            inside = np.nonzero((t0 >= m.t_start) & (t1 <= m.t_end))[0]
            if inside.size:
                pair = list(m.vehicles)
                acc = A[inside][:, pair]
                pick = np.argmax(np.abs(acc), axis=0)
                m = m.raise_peaks(float(np.max(F[inside, m.contact])),
                                  acc[pick, [0, 1]], self.scene.g)
            new.append(m)
        self.impacts = tuple(new)
        self._headline()
        _check_finite(self)

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
            for k in range(r.deformation.shape[1])]


def _failure_times(r: Result) -> np.ndarray:
    """Per contact: when the force first exceeded the failure force (NaN: never, or none set)."""
    out = np.full(len(r.scene.contacts), np.nan)
    for k, c in enumerate(r.scene.contacts):
        if c.failure is None:
            continue
        times = [ev.time for ev in r.events if "failure" in ev.kind.split("+") and ev.index == k]
        if times:
            out[k] = times[0]
        elif r.force.size and np.any(r.force[:, k] > c.failure.force):
            out[k] = r.t[np.argmax(r.force[:, k] > c.failure.force)]
    return out


def _check_finite(r: Result) -> None:
    """Raise :class:`SimulationError` if a series or a metric is NaN or infinite where a number
    is expected (NaN is allowed only where :data:`_NOT_APPLICABLE` documents it)."""
    bad = [name for name in _SERIES_KINDS if not np.all(np.isfinite(getattr(r, name)))]
    for name in (*METRICS, *TOTALS):
        value = np.asarray(getattr(r, name), float)
        allowed = np.isnan(value) & _not_applicable(r, name, value.shape)
        if not np.all(np.isfinite(value) | allowed):
            bad.append(name)
    if bad:
        raise SimulationError(
            f"{r.method}: the solve produced non-finite values in {', '.join(bad)}; the "
            "scene's magnitudes are beyond what the computation can represent (check the "
            "speeds, masses, gaps and stiffnesses for absurd values)")


def _not_applicable(r: Result, name: str, shape) -> np.ndarray:
    """Where ``name`` may be NaN (not applicable) on ``r``."""
    test = _NOT_APPLICABLE.get(name)
    return np.broadcast_to(test(r), shape) if test else np.zeros(shape, bool)
