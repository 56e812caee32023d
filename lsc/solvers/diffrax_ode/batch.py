"""Batches of diffrax solves: the members of one scene structure in vmapped compiled calls.

:func:`solve_batch` is the backend's batch path (the contract of
:meth:`lsc.solvers.base.Backend.solve_batch`): the members in chunks, ordered so that members
that take similar paths share a chunk, each chunk one call of :func:`solve_params`, which vmaps
the segment loop (without the records) over a batch of parameters and returns the Result
metrics per member, with the Result's definitions (:func:`lsc.metrics.metrics`). Members whose
pairs may lock (:func:`lsc.locking.lock_members`) are handed to the single solve, which locks
(:func:`lsc.solvers.base.solve_alone`; its compiled loop is built once per structure and reused
from member to member): the metrics loop follows the plain law.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .compiled import f64, structure, to_numpy

import jax  # noqa: E402

from ...locking import lock_members  # noqa: E402
from ...model import HybridModel  # noqa: E402
from ...parameters import batch_params  # noqa: E402
from ...result import METRICS  # noqa: E402
from ..base import solve_alone  # noqa: E402
from .core import check_settings, segment_loop, status_message  # noqa: E402

__all__ = ["solve_batch", "solve_params", "BATCH_METRICS", "CHUNK"]

#: Most members in one compiled call by default (a smaller batch is padded to a power of two):
#: small, because in a vmapped loop every member of a call waits for its slowest.
CHUNK = 1024

#: The metrics :func:`solve_batch` returns (as on a Result; ``peak_acceleration_g`` uses ``g``).
BATCH_METRICS = ("delta_v", "v_final", "peak_acceleration", "peak_acceleration_g", "duration",
                 "max_deformation", "permanent_deformation", "peak_force", "restitution",
                 "restitution_energy", "energy_absorbed", "energy_returned", "contact_time",
                 "separation_time", "failure_time")


def solve_params(model, params_batch, *, integrator: str = "Dopri8", rtol: float = 1e-10,
                 atol=None, t_end=None, max_steps: int = 2048, max_events: int = 256, g=None,
                 horizon=None):
    """Solve many scenes of ``model``'s structure in one vmapped compiled call.

    The array-level batch under :func:`solve_batch`. ``params_batch`` has the structure of
    ``model.params``; a leaf with one more leading axis than in ``model.params`` is batched (size
    B, the same for all), the others are shared (the initial state follows from ``v0``). Returns
    NumPy arrays with a leading axis B: the metrics of :data:`BATCH_METRICS` (as a Result
    defines them: the headline metrics over the first impacts; NaN for a failed member),
    ``status`` (0 = ok, see :data:`~.core.STATUS_CODES`), ``message`` (list of str: the
    single solve's :class:`~lsc.errors.SimulationError` message), ``steps``, ``segments``; and
    ``stats``
    (``compile_time``, ``wall_time`` [s], ``size``). Peaks of force and acceleration are taken
    at the events and, where they can lie between events (damping laws, braking, chains), at the
    extrema inside every step's dense output. ``horizon`` [s] (scalar or (B,)): when a contact
    still closed is an error (default: each member's :meth:`HybridModel.horizon`); ``g``
    [acceleration] (scalar or (B,)): for ``peak_acceleration_g`` (default the scene's).
    """
    check_settings(integrator, rtol, atol, max_steps, max_events)
    core = segment_loop(model, integrator, max_steps, max_events)
    base, tree = jax.tree_util.tree_flatten(model.params)
    leaves = tree.flatten_up_to(params_batch)
    axes, sizes = [], set()
    for b, a in zip(base, leaves):
        a = np.asarray(a)
        if a.ndim == np.ndim(b) + 1:
            axes.append(0)
            sizes.add(a.shape[0])
        elif a.shape == np.shape(b):
            axes.append(None)
        else:
            raise ValueError(f"a batched parameter has shape {a.shape}; expected {np.shape(b)} "
                             "or (B,) + that")
    if len(sizes) != 1:
        raise ValueError("params_batch needs at least one batched leaf, all of one batch size "
                         f"(got sizes {sorted(sizes)})")
    p = jax.tree_util.tree_unflatten(tree, [f64(a) for a in leaves])
    g = model.scene.g if g is None else g  # scalar or (B,)
    out, compile_time, wall = core.run_batched(
        jax.tree_util.tree_unflatten(tree, axes), p, f64(rtol),
        f64(np.nan if atol is None else atol), f64(np.nan if t_end is None else t_end),
        f64(np.nan if horizon is None else horizon), f64(g))
    out = to_numpy(out)
    status = out["status"].astype(int)
    res = {name: np.array(out[name], float) for name in BATCH_METRICS}
    for name in BATCH_METRICS:
        res[name][status != 0] = np.nan
    res["status"] = status
    res["message"] = ["ok" if s == 0 else status_message(s, k, t, integrator)
                      for s, k, t in zip(status, out["status_contact"].tolist(), out["t"].tolist())]
    res["steps"], res["segments"] = out["steps"], out["segments"]
    res["stats"] = {"compile_time": compile_time, "wall_time": wall, "size": sizes.pop()}
    return res


def solve_batch(model, values: dict, *, progress=None, chunk: int = CHUNK, workers=None,
                integrator: str = "Dopri8", rtol: float = 1e-10, atol=None, t_end=None,
                max_steps: int = 2048, max_events: int = 256) -> dict:
    """Solve every member of ``values`` (dotted scene path → (n,) array in scene units, each
    member already validated) of ``model``'s scene, as the single solve of each would.

    The members go in chunks of at most ``chunk`` (one vmapped compiled call each, ``workers``
    at once in threads, default the CPU count); ``progress(k)``, if given, is called as ``k``
    more members are done. Paths that :func:`lsc.parameters.setter` cannot write re-load the
    scene per member (members whose structure differs are batched apart). The solver options
    are those of :func:`~.single.solve`.

    Returns ``{"metrics": {name: array (n, ...) for every name of lsc.result.METRICS},
    "status": (n,) object array}``: ``"ok"``, or ``"SimulationError: <message>"`` (the message
    the single solve of that member raises) with NaN metrics.
    """
    check_settings(integrator, rtol, atol, max_steps, max_events)
    n = len(next(iter(values.values()))) if values else 1
    metrics = _empty_metrics(model, n)
    status = np.full(n, "ok", dtype=object)
    options = dict(integrator=integrator, rtol=rtol, atol=atol, t_end=t_end,
                   max_steps=max_steps, max_events=max_events)
    workers = (os.cpu_count() or 1) if workers is None else int(workers)
    params = batch_params(model, values)
    groups = ([(model, np.arange(n), params, np.full(n, model.scene.g))] if params is not None
              else _reloaded(model, values, n))
    alone = []
    for member_model, members, p, g in groups:
        locks = lock_members(member_model, p)   # (pairs that may lock: the single solve)
        alone.append(members[locks])
        keep = np.flatnonzero(~locks)
        p = jax.tree_util.tree_map(lambda a: np.asarray(a)[keep] if np.ndim(a) else a, p)
        _solve_chunks(member_model, members[keep], p, np.asarray(g)[keep], metrics, status,
                      progress, int(chunk), workers, options)
    from .single import solve
    solve_alone(solve, model, values, np.concatenate(alone).astype(int), metrics, status,
                progress=progress, **options)
    return {"metrics": metrics, "status": status}


def _empty_metrics(model, n: int) -> dict:
    """NaN arrays of every metric of :data:`lsc.result.METRICS` for ``n`` members."""
    shape = {"vehicle": (n, model.N), "contact": (n, model.K), "scene": (n,)}
    return {name: np.full(shape[per], np.nan) for name, (_, per) in METRICS.items()}


def _stack(trees):
    """Pytrees of one structure stacked along a new leading (member) axis."""
    return jax.tree_util.tree_map(lambda *xs: np.stack([np.asarray(x, float) for x in xs]), *trees)


def _reloaded(model, values: dict, n: int):
    """The members re-loaded one by one (:meth:`lsc.Scene.with_values`), grouped by model
    structure: ``(model, members, batched params, g per member)`` for each group."""
    groups = {}
    for j in range(n):
        scene = model.scene.with_values({path: float(v[j]) for path, v in values.items()})
        member = HybridModel(scene)
        entry = groups.setdefault(structure(member), (member, [], [], []))
        entry[1].append(j)
        entry[2].append(member.params)
        entry[3].append(scene.g)
    return [(m, np.array(idx), _stack(ps), np.array(gs, float))
            for m, idx, ps, gs in groups.values()]


def _solve_chunks(model, members, p, g, metrics, status, progress, chunk, workers, options):
    """Solve ``members`` (indices into ``metrics`` and ``status``; batched parameters ``p`` and
    ``g`` (per member) in their order) in chunks of at most ``chunk``, each one vmapped compiled
    solve (:func:`solve_params`), ``workers`` chunks at a time (threads: a compiled call
    releases the GIL). In a vmapped loop every member waits for the slowest of its chunk, so
    the members are first ordered by :func:`_work_order` and the chunks are small. Parameters
    that no member changes are shared, not batched. A smaller batch is padded (with its last
    member) to a power of two, the last chunk to ``chunk``, so that few batch shapes are
    compiled."""
    if members.size == 0:
        return
    leaves, tree = jax.tree_util.tree_flatten(model.params)
    batch = [np.asarray(b, float) for b in tree.flatten_up_to(p)]
    order = _work_order(jax.tree_util.tree_unflatten(tree, batch))
    members, g = members[order], np.asarray(g, float)[order]
    batch = [b[order] for b in batch]
    horizon = model.horizon(jax.tree_util.tree_unflatten(tree, batch))
    varies = [bool(np.any(b != np.asarray(a, float))) for a, b in zip(leaves, batch)]
    if not any(varies):  # every member is the base scene: batch one leaf all the same
        varies[0] = True
    batch = [b if v else np.asarray(a, float) for a, b, v in zip(leaves, batch, varies)]
    size = min(max(1, chunk), 1 << (members.size - 1).bit_length())
    starts = list(range(0, members.size, size))

    def solve(lo):
        idx = np.arange(lo, min(lo + size, members.size))
        pad = np.concatenate([idx, np.full(size - idx.size, idx[-1])])
        pb = jax.tree_util.tree_unflatten(tree, [b[pad] if v else b
                                                 for b, v in zip(batch, varies)])
        return idx, solve_params(model, pb, horizon=horizon[pad], g=g[pad], **options)

    def store(idx, res):
        done = members[idx]
        good = res["status"][: idx.size] == 0
        for name in metrics:
            arr = np.asarray(res[name], float)[: idx.size]
            if metrics[name].ndim == 2 and arr.ndim == 1:
                arr = arr[:, None]
            metrics[name][done[good]] = arr[good]
        for j in np.nonzero(~good)[0]:
            status[done[j]] = f"SimulationError: {res['message'][j]}"
        if progress is not None:
            progress(idx.size)

    store(*solve(starts[0]))  # compiles (once per structure, options and chunk size)
    workers = max(1, min(workers, len(starts) - 1))
    if workers > 1:
        with ThreadPoolExecutor(workers) as pool:
            for idx, res in pool.map(solve, starts[1:]):
                store(idx, res)
    else:
        for lo in starts[1:]:
            store(*solve(lo))


def _work_order(p: dict) -> np.ndarray:
    """An order of the members (batched parameters ``p``) that puts members that take similar
    paths next to each other: by relative kinetic energy over the energy the loading curves
    hold at their last breakpoint (which breakpoints a crash crosses, hence its segments)."""
    m, v0 = np.asarray(p["m"], float), np.asarray(p["v0"], float)
    mu = m[:, :-1] * m[:, 1:] / (m[:, :-1] + m[:, 1:])
    w = np.maximum(v0[:, :-1] - v0[:, 1:], 0.0)
    key = np.zeros(m.shape[0])
    for k, c in enumerate(p["contacts"]):
        cap = np.asarray(c["le"], float)[:, -2] if "le" in c else np.zeros(m.shape[0])
        key = key + 0.5 * mu[:, k] * w[:, k] ** 2 / np.where(cap > 0, cap, 1.0)
    return np.argsort(key, kind="stable")
