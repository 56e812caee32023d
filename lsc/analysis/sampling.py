"""Sampling the uncertain inputs of a study: distributions, designs, correlation.

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

An optional ``correlation`` entry sets the Spearman rank correlation between sampled inputs:
a matrix in the table's order of the sampled (non-``function``) paths, e.g.
``correlation = [[1, 0.5], [0.5, 1]]``, or named pairs
``correlation = [["vehicles.0.speed", "vehicles.1.weight", 0.5]]``. It is applied with a
Gaussian copula (the Cholesky factor of the normal scores' correlation ``2 sin(π ρ_S / 6)``,
then each distribution's inverse CDF), so every marginal distribution is kept.
"""

from __future__ import annotations

import inspect
import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..scene import Scene
from ._common import path_quantity
from .correlation import correlated_pairs, normal_scores, rank_correlation

__all__ = ["sample", "flatten_distributions", "SAMPLINGS", "inputs", "Inputs",
           "rank_correlation", "unit_points", "map_points", "apply_functions", "warn_sobol_count",
           "design_points", "correlate", "check_sampling", "correlated_pairs"]

_KINDS = ("normal", "uniform", "triangular", "choice", "function")
_EXTRA = {"normal": ("min", "max")}


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


#: Accepted ``sampling`` designs: plain pseudo-random draws, scrambled Sobol' points
#: (quasi-Monte Carlo) and a Latin hypercube (both from :mod:`scipy.stats.qmc`).
SAMPLINGS = ("random", "sobol", "lhs")

# The open interval (0, 1) that the inverse CDFs are evaluated on (a design point or a copula
# value of exactly 0 or 1 would map an unbounded distribution to an infinite value).
_U_MIN, _U_MAX = np.finfo(float).tiny, np.nextafter(1.0, 0.0)


@dataclass(frozen=True)
class _Normal:
    """A normal distribution [scene units], truncated to ``[lo, hi]`` where those are finite."""

    mean: float
    sd: float
    lo: float = -np.inf
    hi: float = np.inf

    @property
    def truncated(self) -> bool:
        return bool(np.isfinite(self.lo) or np.isfinite(self.hi))

    def draw(self, rng, n: int) -> np.ndarray:
        if not self.truncated:
            return rng.normal(self.mean, self.sd, n)
        if self.sd == 0:
            return np.full(n, np.clip(self.mean, self.lo, self.hi))
        return _truncated_normal(rng, self.mean, self.sd, self.lo, self.hi, n)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        from scipy import stats
        if self.sd == 0:
            return np.full(u.shape, np.clip(self.mean, self.lo, self.hi))
        if not self.truncated:
            return stats.norm.ppf(u, loc=self.mean, scale=self.sd)
        a, b = (self.lo - self.mean) / self.sd, (self.hi - self.mean) / self.sd
        return stats.truncnorm.ppf(u, a, b, loc=self.mean, scale=self.sd)


@dataclass(frozen=True)
class _Uniform:
    lo: float
    hi: float

    def draw(self, rng, n: int) -> np.ndarray:
        return rng.uniform(self.lo, self.hi, n)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        return self.lo + (self.hi - self.lo) * u  # (lo == hi allowed: a constant)


@dataclass(frozen=True)
class _Triangular:
    lo: float
    mode: float
    hi: float

    def draw(self, rng, n: int) -> np.ndarray:
        return rng.triangular(self.lo, self.mode, self.hi, n)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        from scipy import stats
        width = self.hi - self.lo
        return stats.triang.ppf(u, (self.mode - self.lo) / width, loc=self.lo, scale=width)


@dataclass(frozen=True)
class _Choice:
    """Equally likely values [scene units]."""

    values: np.ndarray

    def draw(self, rng, n: int) -> np.ndarray:
        return self.values[rng.integers(0, self.values.size, n)]

    def ppf(self, u: np.ndarray) -> np.ndarray:
        k = self.values.size
        return self.values[np.minimum((u * k).astype(np.int64), k - 1)]


