"""The metrics of a crash from its first-impact record: one definition for every backend.

Array code for NumPy and ``jax.numpy`` alike (the ``xp`` argument), with any leading batch axes
(``...``) and no Python control flow on values, so that a backend's compiled loop can carry the
record and a Result computes its headline metrics with the same function.

The **first-impact record** (``FIRST_KEYS``) holds, per contact ``k`` (vehicles ``k, k+1``):
``contact_time`` (..., K) [time]: its first touch (NaN: never); ``v_touch`` (..., K, 2)
[velocity]: the (rear, front) speeds then; ``first_end`` (..., K) [time]: the separation that
ends that first impact (NaN: not ended); ``v_sep`` (..., K, 2) [velocity]: the speeds then;
``peak_force`` (..., K) [force] and ``peak_acc`` (..., K, 2) [acceleration] (signed, largest
magnitude) over that impact; and ``v_max`` (...) [velocity]: the run's largest speed, the scale
of the pushed-shut test (:data:`lsc.impacts.PUSHED`). The definitions are those of the docs'
metrics page: each vehicle's headline values come from the first impact of the adjacent contact
that touched first; the duration is the scene's first impact's; a contact's velocity restitution
is NaN where it never touched or was pushed shut. First touches that the solve cannot order (less
than :func:`tie_window` apart, or a contact pushed shut during its neighbour's first impact:
:func:`simultaneous_touch`) are simultaneous: the lower contact index takes the tie, from the first
of the touches (:func:`headline`), whichever way the solve's rounding or tolerance ordered them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PER_CONTACT", "one_contact", "FIRST_KEYS", "PUSHED", "pairs", "first_impacts_init",
           "ongoing", "fold_peaks", "event_update", "restitution", "in_g", "tie_window",
           "TIE_ROUNDING", "RESTART_SHIFT", "INTEGRATOR_TIE", "simultaneous_touch", "headline", "metrics"]

#: A contact whose closing speed at touch is at most this fraction of the run's largest speed
#: is pushed shut, not struck: its velocity restitution is not applicable (NaN).
PUSHED = 1e-6

#: The fields of the first-impact record (see the module docstring).
FIRST_KEYS = ("contact_time", "v_touch", "first_end", "v_sep", "peak_force", "peak_acc",
              "v_max")


#: The relative time resolution of an exact solve (its event times' rounding, a few hundred ulps
#: after many events): the least ``resolution`` :func:`tie_window` takes.
TIE_ROUNDING = 1e-13

#: The integrators' restart shift, relative to an event's scale: an event that starts a segment
#: on its surface fires only once the state is this far into it (SciPy's and diffrax's
#: ``EVENT_TOL``; SciPy fires one going further in at once, diffrax then), so diffrax sees a
#: closing simultaneous with another event ``RESTART_SHIFT`` times the event's length scale
#: (the speed scale times the contact time) over the closing rate late: 4.5e-13 s of a 1.5 s
#: impact at 1 ft/s, 1.1e-12 s of a 0.9 s one with the cars at 6 ft/s, whatever the ``rtol``.
RESTART_SHIFT = 1e-12

#: The least ``resolution`` :func:`tie_window` takes for an integrator: the restart shift's
#: delay for a closing rate down to 1/1000 of the speed scale, relative to the contact time.
INTEGRATOR_TIE = 1e3 * RESTART_SHIFT


def tie_window(t, span, resolution=0.0, xp=np):
    """(...) [time]: how far apart two closings can be and still be simultaneous, for a closing
    at time ``t`` (...) [time] whose impact lasts ``span`` (...) [time], in a solve whose event
    times are resolved to ``resolution`` [-] (relative; an integrator's ``rtol``, 0 for an
    exact backend): ``max(resolution, floor) * max(|t|, span)``, the floor
    :data:`INTEGRATOR_TIE` for an integrator, :data:`TIE_ROUNDING` for an exact backend."""
    resolution = xp.asarray(resolution)
    floor = xp.where(resolution > 0, INTEGRATOR_TIE, TIE_ROUNDING)
    return xp.maximum(resolution, floor) * xp.maximum(xp.abs(t), span)


def pairs(v, xp=np):
    """(..., K, 2): the (rear, front) values of each contact's vehicles from ``v`` (..., N)."""
    return xp.concatenate([v[..., :-1, None], v[..., 1:, None]], axis=-1)   # (stack's values)


