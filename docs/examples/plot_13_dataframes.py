"""
Results in pandas and xarray, as in a notebook
==============================================

A crash's time series and metrics as pandas DataFrames, a sweep as one row per member, and a
grid sweep as an xarray Dataset with one dimension per swept parameter. Units travel with the
data: in every column name (``"v[bullet] (ft/s)"``) and in ``df.attrs["units"]`` (in a
Dataset, in each variable's ``attrs["units"]``). Run this file cell by cell in Jupyter (or
VS Code): each cell's last expression is shown as a table, as on this page.

:mod:`lsc.frames` holds the functions; xarray and pyarrow (for Parquet files) come with
``pip install "lsc[frames]"``.
"""

import matplotlib.pyplot as plt

import lsc
from lsc import data
from lsc.frames import result_frame, summary_frame, sweep_frame, sweep_xarray

scene = data.load("default")  # the paper's parametric study 1 at e = 0.4
r = lsc.solve(scene)
df = result_frame(r)
df.head()

# %%
# One row per vehicle, per contact and for the scene; each metric in its own part's rows:
summary_frame(r)

# %%
# The units of every column are in ``attrs`` too, for code that must not parse names:
df.attrs["units"]

# %%
# Plotting from the frame: the target's acceleration in g.
ax = (df["a[target] (ft/s^2)"] / scene.g).plot(figsize=(6, 3.5))  # g = 32.2 ft/s² here
ax.set_xlabel(df.index.name)
ax.set_ylabel("target acceleration (g)")
plt.tight_layout()

# %%
# A grid sweep: closing speed × restitution. As a DataFrame, one row per member (the swept
# values, every metric, the member's status), ready for ``to_parquet`` or ``groupby``:
s = lsc.sweep(scene, {"vehicles.0.speed": [4.0, 6.0, 8.0, 10.0],
                      "contacts.0.unloading.restitution": [0.2, 0.4, 0.6]}, grid=True)
sweep_frame(s)[["vehicles.0.speed (ft/s)", "contacts.0.unloading.restitution",
                "delta_v[target] (ft/s)", "peak_acceleration_g[target]", "status"]]

# %%
# As an xarray Dataset: one dimension per swept path, the metrics on the grid. ΔV of the
# target depends on both parameters, the peak acceleration on the speed only (restitution
# shapes the unloading, not the peak):
ds = sweep_xarray(s)
ds["delta_v"].sel(vehicle="target").to_pandas()

# %%
ds["peak_acceleration_g"].sel(vehicle="target").to_pandas()
