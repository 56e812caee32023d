"""The diffrax backend's public names, gathered from the modules that hold them (importing this
imports JAX): what :mod:`lsc.solvers.diffrax_ode` forwards to on first use.

- :mod:`.compiled`: float64, the compilation cache, :class:`~.compiled.Compiled`, ``TRACES``;
- :mod:`.wrappers`: the integrators and the solver wrappers;
- :mod:`.dips`, :mod:`.peaks`: events and peaks inside a step;
- :mod:`.core`: the segment loop, its status codes and cache;
- :mod:`.single`: :func:`solve`; :mod:`.batch`: :func:`solve_batch`, :func:`solve_params`;
- :mod:`.derivatives`: :func:`metrics_jacobian`.
"""

from __future__ import annotations

from .batch import BATCH_METRICS, CHUNK, solve_batch, solve_params
from .compiled import TRACES
from .core import STATUS_CODES, check_settings, status_message
from .derivatives import DIFFERENTIATED, metrics_jacobian
from .dips import _CHEB_DIP, _DIP_POINTS, dip_floor  # noqa: F401  (read by the dip tests)
from .single import solve
from .wrappers import INTEGRATORS

__all__ = ["solve", "solve_batch", "solve_params", "metrics_jacobian", "check_settings",
           "status_message", "INTEGRATORS", "BATCH_METRICS", "DIFFERENTIATED", "STATUS_CODES",
           "TRACES", "CHUNK", "dip_floor"]
