"""JAX set-up and the compile cache of the diffrax backend.

Importing this module turns float64 on (``jax_enable_x64``) and the persistent compilation cache
(:mod:`lsc.solvers.jax_setup`), before anything is compiled: on first use of
``method="diffrax"``, never at ``import lsc``.

Compilation. One compiled solver per scene *structure* (:func:`structure`: vehicle and contact
counts, contact laws and effects, table lengths), integrator, ``max_steps`` and ``max_events``;
every number (masses, speeds, curves, restitution, ``rtol``, ``atol``, ``t_end``) is a traced
argument, so a scene whose structure was compiled before runs without retracing.
:class:`Compiled` measures compile time apart from run time.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import jax
from .. import jax_setup  # noqa: E402, F401  (the persistent compilation cache, before any compile)

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
from jax import lax  # noqa: E402

__all__ = ["TRACES", "Compiled", "structure", "f64", "to_numpy", "bucket"]

#: Trace counters, ``core`` and ``sampler`` (a Python side effect runs only while JAX traces).
TRACES = {"core": 0, "sampler": 0}


def structure(model) -> tuple:
    """Hashable structure of a model: what the traced code branches on (no numbers)."""
    parts = []
    for part in model.parts:
        attrs = tuple(sorted((k, v) for k, v in vars(part).items()
                             if isinstance(v, (bool, int, str, np.integer, np.bool_))))
        parts.append((type(part).__name__, attrs))
    leaves, tree = jax.tree_util.tree_flatten(model.params)
    return (model.N, model.K, model.n_state, tuple(parts), str(tree),
            tuple(np.shape(a) for a in leaves))


def canon(disc):
    """The discrete state with fixed dtypes (int32 / float64, never weak), for loop carries."""
    def one(a):
        a = jnp.asarray(a)
        dt = jnp.int32 if jnp.issubdtype(a.dtype, jnp.integer) else (
            jnp.bool_ if a.dtype == jnp.bool_ else jnp.float64)
        return lax.convert_element_type(a, dt)
    return jax.tree_util.tree_map(one, disc)


def flat(disc):
    """A discrete state as one float64 vector (its integer codes are exact in float64)."""
    return jnp.concatenate([jnp.ravel(a).astype(jnp.float64)
                            for a in jax.tree_util.tree_leaves(disc)])


def unflat(rows, like):
    """The discrete states in the rows ``(n, L)`` of ``rows``, structured and typed as ``like``."""
    leaves, tree = jax.tree_util.tree_flatten(like)
    return jax.tree_util.tree_unflatten(
        tree, [rows[..., i].astype(a.dtype) for i, a in enumerate(leaves)])


def bucket(n: int, least: int) -> int:
    """Next power of two >= max(n, least): few array shapes, few sampler compiles."""
    n = max(int(n), int(least), 1)
    return 1 << (n - 1).bit_length()


def f64(x):
    """``x`` as a float64 NumPy array (the dtype of every traced number of the backend)."""
    return np.asarray(x, dtype=np.float64)


def to_numpy(tree):
    """A pytree of JAX arrays as NumPy arrays."""
    return jax.tree_util.tree_map(np.asarray, tree)


class Compiled:
    """A jitted function and its ahead-of-time compiled executables, keyed by argument shapes
    (so that compile time is measured apart from run time). :meth:`warm` compiles for given
    shapes in a background thread ahead of the first call (which then waits for it).
    ``options``: XLA compiler options (then the compiled executable itself is called)."""

    def __init__(self, fn, options: dict | None = None):
        self.fn = jax.jit(fn)
        self.options = options
        self.exe = {}
        self.pending = {}

    def _compile(self, args):
        return self.fn.lower(*args).compile(self.options)

    @staticmethod
    def _key(args):
        leaves, tree = jax.tree_util.tree_flatten(args)
        return (tree, tuple((np.shape(a), np.asarray(a).dtype.str) for a in leaves))

    def warm(self, *args) -> None:
        """Compile for the shapes and dtypes of ``args`` (their values are not used) in a
        background thread (:data:`WARMING`), unless compiled or under way already."""
        key = self._key(args)
        if key not in self.exe and key not in self.pending:
            self.pending[key] = WARMING.submit(self._compile, args)

    def __call__(self, *args):
        key = self._key(args)
        compile_time = 0.0
        if key not in self.exe:
            t0 = time.perf_counter()
            job = self.pending.pop(key, None)
            # (a warm-up under way: its wait is this call's compile time)
            self.exe[key] = job.result() if job is not None else self._compile(args)
            compile_time = time.perf_counter() - t0
        # run through the jitted function: its C++ dispatch is several times cheaper than an
        # AOT executable's, and it finds the executable just compiled (no retrace, no compile)
        t0 = time.perf_counter()
        out = jax.block_until_ready(self.exe[key](*args) if self.options else self.fn(*args))
        return out, compile_time, time.perf_counter() - t0


#: The threads :meth:`Compiled.warm` compiles in (XLA compiles one program on one core; two
#: programs compile side by side on two).
WARMING = ThreadPoolExecutor(max_workers=2, thread_name_prefix="lsc-compile")
