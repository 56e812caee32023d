"""Comparing an lsc Result's events with those of the independent modal solution
(tests/hard/modal_chain.py): the filters for what rounding alone decides (a touching contact's
first closing, an elastic re-closing's touch of its max deformation, the order of events at one
instant), then the same sequence; and every metric, each relative to its scale, with the
rounding response of ill-conditioned chains."""

from __future__ import annotations

import copy

import numpy as np
from hypothesis import reject

import lsc

from hard.common import closing_scale, energy_error, relative_ke
from hard.modal_chain import ModalChain
from hard.modal_metrics import metrics as modal_metrics


def after_touching(events, gaps):
    """``[(time, contact, kind)]`` without the first closing of each contact that starts
    touching (gap 0): it closes at once where it is closing or pushed shut, which the
    independent solution, moving a function that starts on its surface off it by 1e-13 of its
    scale, records a moment later (after D has grown to that size)."""
    seen, out = set(), []
    for e in events:
        first = e[1] not in seen
        seen.add(e[1])
        if not (first and e[2] == "contact" and gaps[e[1]] == 0):
            out.append(e)
    return out


def without_touches(events, t_last):
    """``[(time, contact, kind)]`` without the touches of D_max: a contact re-closing along an
    elastic unloading line comes back to its max deformation exactly (a tangency), which
    rounding turns into ``reload_past_max`` followed at once by ``max_deformation``, or into
    nothing; the two readings differ by nothing measurable (the pair leaves the line for 1e-10 of
    the run) and are both correct."""
    out, skip = [], set()
    for i, e in enumerate(events):
        if i in skip:
            continue
        nxt = next((j for j in range(i + 1, len(events)) if events[j][1] == e[1]), None)
        if (e[2] == "reload_past_max" and nxt is not None and events[nxt][2] == "max_deformation"
                and events[nxt][0] - e[0] <= 1e-8 * t_last):
            skip.add(nxt)
            continue
        out.append(e)
    return out


def tie_order(events, t_last):
    """``events`` (time, index, kind) with each run of events less than 1e-10 of ``t_last``
    apart sorted by contact and kind (their order within the run is rounding's)."""
    out, run = [], []
    for e in events:
        if run and e[0] - run[-1][0] > 1e-10 * t_last:
            out += sorted(run, key=lambda x: x[1:])
            run = []
        run.append(e)
    return out + sorted(run, key=lambda x: x[1:])


def same_events(r, events, t_last, gaps):
    """Assert that the Result ``r``'s events and the reference's ``events`` ``(time, index,
    kind)`` come in the same sequence (after the filters), and return both lists' times. (A
    ``settle`` of lsc's lock rule, a turning point it watched on a line where the pair did not
    lock, changes no state: left out.)"""
    ours = without_touches(after_touching([(e.time, e.index, e.kind) for e in r.events
                                           if e.kind != "settle"], gaps), t_last)
    theirs = without_touches(after_touching(events, gaps), t_last)
    # (events of different contacts at one instant, to 1e-10 of the run — a symmetric chain's
    # two max deformations — come in the order rounding gives them: compared as a set)
    ours, theirs = tie_order(ours, t_last), tie_order(theirs, t_last)
    assert [e[1:] for e in ours] == [e[1:] for e in theirs], (ours, theirs)
    return np.array([e[0] for e in ours]), np.array([e[0] for e in theirs])


#: Every metric of a Result (lsc.result.METRICS), compared with the independent solution.
METRICS_ALL = tuple(lsc.result.METRICS)


def reference(scene, resolution=0.0, horizon=np.inf):
    """The independent solution's events ``(time, index, kind)`` and every metric (reading the
    scene dict itself), or a hypothesis reject where it cannot finish (a near-plastic chain
    that locks: SciPy's business); ``horizon`` [s]: where the crash ends (lsc's
    ``HybridModel.crash_horizon``: a contact that would close again only after it does not)."""
    ch = ModalChain.from_scene(scene)
    try:
        ch.run(max_events=1000, horizon=horizon)
    except RuntimeError:
        reject()
    return [(t, j, kind) for t, (_, j), kind, _ in ch.log], modal_metrics(ch, resolution)


def values(obj) -> dict:
    """Every metric of a Result, or of a dict of them, as float arrays."""
    get = obj.get if isinstance(obj, dict) else lambda name: getattr(obj, name)
    return {name: np.asarray(get(name), float) for name in METRICS_ALL}


