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
minimum over repeated runs after a warm-up of ``lsc.solve`` (the scene already loaded, a
two-point series), i.e. what a user waits for, Result included; ``backend_s`` is the backend's own
``stats["wall_time"]`` (for diffrax the compiled solve alone). diffrax's JIT compile time is
excluded from both and reported in its own column (``compile_s``: the compile of the first call;
a later nonzero value is the sampler of the Result compiling for a larger number of steps).

Output (``--out``, default ``compare-out/``): ``compare_integrators.csv``, one PNG diagram per
scene, ``cheapest.md`` (and ``cheapest.csv``), the cheapest method for each accuracy level.

    python scripts/compare_integrators.py            # full study (several minutes)
    python scripts/compare_integrators.py --quick    # smoke run, under a minute: fewer
                                                     # tolerances and steps, diffrax Dopri8 only
    python scripts/compare_integrators.py --out docs/_static/work_precision   # the docs' figures
    python scripts/compare_integrators.py --out docs/_static/work_precision --replot  # redraw only

The diagrams keep one colour and marker per method in every panel, label each point with its
tolerance (rtol) or step (dt), ring the settings ``lsc.solve`` uses by default, and state
diffrax's compile time (left out of the plotted times) in the title.
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
DIFFRAX_QUICK = ["Dopri8"]  # one compile per scene: --quick stays under a minute
LEVELS = [1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12]


def metrics(r) -> np.ndarray:
    """The compared quantities: ΔV1, ΔV2, duration, peak force."""
    return np.concatenate([r.delta_v, [r.duration], r.peak_force[:1]])


def error(r, ref) -> float:
    """Max relative error over the compared quantities."""
    return float(np.max(np.abs(metrics(r) - ref) / np.abs(ref)))


def timed(scene, repeat: int, **kw):
    """(best time [s], result, compile time [s] or nan) of lsc.solve after one warm-up run; the
    result's ``stats["wall_time"]`` is the best of the repeats too."""
    first = lsc.solve(scene, n_samples=2, **kw)
    compile_time = float(first.stats.get("compile_time", np.nan))
    best, r, backend = np.inf, first, np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = lsc.solve(scene, n_samples=2, **kw)
        best = min(best, time.perf_counter() - t0)
        backend = min(backend, r.stats.get("wall_time", np.nan))
    r.stats["wall_time"] = backend
    return best, r, compile_time


#: How closely each scene's two references agree (max relative difference): accuracy levels
#: finer than this are not reported (0 for the closed form). Filled by :func:`reference_metrics`.
REF_AGREEMENT: dict[str, float] = {}


def reference_metrics(name: str, scene) -> np.ndarray:
    """The exact (or tightest, cross-checked) answer for a scene; records how closely the two
    references agree in :data:`REF_AGREEMENT`."""
    if name == "linear":
        REF_AGREEMENT[name] = 0.0
        return metrics(lsc.solve(scene, method="closed-form"))
    if name == "table":
        a = metrics(lsc.solve(scene, method="exact"))
        b = metrics(lsc.solve(scene, method="scipy", rtol=1e-13, atol=1e-16))
        agree = float(np.max(np.abs(a - b) / np.abs(a)))
        if agree > 1e-12:
            raise SystemExit(f"the table scene's references disagree by {agree:.2e} > 1e-12")
        REF_AGREEMENT[name] = agree
        return a
    a = metrics(lsc.solve(scene, method="scipy", rtol=1e-13, atol=1e-16))
    REF_AGREEMENT[name] = np.nan
    if have_diffrax():
        b = metrics(lsc.solve(scene, method="diffrax", integrator="Dopri8", rtol=1e-13))
        agree = float(np.max(np.abs(a - b) / np.abs(a)))
        if agree > 1e-10:
            raise SystemExit(f"the damping scene's references disagree by {agree:.2e}")
        REF_AGREEMENT[name] = agree
    return a


def have_diffrax() -> bool:
    return importlib.util.find_spec("diffrax") is not None


