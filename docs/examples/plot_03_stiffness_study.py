"""
Parametric study 2: stiffness (Fig. 10)
=======================================

System stiffness from 12,000 to 72,000 lb/ft with e = 0.4: ΔV1 = -7 and ΔV2 = 7 ft/s at every
stiffness (they depend only on masses, closing speed and restitution), while a stiffer bumper
shortens the pulse and raises its peak, both as √k.
"""

import matplotlib.pyplot as plt
import numpy as np

import lsc

scene = lsc.Scene.load({
    "units": "US", "g": "32.2 ft/s^2",
    "vehicles": [{"name": "bullet", "weight": 3500, "speed": 10},
                 {"name": "target", "weight": 3500, "speed": 0}],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}],
})
ks = np.arange(12000, 72001, 12000)
s = lsc.sweep(scene, {"contacts.0.loading.stiffness": ks})
for k, dv, T, a in zip(ks, s.delta_v, s.duration, s.peak_acceleration_g[:, 1]):
    print(f"k = {k:>6d} lb/ft: ΔV = ({dv[0]:+.2f}, {dv[1]:+.2f}) ft/s, duration {T:.4f} s, "
          f"peak {a:.2f} g")

fig, ax = plt.subplots(figsize=(6, 4))
for k in ks:
    r = lsc.solve(scene.with_values({"contacts.0.loading.stiffness": float(k)}))
    ax.plot(r.t, r.a[:, 1] / 32.2, label=f"{k:,} lb/ft")
ax.set(xlabel="time (s)", ylabel="target acceleration (g)", title="Fig. 10")
ax.legend()
fig.tight_layout()
