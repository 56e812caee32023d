"""
From test channels to a fitted scene: IF-D loop, least-squares fit, rating
==========================================================================

The packaged data set ``synthetic_test`` is **synthetic** (the packaged default scene — two
3500 lbf cars, 10 ft/s, 24,000 lbf/ft, e = 0.4 — simulated, sampled at 10 kHz, given sensor noise
and filtered to SAE J211 CFC 60; ``scripts/make_synthetic_test.py``), so the answer is known.
Here its dynamic IF-D loop is drawn from the load cell and displacement channels, the bumper
stiffness and restitution of a scene that starts wrong (30,000 lbf/ft, e = 0.25) are fitted to
both vehicles' accelerations, and the fitted scene is compared with the test and written as TOML.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import lsc
import lsc.data
from lsc.analysis import calibrate_force_scale, fit, ifd_loop, read_channels

test = read_channels(Path(lsc.data.__file__).parent / "synthetic_test.csv")
scene = lsc.data.load("default")

# %%
# The dynamic IF-D loop (the paper's Fig. 3): force against deformation, split at the maximum
# deformation into a loading and an unloading table that a scene takes as they are.
loop = ifd_loop(test, scene)
print(f"loop from {loop.source}: D_max = {loop.max_deformation:.4f} ft, F_max = {loop.max_force:.0f} lbf, "
      f"permanent set {loop.permanent_set:.4f} ft")
print("  " + "; ".join(loop.notes))
loop.figure()

# %%
# The fit: stiffness and restitution from wrong starting values, against both accelerations.
STIFFNESS, RESTITUTION = "contacts.0.loading.stiffness", "contacts.0.unloading.restitution"
start = scene.with_values({STIFFNESS: 30000, RESTITUTION: 0.25})
result = fit(start, test, [STIFFNESS, RESTITUTION], roles=["accel_bullet", "accel_target"])
print(result.summary())

# %%
# The fitted crash beside the test (the paper's Figs. 6-7), its metric differences and ratings.
comparison = result.comparison()
print(comparison.to_frame().to_string(index=False, float_format="{:.4g}".format))
comparison.figure()

# %%
# The fitted scene, as TOML (``lsc run`` reads it back).
with tempfile.TemporaryDirectory() as tmp:
    text = result.to_toml(Path(tmp) / "fitted.toml")
print(text)

# %%
# The paper's force-scale calibration as a special case: the measured loading table with its
# forces scaled by one factor. The calibration finds the factor that brings the vehicles to their
# common velocity at the table's last point (one equation: the energy the table absorbs up to its
# end is the closing energy ½ μ v0²); the fit finds the factor that best reproduces the
# accelerations (the table extended beyond its last point, so that any factor gives a crash).
# On channels that agree with Newton's law the two answers agree to the noise, as here.
measured = scene.with_values({"contacts.0.loading": loop.loading_spec(),
                              "contacts.0.unloading": {"restitution": 0.4}})
calibration = calibrate_force_scale(measured)
extended = scene.with_values({"contacts.0.loading": {
    "table": loop.loading.tolist() + [[2 * loop.max_deformation, 2 * loop.max_force]]},
    "contacts.0.unloading": {"restitution": 0.4}})
scaled = fit(extended, test, ["contacts.0.loading.scale"], roles=["accel_bullet", "accel_target"])
print(f"calibrate_force_scale: {calibration.factor:.4f}; fitted scale: "
      f"{scaled.values['contacts.0.loading.scale']:.4f} ± {scaled.standard_errors['contacts.0.loading.scale']:.4f}")
plt.show()
