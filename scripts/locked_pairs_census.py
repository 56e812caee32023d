"""How many near-plastic chains chatter, with and without locked pairs (lsc.locking).

Draws random 3-5 car chains (tests/hard/test_chains.py's ``chains`` strategy: e from 0 to 0.05,
masses 1 to 1000 slug; stiffness ratios between neighbouring contacts clipped to ``--ratio``),
solves each with SciPy on the plain model (as before locked pairs) and on the model with locks,
at most ``--events`` events, and counts: chattered before (stopped at a limit) and finish now;
still stop; finished before and give the same metrics (to 1e-10) or different ones.

    PYTHONPATH=$PWD python scripts/locked_pairs_census.py --n 80 --seed 3 --integrator DOP853

With ``--exact``: each chain by exact-chain (which locks by the same rules) and by SciPy with
locks at ``--rtol``: how many each finishes, whether they give the same events (kind and
contact) and how far their metrics are apart (relative, binned), why exact-chain stops, and the CPU time per chain of each (``auto`` picks exact-chain).

    PYTHONPATH=$PWD python scripts/locked_pairs_census.py --n 40 --seed 3 --exact
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

METRICS = ("delta_v", "v_final", "max_deformation", "peak_force")


def clip_ratio(scene, ratio):
    """``scene`` with each contact's stiffness within ``ratio`` of its rear neighbour's (a
    table's forces scaled as a whole)."""
    prev = None
    for c in scene["contacts"]:
        load = c["loading"]
        k = load["stiffness"] if "stiffness" in load else load["table"][1][1] / load["table"][1][0]
        if prev is not None:
            f = min(max(k, prev / ratio), prev * ratio) / k
            if "stiffness" in load:
                load["stiffness"] = k * f
            else:
                load["table"] = [[d, F * f] for d, F in load["table"]]
            k *= f
        prev = k
    return scene


def draw(n, seed, ratio):
    """``n`` chains from the hard suite's strategy, reproducibly."""
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hseed

    from hard.test_chains import chains

    out = []

    @hseed(seed)
    @settings(max_examples=n, database=None, phases=[Phase.generate], deadline=None,
              suppress_health_check=list(HealthCheck))
    @given(chains(n_max=5, e_min=0.0, e_max=0.05))
    def collect(case):
        out.append(clip_ratio(case[1], ratio))
    collect()
    return out


def solve(scene, locks, integrator, events, method="scipy", **kw):
    """``(result or None, error or None, CPU seconds)``."""
    import lsc
    import lsc.solvers.scipy_ode as scipy_ode
    from lsc.locking import locking_model

    scipy_ode.locking_model = locking_model if locks else (lambda model: model)
    if method != "scipy":
        kw = {}
    else:
        kw = dict(kw, integrator=integrator)
    t0 = time.process_time()
    try:
        r = lsc.solve(scene, method=method, max_events=events, **kw)
        return r, None, time.process_time() - t0
    except lsc.SimulationError as err:
        return None, str(err), time.process_time() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=80)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--ratio", type=float, default=1000.0)
    ap.add_argument("--events", type=int, default=200)
    ap.add_argument("--integrator", default="DOP853")
    ap.add_argument("--exact", action="store_true",
                    help="exact-chain against SciPy, both with locks")
    ap.add_argument("--rtol", type=float, default=1e-12)
    args = ap.parse_args()
    if args.exact:
        return exact_census(args)
    counts, why = Counter(), Counter()
    for i, scene in enumerate(draw(args.n, args.seed, args.ratio)):
        before, _, _ = solve(scene, False, args.integrator, args.events)
        after, err, cpu = solve(scene, True, args.integrator, args.events)
        if after is None:
            why[err.split(":")[0] if "impact" in err else err[:40]] += 1
        if before is None:
            counts["chattered, finish now" if after is not None else "chattered, still stop"] += 1
        elif after is None:
            counts["finished, stop now"] += 1
        else:
            off = max(float(np.max(np.abs(np.asarray(getattr(after, k), float)
                                          - np.asarray(getattr(before, k), float))))
                      / max(float(np.max(np.abs(getattr(before, k)))), 1e-300) for k in METRICS)
            counts["finished, same" if off <= 1e-10 else "finished, changed"] += 1
        print(i, "stops:" if after is None else f"{len(after.events)} events", err or "",
              f"({cpu:.2f} s)", flush=True)
    print(dict(counts))
    print("why the rest stop:", dict(why))


def exact_census(args):
    """Exact-chain against SciPy (both locking) on the drawn chains: counts and CPU times."""
    counts, why, cpu = Counter(), Counter(), {"exact-chain": [], "scipy": []}
    for i, scene in enumerate(draw(args.n, args.seed, args.ratio)):
        exact, err, t_exact = solve(scene, True, args.integrator, args.events, "exact-chain")
        ref, err_ref, t_ref = solve(scene, True, args.integrator, args.events, rtol=args.rtol)
        cpu["exact-chain"].append(t_exact)
        cpu["scipy"].append(t_ref)
        if exact is None:
            why[err.split(" by t =")[0].split(":")[0 if "impact" in err else -1][:70]] += 1
        key = ("exact-chain finishes" if exact is not None else "exact-chain stops") + (
            ", scipy finishes" if ref is not None else ", scipy stops")
        if exact is not None and ref is not None:
            same = [(e.kind, e.index) for e in exact.events] == [(e.kind, e.index)
                                                                for e in ref.events]
            offs = {k: float(np.max(np.abs(np.asarray(getattr(exact, k), float)
                                           - np.asarray(getattr(ref, k), float))))
                    / max(float(np.max(np.abs(getattr(ref, k)))), 1e-300) for k in METRICS}
            key += (", same events" if same else ", other events") + next(
                f", ΔV to {tol:g}" for tol in (1e-8, 1e-6, 1e-4, np.inf)
                if offs["delta_v"] <= tol) + next(
                f", all metrics to {tol:g}" for tol in (1e-8, 1e-6, 1e-4, np.inf)
                if max(offs.values()) <= tol)
        counts[key] += 1
        locked = exact is not None and bool(exact.warnings)
        print(i, key, "(locked)" if locked else "", err or "",
              f"exact {t_exact:.3f} s, scipy {t_ref:.3f} s", flush=True)
    print(dict(counts))
    print("why exact-chain stops:", dict(why))
    for name, ts in cpu.items():
        print(f"{name}: CPU per chain: median {np.median(ts):.3f} s, mean {np.mean(ts):.3f} s")


if __name__ == "__main__":
    main()
