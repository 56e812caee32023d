"""Questions asked of the model, as functions (values in the scene's unit system):

- :func:`max_closing_speed`: the paper's severity bound, the speed at which the peak contact force
  reaches a bumper failure force (Table 3), by root finding;
- :func:`calibrate_force_scale`: the force factor that makes a measured crash-test IF-D table bring
  the vehicles to a common velocity at its last point (the paper's 1.14, 1.18, 1.16);
- :func:`mer`, :func:`mer_for`: Momentum–Energy–Restitution ΔVs, to set beside a simulation;
- :func:`monte_carlo`: percentiles of ΔV, peak acceleration, pulse and peak force over sampled
  scene parameters;
- :func:`sensitivity`: derivatives (and elasticities) of ΔV, peak acceleration and pulse duration
  with respect to masses, speeds, stiffness and restitution, by forward-mode autodiff through the
  diffrax solve (events included) or by finite differences;
- :func:`global_sensitivity`: Sobol' first-order and total indices of the metrics over the
  uncertain inputs of an ``[uncertainty]`` table (SALib, with confidence intervals);
- :func:`read_measured`, :func:`measured_curve`, :func:`series_measured`: measured force–deflection
  data as loading curves; :func:`cfc_filter`: the SAE J211 / ISO 6487 CFC filter;
- :func:`read_channels`: crash-test channels from CSV/TSV/Excel tables or ISO-MME data sets;
  :func:`iso18571`: the ISO/TS 18571 objective rating of two time histories; :func:`compare`: a
  simulation beside its test (pulses, metric differences, ratings);
- :func:`ifd_loop`: the dynamic IF-D loop of a test (load cell and displacement, or both
  accelerations) as a scene's loading and unloading tables; :func:`fit`: least-squares fit of
  scene parameters to test channels, with standard errors and ISO/TS 18571 ratings.
"""

from .bounds import Bound, max_closing_speed, peak_force
from .calibration import Calibration, calibrate_force_scale, energy_force_scale
from .channels import Channel, Channels, read_channels
from .compare import Comparison, compare
from .global_sensitivity import GlobalSensitivity, global_sensitivity
from .fit import FitResult, fit, sampled_channels, scene_toml
from .filters import CFC_CLASSES, cfc_coefficients, cfc_filter, cfc_response, j211_corridor
from .measured import (curve_table, envelope, measured_curve, read_columns, read_measured,
                       series_measured)
from .ifd_loop import IFDLoop, ifd_loop
from .iso18571 import ISO18571Rating, iso18571
from .mer import MER, format_mer, mer, mer_for
from .sensitivity import Sensitivity, default_params, sensitivity
from .uncertainty import MonteCarlo, monte_carlo, sample

__all__ = [
    "max_closing_speed", "Bound", "peak_force",
    "calibrate_force_scale", "energy_force_scale", "Calibration",
    "mer", "mer_for", "format_mer", "MER",
    "monte_carlo", "sample", "MonteCarlo",
    "sensitivity", "Sensitivity", "default_params", "global_sensitivity", "GlobalSensitivity",
    "read_measured", "read_columns", "measured_curve", "series_measured", "curve_table", "envelope",
    "cfc_filter", "cfc_coefficients", "cfc_response", "j211_corridor", "CFC_CLASSES",
    "read_channels", "Channels", "Channel", "iso18571", "ISO18571Rating", "compare", "Comparison",
    "ifd_loop", "IFDLoop", "fit", "FitResult", "sampled_channels", "scene_toml",
]
