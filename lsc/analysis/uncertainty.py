"""Monte Carlo uncertainty: scene parameters as distributions, solved with :func:`lsc.sweep`.

Distributions map dotted scene paths to specs (a plain dict, e.g. a TOML ``[uncertainty]`` table
that the caller reads beside the scene)::

    {"vehicles.0.speed": {"uniform": ["4 ft/s", "8 ft/s"]},
     "vehicles.1.weight": {"normal": [3500, 100]},             # optional "min", "max": truncated
     "contacts.0.loading.scale": {"triangular": [0.9, 1.0, 1.2]},
     "vehicles.0.mass": {"choice": [100, 110, 120]},            # or a bare list
     "contacts.0.unloading.restitution": {"function": e_of_speed}}

A ``function`` is called with the dict of the arrays already sampled (and, if it takes a second
argument, the random generator) and returns the values (n,). Values may carry units where the
path's kind is known (speeds, masses, weights, gaps, stiffnesses, forces). Nested tables (TOML
dotted keys written without quotes) are flattened to dotted paths.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError
from ..result import METRICS as RESULT_METRICS
from ..scene import Scene
from ._common import SummaryHTML, check_keywords, path_quantity

__all__ = ["monte_carlo", "sample", "MonteCarlo", "flatten_distributions", "METRICS"]

_KINDS = ("normal", "uniform", "triangular", "choice", "function")
_EXTRA = {"normal": ("min", "max")}

#: Metrics summarised by default: name → (label, per "vehicle" | "contact" | "scene").
METRICS = {
    "delta_v": ("delta-V", "vehicle"),
    "peak_acceleration_g": ("peak acceleration (signed)", "vehicle"),
    "duration": ("pulse duration", "scene"),
    "peak_force": ("peak force", "contact"),
}


@dataclass(eq=False)
class MonteCarlo(SummaryHTML):
    """The result of :func:`monte_carlo`.

    ``samples``: path → sampled values (n,) [scene units]; ``sweep``: the
    :class:`~lsc.SweepResult` (every metric per member; failed members are NaN with their reason
    in ``sweep.status``); ``q``: the percentiles [%]; ``percentiles``: metric → array
    ``(len(q),)``, ``(len(q), N)`` or ``(len(q), K)`` over the solved members, in scene units
    (peak acceleration in g); ``seed``, ``n``.
    """

    scene: Scene
    samples: dict
    sweep: object
    q: tuple
    percentiles: dict = field(default_factory=dict)
    seed: object = None
    n: int = 0

    @property
    def ok(self) -> np.ndarray:
        """Mask of the members that were solved."""
        return self.sweep.ok

    def values(self, metric: str, index: int | None = None) -> np.ndarray:
        """The solved members' values of ``metric`` (for vehicle ``index`` / contact ``index``;
        default: the front vehicle of a per-vehicle metric, contact 0 of a per-contact one)."""
        arr = np.asarray(self.sweep.metrics[metric])[self.ok]
        if arr.ndim == 2:
            arr = arr[:, _default_index(self.scene, metric) if index is None else index]
        return arr

    def summary(self) -> str:
        """A plain-text percentile table (what ``lsc mc`` prints)."""
        s = self.scene
        names = [v.name for v in s.vehicles]
        units = self.sweep.units
        head = " ".join(f"{f'p{q:g}':>12}" for q in self.q)
        n_ok = int(np.sum(self.ok))
        lines = [f"{s.name}: Monte Carlo, {self.n} samples (seed {self.seed}), {n_ok} solved"
                 f" ({self.n - n_ok} failed), method {self.sweep.method}",
                 "", "sampled: " + ", ".join(self.samples), "",
                 f"{'metric':<34} {'unit':>6} {head}"]
        for name, (label, per) in METRICS.items():
            p = self.percentiles[name]
            unit = "g" if name == "peak_acceleration_g" else units[name]
            if per == "scene":
                rows = [(label, p)]
            elif per == "vehicle":
                rows = [(f"{label} {n}", p[:, i]) for i, n in enumerate(names)]
            else:
                rows = [(f"{label} contact {k}", p[:, k]) for k in range(p.shape[1])]
            for lab, vals in rows:
                lines.append(f"{lab:<34} {unit:>6} " + " ".join(f"{v:>12.5g}" for v in vals))
        if n_ok < self.n:
            reasons, counts = np.unique(self.sweep.status[~self.ok].astype(str), return_counts=True)
            lines.append("")
            lines.append("failed members:")
            for r, c in sorted(zip(reasons, counts), key=lambda rc: -rc[1])[:5]:
                lines.append(f"  {c} x {r}")
        return "\n".join(lines)

    def histogram(self, metric: str = "delta_v", index: int | None = None, *, bins=50, ax=None):
        """A histogram of ``metric`` over the solved members with the percentiles marked; for a
        per-vehicle or per-contact metric, of vehicle / contact ``index`` (default: the front
        vehicle, contact 0). Draws on ``ax`` or a new figure; returns the matplotlib Figure."""
        fig, ax = _axes(ax)
        vals = self.values(metric, index)
        ax.hist(vals, bins=bins, color="0.65", edgecolor="0.35", linewidth=0.5)
        for q, v in zip(self.q, np.percentile(vals, self.q) if vals.size else []):
            ax.axvline(v, color="C3", lw=1)
            ax.annotate(f"p{q:g}", (v, 1.0), xycoords=("data", "axes fraction"), ha="center",
                        va="bottom", fontsize=8, color="C3")
        unit = "g" if metric == "peak_acceleration_g" else self.sweep.units.get(metric, "")
        label = {"delta_v": "delta-V", "peak_acceleration_g": "peak acceleration",
                 "duration": "pulse duration", "peak_force": "peak force"}.get(metric, metric)
        if np.asarray(self.sweep.metrics[metric]).ndim == 2:
            i = _default_index(self.scene, metric) if index is None else index
            per = RESULT_METRICS[metric][1]
            label += f", {self.scene.vehicles[i].name}" if per == "vehicle" else f", contact {i}"
        ax.set_xlabel(f"{label} [{unit}]" if unit else label)
        ax.set_ylabel("samples")
        ax.set_title(f"{self.scene.name}: {vals.size} of {self.n} samples", fontsize=10, pad=14)
        return fig


def _axes(ax):
    """``(figure, axes)``: those of ``ax``, or a new figure (pyplot on Agg without a display)."""
    if ax is not None:
        return ax.figure, ax
    import os
    import sys
    import matplotlib
    if "matplotlib.pyplot" not in sys.modules and not os.environ.get("MPLBACKEND") \
            and sys.platform.startswith("linux") \
            and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt.subplots(figsize=(6.0, 4.0), layout="constrained")


def _default_index(scene: Scene, metric: str) -> int:
    per = RESULT_METRICS[metric][1]
    return scene.n_vehicles - 1 if per == "vehicle" else 0


def flatten_distributions(dists) -> dict:
    """Dotted path → spec, from a dict that may nest (``{"vehicles": {"0": {"speed": ...}}}``)."""
    if not isinstance(dists, dict) or not dists:
        raise SceneError("uncertainty", "distributions are a non-empty dict of dotted scene paths "
                                        "to specs such as { uniform = [4, 8] }")
    out = {}

    def walk(prefix, node):
        if isinstance(node, dict) and not any(k in node for k in _KINDS):
            if not node:
                raise SceneError(prefix or "uncertainty", "an empty table is not a distribution")
            for key, sub in node.items():
                walk(f"{prefix}.{key}" if prefix else str(key), sub)
        else:
            out[prefix] = node

    walk("", dists)
    return out


def _spec(path: str, spec):
    """``(kind, args, extra)`` of one spec (a dict with one kind, a bare list = choice)."""
    if isinstance(spec, (list, tuple)):
        return "choice", list(spec), {}
    if callable(spec):
        return "function", spec, {}
    if not isinstance(spec, dict):
        raise SceneError(path, f"a distribution is a table such as {{ normal = [mean, sd] }}, "
                               f"{{ uniform = [lo, hi] }}, {{ triangular = [lo, mode, hi] }}, "
                               f"{{ choice = [...] }} or {{ function = f }}; got {spec!r}")
    kinds = [k for k in _KINDS if k in spec]
    if len(kinds) != 1:
        raise SceneError(path, f"a distribution names exactly one of {', '.join(_KINDS)}; got "
                               f"{', '.join(map(str, spec)) or 'none'}")
    kind = kinds[0]
    extra = {k: v for k, v in spec.items() if k != kind}
    bad = set(extra) - set(_EXTRA.get(kind, ()))
    if bad:
        raise SceneError(f"{path}.{sorted(bad)[0]}", f"unknown key for a {kind} distribution"
                         + (f"; accepted: {', '.join(_EXTRA[kind])}" if kind in _EXTRA else ""))
    return kind, spec[kind], extra


def _numbers(vals, n_args, scene, path, kind):
    if not isinstance(vals, (list, tuple)) or len(vals) != n_args:
        raise SceneError(f"{path}.{kind}", f"a {kind} distribution takes {n_args} values, got {vals!r}")
    return [path_quantity(v, scene, path) for v in vals]


def _function(path: str, f):
    if isinstance(f, str) and ":" in f:  # "package.module:name" (from a TOML file)
        import importlib
        mod, _, name = f.partition(":")
        try:
            f = getattr(importlib.import_module(mod), name)
        except (ImportError, AttributeError) as e:
            raise SceneError(f"{path}.function", f"cannot import {f!r}: {e}") from None
    if not callable(f):
        raise SceneError(f"{path}.function", f"expected a callable (or \"module:name\"), got {f!r}")
    try:
        params = [p for p in inspect.signature(f).parameters.values()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
        takes_rng = len(params) >= 2
    except (TypeError, ValueError):
        takes_rng = False
    return f, takes_rng


def sample(scene, distributions: dict, n: int, *, seed=None) -> dict:
    """Draw ``n`` values per path [scene units], reproducibly for a ``seed``.

    Paths are drawn in the dict's order from one ``numpy.random.Generator(PCG64(seed))``; the
    ``function`` specs are evaluated after every other one, in their order.
    """
    from ..sweep import check_members

    base = Scene.load(scene)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise SceneError("n", f"the number of samples must be a positive integer, got {n!r}")
    check_members(int(n), "n")
    if seed is not None and (isinstance(seed, (bool, np.bool_))
                             or not isinstance(seed, (int, np.integer)) or seed < 0):
        raise SceneError("seed", "the seed must be a whole number >= 0 (or None: a fresh one "
                                 f"each run), got {seed!r}")
    rng = np.random.default_rng(seed)
    specs = {p: _spec(p, s) for p, s in flatten_distributions(distributions).items()}
    out: dict[str, np.ndarray] = {}
    for path, (kind, args, extra) in specs.items():
        if kind == "normal":
            mean, sd = _numbers(args, 2, base, path, kind)
            if not sd >= 0:
                raise SceneError(f"{path}.normal", f"the standard deviation must be >= 0, got {sd:g}")
            lo = path_quantity(extra["min"], base, path) if "min" in extra else -np.inf
            hi = path_quantity(extra["max"], base, path) if "max" in extra else np.inf
            if not lo < hi:
                raise SceneError(f"{path}.min", f"min must be below max, got {lo:g} and {hi:g}")
            if np.isfinite(lo) or np.isfinite(hi):
                if sd == 0:
                    out[path] = np.full(n, np.clip(mean, lo, hi))
                    continue
                out[path] = _truncated_normal(rng, mean, sd, lo, hi, n)
            else:
                out[path] = rng.normal(mean, sd, n)
        elif kind == "uniform":
            lo, hi = _numbers(args, 2, base, path, kind)
            if not lo <= hi:
                raise SceneError(f"{path}.uniform", f"needs lo <= hi, got {lo:g} and {hi:g}")
            out[path] = rng.uniform(lo, hi, n)
        elif kind == "triangular":
            lo, mode, hi = _numbers(args, 3, base, path, kind)
            if not (lo <= mode <= hi and lo < hi):
                raise SceneError(f"{path}.triangular", f"needs lo <= mode <= hi and lo < hi, got "
                                                       f"{lo:g}, {mode:g}, {hi:g}")
            out[path] = rng.triangular(lo, mode, hi, n)
        elif kind == "choice":
            if not isinstance(args, (list, tuple)) or not args:
                raise SceneError(f"{path}.choice", "a choice is a non-empty list of values")
            vals = np.array([path_quantity(v, base, path) for v in args])
            out[path] = vals[rng.integers(0, vals.size, n)]
    for path, (kind, args, extra) in specs.items():
        if kind != "function":
            continue
        f, takes_rng = _function(path, args)
        view = {p: v.copy() for p, v in out.items()}
        vals = f(view, rng) if takes_rng else f(view)
        try:
            arr = np.broadcast_to(np.asarray(vals, float), (n,)).copy()
        except (TypeError, ValueError):
            raise SceneError(f"{path}.function", f"the function must return {n} numbers (or one), "
                                                 f"got {np.shape(vals)}") from None
        out[path] = arr
    for path in specs:
        _check_path(base, path, out[path][0])
    return {p: out[p] for p in specs}


def _truncated_normal(rng, mean: float, sd: float, lo: float, hi: float, n: int) -> np.ndarray:
    """``n`` draws of a normal truncated to ``[lo, hi]``: by rejection while at least 5 % of the
    normal lies inside (deterministic for the generator's state), else by the inverse CDF."""
    a, b = (lo - mean) / sd, (hi - mean) / sd
    inside = 0.5 * (math.erf(b / math.sqrt(2)) - math.erf(a / math.sqrt(2)))
    if inside >= 0.05:
        out = np.empty(0)
        while out.size < n:
            z = rng.normal(0.0, 1.0, int((n - out.size) / inside * 1.1) + 16)
            out = np.concatenate([out, z[(z >= a) & (z <= b)]])
        return mean + sd * out[:n]
    from scipy.special import ndtr, ndtri
    flip = a > 0  # work in the lower tail, where ndtr keeps its precision
    if flip:
        a, b = -b, -a
    z = np.clip(ndtri(rng.uniform(ndtr(a), ndtr(b), n)), a, b)
    return mean + sd * (-z if flip else z)


def _check_path(scene: Scene, path: str, value: float) -> None:
    """SceneError if ``path`` names no field of the scene (a misspelled distribution kind nested
    as a table ends up here too)."""
    try:
        scene.with_values({path: float(value)})
    except SceneError as e:
        msg = str(e)
        if "unknown key" in msg or "no such field" in msg:
            raise SceneError(path, f"{e.message if hasattr(e, 'message') else msg} (a distribution "
                                   f"names exactly one of {', '.join(_KINDS)})") from None


def monte_carlo(scene, distributions: dict, n: int, *, seed=None, method: str = "auto",
                progress=None, percentiles=(5, 50, 95), **options) -> MonteCarlo:
    """Sample the distributions, solve every member with :func:`lsc.sweep`, and summarise.

    Parameters
    ----------
    scene : dict, path or Scene
        The base scene.
    distributions : dict
        Dotted path → spec (see the module docstring).
    n : int
        Number of samples.
    seed : int or None
        Seed of the random generator (the same seed gives the same samples and results).
    method : str
        Backend (``"auto"``: the cheapest exact one; the closed form is vectorised).
    progress : bool or None
        Progress bar (``None``: when stderr is a terminal).
    percentiles : sequence of float
        Percentiles reported [%] (default 5, 50, 95).
    **options
        Solver options, as for :func:`lsc.solve`.

    Returns
    -------
    MonteCarlo
        Samples, the sweep, and the percentiles of ΔV, peak acceleration [g], pulse duration and
        peak force over the members that were solved.
    """
    from ..sweep import sweep

    check_keywords("monte_carlo", options, ("seed", "method", "progress", "percentiles"))
    base = Scene.load(scene)
    q = tuple(float(x) for x in np.atleast_1d(percentiles))
    if not q or any(not 0 <= x <= 100 for x in q):
        raise SceneError("percentiles", f"percentiles lie in [0, 100], got {percentiles!r}")
    samples = sample(base, distributions, n, seed=seed)
    sw = sweep(base, samples, method=method, progress=progress, **options)
    pct = {}
    ok = sw.ok
    for name in METRICS:
        arr = np.asarray(sw.metrics[name])[ok]
        pct[name] = (np.percentile(arr, q, axis=0) if arr.shape[0]
                     else np.full((len(q),) + arr.shape[1:], np.nan))
    return MonteCarlo(base, samples, sw, q, pct, seed, int(n))
