"""Monte Carlo uncertainty: scene parameters as distributions (:mod:`lsc.analysis.sampling`),
solved with :func:`lsc.sweep`, summarised by percentiles."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError
from ..result import METRICS as RESULT_METRICS
from ..scene import Scene
from ._common import SummaryHTML, check_keywords
from .sampling import (SAMPLINGS, Inputs, apply_functions, correlated_pairs,
                       flatten_distributions, inputs, map_points, rank_correlation, sample,
                       unit_points, warn_sobol_count, check_sampling)
from .sampling import _check_count  # (also re-exported for global_sensitivity)
from .blocks import BlockSampler

__all__ = ["monte_carlo", "sample", "MonteCarlo", "flatten_distributions", "METRICS",
           "SAMPLINGS", "inputs", "Inputs", "rank_correlation", "unit_points", "map_points",
           "apply_functions", "warn_sobol_count"]


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
    in ``sweep.status``), or for a study written to Parquet the
    :class:`~lsc.parquet.SweepFile` (``samples`` and metrics then read from it on access); ``q``: the percentiles [%]; ``percentiles``: metric → array
    ``(len(q),)``, ``(len(q), N)`` or ``(len(q), K)`` over the solved members, in scene units
    (peak acceleration in g); ``seed``, ``n``, ``sampling`` (the design: :data:`SAMPLINGS`);
    ``rank_correlation``: ``(path_a, path_b)`` → the requested Spearman rank correlation of each
    correlated pair (empty: independent inputs).
    """

    scene: Scene
    samples: dict
    sweep: object
    q: tuple
    percentiles: dict = field(default_factory=dict)
    seed: object = None
    n: int = 0
    sampling: str = "random"
    rank_correlation: dict = field(default_factory=dict)

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
        n_ok = self.n - int(self.sweep.stats["failed"])
        design = {"random": "", "sobol": ", scrambled Sobol' points",
                  "lhs": ", Latin hypercube"}[self.sampling]
        lines = [f"{s.name}: Monte Carlo, {self.n} samples (seed {self.seed}{design}), "
                 f"{n_ok} solved ({self.n - n_ok} failed), method {self.sweep.method}",
                 "", "sampled: " + ", ".join(self.samples), *self._correlation_lines(), "",
                 f"{'metric':<34} {'unit':>6} {head}"]
        for name, (label, per) in METRICS.items():
            if name not in self.percentiles:
                continue
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
            lines.append("")
            lines.append("failed members:")
            for r, c in self._failures()[:5]:
                lines.append(f"  {c} x {r}")
        warned = int(self.sweep.stats.get("warned", 0))
        if warned:
            j, first = next((j, w) for j, w in enumerate(self.sweep.warnings) if w)
            lines += ["", f"{warned} members with warnings (their own solves', in "
                      f"sweep.warnings and the warnings column), the first: member {j}: "
                      f"{first[0]}"]
        return "\n".join(lines)

    def _failures(self) -> list:
        """``(reason, count)`` of the failed members, most frequent first (a study written to
        a file counted them as it ran)."""
        if hasattr(self.sweep, "reasons"):
            counts = self.sweep.reasons.items()
        else:
            counts = zip(*np.unique(self.sweep.status[~self.ok].astype(str), return_counts=True))
        return sorted(counts, key=lambda rc: -rc[1])

    def _correlation_lines(self) -> list[str]:
        """The requested rank correlations, one line (none when independent)."""
        pairs = [f"{a} ~ {b} {rho:g}" for (a, b), rho in self.rank_correlation.items()]
        return ["rank correlation: " + ", ".join(pairs)] if pairs else []

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



def monte_carlo(scene, distributions: dict, n: int, *, seed=None, sampling: str = "random",
                method: str = "auto", progress=None, percentiles=(5, 50, 95), metrics=None,
                out=None, overwrite: bool = False, executor=None, task_size: int | None = None,
                **options) -> MonteCarlo:
    """Sample the distributions, solve every member with :func:`lsc.sweep`, and summarise.

    Parameters
    ----------
    scene : dict, path or Scene
        The base scene.
    distributions : dict
        Dotted path → spec (see :mod:`lsc.analysis.sampling`).
    n : int
        Number of samples.
    seed : int or None
        Seed of the random generator (the same seed gives the same samples and results).
    sampling : str
        ``"random"`` (pseudo-random draws, the default), ``"sobol"`` (scrambled Sobol' points:
        quasi-Monte Carlo; ``n`` a power of two) or ``"lhs"`` (Latin hypercube); see
        :func:`sample`. Correlated inputs: a ``correlation`` entry in ``distributions``.
    method : str
        Backend (``"auto"``: the cheapest exact one; the closed form is vectorised).
    progress : bool or None
        Progress bar (``None``: when stderr is a terminal).
    percentiles : sequence of float
        Percentiles reported [%] (default 5, 50, 95).
    metrics : sequence of str, optional
        The metrics kept per member (default: all in memory; with ``out``, those of
        :data:`METRICS`). The percentiles are those of :data:`METRICS` kept.
    out : path, optional
        Stream the study to this Parquet file (:func:`lsc.sweep`'s ``out``): the samples are
        drawn a block at a time (:mod:`lsc.analysis.blocks`; with ``sampling="random"`` not the
        values of an in-memory run of the same seed), nothing is held per member, and the
        percentiles are exact, read back from the file a column at a time. ``overwrite``: replace
        an existing file.
    executor, task_size
        As for :func:`lsc.sweep`: where the tasks run, and their size.
    **options
        Solver options, as for :func:`lsc.solve`.

    Returns
    -------
    MonteCarlo
        Samples, the sweep (a :class:`lsc.parquet.SweepFile` with ``out``), and the percentiles
        of ΔV, peak acceleration [g], pulse duration and peak force over the members solved.
    """
    from ..sweep import Arrays, study

    check_keywords("monte_carlo", options, ("seed", "method", "progress", "percentiles",
                                            "metrics", "out", "overwrite", "executor",
                                            "task_size"))
    base = Scene.load(scene)
    q = tuple(float(x) for x in np.atleast_1d(percentiles))
    if not q or any(not 0 <= x <= 100 for x in q):
        raise SceneError("percentiles", f"percentiles lie in [0, 100], got {percentiles!r}")
    if out is None:
        samples = sample(base, distributions, n, seed=seed, sampling=sampling)
        members = Arrays(samples)
    else:
        _check_count(n, seed, in_memory=False)
        check_sampling(sampling)
        members = BlockSampler(inputs(base, distributions), sampling, n, seed)
        seed = members.seed
        metrics = tuple(METRICS) if metrics is None else metrics
    correlation = correlated_pairs(inputs(base, distributions))
    sw = study(base, members, (int(n),), method=method, options=options, controls={},
               metrics=metrics, out=out, overwrite=overwrite, executor=executor,
               task_size=task_size, progress=progress)
    if out is not None:
        samples = sw.params
    pct = {name: _percentiles(sw, name, q) for name in METRICS if name in sw.metrics}
    return MonteCarlo(base, samples, sw, q, pct, seed, int(n), sampling, correlation)


def _percentiles(sw, name: str, q: tuple) -> np.ndarray:
    """Percentiles ``q`` of metric ``name`` over the solved members of a sweep (in memory, or
    read back from its file a column at a time)."""
    if hasattr(sw, "percentiles"):
        return sw.percentiles(name, q)
    arr = np.asarray(sw.metrics[name])[sw.ok]
    return (np.percentile(arr, q, axis=0) if arr.shape[0]
            else np.full((len(q),) + arr.shape[1:], np.nan))
