"""Benchmark: an exact solve read only for its metrics, against the SciPy solve of the scene.

One two-vehicle scene (SI) with a piecewise-linear loading table (a plateau and a falling
segment, extending beyond its last point) and restitution unloading. Measured in one run, each
the best of ``--repeat`` runs of ``--number`` solves:

1. ``lsc.solve(scene, method="exact")`` reading only the metrics (``r.metrics()``), the same
   loaded Scene every time (as a study solving one scene again: its model is built once);
2. the same, then reading the sampled series too (``r.v``: 1000 samples);
3. ``lsc.solve(scene, method="scipy", integrator="DOP853", rtol=1e-10)`` reading the metrics;
4. as 1 on a new Scene object every time (``dataclasses.replace``: its model built each time;
   its contacts, and so the numbers their laws derive once, shared);

and the ratios of 3 to 1 and to 2, with the largest difference of the metrics (exact against
SciPy, relative to each metric's scale).

    python scripts/bench_result.py [--repeat 7] [--number 20]

Target (issue 12): the exact metrics-only solve at least 20x faster than the SciPy solve.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

import lsc

SCENE = {
    "name": "bench: two vehicles, loading table", "units": "SI",
    "vehicles": [{"name": "bullet", "mass": 1500, "speed": 4.0},
                 {"name": "target", "mass": 1200, "speed": 0.0}],
    "contacts": [{"loading": {"table": [[0, 0], [0.02, 60000], [0.04, 60000], [0.06, 40000],
                                        [0.10, 300000]]},
                  "unloading": {"restitution": 0.4}}],
}


def best(fn, repeat: int, number: int) -> float:
    """Best time per call [s] of ``fn`` over ``repeat`` runs of ``number`` calls."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - start) / number)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--number", type=int, default=20)
    args = ap.parse_args()
    scene = lsc.Scene.load(SCENE)

    def exact_metrics():
        return lsc.solve(scene, method="exact").metrics()

    def exact_series():
        r = lsc.solve(scene, method="exact")
        return r.metrics(), r.v

    def exact_new_scene():
        return lsc.solve(dataclasses.replace(scene), method="exact").metrics()

    def scipy_metrics():
        return lsc.solve(scene, method="scipy", integrator="DOP853", rtol=1e-10).metrics()

    for fn in (exact_metrics, exact_series, scipy_metrics, exact_new_scene):  # warm up
        fn()
    t_exact = best(exact_metrics, args.repeat, args.number)
    t_series = best(exact_series, args.repeat, args.number)
    t_scipy = best(scipy_metrics, args.repeat, max(1, args.number // 4))
    t_new = best(exact_new_scene, args.repeat, args.number)
    ex, sp = exact_metrics(), scipy_metrics()
    err = max(float(np.max(np.abs(np.asarray(ex[k]) - np.asarray(sp[k]))
                           / max(float(np.max(np.abs(sp[k]))), 1e-300)))
              for k in ("delta_v", "duration", "peak_force", "max_deformation",
                        "permanent_deformation"))
    print(f"exact, metrics only        {t_exact * 1e3:9.3f} ms")
    print(f"exact, metrics and series  {t_series * 1e3:9.3f} ms")
    print(f"scipy DOP853 rtol 1e-10    {t_scipy * 1e3:9.3f} ms")
    print(f"scipy / exact metrics only {t_scipy / t_exact:9.1f} x   (target >= 20)")
    print(f"scipy / exact with series  {t_scipy / t_series:9.1f} x")
    print(f"exact, metrics only, a new Scene object each solve {t_new * 1e3:9.3f} ms "
          f"(scipy / that {t_scipy / t_new:.1f} x)")
    print(f"max relative difference of the metrics, exact vs scipy: {err:.2e}")


if __name__ == "__main__":
    main()
