"""Benchmark: ``lsc.sweep`` of many random 3-car chains by the exact-chain batch (issue 13: at
least 20,000 members per second on the 2-core machine), beside the single exact-chain solve
looped over a subset (its throughput extrapolated), and the largest difference between the two
on that subset (every metric, relative to its scale per member).

Members (US units, the random chains of ``tests/test_exact_chain_batch.py``): masses 50 to
1000 lb (1:20), stiffnesses 1e3 to 1e7 lbf/ft, restitutions in [--e-min, 1] (a fifth elastic), gaps of 1e-3 to 1 ft (or none, 40 %), closing speeds 0.1 to
30 ft/s per pair (or none, 30 %), the front car at rest or moving. The batch hands a member to
the single solve where its vectorised search cannot decide: the count is reported, with the
time the single solve spends on them (summed over the worker processes), and the vectorised
path's own throughput without them; a member still running after 200 events (contacts that
chatter) is taken on from its state by the single solve's segments, within that path (their
count and time reported too).

The sweep is run in this process (``--workers 1``) and on a process pool (``--workers 2``:
``lsc.sweep(..., executor=ProcessPoolExecutor(2))``, chunks of :func:`lsc.chunks.task_size`
or ``--task-size``), side by side, in wall time and in CPU time (this process's, or the
workers' summed: the figure to compare on a shared machine). (``lsc.sweep(..., workers=2)`` makes the same pool
itself; the pool here is the script's own, to count the hand-offs in its workers.)

    python scripts/bench_chain_sweep.py                     # 10^5 members, subset 200
    python scripts/bench_chain_sweep.py --n 20000 --subset 100 --e-min 0 --workers 1,2
"""

from __future__ import annotations

import argparse
import multiprocessing
import resource
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

import lsc  # noqa: E402
from lsc.model import HybridModel  # noqa: E402
from lsc.result import METRICS  # noqa: E402
from lsc.solvers import exact_chain  # noqa: E402
from lsc.solvers.exact_chain import _batch  # noqa: E402
from test_exact_chain_batch import (random_chains, rounding,  # noqa: E402  (the tests')
                                    _rounding_response)

from test_exact_chain_batch import SCALE_OF  # noqa: E402


#: The single solve the batch runs on a member it hands off.
_SINGLE = _batch.solve_one


#: The continuation the batch runs on a member at its hand-off's event count.
_RESUME = _batch._Batch._resume


def _count_alone(shared) -> None:
    """Wrap the single solve the batch runs on a handed member, adding its wall and CPU time
    to ``shared`` (a ``multiprocessing`` array: members, time, CPU time; then the same for the
    members taken on from the hand-off, :meth:`_batch._Batch._resume`); also a pool's
    initializer, so that the workers' hand-offs are counted too."""

    def counting(original, at):
        def counted(*args, **kw):
            start, cpu = time.perf_counter(), time.process_time()
            try:
                return original(*args, **kw)
            finally:
                with shared.get_lock():
                    shared[at] += 1
                    shared[at + 1] += time.perf_counter() - start
                    shared[at + 2] += time.process_time() - cpu
        return counted

    _batch.solve_one = counting(_SINGLE, 0)
    _batch._Batch._resume = counting(_RESUME, 3)


def _sweep(scene, values, workers: int, task_size):
    """``(result, wall time, members handed off, their time and CPU time summed over the
    workers, this process's CPU time, (members taken on from the hand-off, their time, their
    CPU time))`` of ``lsc.sweep`` with ``workers`` processes (1: this process)."""
    shared = multiprocessing.Array("d", 6)
    executor, children = None, _children_cpu()
    if workers > 1:
        executor = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"),
                                       initializer=_count_alone, initargs=(shared,))
        list(executor.map(abs, range(4 * workers)))     # (the workers started: not timed)
    else:
        _count_alone(shared)
    try:
        start, cpu = time.perf_counter(), time.process_time()
        res = lsc.sweep(scene, values, method="exact-chain", progress=False, executor=executor,
                        task_size=task_size)
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    finally:
        if executor is not None:
            executor.shutdown()
    if executor is not None:     # (the workers' CPU time, theirs and not this process's)
        cpu = _children_cpu() - children
    return res, wall, int(shared[0]), shared[1], shared[2], cpu, (int(shared[3]), *shared[4:])


