"""
Sensitivities: which inputs the answer depends on most
======================================================

A reconstruction rests on inputs known only roughly: speeds, weights, the bumpers' IF-D curve,
the restitution. :func:`lsc.analysis.sensitivity` gives the derivative of ΔV, peak acceleration
and pulse duration with respect to each of them, at the crash as given, by differentiating the
simulation itself: forward-mode automatic differentiation through the diffrax solve, the events
(breakpoints of the table, the common velocity, the separation) included. Each derivative is in
the scene's units (ft/s of ΔV per ft/s of speed, per lbf of weight, ...); the elasticity,
``(∂M/∂p) p / M``, is the percent change of the metric per percent change of the parameter, and
ranks them in a tornado chart.

The scene is a crash like the paper's Test 3 (a 4246 lbf bullet at 5.9 ft/s into a 3382 lbf
target) with a measured-like system IF-D table that rises, holds at 8500 lbf and rises again.
"""

import matplotlib.pyplot as plt
import numpy as np

import lsc
from lsc.analysis import sensitivity
from lsc.plots import tornado

scene = lsc.Scene.load({
    "name": "Test 3-like crash", "units": "US", "g": "32.2 ft/s^2",
    "vehicles": [{"name": "bullet", "weight": 4246, "speed": 5.9},
                 {"name": "target", "weight": 3382, "speed": 0}],
    "contacts": [{"loading": {"table": [[0, 0], [0.021, 300], [0.1, 2500], [0.2, 6500],
                                        [0.24, 8500], [0.45, 8500], [0.6, 12500]]},
                  "unloading": {"restitution": 0.3}}],
})
s = sensitivity(scene, metrics=("delta_v", "peak_acceleration_g", "duration"))
print(s.summary())

# %%
# The same derivatives by fourth-order central differences of the exact piecewise solve (no
# autodiff): they agree to about 1e-9 relative, far inside what a report needs.
fd = sensitivity(scene, metrics=("delta_v", "peak_acceleration_g", "duration"),
                 method="finite-difference")
for m in s.derivatives:
    a, b = s.derivatives[m], fd.derivatives[m]
    big = np.abs(s.elasticities[m]) > 1e-6          # leave out the parameters without effect
    rel = np.max(np.abs(a - b)[big] / np.abs(b)[big])
    print(f"{m:>20}: largest relative difference autodiff vs finite differences {rel:.1e}")
print(f"autodiff: {s.stats['steps']} steps, {s.stats['segments']} segments, "
      f"{1e3 * s.stats['wall_time']:.1f} ms after a one-off compile of {s.stats['compile_time']:.0f} s")

# %%
# For a linear IF-D the elasticities are the closed forms' exponents: ΔV is proportional to the
# closing speed (1) and to ``(1 + e)``, the peak force to ``√k`` (1/2), the pulse to ``1/√k``
# (-1/2) and does not depend on the speed. With this table the crush runs onto the 8500 lbf
# plateau: the peak force is the plateau's, so the peak acceleration no longer grows with the
# speed, a curve with more force (``loading.scale``) raises it one for one, and only the target's
# own weight lowers it:
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 3.8), layout="constrained")
tornado(s, "delta_v", "target", ax=ax1)
tornado(s, "peak_acceleration_g", "target", ax=ax2)
for ax in (ax1, ax2):
    ax.set_title(ax.get_title().split("\n")[-1], fontsize=10)

# %%
# With the uncertainty of each input as a swing (scene units, or strings with units), the chart
# shows the first-order range of the metric: here the target's ΔV for a speed known to ±0.5 mph,
# weights to ±100 lbf, the curve's force level to ±10 % and the restitution to ±0.1.
fig = plt.figure(figsize=(7, 3.6), layout="constrained")
tornado(s, "delta_v", "target", ax=fig.add_subplot(),
        swing={"vehicles.0.speed": "0.5 mph", "vehicles.0.weight": "100 lbf",
               "vehicles.1.weight": "100 lbf", "contacts.0.loading.scale": 0.1,
               "contacts.0.unloading.restitution": 0.1})
