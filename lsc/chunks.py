"""A study's members in chunks: the unit of work of :func:`lsc.sweep` and Monte Carlo.

A :class:`Task` is one chunk of members of one scene (dotted path → (m,) values in scene units)
with the backend and options that solve it; :func:`solve_task` validates the chunk's members
(exactly as the loader would each), solves the valid ones in one ``solve_batch`` call of the
backend (or one by one where the batch path does not apply) and returns the kept metrics and
every member's status. A task is a plain picklable value and :func:`solve_task` a module-level
function, so a chunk runs the same in this process, in a process pool or on a Dask worker;
every member's numbers depend on that member alone, never on the chunk it was solved in.

:func:`run_tasks` runs the chunks in order on any :class:`concurrent.futures.Executor` (through
``submit``; a ``dask.distributed.Client`` is one) or in this process, keeping at most
:func:`window` chunks in flight, and hands each chunk's result to a consumer as it comes, in
member order: memory is bounded by the chunk size, not by the number of members.
"""

from __future__ import annotations

import math
import os
from collections import deque
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from .errors import SceneError, SimulationError
from .model import HybridModel
from .result import METRICS
from .scene import GAP_RATIO, MAGNITUDES, Damping, Scene, UnloadingStiffness
from . import parameters, solvers
from .solvers.base import warning_array

__all__ = ["Task", "solve_task", "run_tasks", "task_size", "slots", "window", "is_dask",
           "executor_from", "MAX_TASK", "MIN_TASK", "DASK_RETRIES"]

#: Most members in one chunk of a batch path: its metrics take a few hundred bytes per member,
#: so a chunk holds tens of MB at most (and a chunk is long enough to dwarf a scheduler's
#: per-task overhead, about a millisecond for Dask).
MAX_TASK = 65_536
#: Fewest members in a chunk of a batch path spread over workers, unless a slot would be left
#: idle: a batch call has a cost that does not shrink with the chunk (the exact-chain batch's
#: last events, a few members left each: about a second, the time of some 5,000 members),
#: besides the scheduler's overhead (random 3-car chains, 50,000 members in one process:
#: chunks of 25,000 took 12 % more CPU time than one chunk, ``scripts/bench_chain_sweep.py
#: --task-size``; 10^5 members on 2 workers: two chunks, not four).
MIN_TASK = 32_768
#: Chunks per worker slot that a study is cut into when it can: enough for the last chunks to
#: even out the load, few enough for the overhead per chunk to stay small (random 3-car
#: chains on the exact-chain batch, 40,000 members on 2 processes: chunks of 20,000 took half
#: the time of chunks of 5,000, ``scripts/bench_chain_sweep.py``).
TASKS_PER_SLOT = 2
#: A Dask task that raises is tried again this many times (a worker that dies is replaced and
#: its tasks recomputed by the scheduler itself).
DASK_RETRIES = 2


@dataclass(frozen=True, eq=False)
class Task:
    """One chunk of members: ``values`` (dotted path → (m,) floats [scene units]) of ``scene``,
    solved by ``method`` with ``options``, through the backend's batch path (``batch``) or one
    by one; ``metrics``: the names of :data:`lsc.result.METRICS` kept."""

    scene: Scene
    method: str | None
    options: dict
    batch: bool
    values: dict
    metrics: tuple

    def __len__(self) -> int:
        return len(next(iter(self.values.values())))


def solve_task(task: Task, progress=None) -> dict:
    """``{"metrics": name → array (m, ...), "status": (m,) object array, "warnings": (m,)
    object array}`` of one chunk: each member validated, then solved (``"ok"``) or given its
    error message (and NaN metrics), with its ``Result.warnings`` (a tuple, empty where none).
    ``progress(k)``: optional, advanced by ``k`` members as they finish."""
    n = len(task)
    status = validate(task.scene, task.values, n)
    metrics = empty_metrics(task.scene, n, task.metrics)
    warnings = warning_array([()] * n)
    if task.batch:
        _batch(task, status, metrics, warnings, progress)
    else:
        _loop(task, status, metrics, warnings, progress)
    return {"metrics": metrics, "status": status, "warnings": warnings}


