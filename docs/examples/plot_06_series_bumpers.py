"""
Appendix B: two bumpers in series
=================================

At equal force the two bumpers' deformations add (Eq. 11 generalised): for two lines
``S = 1/(1/S_a + 1/S_b)``; for measured curves the system curve is built point by point in force.
Here a measured-like Edge front bumper (a soft honeycomb absorber for the first 0.021 ft, then a
stiffer impact bar) meets a Sportage rear bumper; the dotted curve is the system IF-D curve the
simulation uses (the paper's Fig. B5).
"""

import matplotlib.pyplot as plt
import numpy as np

import lsc
from lsc.curves import Curve

edge = Curve.table([[0, 0], [0.021, 300], [0.1, 3500], [0.3, 13000], [0.45, 22000]])
sportage_rear = Curve.table([[0, 0], [0.05, 1500], [0.2, 8000], [0.35, 17500]])
system = Curve.series(edge, sportage_rear)

F = np.linspace(0, 17000, 7)
print(" force (lb)   D_edge (ft)   D_sportage (ft)   D_system (ft)")
for f in F:
    print(f"{f:>10.0f}   {edge.deformation_at(f):>11.4f}   {sportage_rear.deformation_at(f):>15.4f}"
          f"   {system.deformation_at(f):>13.4f}")

fig, ax = plt.subplots(figsize=(6, 4))
for c, label, style in ((edge, "Edge front", "-"), (sportage_rear, "Sportage rear", "-"),
                        (system, "system (series)", ":")):
    ax.plot(c.d, c.f, style, marker="o", ms=3, label=label)
ax.set(xlabel="deformation (ft)", ylabel="force (lb)", title="Bumpers in series (Fig. B5)")
ax.legend()
fig.tight_layout()

# %%
# The same combination in a scene, and a crash with it:
scene = {"units": "US", "g": "32.2 ft/s^2",
         "vehicles": [{"name": "bullet", "weight": 4246, "speed": 5.9},
                      {"name": "target", "weight": 3382, "speed": 0}],
         "contacts": [{"loading": {"series": [{"table": edge_t} for edge_t in
                                              (np.column_stack([edge.d, edge.f]).tolist(),
                                               np.column_stack([sportage_rear.d,
                                                                sportage_rear.f]).tolist())]},
                       "unloading": {"restitution": 0.5}}]}
r = lsc.solve(scene)
print(r.summary())
