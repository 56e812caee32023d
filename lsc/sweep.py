"""``lsc.sweep``: one scene, many parameter values, every scalar metric as arrays.

Parameters are given by dotted scene paths (``"vehicles.0.speed"``,
``"contacts.0.unloading.restitution"``) mapped to equal-length arrays (or, with ``grid=True``, to
axes of a grid). Every member is validated exactly as a scene would be: a member that is invalid
or whose physics cannot be completed gets its reason in ``status`` and NaN metrics, and the other
members are still returned.

Backends: ``closed-form`` is one vectorised NumPy evaluation; ``exact`` is one vectorised NumPy
stepper over the batch; ``diffrax`` is one ``jax.vmap``-ed compiled solve per chunk of members
(members that end at different times simply stop while the others go on); every other method
loops over members. A sweep over solver settings (``solver.rtol``, ...) or over a path the batch
paths cannot set loops, so that each member uses its own settings.
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

__all__ = ["sweep", "SweepResult", "CHUNK", "MAX_MEMBERS", "check_keywords"]

#: Most members in one compiled ``diffrax`` call (a smaller sweep is padded to a power of two):
#: small, because in a vmapped loop every member of a call waits for its slowest.
CHUNK = 1024

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
          chunk: int = CHUNK, workers: int | None = None, **options) -> SweepResult:
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
        backend for the base scene).
    progress : bool or None
        Show a progress bar (``None``: only when stderr is a terminal).
    chunk : int
        ``diffrax`` batches: most members in one compiled vmapped call (memory and the time
        the slowest member of a chunk holds the others are bounded by it; the progress bar
        advances per chunk).
    workers : int, optional
        ``diffrax`` batches: chunks solved at once, in threads (default: the CPU count).
    **options
        Solver options as for :func:`lsc.solve` (``rtol``, ``dt``, ...).

    Returns
    -------
    SweepResult
    """
    start = time.perf_counter()
    check_keywords("sweep", options, ("method", "grid", "progress", "chunk", "workers"))
    if workers is None:
        import os

        workers = os.cpu_count() or 1
    _check_count("chunk", chunk)
    _check_count("workers", workers)
    if not isinstance(grid, (bool, np.bool_)):
        raise SceneError("grid", f"grid must be True or False, got {grid!r}")
    base = Scene.load(scene)
    values, shape = _axes(base, params, grid)
    n = int(np.prod(shape))
    from .api import resolve

    backend, opts = resolve(base, method, options)
    status = _validate(base, values, n)
    metrics = _empty_metrics(base, n)
    setters = {p: parameters.setter(base, p) for p in values}
    fast = all(s is not None for s in setters.values())
    ok = status == "ok"
    if backend == "closed-form" and fast:
        _closed_form_batch(base, values, setters, ok, metrics)
    elif (backend == "exact" and fast and not set(opts) - {"n_samples"}
          and not any(v.brake is not None for v in base.vehicles)
          and not any(c.failure is not None and c.failure.post_failure is not None
                      for c in base.contacts)):
        # (the vectorised exact stepper has no friction and no post-failure curve: such scenes
        # are solved one by one)
        _exact_batch(base, values, setters, ok, metrics, status)
    elif backend == "diffrax" and fast and _have_diffrax():
        _diffrax_batch(base, values, setters, ok, metrics, status, opts, progress, chunk,
                       workers)
    else:
        _loop(base, values, method, options, status, metrics, progress)
    wall = time.perf_counter() - start
    return SweepResult(base, values, metrics, status, backend, tuple(shape),
                       {"wall_time": wall, "members": n, "failed": int(np.sum(status != "ok"))})


def _check_count(name: str, value) -> None:
    """A positive whole number of ``sweep`` (``chunk``, ``workers``), or a ``SceneError``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or value < 1:
        raise SceneError(name, f"{name} must be a positive integer, got {value!r}")


def _closed_form_batch(base, values, setters, ok, metrics):
    """Every member at once through the vectorised closed form."""
    from .solvers import closed_form

    n = ok.size
    p = parameters.batched(HybridModel(base).params, n)
    for path, vals in values.items():
        setters[path](p, vals)
    c = p["contacts"][0]
    k = c["ls"][:, 0]
    e = c["e"] if "e" in c else np.sqrt(k / c["su"])
    with np.errstate(invalid="ignore", divide="ignore"):
        fail = base.contacts[0].failure
        out = closed_form.metrics(p["m"][:, 0], p["m"][:, 1], p["v0"][:, 0], p["v0"][:, 1], k, e,
                                  p["gap"][:, 0], base.g, fail.force if fail else np.nan)
    for name in metrics:
        arr = np.asarray(out[name], float)
        if metrics[name].ndim == 2 and arr.ndim == 1:
            arr = arr[:, None]
        metrics[name][ok] = arr[ok]


def _exact_batch(base, values, setters, ok, metrics, status):
    """Every member at once through the exact backend's vectorised stepper."""
    from .solvers import exact
    from .scene import UnloadingTable

    n = ok.size
    model = HybridModel(base)
    p = parameters.batched(model.params, n)
    for path, vals in values.items():
        setters[path](p, vals)
    law, c = model.laws[0], p["contacts"][0]
    P = {"m1": p["m"][:, 0], "m2": p["m"][:, 1], "v1": p["v0"][:, 0], "v2": p["v0"][:, 1],
         "gap": p["gap"][:, 0], "g": np.full(n, base.g)}
    if law.n_load == 1 and law.extends and base.contacts[0].law.loading.f[0] == 0:
        P["stiffness"] = c["ls"][:, 0]
    else:
        P["load_d"], P["load_f"] = c["ld"][:, : law.n_load], c["lf"][:, : law.n_load]
        if law.extends:
            P["load_end_slope"] = c["ls"][:, law.n_load - 1]
    unl = base.contacts[0].law.unloading
    if law.unload_kind == "restitution":
        P["e"] = c["e"]
    elif law.unload_kind == "stiffness":
        P["unload_stiffness"] = c["su"]
    else:
        assert isinstance(unl, UnloadingTable)
        P["unload_d"] = np.tile(np.asarray(unl.d, float), (n, 1))
        P["unload_f"] = np.tile(np.asarray(unl.f, float), (n, 1))
    fail = base.contacts[0].failure
    if fail is not None:
        P["failure_force"] = np.full(n, fail.force)
    run = np.nonzero(ok)[0]
    if run.size == 0:
        return
    out = exact.solve_batch({k: v[run] for k, v in P.items()})
    good = out["status"] == 0
    for name in metrics:
        arr = np.asarray(out[name], float)
        if metrics[name].ndim == 2 and arr.ndim == 1:
            arr = arr[:, None]
        metrics[name][run[good]] = arr[good]
    # A member the batch could not complete is solved alone: its status is then the single
    # solve's own message (with the contact and the time), word for word.
    for j in run[~good]:
        _solve_member(base, values, j, "exact", {}, status, metrics)


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