def first_impacts_init(closed0, v0, F0, a0, xp=np) -> dict:
    """The record at t = 0: the contacts closed then (``closed0`` (..., K) bool) touch at 0 at
    the initial speeds ``v0`` (..., N) [velocity]; their peaks start at the initial contact
    forces ``F0`` (..., K) [force] and accelerations ``a0`` (..., N) [acceleration]."""
    nan = xp.full(xp.shape(closed0), xp.nan)
    closed2 = closed0[..., None]
    return {"contact_time": xp.where(closed0, 0.0, nan),
            "v_touch": xp.where(closed2, pairs(v0, xp), xp.nan),
            "first_end": nan,
            "v_sep": xp.full(xp.shape(closed0) + (2,), xp.nan),
            "peak_force": xp.where(closed0, F0, 0.0),
            "peak_acc": xp.where(closed2, pairs(a0, xp), 0.0),
            "v_max": _fastest(v0, xp)}


def ongoing(first, xp=np):
    """(..., K): whether each contact's first impact has begun and not ended."""
    return ~xp.isnan(first["contact_time"]) & xp.isnan(first["first_end"])


def fold_peaks(first, F, a, where, xp=np) -> dict:
    """The record with contact forces ``F`` (..., K) [force] and accelerations ``a`` (..., N)
    [acceleration] folded into the peaks of the contacts ``where`` (..., K) (those whose first
    impact is ongoing): the largest force, the acceleration of largest magnitude (signed)."""
    A = pairs(a, xp)
    larger = where[..., None] & (xp.abs(A) > xp.abs(first["peak_acc"]))
    return dict(first,
                peak_force=xp.where(where, xp.maximum(first["peak_force"], F),
                                    first["peak_force"]),
                peak_acc=xp.where(larger, A, first["peak_acc"]))


def event_update(first, t, v, closes, opens, xp=np) -> dict:
    """The record after an event at time ``t`` (...) [time] with speeds ``v`` (..., N)
    [velocity], where the contacts ``closes`` (..., K) touch and ``opens`` (..., K) separate."""
    t = xp.asarray(t)[..., None]
    touch = closes & xp.isnan(first["contact_time"])
    end = opens & ongoing(first, xp)
    V = pairs(v, xp)
    return dict(first,
                contact_time=xp.where(touch, t, first["contact_time"]),
                v_touch=xp.where(touch[..., None], V, first["v_touch"]),
                first_end=xp.where(end, t, first["first_end"]),
                v_sep=xp.where(end[..., None], V, first["v_sep"]),
                v_max=xp.maximum(first["v_max"], _fastest(v, xp)))


def _fastest(v, xp):
    """(...): the largest magnitude of ``v`` (..., N), as an elementwise maximum over the N
    vehicles (the same value as ``max(abs(v), axis=-1)``, many times cheaper on NumPy with a
    long batch axis and few vehicles)."""
    out = xp.abs(v[..., 0])
    for i in range(1, v.shape[-1]):
        out = xp.maximum(out, xp.abs(v[..., i]))
    return out


def restitution(v_touch, v_end, v_max, xp=np):
    """Velocity restitution (Eq. 9) (...) [-] of impacts with (rear, front) speeds ``v_touch``
    and ``v_end`` (..., 2) at touch and at separation: separation over closing speed, NaN where
    the closing speed is at most :data:`PUSHED` times ``v_max`` (pushed shut) or not a number
    (never touched)."""
    closing = v_touch[..., 0] - v_touch[..., 1]
    struck = closing > PUSHED * v_max
    return xp.where(struck, (v_end[..., 1] - v_end[..., 0]) / xp.where(struck, closing, 1.0),
                    xp.nan)


def in_g(acceleration, g, xp=np):
    """Accelerations (..., N) [acceleration] in g, for ``g`` (...) [acceleration]."""
    return acceleration / xp.asarray(g, dtype=float)[..., None]


def _sides(x, pad, xp):
    """(rear, front) (..., N) of per-contact values ``x`` (..., K): each vehicle's rear
    contact's and front contact's (``pad`` (..., 1) where it has none): two views of one
    padded array."""
    both = xp.concatenate([pad, x, pad], axis=-1)
    return both[..., :-1], both[..., 1:]


