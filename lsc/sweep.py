"""``lsc.sweep``: one scene, many parameter values, every scalar metric as arrays.

Parameters are given by dotted scene paths (``"vehicles.0.speed"``,
``"contacts.0.unloading.restitution"``) mapped to equal-length arrays (or, with ``grid=True``, to
axes of a grid). Every member is validated exactly as a scene would be: a member that is invalid
or whose physics cannot be completed gets its reason in ``status`` and NaN metrics, and the other
members are still returned.

The sweep knows no backend: it resolves one (:func:`lsc.api.resolve`, ``auto`` preferring a
batch path for a batch) and reads its declaration (:mod:`lsc.solvers.base`). Where the
backend's batch path declares everything the scene uses, takes the options given and every swept
path maps onto the model's numbers (:func:`lsc.parameters.batch_params`), all valid members go
to its ``solve_batch`` at once; otherwise (a sweep over solver settings, a path the batch cannot
set, a backend with no batch path) the members are solved one by one, each with its own
settings.
"""

from __future__ import annotations

import math
import numbers
import time
from dataclasses import dataclass, field

from pathlib import Path

import numpy as np

from .errors import SceneError, SimulationError
from .model import HybridModel
from .result import METRICS
from .scene import Scene, UnloadingStiffness
from . import parameters, solvers

__all__ = ["sweep", "SweepResult", "MAX_MEMBERS", "check_keywords"]

#: Most members of one sweep (a grid counts its product): the batch paths hold a few hundred
#: bytes per member at once, so this bounds a sweep's memory to a few GiB. Split a larger study.
MAX_MEMBERS = 10_000_000


def check_keywords(function: str, options: dict, own) -> None:
    """Refuse keywords of ``function`` that are neither its own (``own``) nor an option of some
    backend (``rtol``, ``dt``, ...): a ``SceneError`` whose path is the keyword, listing what is
    accepted. (Options that apply to another backend than the one used are refused by it.)"""
    from .solvers import METHODS, options_of

    solver = sorted(set().union(*(options_of(m) for m in METHODS)) - set(own))
    for name in options:
        if name not in solver:
            raise SceneError(str(name), f"{function}() got an unknown keyword {name!r}; it "
                             f"accepts {', '.join(own)} and the solver options "
                             f"{', '.join(solver)}")


def check_members(n: int, what: str) -> None:
    """Refuse a study of more than :data:`MAX_MEMBERS` members up front (``SceneError`` on
    ``what``, the argument that sets ``n``)."""
    if n > MAX_MEMBERS:
        raise SceneError(what, f"{n} members are more than the {MAX_MEMBERS} one study solves "
                               "(every member's metrics are held in memory at once): split it "
                               "into smaller ones")