# --------------------------------------------------------------------------- validation
def validate(scene: Scene, values: dict, n: int) -> np.ndarray:
    """Status per member: ``"ok"`` or the loader's error for that member.

    Numeric fields are checked against the loader's bounds by probing each path's extremes
    (every bound the loader applies to one field is an interval); cross-field rules (closing
    speeds, the speeds' spread, gaps against the crush, unloading stiffer than loading) are
    screened per member (:func:`_speed_screen`). Any member a screen flags is loaded in full,
    so its message is exactly the loader's.
    """
    status = np.full(n, "ok", dtype=object)
    speeds = np.tile(scene.speeds, (n, 1))
    for path, vals in values.items():
        parts = parameters._split(path)
        if parts[0] == "vehicles" and len(parts) == 3 and parts[2] == "speed":
            speeds[:, int(parts[1])] = vals
    # the rules on the speeds together besides the closing one
    suspect = _speed_screen(scene, values, speeds)
    for path, vals in values.items():
        bad = ~np.isfinite(vals)
        lo, hi = _valid_interval(scene, path, np.unique(vals[~bad]))
        suspect |= bad | (vals < lo) | (vals > hi)
    # closing speeds (no brakes): the rear vehicle of some pair must be faster
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
    """The range ``[lo, hi]`` of sorted values ``u`` the loader accepts for ``path`` alone
    (a speed beside the others closing on it, :func:`_probe`).

    Every bound the loader puts on one numeric field is an interval, so bisection from an
    accepted anchor (the value nearest the base scene's own) finds its ends in O(log n) loads.
    """
    if u.size == 0:
        return np.inf, -np.inf

    probe = _probe(scene, path)

    def accepted(j: int) -> bool:
        try:
            scene.with_values(probe(float(u[j])))
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


def _speed_screen(scene: Scene, values: dict, speeds: np.ndarray) -> np.ndarray:
    """(n,) bool: the members that the loader's rules on the vehicles' speeds together, besides
    the closing one, might refuse: speeds all within :data:`lsc.scene.MAGNITUDES` of each
    other, and a gap wider than :data:`lsc.scene.GAP_RATIO` times the crush the relative
    kinetic energy can reach (the members whose energy is at most what the contact's loading
    absorbs up to twice that gap over the ratio: a factor 2 to spare); ``speeds`` (n, N) each
    member's [scene units]. Where that crush is out of reach here (a swept path other than a
    vehicle's speed, mass or weight, a contact's gap or unloading, or a straight loading line's
    stiffness), every member with a gap on that contact is flagged."""
    n = speeds.shape[0]
    masses = np.tile([v.mass for v in scene.vehicles], (n, 1))
    swept, known = {}, True
    for path, vals in values.items():
        parts = parameters._split(path)
        if len(parts) < 3 or not parts[1].isdigit():
            known = False
        elif parts[0] == "vehicles" and parts[2:] in (["speed"], ["mass"], ["weight"]):
            if parts[2] != "speed":
                masses[:, int(parts[1])] = vals if parts[2] == "mass" else vals / scene.g
        elif parts[0] == "contacts" and (parts[2:] in (["gap"], ["loading", "stiffness"])
                                         or parts[2] == "unloading"):
            swept[(int(parts[1]), parts[2])] = vals
        else:
            known = False
    with np.errstate(all="ignore"):   # (a non-finite value: flagged, NaN compares False)
        u = speeds - (np.sum(masses * speeds, axis=1, keepdims=True)
                      / np.sum(masses, axis=1, keepdims=True))
        energy = 0.5 * np.sum(masses * u * u, axis=1)
        suspect = ~(np.ptp(speeds, axis=1) >= 2 * MAGNITUDES[0])
        for k, c in enumerate(scene.contacts):
            gap = swept.get((k, "gap"), c.gap)
            d = 2.0 * gap / GAP_RATIO
            law, stiff = c.law, swept.get((k, "loading"))
            loading = getattr(law, "loading", None)
            if not known:
                reach = np.where(gap > 0, np.inf, -np.inf)
            elif isinstance(law, Damping) and stiff is None:
                reach = law.stiffness * d ** (law.exponent + 1.0) / (law.exponent + 1.0)
            elif loading is not None and loading.is_linear:
                reach = 0.5 * (loading.end_slope if stiff is None else stiff) * d * d
            elif loading is not None and stiff is None:
                reach = loading.energy(d)     # (NaN beyond a table's end: flagged)
            else:
                reach = np.where(gap > 0, np.inf, -np.inf)
            suspect |= ~(energy > reach)
    return suspect


