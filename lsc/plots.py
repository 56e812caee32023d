"""Figures of one simulated crash (matplotlib, imported on first use).

- :func:`acceleration`: acceleration against time per vehicle, in g with the scene's unit on the
  right-hand axis (the paper's Fig. 6);
- :func:`velocity`: velocity against time per vehicle (Fig. 7);
- :func:`ifd_loop`: force against deformation per contact, loading and unloading branches
  (the IF-D loop, Fig. 3);
- :func:`save_all`: the three as ``acceleration.png``, ``velocity.png`` and ``ifd.png`` (all or
  none, never over an earlier run's unless ``overwrite=True``);
- :func:`tornado`: a tornado chart of the sensitivities of one metric
  (:func:`lsc.analysis.sensitivity`);
- :func:`sweep_metric`: one metric of a sweep against the swept parameter;
- :func:`sobol_indices`: Sobol' indices of a global sensitivity study
  (:func:`lsc.analysis.global_sensitivity`); these three from :mod:`lsc.study_plots`.

Each function draws on ``ax`` if given, else on a new figure, and returns the figure. Events
(contact, max deformation, separation, ...) are marked. Units come from ``result.units``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

# the figures of studies (and the legend helper they share) live in lsc.study_plots
from .study_plots import (METRIC_NAMES, _legend_below, metric_label, param_label,  # noqa: F401
                          sobol_indices, sweep_metric, tornado)

__all__ = ["acceleration", "velocity", "ifd_loop", "save_all", "sweep_metric", "tornado",
           "sobol_indices", "FILES", "param_label", "metric_label"]

#: The files :func:`save_all` writes.
FILES = ("acceleration.png", "velocity.png", "ifd.png")

# How events are drawn: kind → (label, line style, marker, colour); no two kinds alike (the
# line style and colour together tell them apart in the legend). Kinds not listed get one of
# _SPARE_STYLES, each a style no listed kind has (:func:`_event_styles`).
_EVENT_STYLE = {
    "contact": ("contact", (0, (1, 2)), "^", "0.35"),
    "max_deformation": ("max deformation", "--", "o", "0.35"),
    "max_deformation+separation": ("max deformation, separation", (0, (6, 2, 1, 2, 1, 2)), "o",
                                   "0.2"),
    "separation": ("separation", "-.", "s", "0.35"),
    "reload_past_max": ("reload past max", ":", "D", "0.35"),
    "breakpoint": ("table breakpoint", (0, (1, 4)), ".", "0.7"),
    "failure": ("bumper failure", (0, (3, 1, 1, 1)), "x", "tab:red"),
}
_SPARE_STYLES = [((0, (5, 1)), "tab:purple"), ((0, (2, 2)), "tab:brown"),
                 ((0, (8, 3, 2, 3)), "tab:olive"), ((0, (1, 1)), "tab:cyan"),
                 ((0, (4, 2, 1, 2)), "tab:pink"), ((0, (10, 4)), "tab:gray")]
_MAX_EVENT_LINES = 40  # beyond this many, table breakpoints are not drawn on the time plots


def _pyplot():
    """pyplot, on the Agg backend where no display is available and none was chosen."""
    import matplotlib
    if "matplotlib.pyplot" not in sys.modules and not os.environ.get("MPLBACKEND") \
            and sys.platform.startswith("linux") \
            and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _axes(ax, figsize=(7.0, 4.5)):
    if ax is not None:
        return ax.figure, ax
    fig, ax = _pyplot().subplots(figsize=figsize, layout="constrained")
    return fig, ax


def _unit(result, key: str) -> str:
    u = result.units.get(key, "")
    return f" [{u}]" if u else ""


def _title(result) -> str:
    return f"{result.scene.name} ({result.method})"


def _style(kind: str):
    """``(label, line style, marker, colour)`` of a listed event kind (a default for others)."""
    return _EVENT_STYLE.get(kind, (kind.replace("_", " ").replace("+", ", "), ":", "x", "0.35"))


def _event_styles(kinds) -> dict:
    """kind → ``(label, line style, marker, colour)`` for the event kinds of one figure, no two
    alike: listed kinds keep theirs, the others take the spare styles in order of name (cycled
    with markers beyond them)."""
    out = {k: _EVENT_STYLE[k] for k in kinds if k in _EVENT_STYLE}
    others = sorted(set(kinds) - set(out))
    markers = "v<>phH*"
    for j, kind in enumerate(others):
        ls, color = _SPARE_STYLES[j % len(_SPARE_STYLES)]
        out[kind] = (_style(kind)[0], ls, markers[j // len(_SPARE_STYLES) % len(markers)],
                     color if j < len(_SPARE_STYLES) else f"C{j % 10}")
    return out


def _mark_events(ax, result):
    """Vertical lines at the event times, one legend entry per kind, each kind its own style."""
    events = list(result.events)
    if len(events) > _MAX_EVENT_LINES:
        events = [e for e in events if e.kind != "breakpoint"]
    styles = _event_styles({e.kind for e in events})
    seen = set()
    for ev in events:
        label, ls, _, color = styles[ev.kind]
        ax.axvline(float(ev.time), color=color, lw=0.9, ls=ls,
                   label=None if ev.kind in seen else label, zorder=0)
        seen.add(ev.kind)


def _time_plot(result, ax, values, ylabel):
    fig, ax = _axes(ax)
    for i, veh in enumerate(result.scene.vehicles):
        ax.plot(result.t, values[:, i], lw=1.8, label=veh.name)
    _mark_events(ax, result)
    ax.axhline(0.0, color="0.8", lw=0.8, zorder=0)
    ax.set_xlabel(f"time{_unit(result, 't')}")
    ax.set_ylabel(ylabel)
    ax.set_title(_title(result), fontsize="medium")
    ax.grid(True, alpha=0.3)
    _legend_below(ax)
    return fig, ax


def acceleration(result, ax=None):
    """Acceleration against time per vehicle (the paper's Fig. 6): in g on the left axis, in
    the scene's unit on the right. Returns the figure."""
    g = float(result.scene.g)
    fig, ax = _time_plot(result, ax, np.asarray(result.a) / g, "acceleration [g]")
    right = ax.secondary_yaxis("right", functions=(lambda y: y * g, lambda y: y / g))
    right.set_ylabel(f"acceleration{_unit(result, 'a')}")
    return fig


def velocity(result, ax=None):
    """Velocity against time per vehicle (the paper's Fig. 7). Returns the figure."""
    fig, _ = _time_plot(result, ax, np.asarray(result.v), f"velocity{_unit(result, 'v')}")
    return fig


_AFTER = {"contact": "loading", "reload_past_max": "loading", "max_deformation": "unloading",
          "max_deformation+separation": "open", "separation": "open"}


_BRANCH_STYLE = {"loading": "-", "unloading": "--", "reloading": ":"}


def _branches(result, k: int):
    """``(branch, mask)`` per stretch of contact ``k`` between its events, ``branch`` being
    ``"loading"``, ``"unloading"`` or ``"reloading"`` (closing again after a separation, up the
    unloading line); each mask includes both end samples, so the branches join."""
    t = np.asarray(result.t)
    evs = sorted((e for e in result.events if e.index == k and e.kind in _AFTER),
                 key=lambda e: e.time)
    if not evs:  # no hysteresis events (another contact law): draw where the force acts
        on = np.asarray(result.force)[:, k] > 0
        return [("loading", on | np.r_[False, on[:-1]] | np.r_[on[1:], False])]
    out = []
    for ev, nxt in zip(evs, evs[1:] + [None]):
        branch = _AFTER[ev.kind]
        if ev.kind == "contact" and out:
            branch = "reloading"
        if branch != "open":
            end = t[-1] if nxt is None else nxt.time
            out.append((branch, (t >= ev.time) & (t <= end)))
    return out


def ifd_loop(result, ax=None):
    """Force against deformation per contact: the IF-D loop (the paper's Fig. 3). Loading is
    drawn solid, unloading dashed, reloading dotted; max deformation and separation are marked.
    Returns the figure."""
    fig, ax = _axes(ax, figsize=(6.5, 4.5))
    t, D, F = np.asarray(result.t), np.asarray(result.deformation), np.asarray(result.force)
    names = [v.name for v in result.scene.vehicles]
    drawn = set()  # the branch styles drawn, for the legend
    for k in range(D.shape[1]):
        color = f"C{k % 10}"
        name = f"contact {k} ({names[k]}–{names[k + 1]})" if D.shape[1] > 1 else \
            f"{names[k]}–{names[k + 1]}"
        for j, (branch, on) in enumerate(_branches(result, k)):
            ax.plot(D[on, k], F[on, k], ls=_BRANCH_STYLE[branch], color=color, lw=1.8,
                    label=None if j else name)
            drawn.add(branch)
        for ev in result.events:
            if ev.index != k or ev.kind not in ("max_deformation", "max_deformation+separation",
                                                 "separation", "reload_past_max"):
                continue
            i = int(np.argmin(np.abs(t - ev.time)))
            if ev.kind == "max_deformation+separation":  # e = 0: the force drops at D_max
                ax.plot([D[i, k], D[i, k]], [F[i, k], 0.0], ls="--", color=color, lw=1.8)
                ax.plot(D[i, k], 0.0, ls="none", marker=_style("separation")[2], color=color,
                        mfc="white", ms=6, zorder=3)
                drawn.add("unloading")
            ax.plot(D[i, k], F[i, k], ls="none", marker=_style(ev.kind)[2], color=color,
                    mfc="white", ms=6, zorder=3)
    # legend proxies for the branch styles and the markers
    for branch, ls in _BRANCH_STYLE.items():
        if branch in drawn:
            ax.plot([], [], color="0.3", ls=ls, label=branch)
    kinds = {e.kind for e in result.events}
    for kind in ("max_deformation", "separation"):
        if kind in kinds or "max_deformation+separation" in kinds:
            ax.plot([], [], ls="none", marker=_style(kind)[2], color="0.3", mfc="white",
                    label=_style(kind)[0] if kind != "separation" else "separation (permanent set)")
    ax.axhline(0.0, color="0.8", lw=0.8, zorder=0)
    ax.set_xlabel(f"deformation{_unit(result, 'deformation')}")
    ax.set_ylabel(f"force{_unit(result, 'force')}")
    ax.set_title(_title(result), fontsize="medium")
    ax.grid(True, alpha=0.3)
    _legend_below(ax)
    return fig


def figure_writers(result, dpi: int = 150) -> dict:
    """``file name → writer(path)`` for the three figures of :func:`save_all` (for
    :func:`lsc.outputs.write_files`). Uses no GUI backend (figures are not kept by pyplot)."""
    from matplotlib.figure import Figure

    def writer(draw, figsize):
        def write(path):
            fig = Figure(figsize=figsize, layout="constrained")
            draw(result, ax=fig.add_subplot())
            fig.savefig(path, dpi=dpi)
        return write

    return {file: writer(draw, (6.5, 4.5) if draw is ifd_loop else (7.0, 4.5))
            for file, draw in zip(FILES, (acceleration, velocity, ifd_loop))}


def save_all(result, out_dir, dpi: int = 150, *, overwrite: bool = False) -> list[Path]:
    """Write ``acceleration.png``, ``velocity.png`` and ``ifd.png`` into ``out_dir`` (created if
    needed), all three or none; returns their paths. Refuses to replace those of an earlier run
    (:class:`lsc.outputs.OutputExistsError`, a ``FileExistsError``) unless ``overwrite=True``;
    a file that cannot be written raises :class:`lsc.outputs.OutputError` (an ``OSError``)."""
    from .outputs import write_files
    out = Path(out_dir)
    return write_files({out / f: w for f, w in figure_writers(result, dpi).items()},
                       overwrite=overwrite)

