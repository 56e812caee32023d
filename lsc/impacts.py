"""Impacts: the touch → separation episodes of each contact, read off a result's event points.

An impact is one episode of one contact: from its first touch (a ``"contact"`` event, or t = 0
for a contact closing at the start) to its separation (an event whose kind includes
``"separation"``). A contact of a chain that closes twice has two impacts. Every quantity of an
impact is taken over its own interval, so a vehicle's braking before the touch or a later
impact never enters it. The states come from the rows a backend gives at its event points (both
sides of every event: the end of one segment and the start of the next), the peaks from those
rows and from the peaks the backend located between them. Units: the scene's (see
:attr:`lsc.Result.units`).
"""

from __future__ import annotations

import bisect
import math
import sys
from dataclasses import dataclass

import numpy as np

from .errors import SimulationError
from .metrics import PUSHED, restitution, simultaneous_touch, tie_window

__all__ = ["Impact", "find_impacts", "check_resolved", "PUSHED"]

#: Relative accuracy to which the absolute times must resolve every impact's duration.
TIME_RESOLUTION = 1e-8

@dataclass(frozen=True)
class Impact:
    """One impact of contact ``contact`` between vehicles ``vehicles = (rear, front)``.

    ``t_start`` (first touch), ``t_end`` (separation; the end of the run if ``separated`` is
    False) [time]; ``closing_speed`` (rear minus front speed at touch) and ``separation_speed``
    (front minus rear at ``t_end``) [velocity]; ``v_start, v_end, delta_v`` (rear, front)
    [velocity]: the speeds at touch and at separation and their difference; ``peak_acceleration``
    (rear, front) [acceleration]: signed, largest magnitude over the impact, and
    ``peak_acceleration_g`` [g]; ``peak_force`` [force] and ``max_deformation`` [length] over the
    impact; ``restitution`` = separation speed / closing speed (velocity definition, Eq. 9) [-];
    ``restitution_energy`` = sqrt(returned / absorbed energy) (Eq. 10) [-], or ``None`` where
    the contact closes more than once (its energies are recorded per contact, over the run).
    """

    contact: int
    vehicles: tuple
    t_start: float
    t_end: float
    separated: bool
    closing_speed: float
    separation_speed: float
    v_start: tuple
    v_end: tuple
    delta_v: tuple
    peak_acceleration: tuple
    peak_acceleration_g: tuple
    peak_force: float
    max_deformation: float
    restitution: float
    restitution_energy: float | None
    struck: bool

    @property
    def duration(self) -> float:
        """``t_end - t_start`` [time]."""
        return self.t_end - self.t_start


def _parts(kind: str) -> list:
    return kind.split("+")


def episodes(events, K: int, t_last: float,
             resolution: float = 0.0) -> list[tuple[int, float, float, bool]]:
    """``(contact, t_start, t_end, separated)`` of every touch → separation episode, in the order
    of their first touch; touches less than :func:`lsc.metrics.tie_window` apart (the solve's
    relative time ``resolution`` [-]) are simultaneous, ordered by contact index."""
    open_at = [None] * K
    found = []
    for ev in events:
        kinds = _parts(ev.kind)
        if "contact" in kinds and open_at[ev.index] is None:
            open_at[ev.index] = ev.time
        if "separation" in kinds and open_at[ev.index] is not None:
            found.append((ev.index, open_at[ev.index], ev.time, True))
            open_at[ev.index] = None
    found += [(k, t0, t_last, False) for k, t0 in enumerate(open_at) if t0 is not None]
    return _in_order(found, resolution)


def _in_order(found: list, resolution: float) -> list:
    """The episodes ``found`` by first touch, each run of touches within the tie window of its
    first one by contact index."""
    found = sorted(found, key=lambda e: (e[1], e[0]))
    # (every episode's tie window in one NumPy call)
    window = tie_window(np.array([e[1] for e in found]), np.array([e[2] - e[1] for e in found]),
                        resolution).tolist() if len(found) > 1 else []
    out, i = [], 0
    while i < len(found):
        t0 = found[i][1]
        j = i + 1
        while j < len(found) and found[j][1] - t0 <= max(window[i], window[j]):
            j += 1
        out += sorted(found[i:j], key=lambda e: e[0])
        i = j
    return out


def _touch_speeds(t: list, v: list, speeds: list, t0: float, t1: float) -> list:
    """The speeds (N,) at the touch of an episode ``[t0, t1]``: the initial ``speeds`` at
    t = 0, else the first row of the episode."""
    return speeds if t0 == 0.0 else v[_rows(t, t0, t1)[0]]


