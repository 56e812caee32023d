"""Benchmark: the exact piecewise backend against the event-driven SciPy solve.

Random two-vehicle scenes (SI units) with piecewise-linear loading tables of ``--points`` points
that each hold a plateau (zero slope) and a falling (negative slope) segment and go on beyond the
last point with a positive slope, and restitution unloading. Measured in one run:

1. ``exact.solve_arrays`` (the vectorised stepper) on ``--batch`` scenes (default 10^5): wall
   time (best of ``--repeat``).
2. On ``--sample`` of those scenes, per scene: ``lsc`` SciPy DOP853 at rtol = 1e-10 (the model
   already built), the exact backend's ``solve`` (a full Result with 1000-sample series) and the
   exact batch time per scene, with the max error of exact against SciPy over ΔV, duration,
   peak force, D_max and D_perm, each relative to its scale (scenes where SciPy stepped over a
   breakpoint are counted apart), the exact energy identity at the common velocity, and the
   difference between exact solve and exact batch.

    python scripts/bench_exact.py [--batch 100000] [--sample 20] [--points 6] [--repeat 3]

Targets (issue 4): the batch under 1 s for 10^5 scenes on this 2-core machine; exact at least
100x faster per scene than SciPy at rtol 1e-10.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from lsc.curves import Curve
from lsc.model import HybridModel
from lsc.scene import Contact, Hysteresis, Restitution, Scene, Vehicle
from lsc.solvers import exact, scipy_ode

METRICS = ("delta_v", "duration", "peak_force", "max_deformation", "permanent_deformation")


def random_params(B: int, n: int, seed: int = 0) -> dict:
    """Batch parameters of ``B`` random scenes with ``n``-point loading tables (SI)."""
    rng = np.random.default_rng(seed)
    widths = rng.uniform(0.01, 0.06, (B, n - 1))
    slopes = rng.uniform(1e5, 1e6, (B, n - 1))
    cols = rng.permuted(np.tile(np.arange(1, n - 1), (B, 1)), axis=1)[:, :2]
    rows = np.arange(B)
    slopes[rows, cols[:, 0]] = 0.0                                   # a plateau
    slopes[rows, cols[:, 1]] = -rng.uniform(0.1, 0.5, B) * slopes[rows, 0]  # a falling segment
    d = np.concatenate([np.zeros((B, 1)), np.cumsum(widths, axis=1)], axis=1)
    f = np.concatenate([np.zeros((B, 1)), np.cumsum(slopes * widths, axis=1)], axis=1)
    f = np.maximum(f, 0.0)
    return {"m1": rng.uniform(800, 2500, B), "m2": rng.uniform(800, 2500, B),
            "v1": rng.uniform(1.0, 7.0, B), "v2": rng.uniform(-1.0, 0.5, B),
            "load_d": d, "load_f": f, "load_end_slope": rng.uniform(2e5, 2e6, B),
            "e": rng.uniform(0.0, 0.8, B), "g": np.full(B, 9.80665)}


def scene_of(P: dict, i: int) -> Scene:
    """Member ``i`` of the batch parameters as a Scene."""
    law = Hysteresis(Curve(P["load_d"][i], P["load_f"][i], float(P["load_end_slope"][i])),
                     Restitution(float(P["e"][i])))
    return Scene(name=f"random {i}", units="SI", g=9.80665,
                 vehicles=(Vehicle("bullet", float(P["m1"][i]), float(P["v1"][i])),
                           Vehicle("target", float(P["m2"][i]), float(P["v2"][i]))),
                 contacts=(Contact(law),))


def take(P: dict, idx) -> dict:
    return {k: np.asarray(v)[idx] for k, v in P.items()}


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def rel_err(a: dict, b: dict) -> float:
    """Max error over METRICS, each relative to its scale (ΔV: largest |ΔV|; D_perm: D_max)."""
    scale = {"delta_v": np.max(np.abs(b["delta_v"])), "duration": b["duration"],
             "peak_force": np.max(b["peak_force"]), "max_deformation": np.max(b["max_deformation"]),
             "permanent_deformation": np.max(b["max_deformation"])}
    return max(float(np.max(np.abs(np.asarray(a[k]) - np.asarray(b[k]))) / scale[k])
               for k in METRICS)


def stepped_over(P: dict, i: int, r) -> bool:
    """True when a SciPy result passed a breakpoint without stopping there (the deformation went
    past it and back within one step), so that it went on with the previous segment's slope."""
    n = sum(e.kind == "breakpoint" for e in r.events)
    return int(np.sum(P["load_d"][i] < r.max_deformation[0])) - 1 > n


