"""Compact HTML summaries of results, for Jupyter (``_repr_html_``).

:func:`result_html` shows one crash: every metric of :data:`lsc.result.METRICS` per vehicle and
per contact, the scene's own, the method and tolerances, and any accuracy warning.
:func:`sweep_html` shows a sweep: the swept paths' ranges, each metric's range over the solved
members, and the failures. :func:`summary_html` shows any result with a plain-text
``summary()`` (the analyses' :class:`~lsc.analysis.Bound`, :class:`~lsc.analysis.MonteCarlo`,
:class:`~lsc.analysis.Sensitivity`, :class:`~lsc.analysis.Calibration`) as that text. Numbers are given to 6 significant digits with their units; every
name from the scene is escaped. No pandas, no scripts, no external URL.
"""

from __future__ import annotations

from html import escape

import numpy as np

from .frames import _path_unit, contact_labels, vehicle_labels
from .result import METRICS

__all__ = ["result_html", "sweep_html", "summary_html"]

#: At most this many failure messages of a sweep are listed (their count is always given).
MAX_FAILURES_SHOWN = 5

_STYLE = ("<style>.lsc-html table{border-collapse:collapse;margin:0.3em 0}"
          ".lsc-html th,.lsc-html td{padding:0.1em 0.6em;text-align:right}"
          ".lsc-html th:first-child,.lsc-html td:first-child{text-align:left}"
          ".lsc-html caption{text-align:left;font-weight:bold}</style>")


def _num(x) -> str:
    """A number to 6 significant digits (``nan`` kept as such: undefined or never reached)."""
    return format(float(x), ".6g")


def _head(name: str, unit: str) -> str:
    return escape(name) + (f"<br><small>{escape(unit)}</small>" if unit else "")


def _table(caption: str, header: list[str], rows: list[list[str]]) -> str:
    """An HTML table; ``header`` and ``rows`` cells are HTML already (escape before)."""
    head = "".join(f"<th>{h}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return (f"<table><caption>{escape(caption)}</caption><thead><tr>{head}</tr></thead>"
            f"<tbody>{body}</tbody></table>")


def _wrap(parts: list[str]) -> str:
    return _STYLE + '<div class="lsc-html">' + "".join(parts) + "</div>"


def _names(per: str) -> list[str]:
    return [name for name, (_, p) in METRICS.items() if p == per]


def _settings(method: str, tolerances: dict) -> str:
    tol = ", ".join(f"{escape(str(k))} = {_num(v)}" for k, v in tolerances.items()
                    if v is not None)
    return f"method {escape(method)}" + (f" ({tol})" if tol else "")


# --------------------------------------------------------------------------- one result
def result_html(result) -> str:
    """The summary of one :class:`lsc.Result` as an HTML fragment (tables of every metric)."""
    s, u = result.scene, result.units
    v_unit = s.unit("velocity")
    parts = [f"<p><b>{escape(s.name)}</b> — {_settings(result.method, result.tolerances)}, "
             f"{escape(s.units)} units</p>"]
    names = _names("vehicle")
    rows = [[escape(label), _num(veh.speed)] + [_num(getattr(result, n)[i]) for n in names]
            for i, (label, veh) in enumerate(zip(vehicle_labels(s), s.vehicles))]
    parts.append(_table("vehicles", ["vehicle", _head("v0", v_unit)]
                        + [_head(n, u[n]) for n in names], rows))
    names = _names("contact")
    rows = [[escape(label)] + [_num(getattr(result, n)[k]) for n in names]
            for k, label in enumerate(contact_labels(s))]
    parts.append(_table("contacts", ["contact"] + [_head(n, u[n]) for n in names], rows))
    scene_metrics = [f"{escape(n)} {_num(getattr(result, n))} {escape(u[n])}".rstrip()
                     for n in _names("scene")]
    parts.append(f"<p>{'; '.join(scene_metrics)}; {len(result.events)} events</p>")
    warnings = getattr(result, "warnings", None) or result.stats.get("warnings", ())
    if warnings:
        items = "".join(f"<li>{escape(str(w))}</li>" for w in warnings)
        parts.append(f"<p><b>warnings</b></p><ul>{items}</ul>")
    return _wrap(parts)


# --------------------------------------------------------------------------- sweeps
def _range_row(label: str, values: np.ndarray) -> list[str]:
    """``[label, min, max]`` of the finite values (``"—"`` where there are none)."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return [escape(label), "—", "—"]
    return [escape(label), _num(finite.min()), _num(finite.max())]


def sweep_html(sweep_result) -> str:
    """The summary of a :class:`lsc.SweepResult` as an HTML fragment: members, the swept
    paths' ranges, each metric's range over the solved members, the failures and the members
    with warnings."""
    sw = sweep_result
    s, n = sw.scene, len(sw.status)
    ok = np.asarray(sw.ok)
    grid = " × ".join(str(d) for d in sw.shape)
    parts = [f"<p><b>{escape(s.name)}</b> — sweep of {n} members (shape {grid}), "
             f"method {escape(sw.method)}, {escape(s.units)} units; {int(ok.sum())} solved, "
             f"{n - int(ok.sum())} failed</p>"]
    rows = []
    for path, values in sw.params.items():
        values = np.asarray(values, float)
        rows.append(_range_row(path, values) + [str(np.unique(values).size),
                                                escape(_path_unit(s, path) or "")])
    parts.append(_table("swept", ["path", "min", "max", "values", "unit"], rows))
    labels = {"vehicle": vehicle_labels(s), "contact": [str(k) for k in range(len(s.contacts))]}
    rows = []
    for name, (_, per) in METRICS.items():
        arr = np.asarray(sw.metrics[name], float)[ok]
        items = [(name, arr)] if per == "scene" else [
            (f"{name}[{label}]", arr[:, j]) for j, label in enumerate(labels[per])]
        rows += [_range_row(label, col) + [escape(sw.units[name])] for label, col in items]
    parts.append(_table("metrics over the solved members", ["metric", "min", "max", "unit"],
                        rows))
    failed = [(j, msg) for j, msg in enumerate(sw.status) if msg != "ok"]
    warned = [(j, "; ".join(w)) for j, w in enumerate(sw.warnings) if w]
    for what, column, listed in (("failed members", "status", failed),
                                 ("members with warnings", "warnings", warned)):
        if listed:
            items = "".join(f"<li>member {j}: {escape(str(msg))}</li>"
                            for j, msg in listed[:MAX_FAILURES_SHOWN])
            more = len(listed) - MAX_FAILURES_SHOWN
            tail = f"<p>… and {more} more (see {column})</p>" if more > 0 else ""
            parts.append(f"<p><b>{what}</b></p><ul>{items}</ul>{tail}")
    return _wrap(parts)


# --------------------------------------------------------------------------- analyses
def summary_html(obj) -> str:
    """Any result with a plain-text ``summary()`` (the analyses' results) as an HTML fragment:
    that table, escaped, in a ``<pre>`` block, so that its columns stay aligned."""
    return _wrap([f"<pre>{escape(obj.summary())}</pre>"])