def simultaneous_touch(ct, end, pushed, xp=np):
    """(..., K) [time]: each contact's first touch ``ct`` (..., K) [time] (NaN: never), or,
    where it was pushed shut (``pushed`` (..., K)) while a neighbour's first impact went on
    (from its touch to ``end`` (..., K) [time]), that neighbour's (its compression began with
    that impact: its own touch time is set by rounding, the deformation growing from zero as
    a power of time); inf where it never touched."""
    inf = xp.full(xp.shape(ct)[:-1] + (1,), xp.inf)
    touched = ~xp.isnan(ct)
    c0 = xp.where(touched, ct, 0.0)
    eff = xp.where(touched, ct, xp.inf)
    if xp is np and not pushed.any():
        return eff   # (none pushed shut: each its own touch, told at once on NumPy's values)
    for _ in range(ct.shape[-1] - 1):   # (a push passed down a line of touching vehicles)
        by_rear = pushed[..., 1:] & touched[..., :-1] & (c0[..., :-1] <= c0[..., 1:]) & \
            (c0[..., 1:] <= end[..., :-1])
        by_front = pushed[..., :-1] & touched[..., 1:] & (c0[..., 1:] <= c0[..., :-1]) & \
            (c0[..., :-1] <= end[..., 1:])
        eff = xp.minimum(eff, xp.concatenate([inf, xp.where(by_rear, eff[..., :-1], xp.inf)],
                                             axis=-1))
        eff = xp.minimum(eff, xp.concatenate([xp.where(by_front, eff[..., 1:], xp.inf), inf],
                                             axis=-1))
    return eff


def _ties(first, touched, c0, end, v_touch, v_end, resolution, xp):
    """``delta_v``, ``peak_acceleration`` (..., N) and ``duration`` (...) of a chain (see
    :func:`headline`), simultaneous first touches taken as one."""
    tie = xp.where(touched, tie_window(c0, end - c0, xp.asarray(resolution)[..., None], xp),
                   0.0)
    pushed = touched & ~(v_touch[..., 0] - v_touch[..., 1] > PUSHED * first["v_max"][..., None])
    eff = simultaneous_touch(first["contact_time"], end, pushed, xp)
    w = xp.where(touched, eff, 0.0)
    # each vehicle from its rear contact (side 1) and its front contact (side 0)
    hit_r, hit_f = _sides(touched, xp.zeros_like(touched[..., :1]), xp)
    # (the times and the speeds and peaks at either end of the contacts, all padded at once)
    acc = first["peak_acc"]
    x = xp.asarray([c0, tie, w, v_end[..., 1], v_touch[..., 1], acc[..., 1], v_end[..., 0],
                    v_touch[..., 0], acc[..., 0]])   # (stacked: a quarter of xp.stack's cost)
    by_rear, by_front = _sides(x, xp.zeros_like(x[..., :1]), xp)
    (c_r, tie_r, w_r), (c_f, tie_f, w_f) = by_rear[:3], by_front[:3]
    tied = hit_r & hit_f & (xp.abs(w_r - w_f) <= xp.maximum(tie_r, tie_f))
    # the first touch (the rear on equal times); the impact: that one's, the rear one's if tied
    first_r = hit_r & (~hit_f | (c_r <= c_f))
    rear = first_r | tied

    def side(i, use_rear):   # (i: 0 the speeds at the end, 1 at touch, 2 the peaks)
        return xp.where(use_rear, by_rear[3 + i], by_front[6 + i])

    hit = hit_r | hit_f
    dv = xp.where(hit, side(0, rear) - side(1, first_r), 0.0)
    acc = xp.where(hit, side(2, rear), 0.0)
    # the scene's first impact: of the first touches simultaneous with the earliest, the lowest
    # contact index's, from the earliest
    # (the arrays' own reductions: the same as xp's functions, without their dispatch)
    w_min = eff.min(axis=-1, keepdims=True)
    group = touched & (eff - xp.where(xp.isinf(w_min), 0.0, w_min) <= tie)
    k1 = group.argmax(axis=-1)[..., None] == xp.arange(c0.shape[-1])
    duration = xp.where(group.any(axis=-1), xp.where(k1, end, 0.0).sum(axis=-1)
                        - xp.where(group, c0, xp.inf).min(axis=-1), 0.0)
    return dv, acc, duration


