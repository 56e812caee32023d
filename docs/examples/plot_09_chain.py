"""
A three-car chain
=================

Three cars in line, the last one struck. With elastic bumpers, equal masses and a gap before the
front car long enough that the two contacts never overlap in time, the speed passes down the
chain exactly, as for billiard balls; when the contacts overlap it does not.
"""

import matplotlib.pyplot as plt
import numpy as np

import lsc

def chain(gap):
    return {"units": "SI", "vehicles": [{"name": n, "mass": 1200, "speed": s}
                                         for n, s in (("rear", 2.0), ("middle", 0), ("front", 0))],
            "contacts": [{"loading": {"stiffness": 1e5}, "unloading": {"restitution": 1.0}},
                         {"loading": {"stiffness": 1e5}, "unloading": {"restitution": 1.0},
                          "gap": gap}]}

fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
for ax, gap in zip(axes, (0.5, 0.0)):
    r = lsc.solve(chain(gap), t_end=1.0)
    for i, name in enumerate(("rear", "middle", "front")):
        ax.plot(r.t, r.v[:, i], label=name)
    ax.set(xlabel="time (s)", title=f"gap before the front car: {gap} m")
    print(f"gap {gap} m: final speeds {np.round(r.v_final, 6)} m/s, "
          f"momentum {np.sum(1200 * r.v_final):.9f} kg m/s")
axes[0].set_ylabel("velocity (m/s)")
axes[0].legend()
fig.tight_layout()