def _marginal(base: Scene, path: str, kind: str, args, extra: dict):
    """The distribution of one ``(kind, args, extra)`` spec, checked (``SceneError`` naming the
    path's field otherwise)."""
    if kind == "normal":
        mean, sd = _numbers(args, 2, base, path, kind)
        if not sd >= 0:
            raise SceneError(f"{path}.normal", f"the standard deviation must be >= 0, got {sd:g}")
        lo = path_quantity(extra["min"], base, path) if "min" in extra else -np.inf
        hi = path_quantity(extra["max"], base, path) if "max" in extra else np.inf
        if not lo < hi:
            raise SceneError(f"{path}.min", f"min must be below max, got {lo:g} and {hi:g}")
        return _Normal(mean, sd, lo, hi)
    if kind == "uniform":
        lo, hi = _numbers(args, 2, base, path, kind)
        if not lo <= hi:
            raise SceneError(f"{path}.uniform", f"needs lo <= hi, got {lo:g} and {hi:g}")
        return _Uniform(lo, hi)
    if kind == "triangular":
        lo, mode, hi = _numbers(args, 3, base, path, kind)
        if not (lo <= mode <= hi and lo < hi):
            raise SceneError(f"{path}.triangular", f"needs lo <= mode <= hi and lo < hi, got "
                                                   f"{lo:g}, {mode:g}, {hi:g}")
        return _Triangular(lo, mode, hi)
    if not isinstance(args, (list, tuple)) or not args:
        raise SceneError(f"{path}.choice", "a choice is a non-empty list of values")
    return _Choice(np.array([path_quantity(v, base, path) for v in args]))


def _check_count(n, seed, in_memory: bool = True) -> None:
    """``n`` a positive whole number (within :data:`lsc.sweep.MAX_MEMBERS` if ``in_memory``),
    ``seed`` ``None`` or a whole number >= 0 (``SceneError`` naming them otherwise)."""
    from ..sweep import check_members

    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise SceneError("n", f"the number of samples must be a positive integer, got {n!r}")
    if in_memory:
        check_members(int(n), "n")
    if seed is not None and (isinstance(seed, (bool, np.bool_))
                             or not isinstance(seed, (int, np.integer)) or seed < 0):
        raise SceneError("seed", "the seed must be a whole number >= 0 (or None: a fresh one "
                                 f"each run), got {seed!r}")


@dataclass(frozen=True)
class Inputs:
    """The uncertain inputs of a study: ``marginals`` (sampled path → distribution, in the
    table's order), ``functions`` (path → ``(callable, takes_rng)``, evaluated from the sampled
    ones) and ``rank_correlation`` (the requested Spearman matrix over the sampled paths, or
    ``None``: independent)."""

    scene: Scene
    marginals: dict
    functions: dict
    rank_correlation: np.ndarray | None = None
    order: tuple = ()


def inputs(scene, distributions: dict) -> Inputs:
    """The checked :class:`Inputs` of a distributions table (see the module docstring; an
    optional ``correlation`` entry: see :func:`rank_correlation`)."""
    base = Scene.load(scene)
    dists = dict(distributions) if isinstance(distributions, dict) else distributions
    corr = dists.pop("correlation", None) if isinstance(dists, dict) else None
    specs = {p: _spec(p, s) for p, s in flatten_distributions(dists).items()}
    marginals = {p: _marginal(base, p, *s) for p, s in specs.items() if s[0] != "function"}
    functions = {p: _function(p, s[1]) for p, s in specs.items() if s[0] == "function"}
    matrix = None if corr is None else rank_correlation(corr, marginals)
    return Inputs(base, marginals, functions, matrix, tuple(specs))


def sample(scene, distributions: dict, n: int, *, seed=None, sampling: str = "random") -> dict:
    """Draw ``n`` values per path [scene units], reproducibly for a ``seed``.

    ``sampling="random"`` (independent inputs): paths are drawn in the dict's order from one
    ``numpy.random.Generator(PCG64(seed))``. ``"sobol"`` (scrambled Sobol' points) or ``"lhs"``
    (a Latin hypercube), or correlated inputs: one point of the unit hypercube per member, one
    coordinate per sampled path (a Gaussian copula for the correlation), mapped through each
    distribution's inverse CDF. The ``function`` specs are evaluated after every other one, in
    their order. A Sobol' ``n`` that is not a power of two is kept, with a warning.
    """
    _check_count(n, seed)
    check_sampling(sampling)
    spec = inputs(scene, distributions)
    rng = np.random.default_rng(seed)
    if sampling == "random" and spec.rank_correlation is None:
        out = {p: m.draw(rng, n) for p, m in spec.marginals.items()}
    else:
        u = unit_points(sampling, int(n), len(spec.marginals), rng, spec.rank_correlation)
        out = map_points(spec, u)
    return apply_functions(spec, out, rng, int(n))


