"""
Monte Carlo: what the uncertain inputs do to ΔV and peak acceleration
=====================================================================

A reconstruction rarely knows the closing speed or the restitution exactly. Give them as
distributions and :func:`lsc.analysis.monte_carlo` samples them reproducibly (a seed), solves
every sample with :func:`lsc.sweep` on the fastest applicable backend, and reports percentiles.
"""

import lsc
from lsc.analysis import monte_carlo

scene = lsc.Scene.load({
    "units": "US", "g": "32.2 ft/s^2",
    "vehicles": [{"name": "bullet", "weight": 3500, "speed": 5},
                 {"name": "target", "weight": 3500, "speed": 0}],
    "contacts": [{"loading": {"stiffness": 18462}, "unloading": {"restitution": 0.5}}],
})
mc = monte_carlo(scene, {
    "vehicles.0.speed": {"uniform": ["3 ft/s", "6 ft/s"]},
    "contacts.0.unloading.restitution": {"normal": [0.5, 0.08], "min": 0.1, "max": 0.9},
    "vehicles.1.weight": {"triangular": [3200, 3382, 3600]},
}, n=20000, seed=2026)
print(mc.summary())

# %%
fig = mc.histogram("peak_acceleration_g", index=1)