def _probe(scene: Scene, path: str):
    """``value -> {path: value, ...}``: the values that probe ``path`` alone (the rules on the
    speeds together are :func:`_speed_screen`'s and the closing one's). A vehicle's speed is
    probed with every other vehicle's set to close on it at one unit of speed per place (rear
    ones faster): beside the scene's own speeds, a rear car's speed below the others' would be
    refused by the closing rule and every member with it loaded in full. Setting the others
    can only refuse more values (a narrower interval: more members loaded in full), never
    accept one the field's own checks refuse."""
    parts = parameters._split(path)
    if not (len(parts) == 3 and parts[0] == "vehicles" and parts[1].isdigit()
            and parts[2] == "speed"):
        return lambda value: {path: value}
    i = int(parts[1])
    others = [j for j in range(scene.n_vehicles) if j != i]
    return lambda value: {path: value, **{f"vehicles.{j}.speed": value + (i - j)
                                          for j in others}}


def empty_metrics(scene: Scene, n: int, names=None) -> dict:
    """NaN arrays of the metrics ``names`` (default: all): (n,), (n, N) or (n, K)."""
    N, K = scene.n_vehicles, len(scene.contacts)
    shape = {"vehicle": (n, N), "contact": (n, K), "scene": (n,)}
    return {name: np.full(shape[per], np.nan) for name, (_, per) in METRICS.items()
            if names is None or name in names}


# --------------------------------------------------------------------------- solving a chunk
def _batch(task: Task, status, metrics, warnings, progress) -> None:
    """The valid members at once through the backend's ``solve_batch``: their metrics, their
    status (``"ok"`` or the single solve's message) and warnings."""
    run = np.flatnonzero(status == "ok")
    if run.size == 0:
        return
    decl = solvers.backend(task.method)
    out = decl.solve_batch(HybridModel(task.scene), {p: v[run] for p, v in task.values.items()},
                           progress=progress, **task.options)
    for name in metrics:
        metrics[name][run] = out["metrics"][name]
    status[run] = out["status"]
    warnings[run] = out["warnings"]


def _loop(task: Task, status, metrics, warnings, progress) -> None:
    """Members one by one, as ``lsc.solve`` would do each (re-validated by the loader, with the
    member's own solver settings): its metrics and warnings, or its error in ``status``."""
    from .api import resolve

    for j in range(status.size):
        if status[j] == "ok":
            member = {p: float(v[j]) for p, v in task.values.items()}
            try:
                sc = task.scene.with_values(member)
                backend, opts = resolve(sc, task.method, {"n_samples": 2, **task.options})
                r = solvers.run(HybridModel(sc), backend, opts)
            except (SceneError, SimulationError) as e:
                status[j] = f"{type(e).__name__}: {e}"
            else:
                for name in metrics:
                    metrics[name][j] = getattr(r, name)
                warnings[j] = r.warnings
        if progress is not None:
            progress(1)


# --------------------------------------------------------------------------- executors
def is_dask(executor) -> bool:
    """True for a ``dask.distributed.Client`` (or anything that forwards to one): its
    ``submit`` takes ``retries`` and ``pure``."""
    return callable(getattr(executor, "scheduler_info", None))


def slots(executor) -> int:
    """How many chunks ``executor`` runs at once: a Dask cluster's threads, a pool's workers
    (``max_workers``), else the machine's cores; 1 in this process (``None``)."""
    if executor is None:
        return 1
    if is_dask(executor):
        try:
            return max(1, sum(executor.nthreads().values()))
        except Exception:  # noqa: BLE001  (a client not yet connected: guess the cores)
            return os.cpu_count() or 1
    return max(1, int(getattr(executor, "_max_workers", 0) or os.cpu_count() or 1))


def window(executor) -> int:
    """Most chunks in flight at once: two per slot (one running, one queued behind it)."""
    return 2 * slots(executor)


