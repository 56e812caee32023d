"""
Table 3: bounding a crash by a bumper's failure force
=====================================================

The paper's technique: the bullet's front bumper (a 2007 Kia Sportage, linear 30,000 lb/ft)
failed at about 5,000 lb in the lab, and was not damaged in the subject crash, so the peak impact
force stayed below 5,000 lb. With the target's bumper (a 2007 Ford Edge, 48,000 lb/ft) in series
the system IF-D line is 18,462 lb/ft (Eq. 11), and restitution is set high (e = 0.8) to maximise
ΔV. :func:`lsc.analysis.max_closing_speed` finds the closing speed at which the peak force reaches
the failure force by root finding, instead of trial speeds.
"""

import numpy as np

import lsc
from lsc.analysis import max_closing_speed

scene = lsc.Scene.load({
    "name": "Table 3", "units": "US", "g": "32.2 ft/s^2",
    "vehicles": [{"name": "bullet", "weight": 3500, "speed": 5},
                 {"name": "target", "weight": 3500, "speed": 0}],
    "contacts": [{"loading": {"series": [{"stiffness": 48000}, {"stiffness": 30000}]},
                  "unloading": {"restitution": 0.8}}],
})
print(f"system stiffness: {scene.contacts[0].law.loading.stiffness:.1f} lb/ft")

bound = max_closing_speed(scene, "5000 lbf")
print(bound.summary())

# %%
# The paper's Table 3, and the closed-form root ``v = F / √(kμ)`` for comparison:
print(f"{'speed (ft/s)':>12} {'peak force (lb)':>16} {'ΔV2 (ft/s)':>11}")
for v in (4, 5, 6):
    r = lsc.solve(scene.with_values({"vehicles.0.speed": v}))
    print(f"{v:>12} {r.peak_force[0]:>16.0f} {r.delta_v[1]:>11.1f}")
mu = 3500 / 32.2 / 2
print(f"root: {bound.speed:.9f} ft/s; closed form: {5000 / np.sqrt(18462 * mu):.9f} ft/s "
      f"(18,462 rounded) / {5000 / np.sqrt(scene.contacts[0].law.loading.stiffness * mu):.9f}")