def _pushed_from_the_start(found: list, K: int, t: list, v: list, speeds: list, v_max: float,
                           resolution: float) -> list:
    """The episodes ``found`` with each contact's first one that was pushed shut during its
    neighbour's first impact started at that impact's touch, and put in order again
    (:func:`lsc.metrics.simultaneous_touch`, the rule the headline metrics take: a solve sees
    such a touch only once the deformation passes its rounding, an integrator microseconds
    late, so that the impacts' order, ``Result.first_impact`` and ``duration`` agree on every
    backend)."""
    ct, end, pushed, first = [math.nan] * K, [math.nan] * K, [False] * K, {}
    for i, (k, t0, t1, _) in enumerate(found):
        if k in first:
            continue
        first[k] = i
        row = _touch_speeds(t, v, speeds, t0, t1)
        ct[k], end[k] = t0, t1
        pushed[k] = not row[k] - row[k + 1] > PUSHED * v_max
    if not any(pushed):
        return found   # (none pushed shut: simultaneous_touch keeps every touch as it is)
    eff = simultaneous_touch(np.array(ct), np.array(end), np.array(pushed)).tolist()
    moved = [k for k, i in first.items() if eff[k] < found[i][1]]
    if not moved:
        return found
    found = list(found)
    for k in moved:
        i = first[k]
        found[i] = (k, float(eff[k]), *found[i][2:])
    return _in_order(found, resolution)


def _rows(t: list, t0: float, t1: float) -> range:
    """The series rows of ``[t0, t1]`` (``t`` sorted, a list): at an event time that is sampled
    twice (end of one segment, start of the next) the row of the segment inside the interval."""
    i0 = max(bisect.bisect_right(t, t0) - 1, 0)
    i1 = max(bisect.bisect_left(t, t1), i0)
    return range(i0, min(i1, len(t) - 1) + 1)


def _largest(a: list) -> float:
    """``max(a)`` as NumPy's ``max`` gives it (of equal zeros, the last one's sign)."""
    out = max(a)
    return float(np.max(a)) if out == 0.0 else out


def _signed_peak(a: list) -> float:
    """The value of ``a`` of largest magnitude, with its sign (the first such; 0 if empty)."""
    return max(a, key=abs) if a else 0.0


def _peaks_between(spans, t0: float, t1: float, contact: int, pair: tuple):
    """The largest force of ``contact`` and the (rear, front) accelerations of largest magnitude
    (signed) over the ``spans`` inside ``[t0, t1]`` (``None, None`` where none is)."""
    inside = [s for s in spans if s[0] >= t0 and s[1] <= t1]
    if not inside:
        return None, None
    peak = []
    for i in pair:   # the first of the largest magnitude, with its sign (NaN first of all)
        values = [float(s[3][i]) for s in inside]
        nan = [v for v in values if v != v]
        peak.append(nan[0] if nan else max(values, key=abs))
    return max(float(s[2][contact]) for s in inside), tuple(peak)


def _crush_between(spans, t0: float, t1: float, contact: int) -> float:
    """The largest deformation of ``contact`` over the ``spans`` inside ``[t0, t1]`` that give
    one (-inf where none does)."""
    return max((float(s[4][contact]) for s in spans
                if len(s) > 4 and s[0] >= t0 and s[1] <= t1), default=-np.inf)


def _raised(force: float, acc: tuple, span_force, span_acc) -> tuple[float, tuple]:
    """``force`` and ``acc`` raised to the spans' peaks where those are larger in magnitude."""
    if span_force is None:
        return force, acc
    return (max(force, span_force),
            tuple(float(b) if abs(b) > abs(a) else a for a, b in zip(acc, span_acc)))


def last_speeds(rows, impacts, v_post) -> np.ndarray:
    """The speeds (N,) at the end of the rows, where an impact still open then ends (as
    :func:`find_impacts`, which found ``impacts``, takes them): ``v_post`` if the last
    separation is then."""
    t = rows["t"]
    if float(t[-1]) == max((m.t_end for m in impacts if m.separated), default=np.nan):
        return np.asarray(v_post, float)
    return rows["v"][min(int(np.searchsorted(t, t[-1], side="left")), t.size - 1)]


