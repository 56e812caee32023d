"""Strategies for the table hard cases: piecewise-linear loading tables (measured data: plateaus,
falling segments, 10,000 noisy points, a kink or a breakpoint exactly at the max deformation, a
force falling to zero exactly where the vehicles reach their common velocity) and unloading rules
chosen so that the crash can be completed (the generator knows where the common velocity is).
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

from lsc.curves import Curve

from .common import closing_speeds, front_speeds, log_uniform, masses, stiffnesses

#: Table shapes.
KINDS = ("random", "plateau", "falling", "kink_at_max", "breakpoint_at_max", "zero_tangent",
         "noisy")
#: The shapes whose max deformation is placed exactly on a breakpoint (ties: the backends may
#: take either side of it).
AT_BREAKPOINT = ("kink_at_max", "breakpoint_at_max", "zero_tangent")


def common_velocity_point(d, f, ke):
    """``(D*, F*)``: the first deformation where the energy under the table reaches ``ke``, and
    the force there."""
    c = Curve.table(np.column_stack([d, f]))
    cum = c.cum_energy
    i = int(np.searchsorted(cum, ke, side="left")) - 1
    i = min(max(i, 0), d.size - 2)
    s = (f[i + 1] - f[i]) / (d[i + 1] - d[i])
    rest = ke - cum[i]
    # f_i x + s x²/2 = rest, the smallest root in [0, d_{i+1} - d_i]
    if s == 0:
        x = rest / f[i] if f[i] > 0 else 0.0
    else:
        disc = max(f[i] * f[i] + 2.0 * s * rest, 0.0)
        x = 2.0 * rest / (f[i] + math.sqrt(disc)) if f[i] + math.sqrt(disc) > 0 else 0.0
    D = d[i] + x
    return D, float(c.force(D))


#: Table forces, relative: exactly zero, or from 1e-3 to 1 (no subnormal "almost zero" forces:
#: a force of 1e-300 is zero to the physics, and a crash against it lasts 1e150 s).
rel_forces = st.one_of(st.just(0.0), st.floats(1e-3, 1.0))


@st.composite
def loading_tables(draw, kinds=KINDS, n_max=30, n_min=2):
    """``(kind, d, f, e)``: a table shape (``d`` from 0 to 1, ``f`` up to 1) and the energy
    ``e`` under it at the common velocity (the crash is scaled onto it by
    :func:`table_scenes`)."""
    kind = draw(st.sampled_from(kinds))
    if kind == "noisy":
        n = 10_000
        rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
        d = np.cumsum(rng.uniform(0.5, 1.5, n))
        d = np.concatenate([[0.0], d[:-1]]) / d[-2]
        f = np.abs(d * (1.0 + 0.2 * rng.standard_normal(n)))   # falling pieces everywhere
        f[0] = 0.0
        frac = draw(st.floats(0.0005, 0.02))   # a few hundred breakpoints crossed
        return kind, d, f, frac * float(Curve.table(np.column_stack([d, f])).cum_energy[-1])
    n = draw(st.integers(max(n_min, 3 if kind in AT_BREAKPOINT else 2), n_max))
    inc = np.array(draw(st.lists(st.floats(0.05, 1.0), min_size=n - 1, max_size=n - 1)))
    d = np.concatenate([[0.0], np.cumsum(inc)])
    d = d / d[-1]
    f = np.array(draw(st.lists(rel_forces, min_size=n, max_size=n)))
    if draw(st.booleans()):
        f[0] = 0.0
    if kind == "plateau":
        i = draw(st.integers(0, n - 2))
        f[i + 1] = f[i] = f[i] if draw(st.booleans()) else 0.0
    elif kind == "falling":
        i = draw(st.integers(0, n - 2))
        f[i], f[i + 1] = max(f[i], f[i + 1], 0.5), min(f[i], f[i + 1])
    if f.max() <= 0:
        f[-1] = 1.0
    if kind in AT_BREAKPOINT:
        k = draw(st.integers(1, n - 2))
        if kind == "zero_tangent":
            # falling to exactly zero at the breakpoint where the common velocity is reached
            # (and rising again after it: on a zero-force plateau beyond, the vehicles would
            # drift on at the closing rate left by rounding, a neutral equilibrium, for as
            # long as 1/rounding contact times)
            f[k] = 0.0
            f[k - 1], f[k + 1] = max(f[k - 1], 0.1), max(f[k + 1], 0.1)
        elif kind == "breakpoint_at_max":
            # a breakpoint on a straight line (no kink)
            f[k - 1], f[k + 1] = max(f[k - 1], 0.1), max(f[k + 1], 0.1)
            f[k] = f[k - 1] + (f[k + 1] - f[k - 1]) * (d[k] - d[k - 1]) / (d[k + 1] - d[k - 1])
        else:
            f[k] = max(f[k], 0.1)   # a kink with a force well above zero
        e = float(Curve.table(np.column_stack([d, f])).cum_energy[k])
        if not e > 0:
            f[k - 1] = 1.0
            e = float(Curve.table(np.column_stack([d, f])).cum_energy[k])
        return kind, d, f, e
    frac = draw(st.floats(0.01, 0.99))
    return kind, d, f, frac * float(Curve.table(np.column_stack([d, f])).cum_energy[-1])


@st.composite
def unloadings(draw, D, F, ke, f_top, kinds=("restitution", "stiffness", "table")):
    """An unloading rule that completes from ``(D, F)`` with ``ke`` absorbed: a restitution whose
    permanent set is not negative, an unloading stiffness that returns no more than ``ke``, or a
    measured rebound table mapped onto ``(D, F)`` that does neither.

    Where the force at the common velocity is (nearly) zero (``F <= 1e-6 f_top``: a table
    falling to zero force there), only a plastic one: the vehicles creep up to that point along a
    separatrix, and an energy off by ``ε`` moves the max deformation by ``√ε`` and ``F_max`` with
    it; a rebound table mapped by ``F_max`` then returns an energy ``∝ F_max``, a rebound speed
    ``∝ ε^{1/4}``: 1e-4 of the closing speed from rounding alone, a property of the model."""
    if not F > 1e-6 * f_top:
        return {"restitution": 0.0}
    kind = draw(st.sampled_from(kinds))
    if kind == "restitution":
        e_max = min(1.0, math.sqrt(0.99 * D * F / (2.0 * ke)))
        e = draw(st.one_of(st.sampled_from([0.0, 1e-6, 1.0]), st.floats(0.0, 1.0),
                           log_uniform(1e-12, 1e-2)))
        return {"restitution": float(min(e, e_max))}
    if kind == "stiffness":
        # returns F²/(2 k_u) <= ke, and a permanent set D - F/k_u >= 0
        k_min = max(F * F / (2.0 * 0.99 * ke), F / (0.99 * D))
        return {"stiffness": float(k_min * draw(log_uniform(1.0, 1e4)))}
    # a rebound table in time order, from (D0, F0) down to zero force, within D and ke
    m = draw(st.integers(2, 8))
    f0 = draw(log_uniform(1.0, 1e5))
    fr = np.sort(np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=m - 2, max_size=m - 2))))[::-1]
    forces = np.concatenate([[1.0], fr, [0.0]]) * f0
    widths = np.array(draw(st.lists(st.floats(0.05, 1.0), min_size=m - 1, max_size=m - 1)))
    area = float(np.sum(0.5 * (forces[1:] + forces[:-1]) / f0 * widths))   # at unit width, F0 = 1
    # mapped: forces x F/f0, widths as given (x w): energy F w area <= ke, total width <= D
    w = 0.99 * min(ke / (F * area), D / widths.sum()) * draw(st.floats(0.01, 1.0))
    d0 = draw(st.floats(0.0, 10.0))
    dd = d0 - np.concatenate([[0.0], np.cumsum(widths * w)])
    if not np.all(np.diff(dd) < 0):
        return {"restitution": 0.0}
    return {"table": np.column_stack([dd, forces]).tolist()}


@st.composite
def table_scenes(draw, kinds=KINDS, n_max=30, n_min=2,
                 unload_kinds=("restitution", "stiffness", "table")):
    """``(kind, scene)``: a two-vehicle US scene with a loading table, an unloading rule that
    completes, masses 1:1000 to 1000:1, closing speeds 1e-4 to 150 ft/s, an effective stiffness
    (the table's force over its length) 1e2 to 1e9 lbf/ft and the front vehicle at rest or
    moving: the table shape is scaled so that the vehicles reach their common velocity where
    the shape says."""
    kind, d, f, e = draw(loading_tables(kinds, n_max, n_min))
    (m1, m2), w, v2 = draw(masses), draw(closing_speeds), draw(front_speeds)
    k_eff = draw(stiffnesses)
    mu = m1 * m2 / (m1 + m2)
    ke = 0.5 * mu * w * w
    # forces x fs, deformations x ds: energy x fs ds = ke / e, slope x fs/ds = k_eff
    fs, ds = math.sqrt(k_eff * ke / e), math.sqrt(ke / (e * k_eff))
    d, f = d * ds, f * fs
    D, F = common_velocity_point(d, f, ke)
    unloading = draw(unloadings(D, F, ke, float(np.max(f)), unload_kinds))
    scene = {"units": "US",
             "vehicles": [{"mass": m1, "speed": v2 + w}, {"mass": m2, "speed": v2}],
             "contacts": [{"loading": {"table": np.column_stack([d, f]).tolist()},
                           "unloading": unloading}]}
    return kind, scene
