"""Benchmark: the paper's fixed-step reference against the event-driven SciPy solve.

On the same scene (the paper's parametric-study scene, e = 0.4), measured side by side in one
run: the time of ``lsc.solve`` (minimum over repeats, scene already loaded) and the error against
the closed form (max relative error over ΔV1, ΔV2, pulse duration and peak force), for
``reference`` at dt = 1e-5 s and ``scipy`` DOP853 at rtol = 1e-10.

    python scripts/bench_solve.py [--repeat 100]

Times are minima over the repeats (the run least disturbed by other work on the machine; a
sub-millisecond solve needs many repeats for that: its median on a quiet 2-core machine is
about 1.6 times its minimum).

Target (issue 2): SciPy at least 2x faster than the reference while at least 1000x more accurate.

With diffrax installed (issue 3) it also times ``diffrax`` Dopri8 at ``rtol = 1e-10`` after
compilation: the compiled solve alone (``stats["wall_time"]``, minimum over the repeats; target
under 0.5 ms), the whole ``lsc.solve`` (which adds the Result: the sampled series and metrics)
and the compile time of the first call, reported apart.
"""

from __future__ import annotations

import argparse
import importlib.util
import time

import numpy as np

import lsc
from lsc.data import load as load_packaged


def error(r, exact) -> float:
    """Max relative error over ΔV1, ΔV2, duration and peak force."""
    got = np.concatenate([r.delta_v, [r.duration], r.peak_force])
    ref = np.concatenate([exact.delta_v, [exact.duration], exact.peak_force])
    return float(np.max(np.abs(got - ref) / np.abs(ref)))


def best_time(fn, repeat: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=100)
    args = ap.parse_args(argv)
    scene = load_packaged("default")
    exact = lsc.solve(scene, method="closed-form")
    runs = {
        "reference dt=1e-5": lambda: lsc.solve(scene, method="reference", dt=1e-5),
        "scipy DOP853 rtol=1e-10": lambda: lsc.solve(scene, method="scipy", integrator="DOP853",
                                                     rtol=1e-10),
        "closed-form": lambda: lsc.solve(scene, method="closed-form"),
    }
    diffrax = importlib.util.find_spec("diffrax") is not None
    if diffrax:
        first = lsc.solve(scene, method="diffrax", rtol=1e-10)  # compiles
        runs["diffrax Dopri8 rtol=1e-10"] = lambda: lsc.solve(scene, method="diffrax",
                                                              rtol=1e-10)
    rows = {}
    for name, fn in runs.items():
        rows[name] = (best_time(fn, args.repeat), error(fn(), exact))
    print(f"{'method':<26} {'time [ms]':>10} {'max rel. error':>15}")
    for name, (t, e) in rows.items():
        print(f"{name:<26} {t * 1e3:>10.3f} {e:>15.3e}")
    (tr, er), (ts, es) = rows["reference dt=1e-5"], rows["scipy DOP853 rtol=1e-10"]
    speed, acc = tr / ts, er / max(es, 1e-300)
    print(f"\nscipy vs reference: {speed:.1f}x faster, {acc:.3g}x more accurate "
          f"(targets: >= 2x faster, >= 1000x more accurate): "
          f"{'MET' if speed >= 2 and acc >= 1000 else 'NOT MET'}")
    if diffrax:
        walls = [lsc.solve(scene, method="diffrax", rtol=1e-10).stats["wall_time"]
                 for _ in range(max(args.repeat, 100))]
        solve_ms = min(walls) * 1e3
        print(f"diffrax Dopri8 rtol=1e-10: compiled solve {solve_ms:.3f} ms (target < 0.5 ms: "
              f"{'MET' if solve_ms < 0.5 else 'NOT MET'}), lsc.solve with the Result "
              f"{rows['diffrax Dopri8 rtol=1e-10'][0] * 1e3:.3f} ms, compile "
              f"{first.stats['compile_time']:.2f} s (first call only)")


if __name__ == "__main__":
    main()
