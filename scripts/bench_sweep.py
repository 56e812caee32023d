"""Benchmark: throughput of ``lsc.sweep`` on many random measured-like (piecewise-linear) scenes.

Scenes of type (b) of ``compare_integrators.py``: a loading table with several kinks, a plateau
and a dip; per member a random closing speed (1–8 ft/s), target weight (2500–4500 lbf),
restitution (0.1–0.9) and force scale (0.9–1.3). Each configuration runs in a fresh Python
process, so its peak memory (max RSS) is its own:

- ``diffrax`` (batched: one vmapped, jit-compiled solve; compile time reported apart),
- ``exact`` (the vectorised piecewise-linear stepper),
- ``scipy`` (looped, DOP853; measured on a subset, throughput extrapolated).

Errors: max relative error over ΔV1, ΔV2, duration and peak force against the exact backend
(machine precision), on the members every method solved.

    python scripts/bench_sweep.py                  # 10^4 and 10^5 members
    python scripts/bench_sweep.py --sizes 10000 --scipy-subset 200
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import subprocess
import sys
import textwrap

SCENE = {
    "name": "measured-like table", "units": "US", "g": "32.2 ft/s^2",
    "vehicles": [{"name": "bullet", "weight": 3500, "speed": 5},
                 {"name": "target", "weight": 3500, "speed": 0}],
    "contacts": [{"loading": {"table": [[0, 0], [0.021, 300], [0.08, 2200], [0.15, 5200],
                                        [0.2, 5200], [0.24, 4700], [0.32, 8000], [0.6, 22000]]},
                  "unloading": {"restitution": 0.5}}],
}

WORKER = textwrap.dedent("""
    import json, resource, sys, time
    import numpy as np
    import lsc
    cfg = json.loads(sys.argv[1])
    rng = np.random.default_rng(cfg["seed"])
    n = cfg["n"]
    params = {"vehicles.0.speed": rng.uniform(1, 8, n),
              "vehicles.1.weight": rng.uniform(2500, 4500, n),
              "contacts.0.unloading.restitution": rng.uniform(0.1, 0.9, n),
              "contacts.0.loading.scale": rng.uniform(0.9, 1.3, n)}
    take = cfg.get("take")
    if take:
        params = {k: v[:take] for k, v in params.items()}
    scene = lsc.Scene.load(cfg["scene"])
    opts = cfg.get("options", {})
    compile_time = float("nan")
    if cfg["method"] == "diffrax":  # compile once on a small batch of the same structure
        t0 = time.perf_counter()
        lsc.sweep(scene, {k: v[:2] for k, v in params.items()}, method="diffrax", **opts)
        compile_time = time.perf_counter() - t0
    t0 = time.perf_counter()
    s = lsc.sweep(scene, params, method=cfg["method"], progress=False, **opts)
    wall = time.perf_counter() - t0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    out = {"members": len(s.status), "wall": wall, "compile": compile_time, "rss_mb": rss,
           "ok": s.ok.tolist(),
           "m": np.column_stack([s.delta_v, s.duration, s.peak_force[:, 0]]).tolist()}
    print(json.dumps(out))
""")


def run(method: str, n: int, seed: int, take: int | None = None, options=None) -> dict:
    cfg = {"scene": SCENE, "method": method, "n": n, "seed": seed, "take": take,
           "options": options or {}}
    proc = subprocess.run([sys.executable, "-c", WORKER, json.dumps(cfg)], capture_output=True,
                          text=True)
    if proc.returncode:
        raise SystemExit(f"{method} n={n} failed:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def max_error(res: dict, ref: dict) -> float:
    import numpy as np

    m, r = np.asarray(res["m"], float), np.asarray(ref["m"], float)[: len(res["m"])]
    ok = np.asarray(res["ok"]) & np.asarray(ref["ok"])[: len(res["ok"])]
    if not ok.any():
        return float("nan")
    return float(np.max(np.abs(m[ok] - r[ok]) / np.abs(r[ok])))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Throughput of lsc.sweep on random table scenes.")
    ap.add_argument("--sizes", type=int, nargs="*", default=[10_000, 100_000])
    ap.add_argument("--scipy-subset", type=int, default=300,
                    help="members the looped SciPy sweep solves (throughput extrapolated)")
    ap.add_argument("--rtol", type=float, default=1e-10, help="rtol of diffrax and scipy")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    have_diffrax = importlib.util.find_spec("diffrax") is not None
    print(f"{'method':<22} {'members':>8} {'wall [s]':>9} {'compile [s]':>11} "
          f"{'scenes/s':>10} {'max rel err':>12} {'peak RSS [MB]':>14}")
    for n in args.sizes:
        ref = run("exact", n, args.seed)
        rows = [("exact (batched)", ref)]
        if have_diffrax:
            rows.append(("diffrax (batched)", run("diffrax", n, args.seed,
                                                  options={"rtol": args.rtol})))
        rows.append((f"scipy (looped, {args.scipy_subset})",
                     run("scipy", n, args.seed, take=args.scipy_subset,
                         options={"rtol": args.rtol})))
        thr = {}
        for name, res in rows:
            rate = res["members"] / res["wall"]
            thr[name.split()[0]] = rate
            print(f"{name:<22} {n:>8} {res['wall']:>9.3f} {res['compile']:>11.3f} "
                  f"{rate:>10.0f} {max_error(res, ref):>12.2e} {res['rss_mb']:>14.0f}")
        if "diffrax" in thr:
            print(f"  diffrax batched / scipy looped throughput: {thr['diffrax'] / thr['scipy']:.0f}x")
        print(f"  exact batched / scipy looped throughput: {thr['exact'] / thr['scipy']:.0f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
