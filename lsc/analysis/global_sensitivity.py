"""Global (variance-based) sensitivity: Sobol' indices of the crash metrics over the uncertain
inputs of an ``[uncertainty]`` table, with SALib.

The inputs are the table's sampled distributions (see :mod:`lsc.analysis.uncertainty`; they must
be independent: no ``correlation``); ``function`` entries are computed from them. SALib's Sobol'
design (Saltelli's scheme: ``n (d + 2)`` members for ``d`` inputs, no second-order indices) is
drawn on the unit hypercube and mapped through each distribution's inverse CDF, every member is
solved with :func:`lsc.sweep`, and :func:`SALib.analyze.sobol.analyze` gives, for every metric
column, each input's first-order index ``S1`` (the share of the metric's variance that the input
explains alone) and total index ``ST`` (alone and with the others), with bootstrap confidence
intervals. ``import lsc`` does not import SALib: it loads on the first call.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, SimulationError
from ..result import METRICS as RESULT_METRICS
from ._common import SummaryHTML, check_keywords
from .uncertainty import apply_functions, inputs, map_points, warn_sobol_count

__all__ = ["global_sensitivity", "GlobalSensitivity", "DEFAULT_METRICS", "COLUMNS"]

#: Metrics analysed by default.
DEFAULT_METRICS = ("delta_v", "peak_acceleration", "duration")
#: The columns of :attr:`GlobalSensitivity.table`.
COLUMNS = ("input", "metric", "S1", "S1_conf", "ST", "ST_conf")


@dataclass(eq=False)
class GlobalSensitivity(SummaryHTML):
    """The result of :func:`global_sensitivity`.

    ``table``: a pandas DataFrame, one row per (input, metric column) with ``S1``, ``S1_conf``,
    ``ST``, ``ST_conf`` (the half-widths of the ``conf_level`` bootstrap intervals);
    ``inputs``: the sampled paths; ``metrics``: the metric columns (``"delta_v[target]"``, as in
    :meth:`lsc.SweepResult.columns`, without units: the indices are fractions of variance);
    ``sweep``: the :class:`~lsc.SweepResult` of every member; ``n``: base samples (the design has
    ``n (d + 2)`` members); ``seed``; ``conf_level``.
    """

    scene: object
    inputs: list
    metrics: list
    table: object
    sweep: object
    n: int
    seed: object = None
    conf_level: float = 0.95
    stats: dict = field(default_factory=dict)

    def summary(self) -> str:
        """A plain-text table of the indices (what ``lsc sensitivity --global`` prints)."""
        lines = [f"{self.scene.name}: Sobol' indices, {self.n} base samples x "
                 f"({len(self.inputs)} inputs + 2) = {self.sweep.status.size} solves "
                 f"(seed {self.seed}), method {self.sweep.method}",
                 f"S1: first order, ST: total; +- the {100 * self.conf_level:g} % bootstrap "
                 "interval", ""]
        width = max(len(p) for p in self.inputs)
        for metric in self.metrics:
            lines.append(metric)
            rows = self.table[self.table["metric"] == metric]
            for r in rows.itertuples(index=False):
                lines.append(f"  {r.input:<{width}}  S1 {r.S1:7.3f} +- {r.S1_conf:5.3f}   "
                             f"ST {r.ST:7.3f} +- {r.ST_conf:5.3f}")
        return "\n".join(lines)

    def plot(self, metric: str | None = None, *, ax=None, file=None, overwrite: bool = False):
        """A bar chart of S1 and ST per input with their intervals
        (:func:`lsc.plots.sobol_indices`)."""
        from ..plots import sobol_indices
        return sobol_indices(self, metric, ax=ax, file=file, overwrite=overwrite)

    def to_csv(self, path, *, overwrite: bool = False):
        """Write :attr:`table` as CSV (shortest round-trip decimals), whole or not at all; an
        existing file is refused (:class:`lsc.outputs.OutputExistsError`) unless ``overwrite``."""
        from ..outputs import write_file
        return write_file(path, lambda f: self.table.to_csv(
            f, index=False, float_format=lambda x: repr(float(x))),
                          overwrite=overwrite)


def global_sensitivity(scene, distributions: dict, *, metrics=DEFAULT_METRICS, n: int = 1024,
                       seed=None, method: str = "auto", conf_level: float = 0.95,
                       num_resamples: int = 100, progress=None, **options) -> GlobalSensitivity:
    """Sobol' first-order and total indices of ``metrics`` with respect to each uncertain input.

    Parameters
    ----------
    scene : dict, path or Scene
        The base scene.
    distributions : dict
        Dotted path → distribution, as for :func:`lsc.analysis.monte_carlo` (independent inputs:
        a ``correlation`` is refused, the indices assume independence).
    metrics : sequence of str
        Names of :data:`lsc.result.METRICS`; a per-vehicle / per-contact metric gives one column
        per vehicle / contact.
    n : int
        Base samples of the Sobol' design (a power of two; another count is kept, with a
        warning); ``n (d + 2)`` members are solved for ``d`` inputs.
    seed : int or None
        Seed of the design's scrambling and of the bootstrap (the same seed, the same indices).
    method : str
        Backend of the solves (``"auto"``: the cheapest exact one).
    conf_level : float
        Level of the bootstrap confidence intervals (default 0.95), over ``num_resamples``.
    **options
        Solver options, as for :func:`lsc.solve`.

    Returns
    -------
    GlobalSensitivity

    Raises
    ------
    SimulationError
        When a member cannot be solved (the indices need every member).
    """
    from ..sweep import check_members, sweep
    from .uncertainty import _check_count

    check_keywords("global_sensitivity", options, ("metrics", "n", "seed", "method",
                                                   "conf_level", "num_resamples", "progress"))
    _check_count(n, seed)
    spec = _independent_inputs(scene, distributions)
    names = _metric_names(metrics)
    _check_fraction("conf_level", conf_level)
    if isinstance(num_resamples, bool) or not isinstance(num_resamples, (int, np.integer)) \
            or num_resamples < 2:
        raise SceneError("num_resamples", f"num_resamples must be an integer >= 2, got "
                                          f"{num_resamples!r}")
    problem = {"num_vars": len(spec.marginals), "names": list(spec.marginals),
               "bounds": [[0.0, 1.0]] * len(spec.marginals)}
    check_members(int(n) * (len(spec.marginals) + 2), "n")
    u = _design(problem, int(n), seed)
    values = apply_functions(spec, map_points(spec, u), np.random.default_rng(seed), u.shape[0])
    sw = sweep(spec.scene, values, method=method, progress=progress, **options)
    _require_all_solved(sw)
    table = _indices(problem, sw, names, conf_level, num_resamples, seed)
    return GlobalSensitivity(spec.scene, list(spec.marginals), list(dict.fromkeys(table["metric"])),
                             table, sw, int(n), seed, float(conf_level),
                             {"members": int(u.shape[0]), "wall_time": sw.stats.get("wall_time")})


def _independent_inputs(scene, distributions):
    """The table's inputs, refused when correlated or when a function draws its own randomness."""
    spec = inputs(scene, distributions)
    if spec.rank_correlation is not None:
        raise SceneError("uncertainty.correlation", "Sobol' indices apportion the variance of "
                         "independent inputs: remove the correlation for a global sensitivity "
                         "analysis (monte_carlo takes correlated inputs)")
    if not spec.marginals:
        raise SceneError("uncertainty", "no sampled input: Sobol' indices need at least one "
                                        "distribution other than a function")
    for path, (_, takes_rng) in spec.functions.items():
        if takes_rng:
            raise SceneError(f"{path}.function", "this function takes a random generator: its "
                             "randomness would be an input without an index; give that input a "
                             "distribution of its own instead")
    return spec


