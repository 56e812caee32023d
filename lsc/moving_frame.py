"""The moving frame a segment is integrated in (:meth:`lsc.model.HybridModel.frame`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["Frame"]


class Frame(NamedTuple):
    """The moving frame one segment is integrated in (:meth:`HybridModel.frame`): each vehicle's
    position from where it was at the segment start ``t0`` [s] (``x0`` (N,) [length]), less the
    motion of the frame ``V (t - t0)`` (``V`` [velocity]), and velocities less ``V``; contact
    ``k``'s gap becomes ``-D0_k`` (:meth:`params`), so that its deformation is
    ``D0_k + (u_k - u_{k+1})``, resolved to the ulps of ``D`` itself, not of the positions. A
    pytree (JAX traces it as three arrays). States are laid out as the model's: ``(n, ...)``,
    the state first, at times ``t`` of shape ``(...)``."""

    t0: Any
    x0: Any
    V: Any

    def params(self, p):
        """The parameters the model is evaluated on in this frame (its gaps moved)."""
        x0 = self.x0
        return dict(p, gap=-(x0[:-1] - x0[1:] - p["gap"]))

    def shift(self, t, xp=np):
        """Where the frame's origin of each vehicle is at time(s) ``t`` (N, ...) [length]."""
        t = xp.asarray(t, dtype=float)
        x0 = xp.reshape(self.x0, xp.shape(self.x0) + (1,) * t.ndim)
        return x0 + self.V * (t - self.t0)

    def to_abs(self, t, u, xp=np):
        """Absolute state(s) ``y`` (n, ...) at time(s) ``t`` (...) from frame states ``u``."""
        N = xp.shape(self.x0)[0]
        return xp.concatenate([u[:N] + self.shift(t, xp), u[N:2 * N] + self.V, u[2 * N:]])

    def to_frame(self, t, y, xp=np):
        """Frame state(s) ``u`` (n, ...) at time(s) ``t`` (...) from absolute states ``y``."""
        N = xp.shape(self.x0)[0]
        return xp.concatenate([y[:N] - self.shift(t, xp), y[N:2 * N] - self.V, y[2 * N:]])
