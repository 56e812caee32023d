"""
Bumper failure with a post-failure curve
========================================

The paper's car-to-car scene (3500 lb each, 24,000 lbf/ft, e = 0.4) with a bumper that fails at
5000 lbf. Given only ``failure = { force = ... }`` the result just says whether and when the
force reached it. With a ``post_failure`` curve the bumper also *behaves* differently once it has
failed: its loading follows the virgin curve up to the deformation ``D_f`` where that reaches the
failure force (here ``D_f = 5000 / 24000`` ft = 2.5 in), then the post-failure curve counted from
there — here the force drops to 2500 lbf and rises at 15,000 lbf/ft (the softer structure
behind the failed bar). The drop is a vertical step in the IF-D loop; unloading works from the spliced
curve as from any loading curve (the energy restitution takes its area up to ``D_max``).

A softer structure behind the failed bar absorbs the crash over more crush and with a lower
peak force than the intact bumper; ΔV, set by momentum and restitution alone, is unchanged.
"""

import matplotlib.pyplot as plt

import lsc
from lsc.plots import ifd_loop

scene = {
    "units": "US", "g": "32.2 ft/s^2",
    "vehicles": [{"name": "bullet", "weight": 3500, "speed": 12},
                 {"name": "target", "weight": 3500, "speed": 0}],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4},
                  "failure": {"force": "5000 lbf",
                              "post_failure": {"table": [[0, 2500], [1.0, 17500]]}}}],
}
intact = {**scene, "contacts": [{**scene["contacts"][0], "failure": {"force": "5000 lbf"}}]}

fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharex=True, sharey=True)
for ax, (name, sc) in zip(axes, (("intact bumper", intact), ("with post-failure curve", scene))):
    r = lsc.solve(sc)
    print(f"{name} ({r.method}): failed at t = {r.failure_time[0] * 1000:.3f} ms, "
          f"D_max = {r.max_deformation[0] * 12:.3f} in, peak force {r.peak_force[0]:.0f} lbf, "
          f"D_perm = {r.permanent_deformation[0] * 12:.3f} in, "
          f"ΔV = ({r.delta_v[0]:+.4f}, {r.delta_v[1]:+.4f}) ft/s")
    ifd_loop(r, ax=ax)
    ax.set_title(name)