def task_size(n: int, executor, batch: bool) -> int:
    """Members per chunk of a study of ``n``: for a batch path, ``n`` cut into
    :data:`TASKS_PER_SLOT` chunks per slot of ``executor``, or into fewer where they would hold
    less than :data:`MIN_TASK` members each, but as many chunks as slots at least and a whole
    number per slot (no slot idle at the end), within :data:`MAX_TASK` (in this process:
    :data:`MAX_TASK`); for members solved one by one (milliseconds each), chunks of at most
    64."""
    if not batch:
        return max(1, min(64, math.ceil(n / (TASKS_PER_SLOT * slots(executor)))))
    if executor is None:
        return max(1, min(n, MAX_TASK))
    s = slots(executor)
    count = max(s, min(TASKS_PER_SLOT * s, n // MIN_TASK) // s * s)
    return max(1, min(n, MAX_TASK, math.ceil(n / count)))


def _submit(executor, task: Task):
    if is_dask(executor):
        return executor.submit(solve_task, task, pure=False, retries=DASK_RETRIES)
    return executor.submit(solve_task, task)


def run_tasks(tasks, consume, *, executor=None, progress=None) -> None:
    """Solve every ``(start, task)`` of the iterable ``tasks`` and call
    ``consume(start, task, result)`` for each, in order.

    ``executor``: ``None`` (this process) or any :class:`concurrent.futures.Executor`-like
    object with ``submit`` (a process pool, a ``dask.distributed.Client``); at most
    :func:`window` chunks are in flight, so the iterable is drawn lazily. ``progress(k)``:
    optional, advanced by ``k`` members as they finish. An error in a chunk (not a member's
    ``SceneError`` / ``SimulationError``, which is its status) cancels the chunks not yet
    finished and propagates."""
    if executor is None:
        for start, task in tasks:
            consume(start, task, solve_task(task, progress))
        return
    pending, most = deque(), window(executor)
    try:
        for start, task in tasks:
            pending.append((start, task, _submit(executor, task)))
            if len(pending) >= most:
                _finish(pending.popleft(), consume, progress)
        while pending:
            _finish(pending.popleft(), consume, progress)
    finally:
        for _, _, future in pending:
            future.cancel()


def _finish(item, consume, progress) -> None:
    start, task, future = item
    consume(start, task, future.result())
    if progress is not None:
        progress(len(task))


#: The Dask setting by which a nanny starts its worker with ``MALLOC_TRIM_THRESHOLD_=65536``
#: (by default): glibc then hands every freed array of more than 64 KiB back to the system, and
#: the batch paths, which make and free many such temporaries, run about half as fast. The
#: local cluster of :func:`executor_from` leaves the variable unset (glibc's own threshold).
MALLOC_TRIM = "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"


def _start_method():
    """The start method of a pool's processes: ``fork`` (the cheapest: no import in the
    workers) where this process runs no JAX (whose threads a forked child may deadlock on),
    else ``forkserver`` (workers forked from a clean server process); the platform's default
    where neither exists (``spawn``)."""
    import multiprocessing
    import sys

    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods and "jax" not in sys.modules:
        return multiprocessing.get_context("fork")
    if "forkserver" in methods:
        return multiprocessing.get_context("forkserver")
    return None


@contextmanager
def executor_from(workers: int | None = None, scheduler: str | None = None,
                  dask: bool = False):
    """The executor the CLI options ask for, closed on exit: ``None`` (this process; also for
    ``workers=1``), a ``ProcessPoolExecutor`` of ``workers`` processes (started as
    :func:`_start_method` says), or a Dask client: of the
    running cluster at ``scheduler`` (``tcp://host:port``), or with ``dask`` of a new
    ``LocalCluster`` of ``workers`` single-threaded processes (default: one per core)."""
    if scheduler is not None and workers is not None:
        raise SceneError("--workers", "--workers sets the processes of this machine (or of "
                                      "--dask's local cluster); a running cluster "
                                      "(--scheduler) has the workers it was started with")
    if scheduler is None and not dask:
        if workers is None or workers == 1:
            yield None
            return
        from concurrent.futures import ProcessPoolExecutor
        with ProcessPoolExecutor(workers, mp_context=_start_method()) as pool:
            yield pool
        return
    try:
        import distributed
    except ModuleNotFoundError:
        raise SceneError("--scheduler" if scheduler else "--dask",
                         "running on Dask needs dask.distributed: pip install 'lsc[dask]'") \
            from None
    if scheduler is not None:
        with distributed.Client(scheduler) as client:
            yield client
        return
    import dask
    with dask.config.set({MALLOC_TRIM: None}), \
            distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                     dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        yield client