def run_scene(name: str, scene, quick: bool, repeat: int) -> list[dict]:
    """Every method over its settings on one scene: a row per run (time [s], error, compile
    time [s], backend time [s], right-hand-side evaluations)."""
    rows = []
    ref = reference_metrics(name, scene)
    rtols = RTOLS[::3] if quick else RTOLS
    dts = DTS[:3:2] if quick else DTS

    def add(method, setting, t, r, compile_time=np.nan):
        rows.append({"scene": name, "method": method, "setting": setting, "time_s": t,
                     "error": max(error(r, ref), 1e-17), "compile_s": compile_time,
                     "backend_s": r.stats.get("wall_time", np.nan),
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
        for integ in (DIFFRAX_QUICK if quick else DIFFRAX):
            for rtol in rtols:
                try:
                    t, r, c = timed(scene, repeat, method="diffrax", integrator=integ, rtol=rtol)
                except lsc.SimulationError as e:
                    print(f"  diffrax {integ} rtol={rtol:g}: {e}")
                    continue
                add(f"diffrax {integ}", f"rtol={rtol:g}", t, r, c)
    return rows


#: Every method of the study, in a fixed order: its colour and marker are the same in every
#: panel, whichever methods a scene has.
ALL_METHODS = ["closed-form", "exact", "reference", *(f"scipy {i}" for i in SCIPY),
               *(f"diffrax {i}" for i in DIFFRAX)]
_MARKERS = "*PsovD^<>hX"


def method_style(method: str) -> dict:
    """Colour and marker of a method, fixed across panels (:data:`ALL_METHODS`)."""
    j = ALL_METHODS.index(method) if method in ALL_METHODS else len(ALL_METHODS)
    return {"color": f"C{j % 10}" if j < len(ALL_METHODS) else "k",
            "marker": _MARKERS[j % len(_MARKERS)]}


def default_settings() -> dict[str, str]:
    """method → its setting when ``lsc.solve`` is given none (read from the backends' own
    signatures): the points marked "default" on the diagrams."""
    import inspect
    from lsc.solvers import reference, scipy_ode, stiffness

    def default(fn, name):
        return inspect.signature(fn).parameters[name].default

    out = {"reference": f"dt={default(reference.solve, 'dt'):g}",
           # (no integrator named: DOP853, but for a stiff damping law, lsc.solvers.stiffness)
           f"scipy {default(scipy_ode.solve, 'integrator') or stiffness.DEFAULT}":
               f"rtol={default(scipy_ode.solve, 'rtol'):g}"}
    if have_diffrax():
        from lsc.solvers import diffrax_ode
        out[f"diffrax {default(diffrax_ode.solve, 'integrator')}"] = \
            f"rtol={default(diffrax_ode.solve, 'rtol'):g}"
    return out


def _short_setting(setting: str) -> str:
    """``"rtol=1e-06"`` → ``"1e-6"``, ``"dt=0.0003"`` → ``"3e-4"`` (a tolerance point's label)."""
    value = setting.split("=", 1)[-1]
    try:
        value = f"{float(value):.0e}"
    except ValueError:
        pass
    return value.replace("e-0", "e-").replace("e+0", "e+")


def compile_note(rows: list[dict], name: str) -> str:
    """The diffrax compile times of one scene (left out of the plotted times), in words."""
    times = {}
    for r in rows:
        c = float(r["compile_s"])
        if r["scene"] == name and np.isfinite(c):
            times[r["method"]] = max(times.get(r["method"], 0.0), c)
    if not times:
        return ""
    return ("JIT compile, not in the times: "
            + ", ".join(f"{m.split(' ', 1)[-1]} up to {t:.2g} s" for m, t in times.items()))


def figure(rows: list[dict], name: str, title: str, defaults: dict | None = None):
    """The work-precision diagram of one scene as a matplotlib Figure: one colour and marker
    per method (the same in every panel), each tolerance point labelled with its tolerance or
    step, the default settings ringed, diffrax's compile time stated in the title."""
    from matplotlib.figure import Figure

    defaults = default_settings() if defaults is None else defaults
    fig = Figure(figsize=(8.5, 5.2), layout="constrained")
    ax = fig.add_subplot()
    methods = [m for m in dict.fromkeys(r["method"] for r in rows if r["scene"] == name)]
    methods.sort(key=lambda m: (ALL_METHODS + [m]).index(m))
    ringed = False
    for m in methods:
        pts = sorted((float(r["error"]), float(r["time_s"]), r["setting"])
                     for r in rows if r["scene"] == name and r["method"] == m)
        e, t, settings = zip(*pts)
        style = method_style(m)
        ax.loglog(e, t, "-" if len(e) > 1 else "none", marker=style["marker"],
                  color=style["color"], label=m, markersize=5 if len(e) > 1 else 11)
        for x, y, setting in pts:
            if setting != "-":
                ax.annotate(_short_setting(setting), (x, y), xytext=(3, 3),
                            textcoords="offset points", fontsize=5.5, color=style["color"])
            if defaults.get(m) == setting:
                ax.plot(x, y, ls="none", marker="o", ms=13, mfc="none", mec="k", mew=1.2,
                        label=None if ringed else "default setting of lsc.solve")
                ringed = True
    agree = REF_AGREEMENT.get(name, 0.0)
    if agree > 0:
        ax.axvline(agree, color="0.5", ls="--", lw=1)
        ax.text(agree, ax.get_ylim()[1], " reference's own accuracy", color="0.4", fontsize=7,
                va="top", rotation=90)
    ax.set_xlabel("max relative error (ΔV1, ΔV2, duration, peak force)")
    ax.set_ylabel("time per solve (s), compile excluded")
    note = compile_note(rows, name)
    ax.set_title(f"Work–precision: {title}" + (f"\ndiffrax {note}" if note else ""),
                 fontsize="medium")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return fig


def plot(rows: list[dict], name: str, title: str, out: Path) -> None:
    """The work-precision diagram of one scene: ``out/work_precision_<name>.png``."""
    figure(rows, name, title).savefig(out / f"work_precision_{name}.png", dpi=120)


def cheapest(rows: list[dict]) -> list[list[str]]:
    """Per scene and accuracy level: the fastest run that reached it, and the fastest
    integrator (not an exact backend) that did: rows of text cells."""
    out = []
    for name in dict.fromkeys(r["scene"] for r in rows):
        for level in LEVELS:
            agree = REF_AGREEMENT.get(name, 0.0)
            if not agree <= level:  # the reference is not that accurate (or not checked)
                out.append([name, f"{level:g}", f"(the reference is good to {agree:.1g} only)",
                            "", "", "", ""])
                continue
            ok = [r for r in rows if r["scene"] == name and r["error"] <= level]
            if not ok:
                out.append([name, f"{level:g}", "(none reached it)", "", "", "", ""])
                continue
            best = min(ok, key=lambda r: r["time_s"])
            integ = [r for r in ok if r["method"] not in ("closed-form", "exact")]
            ib = min(integ, key=lambda r: r["time_s"]) if integ else None
            out.append([name, f"{level:g}", best["method"], best["setting"],
                        f"{best['time_s'] * 1e3:.3f}",
                        f"{ib['method']} ({ib['setting']})" if ib else "(none)",
                        f"{ib['time_s'] * 1e3:.3f}" if ib else ""])
    return out


HEADER = ["scene", "accuracy", "cheapest method", "setting", "time (ms)",
          "cheapest integrator", "its time (ms)"]


def cheapest_table(rows: list[dict]) -> str:
    """The :func:`cheapest` table in markdown."""
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    lines += ["| " + " | ".join(cells) + " |" for cells in cheapest(rows)]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Work-precision study of lsc's backends.")
    ap.add_argument("--quick", action="store_true", help="a smoke run (under a minute)")
    ap.add_argument("--out", default="compare-out", help="output folder")
    ap.add_argument("--repeat", type=int, default=None, help="timed repeats per point")
    ap.add_argument("--scenes", nargs="*", default=list(SCENES), help="which scenes")
    ap.add_argument("--replot", action="store_true",
                    help="only redraw the diagrams from the --out folder's compare_integrators.csv "
                         "(the references' agreement is recomputed; nothing is timed)")
    args = ap.parse_args(argv)
    if args.replot:
        return replot(Path(args.out), args.scenes)
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
        print(f"scene {name} ...", flush=True)
        t0 = time.perf_counter()
        rows += run_scene(name, scene, args.quick, repeat)
        print(f"  {time.perf_counter() - t0:.1f} s", flush=True)
        plot(rows, name, scene.name, out)
    with open(out / "compare_integrators.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    table = cheapest_table(rows)
    (out / "cheapest.md").write_text(table + "\n")
    with open(out / "cheapest.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(HEADER)
        w.writerows(cheapest(rows))
    print(table)
    print(f"\nwrote {out}/compare_integrators.csv, {out}/cheapest.md and the PNG diagrams")
    return 0


def replot(out: Path, names) -> int:
    """Redraw the diagrams of ``names`` from ``out/compare_integrators.csv``."""
    with open(out / "compare_integrators.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for name in names:
        if any(r["scene"] == name for r in rows):
            scene = lsc.Scene.load(SCENES[name])
            reference_metrics(name, scene)
            plot(rows, name, scene.name, out)
            print(f"redrew {out}/work_precision_{name}.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