def _children_cpu() -> float:
    """CPU time [s] of this process's ended children (a pool's workers, once shut down)."""
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=100_000, help="members of the sweep")
    ap.add_argument("--subset", type=int, default=200, help="members solved one by one")
    ap.add_argument("--vehicles", type=int, default=3)
    ap.add_argument("--e-min", type=float, default=0.05, help="lowest restitution")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", default="1,2", help="worker processes to compare (1: this "
                    "process; more: a process pool as executor=)")
    ap.add_argument("--task-size", type=int, default=None, help="members per task (default: "
                    "lsc.chunks.task_size)")
    a = ap.parse_args()
    scene, values = random_chains(a.vehicles, a.n, a.seed, a.e_min)
    res, t_batch = None, None
    for workers in (int(w) for w in a.workers.split(",")):
        got, wall, handed, t_alone, cpu_alone, cpu, taken = _sweep(scene, values, workers,
                                                                  a.task_size)
        res = got if res is None else res
        same = all(np.array_equal(got.metrics[k], res.metrics[k], equal_nan=True)
                   for k in METRICS) and np.array_equal(got.status, res.status)
        done = a.n - handed
        # (the single solves' time is summed over the workers: spread over them, it takes
        # about that sum / workers of the wall time)
        t_vec = wall - t_alone / workers
        print(f"workers={workers}: {a.n} random {a.vehicles}-car chains (e >= {a.e_min}) in "
              f"{wall:.2f} s wall: {a.n / wall:,.0f} members/s; failed "
              f"{int((res.status != 'ok').sum())}; handed to the single solve {handed} "
              f"({t_alone:.2f} s summed over the workers); vectorised path alone {done} in "
              f"~{t_vec:.2f} s: {done / t_vec:,.0f} members/s (of them taken on from the "
              f"hand-off at {_batch.HANDOFF_EVENTS} events: {taken[0]}, {taken[1]:.2f} s "
              f"summed over the workers)"
              + ("" if same else "; NOT the same numbers as the first run"))
        # (the CPU time too, of this process or summed over the workers (their start and
        # the pool's pickling included): on a shared machine the wall time counts the other
        # processes')
        print(f"  vectorised path alone, CPU time{'' if workers == 1 else ' of the workers'}: "
              f"{cpu - cpu_alone:.2f} s: {done / (cpu - cpu_alone):,.0f} members/s per "
              f"process; of it the members taken on from the hand-off: {taken[2]:.2f} s")
        t_batch = wall if workers == 1 else t_batch
    m = min(a.subset, a.n)
    worst, where, beyond, checks = 0.0, None, set(), []
    start = time.perf_counter()
    for j in range(m):
        member = scene.with_values({p: float(v[j]) for p, v in values.items()})
        try:
            r = exact_chain.solve(HybridModel(member), n_samples=2)
        except lsc.SimulationError as err:
            assert res.status[j] == f"SimulationError: {err}", (j, res.status[j], err)
            continue
        for name in METRICS:
            want, got = np.asarray(getattr(r, name), float), res.metrics[name][j]
            if np.all(np.isnan(want)):
                continue
            scale = np.nanmax(np.abs(getattr(r, SCALE_OF.get(name, name))))
            err = float(np.nanmax(np.abs(got - want)) / scale)
            tol = 1e-12 * scale + rounding(r).get(name, 0.0)
            if np.any(np.abs(got - want) > tol):
                beyond.add(j)
                checks.append((j, name, np.abs(got - want), tol))
            if err > worst:
                worst, where = err, (j, name)
    t_single = (time.perf_counter() - start) / m
    # (the members beyond the first tolerance: each against its own conditioning, untimed)
    unexplained = {j for j, name, diff, tol in checks
                   if np.any(diff > tol + 100 * _rounding_response(scene, values, j, name))}
    print(f"single solve looped: {m} members, {t_single * 1e3:.1f} ms each: {1 / t_single:,.0f} "
          f"members/s (extrapolated to {a.n}: {a.n * t_single:,.0f} s); batch / single "
          f"{t_single * a.n / t_batch:.0f}x")
    print(f"max difference batch vs single on those {m}: {worst:.2e} of the metric's scale "
          f"(member, metric: {where}); beyond 1e-12 and the rounding of the positions (the "
          f"tests' first tolerance): {len(beyond)} members {sorted(beyond)[:10]}; beyond what a "
          f"relative change of 1e-12 in the data does too (the tests' allowance): "
          f"{len(unexplained)} {sorted(unexplained)[:10]}")


if __name__ == "__main__":
    main()
