"""A simulation set beside measured channels: time-aligned pulses, metric differences, ISO/TS 18571.

:func:`compare` matches the channels to the result's vehicles (``accel_<name>``,
``velocity_<name>`` or an explicit mapping, see :meth:`~lsc.analysis.channels.Channels.match`)
and, for each vehicle with a channel, puts measured and simulated acceleration and velocity
change (ΔV since time zero: the measured one integrated from the acceleration unless a velocity
channel is given) on the measured time base over the compared interval: from time zero (first
contact in the test; the simulation's first ``contact`` event, or its start, in the result) to the
end of the measured record, or ``window``. After the simulated crash has ended
the vehicles of a scene without braking move uniformly (acceleration 0, velocity constant), so the
simulation is continued so; with braking its motion after the result's last time is not known,
and the interval ends there (``Comparison.notes`` says so). It reports, per vehicle, the peak
acceleration, the ΔV at the end of the interval and the pulse duration (first to last sample with
``|a|`` at least ``pulse_threshold`` times its peak, the same rule for both), measured, simulated
and their difference (simulated - measured), and the ISO/TS 18571 rating of each compared channel
(the simulation rated against the test, both resampled to 10 kHz). Values are in the scene's
unit system.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import SceneError
from ..outputs import write_file
from .iso18571 import ISO18571Rating, iso18571, resample

__all__ = ["Comparison", "VehicleComparison", "compare", "METRICS"]

#: Compared metrics: name → unit kind.
METRICS = {"peak_acceleration": "acceleration", "delta_v": "velocity", "pulse_duration": "time"}


@dataclass(frozen=True)
class VehicleComparison:
    """One vehicle's measured and simulated acceleration and ΔV on the time base ``t`` [s]
    (scene units), and ``metrics``: ``{name: (measured, simulated, simulated - measured)}``."""

    name: str
    t: np.ndarray
    measured_acceleration: np.ndarray
    simulated_acceleration: np.ndarray
    measured_delta_v: np.ndarray
    simulated_delta_v: np.ndarray
    metrics: dict


@dataclass(frozen=True)
class Comparison:
    """The comparison of one result with its test: per-vehicle pulses and metrics, and
    ``iso18571``: ``{channel role: ISO18571Rating}`` (e.g. ``"accel_target"``)."""

    vehicles: tuple
    iso18571: dict
    units: dict
    unit_system: str
    notes: tuple = ()

    def rows(self) -> list[dict]:
        """One row per vehicle and metric: vehicle, metric, unit, measured, simulated, difference."""
        return [{"vehicle": v.name, "metric": m, "unit": self.units[m], "measured": meas,
                 "simulated": sim, "difference": diff}
                for v in self.vehicles for m, (meas, sim, diff) in v.metrics.items()]

    def summary(self) -> str:
        """A plain-text table (what ``lsc compare`` prints): each vehicle's metrics, measured,
        simulated and their difference, then the ISO/TS 18571 scores of each rated channel."""
        rows = self.rows()
        w = max([7, *(len(r["vehicle"]) for r in rows), *(len(ch) for ch in self.iso18571)])
        lines = [f"{'vehicle':<{w}} {'metric':<17} {'unit':>7} {'measured':>11} "
                 f"{'simulated':>11} {'difference':>11}"]
        lines += [f"{r['vehicle']:<{w}} {r['metric']:<17} {r['unit']:>7} {r['measured']:>11.5g} "
                  f"{r['simulated']:>11.5g} {r['difference']:>11.4g}" for r in rows]
        if self.iso18571:
            lines += ["", f"{'ISO/TS 18571':<{w}} {'corridor':>9} {'phase':>9} {'magnitude':>9} "
                          f"{'slope':>9} {'total':>9}"]
            lines += [f"{ch:<{w}} {r.corridor:>9.4f} {r.phase:>9.4f} {r.magnitude:>9.4f} "
                      f"{r.slope:>9.4f} {r.total:>9.4f}" for ch, r in self.iso18571.items()]
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def to_frame(self):
        """The metric table (:meth:`rows`) as a pandas DataFrame."""
        import pandas as pd

        return pd.DataFrame(self.rows())

    def to_dict(self) -> dict:
        """A JSON-ready dict: unit system, units, metric rows and ISO/TS 18571 ratings."""
        return {"unit_system": self.unit_system, "units": dict(self.units), "metrics": self.rows(),
                "iso18571": {k: r.as_dict() for k, r in self.iso18571.items()}}

    def to_json(self, path, *, overwrite: bool = False) -> Path:
        """:meth:`to_dict` as a JSON file (an existing one refused unless ``overwrite``)."""
        text = json.dumps(self.to_dict(), indent=2) + "\n"
        return write_file(path, lambda f: Path(f).write_text(text, encoding="utf-8"),
                          overwrite=overwrite)

    def to_csv(self, path, *, overwrite: bool = False) -> Path:
        """The metric table, then one row per rated channel (metric ``iso18571_<score>``); an
        existing file is refused unless ``overwrite``."""
        rows = self.rows() + [{"vehicle": ch, "metric": f"iso18571_{k}", "unit": "s" if k == "shift" else "",
                               "measured": "", "simulated": v, "difference": ""}
                              for ch, r in self.iso18571.items() for k, v in r.as_dict().items()]
        cols = ("vehicle", "metric", "unit", "measured", "simulated", "difference")
        lines = [",".join(cols)] + [",".join(_cell(r[c]) for c in cols) for r in rows]
        text = "\n".join(lines) + "\n"
        return write_file(path, lambda f: Path(f).write_text(text, encoding="utf-8"),
                          overwrite=overwrite)
        return path

    def figure(self):
        """Measured and simulated acceleration (top) and ΔV (bottom), one column per vehicle
        (the paper's Figs. 6-7); matplotlib is imported here."""
        import matplotlib.pyplot as plt

        n = len(self.vehicles)
        fig, axes = plt.subplots(2, n, figsize=(5 * n, 6), sharex=True, squeeze=False)
        for j, v in enumerate(self.vehicles):
            for row, (meas, sim, what, unit) in enumerate((
                    (v.measured_acceleration, v.simulated_acceleration, "acceleration", self.units["acceleration"]),
                    (v.measured_delta_v, v.simulated_delta_v, "ΔV", self.units["delta_v"]))):
                ax = axes[row, j]
                ax.plot(v.t * 1e3, meas, label="measured", color="0.3")
                ax.plot(v.t * 1e3, sim, "--", label="simulated", color="C0")
                ax.set_ylabel(f"{what} [{unit}]")
                ax.grid(alpha=0.3)
            rating = self.iso18571.get(f"accel_{v.name}")
            title = v.name + (f" — ISO/TS 18571 {rating.total:.3f}" if rating else "")
            axes[0, j].set_title(title)
            axes[1, j].set_xlabel("time [ms]")
        axes[0, 0].legend()
        fig.tight_layout()
        return fig


def _cell(x) -> str:
    return f"{x:.10g}" if isinstance(x, float) else str(x)


def compare(result, channels, *, mapping: dict | None = None, window=None,
            pulse_threshold: float = 0.05) -> Comparison:
    """Compare a :class:`~lsc.Result` with measured :class:`~lsc.analysis.channels.Channels`.

    ``mapping``: ``{role: channel name}`` (roles ``accel_<vehicle>``, ``velocity_<vehicle>``);
    ``window``: ``(t_start, t_end)`` [s] inside the record (default: time zero to the end of the
    record; for a scene with braking, to the end of the simulation if that comes first);
    ``pulse_threshold``: fraction of the peak acceleration that bounds the pulse, in (0, 1).
    Raises :class:`~lsc.SceneError` when no channel matches a vehicle or the window is outside
    the records.
    """
    if not 0 < pulse_threshold < 1:
        raise SceneError("pulse_threshold", f"a fraction of the peak in (0, 1), got {pulse_threshold!r}")
    roles = channels.match(result.scene, mapping)
    uniform_after = all(v.brake is None for v in result.scene.vehicles)
    t_sim = result.t - _first_contact(result)
    t0, t1 = _window(t_sim, channels, window, uniform_after)
    inside = (channels.t >= t0 - 1e-9) & (channels.t <= t1 + 1e-9)
    vehicles, ratings = [], {}
    for i, vehicle in enumerate(result.scene.vehicles):
        acc, vel = roles.get(f"accel_{vehicle.name}"), roles.get(f"velocity_{vehicle.name}")
        if acc is None and vel is None:
            continue
        simulated = (t_sim, result.v[:, i], result.a[:, i])
        vc = _compare_vehicle(vehicle.name, channels.t[inside], inside, simulated, acc, vel,
                              result.scene.units, pulse_threshold)
        vehicles.append(vc)
        if acc is not None:
            ratings[f"accel_{vehicle.name}"] = _rate(vc.t, vc.measured_acceleration, vc.simulated_acceleration)
        if vel is not None:
            ratings[f"velocity_{vehicle.name}"] = _rate(vc.t, vc.measured_delta_v, vc.simulated_delta_v)
    if not vehicles:
        wanted = ", ".join(f"accel_{v.name}" for v in result.scene.vehicles)
        raise SceneError(channels.source, f"no channel matches a vehicle of the scene: name them {wanted} "
                                          f"(or velocity_<vehicle>) or pass mapping={{role: channel}}; "
                                          f"the channels are: {', '.join(channels.names)}")
    cut_short = window is None and not uniform_after and t1 < float(channels.t[-1]) - 1e-9
    notes = () if not cut_short else (
        f"the scene has braking: the simulation's motion after its last time {float(t_sim[-1]):.6g} s is "
        "not known, so the comparison ends there, before the end of the measured record",)
    units = {"acceleration": result.units["a"], "delta_v": result.units["v"], "peak_acceleration": result.units["a"],
             "pulse_duration": "s"}
    return Comparison(tuple(vehicles), ratings, units, result.scene.units, notes)


def _compare_vehicle(name, t, inside, simulated, acc, vel, system, threshold) -> VehicleComparison:
    """One vehicle's measured and simulated pulses on ``t`` (the record's samples ``inside`` the
    interval); ``simulated`` = (time from first contact, velocity, acceleration)."""
    t_sim, v, a = simulated
    v_sim = np.interp(t, t_sim, v)                    # constant after the end
    sim_a = np.interp(t, t_sim, a, right=0.0)         # uniform motion after the end
    sim_dv = v_sim - v_sim[0]
    if vel is None:
        meas_a = acc.to(system)[inside]
        meas_dv = _delta_v(t, meas_a)
    else:
        meas_v = vel.to(system)[inside]
        meas_dv = meas_v - meas_v[0]
        meas_a = acc.to(system)[inside] if acc is not None else np.gradient(meas_v, t)
    metrics = _metrics(t, meas_a, sim_a, meas_dv, sim_dv, threshold)
    return VehicleComparison(name, t, meas_a, sim_a, meas_dv, sim_dv, metrics)


def _first_contact(result) -> float:
    """Time [s] of the result's first contact: its first ``contact`` event, else its start."""
    return min((float(e.time) for e in result.events if e.kind == "contact"), default=float(result.t[0]))


def _window(t_sim, channels, window, uniform_after: bool) -> tuple[float, float]:
    lo = max(0.0, float(channels.t[0]))
    hi = float(channels.t[-1]) if uniform_after else min(float(t_sim[-1]), float(channels.t[-1]))
    if window is None:
        t0, t1 = lo, hi
    else:
        t0, t1 = (float(w) for w in window)
        if not (lo - 1e-12 <= t0 < t1 <= hi + 1e-12):
            raise SceneError("window", f"the window ({t0:g}, {t1:g}) s must lie inside both records, "
                                       f"which overlap over ({lo:g}, {hi:g}) s")
    if not t1 - t0 >= 10 * channels.dt:
        raise SceneError("window", f"the records overlap over ({t0:g}, {t1:g}) s only: fewer than 10 samples")
    return t0, t1


def _delta_v(t: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Velocity change since ``t[0]``: the trapezoidal integral of ``a``."""
    return np.concatenate(([0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(t))))


def _peak(a: np.ndarray) -> float:
    return float(a[np.argmax(np.abs(a))])


def _pulse_duration(t: np.ndarray, a: np.ndarray, threshold: float) -> float:
    above = np.nonzero(np.abs(a) >= threshold * np.max(np.abs(a)))[0]
    return float(t[above[-1]] - t[above[0]]) if above.size and np.any(a) else 0.0


def _metrics(t, meas_a, sim_a, meas_dv, sim_dv, threshold) -> dict:
    pairs = {"peak_acceleration": (_peak(meas_a), _peak(sim_a)),
             "delta_v": (float(meas_dv[-1]), float(sim_dv[-1])),
             "pulse_duration": (_pulse_duration(t, meas_a, threshold), _pulse_duration(t, sim_a, threshold))}
    return {k: (m, s, s - m) for k, (m, s) in pairs.items()}


def _rate(t, measured, simulated) -> ISO18571Rating:
    grid, ref = resample(t, measured, t[0], t[-1])
    _, cand = resample(t, simulated, t[0], t[-1])
    return iso18571(ref, cand, grid)
