"""Work–precision study: what accuracy costs in time, for every lsc backend.

For each scene, each method is run over a range of tolerances (or time steps) and placed on a
work–precision diagram the way DiffEqBenchmarks draws them: error on x, time on y, log–log, one
line per method.

Scenes
  (a) ``linear``: the paper's scene, k = 24,000 lbf/ft, e = 0.4. Reference: the closed form.
  (b) ``table``: a measured-like piecewise-linear loading table (several kinks, a plateau, a dip),
      e = 0.5. Reference: the exact piecewise-linear solve, checked against SciPy DOP853 at
      rtol = 1e-13, atol = 1e-16 (they must agree to 1e-12 before the study runs).
  (c) ``hunt-crossley``: a Hunt–Crossley contact (k D^1.5 (1 + α Ḋ)), when the damping laws are
      available. Reference: SciPy DOP853 at rtol = 1e-13, checked against diffrax Dopri8.

Methods: ``reference`` over dt = 1e-3 … 1e-6 s; SciPy RK45, DOP853, LSODA, Radau and diffrax
Tsit5, Dopri8, Kvaerno5 over rtol = 1e-3 … 1e-12; the exact backends (closed form, exact).

Error: the maximum relative error over ΔV1, ΔV2, pulse duration and peak force. Time: the
minimum over repeated runs after a warm-up (``lsc.solve`` with the scene already loaded and a
two-point series, so the integration is timed, not the sampling); diffrax's JIT compile time is
excluded and reported in its own column.

Output (``--out``, default ``compare-out/``): ``compare_integrators.csv``, one PNG diagram per
scene, and ``cheapest.md``, the cheapest method for each accuracy level.

    python scripts/compare_integrators.py            # full study (several minutes)
    python scripts/compare_integrators.py --quick    # smoke run, under a minute
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import time
from pathlib import Path

import numpy as np

import lsc

US = {"units": "US", "g": "32.2 ft/s^2"}
CARS = [{"name": "bullet", "weight": 3500, "speed": 10}, {"name": "target", "weight": 3500, "speed": 0}]

SCENES = {
    "linear": {**US, "name": "(a) paper, linear, e = 0.4", "vehicles": CARS,
               "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}]},
    "table": {**US, "name": "(b) measured-like table, e = 0.5", "vehicles": CARS,
              "contacts": [{"loading": {"table": [[0, 0], [0.021, 300], [0.08, 2200], [0.15, 5200],
                                                  [0.2, 5200], [0.24, 4700], [0.32, 8000],
                                                  [0.6, 22000]]},
                            "unloading": {"restitution": 0.5}}]},
    "hunt-crossley": {**US, "name": "(c) Hunt-Crossley, n = 1.5, e = 0.5", "vehicles": CARS,
                      "contacts": [{"law": "hunt-crossley", "stiffness": 60000, "exponent": 1.5,
                                    "restitution": 0.5}]},
}

RTOLS = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]
DTS = [1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6]
SCIPY = ["RK45", "DOP853", "LSODA", "Radau"]
DIFFRAX = ["Tsit5", "Dopri8", "Kvaerno5"]
LEVELS = [1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12]


def metrics(r) -> np.ndarray:
    """The compared quantities: ΔV1, ΔV2, duration, peak force."""
    return np.concatenate([r.delta_v, [r.duration], r.peak_force[:1]])


def error(r, ref) -> float:
    """Max relative error over the compared quantities."""
    return float(np.max(np.abs(metrics(r) - ref) / np.abs(ref)))


def timed(scene, repeat: int, **kw):
    """(best time [s], result, compile time [s] or nan) of lsc.solve after one warm-up run."""
    first = lsc.solve(scene, n_samples=2, **kw)
    compile_time = float(first.stats.get("compile_time", np.nan))
    best, r = np.inf, first
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = lsc.solve(scene, n_samples=2, **kw)
        best = min(best, time.perf_counter() - t0)
    return best, r, compile_time


def reference_metrics(name: str, scene) -> np.ndarray:
    """The exact (or tightest, cross-checked) answer for a scene."""
    if name == "linear":
        return metrics(lsc.solve(scene, method="closed-form"))
    if name == "table":
        a = metrics(lsc.solve(scene, method="exact"))
        b = metrics(lsc.solve(scene, method="scipy", rtol=1e-13, atol=1e-16))
        agree = float(np.max(np.abs(a - b) / np.abs(a)))
        if agree > 1e-12:
            raise SystemExit(f"the table scene's references disagree by {agree:.2e} > 1e-12")
        return a
    a = metrics(lsc.solve(scene, method="scipy", rtol=1e-13, atol=1e-16))
    if have_diffrax():
        b = metrics(lsc.solve(scene, method="diffrax", integrator="Dopri8", rtol=1e-13))
        agree = float(np.max(np.abs(a - b) / np.abs(a)))
        if agree > 1e-10:
            raise SystemExit(f"the damping scene's references disagree by {agree:.2e}")
    return a


def have_diffrax() -> bool:
    return importlib.util.find_spec("diffrax") is not None


def run_scene(name: str, scene, quick: bool, repeat: int) -> list[dict]:
    rows = []
    ref = reference_metrics(name, scene)
    rtols = RTOLS[::3] if quick else RTOLS
    dts = DTS[::3] if quick else DTS

    def add(method, setting, t, r, compile_time=np.nan):
        rows.append({"scene": name, "method": method, "setting": setting, "time_s": t,
                     "error": max(error(r, ref), 1e-17), "compile_s": compile_time,
                     "rhs_evaluations": r.stats.get("rhs_evaluations", 0)})

    for exact in ("closed-form", "exact"):
        try:
            t, r, _ = timed(scene, repeat, method=exact)
            add(exact, "-", t, r)
        except lsc.SceneError:
            pass  # does not apply to this scene
    for dt in dts:
        try:
            t, r, _ = timed(scene, max(1, repeat // 2), method="reference", dt=dt)
            add("reference", f"dt={dt:g}", t, r)
        except lsc.SceneError:
            break
    for integ in SCIPY:
        for rtol in rtols:
            try:
                t, r, _ = timed(scene, repeat, method="scipy", integrator=integ, rtol=rtol)
            except lsc.SimulationError as e:
                print(f"  scipy {integ} rtol={rtol:g}: {e}")
                continue
            add(f"scipy {integ}", f"rtol={rtol:g}", t, r)
    if have_diffrax():
        for integ in DIFFRAX:
            for rtol in rtols:
                try:
                    t, r, c = timed(scene, repeat, method="diffrax", integrator=integ, rtol=rtol)
                except lsc.SimulationError as e:
                    print(f"  diffrax {integ} rtol={rtol:g}: {e}")
                    continue
                add(f"diffrax {integ}", f"rtol={rtol:g}", t, r, c)
    return rows


def plot(rows: list[dict], name: str, title: str, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    methods = sorted({r["method"] for r in rows if r["scene"] == name})
    for m in methods:
        pts = sorted((r["error"], r["time_s"]) for r in rows if r["scene"] == name and r["method"] == m)
        e, t = zip(*pts)
        ax.loglog(e, t, "o-" if len(e) > 1 else "*", label=m, markersize=5 if len(e) > 1 else 12)
    ax.set_xlabel("max relative error (ΔV1, ΔV2, duration, peak force)")
    ax.set_ylabel("time per solve (s)")
    ax.set_title(f"Work–precision: {title}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / f"work_precision_{name}.png", dpi=120)
    plt.close(fig)


def cheapest_table(rows: list[dict]) -> str:
    lines = ["| scene | accuracy | cheapest method | setting | time (ms) |",
             "|---|---|---|---|---|"]
    for name in dict.fromkeys(r["scene"] for r in rows):
        for level in LEVELS:
            ok = [r for r in rows if r["scene"] == name and r["error"] <= level]
            if not ok:
                lines.append(f"| {name} | {level:g} | (none reached it) | | |")
                continue
            best = min(ok, key=lambda r: r["time_s"])
            lines.append(f"| {name} | {level:g} | {best['method']} | {best['setting']} | "
                         f"{best['time_s'] * 1e3:.3f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Work-precision study of lsc's backends.")
    ap.add_argument("--quick", action="store_true", help="a smoke run (under a minute)")
    ap.add_argument("--out", default="compare-out", help="output folder")
    ap.add_argument("--repeat", type=int, default=None, help="timed repeats per point")
    ap.add_argument("--scenes", nargs="*", default=list(SCENES), help="which scenes")
    args = ap.parse_args(argv)
    repeat = args.repeat or (1 if args.quick else 5)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.scenes:
        try:
            scene = lsc.Scene.load(SCENES[name])
        except lsc.SceneError as e:
            print(f"scene {name}: skipped ({e})")
            continue
        print(f"scene {name} ...")
        rows += run_scene(name, scene, args.quick, repeat)
        plot(rows, name, scene.name, out)
    with open(out / "compare_integrators.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    table = cheapest_table(rows)
    (out / "cheapest.md").write_text(table + "\n")
    print(table)
    print(f"\nwrote {out}/compare_integrators.csv, {out}/cheapest.md and the PNG diagrams")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
