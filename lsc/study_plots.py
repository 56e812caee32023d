"""Figures of studies (matplotlib, imported on first use): one metric of a sweep against the
swept parameter (:func:`sweep_metric`), a tornado chart of local sensitivities (:func:`tornado`),
Sobol' indices (:func:`sobol_indices`), and the axis labels they share. Re-exported by
:mod:`lsc.plots`."""

from __future__ import annotations

import numpy as np


__all__ = ["sweep_metric", "tornado", "sobol_indices", "param_label", "metric_label",
           "METRIC_NAMES"]


def _legend_below(ax, **kwargs):
    """The axes' legend under the axes and their x label, off the data; constrained layout
    makes room for it. Returns the legend."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.transforms import ScaledTranslation
    import matplotlib as mpl

    def points(size):
        return FontProperties(size=size).get_size_in_points()

    rc = mpl.rcParams
    drop = (rc["xtick.major.size"] + rc["xtick.major.pad"] + points(rc["xtick.labelsize"])
            + ax.xaxis.labelpad + points(rc["axes.labelsize"]) + 6)  # [pt]
    n = len(ax.get_legend_handles_labels()[1])
    where = ax.transAxes + ScaledTranslation(0, -drop / 72, ax.figure.dpi_scale_trans)
    return ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.0), bbox_transform=where,
                     ncols=min(n, 4) or 1, fontsize="small", **kwargs)


#: Readable names of the metrics (axis labels).
METRIC_NAMES = {
    "delta_v": "ΔV", "v_final": "final speed", "peak_acceleration": "peak acceleration",
    "peak_acceleration_g": "peak acceleration", "duration": "pulse duration",
    "max_deformation": "maximum deformation", "permanent_deformation": "permanent deformation",
    "peak_force": "peak force", "restitution": "restitution (velocity)",
    "restitution_energy": "restitution (energy)", "energy_absorbed": "energy absorbed",
    "energy_returned": "energy returned", "failure_time": "time of bumper failure",
}

# Readable names of the numeric fields of a scene path, after the vehicle or contact index.
_FIELD_NAMES = {
    ("speed",): "initial speed", ("mass",): "mass", ("weight",): "weight", ("gap",): "gap",
    ("loading", "stiffness"): "loading stiffness", ("loading", "scale"): "loading force scale",
    ("unloading", "stiffness"): "unloading stiffness",
    ("unloading", "restitution"): "restitution", ("failure", "force"): "failure force",
    ("brake", "mu"): "braking friction coefficient",
    ("brake", "mu_static"): "static friction coefficient",
}


def _contact_name(scene, k: int) -> str:
    names = [v.name for v in scene.vehicles]
    return f"contact {k} ({names[k]}–{names[k + 1]})" if 0 <= k < len(scene.contacts) \
        else f"contact {k}"


def _with_unit(text: str, unit: str) -> str:
    return f"{text} [{unit}]" if unit else text


def param_label(scene, path: str) -> str:
    """An axis label for a swept scene path, with its unit: ``"vehicles.0.speed"`` → ``"initial
    speed of bullet [ft/s]"``; a path it has no name for is shown as given."""
    from .analysis._common import path_kind, split_path
    parts = split_path(path)
    kind = path_kind(path)
    unit = scene.unit(kind) if kind and kind != "dimensionless" else ""
    if parts == ["g"]:
        return _with_unit("gravitational acceleration g", unit)
    if len(parts) >= 3 and parts[1].isdigit() and parts[0] in ("vehicles", "contacts"):
        i, rest = int(parts[1]), tuple(parts[2:])
        field = _FIELD_NAMES.get(rest, " ".join(rest).replace("_", " "))
        if parts[0] == "vehicles":
            owner = scene.vehicles[i].name if i < len(scene.vehicles) else f"vehicle {i}"
        else:
            owner = _contact_name(scene, i)
        return _with_unit(f"{field} of {owner}", unit)
    return _with_unit(path, unit)


def metric_label(scene, metric: str, index=None) -> str:
    """An axis label for a metric with its unit (``"ΔV of target [ft/s]"``, ``"peak acceleration
    of bullet [g]"``); ``index``: the vehicle or contact of a per-vehicle / per-contact one."""
    from .result import METRICS
    kind, per = METRICS[metric]
    text = METRIC_NAMES.get(metric, metric.replace("_", " "))
    if per == "vehicle":
        text += f" of {scene.vehicles[index].name}"
    elif per == "contact":
        text += f" of {_contact_name(scene, index)}"
    unit = "g" if metric == "peak_acceleration_g" else scene.unit(kind)
    return _with_unit(text, unit)


def _short(label: str) -> str:
    """A label without its unit (for legend entries that give the value and unit)."""
    return label.rsplit(" [", 1)[0]


