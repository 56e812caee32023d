"""Benchmark: one 3-car chain by the exact chain backend against the SciPy solve.

On the same scene (a pile-up at a light: a car at 15 mph runs into two stopped cars, the front
pair 0.1 ft apart), measured side by side in one run: the time of ``lsc.solve`` (minimum over
repeats, scene already loaded) by ``exact-chain`` and by ``scipy`` DOP853 at rtol = 1e-10, their
ratio, and how far the SciPy metrics are from the exact ones (max over ΔV, peak force, max
deformation, relative to each metric's scale).

    python scripts/bench_chain.py [--repeat 20] [--chatter 10 [--seed 1] [--max-events 150]]
    PYTHONPATH=/work/main python scripts/bench_chain.py --dump main.pkl
    python scripts/bench_chain.py --against main.pkl

Also printed: the same exact solve with its kept modes dropped before each solve (a chain whose
masses and slopes were not solved before: the eigensolves are paid again), from the scene's dict
(``lsc.solve(dict)``: the Scene kept by content, :mod:`lsc.scene._cache`, its model built anew
each time), the time of the exact
segment loop alone (``stats["wall_time"]``) and what comes on top of it in ``lsc.solve`` (the
model, the backend's checks, the peaks inside the segments, searched after the loop for all
segments at once, and the Result's metrics).

``--dump FILE`` / ``--against FILE``: every metric and event of 260 chains
(:func:`agreement_chains`) solved by one version of ``lsc`` (the one on ``PYTHONPATH``), saved,
then compared with another's: the outcomes, the sequences of events, how many chains differ in
some number (not bit for bit) and the largest relative difference.

``--chatter N``: N random near-plastic chains (3 or 4 vehicles, restitutions 0 to 0.05,
stiffnesses 1e2 to 1e9 lbf/ft, tables with a plateau, gaps: the near-plastic strategy of
tests/hard/test_chains.py), where a contact at its permanent set that a neighbour pushes shut
closes and separates over and over: the wall time and outcome of ``auto`` (exact-chain, which
stops where a pair would lock) and of SciPy (its default DOP853, which locks it), how far their
final speeds are apart where both finish, and the totals.

Target (issue 13): exact-chain at least 50x faster than SciPy at rtol = 1e-10.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import lsc

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))   # (the tests' chains)

SCENE = {
    "name": "three-car pile-up at a light",
    "units": "US",
    "vehicles": [{"weight": 3500, "speed": "15 mph"}, {"weight": 2800, "speed": 0},
                 {"weight": 4200, "speed": 0}],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}},
                 {"loading": {"stiffness": 50000}, "unloading": {"restitution": 0.3},
                  "gap": 0.1}],
}


def best_time(scene, repeat: int, fresh: bool = False, **kw):
    """``(minimum wall time of lsc.solve [s], minimum stats wall time [s], the last Result)``;
    ``fresh``: the exact chain's kept modes (:class:`~lsc.solvers.exact_chain._modes.Shape`)
    dropped before each solve, as for a chain whose masses and slopes were not solved before."""
    from lsc.solvers.exact_chain._modes import Shape

    times, inner, r = [], [], None
    for _ in range(repeat):
        if fresh:
            Shape._cache.clear()
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
    ap.add_argument("--chatter", type=int, default=0, help="near-plastic chains to compare")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-events", type=int, default=150)
    ap.add_argument("--dump", metavar="FILE", help="solve the agreement chains, save them, stop")
    ap.add_argument("--against", metavar="FILE", help="compare the agreement chains with a dump")
    args = ap.parse_args()
    if args.dump or args.against:
        agreement(args.dump, args.against)
        return
    scene = lsc.Scene.load(SCENE)
    lsc.solve(scene, method="exact-chain")   # (imports and first-call costs out of the way)
    lsc.solve(scene, method="scipy", rtol=1e-10)
    t_exact, loop_exact, exact = best_time(scene, args.repeat, method="exact-chain")
    t_fresh, loop_fresh, _ = best_time(scene, args.repeat, True, method="exact-chain")
    t_dict, loop_dict, _ = best_time(SCENE, args.repeat, method="exact-chain")
    t_scipy, loop_scipy, scipy = best_time(scene, args.repeat, method="scipy", rtol=1e-10)
    print(f"scene: {SCENE['name']} ({len(exact.events)} events)")
    print(f"{'method':<22}{'lsc.solve [ms]':>16}{'solve loop [ms]':>17}{'diff vs exact':>15}")
    print(f"{'exact-chain':<22}{1e3 * t_exact:>16.3f}{1e3 * loop_exact:>17.3f}{0.0:>15.1e}")
    print(f"{'exact-chain, new modes':<22}{1e3 * t_fresh:>16.3f}{1e3 * loop_fresh:>17.3f}"
          f"{0.0:>15.1e}")
    print(f"{'exact-chain, dict':<22}{1e3 * t_dict:>16.3f}{1e3 * loop_dict:>17.3f}{0.0:>15.1e}")
    print(f"{'scipy DOP853 1e-10':<22}{1e3 * t_scipy:>16.3f}{1e3 * loop_scipy:>17.3f}"
          f"{difference(scipy, exact):>15.1e}")
    print(f"speed-up of exact-chain: {t_scipy / t_exact:.1f}x (target 50x); of its "
          f"{1e3 * t_exact:.3f} ms, {1e3 * (t_exact - loop_exact):.3f} ms outside the segment loop;"
          f" {t_scipy / t_fresh:.1f}x where its modes are computed anew (masses and slopes not "
          "solved before)")
    if args.chatter:
        chatter(args.chatter, np.random.default_rng(args.seed), args.max_events)


def _log_uniform(rng, lo: float, hi: float) -> float:
    return float(10.0 ** rng.uniform(np.log10(lo), np.log10(hi)))


def near_plastic_chain(rng) -> dict:
    """A random near-plastic chain (the strategy of tests/hard/test_chains.py, e <= 0.05)."""
    n = int(rng.integers(3, 5))
    start = rng.choice(["gaps", "touching", "simultaneous", "at_rest"])
    if start == "simultaneous":
        closing, gaps = [_log_uniform(rng, 1e-2, 50.0)] * (n - 1), \
            [_log_uniform(rng, 1e-3, 1.0)] * (n - 1)
    elif start == "at_rest":
        closing, gaps = [_log_uniform(rng, 1e-2, 50.0)] + [0.0] * (n - 2), [0.0] * (n - 1)
    else:
        closing = [0.0 if rng.random() < 0.3 else _log_uniform(rng, 1e-3, 50.0)
                   for _ in range(n - 1)]
        closing[0] = closing[0] or 1.0
        gaps = [0.0 if start == "touching" or rng.random() < 0.3 else
                _log_uniform(rng, 1e-4, 1.0) for _ in range(n - 1)]
    v = [0.0 if rng.random() < 0.5 else float(rng.uniform(-30.0, 60.0))]
    for c in reversed(closing):
        v.insert(0, v[0] + c)
    contacts = []
    for gap in gaps:
        k0 = _log_uniform(rng, 1e2, 1e9)
        d1 = _log_uniform(rng, 1e-3, 0.5)
        loading = {"stiffness": k0} if rng.random() < 0.5 else {"table": [
            [0.0, 0.0], [d1, k0 * d1], [2 * d1, k0 * d1], [1e3, k0 * d1 + 10 * k0 * 1e3]]}
        e = rng.choice([0.0, 1e-6, float(rng.uniform(0.0, 0.05)),
                        _log_uniform(rng, 1e-12, 0.05)])
        contacts.append({"loading": loading, "unloading": {"restitution": float(e)},
                         "gap": gap})
    return {"units": "US", "contacts": contacts,
            "vehicles": [{"mass": _log_uniform(rng, 1.0, 1000.0), "speed": vi} for vi in v]}


def _timed(scene, **kw):
    """``(wall time [s], "ok" or the SimulationError's first words, final speeds or None)``."""
    t = time.perf_counter()
    try:
        r = lsc.solve(scene, **kw)
        locked = ", locked" if any("lock" in e.kind.split("+") for e in r.events) else ""
        return time.perf_counter() - t, f"ok, {len(r.events)} events{locked}", r.v_final
    except lsc.SimulationError as err:
        return time.perf_counter() - t, str(err)[:40], None


def chatter(n: int, rng, max_events: int) -> None:
    """``auto`` (exact-chain) against SciPy on ``n`` near-plastic chains."""
    print(f"\nnear-plastic chains, max_events = {max_events}:")
    print(f"{'':>3}{'auto [s]':>10}  {'outcome':<42}{'scipy [s]':>10}  {'outcome':<42}dv/v0")
    tally = {"auto stops where a pair would lock": 0, "auto finishes": 0, "auto stops otherwise": 0,
             "scipy finishes with locks": 0, "scipy finishes, no lock": 0, "scipy stops": 0}
    for j in range(n):
        scene = near_plastic_chain(rng)
        assert lsc.solvers.pick(lsc.Scene.load(scene), "auto") == "exact-chain"
        ta, oa, va = _timed(scene, max_events=max_events)
        ts, os_, vs = _timed(scene, method="scipy", max_events=max_events)
        v0 = max(abs(v["speed"]) for v in scene["vehicles"])
        dv = f"{np.max(np.abs(va - vs)) / v0:.1e}" if va is not None and vs is not None else "-"
        print(f"{j:>3}{ta:>10.3f}  {oa:<42}{ts:>10.3f}  {os_:<42}{dv}", flush=True)
        tally["auto finishes" if va is not None else "auto stops where a pair would lock"
              if "chatters at" in oa else "auto stops otherwise"] += 1
        tally["scipy stops" if vs is None else "scipy finishes with locks" if "locked" in os_
              else "scipy finishes, no lock"] += 1
    print("totals (of", n, "chains):", tally)


def agreement_chains():
    """260 chains: 50 random ones of each of 3 to 6 vehicles (the batch tests' members), 40
    near-plastic ones (many end at the event limit: the same error is expected) and 20 whose
    front contact has a falling table piece (hyperbolic modes)."""
    from test_exact_chain_batch import random_chains

    for N in (3, 4, 5, 6):
        base, values = random_chains(N, 50, seed=100 + N)
        for j in range(50):
            yield base.with_values({p: float(v[j]) for p, v in values.items()})
    rng = np.random.default_rng(7)
    for _ in range(40):
        yield lsc.load_scene(near_plastic_chain(rng))
    rng = np.random.default_rng(8)
    for _ in range(20):
        d1, k = 10 ** rng.uniform(-2, -1), 10 ** rng.uniform(3.5, 5)
        table = [[0, 0], [d1, k * d1], [2 * d1, 0.6 * k * d1], [1e3, 0.6 * k * d1 + 1e4 * k]]
        speeds = (float(rng.uniform(10, 30)), 0.0, 0.0)
        yield lsc.load_scene({
            "units": "US",
            "vehicles": [{"mass": float(10 ** rng.uniform(1.7, 3)), "speed": v} for v in speeds],
            "contacts": [{"loading": {"table": table}, "unloading": {"restitution": 0.3},
                          "gap": float(rng.uniform(0, 0.1))},
                         {"loading": {"stiffness": float(10 ** rng.uniform(3, 6))},
                          "unloading": {"restitution": float(rng.uniform(0.1, 1))}}]})


def agreement(dump: str | None, against: str | None) -> None:
    """Solve :func:`agreement_chains` by exact-chain (``max_events=150``): save every metric
    and event (or the error) to ``dump``, or compare them with a dump made by another version
    (``PYTHONPATH=/other/checkout python scripts/bench_chain.py --dump FILE``): the statuses,
    the sequences of events and the largest relative difference of any metric or event time."""
    import pickle

    from lsc.result import METRICS

    from test_exact_chain_batch import SCALE_OF

    out = []
    for scene in agreement_chains():
        try:
            r = lsc.solve(scene, method="exact-chain", max_events=150)
            out.append(({n: np.asarray(getattr(r, n), float) for n in METRICS},
                        [(e.time, e.kind, e.index) for e in r.events]))
        except lsc.SimulationError as err:
            out.append(str(err))
    if dump:
        with open(dump, "wb") as f:
            pickle.dump(out, f)
        print(f"{len(out)} chains, {sum(isinstance(o, str) for o in out)} errors: {dump}")
        return
    with open(against, "rb") as f:
        ref = pickle.load(f)
    worst, where, differ, unequal = 0.0, None, 0, set()
    for i, (a, b) in enumerate(zip(ref, out)):
        if isinstance(a, str) or isinstance(b, str):
            if a != b:   # (an error against a result, or another error)
                differ += 1
                print(f"chain {i}: a different outcome: {str(a)[:60]} | {str(b)[:60]}")
            continue
        if [e[1:] for e in a[1]] != [e[1:] for e in b[1]]:
            differ += 1
            print(f"chain {i}: a different sequence of events")
            continue
        times = np.array([e[0] for e in a[1]])
        pairs = [("event times", times, np.array([e[0] for e in b[1]]), times)]
        # (each metric relative to its scale in the chain: a permanent deformation to the max
        # deformation's, as the tests compare them; one that is zero has no scale of its own)
        pairs += [(n, v, b[0][n], a[0][SCALE_OF.get(n, n)]) for n, v in a[0].items()]
        for name, x, y, of in pairs:
            ok = ~np.isnan(x)
            if not np.array_equal(ok, ~np.isnan(y)):
                differ += 1
                print(f"chain {i}: {name} defined elsewhere")
            elif ok.any():
                d = float(np.max(np.abs(x[ok] - y[ok])) / max(np.nanmax(np.abs(of)), 1e-300))
                if not np.array_equal(x[ok], y[ok]):
                    unequal.add(i)
                if d > worst:
                    worst, where = d, (i, name)
    print(f"{len(out)} chains, {differ} differ in outcome or events, {len(unequal)} in some "
          f"number (not bit for bit); largest relative difference {worst:.2e} (chain, "
          f"quantity: {where})")


if __name__ == "__main__":
    main()
