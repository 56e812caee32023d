"""The batch metrics of a metrics solve, from each contact's first impact tracked in the loop's
carry, with the Result's definitions (:mod:`lsc.impacts`).

These functions are the one place the diffrax backend computes metrics (to be replaced as one
by a shared metrics function): :func:`first_impacts_init`, :func:`fold_first` and
:func:`first_event` update the carry; :func:`carry_metrics` gives the metrics at the end.

The headline metrics are over each vehicle's and contact's first impact, tracked in the loop's
carry (first touch and separation, the speeds then, the peaks folded only while that impact is
ongoing). (The scale of the pushed-shut test, :data:`lsc.impacts.PUSHED`, is the largest speed at
t = 0 and at the events, where the Result takes it over its samples: they differ only for a scene
whose speeds peak between events, and then only for a closing speed at touch within a hair of
1e-6 of that scale.)
"""

from __future__ import annotations

from . import compiled  # noqa: F401  (float64 before any array is made)

import jax.numpy as jnp  # noqa: E402

from ...impacts import PUSHED  # noqa: E402

__all__ = ["FIRST_KEYS", "first_impacts_init", "impact_ongoing", "fold_first", "first_event",
           "headline", "carry_metrics"]

# The batch metrics follow lsc.impacts: an impact is one touch -> separation episode of one
# contact; the headline metrics are each contact's and each vehicle's FIRST impact. The carry
# holds, per contact k (vehicles k, k+1): its first touch ``contact_time`` and the velocities
# then ``v_touch`` (K, 2), its first separation ``first_end`` and the velocities then ``v_sep``
# (K, 2), the peak force ``peak_force`` (K,) and the signed peak accelerations ``peak_acc``
# (K, 2) over that impact; and ``v_max``, the largest speed at t = 0 and at the events (the
# scale of the pushed-shut test, lsc.impacts.PUSHED).
FIRST_KEYS = ("contact_time", "v_touch", "first_end", "v_sep", "peak_force", "peak_acc",
              "v_max")


def _pairs(v):
    """(K, 2): the (rear, front) values of each contact's vehicles from per-vehicle ``v`` (N,)."""
    return jnp.stack([v[:-1], v[1:]], axis=1)


def first_impacts_init(closed0, v0, F0, a0):
    """The first-impact carry at t = 0: contacts closed then (``closed0`` (K,)) touch at 0, at the
    initial speeds ``v0`` (N,), and their peaks start at the initial force and accelerations."""
    K = closed0.shape[0]
    return {"contact_time": jnp.where(closed0, 0.0, jnp.nan),
            "v_touch": jnp.where(closed0[:, None], _pairs(v0), jnp.nan),
            "first_end": jnp.full(K, jnp.nan), "v_sep": jnp.full((K, 2), jnp.nan),
            "peak_force": jnp.where(closed0, F0, 0.0),
            "peak_acc": jnp.where(closed0[:, None], _pairs(a0), 0.0),
            "v_max": jnp.max(jnp.abs(v0))}


def impact_ongoing(first):
    """(K,): whether each contact's first impact has begun and not ended."""
    return ~jnp.isnan(first["contact_time"]) & jnp.isnan(first["first_end"])


def fold_first(first, F, a, ongoing):
    """Fold force (K,) and accelerations (N,) into the peaks of the first impacts ``ongoing``."""
    A = _pairs(a)
    return dict(first,
                peak_force=jnp.where(ongoing, jnp.maximum(first["peak_force"], F),
                                     first["peak_force"]),
                peak_acc=jnp.where(ongoing[:, None] & (jnp.abs(A) > jnp.abs(first["peak_acc"])),
                                   A, first["peak_acc"]))


def first_event(first, t, v, closes, opens):
    """The first-impact carry after an event at time ``t`` with velocities ``v`` (N,), where the
    contacts ``closes`` (K,) touch and ``opens`` (K,) separate."""
    touch = closes & jnp.isnan(first["contact_time"])
    end = opens & impact_ongoing(first)
    V = _pairs(v)
    return dict(first,
                contact_time=jnp.where(touch, t, first["contact_time"]),
                v_touch=jnp.where(touch[:, None], V, first["v_touch"]),
                first_end=jnp.where(end, t, first["first_end"]),
                v_sep=jnp.where(end[:, None], V, first["v_sep"]),
                v_max=jnp.maximum(first["v_max"], jnp.max(jnp.abs(v))))


def headline(first, t_last, v_last):
    """The headline metrics (as :meth:`lsc.Result._headline`) from the first-impact carry at the
    end of the run (time ``t_last``, velocities ``v_last`` (N,): the end of an impact still
    open). Per vehicle, its first impact is that of the adjacent contact that touched first
    (ties: the lower contact index); a vehicle in no impact has ``delta_v`` and
    ``peak_acceleration`` 0. ``duration``: the scene's first impact (0 if none)."""
    ct, t1 = first["contact_time"], first["first_end"]
    K = ct.shape[0]
    touched = ~jnp.isnan(ct)
    ended = ~jnp.isnan(t1)
    v_end = jnp.where(ended[:, None], first["v_sep"], _pairs(v_last))
    dv = jnp.where(touched[:, None], v_end - first["v_touch"], 0.0)
    closing = first["v_touch"][:, 0] - first["v_touch"][:, 1]
    struck = touched & (closing > PUSHED * first["v_max"])
    restitution = jnp.where(struck, (v_end[:, 1] - v_end[:, 0]) / jnp.where(struck, closing, 1.0),
                            jnp.nan)
    start = jnp.where(touched, ct, jnp.inf)
    # each vehicle: its rear contact (side 1) when that touched first, else its front (side 0)
    rear = jnp.concatenate([jnp.array([False]), start[:-1] <= start[1:], jnp.array([True])])
    k_rear, k_front = jnp.arange(K + 1) - 1, jnp.arange(K + 1)
    kv = jnp.clip(jnp.where(rear, k_rear, k_front), 0, K - 1)
    side = jnp.where(rear, 1, 0)
    hit = touched[kv]
    k1 = jnp.argmin(start)   # the scene's first impact (argmin: ties to the lower index)
    duration = jnp.where(touched[k1], jnp.where(ended[k1], t1[k1], t_last) - ct[k1], 0.0)
    return {"delta_v": jnp.where(hit, dv[kv, side], 0.0),
            "peak_acceleration": jnp.where(hit, first["peak_acc"][kv, side], 0.0),
            "peak_force": first["peak_force"], "restitution": restitution,
            "duration": duration, "contact_time": ct}


def carry_metrics(model, c):
    """The Result metrics from the final carry ``c`` of a metrics solve of ``model`` (as
    Result.build computes them): the headline metrics from each vehicle's and contact's first
    impact (:func:`headline`), the records and ``v_final`` over the run."""
    m = model
    disc = c["disc"][: m.K]
    post = jnp.where(c["separated"], c["y_post"], c["y"])
    vf = post[m.N: 2 * m.N]
    rec = {key: jnp.stack([d[key] for d in disc]) for key in ("dmax", "dperm", "ec", "er")}
    out = headline({key: c[key] for key in FIRST_KEYS}, c["t"], c["y"][m.N: 2 * m.N])
    out.update({
        "v_final": vf,
        "max_deformation": rec["dmax"], "permanent_deformation": rec["dperm"],
        "restitution_energy": jnp.sqrt(rec["er"] / rec["ec"]),
        "energy_absorbed": rec["ec"], "energy_returned": rec["er"],
        "separation_time": c["separation_time"], "failure_time": c["failure_time"]})
    return out