def find_impacts(rows, events, v_post, records, *, speeds, g, v_max,
                 spans=(), resolution=0.0) -> tuple[Impact, ...]:
    """Every impact, in order of first touch (simultaneous ones, to the solve's relative time
    ``resolution`` [-], by contact index: :func:`episodes`; a contact pushed shut during its
    neighbour's first impact from that impact's touch: :func:`_pushed_from_the_start`).

    ``rows``: ``t`` (n,), ``v, a`` (n, N), ``deformation, force`` (n, K) at points that hold
    both sides of every event (the ends of every segment; or a whole sampled series);
    ``events`` the event list; ``v_post`` (N,) the velocities at the last separation (the end
    speeds of an impact that ends then); ``records`` the contacts' records (``dmax, ec, er``);
    ``speeds`` (N,) at t = 0; ``g`` [acceleration]; ``v_max`` the scale of the pushed-shut test
    (:data:`PUSHED`); ``spans``: peaks a backend located between the rows, ``(t0, t1, force
    (K,), acceleration (N,) signed)`` and optionally ``deformation (K,)``, each counted in the
    impacts that hold ``[t0, t1]``."""
    # (on Python floats: a few rows per impact, where NumPy's cost per call dominates; the rows
    # are finite, Result.build checked them)
    t, v, a, force = (rows[key].tolist() for key in ("t", "v", "a", "force"))
    K = rows["deformation"].shape[1]
    v_post, speeds = np.asarray(v_post, float).tolist(), np.asarray(speeds, float).tolist()
    found = episodes(events, K, t[-1], resolution)
    if K > 1 and found:
        found = _pushed_from_the_start(found, K, t, v, speeds, v_max, resolution)
    t_post = max((e[2] for e in found if e[3]), default=np.nan)
    count = [0] * K
    for e in found:
        count[e[0]] += 1
    impacts = []
    for k, t0, t1, separated in found:
        span = _rows(t, t0, t1)
        pair = (k, k + 1)
        vs = tuple(_touch_speeds(t, v, speeds, t0, t1)[i] for i in pair)
        ve = tuple(v_post[i] if t1 == t_post else v[span[-1]][i] for i in pair)
        force_k, peak_a = _raised(_largest([force[j][k] for j in span]),
                                  tuple(_signed_peak([a[j][i] for j in span]) for i in pair),
                                  *_peaks_between(spans, t0, t1, k, pair))
        closing, separating = vs[0] - vs[1], ve[1] - ve[0]
        rec, alone = records[k], count[k] == 1
        e_energy = _root_ratio(rec["er"], rec["ec"]) if alone and rec["ec"] > 0 else None
        # (the record's max deformation is exact; for a contact that closes again, the rows
        # hold it at its events, the spans where it turns inside a segment)
        crush = float(rec["dmax"]) if alone else max(
            float(np.max(rows["deformation"][span.start:span.stop, k])),
            _crush_between(spans, t0, t1, k))
        impacts.append(dict(
            contact=k, vehicles=pair, t_start=t0, t_end=t1, separated=separated,
            closing_speed=closing, separation_speed=separating, v_start=vs, v_end=ve,
            delta_v=(ve[0] - vs[0], ve[1] - vs[1]), peak_acceleration=peak_a,
            peak_acceleration_g=tuple(x / g for x in peak_a), peak_force=force_k,
            max_deformation=crush,
            restitution_energy=e_energy, struck=closing > PUSHED * v_max))
    if not impacts:
        return ()
    # (every impact's restitution in one NumPy call, where one per impact cost more)
    e = restitution(np.array([m["v_start"] for m in impacts]),
                    np.array([m["v_end"] for m in impacts]), v_max).tolist()
    return tuple(Impact(**m, restitution=x) for m, x in zip(impacts, e))


def _root_ratio(er: float, ec: float) -> float:
    """``sqrt(er / ec)`` [-] as NumPy takes it on floats (NaN for a negative ratio)."""
    return math.sqrt(er / ec) if er >= 0 else math.nan


def check_resolved(t0: float, t1: float, what: str) -> None:
    """Raise :class:`SimulationError` when the absolute times ``t0 < t1`` [s] cannot resolve
    the interval between them to :data:`TIME_RESOLUTION` (the result could not represent it)."""
    span = t1 - t0
    if not math.isfinite(span):
        raise SimulationError(
            f"{what} has non-finite times ({t0:.6g} s to {t1:.6g} s): the scene's magnitudes are "
            "beyond what the computation can represent (check the speeds, masses, gaps and "
            "stiffnesses for absurd values)")
    # (np.spacing's value: the gap to the next float up; beyond the largest, infinite)
    top = max(abs(t0), abs(t1))
    ulp = math.ulp(top) if top < sys.float_info.max else math.inf
    if not span * TIME_RESOLUTION >= ulp:
        raise SimulationError(
            f"{what} starts at t = {t0:.6g} s and lasts {span:.3g} s: at that time the clock "
            f"resolves only {ulp:.3g} s, too coarse to represent the impact (its duration, its "
            "pulse) to a relative 1e-8. Start the scene closer to the first contact (a smaller "
            "gap, or the speeds at touch with no gap); a contact this brief long after the first "
            "touch is a re-contact (a near-plastic pair kicked back onto its rebound line) that "
            "no backend resolves at that time: check the scene for restitutions near 0")