def metric_errors(r, a, b, closing) -> dict:
    """Each metric's largest difference between ``a`` and ``b`` (Results or dicts of metrics)
    relative to its scale in the Result ``r`` (:func:`metric_scale`); a contact's restitution, a
    ratio of speeds over its closing speed ``closing`` (K,), as its separation speed relative
    to the chain's closing speed (the delta_v rule). inf where they are NaN ("not applicable")
    at different places. A signed peak acceleration is also held to ``b``'s extreme of the
    other sign (the reference's ``peak_acceleration_other``) plus how much smaller that is: of
    two extremes of one magnitude, +49.556 and -49.556 ft/s² to 1e-15 (a pair ringing
    symmetrically), which one is the peak is rounding's."""
    other = b.get("peak_acceleration_other") if isinstance(b, dict) else None
    a, b, out = values(a), values(b), {}
    for name in METRICS_ALL:
        if not np.array_equal(np.isnan(a[name]), np.isnan(b[name])):
            out[name] = np.inf
            continue
        d = np.abs(a[name] - b[name])
        if other is not None and name.startswith("peak_acceleration"):
            alt = other * (b[name] / np.where(b["peak_acceleration"] != 0,
                                              b["peak_acceleration"], 1.0))   # (in g too)
            d = np.minimum(d, np.abs(a[name] - alt) + np.abs(b[name]) - np.abs(alt))
        if name == "restitution":
            d = d * np.abs(closing) / closing_scale(r.scene)
        else:
            d = d / metric_scale(r, name)
        out[name] = float(np.max(d, where=~np.isnan(d), initial=0.0))
    return out


def metric_scale(r, name):
    if name in ("delta_v", "v_final"):
        return closing_scale(r.scene)
    if name == "permanent_deformation":
        return max(float(np.max(r.max_deformation)), 1e-300)
    if name.startswith("energy"):
        return relative_ke(r.scene.masses, r.scene.speeds)
    x = np.abs(np.asarray(getattr(r, name), float))
    return max(float(np.max(x, where=~np.isnan(x), initial=0.0)), 1e-300)


def nudged(scene) -> dict:
    """``scene`` with the rear car's speed moved by a relative 1e-14 (a rear car at rest: to
    1e-14 of the fastest car's speed, else nothing would move): rounding's size of change."""
    moved = copy.deepcopy(scene)
    v0 = moved["vehicles"][0]["speed"]
    moved["vehicles"][0]["speed"] = v0 * (1 + 1e-14) if v0 else \
        1e-14 * max(abs(v["speed"]) for v in moved["vehicles"])
    return moved


def rounding_decides(scene, r, events, horizon=np.inf) -> bool:
    """Whether rounding decides the sequence of events of a chaotic chain (light cars
    rattling between stiff contacts, a braked one sticking and slipping): whether moving one
    car's speed by 1e-14 of the fastest car's (each car in turn, rear first) changes
    exact-chain's events (Result ``r``) or the reference's (``events``, run to ``horizon``).
    Two solutions of such a chain that part are each rounding's. (The rear car alone is not
    enough: a heavy one's nudge can leave both sequences as they are where a light one's flips
    both, a six-car chain whose solutions' final speeds part by 1e-3 ft/s.)"""
    ours = [(e.index, e.kind) for e in r.events]
    theirs = [e[1:] for e in events]
    fastest = max(abs(v["speed"]) for v in scene["vehicles"])
    for car in range(len(scene["vehicles"])):
        moved = copy.deepcopy(scene)
        moved["vehicles"][car]["speed"] += 1e-14 * fastest
        if [e[1:] for e in reference(moved, horizon=horizon)[0]] != theirs or \
                [(e.index, e.kind) for e in lsc.solve(moved, method="exact-chain").events] != ours:
            return True
    return False


def rounding_response(scene, r, ref=None, horizon=np.inf):
    """How far exact-chain's event times [s] and each metric (name -> relative change, as
    :func:`metric_errors`; "energy": the balance's change) move when the rear car's speed
    moves by a relative 1e-14 (inf where the events change; a rear car at rest: by 1e-14 of
    the fastest car's speed, else nothing would move: :func:`nudged`); with the reference's
    metrics ``ref`` (run to ``horizon``), plus how far the reference's move."""
    moved = nudged(scene)
    r2 = lsc.solve(moved, method="exact-chain")
    closing = np.array([np.nan if m is None else m.closing_speed for m in
                        [next((i for i in r.impacts if i.contact == k), None)
                         for k in range(len(r.scene.contacts))]])
    if [(e.index, e.kind) for e in r2.events] != [(e.index, e.kind) for e in r.events]:
        return np.inf, {name: np.inf for name in (*METRICS_ALL, "energy")}
    cond = metric_errors(r, r, r2, closing)
    cond["energy"] = abs(energy_error(r2) - energy_error(r))
    t_cond = max(abs(a.time - b.time) for a, b in zip(r.events, r2.events))
    if ref is not None:
        events2, ref2 = reference(moved, horizon=horizon)
        events = reference(scene, horizon=horizon)[0]
        if [e[1:] for e in events2] != [e[1:] for e in events]:
            return np.inf, {name: np.inf for name in cond}
        t_cond += max((abs(a[0] - b[0]) for a, b in zip(events, events2)), default=0.0)
        for name, err in metric_errors(r, ref, ref2, closing).items():
            cond[name] += err
    return t_cond, cond