@dataclass(eq=False)
class SweepResult:
    """Metrics of every member of a sweep, in the scene's unit system.

    ``params``: swept path → values (n,) [scene units]. ``metrics``: name → array, (n,) per scene,
    (n, N) per vehicle, (n, K) per contact (also reachable as attributes: ``s.delta_v``).
    ``status``: ``"ok"`` or the member's error message. ``shape``: the grid shape (``(n,)`` for
    a plain sweep). ``method``: the backend used. ``stats``: wall time [s], members, failures.
    """

    scene: Scene
    params: dict
    metrics: dict
    status: np.ndarray
    method: str
    shape: tuple
    stats: dict = field(default_factory=dict)

    def __getattr__(self, name):
        metrics = self.__dict__.get("metrics", {})
        if name in metrics:
            return metrics[name]
        raise AttributeError(name)

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask of the members that were solved."""
        return self.status == "ok"

    @property
    def units(self) -> dict[str, str]:
        """Unit of every metric (pint spelling)."""
        return {name: self.scene.unit(kind) for name, (kind, _) in METRICS.items()}

    def columns(self, metrics=None) -> dict[str, np.ndarray]:
        """Flat named columns (params, then metrics per vehicle/contact, then status) for CSV;
        ``metrics`` selects some metrics (default: all)."""
        cols = {}
        for path, vals in self.params.items():
            cols[path] = vals
        names = [v.name for v in self.scene.vehicles]
        for name, (kind, per) in METRICS.items():
            if metrics is not None and name not in metrics:
                continue
            arr = self.metrics[name]
            unit = self.scene.unit(kind)
            suffix = f" ({unit})" if unit else ""
            if per == "vehicle":
                for i, n in enumerate(names):
                    cols[f"{name}[{n}]{suffix}"] = arr[:, i]
            elif per == "contact":
                for k in range(arr.shape[1]):
                    cols[f"{name}[{k}]{suffix}"] = arr[:, k]
            else:
                cols[f"{name}{suffix}"] = arr
        cols["status"] = self.status
        return cols

    def to_dataframe(self):
        """One row per member: the swept values, every metric and the status, as a pandas
        DataFrame (:func:`lsc.frames.sweep_frame`)."""
        from .frames import sweep_frame
        return sweep_frame(self)

    def to_xarray(self):
        """A grid sweep as an xarray Dataset, one dimension per swept path
        (:func:`lsc.frames.sweep_xarray`)."""
        from .frames import sweep_xarray
        return sweep_xarray(self)

    def _repr_html_(self) -> str:
        from .html import sweep_html
        return sweep_html(self)

    def to_csv(self, path, metrics=None, *, overwrite: bool = False) -> Path:
        """Write :meth:`columns` as a CSV file with a header row (shortest round-trip decimals),
        whole or not at all; an existing file is refused (:class:`lsc.outputs.OutputExistsError`)
        unless ``overwrite``."""
        import csv

        from .outputs import write_file

        cols = self.columns(metrics)
        keys = list(cols)
        status = cols.pop("status")
        table = np.column_stack([np.asarray(c, float) for c in cols.values()]).tolist()
        fmt = ",".join(["%r"] * len(cols)) + ",%s\n"

        def write(file):
            with open(file, "w", newline="") as fh:
                csv.writer(fh, quoting=csv.QUOTE_MINIMAL).writerow(keys)
                fh.writelines(fmt % (*row, _csv_text(st)) for row, st in zip(table, status))
        return write_file(path, write, overwrite=overwrite)


def _csv_text(text: str) -> str:
    """A CSV field: quoted (with doubled quotes) when it holds a comma, a quote or a newline."""
    if any(ch in text for ch in ',"\n\r'):
        return '"' + text.replace('"', '""') + '"'
    return text


# --------------------------------------------------------------------------- parameters
def _axes(scene: Scene, params: dict, grid: bool):
    """Swept values per path as float arrays (n,) in scene units, and the sweep shape."""
    if not isinstance(params, dict) or not params:
        raise SceneError("params", "a sweep needs a dict of dotted scene paths to arrays of values")
    raw = {}
    for path, vals in params.items():
        _check_path(scene, str(path))
        raw[path] = _to_numbers(scene, path, _sweep_values(str(path), vals))
    if grid:
        check_members(math.prod(a.size for a in raw.values()), "params")
        mesh = np.meshgrid(*raw.values(), indexing="ij")
        shape = mesh[0].shape
        return {p: m.reshape(-1) for p, m in zip(raw, mesh)}, shape
    sizes = {p: a.size for p, a in raw.items()}
    if len(set(sizes.values())) != 1:
        raise SceneError("params", f"sweep arrays must have equal lengths (or pass grid=True), got "
                         + ", ".join(f"{p}: {n}" for p, n in sizes.items()))
    n = next(iter(sizes.values()))
    return raw, (n,)


def _check_path(scene: Scene, path: str) -> None:
    """Raise the loader's error if ``path`` names no field of the scene (checked on a probe)."""
    try:
        scene.with_values({path: 1.0})
    except SceneError as e:
        if "unknown key" in str(e) or "no such field" in str(e):
            raise SceneError(path, str(e.message if hasattr(e, "message") else e)) from None


def _sweep_values(path: str, vals) -> np.ndarray:
    """The values of one swept path as a 1-D array: floats, or objects (floats and strings with
    units). A generator or iterator is refused (it may not end, and it is used up once): give a
    list, a tuple or an array; so is a boolean (not a number) and anything but a real number or a
    string."""
    if (isinstance(vals, (str, bytes, dict, set, frozenset)) or hasattr(vals, "__next__")
            or not (hasattr(vals, "__len__") or hasattr(vals, "__array__"))):
        raise SceneError(path, "sweep values must be a list, tuple or 1-D array of numbers (or "
                               f"strings with units), got a {type(vals).__name__}"
                         + (" (make it a list first: list(...))" if hasattr(vals, "__next__")
                            else ""))
    if isinstance(vals, np.ndarray) and vals.dtype.kind in "iuf":
        arr = vals
    else:
        arr = np.asarray(vals, dtype=object)
        if arr.ndim == 1:
            for v in arr:
                if isinstance(v, (bool, np.bool_)) or not isinstance(v, (str, numbers.Real)):
                    raise SceneError(path, "sweep values must be numbers (or strings with "
                                           f"units), got {v!r}")
            if not any(isinstance(v, str) for v in arr):
                arr = arr.astype(float)
    if arr.ndim != 1 or arr.size == 0:
        raise SceneError(path, "sweep values must be a non-empty 1-D list or array")
    check_members(arr.size, path)
    return arr


