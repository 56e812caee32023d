"""Benchmark: throughput of ``lsc.sweep`` on many random measured-like (piecewise-linear) scenes.

Scenes of type (b) of ``compare_integrators.py``: a loading table with several kinks, a plateau
and a dip; per member a random closing speed (1–8 ft/s), target weight (2500–4500 lbf),
restitution (0.1–0.9) and force scale (0.9–1.3). Each configuration runs in a fresh Python
process, so its peak memory (max RSS) is its own:

- ``diffrax`` (batched: vmapped, jit-compiled chunks; the compile is done first, on one chunk
  of the same shape, and reported apart: throughput is after compilation),
- ``exact`` (the vectorised piecewise-linear stepper: the reference, exact to rounding),
- ``scipy`` (looped, DOP853; measured on a subset of ``--scipy-subset`` members and its
  throughput extrapolated: the table says so).

Errors: max relative error over ΔV1, ΔV2, duration and peak force against the exact backend
(the tightest solve there is: closed-form segments, machine precision), on the members both
solved. Targets (issue #3): diffrax batched at least 50,000 scenes/s after compilation, and at
least 20 times the throughput of looping SciPy, at 1e-9 accuracy.

    python scripts/bench_sweep.py                  # 10^4 and 10^5 members
    python scripts/bench_sweep.py --sizes 10000 --scipy-subset 200 --workers 1
    python scripts/bench_sweep.py --cold-only      # the cold first exact sweep alone

First, the cold first exact sweep: a fresh process's ``import lsc`` and its first
``lsc.sweep(..., method="exact")`` of ``--cold`` members (the best of ``--cold-repeat``
processes): what a script waits for its first numbers, imports included; once with the
bytecode cached (as installed), once compiling every module (as with PYTHONDONTWRITEBYTECODE).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
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
    if cfg["method"] == "diffrax":  # compile on one chunk of the shape the sweep will use
        chunk = cfg["chunk"]
        k = min(n, chunk)
        t0 = time.perf_counter()
        lsc.sweep(scene, {p: v[:k] for p, v in params.items()}, method="diffrax", progress=False,
                  chunk=chunk, **opts)
        compile_time = time.perf_counter() - t0
        opts = dict(opts, chunk=chunk, workers=cfg.get("workers"))
    t0 = time.perf_counter()
    s = lsc.sweep(scene, params, method=cfg["method"], progress=False, **opts)
    wall = time.perf_counter() - t0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    out = {"members": len(s.status), "wall": wall, "compile": compile_time, "rss_mb": rss,
           "ok": s.ok.tolist(),
           "m": np.column_stack([s.delta_v, s.duration, s.peak_force[:, 0]]).tolist()}
    print(json.dumps(out))
""")


COLD = textwrap.dedent("""
    import json, sys, time
    start, cpu = time.perf_counter(), time.process_time()
    import numpy as np
    import lsc
    cfg = json.loads(sys.argv[1])
    speeds = np.random.default_rng(cfg["seed"]).uniform(1, 8, cfg["n"])
    lsc.sweep(lsc.Scene.load(cfg["scene"]), {"vehicles.0.speed": speeds}, method="exact",
              progress=False)
    print(json.dumps({"wall": time.perf_counter() - start, "cpu": time.process_time() - cpu}))
""")


def cold(n: int, repeat: int, seed: int, bytecode: bool) -> tuple[float, float]:
    """The best of ``repeat`` fresh processes' first exact sweep of ``n`` members, counted from
    before ``import lsc`` (imports included: what a script's first sweep waits): wall time and
    the process's CPU time [s] (the CPU time is the steadier on a busy machine).
    ``bytecode``: with the modules' compiled bytecode cached (in a temporary folder, written by
    one untimed run first), as an installed package has it; else every source is compiled in
    each process (``PYTHONDONTWRITEBYTECODE`` and no cache)."""
    cfg = json.dumps({"scene": SCENE, "n": n, "seed": seed})
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ)
        if bytecode:   # (in the prefix, the installed packages' bytecode is written too)
            env.pop("PYTHONDONTWRITEBYTECODE", None)
            env["PYTHONPYCACHEPREFIX"] = cache
        else:          # (theirs is read where it is installed)
            env["PYTHONDONTWRITEBYTECODE"] = "1"
        walls, cpus = [], []
        for i in range(repeat + bytecode):
            proc = subprocess.run([sys.executable, "-c", COLD, cfg], capture_output=True,
                                  text=True, env=env)
            if proc.returncode:
                raise SystemExit(f"cold exact sweep failed:\n{proc.stderr[-2000:]}")
            if i or not bytecode:   # (the first run with bytecode only writes the cache)
                out = json.loads(proc.stdout.strip().splitlines()[-1])
                walls.append(out["wall"])
                cpus.append(out["cpu"])
    return min(walls), min(cpus)


