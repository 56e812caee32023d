"""
Calibrating a measured crash-test IF-D curve
============================================

The paper could not simulate its crash tests with the measured dynamic IF-D curves as they were:
with the tests' masses and speeds the vehicles had not reached a common velocity when the curve
ended (force and accelerometer data do not follow Newton's second law exactly). It multiplied the
forces by a constant found by iteration — 1.14, 1.18 and 1.16 for Tests 1, 2 and 3 (Fig. 5).
lsc says why such a simulation cannot be completed, and
:func:`lsc.analysis.calibrate_force_scale` finds the constant by root finding.

The curve here is a synthetic measured-like compression branch (a soft start, a plateau, a dip
where the impact bar buckles, a stiff end) for the Test 3 vehicles (4246 and 3382 lbf).
"""

import matplotlib.pyplot as plt
import numpy as np

import lsc
from lsc.analysis import calibrate_force_scale, energy_force_scale, mer_for

measured = [[0, 0], [0.017, 300], [0.052, 2500], [0.087, 2600], [0.139, 5200], [0.174, 4800],
            [0.226, 9000]]
scene = lsc.Scene.load({
    "name": "crash test, measured IF-D", "units": "US",
    "vehicles": [{"name": "bullet", "weight": 4246, "speed": 5.9},
                 {"name": "target", "weight": 3382, "speed": 0}],
    "contacts": [{"loading": {"table": measured}, "unloading": {"restitution": 0.51}}],
})
try:
    lsc.solve(scene)
except lsc.SimulationError as err:
    print("as measured:", err)

# %%
# The factor that puts the common velocity exactly on the curve's last point, found on
# simulations (Brent's method), and the same factor from the energy identity of Appendix A,
# ``c ∫ f dD = ½ μ v0²`` (two free vehicles):
cal = calibrate_force_scale(scene)
print(cal.summary())
print(f"energy identity: {energy_force_scale(scene):.10f}")
r = cal.result
print(f"calibrated crash: ΔV = {np.round(r.delta_v, 3)} ft/s, peak {np.round(r.peak_acceleration_g, 3)} g, "
      f"pulse {r.duration:.4f} s")
m = mer_for(r)
print(f"MER cross-check: ΔV = {np.round(m.delta_v, 6)} ft/s")

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8), layout="constrained")
d, f = np.array(measured).T
ax1.plot(d, f, "-", color="0.3", label="measured")
ax1.plot(d, cal.factor * f, "--", color="C3", label=f"x {cal.factor:.3f} (simulated)")
ax1.plot(r.deformation[:, 0], r.force[:, 0], ":", color="C0", label="simulated IF-D loop")
ax1.set(xlabel="deformation (ft)", ylabel="force (lbf)", title="Fig. 5: measured and modified")
ax1.legend(fontsize=8)
ax2.plot(r.t, r.a / 32.174, label=[v.name for v in scene.vehicles])
ax2.set(xlabel="time (s)", ylabel="acceleration (g)", title="calibrated crash pulse")
ax2.legend()
