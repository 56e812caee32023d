"""Benchmark: one 3-car chain by the exact chain backend against the SciPy solve.

On the same scene (a pile-up at a light: a car at 15 mph runs into two stopped cars, the front
pair 0.1 ft apart), measured side by side in one run: the time of ``lsc.solve`` (minimum over
repeats, scene already loaded) by ``exact-chain`` and by ``scipy`` DOP853 at rtol = 1e-10, their
ratio, and how far the SciPy metrics are from the exact ones (max over ΔV, peak force, max
deformation, relative to each metric's scale).

    python scripts/bench_chain.py [--repeat 20]

Also printed: the time of the exact segment loop alone (``stats["wall_time"]``: the Result's
sampled series and metrics come on top of it).

Target (issue 13): exact-chain at least 50x faster than SciPy at rtol = 1e-10.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import lsc

SCENE = {
    "name": "three-car pile-up at a light",
    "units": "US",
    "vehicles": [{"weight": 3500, "speed": "15 mph"}, {"weight": 2800, "speed": 0},
                 {"weight": 4200, "speed": 0}],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}},
                 {"loading": {"stiffness": 50000}, "unloading": {"restitution": 0.3},
                  "gap": 0.1}],
}


def best_time(scene, repeat: int, **kw):
    """``(minimum wall time of lsc.solve [s], minimum stats wall time [s], the last Result)``."""
    times, inner, r = [], [], None
    for _ in range(repeat):
        t = time.perf_counter()
        r = lsc.solve(scene, **kw)
        times.append(time.perf_counter() - t)
        inner.append(r.stats.get("wall_time", np.nan))
    return min(times), min(inner), r


def difference(r, ref) -> float:
    """Max over ΔV, peak force and max deformation of |r - ref| / max|ref|."""
    return max(float(np.max(np.abs(getattr(r, n) - getattr(ref, n))) /
                     np.max(np.abs(getattr(ref, n))))
               for n in ("delta_v", "peak_force", "max_deformation"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20)
    args = ap.parse_args()
    scene = lsc.Scene.load(SCENE)
    lsc.solve(scene, method="exact-chain")   # (imports and first-call costs out of the way)
    lsc.solve(scene, method="scipy", rtol=1e-10)
    t_exact, loop_exact, exact = best_time(scene, args.repeat, method="exact-chain")
    t_scipy, loop_scipy, scipy = best_time(scene, args.repeat, method="scipy", rtol=1e-10)
    print(f"scene: {SCENE['name']} ({len(exact.events)} events)")
    print(f"{'method':<22}{'lsc.solve [ms]':>16}{'solve loop [ms]':>17}{'diff vs exact':>15}")
    print(f"{'exact-chain':<22}{1e3 * t_exact:>16.3f}{1e3 * loop_exact:>17.3f}{0.0:>15.1e}")
    print(f"{'scipy DOP853 1e-10':<22}{1e3 * t_scipy:>16.3f}{1e3 * loop_scipy:>17.3f}"
          f"{difference(scipy, exact):>15.1e}")
    print(f"speed-up of exact-chain: {t_scipy / t_exact:.1f}x (target 50x)")


if __name__ == "__main__":
    main()
