"""Result: time series, events and metrics of one simulated crash, in the scene's units.

Every backend hands the same raw material to :meth:`Result.build`: sampled series (which include
every event point, so peaks reached at events are exact), the event list, each contact's final
hysteresis record and the solver statistics. Metrics are computed here, once, from that.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Result", "Event", "METRICS"]

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

    Series: ``t`` (n,), ``x, v, a`` (n, N), ``deformation, force`` (n, K).
    Per vehicle (N,): ``delta_v, v_final, peak_acceleration`` (signed, largest magnitude),
    ``peak_acceleration_g``. Per contact (K,): ``max_deformation, permanent_deformation,
    peak_force, restitution`` (velocity definition, Eq. 9, over the closing speed at t = 0: NaN
    for a contact of a chain that was not closing then), ``restitution_energy`` (energy
    definition, Eq. 10: ``sqrt(returned / absorbed)``), ``energy_absorbed, energy_returned``.
    ``duration``: first contact to last separation [time]. ``failure_time`` (K,): when the
    contact force first exceeded the contact's failure force (NaN if never; ``failed`` says
    which); with a post-failure curve, when the deformation first reached the failure point
    ``D_f`` (where the loading curve reaches the failure force). ``events``: list of :class:`Event`.
    ``method``, ``tolerances`` (rtol, atol or dt) and ``stats`` (steps, rhs evaluations,
    segments, wall time [s]) say how it was computed.
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

    @classmethod
    def build(cls, scene, *, t, x, v, a, deformation, force, events, contacts, v_final,
              method, tolerances, stats) -> "Result":
        """Assemble a result from sampled series and each contact's record.

        ``contacts`` is a list of dicts with ``dmax, fmax, dperm, ec, er`` (max and permanent
        deformation, force at max deformation, absorbed and returned energy) per contact;
        ``v_final`` (N,) the velocities after the last event.
        """
        r = cls(scene=scene, t=np.asarray(t, float), x=np.asarray(x, float),
                v=np.asarray(v, float), a=np.asarray(a, float),
                deformation=np.asarray(deformation, float), force=np.asarray(force, float),
                events=list(events), method=method, tolerances=dict(tolerances),
                stats=dict(stats))
        v0 = scene.speeds
        r.v_final = np.asarray(v_final, float)
        r.delta_v = r.v_final - v0
        idx = np.argmax(np.abs(r.a), axis=0)
        r.peak_acceleration = r.a[idx, np.arange(r.a.shape[1])]
        r.peak_acceleration_g = r.peak_acceleration / scene.g
        r.max_deformation = np.array([c["dmax"] for c in contacts], float)
        r.permanent_deformation = np.array([c["dperm"] for c in contacts], float)
        r.peak_force = np.max(r.force, axis=0) if r.force.size else np.zeros(len(contacts))
        r.energy_absorbed = np.array([c["ec"] for c in contacts], float)
        r.energy_returned = np.array([c["er"] for c in contacts], float)
        K = len(contacts)
        r.contact_time = np.full(K, np.nan)
        r.separation_time = np.full(K, np.nan)
        for ev in r.events:
            if ev.kind == "contact" and np.isnan(r.contact_time[ev.index]):
                r.contact_time[ev.index] = ev.time
            if "separation" in ev.kind:
                r.separation_time[ev.index] = ev.time
        with np.errstate(invalid="ignore", divide="ignore"):
            # Eq. 9, over the closing speed at t = 0; undefined (NaN, not ±inf) for a contact
            # that was not closing then (in a chain, vehicles at rest in front: such a contact
            # is closed by the crash behind it, its closing speed is whatever that makes it,
            # from zero up); the energy definition holds for every contact that closed
            closing = v0[:-1] - v0[1:]
            closing = np.where(closing > 0, closing, np.nan)
            r.restitution = (r.v_final[1:] - r.v_final[:-1]) / closing
            r.restitution_energy = np.sqrt(r.energy_returned / r.energy_absorbed)
        # bumper failure: when the force first exceeded the failure force (NaN: never, or none set)
        r.failure_time = np.full(K, np.nan)
        for k, c in enumerate(scene.contacts):
            if c.failure is None:
                continue
            times = [ev.time for ev in r.events
                     if "failure" in ev.kind.split("+") and ev.index == k]
            if times:
                r.failure_time[k] = times[0]
            elif r.force.size and np.any(r.force[:, k] > c.failure.force):
                r.failure_time[k] = r.t[np.argmax(r.force[:, k] > c.failure.force)]
        touched = np.isfinite(r.contact_time)
        if np.any(touched) and np.all(np.isfinite(r.separation_time[touched])):
            r.duration = float(np.max(r.separation_time[touched]) - np.min(r.contact_time[touched]))
        else:
            r.duration = float("nan")
        return r

    @property
    def failed(self) -> np.ndarray:
        """Per contact (K,): True where the force exceeded the contact's failure force."""
        return np.isfinite(self.failure_time)

    # ------------------------------------------------------------------ units and export
    @property
    def units(self) -> dict[str, str]:
        """The unit of every series and metric (pint spelling; ``""`` for dimensionless)."""
        u = {name: self.scene.unit(kind) for name, kind in _SERIES_KINDS.items()}
        u.update({name: self.scene.unit(kind) for name, (kind, _) in METRICS.items()})
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

    def summary(self) -> str:
        """A plain-text summary table (what ``lsc run`` prints)."""
        u = self.units
        s = self.scene
        lines = [f"{s.name}  —  method {self.method}, {self.scene.units} units"]
        tol = ", ".join(f"{k}={v:g}" for k, v in self.tolerances.items() if v is not None)
        if tol:
            lines[0] += f" ({tol})"
        w = max(12, *(len(v.name) for v in s.vehicles))
        lines.append("")
        lines.append(f"{'vehicle':<{w}} {'v0':>10} {'v_final':>10} {'delta_v':>10} "
                     f"{'peak a':>11} {'peak a':>8}")
        lines.append(f"{'':<{w}} {u['v_final']:>10} {u['v_final']:>10} {u['delta_v']:>10} "
                     f"{u['peak_acceleration']:>11} {'g':>8}")
        for i, veh in enumerate(s.vehicles):
            lines.append(f"{veh.name:<{w}} {veh.speed:>10.4g} {self.v_final[i]:>10.4f} "
                         f"{self.delta_v[i]:>10.4f} {self.peak_acceleration[i]:>11.4g} "
                         f"{self.peak_acceleration_g[i]:>8.3f}")
        lines.append("")
        lines.append(f"{'contact':<{w}} {'D_max':>10} {'D_perm':>10} {'F_peak':>10} "
                     f"{'e (vel)':>8} {'e (energy)':>10}")
        lines.append(f"{'':<{w}} {u['max_deformation']:>10} {u['permanent_deformation']:>10} "
                     f"{u['peak_force']:>10} {'':>8} {'':>10}")
        for k in range(len(s.contacts)):
            lines.append(f"{f'{k} ({s.vehicles[k].name}-{s.vehicles[k + 1].name})':<{w}} "
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
        lines.append("")
        lines.append(f"pulse duration {self.duration:.6g} {u['duration']}; "
                     f"{len(self.events)} events; "
                     + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                 for k, v in self.stats.items()))
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (f"<Result {self.scene.name!r} method={self.method} duration={self.duration:.6g} "
                f"delta_v={np.array2string(self.delta_v, precision=6)}>")