def check_sampling(sampling) -> None:
    """``SceneError`` unless ``sampling`` is one of :data:`SAMPLINGS`."""
    if sampling not in SAMPLINGS:
        raise SceneError("sampling", f"the sampling design is one of {', '.join(SAMPLINGS)}; "
                                     f"got {sampling!r}")


def map_points(spec: Inputs, u: np.ndarray) -> dict:
    """Points ``u`` (n, d) of the open unit hypercube → sampled path → values (n,) [scene
    units], each column through its distribution's inverse CDF."""
    u = np.clip(u, _U_MIN, _U_MAX)
    return {p: m.ppf(u[:, j]) for j, (p, m) in enumerate(spec.marginals.items())}


def apply_functions(spec: Inputs, out: dict, rng, n: int) -> dict:
    """``out`` with the ``function`` specs evaluated (each on a copy of the values so far, and
    ``rng`` if it takes one), every path checked against the scene; in the table's order."""
    for path, (f, takes_rng) in spec.functions.items():
        view = {p: v.copy() for p, v in out.items()}
        vals = f(view, rng) if takes_rng else f(view)
        try:
            arr = np.broadcast_to(np.asarray(vals, float), (n,)).copy()
        except (TypeError, ValueError):
            raise SceneError(f"{path}.function", f"the function must return {n} numbers (or one), "
                                                 f"got {np.shape(vals)}") from None
        out[path] = arr
    for path in out:
        _check_path(spec.scene, path, out[path][0])
    return {p: out[p] for p in spec.order}


def unit_points(sampling: str, n: int, d: int, rng, rank_correlation=None) -> np.ndarray:
    """``n`` points (n, d) of the unit hypercube for a design of :data:`SAMPLINGS`, with the
    requested Spearman rank correlation between columns (a Gaussian copula) if one is given."""
    from scipy.stats import qmc

    if d == 0:
        return np.empty((n, 0))
    if sampling == "random":
        return correlate(rng.standard_normal((n, d)), rank_correlation, normal=True)
    if sampling == "sobol":
        warn_sobol_count(n, "n")
        engine = _qmc_engine(qmc.Sobol, d, rng, scramble=True)
    else:
        engine = _qmc_engine(qmc.LatinHypercube, d, rng)
    return correlate(design_points(engine, n), rank_correlation)


def design_points(engine, n: int) -> np.ndarray:
    """The next ``n`` points of a :mod:`scipy.stats.qmc` engine (a Sobol' count that is not a
    power of two is warned about by the caller, once)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*balance properties of Sobol")
        return engine.random(n)


def correlate(points: np.ndarray, rank_correlation=None, normal: bool = False) -> np.ndarray:
    """Points of the unit hypercube (or, with ``normal``, standard normal scores) with the
    requested Spearman rank correlation between columns, by a Gaussian copula (each row on its
    own); unchanged unit points where ``rank_correlation`` is ``None``."""
    from scipy.special import ndtr, ndtri

    if rank_correlation is None and not normal:
        return points
    z = points if normal else ndtri(np.clip(points, _U_MIN, _U_MAX))
    if rank_correlation is not None:
        z = z @ np.linalg.cholesky(normal_scores(rank_correlation)).T
    return ndtr(z)


def _qmc_engine(cls, d: int, rng, **kw):
    """A :mod:`scipy.stats.qmc` engine seeded from ``rng`` (keyword ``rng`` since SciPy 1.15,
    ``seed`` before)."""
    try:
        return cls(d, rng=rng, **kw)
    except TypeError:
        return cls(d, seed=rng, **kw)


def warn_sobol_count(n: int, what: str) -> None:
    """Warn that a Sobol' sample of ``n`` points (the argument ``what``) is not a power of two:
    the first ``n`` points of the sequence are used, as asked, without its balance."""
    if n & (n - 1):
        up = 1 << (n - 1).bit_length()
        warnings.warn(f"{what} = {n} is not a power of two: the first {n} points of a scrambled "
                      f"Sobol' sequence are used as asked, but only a power of two keeps its "
                      f"balance (and its faster convergence); use {what} = {up // 2} or {up}",
                      UserWarning, stacklevel=3)


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
