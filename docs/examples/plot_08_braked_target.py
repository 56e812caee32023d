"""
A braked target: stick, slip and a friction impulse
===================================================

The target stands with its brakes on (μ = 0.7, μs = 0.8). Below the break-away force it does not
move at all and the bullet rebounds as off a wall; above it the target slides and the tyre
friction takes momentum out of the crash, so ΔV is no longer set by restitution alone. The
unbraked bullet may then catch the stopped target again: the simulation goes on until no contact
can close any more, and ``delta_v`` is taken at the last separation — so a target that slides,
stops and is struck again can end the crash with ΔV = 0: its velocity series ``r.v`` shows how
fast it moved in between.
"""

import matplotlib.pyplot as plt

import lsc

base = lsc.Scene.load({
    "units": "US", "g": "32.2 ft/s^2",
    "vehicles": [{"name": "bullet", "weight": 3500, "speed": 4},
                 {"name": "target", "weight": 3500, "speed": 0,
                  "brake": {"mu": 0.7, "mu_static": 0.8}}],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}],
})
fig, ax = plt.subplots(figsize=(6, 4))
for v in (2.0, 4.0, 8.0):
    r = lsc.solve(base.with_values({"vehicles.0.speed": v}))
    moved = r.x[-1, 1]
    kinds = sorted({ev.kind for ev in r.events})
    print(f"v0 = {v} ft/s: peak force {r.peak_force[0]:.0f} lbf (break-away {0.8 * 3500:.0f}), "
          f"ΔV = ({r.delta_v[0]:+.3f}, {r.delta_v[1]:+.3f}) ft/s, target slid {moved:.4f} ft; "
          f"events: {', '.join(kinds)}")
    ax.plot(r.t, r.v[:, 1], label=f"target, v0 = {v} ft/s")
ax.set(xlabel="time (s)", ylabel="target velocity (ft/s)", title="Braked target")
ax.legend()
fig.tight_layout()