def _to_numbers(scene: Scene, path: str, arr: np.ndarray) -> np.ndarray:
    """Values with units (strings) converted to scene units through the loader, once per value."""
    if arr.dtype != object:
        return arr.astype(float)
    out = np.empty(arr.size)
    cache = {}
    for j, v in enumerate(arr):
        if not isinstance(v, str):
            out[j] = float(v)
            continue
        if v not in cache:
            probe = scene.with_values({path: v})
            cache[v] = parameters.read_back(probe, path)
        out[j] = cache[v]
    return out


def _validate(scene: Scene, values: dict, n: int) -> np.ndarray:
    """Status per member: ``"ok"`` or the loader's error for that member.

    Numeric fields are checked against the loader's bounds by probing each path's extremes
    (every bound the loader applies to one field is an interval); cross-field rules (closing
    speeds, unloading stiffer than loading) are screened per member. Any member a screen flags is
    loaded in full, so its message is exactly the loader's.
    """
    status = np.full(n, "ok", dtype=object)
    suspect = np.zeros(n, bool)
    for path, vals in values.items():
        bad = ~np.isfinite(vals)
        lo, hi = _valid_interval(scene, path, np.unique(vals[~bad]))
        suspect |= bad | (vals < lo) | (vals > hi)
    # closing speeds (no brakes): the rear vehicle of some pair must be faster
    speeds = np.tile(scene.speeds, (n, 1))
    for path, vals in values.items():
        parts = path.replace("[", ".").replace("]", "").split(".")
        if parts[0] == "vehicles" and len(parts) == 3 and parts[2] == "speed":
            speeds[:, int(parts[1])] = vals
    if not any(v.brake is not None for v in scene.vehicles):
        suspect |= ~np.any(speeds[:, :-1] - speeds[:, 1:] > 0, axis=1)
    # unloading stiffer than a linear loading line
    for k, c in enumerate(scene.contacts):
        ks = values.get(f"contacts.{k}.loading.stiffness")
        su = values.get(f"contacts.{k}.unloading.stiffness")
        if (ks is not None or su is not None) and isinstance(c.law.unloading, UnloadingStiffness):
            kk = ks if ks is not None else c.law.loading.end_slope
            ss = su if su is not None else c.law.unloading.stiffness
            suspect |= np.asarray(ss < kk)
    cache = {}
    for j in np.nonzero(suspect)[0]:
        member = {p: float(v[j]) for p, v in values.items()}
        key = tuple(member.items())
        if key not in cache:
            try:
                scene.with_values(member)
                cache[key] = "ok"
            except SceneError as e:
                cache[key] = f"SceneError: {e}"
        status[j] = cache[key]
    return status


def _valid_interval(scene: Scene, path: str, u: np.ndarray) -> tuple[float, float]:
    """The range ``[lo, hi]`` of sorted values ``u`` the loader accepts for ``path`` alone.

    Every bound the loader puts on one numeric field is an interval, so bisection from an
    accepted anchor (the value nearest the base scene's own) finds its ends in O(log n) loads.
    """
    if u.size == 0:
        return np.inf, -np.inf

    def accepted(j: int) -> bool:
        try:
            scene.with_values({path: float(u[j])})
            return True
        except SceneError:
            return False

    try:
        anchor = int(np.argmin(np.abs(u - parameters.read_back(scene, path))))
    except (SceneError, AttributeError, IndexError, ValueError, KeyError):
        anchor = u.size // 2
    if not accepted(anchor):
        return np.inf, -np.inf  # no anchor: every member is checked in full
    if accepted(0):
        first = 0
    else:
        a, b = 0, anchor  # u[a] rejected, u[b] accepted
        while b - a > 1:
            mid = (a + b) // 2
            a, b = (a, mid) if accepted(mid) else (mid, b)
        first = b
    if accepted(u.size - 1):
        last = u.size - 1
    else:
        a, b = anchor, u.size - 1  # u[a] accepted, u[b] rejected
        while b - a > 1:
            mid = (a + b) // 2
            a, b = (mid, b) if accepted(mid) else (a, mid)
        last = a
    return float(u[first]), float(u[last])


def _empty_metrics(scene: Scene, n: int) -> dict:
    N, K = scene.n_vehicles, len(scene.contacts)
    shape = {"vehicle": (n, N), "contact": (n, K), "scene": (n,)}
    return {name: np.full(shape[per], np.nan) for name, (_, per) in METRICS.items()}


def _progress(total: int, progress):
    from tqdm.auto import tqdm

    return tqdm(total=total, disable=(None if progress is None else not progress),
                unit="scene", desc="lsc sweep", leave=False)


