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
# Which digits lsc reproduces, and why
# ------------------------------------
#
# The paper's Table 3 gives, at 4, 5 and 6 ft/s, peak forces of 4007, 5009 and 6011 lb and
# ΔV2 of 3.6, 4.5 and 5.4 ft/s. ``lsc`` (``auto`` picks the closed form here: the exact
# answer, ``F = v √(kμ)`` with ``μ = m1 m2 / (m1 + m2)``) gives the ΔV2 digits, and the peak
# forces 4006.7, 5008.4 and 6010.0 lb: the first rounds to the paper's 4007, the other two are
# one pound below it. The paper's last digits are what its own computation gives, not the
# physics: its fixed-step algorithm (Eqs. 1–8, ``method="reference"``) at the time step it
# chose with Table 1, ``dt = 1e-5`` s, which overshoots the peak force slightly, with the
# system stiffness it quotes, 18,462 lb/ft (rounded: the series value of 48,000 and 30,000
# lb/ft is 18,461.5). The table below computes each of these; only both together round to
# every one of the paper's forces (the code checks it).
paper = {4: (4007, 3.6), 5: (5009, 4.5), 6: (6011, 5.4)}
rounded = scene.with_values({"contacts.0.loading": {"stiffness": 18462}})
ways = {"exact": (scene, {}),
        "dt=1e-5": (scene, {"method": "reference", "dt": 1e-5}),
        "dt=1e-5,k=18462": (rounded, {"method": "reference", "dt": 1e-5})}
print(f"{'speed':>5} {'paper':>6} " + " ".join(f"{w:>15}" for w in ways) + f" {'ΔV2':>6}")
peaks = {}
for v, (force, dv2) in paper.items():
    runs = [lsc.solve(base.with_values({"vehicles.0.speed": v}), **options)
            for base, options in ways.values()]
    peaks[v] = [r.peak_force[0] for r in runs]
    print(f"{v:>5} {force:>6} " + " ".join(f"{p:>15.3f}" for p in peaks[v])
          + f" {runs[0].delta_v[1]:>6.3f}")
    assert round(runs[0].delta_v[1], 1) == dv2
print("peak force (lb) exact, by the paper's algorithm, and with its rounded stiffness; "
      "speed and ΔV2 (ft/s)")
matches = [all(round(peaks[v][j]) == paper[v][0] for v in paper) for j in range(len(ways))]
print("rounds to every one of the paper's forces:", dict(zip(ways, matches)))
assert matches == [False, False, True]
print(f"relative overshoot at 5 ft/s: time step {peaks[5][1] / peaks[5][0] - 1:.1e}, "
      f"rounded stiffness {peaks[5][2] / peaks[5][1] - 1:.1e}")

# %%
# So the numbers to quote are the exact ones (4006.7, 5008.4, 6010.0 lb): the paper's differ
# from them by its time step and its rounded stiffness (both below 1e-4 relative, see also
# :doc:`/backends`), far inside the uncertainty of a bumper's failure force. The bound itself does not depend on any
# of this: the root above agrees with the closed form ``v = F / √(kμ)``:
mu = 3500 / 32.2 / 2
print(f"root: {bound.speed:.9f} ft/s; closed form: "
      f"{5000 / np.sqrt(scene.contacts[0].law.loading.stiffness * mu):.9f} ft/s "
      f"(with 18,462 lb/ft: {5000 / np.sqrt(18462 * mu):.9f})")