def energy_error(P: dict, i: int, r) -> float:
    """|absorbed energy - (1/2) μ v0²| / (1/2) μ v0² at the common velocity (exact identity)."""
    m1, m2, v = P["m1"][i], P["m2"][i], P["v1"][i] - P["v2"][i]
    e = 0.5 * m1 * m2 / (m1 + m2) * v * v
    return abs(r.energy_absorbed[0] - e) / e


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=100_000)
    ap.add_argument("--sample", type=int, default=20)
    ap.add_argument("--points", type=int, default=6)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)

    P = random_params(args.batch, args.points)
    exact.solve_arrays(take(P, slice(0, 100)))  # warm-up
    out = None

    def run_batch():
        nonlocal out
        out = exact.solve_arrays(P)

    t_batch = best(run_batch, args.repeat)
    ok = out["status"] == 0
    codes, counts = np.unique(out["status"][~ok], return_counts=True)
    others = {int(c): int(n) for c, n in zip(codes, counts)}
    print(f"exact batch: {args.batch} scenes ({args.points}-point tables, plateau + falling "
          f"segment), {t_batch:.3f} s = {t_batch / args.batch * 1e6:.2f} us/scene; "
          f"status ok {int(ok.sum())}, others {others}; "
          f"events per scene {out['events'][ok].mean():.1f} (max {out['events'].max()})")

    idx = np.flatnonzero(ok)[: args.sample]
    t_sp, t_ex, err_sp, err_batch, err_energy, missed = [], [], [], 0.0, 0.0, []
    for i in idx:
        model = HybridModel(scene_of(P, i))
        t_sp.append(best(lambda: scipy_ode.solve(model, rtol=1e-10), 1))
        t_ex.append(best(lambda: exact.solve(model), args.repeat))
        r_sp = scipy_ode.solve(model, rtol=1e-10)
        r_ex = exact.solve(model)
        m_ex = {k: getattr(r_ex, k) for k in METRICS}
        m_sp = {k: getattr(r_sp, k) for k in METRICS}
        m_b = {k: out[k][i] for k in METRICS}
        (missed if stepped_over(P, i, r_sp) else err_sp).append(rel_err(m_ex, m_sp))
        err_batch = max(err_batch, rel_err(m_b, m_ex))
        err_energy = max(err_energy, energy_error(P, i, r_ex))
    t_sp, t_ex = float(np.mean(t_sp)), float(np.mean(t_ex))
    t_b = t_batch / args.batch
    print(f"\nper scene, mean over {idx.size} scenes:")
    print(f"{'method':<34} {'time/scene':>12} {'speed-up':>9}")
    print(f"{'scipy DOP853 rtol=1e-10 (Result)':<34} {t_sp * 1e3:>9.3f} ms {1.0:>8.0f}x")
    print(f"{'exact solve (Result, 1000 samples)':<34} {t_ex * 1e3:>9.3f} ms {t_sp / t_ex:>8.0f}x")
    print(f"{'exact batch (metrics)':<34} {t_b * 1e6:>9.2f} us {t_sp / t_b:>8.0f}x")
    print(f"\nmax error of exact against scipy rtol=1e-10 (relative to each metric's scale): "
          f"{max(err_sp, default=float('nan')):.2e} over the {len(err_sp)} scenes where SciPy "
          f"stopped at every breakpoint")
    if missed:
        print(f"SciPy stepped over a breakpoint in {len(missed)} of {idx.size} scenes (it misses "
              f"an excursion past a breakpoint that fits in one step): differences there up to "
              f"{max(missed):.2e}")
    print(f"exact: energy at the common velocity vs (1/2) mu v0^2: max rel. error "
          f"{err_energy:.1e}; exact batch vs exact solve: max difference {err_batch:.1e}")
    print(f"targets: batch of 10^5 < 1 s: {'met' if t_batch * 1e5 / args.batch < 1 else 'NOT met'} "
          f"({t_batch * 1e5 / args.batch:.3f} s per 10^5); exact >= 100x faster per scene: "
          f"solve {t_sp / t_ex:.0f}x, batch {t_sp / t_b:.0f}x")


if __name__ == "__main__":
    main()
