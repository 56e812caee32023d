"""Force–deformation curves: linear, piecewise-linear tables, series combinations.

A :class:`Curve` is the loading branch of an IF-D function, ``F = f(D)`` with ``D >= 0`` the
system deformation (the sum of both bumpers' crush) and ``F >= 0`` the contact force, both in the
scene's unit system (m and N, or ft and lbf). It is piecewise linear: breakpoints ``d`` (strictly
increasing, ``d[0] = 0``) with forces ``f``, and beyond the last breakpoint either a straight line
of slope ``end_slope`` (a linear curve is one breakpoint at the origin and ``end_slope = k``) or
nothing (a measured table ends there).

A bumper that fails continues on a post-failure curve: :meth:`Curve.splice` builds the loading
curve it follows, which may have a vertical *step* at the failure point (the force jumps there,
down or up). Such a curve repeats that deformation (``steps=True``); only :meth:`Curve.splice`
makes one, and a user's table with a repeated deformation is still rejected. On a step the
curve takes the force *after* it (:meth:`segment` picks the piece starting there), and
:meth:`pieces` lists the pieces of positive width that a contact law steps through.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Curve"]


@dataclass(frozen=True, eq=False)
class Curve:
    """Piecewise-linear force–deformation curve ``F(D)``.

    Parameters
    ----------
    d : array (n,)
        Breakpoint deformations [length], strictly increasing, ``d[0] == 0``.
    f : array (n,)
        Forces at the breakpoints [force], all ``>= 0``.
    end_slope : float or None
        Slope beyond ``d[-1]`` [force/length]; ``None`` if the curve ends at ``d[-1]``.
    steps : bool
        Allow vertical steps: a deformation repeated once (two consecutive points), the force
        jumping from the first to the second. Set by :meth:`splice` only.
    """

    d: np.ndarray
    f: np.ndarray
    end_slope: float | None = None
    steps: bool = False

    def __post_init__(self):
        d = np.asarray(self.d, dtype=float).reshape(-1)
        f = np.asarray(self.f, dtype=float).reshape(-1)
        if d.shape != f.shape or d.size < 1:
            raise ValueError("deformations and forces must be two equal-length lists of at least one point")
        if not (np.all(np.isfinite(d)) and np.all(np.isfinite(f))):
            raise ValueError("deformations and forces must be finite numbers")
        if d[0] != 0.0:
            raise ValueError(f"a curve starts at zero deformation (first point has deformation {d[0]:g})")
        if d.size > 1 and not np.all(np.diff(d) > 0):
            step = np.diff(d) >= 0
            if self.steps and np.all(step):
                flat = np.diff(d) == 0
                if np.any(flat[1:] & flat[:-1]):
                    raise ValueError("a step repeats a deformation once, not more")
                if flat[-1] and self.end_slope is None:
                    raise ValueError("a table does not end on a step")
            else:
                i = int(np.argmax(~(np.diff(d) > 0))) + 1
                raise ValueError(f"deformations must be strictly increasing (point {i} has "
                                 f"{d[i]:g} after {d[i - 1]:g})")
        if np.any(f < 0):
            i = int(np.argmax(f < 0))
            raise ValueError(f"forces must be >= 0: bumpers push, never pull (point {i} has {f[i]:g})")
        if self.end_slope is None and d.size < 2:
            raise ValueError("a table needs at least two points")
        if self.end_slope is not None and not np.isfinite(self.end_slope):
            raise ValueError("the end slope must be a finite number")
        d.setflags(write=False)
        f.setflags(write=False)
        object.__setattr__(self, "d", d)
        object.__setattr__(self, "f", f)
        if self.end_slope is not None:
            object.__setattr__(self, "end_slope", float(self.end_slope))

    # ----------------------------------------------------------------- constructors
    @classmethod
    def linear(cls, stiffness: float) -> "Curve":
        """A straight line through the origin, ``F = k D`` (``k > 0`` [force/length])."""
        k = float(stiffness)
        if not (np.isfinite(k) and k > 0):
            raise ValueError(f"stiffness must be a positive finite number, got {k:g}")
        return cls(np.zeros(1), np.zeros(1), k)

    @classmethod
    def table(cls, points) -> "Curve":
        """A measured table ``[[D0, F0], [D1, F1], ...]`` (``D0 = 0``), ending at its last point."""
        arr = np.asarray(points, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise ValueError("a table is a list of [deformation, force] pairs")
        if arr.shape[0] < 2:
            raise ValueError(f"a table needs at least two points, got {arr.shape[0]}")
        return cls(arr[:, 0], arr[:, 1], None)

    # ----------------------------------------------------------------- properties
    @property
    def is_linear(self) -> bool:
        """True for a single straight line through the origin."""
        return self.d.size == 1 and self.end_slope is not None and self.f[0] == 0.0

    @property
    def stiffness(self) -> float:
        """Slope of a linear curve [force/length] (``ValueError`` for any other curve)."""
        if not self.is_linear:
            raise ValueError("only a linear curve has a single stiffness")
        return self.end_slope

    @property
    def extends(self) -> bool:
        """True when the curve goes on beyond its last breakpoint."""
        return self.end_slope is not None

    @property
    def d_end(self) -> float:
        """Largest deformation the curve defines [length] (``inf`` if it extends)."""
        return np.inf if self.extends else float(self.d[-1])

    @property
    def slopes(self) -> np.ndarray:
        """Slope of each segment [force/length]; the last entry is the end slope (nan if none).
        A step (a segment of zero width) has slope 0: no deformation lies on it."""
        width = np.diff(self.d)
        inner = np.divide(np.diff(self.f), width, out=np.zeros(width.size), where=width > 0)
        end = np.nan if self.end_slope is None else self.end_slope
        return np.append(inner, end)

    def pieces(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The affine pieces a contact law steps through: start deformation [length], force at
        the start [force], slope [force/length] (the last: the end slope, nan if none) and
        energy absorbed up to the start [energy]. Equal to ``(d, f, slopes, cum_energy)`` for a
        curve without steps; a step's first point (zero width) is left out, so the piece
        after it starts at its own force."""
        pieces = self.__dict__.get("_pieces")
        if pieces is None:   # (computed once: the curve is frozen; read-only arrays)
            keep = np.append(np.diff(self.d) > 0, True)
            pieces = (self.d[keep], self.f[keep], self.slopes[keep], self.cum_energy[keep])
            for arr in pieces:
                arr.setflags(write=False)
            object.__setattr__(self, "_pieces", pieces)
        return pieces

    @property
    def cum_energy(self) -> np.ndarray:
        """``∫_0^{d_i} f dD`` at each breakpoint [energy]."""
        seg = 0.5 * (self.f[1:] + self.f[:-1]) * np.diff(self.d)
        return np.concatenate([[0.0], np.cumsum(seg)])

    # ----------------------------------------------------------------- evaluation
    def segment(self, D):
        """Index of the segment holding ``D`` (the one starting at or below it)."""
        D = np.asarray(D, dtype=float)
        return np.clip(np.searchsorted(self.d, D, side="right") - 1, 0, self.d.size - 1)

    def force(self, D):
        """Force at deformation ``D`` [force]; ``nan`` beyond the end of a table, 0 below zero."""
        D = np.asarray(D, dtype=float)
        i = self.segment(D)
        s = self.slopes[i]
        F = self.f[i] + np.where(D > self.d[i], s * (D - self.d[i]), 0.0)
        F = np.where(D < 0, 0.0, F)
        return np.where(D > self.d_end, np.nan, F)

    def energy(self, D):
        """Energy absorbed along the curve from 0 to ``D``, ``∫_0^D f dD`` [energy]."""
        D = np.asarray(D, dtype=float)
        i = self.segment(D)
        x = np.maximum(D - self.d[i], 0.0)
        s = np.where(x > 0, self.slopes[i], 0.0)
        E = self.cum_energy[i] + self.f[i] * x + 0.5 * s * x * x
        E = np.where(D <= 0, 0.0, E)
        return np.where(D > self.d_end, np.nan, E)

    def deformation_at(self, F: float) -> float:
        """Smallest deformation at which the curve reaches force ``F`` [length] (``nan`` if never)."""
        F = float(F)
        if F <= self.f[0]:
            return 0.0
        over = np.nonzero(self.f >= F)[0]
        if over.size:
            i = int(over[0])
            return float(self.d[i - 1] + (F - self.f[i - 1]) / (self.f[i] - self.f[i - 1])
                         * (self.d[i] - self.d[i - 1]))
        if self.end_slope is not None and self.end_slope > 0:
            return float(self.d[-1] + (F - self.f[-1]) / self.end_slope)
        return float("nan")

    def scaled(self, factor: float) -> "Curve":
        """The same curve with every force multiplied by ``factor`` (> 0)."""
        factor = float(factor)
        if not (np.isfinite(factor) and factor > 0):
            raise ValueError(f"a force scale must be a positive finite number, got {factor:g}")
        end = None if self.end_slope is None else self.end_slope * factor
        return Curve(self.d, self.f * factor, end, self.steps)

    # ----------------------------------------------------------------- failure
    def failure_deformation(self, force: float) -> float:
        """Deformation ``D_f`` [length] where this loading curve first reaches ``force`` [force]
        (``inf`` if it never does): on loading ``D`` only grows, so this is where a bumper with
        that failure force fails."""
        F = float(force)
        at = np.nonzero(self.f >= F)[0]
        if at.size:
            i = int(at[0])
            if i == 0 or self.f[i] == F:
                return float(self.d[i])
            return float(self.d[i - 1] + (F - self.f[i - 1]) / (self.f[i] - self.f[i - 1])
                         * (self.d[i] - self.d[i - 1]))
        if self.end_slope is not None and self.end_slope > 0:
            return float(self.d[-1] + (F - self.f[-1]) / self.end_slope)
        return np.inf

    def splice(self, force: float, post: "Curve") -> tuple["Curve", float]:
        """The loading curve of a bumper that fails at ``force`` [force] and then loads along
        ``post``: this curve up to ``D_f`` (:meth:`failure_deformation`), then
        ``F = post.force(D - D_f)``. The force steps at ``D_f`` from ``force`` to ``post.f[0]``
        (down or up; no step when they are equal); the result extends if ``post`` does.

        Returns ``(curve, D_f)``; ``(self, inf)`` when this curve never reaches ``force`` (the
        post-failure curve is never used). ``ValueError`` if the curve starts at or above
        ``force`` (it would fail at first touch: the post-failure curve *is* the loading) or
        if ``post`` cannot be placed at ``D_f`` in float64 (its first points closer together
        than the rounding of ``D_f``)."""
        if self.steps or post.steps:
            raise ValueError("only a curve without steps is spliced")
        F = float(force)
        if not F > self.f[0]:
            raise ValueError(
                f"the loading curve starts at or above the failure force ({self.f[0]:g} >= {F:g}): "
                "the bumper would fail at first touch and the post-failure curve replace the "
                "loading curve entirely; give that curve as the loading instead")
        df = self.failure_deformation(F)
        if not np.isfinite(df):
            return self, np.inf
        before = self.d < df
        n = int(np.sum(before))  # index of the failure point
        d = np.concatenate([self.d[before], [df], df + post.d])
        f = np.concatenate([self.f[before], [F], post.f])
        step = post.f[0] != F
        if not step:  # one point at D_f
            d, f = np.delete(d, n + 1), np.delete(f, n + 1)
        width = np.diff(d)
        if step:
            width = np.delete(width, n)
        if not np.all(width > 0):
            raise ValueError(
                f"the post-failure curve cannot be placed at the failure deformation {df:g}: its "
                "first points are closer together than the rounding of that deformation")
        return Curve(d, f, post.end_slope, True), float(df)

    # ----------------------------------------------------------------- series
    @property
    def f_top(self) -> float:
        """Largest force the curve reaches [force] (``inf`` if it rises for ever)."""
        if self.end_slope is not None and self.end_slope > 0:
            return np.inf
        return float(np.max(self.f))

    def _inverse_range(self, F: float) -> tuple[float, float]:
        """Interval ``[D_left, D_right]`` where a non-decreasing curve sits at force ``F``."""
        d, f = self.d, self.f
        if F <= f[0]:
            left = 0.0
        else:
            i = int(np.searchsorted(f, F, side="left"))
            if i >= f.size:
                left = d[-1] + (F - f[-1]) / self.end_slope
            else:
                left = d[i - 1] + (F - f[i - 1]) / (f[i] - f[i - 1]) * (d[i] - d[i - 1])
        j = int(np.searchsorted(f, F, side="right")) - 1
        if j < 0:
            right = 0.0
        elif j == f.size - 1:
            right = d[-1] if F == f[-1] else d[-1] + (F - f[-1]) / self.end_slope
        elif f[j] == F:
            right = d[j]
        else:
            right = d[j] + (F - f[j]) / (f[j + 1] - f[j]) * (d[j + 1] - d[j])
        return float(left), float(right)

    @staticmethod
    def series(a: "Curve", b: "Curve") -> "Curve":
        """Two bumpers in series (paper Eq. 11 generalised): at equal force the deformations add.

        Both curves must be non-decreasing. For two lines the result is the line of slope
        ``1/(1/S_a + 1/S_b)``; otherwise a table up to the lower of the two curves' top forces.
        """
        if a.steps or b.steps:
            raise ValueError("a curve with a step (a spliced post-failure curve) is not combined "
                             "in series")
        for name, c in (("first", a), ("second", b)):
            if np.any(np.diff(c.f) < 0) or (c.end_slope is not None and c.end_slope <= 0):
                raise ValueError(
                    f"the {name} curve of a series must be non-decreasing in force "
                    "(a falling segment has no single deformation at a given force)")
        if a.is_linear and b.is_linear:
            return Curve.linear(1.0 / (1.0 / a.stiffness + 1.0 / b.stiffness))
        top = min(a.f_top, b.f_top)
        if not top > 0:
            raise ValueError("the two curves of a series never reach a common positive force; "
                             "each must reach a positive force that the other also reaches")
        forces = np.union1d(a.f, b.f)
        forces = forces[forces <= top]
        if np.isfinite(top):
            forces = np.union1d(forces, [top])
        pts = []
        for F in forces:
            la, ra = a._inverse_range(F)
            lb, rb = b._inverse_range(F)
            pts.append((la + lb, F))
            if ra > la or rb > lb:
                pts.append((ra + rb, F))
        pts = np.array(pts)
        # Keep the last force at each deformation (a force jump at D = 0 for preloaded curves).
        keep = np.append(np.diff(pts[:, 0]) > 0, True)
        pts = pts[keep]
        end = None
        if np.isinf(top):
            # Both extend: slopes combine in series beyond the last breakpoint.
            end = 1.0 / (1.0 / a.end_slope + 1.0 / b.end_slope)
            if pts.shape[0] == 1:
                return Curve(pts[:, 0], pts[:, 1], end)
        if pts.shape[0] < 2 and end is None:
            raise ValueError("the two curves of a series never reach a common positive force; "
                             "each must reach a positive force that the other also reaches")
        return Curve(pts[:, 0], pts[:, 1], end)

    def __repr__(self) -> str:
        if self.is_linear:
            return f"Curve.linear({self.end_slope:g})"
        steps = ", steps" if self.steps else ""
        return (f"Curve({self.d.size} points, D up to {self.d[-1]:g}, "
                f"end_slope={self.end_slope}{steps})")
