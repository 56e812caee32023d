"""Benchmark: studies at any size (issue 16) — bounded memory, every core, a Dask cluster.

Two measurements, each configuration in a fresh Python process (so its peak memory is its own):

1. ``mc``: ``lsc mc`` of ``--mc-n`` members (default 10^7) on the exact backend, streamed with
   ``--out FILE.parquet``, in one process: wall time and peak RSS (``ru_maxrss``). Target:
   under 1 GB at 10^7. ``--mc-n`` smaller runs a smaller study: the RSS does not grow with the
   members (chunks of a fixed size), the time does linearly; both are printed per member.
2. ``sweep``: an exact sweep of ``--sweep-n`` members (default 10^6; random closing speeds and
   restitutions of the paper's scene) in one process, on a process pool of ``--workers``
   processes and on a Dask ``LocalCluster`` of ``--workers`` single-threaded processes: wall
   time, the speed-up over one process (target 1.7x with 2 workers) and a SHA-256 of every
   member's status and metrics (bit-identical results: the same digest).

The machine's load matters for the speed-ups: the script prints the load average before and
after each measurement.

    python scripts/bench_scale.py                       # 10^7 mc, 10^6 sweeps, 2 workers
    python scripts/bench_scale.py --mc-n 1000000 --sweep-n 200000
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap

MC_WORKER = textwrap.dedent("""
    import json, resource, sys, time
    import lsc.cli
    cfg = json.loads(sys.argv[1])
    t0 = time.perf_counter()
    rc = lsc.cli.main(["mc", "default", "--uncertainty", cfg["uncertainty"], "--n", str(cfg["n"]),
                       "--method", "exact", "--no-progress", "--out", cfg["out"]])
    wall = time.perf_counter() - t0
    print(json.dumps({"rc": rc, "wall": wall,
                      "maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
""")

SWEEP_WORKER = textwrap.dedent("""
    import hashlib, json, sys, time
    import numpy as np
    import lsc
    from lsc.cli import resolve_scene
    from lsc.chunks import executor_from
    cfg = json.loads(sys.argv[1])
    rng = np.random.default_rng(0)
    n = cfg["n"]
    params = {"vehicles.0.speed": rng.uniform(0.5, 9.0, n),
              "contacts.0.unloading.restitution": rng.uniform(0.05, 0.95, n)}
    scene = resolve_scene("default")
    with executor_from(cfg["workers"], None, cfg["dask"]) as ex:
        if ex is not None:   # start the workers (and import lsc on them) before the clock
            lsc.sweep(scene, {k: v[:64] for k, v in params.items()}, method="exact",
                      progress=False, executor=ex, task_size=8)
        t0 = time.perf_counter()
        s = lsc.sweep(scene, params, method="exact", progress=False, executor=ex,
                      task_size=cfg.get("task_size"))
        wall = time.perf_counter() - t0
    h = hashlib.sha256(np.asarray(s.status, str).astype("U").tobytes())
    for name in sorted(s.metrics):
        h.update(np.ascontiguousarray(s.metrics[name]).tobytes())
    print(json.dumps({"wall": wall, "sha256": h.hexdigest(), "failed": int((~s.ok).sum())}))
""")

UNCERTAINTY = ('"vehicles.0.speed" = { uniform = ["1 ft/s", "9 ft/s"] }\n'
               '"contacts.0.unloading.restitution" = { normal = [0.4, 0.1], min = 0.05, '
               'max = 0.9 }\n')


def _run(code: str, cfg: dict) -> dict:
    out = subprocess.run([sys.executable, "-c", code, json.dumps(cfg)], capture_output=True,
                         text=True, check=False)
    if out.returncode != 0:
        raise SystemExit(f"benchmark worker failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def bench_mc(n: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        u = os.path.join(tmp, "u.toml")
        with open(u, "w") as fh:
            fh.write(UNCERTAINTY)
        out = os.path.join(tmp, "mc.parquet")
        print(f"lsc mc --n {n} --method exact --out mc.parquet  (load {_load()})")
        r = _run(MC_WORKER, {"n": n, "uncertainty": u, "out": out})
        size = os.path.getsize(out) / 2 ** 20
    print(f"  wall {r['wall']:.1f} s ({n / r['wall']:,.0f} members/s), peak RSS "
          f"{r['maxrss_mb']:.0f} MB, file {size:.0f} MB  (load {_load()})")


def bench_sweep(n: int, workers: int) -> None:
    from lsc.chunks import task_size
    import concurrent.futures as cf

    pool_size = task_size(n, cf.ProcessPoolExecutor(workers), batch=True)
    rows = [("1 process", {"workers": None, "dask": False}),
            (f"1 process, chunks {pool_size}", {"workers": None, "dask": False,
                                                "task_size": pool_size}),
            (f"process pool, {workers}", {"workers": workers, "dask": False}),
            (f"Dask LocalCluster, {workers}", {"workers": workers, "dask": True})]
    base = None
    print(f"exact sweep of {n} members  (load {_load()})")
    for label, cfg in rows:
        r = _run(SWEEP_WORKER, {"n": n, **cfg})
        base = base or r
        print(f"  {label:<26} {r['wall']:8.1f} s  x{base['wall'] / r['wall']:.2f}  "
              f"sha256 {r['sha256'][:16]}  {'identical' if r['sha256'] == base['sha256'] else 'DIFFERENT'}"
              f"  (load {_load()})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mc-n", type=int, default=10_000_000)
    ap.add_argument("--sweep-n", type=int, default=1_000_000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--skip", choices=("mc", "sweep"), action="append", default=[])
    args = ap.parse_args()
    print(f"{os.cpu_count()} cores")
    if "mc" not in args.skip:
        bench_mc(args.mc_n)
    if "sweep" not in args.skip:
        bench_sweep(args.sweep_n, args.workers)


if __name__ == "__main__":
    main()
