"""
Parametric study 1: restitution (Figs. 8 and 9)
===============================================

Same vehicles and the same 24,000 lb/ft loading line; the unloading line is chosen for
restitutions from 0 to 1 by the energy definition (``D_perm = D_max (1 - e²)``). The loading
pulses are identical up to the common velocity of 5 ft/s at 0.0748 s; restitution lengthens the
pulse, up to twice as long when e = 1, and raises ΔV, but leaves the peak unchanged.
"""

import matplotlib.pyplot as plt

import lsc

base = {
    "units": "US", "g": "32.2 ft/s^2",
    "vehicles": [{"name": "bullet", "weight": 3500, "speed": 10},
                 {"name": "target", "weight": 3500, "speed": 0}],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.0}}],
}
scene = lsc.Scene.load(base)

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
for e in (0.0, 0.2, 0.4, 0.6, 0.8, 1.0):
    r = lsc.solve(scene.with_values({"contacts.0.unloading.restitution": e}), t_end=0.16)
    ax1.plot(r.deformation[:, 0], r.force[:, 0], label=f"e = {e:.1f}")
    ax2.plot(r.t, r.a[:, 1] / 32.2, label=f"e = {e:.1f}")
    print(f"e = {e:.1f}: duration {r.duration:.4f} s, ΔV2 = {r.delta_v[1]:.2f} ft/s, "
          f"peak {r.peak_acceleration_g[1]:.3f} g, D_perm = {r.permanent_deformation[0]:.3f} ft")
ax1.set(xlabel="deformation (ft)", ylabel="force (lbf)", title="IF-D loops (Fig. 8)")
ax2.set(xlabel="time (s)", ylabel="target acceleration (g)", title="Target pulses (Fig. 9)")
ax1.legend()
fig.tight_layout()