def headline(first, t_last, v_last, xp=np, resolution=0.0) -> dict:
    """The headline metrics from the record at the end of the run (time ``t_last`` (...),
    speeds ``v_last`` (..., N): the end of a first impact still open then): ``delta_v``,
    ``peak_acceleration`` (..., N) (0 for a vehicle in no impact), ``peak_force``,
    ``restitution``, ``contact_time`` (..., K) and ``duration`` (...) (0 if nothing touched).

    Simultaneous first touches (:func:`tie_window` apart at the solve's relative time
    ``resolution`` (...) [-], or a contact pushed shut during its neighbour's first impact:
    :func:`simultaneous_touch`) count as one: a vehicle whose two contacts touch
    simultaneously takes its rear contact's first impact (the lower contact index), from the
    first of the two touches; the duration is that of the scene's first impact (the lowest
    contact index among the first touches), from the first of them."""
    ct, t1 = first["contact_time"], first["first_end"]
    touched, ended = ~xp.isnan(ct), ~xp.isnan(t1)
    v_touch = first["v_touch"]
    v_end = xp.where(ended[..., None], first["v_sep"], pairs(v_last, xp))
    c0 = xp.where(touched, ct, 0.0)
    end = xp.where(ended, t1, xp.asarray(t_last)[..., None])   # (where touched)
    if ct.shape[-1] == 1:   # one contact: nothing to tie
        hit = xp.concatenate([touched, touched], axis=-1)
        dv = xp.where(hit, (v_end - v_touch)[..., 0, :], 0.0)
        acc = xp.where(hit, first["peak_acc"][..., 0, :], 0.0)
        duration = xp.where(touched[..., 0], end[..., 0] - c0[..., 0], 0.0)
    else:
        dv, acc, duration = _ties(first, touched, c0, end, v_touch, v_end, resolution, xp)
    return {"delta_v": dv, "peak_acceleration": acc,
            "peak_force": first["peak_force"], "duration": duration, "contact_time": ct,
            "restitution": restitution(v_touch, v_end, first["v_max"][..., None], xp)}


def metrics(first, records, v_final, g, failure_time, t_last, v_last, xp=np,
            separation_time=None, resolution=0.0) -> dict:
    """Every metric of :data:`lsc.result.METRICS` (and ``contact_time``; ``separation_time``
    when given) from the first-impact record ``first`` and the run's records.

    ``records``: per contact (..., K) ``dmax, dperm`` [length], ``ec, er`` [energy] (max and
    permanent deformation, absorbed and returned energy over the run); ``v_final`` (..., N)
    [velocity] (after the last separation); ``g`` (...) [acceleration]; ``failure_time``
    (..., K) [time] (NaN: never failed); ``t_last``, ``v_last``: as :func:`headline`.
    ``restitution_energy`` (Eq. 10) is NaN where nothing was absorbed. ``resolution`` [-]: the
    solve's relative time resolution (:func:`tie_window`: its ``rtol``; 0 for an exact one).
    """
    out = headline(first, t_last, v_last, xp, resolution)
    ec, er = records["ec"], records["er"]
    with np.errstate(invalid="ignore", divide="ignore"):
        e_energy = xp.sqrt(er / ec)
    out.update({
        "v_final": v_final,
        "peak_acceleration_g": in_g(out["peak_acceleration"], g, xp),
        "max_deformation": records["dmax"], "permanent_deformation": records["dperm"],
        "energy_absorbed": ec, "energy_returned": er, "restitution_energy": e_energy,
        "failure_time": failure_time})
    if separation_time is not None:
        out["separation_time"] = separation_time
    return out


#: The values :func:`metrics` gives per contact (with the contact axis last).
PER_CONTACT = ("max_deformation", "permanent_deformation", "peak_force", "restitution",
               "restitution_energy", "energy_absorbed", "energy_returned", "contact_time",
               "separation_time", "failure_time")


def one_contact(out: dict) -> dict:
    """The metrics of a one-contact scene (:func:`metrics`' output) with the contact axis of
    the per-contact values (:data:`PER_CONTACT`) dropped: ``(...)`` rather than ``(..., 1)``."""
    return {name: (val[..., 0] if np.ndim(val) and name in PER_CONTACT else val)
            for name, val in out.items()}
