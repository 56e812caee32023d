"""Comparing an lsc Result's events with those of the independent modal solution
(tests/hard/modal_chain.py): the filters for what rounding alone decides (a touching contact's
first closing, an elastic re-closing's touch of its max deformation, the order of events at one
instant), then the same sequence."""

from __future__ import annotations

import numpy as np


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
    kind)`` come in the same sequence (after the filters), and return both lists' times."""
    ours = without_touches(after_touching([(e.time, e.index, e.kind) for e in r.events], gaps),
                           t_last)
    theirs = without_touches(after_touching(events, gaps), t_last)
    # (events of different contacts at one instant, to 1e-10 of the run — a symmetric chain's
    # two max deformations — come in the order rounding gives them: compared as a set)
    ours, theirs = tie_order(ours, t_last), tie_order(theirs, t_last)
    assert [e[1:] for e in ours] == [e[1:] for e in theirs], (ours, theirs)
    return np.array([e[0] for e in ours]), np.array([e[0] for e in theirs])