def run(method: str, n: int, seed: int, take: int | None = None, options=None,
        workers=None, chunk: int = 1024) -> dict:
    """One configuration in a fresh process: wall time [s], compile time [s] (diffrax), peak
    RSS [MB], per-member ok flags and (ΔV1, ΔV2, duration, peak force)."""
    cfg = {"scene": SCENE, "method": method, "n": n, "seed": seed, "take": take,
           "options": options or {}, "workers": workers, "chunk": chunk}
    proc = subprocess.run([sys.executable, "-c", WORKER, json.dumps(cfg)], capture_output=True,
                          text=True)
    if proc.returncode:
        raise SystemExit(f"{method} n={n} failed:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def max_error(res: dict, ref: dict) -> float:
    """Max relative error of ``res`` against ``ref`` over the members both solved."""
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
    ap.add_argument("--rtol", type=float, default=1e-9, help="rtol of diffrax")
    ap.add_argument("--scipy-rtol", type=float, default=1e-11,
                    help="rtol of scipy (DOP853 needs ~1e-11 for a 1e-9 error here)")
    ap.add_argument("--integrator", default="Dopri8", help="diffrax integrator")
    ap.add_argument("--workers", type=int, default=None,
                    help="diffrax chunks solved at once (default: the backend's, the CPU count)")
    ap.add_argument("--chunk", type=int, default=1024,
                    help="diffrax members in one compiled call (compiled once for this shape)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cold", type=int, default=100, metavar="N",
                    help="members of the cold first exact sweep (0: not measured)")
    ap.add_argument("--cold-repeat", type=int, default=7,
                    help="fresh processes for the cold first sweep (the best counts)")
    ap.add_argument("--cold-only", action="store_true",
                    help="measure the cold first exact sweep only")
    args = ap.parse_args(argv)
    if args.cold:
        cached = cold(args.cold, args.cold_repeat, args.seed, True)
        compiling = cold(args.cold, args.cold_repeat, args.seed, False)
        print(f"cold first exact sweep ({args.cold} members, fresh process, imports included, "
              f"best of {args.cold_repeat}): {cached[0]:.3f} s (CPU {cached[1]:.3f} s) with the "
              f"bytecode cached, {compiling[0]:.3f} s (CPU {compiling[1]:.3f} s) compiling every "
              "module")
    if args.cold_only:
        return 0
    have_diffrax = importlib.util.find_spec("diffrax") is not None
    print(f"{'method':<30} {'members':>8} {'wall [s]':>9} {'compile [s]':>11} "
          f"{'scenes/s':>10} {'max rel err':>12} {'peak RSS [MB]':>14}")
    for n in args.sizes:
        ref = run("exact", n, args.seed)
        rows = [("exact (batched)", ref)]
        if have_diffrax:
            rows.append((f"diffrax {args.integrator} (batched)",
                         run("diffrax", n, args.seed, workers=args.workers, chunk=args.chunk,
                             options={"rtol": args.rtol, "integrator": args.integrator})))
        sub = min(args.scipy_subset, n)
        rows.append((f"scipy (looped, {sub} of {n})",
                     run("scipy", n, args.seed, take=sub, options={"rtol": args.scipy_rtol})))
        thr = {}
        for name, res in rows:
            rate = res["members"] / res["wall"]
            thr[name.split()[0]] = rate
            print(f"{name:<30} {n:>8} {res['wall']:>9.3f} {res['compile']:>11.3f} "
                  f"{rate:>10.0f} {max_error(res, ref):>12.2e} {res['rss_mb']:>14.0f}")
        if sub < n:
            print(f"  scipy: {sub} members measured, throughput extrapolated to {n} "
                  f"(about {n / thr['scipy']:.0f} s for all)")
        if "diffrax" in thr:
            ratio = thr["diffrax"] / thr["scipy"]
            print(f"  diffrax batched: {thr['diffrax']:.0f} scenes/s (target >= 50000: "
                  f"{'MET' if thr['diffrax'] >= 50_000 else 'NOT MET'}), {ratio:.0f}x scipy "
                  f"looped (target >= 20x: {'MET' if ratio >= 20 else 'NOT MET'})")
        print(f"  exact batched / scipy looped throughput: {thr['exact'] / thr['scipy']:.0f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
