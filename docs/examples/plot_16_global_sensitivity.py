"""
Global sensitivity: which uncertain input drives ΔV and the peak acceleration?
==============================================================================

Derivatives (:func:`lsc.analysis.sensitivity`) answer *which input matters most* at one point.
Over the whole range of uncertain inputs, the question is how much of a metric's variance each
input explains: the Sobol' indices. :func:`lsc.analysis.global_sensitivity` takes the
distributions of an ``[uncertainty]`` table, solves SALib's Sobol' design (``n (d + 2)``
members for ``d`` inputs) with :func:`lsc.sweep`, and returns each input's first-order index
S1 (its effect alone) and total index ST (alone and through its interactions), with bootstrap
95 % intervals.
"""

from pathlib import Path

from lsc.analysis import global_sensitivity
from lsc.analysis.cli import load_with_uncertainty

# A Test 3-like crash: a piecewise-linear IF-D table, uncertain closing speed, target weight,
# table force scale and restitution (docs/examples/test3_uncertainty.toml).
# (sphinx-gallery runs the example from its own folder, where ``__file__`` is not set)
here = Path(__file__).parent if "__file__" in globals() else Path.cwd()
scene, distributions = load_with_uncertainty(str(here / "test3_uncertainty.toml"))
g = global_sensitivity(scene, distributions, metrics=["delta_v", "peak_acceleration_g"],
                       n=1024, seed=2026)
print(g.summary())

# %%
# The table (a pandas DataFrame; ``g.to_csv(path)`` writes it)
g.table.round(3)

# %%
# The bar chart: S1 and ST of every input, with their intervals. Where ST is close to S1 the
# input acts alone (the model is nearly additive in it); the gap ST - S1 is its share through
# interactions. An input a metric does not depend on gets zero, within its interval.
fig = g.plot()
