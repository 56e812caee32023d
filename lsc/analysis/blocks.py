"""Monte Carlo samples drawn a block at a time, for a study written as it is solved.

A study of ``n`` members is cut into blocks of :data:`SAMPLE_BLOCK` members; block ``b`` is
drawn from its own generator, ``numpy.random.default_rng(SeedSequence(seed, spawn_key=(b,)))``
(the ``b``-th child of ``SeedSequence(seed).spawn``), so a member's values depend on the seed and
its index only: never on how the study is cut into tasks, nor on where they run. By design:

- ``random``: each block's paths drawn as :func:`lsc.analysis.sampling.sample` draws them
  (path by path, or a Gaussian copula for correlated inputs) from the block's generator. (These
  are not the values that ``sample(..., seed)`` draws for the whole study at once from one
  generator.)
- ``sobol``: the scrambled Sobol' sequence of ``sample(..., seed)``, point for point (one
  engine, drawn in member order).
- ``lhs``: the Latin hypercube of ``sample(..., seed)`` (its ``n × d`` unit points are held:
  a hypercube is stratified over the whole study).

``function`` specs are evaluated per block, with the block's generator.
"""

from __future__ import annotations

import numpy as np

from .sampling import (Inputs, _qmc_engine, apply_functions, correlate, design_points,
                       map_points, unit_points, warn_sobol_count)

__all__ = ["BlockSampler", "SAMPLE_BLOCK"]

#: Members per sampling block (each its own child generator).
SAMPLE_BLOCK = 4096


class BlockSampler:
    """The members of a Monte Carlo study (``n`` and ``chunk(start, stop)``: path → values
    [scene units]), drawn a block at a time; ``seed``: the entropy used (a fresh one for
    ``None``, so that the study can be repeated)."""

    def __init__(self, spec: Inputs, sampling: str, n: int, seed=None):
        self.spec, self.sampling, self.n = spec, sampling, int(n)
        self.seed = np.random.SeedSequence(seed).entropy
        self.d = len(spec.marginals)
        self._engine, self._next = None, 0      # the Sobol' engine and its next point
        self._block = (None, None)              # (index, values) of the last block drawn
        self._design = None
        if sampling == "sobol":
            warn_sobol_count(self.n, "n")
        elif sampling == "lhs":
            self._design = unit_points("lhs", self.n, self.d, np.random.default_rng(self.seed),
                                       spec.rank_correlation)

    def chunk(self, start: int, stop: int) -> dict:
        """The members ``start:stop``."""
        parts = []
        for b in range(start // SAMPLE_BLOCK, (stop - 1) // SAMPLE_BLOCK + 1):
            first = b * SAMPLE_BLOCK
            values = self.block(b)
            parts.append({p: v[max(start, first) - first:stop - first]
                          for p, v in values.items()})
        return {p: np.concatenate([part[p] for part in parts]) for p in parts[0]}

    def block(self, b: int) -> dict:
        """The values of block ``b`` (the last one drawn is kept: chunks may share a block)."""
        if self._block[0] == b:
            return self._block[1]
        first, stop = b * SAMPLE_BLOCK, min(self.n, (b + 1) * SAMPLE_BLOCK)
        m = stop - first
        rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(b,)))
        spec = self.spec
        if self.sampling == "random" and spec.rank_correlation is None:
            out = {p: dist.draw(rng, m) for p, dist in spec.marginals.items()}
        else:
            out = map_points(spec, self._points(first, m, rng))
        values = apply_functions(spec, out, rng, m)
        self._block = (b, values)
        return values

    def _points(self, first: int, m: int, rng) -> np.ndarray:
        """Unit points ``first:first + m`` (m, d) of the design."""
        if self.d == 0:
            return np.empty((m, 0))
        if self.sampling == "random":
            return unit_points("random", m, self.d, rng, self.spec.rank_correlation)
        if self.sampling == "lhs":
            return self._design[first:first + m]
        return correlate(self._sobol(first, m), self.spec.rank_correlation)

    def _sobol(self, first: int, m: int) -> np.ndarray:
        """Sobol' points ``first:first + m`` of the engine ``sample`` would seed (drawn in
        order; an engine is rebuilt and fast-forwarded only when asked out of order)."""
        from scipy.stats import qmc

        if self._engine is None or self._next != first:
            self._engine = _qmc_engine(qmc.Sobol, self.d, np.random.default_rng(self.seed),
                                       scramble=True)
            if first:
                self._engine.fast_forward(first)
        self._next = first + m
        return design_points(self._engine, m)