def _metric_names(metrics) -> list[str]:
    names = [metrics] if isinstance(metrics, str) else list(metrics)
    if not names:
        raise SceneError("metrics", "give at least one metric")
    for name in names:
        if name not in RESULT_METRICS:
            raise SceneError("metrics", f"unknown metric {name!r}; accepted: "
                                        f"{', '.join(RESULT_METRICS)}")
    return names


def _check_fraction(name: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) \
            or not 0 < value < 1:
        raise SceneError(name, f"{name} lies strictly between 0 and 1, got {value!r}")


def _design(problem: dict, n: int, seed) -> np.ndarray:
    """SALib's Sobol' design on the unit hypercube, ``n (d + 2)`` points (no second order)."""
    from SALib.sample import sobol as sobol_sample

    warn_sobol_count(n, "n")
    with warnings.catch_warnings():  # (the count was dealt with above)
        warnings.filterwarnings("ignore", message=".*Sobol' sequence")
        warnings.filterwarnings("ignore", message=".*balance properties of Sobol")
        return sobol_sample.sample(problem, n, calc_second_order=False, scramble=True, seed=seed)


def _require_all_solved(sw) -> None:
    if np.all(sw.ok):
        return
    bad = ~sw.ok
    reasons, counts = np.unique(sw.status[bad].astype(str), return_counts=True)
    top = sorted(zip(counts, reasons), reverse=True)[0]
    raise SimulationError(f"{int(bad.sum())} of {sw.status.size} members of the Sobol' design "
                          f"could not be solved (e.g. {top[0]} x {top[1]}); the indices need every "
                          "member: narrow the distributions to crashes the backend completes")


def _columns(sw, names: list[str]) -> dict[str, np.ndarray]:
    """Metric column label → values (n,), as :meth:`lsc.SweepResult.columns` names them."""
    cols = {}
    vehicles = [v.name for v in sw.scene.vehicles]
    for name in names:
        arr = np.asarray(sw.metrics[name], float)
        per = RESULT_METRICS[name][1]
        if per == "scene":
            cols[name] = arr
        else:
            labels = vehicles if per == "vehicle" else range(arr.shape[1])
            cols.update({f"{name}[{lab}]": arr[:, i] for i, lab in enumerate(labels)})
    return cols


def _indices(problem, sw, names, conf_level, num_resamples, seed):
    """The table of S1, ST and their intervals of every metric column."""
    import pandas as pd
    from SALib.analyze import sobol

    rows = []
    for label, y in _columns(sw, names).items():
        if not np.all(np.isfinite(y)):
            raise SceneError("metrics", f"{label} is undefined (NaN) for "
                                        f"{int(np.sum(~np.isfinite(y)))} members: leave it out")
        if np.ptp(y) == 0:
            raise SceneError("metrics", f"{label} is the same for every member (no variance to "
                                        "apportion): leave it out")
        # (a Generator, not the seed: SALib draws from NumPy's global state for a seed of 0)
        res = sobol.analyze(problem, y, calc_second_order=False, num_resamples=num_resamples,
                            conf_level=conf_level, seed=np.random.default_rng(seed))
        for j, path in enumerate(problem["names"]):
            rows.append((path, label, res["S1"][j], res["S1_conf"][j], res["ST"][j],
                         res["ST_conf"][j]))
    return pd.DataFrame(rows, columns=list(COLUMNS))
