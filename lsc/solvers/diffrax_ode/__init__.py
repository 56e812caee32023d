"""diffrax backend: the whole hybrid solve as one compiled JAX function (see
:mod:`lsc.solvers.diffrax_ode.core`; its public names are gathered in
:mod:`lsc.solvers.diffrax_ode.api`).

This package's top level holds only the declaration, so reading it imports no JAX; the solver's
names (``solve``, ``solve_batch``, ``solve_params``, ``metrics_jacobian``, ``INTEGRATORS``, ...)
are loaded on first use (PEP 562).
"""

from __future__ import annotations

from ...effects import integrable_features
from ...locking import FEATURE as LOCK
from ..base import Backend
from ..integrable import BUILTIN

#: What diffrax solves: every integrable feature, and locked pairs (:mod:`lsc.locking`, the
#: same transitions as SciPy's, traced); a live set, as SciPy's.
FEATURES = integrable_features(BUILTIN | {LOCK})

__all__ = ["BACKEND", "solve", "solve_batch", "solve_params", "metrics_jacobian", "INTEGRATORS",
           "BATCH_METRICS", "STATUS_CODES", "TRACES"]

#: The diffrax backend's declaration: any number of vehicles, every law and effect, and a
#: batch path (one vmapped compiled solve) for all of them (members whose pairs may lock go
#: to the single solve, :func:`lsc.locking.lock_members`).
BACKEND = Backend(
    name="diffrax", module=__name__ + ".api",
    options=("rtol", "atol", "integrator", "t_end", "max_events", "max_steps", "n_samples"),
    vehicles=(2, None), solves=FEATURES, batch=FEATURES,
    batch_options=("rtol", "atol", "integrator", "t_end", "max_events", "max_steps", "chunk",
                   "workers"),
    requires=("jax", "diffrax"), install="pip install 'lsc[jax]'",
    summary="event-driven diffrax solve, compiled with JAX (batched with vmap)")


def __getattr__(name: str):
    """The solver's names, from :mod:`.api` (which imports JAX) on first use."""
    if name.startswith("__"):
        raise AttributeError(name)
    impl = BACKEND.implementation()
    try:
        return getattr(impl, name)
    except AttributeError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