def sweep_metric(sweep, metric: str = "delta_v", index=None, file=None, ax=None, *,
                 overwrite: bool = False):
    """One metric of a :class:`~lsc.sweep.SweepResult` against the first swept parameter (one
    line per value of the others, for a grid); the axes are labelled with readable names and
    units (:func:`param_label`, :func:`metric_label`). ``index`` picks the vehicle or contact of a
    per-vehicle/contact metric (default: the last vehicle, the first contact). With ``file``
    the figure is saved there and the path returned; otherwise the figure is returned."""
    from matplotlib.figure import Figure
    from .result import METRICS
    kind, per = METRICS[metric]
    values = np.asarray(sweep.metrics[metric], float)
    i = None
    if per != "scene":
        i = index if index is not None else (values.shape[1] - 1 if per == "vehicle" else 0)
        values = values[:, i]
    paths = list(sweep.params)
    x = np.asarray(sweep.params[paths[0]], float)
    if ax is None:
        fig = Figure(figsize=(7.0, 4.5), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    if len(sweep.shape) == 2:
        rows = x.reshape(sweep.shape)[:, 0]
        for j in range(sweep.shape[1]):
            other = ", ".join(f"{_short(param_label(sweep.scene, p))} = "
                              f"{sweep.params[p].reshape(sweep.shape)[0, j]:g} "
                              f"{_unit_of(param_label(sweep.scene, p))}".rstrip()
                              for p in paths[1:])
            ax.plot(rows, values.reshape(sweep.shape)[:, j], "o-", ms=3, label=other)
    else:
        order = np.argsort(x)
        ax.plot(x[order], values[order], "o-", ms=3)
    ax.set_xlabel(param_label(sweep.scene, paths[0]))
    ax.set_ylabel(metric_label(sweep.scene, metric, i))
    ax.set_title(f"{sweep.scene.name} ({sweep.method})")
    ax.grid(True, alpha=0.3)
    if len(sweep.shape) == 2:
        _legend_below(ax)
    if file is None:
        return fig
    from .outputs import write_file
    return write_file(file, lambda f: fig.savefig(f, dpi=150), overwrite=overwrite)


def _unit_of(label: str) -> str:
    return label.rsplit(" [", 1)[1][:-1] if label.endswith("]") and " [" in label else ""


def tornado(sens, metric: str = "delta_v", index=None, *, swing=None, ax=None, file=None,
            overwrite: bool = False):
    """A tornado chart of one metric of a :class:`~lsc.analysis.sensitivity.Sensitivity`: one
    horizontal bar per parameter, the largest effect on top.

    ``swing=None``: each bar is the elasticity ``(∂M/∂p) p / M`` (percent change of the metric
    per percent change of the parameter; red where raising the parameter raises the metric).
    ``swing=r`` (a number, e.g. ``0.1``): each bar spans the metric's first-order values with
    the parameter moved by ``± r`` of its value (``M ± |∂M/∂p| r p``), around ``M``; ``swing``
    a dict of parameter path → ``Δ`` (scene units, or a string with units): moved by ``± Δ``
    (parameters left out are not drawn). ``index``: the vehicle (index or name) or contact of a
    per-vehicle / per-contact metric (default: the front vehicle, contact 0). Draws on ``ax``
    or a new figure; returns the figure (with ``file``: saves it there and returns the path).
    """
    from matplotlib.figure import Figure
    from .analysis._common import path_quantity

    idx = sens._index(metric, index)
    d = np.asarray(sens.derivatives[metric])[idx]
    M = sens.value(metric, index)
    unit = sens.units[metric]
    labels = list(sens.labels)
    if swing is None:
        score = np.asarray(sens.elasticities[metric])[idx]
        keep = [j for j in range(len(labels)) if np.isfinite(score[j])]
    else:
        if isinstance(swing, dict):
            deltas = np.full(len(labels), np.nan)
            for path, dv in swing.items():
                j = sens._param(path)
                deltas[j] = abs(path_quantity(dv, sens.scene, sens.params[j]))
        else:
            r = float(swing)
            if not (np.isfinite(r) and r > 0):
                raise ValueError(f"swing must be a positive fraction or a dict, got {swing!r}")
            deltas = r * np.asarray(sens.reference, float)
        score = d * deltas
        keep = [j for j in range(len(labels)) if np.isfinite(score[j])]
    keep.sort(key=lambda j: abs(score[j]))  # smallest first: it is drawn at the bottom
    if ax is None:
        fig = Figure(figsize=(7.0, 0.8 + 0.42 * max(len(keep), 1)), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    y = np.arange(len(keep))
    what = sens.label(metric, index)
    if swing is None:
        vals = np.array([score[j] for j in keep])
        ax.barh(y, vals, color=["C3" if v > 0 else "C0" for v in vals], height=0.6)
        ax.axvline(0.0, color="0.3", lw=0.8)
        big = np.max(np.abs(vals)) if vals.size else 0.0
        for yy, v in zip(y, vals):
            ax.annotate("0" if abs(v) <= 1e-9 * big else f"{v:+.3g}", (v, yy), xytext=(4 if v >= 0 else -4, 0),
                        textcoords="offset points", ha="left" if v >= 0 else "right",
                        va="center", fontsize=8)
        ax.set_xlabel("elasticity (% change per % change of the parameter)")
        lim = max(np.max(np.abs(vals)) if vals.size else 1.0, 1e-12) * 1.3
        ax.set_xlim(-lim, lim)
    else:
        for yy, j in zip(y, keep):
            s = score[j]  # the change when the parameter rises by its swing
            ax.barh(yy, s, left=M, color="C3", height=0.6,
                    label="parameter raised" if yy == y[-1] else None)
            ax.barh(yy, -s, left=M, color="C0", height=0.6,
                    label="parameter lowered" if yy == y[-1] else None)
        ax.axvline(M, color="0.3", lw=0.8)
        ax.set_xlabel(f"{what}" + (f" [{unit}]" if unit else "")
                      + (f", parameters ±{100 * float(swing):g} %" if not isinstance(swing, dict)
                         else ", parameters moved by their swing"))
        if keep:
            _legend_below(ax)
    if swing is None:  # a zero parameter is normalised by its reference value: say which
        for j in range(len(labels)):
            if sens.values[j] == 0:
                labels[j] += f"\n(% of {sens.reference[j]:g} {sens.param_units[j]})".replace(" )", ")")
    ax.set_yticks(y)
    ax.set_yticklabels([labels[j] for j in keep])
    ax.set_title(f"{sens.scene.name}\n{what} = {M:.4g} {unit}".rstrip(), fontsize=10)
    ax.grid(True, axis="x", alpha=0.3)
    if file is None:
        return fig
    from .outputs import write_file
    return write_file(file, lambda f: fig.savefig(f, dpi=150), overwrite=overwrite)


def sobol_indices(gsa, metric=None, *, ax=None, file=None, overwrite: bool = False):
    """Bars of the first-order (S1) and total (ST) Sobol' indices of each input, with their
    confidence intervals as error bars, from a
    :class:`~lsc.analysis.global_sensitivity.GlobalSensitivity`: one panel per metric column
    (``metric``: only that one, e.g. ``"delta_v[target]"``). Draws on ``ax`` (one metric) or a
    new figure; returns the figure (with ``file``: saves it there and returns the path)."""
    from matplotlib.figure import Figure
    metrics = list(gsa.metrics) if metric is None else [metric]
    for m in metrics:
        if m not in gsa.metrics:
            raise ValueError(f"metric {m!r} is not among {', '.join(gsa.metrics)}")
    if ax is None:
        fig = Figure(figsize=(7.0, 0.6 + (1.0 + 0.5 * len(gsa.inputs)) * len(metrics)),
                     layout="constrained")
        axes = fig.subplots(len(metrics), 1, squeeze=False)[:, 0]
    else:
        if len(metrics) != 1:
            raise ValueError("give one metric to draw on ax")
        fig, axes = ax.figure, [ax]
    labels = [param_label(gsa.scene, p) for p in gsa.inputs]
    y = np.arange(len(labels))[::-1]  # the table's first input on top
    for a, m in zip(axes, metrics):
        rows = gsa.table[gsa.table["metric"] == m]
        for shift, key, color in ((0.18, "S1", "C0"), (-0.18, "ST", "C3")):
            a.barh(y + shift, rows[key], xerr=rows[f"{key}_conf"], height=0.34, color=color,
                   capsize=3, label={"S1": "first order S1", "ST": "total ST"}[key])
        a.set_yticks(y)
        a.set_yticklabels(labels)
        a.axvline(0.0, color="0.3", lw=0.8)
        a.set_title(f"{m}: Sobol' indices (± {100 * gsa.conf_level:g} % interval)", fontsize=10)
        a.grid(True, axis="x", alpha=0.3)
    axes[-1].set_xlabel("share of the metric's variance")
    _legend_below(axes[-1])
    fig.suptitle(f"{gsa.scene.name}: {gsa.n} base samples, {gsa.sweep.status.size} solves",
                 fontsize=10)
    if file is None:
        return fig
    from .outputs import write_file
    return write_file(file, lambda f: fig.savefig(f, dpi=150), overwrite=overwrite)
