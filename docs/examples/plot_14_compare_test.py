"""
A simulation beside a crash test: ISO-MME channels, metric differences, ISO/TS 18571
====================================================================================

The packaged data set ``synthetic_test`` is **synthetic**: the packaged default scene (two
3500 lbf cars, 10 ft/s, 24,000 lbf/ft, e = 0.4) simulated, sampled at 10 kHz with a 20 ms
pre-trigger, given Gaussian sensor noise and filtered to SAE J211 CFC 60
(``scripts/make_synthetic_test.py`` makes it). It ships as a CSV table and as an ISO-MME 1.6 zip
with the same numbers. Here it is read and compared with two simulations: the scene it came from,
and the same scene with a restitution of 0.3.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import lsc
import lsc.data
from lsc.analysis import compare, read_channels

data = Path(lsc.data.__file__).parent
test = read_channels(data / "synthetic_test.zip")
print(f"{len(test)} channels at {test.sample_rate:.0f} Hz, {test.pre_trigger} pre-trigger samples")
for ch in test:
    print(f"  {ch.name}  {ch.label:13s} {ch.kind:13s} [{ch.unit}]")

scene = lsc.data.load("default")
for e in (0.4, 0.3):
    result = lsc.solve(scene.with_values({"contacts.0.unloading.restitution": e}))
    comparison = compare(result, test)
    print(f"\nsimulation with e = {e}:")
    print(comparison.to_frame().to_string(index=False, float_format="{:.4g}".format))
    for channel, rating in comparison.iso18571.items():
        print(f"  ISO/TS 18571 {channel}: corridor {rating.corridor:.3f}, phase {rating.phase:.3f}, "
              f"magnitude {rating.magnitude:.3f}, slope {rating.slope:.3f}, total {rating.total:.3f}")

# %%
# The last comparison (e = 0.3) as a figure: measured and simulated acceleration and ΔV.
comparison.figure()
plt.show()
