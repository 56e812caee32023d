"""``lsc.sweep``: one scene, many parameter values, every scalar metric as arrays.

Parameters are given by dotted scene paths (``"vehicles.0.speed"``,
``"contacts.0.unloading.restitution"``) mapped to equal-length arrays (or, with ``grid=True``, to
axes of a grid). Every member is validated exactly as a scene would be: a member that is invalid
or whose physics cannot be completed gets its reason in ``status`` and NaN metrics, and the other
members are still returned.

The sweep knows no backend: it resolves one (:func:`lsc.api.resolve`, ``auto`` preferring a
batch path for a batch) and reads its declaration (:mod:`lsc.solvers.base`). Where the
backend's batch path declares everything the scene uses, takes the options given and every swept
path maps onto the model's numbers (:func:`lsc.parameters.batch_params`), each chunk's valid
members go to its ``solve_batch`` at once; otherwise (a sweep over solver settings, a path the
batch cannot set, a backend with no batch path) the members are solved one by one, each with
its own settings.

The members are solved in chunks (:mod:`lsc.chunks`), in this process or on an executor (a
process pool, a Dask cluster; ``workers=N`` for a backend whose batch path does not take it as
its own threads: a pool of N processes), and kept in memory (:class:`SweepResult`) or written
to a Parquet file as they come (``out=``, :class:`lsc.parquet.SweepFile`): memory then holds a
few chunks, whatever the number of members.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from pathlib import Path

import numpy as np

from .errors import SceneError
from .model import HybridModel
from .result import METRICS
from .scene import Scene
from . import parameters, solvers
from .members import Arrays, members as _members  # noqa: F401  (Arrays: lsc.analysis's)

__all__ = ["sweep", "SweepResult", "MAX_MEMBERS", "check_keywords", "study"]

#: Most members of one sweep held in memory (a grid counts its product): a few hundred bytes per
#: member, so this bounds a sweep's memory to a few GiB. A sweep written to Parquet (``out=``)
#: holds one chunk at a time and has no such bound.
MAX_MEMBERS = 10_000_000


def check_keywords(function: str, options: dict, own) -> None:
    """Refuse keywords of ``function`` that are neither its own (``own``) nor an option of some
    backend (``rtol``, ``dt``, ...): a ``SceneError`` whose path is the keyword, listing what is
    accepted. (Options that apply to another backend than the one used are refused by it.)"""
    # (every option some backend takes, without importing every backend's module)
    solver = sorted(solvers.ALL_OPTIONS - set(own))
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
    a plain sweep). ``method``: the backend used. ``stats``: wall time [s], members, failures,
    members with warnings. ``warnings``: each member's ``Result.warnings`` (a tuple of
    strings, empty where none: what its numbers owe to rounding or to a model beside the plain
    law), whatever path solved it.
    """

    scene: Scene
    params: dict
    metrics: dict
    status: np.ndarray
    method: str
    shape: tuple
    stats: dict = field(default_factory=dict)
    warnings: np.ndarray = None

    def __post_init__(self):
        if self.warnings is None:
            from .solvers.base import warning_array
            self.warnings = warning_array([()] * len(self.status))

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
        """Flat named columns (params, then metrics per vehicle/contact, then status and
        warnings, each member's joined by newlines) for CSV; ``metrics`` selects some metrics
        (default: all)."""
        cols = {}
        for path, vals in self.params.items():
            cols[path] = vals
        names = [v.name for v in self.scene.vehicles]
        for name, (kind, per) in METRICS.items():
            if (metrics is not None and name not in metrics) or name not in self.metrics:
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
        cols["warnings"] = warning_text(self.warnings)
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
        status, notes = cols.pop("status"), cols.pop("warnings")
        table = np.column_stack([np.asarray(c, float) for c in cols.values()]).tolist()
        fmt = ",".join(["%r"] * len(cols)) + ",%s,%s\n"

        def write(file):
            with open(file, "w", newline="") as fh:
                csv.writer(fh, quoting=csv.QUOTE_MINIMAL).writerow(keys)
                fh.writelines(fmt % (*row, _csv_text(st), _csv_text(w))
                              for row, st, w in zip(table, status, notes))
        return write_file(path, write, overwrite=overwrite)


def warning_text(warnings) -> np.ndarray:
    """(n,) object array of str: each member's warnings joined by newlines ("" where none), as
    CSV, DataFrames and Parquet files hold them."""
    return np.array(["\n".join(w) for w in warnings], dtype=object)


def _csv_text(text: str) -> str:
    """A CSV field: quoted (with doubled quotes) when it holds a comma, a quote or a newline."""
    if any(ch in text for ch in ',"\n\r'):
        return '"' + text.replace('"', '""') + '"'
    return text


