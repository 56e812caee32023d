"""
Parametric study 3: closing speed (Fig. 11)
===========================================

With the stiffness and restitution fixed, the pulse lasts the same at every closing speed
(π/(2ω)(1 + e) = 0.1046 s here) while its height grows in proportion to the speed.
"""

import matplotlib.pyplot as plt

import lsc

scene = lsc.Scene.load({
    "units": "US", "g": "32.2 ft/s^2",
    "vehicles": [{"name": "bullet", "weight": 3500, "speed": 10},
                 {"name": "target", "weight": 3500, "speed": 0}],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}],
})
fig, ax = plt.subplots(figsize=(6, 4))
for v in (2, 4, 6, 8, 10, 12):
    r = lsc.solve(scene.with_values({"vehicles.0.speed": v}))
    ax.plot(r.t, r.a[:, 1] / 32.2, label=f"{v} ft/s")
    print(f"v0 = {v:>2} ft/s: duration {r.duration:.6f} s, peak {r.peak_acceleration_g[1]:.3f} g, "
          f"ΔV2 = {r.delta_v[1]:.2f} ft/s")
ax.set(xlabel="time (s)", ylabel="target acceleration (g)", title="Fig. 11")
ax.legend()
fig.tight_layout()
