"""Compile and run time of diffrax on a chain whose pairs may lock, against the same scene
structure without locks (the plain model) and against SciPy: ``python
scripts/bench_diffrax_locks.py`` (set ``LSC_JAX_CACHE=0`` to measure cold compiles).

The scenes: car 0 (e = 0.3) strikes cars 1 and 2, which touch at rest on a plastic contact of
stiffness 2e6 lbf/ft (it locks and is released 8 times); and tests/test_locked_pairs.py's
PLAIN_CHAIN (e = 0.001, a contact that may lock, no lock fires), with and without the locks.
Prints the compile time of each model's structure (the same scene structure) and the best of
``--repeat`` run times (min over repeats, as the machine is shared)."""

from __future__ import annotations

import argparse
import time

import lsc
import lsc.solvers.diffrax_ode.single as single


#: tests/test_locked_pairs.py's PLAIN_CHAIN: masses [slug], speeds [ft/s], stiffnesses [lbf/ft],
#: restitutions, gaps [ft].
PLAIN = ([64.93816315762113, 100.0, 23.71373705661655], [4.74274741132331, 2.371373705661655, 0.0],
         [10.0 ** 3.5, 10.0 ** 3.5], [0.25, 0.001], [0.0, 0.5])


def plain_chain() -> dict:
    """PLAIN_CHAIN as a scene."""
    m, v, k, e, gaps = PLAIN
    return {"units": "US", "vehicles": [{"mass": mi, "speed": vi} for mi, vi in zip(m, v)],
            "contacts": [{"loading": {"stiffness": ki}, "unloading": {"restitution": ei},
                          "gap": gi} for ki, ei, gi in zip(k, e, gaps)]}


def scene(e_front: float = 0.0) -> dict:
    """The pushed pair (tests/test_exact_chain_locks.py's ``_pushed(2e6)``)."""
    return {"units": "US", "vehicles": [{"mass": 30.0, "speed": 20.0},
                                        {"mass": 40.0, "speed": 0.0},
                                        {"mass": 50.0, "speed": 0.0}],
            "contacts": [{"loading": {"stiffness": 2e3}, "unloading": {"restitution": 0.3},
                          "gap": 0.0},
                         {"loading": {"stiffness": 2e6},
                          "unloading": {"restitution": e_front}, "gap": 0.0}]}


def best(fn, repeat: int) -> float:
    """The least wall time [s] of ``repeat`` calls of ``fn``."""
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return min(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    locked = lsc.solve(scene(), method="diffrax")
    locks = sum("lock" in e.kind.split("+") for e in locked.events)
    print(f"diffrax, locks: compile {locked.stats['compile_time']:.1f} s, "
          f"{len(locked.events)} events, {locks} locks")
    t_lock = best(lambda: lsc.solve(scene(), method="diffrax"), args.repeat)
    t_scipy = best(lambda: lsc.solve(scene(), method="scipy"), args.repeat)
    plain_model, single.locking_model = single.locking_model, (lambda model: model)
    try:
        plain = lsc.solve(plain_chain(), method="diffrax")
        print(f"diffrax, the plain model of the same structure: compile "
              f"{plain.stats['compile_time']:.1f} s")
        t_plain = best(lambda: lsc.solve(plain_chain(), method="diffrax"), args.repeat)
    finally:
        single.locking_model = plain_model
    t_lock_plain = best(lambda: lsc.solve(plain_chain(), method="diffrax"), args.repeat)
    print(f"run (best of {args.repeat}): pushed pair: diffrax with locks {t_lock * 1e3:.0f} ms, "
          f"SciPy {t_scipy * 1e3:.0f} ms; PLAIN_CHAIN (no lock fires): locking model "
          f"{t_lock_plain * 1e3:.0f} ms, plain model {t_plain * 1e3:.0f} ms")


if __name__ == "__main__":
    main()