class _NoBar:
    """The progress bar of a study that shows none (``progress=False``: tqdm not imported)."""

    def update(self, k: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


def _progress(total: int, progress):
    """A tqdm bar over ``total`` members: shown if ``progress``, never if False, and with
    ``None`` where the output is a terminal."""
    if progress is False:
        return _NoBar()
    from tqdm.auto import tqdm

    return tqdm(total=total, disable=(None if progress is None else not progress),
                unit="scene", desc="lsc sweep", leave=False)


# --------------------------------------------------------------------------- the sweep
def sweep(scene, params: dict, *, method: str | None = None, grid: bool = False, progress=None,
          chunk: int | None = None, workers: int | None = None, metrics=None, out=None,
          overwrite: bool = False, executor=None, task_size: int | None = None,
          **options):
    """Solve ``scene`` for every member of a parameter sweep, in chunks.

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
        them (the batched integrator): most members in one of its batch calls, and batch calls
        run at once (threads) within one task. ``chunk`` given to a backend whose batch path
        does not take it: the members are solved one by one. ``workers`` given to a backend
        whose batch path does not take it (the exact and exact-chain batches, the backends
        with no batch path): the chunks are solved by that many processes (a
        ``ProcessPoolExecutor``; 1: this process), the same numbers member for member; not
        with ``executor``. Unset: the backend's defaults, this process.
    metrics : str or sequence of str, optional
        The metrics kept (names of :data:`lsc.result.METRICS`; default: all).
    out : path, optional
        Write the members to this Parquet file as they are solved (one row group per task;
        :class:`lsc.parquet.SweepFile` is returned and no member is held in memory). Refused if
        the file exists, unless ``overwrite``; whole or not at all. Needs pyarrow.
    executor : concurrent.futures.Executor, optional
        Runs the tasks through its ``submit``: a ``ProcessPoolExecutor``, a
        ``dask.distributed.Client``, ...; default: this process. The results are the same,
        member for member, whatever the executor and the task size.
    task_size : int, optional
        Members per task (one ``solve_batch`` call); default: :func:`lsc.chunks.task_size`.
    **options
        Solver options as for :func:`lsc.solve` (``rtol``, ``dt``, ...).

    Returns
    -------
    SweepResult, or SweepFile with ``out``
    """
    check_keywords("sweep", options, ("method", "grid", "progress", "chunk", "workers",
                                      "metrics", "out", "overwrite", "executor", "task_size"))
    controls = {k: v for k, v in (("chunk", chunk), ("workers", workers)) if v is not None}
    for name, value in {**controls, "task_size": task_size}.items():
        if value is not None:
            _check_count(name, value)
    if not isinstance(grid, (bool, np.bool_)):
        raise SceneError("grid", f"grid must be True or False, got {grid!r}")
    base = Scene.load(scene)
    members, shape = _members(base, params, grid, in_memory=out is None)
    return study(base, members, shape, method=method, options=options, controls=controls,
                 metrics=metrics, out=out, overwrite=overwrite, executor=executor,
                 task_size=task_size, progress=progress)


def study(base: Scene, members, shape: tuple, *, method, options: dict, controls: dict,
          metrics, out, overwrite: bool, executor, task_size, progress):
    """Solve ``members`` (:class:`Arrays`, :class:`Grid` or a sampler: ``n`` and
    ``chunk(start, stop)``) of scene ``base`` in tasks (see :func:`sweep`)."""
    from .api import resolve
    from .chunks import executor_from, run_tasks

    start = time.perf_counter()
    names = _metric_names(metrics)
    _check_executor(executor)
    n = members.n
    model = HybridModel(base)
    name, opts = resolve(base, method, options, model=model, members=n)
    decl = solvers.backend(name)
    controls, processes = _processes(decl, controls, executor)
    batch_opts = {**{k: v for k, v in opts.items() if k != "n_samples"}, **controls}
    batch = _batch_applies(decl, model, members.chunk(0, 1), batch_opts)
    if not batch:
        name = resolve(base, method, options, model=model)[0]  # what each member's solve picks
    bar = _progress(n, progress)
    try:
        with executor_from(processes) as pool:
            executor = pool if pool is not None else executor
            tasks = _tasks(base, members, (decl.name, batch_opts) if batch else (method, options),
                           batch, names, task_size, executor)
            if out is None:
                sink = _Memory(base, n, names)
                run_tasks(tasks, sink, executor=executor, progress=bar.update)
            else:
                sink = _write_parquet(out, overwrite, tasks, base, name, shape, executor, bar)
    finally:
        bar.close()
    stats = {"wall_time": time.perf_counter() - start, "members": n}
    if out is None:
        stats["failed"] = int(np.sum(sink.status != "ok"))
        stats["warned"] = sum(1 for w in sink.warnings if w)
        return SweepResult(base, members.chunk(0, n), sink.metrics, sink.status, name,
                           tuple(shape), stats, sink.warnings)
    from .parquet import SweepFile
    stats["failed"] = sum(sink.reasons.values())
    stats["warned"] = sink.warned
    return SweepFile(Path(out), base, tuple(members.chunk(0, 1)), names, name, tuple(shape),
                     stats, dict(sink.reasons))


def _tasks(base, members, solver: tuple, batch: bool, names: tuple, size, executor):
    """``(start, Task)`` of every chunk, built lazily (a chunk's values only when it is due)."""
    from .chunks import Task, task_size

    n = members.n
    size = size or task_size(n, executor, batch)
    method, options = solver
    for a in range(0, n, size):
        yield a, Task(base, method, options, batch, members.chunk(a, min(n, a + size)), names)


class _Memory:
    """The consumer of :func:`lsc.chunks.run_tasks` that fills whole arrays (n members)."""

    def __init__(self, scene: Scene, n: int, names: tuple):
        from .chunks import empty_metrics
        from .solvers.base import warning_array

        self.metrics = empty_metrics(scene, n, names)
        self.status = np.full(n, "ok", dtype=object)
        self.warnings = warning_array([()] * n)

    def __call__(self, start: int, task, result: dict) -> None:
        stop = start + len(task)
        for name, arr in result["metrics"].items():
            self.metrics[name][start:stop] = arr
        self.status[start:stop] = result["status"]
        self.warnings[start:stop] = result["warnings"]


def _write_parquet(out, overwrite, tasks, base, name, shape, executor, bar):
    """Run ``tasks`` into the Parquet file ``out`` (whole or not at all: written under a
    temporary name, moved into place at the end); returns the sink (its counts)."""
    from .chunks import run_tasks
    from .outputs import write_file
    from .parquet import ParquetSink, require_pyarrow

    require_pyarrow("out")
    sinks = []

    def write(file):
        sink = ParquetSink(file, base, name, shape)
        sinks.append(sink)
        try:
            run_tasks(tasks, sink, executor=executor, progress=bar.update)
        finally:
            sink.close()

    write_file(out, write, overwrite=overwrite)
    return sinks[0]


def _metric_names(metrics) -> tuple:
    """The metrics kept: all of :data:`lsc.result.METRICS` (``None``), or those named."""
    if metrics is None:
        return tuple(METRICS)
    names = (metrics,) if isinstance(metrics, str) else tuple(metrics)
    for m in names:
        if m not in METRICS:
            raise SceneError("metrics", f"unknown metric {m!r}; the metrics are "
                                        f"{', '.join(METRICS)}")
    if not names:
        raise SceneError("metrics", "name at least one metric (or None: all)")
    return tuple(m for m in METRICS if m in names)


def _check_executor(executor) -> None:
    """``None`` or an object with a callable ``submit`` (a ``SceneError`` otherwise)."""
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise SceneError("executor", "executor must be a concurrent.futures.Executor (a "
                                     "ProcessPoolExecutor, a dask.distributed.Client: anything "
                                     f"with submit), or None; got {type(executor).__name__}")


def _check_count(name: str, value) -> None:
    """A positive whole number (``chunk``, ``workers``, ``task_size``), or a ``SceneError``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or value < 1:
        raise SceneError(name, f"{name} must be a positive integer, got {value!r}")


def _processes(decl, controls: dict, executor):
    """``(controls, processes)``: ``workers`` for a backend whose batch path does not take it is
    the number of processes solving the chunks (None or 1: this process), out of the controls;
    a ``SceneError`` beside an ``executor`` (which has its own workers)."""
    if "workers" not in controls or "workers" in decl.batch_options:
        return controls, None
    if executor is not None:
        raise SceneError("workers", f"workers sets the processes of this machine that solve "
                                    f"the chunks ({decl.name}); an executor runs them on the "
                                    f"workers it has: give one or the other")
    return {k: v for k, v in controls.items() if k != "workers"}, controls["workers"]


def _batch_applies(decl, model: HybridModel, values: dict, options: dict) -> bool:
    """True when backend ``decl``'s batch path solves the sweep: it declares everything the
    scene uses, its modules are installed, every swept path maps onto the model's numbers and
    it takes every option (and batch control) given (:func:`lsc.parameters.batch_params`, tried
    on the first member)."""
    return (not decl.missing(model, batch=True) and decl.available()
            and parameters.batch_params(model, values) is not None
            and set(options) <= set(decl.batch_options))