# --------------------------------------------------------------------------- the sweep
def sweep(scene, params: dict, *, method: str | None = None, grid: bool = False, progress=None,
          chunk: int | None = None, workers: int | None = None, **options) -> SweepResult:
    """Solve ``scene`` for every member of a parameter sweep.

    Parameters
    ----------
    scene : dict, path or Scene
        The base scene.
    params : dict
        Dotted scene path → values (numbers in the scene's units, or strings with units), all of
        one length; with ``grid=True`` each array is an axis and the sweep covers their product.
    method : str, optional
        Any ``lsc.solve`` method; by default the scene's own (``"auto"``: the cheapest exact
        backend, preferring one with a batch path for the scene).
    progress : bool or None
        Show a progress bar (``None``: only when stderr is a terminal).
    chunk, workers : int, optional
        Batch controls (:data:`lsc.solvers.base.CONTROLS`) of backends whose batch path takes
        them (the batched integrator): most members in one batch call, and batch calls run at
        once. Given to a backend whose batch path does not take them, the members are solved
        one by one. Unset: the backend's defaults.
    **options
        Solver options as for :func:`lsc.solve` (``rtol``, ``dt``, ...).

    Returns
    -------
    SweepResult
    """
    start = time.perf_counter()
    check_keywords("sweep", options, ("method", "grid", "progress", "chunk", "workers"))
    controls = {k: v for k, v in (("chunk", chunk), ("workers", workers)) if v is not None}
    for name, value in controls.items():
        _check_count(name, value)
    if not isinstance(grid, (bool, np.bool_)):
        raise SceneError("grid", f"grid must be True or False, got {grid!r}")
    base = Scene.load(scene)
    values, shape = _axes(base, params, grid)
    n = int(np.prod(shape))
    from .api import resolve

    model = HybridModel(base)
    name, opts = resolve(base, method, options, model=model, members=n)
    status = _validate(base, values, n)
    metrics = _empty_metrics(base, n)
    decl = solvers.backend(name)
    batch_opts = {**{k: v for k, v in opts.items() if k != "n_samples"}, **controls}
    if _batch_applies(decl, model, values, batch_opts):
        _batch(decl, model, values, batch_opts, status, metrics, progress)
    else:
        name = resolve(base, method, options, model=model)[0]  # what each member's solve picks
        _loop(base, values, method, options, status, metrics, progress)
    wall = time.perf_counter() - start
    return SweepResult(base, values, metrics, status, name, tuple(shape),
                       {"wall_time": wall, "members": n, "failed": int(np.sum(status != "ok"))})


def _check_count(name: str, value) -> None:
    """A positive whole number of ``sweep`` (``chunk``, ``workers``), or a ``SceneError``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or value < 1:
        raise SceneError(name, f"{name} must be a positive integer, got {value!r}")


def _batch_applies(decl, model: HybridModel, values: dict, options: dict) -> bool:
    """True when backend ``decl``'s batch path solves the sweep: it declares everything the
    scene uses, its modules are installed, every swept path maps onto the model's numbers and
    it takes every option (and batch control) given (:func:`lsc.parameters.batch_params`, tried
    on the first member)."""
    return (not decl.missing(model, batch=True) and decl.available()
            and parameters.batch_params(model, {p: v[:1] for p, v in values.items()}) is not None
            and set(options) <= set(decl.batch_options))


def _batch(decl, model, values, options, status, metrics, progress) -> None:
    """The valid members at once through backend ``decl``'s ``solve_batch``: their metrics,
    and their status (``"ok"`` or the single solve's message)."""
    run = np.flatnonzero(status == "ok")
    if run.size == 0:
        return
    bar = _progress(run.size, progress)
    try:
        out = decl.solve_batch(model, {p: v[run] for p, v in values.items()},
                               progress=bar.update, **options)
    finally:
        bar.close()
    for name in metrics:
        metrics[name][run] = out["metrics"][name]
    status[run] = out["status"]


def _loop(base, values, method, options, status, metrics, progress):
    """Members one by one, as ``lsc.solve`` would do each (re-validated by the loader, with the
    member's own solver settings)."""
    n = status.size
    bar = _progress(n, progress)
    try:
        for j in range(n):
            bar.update(1)
            if status[j] == "ok":
                _solve_member(base, values, j, method, options, status, metrics)
    finally:
        bar.close()


def _solve_member(base, values, j, method, options, status, metrics) -> None:
    """Member ``j`` solved alone, as ``lsc.solve`` would (re-validated by the loader, with its
    own solver settings): its metrics, or its error in ``status``."""
    from .api import resolve

    member = {p: float(v[j]) for p, v in values.items()}
    try:
        sc = base.with_values(member)
        backend, opts = resolve(sc, method, {"n_samples": 2, **options})
        r = solvers.run(HybridModel(sc), backend, opts)
    except (SceneError, SimulationError) as e:
        status[j] = f"{type(e).__name__}: {e}"
        for name in metrics:
            metrics[name][j] = np.nan
        return
    status[j] = "ok"
    for name in metrics:
        metrics[name][j] = getattr(r, name)
