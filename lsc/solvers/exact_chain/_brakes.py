"""Braking (stick and slip, :class:`lsc.effects.BrakeEffect`) in the exact chain.

A sliding braked vehicle feels the constant friction force ``-μ m g dir``: it enters the
segment's constant force (``q''(0) = Tᵀ (f_contacts + f_friction)``, :class:`~._modes.Motion`'s
``push``), and its acceleration has that constant offset. A stuck vehicle is held: it does not
move, so its degree of freedom leaves the modal problem (:class:`~._modes.Shape` with ``held``:
a contact of non-zero slope to it grounds its neighbours' group, which then has no rigid mode).

The events are the model's, each a :class:`~._modes.Series` found by the same search that
misses no root: the stop, ``dir v_i(τ)`` through zero while sliding (the vehicle's velocity
in the modes, a sinusoid sum plus the rigid modes' line), and the break-aways,
``μ_s m g ∓ net_i(τ)`` while stuck (the net contact force on the vehicle is linear in the
deformations). The
transitions are the model's (:meth:`~lsc.effects.BrakeEffect.on_event`); a stop sets the
vehicle's speed to zero exactly, and a held vehicle stays exactly where it is.
"""

from __future__ import annotations

import numpy as np

from ._modes import Series

__all__ = ["Brakes"]

_EPS = float(np.finfo(float).eps)


class Brakes:
    """The braked vehicles of one chain: ``(part index, vehicle, μ g [acceleration], μ_s m g
    [force])`` each, from the model's :class:`~lsc.effects.BrakeEffect` parts."""

    def __init__(self, model):
        m = np.asarray(model.params["m"], float)
        self.parts = {}
        for b in model.brakes:
            j = model.parts.index(b)
            g = float(b.params["g"])
            self.parts[j] = (b.i, float(b.params["mu"]) * g,
                             float(b.params["mus"]) * float(m[b.i]) * g)
        self.m = m
        self.force_scale = float(model.force_scale())   # [force] (once per chain)

    def state(self, disc):
        """``(held, push)``: the stuck vehicles (a sorted tuple) and the friction force on each
        vehicle (N,) [force] (``None`` where none slides)."""
        held, push = [], None
        for j, (i, mu_g, _) in self.parts.items():
            st = disc[j]
            if float(st["slide"]):
                if push is None:
                    push = np.zeros(self.m.size)
                push[i] = -mu_g * self.m[i] * float(st["dir"])
            else:
                held.append(i)
        return tuple(sorted(held)), push

    def vehicle(self, j: int) -> int:
        """The vehicle braked by part ``j``."""
        return self.parts[j][0]

    def event_function(self, chain, motion, disc, j: int, which: int, slopes, force, tol_w,
                       start_tol):
        """``(Series, tolerance at the start)`` of brake part ``j``'s event ``which`` (0: the
        stop, ``dir v_i`` through zero while sliding; 1, 2: break-away forward, backward, the
        static limit less or plus the net contact force ``net_i``, while stuck)."""
        i, _, limit = self.parts[j]
        if which == 0:
            return motion.velocity(i, float(disc[j]["dir"])), tol_w
        inc = chain.incidence[i]
        net0 = float(inc @ force)
        row = (inc * slopes) @ motion.P   # net_i(τ) - net_i(0) = row q(τ)
        sign = -1.0 if which == 1 else 1.0
        tol = start_tol * self.force_scale + \
            16 * _EPS * (limit + float(np.abs(inc) @ np.abs(force)))
        return Series(limit + sign * net0, sign * row * motion.a, sign * row * motion.b,
                      motion.modes), tol
