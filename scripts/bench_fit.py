"""Benchmark: a two-parameter fit (loading stiffness, restitution) to a 10 kHz, 200 ms pulse.

The 'measured' channels are the default scene's accelerations (two 3500 lbf cars, 10 ft/s,
24,000 lbf/ft, e = 0.4) sampled at 10 kHz from first contact to 200 ms; the fit starts at
1.5 k and e = 0.2. Timed on the exact backend (``auto``: the closed form here) and on diffrax,
compilation included (the first diffrax solve of the process is inside the timed fit).
Targets (issue 14): under 2 s exact, under 10 s diffrax, on a 2-core machine.

    python scripts/bench_fit.py
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

import lsc
import lsc.data
from lsc.analysis.fit import fit, sampled_channels

PARAMS = ["contacts.0.loading.stiffness", "contacts.0.unloading.restitution"]


def main() -> None:
    truth = lsc.Scene.load(lsc.data.load("default"))
    t = np.round(np.arange(0, 2001) / 1e4, 12)
    chans = sampled_channels(lsc.solve(truth, n_samples=40000), t)
    chans = replace(chans, channels={n: chans[n] for n in ("accel_bullet", "accel_target")})
    start = truth.with_values({PARAMS[0]: 36000, PARAMS[1]: 0.2})
    for method, run in (("auto", "first"), ("diffrax", "compile included"), ("diffrax", "compiled")):
        t0 = time.perf_counter()
        f = fit(start, chans, PARAMS, method=method)
        wall = time.perf_counter() - t0
        k, e = (f.values[p] for p in PARAMS)
        print(f"{method:8s} ({f.method}, {run}): {wall:6.2f} s, {f.nfev} simulations, "
              f"k = {k:.9g} lbf/ft, e = {e:.9g}")


if __name__ == "__main__":
    main()
