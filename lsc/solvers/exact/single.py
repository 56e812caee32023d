"""The exact backend's one-scene solve: segment after segment (:mod:`.kernels`), braking
(:mod:`.braking`) included, through :func:`~lsc.solvers.segments.run_segments`, as a Result.

The transitions between segments are the law's own ``on_event``, evaluated on Python scalars
(:class:`_ScalarTransitions`), never re-derived here; the brakes' transitions are the model's
(:class:`~lsc.effects.BrakeEffect`).
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..segments import Step, build_result, run_segments
from .braking import _stop_time, _turning_deformations
from .kernels import (_PY, _end_force, _force_rise_time, _next_event, _PyMath, _setup,
                      _state)


class _ScalarTransitions:
    """The model as :func:`run_segments` sees it, with the law's transitions (its own
    ``on_event``) evaluated on Python floats and lists (namespace :data:`_PY`), about 10x cheaper
    than NumPy on 0-d values. Everything else is the model's own."""

    def __init__(self, model):
        self.__dict__.update(model.__dict__)   # its attributes, read without __getattr__
        self._model = model
        # the laws' numbers on Python scalars and lists (read only), once per model
        self._pp = model.__dict__.get("_exact_numbers")
        if self._pp is None:
            self._pp = [{k: (v.tolist() if np.ndim(v) else float(v))
                         for k, v in law.params.items()} for law in model.laws]
            for pp in self._pp:   # relative to the anchor, any rebound width is resolved
                pp["wres"] = 0.0
            model.__dict__["_exact_numbers"] = self._pp

    def __getattr__(self, name):
        value = getattr(self._model, name)
        self.__dict__[name] = value   # (looked up once per solve)
        return value

    def initial(self):
        """The model's :meth:`~lsc.model.HybridModel.initial` state, on Python scalars, computed
        once per model (a model solved again starts from the same state) and copied out."""
        model = self._model
        start = model.__dict__.get("_exact_initial")
        if start is None:
            if len(model.parts) > model.K:   # effects: the model's own, on NumPy
                y0, disc = model.initial()
            else:   # the laws' own init, on Python floats (the same expressions)
                p = model.params
                y0 = np.concatenate([np.zeros(model.N), np.asarray(p["v0"], float),
                                     np.zeros(len(model.work))])
                x, v = y0[: model.N].tolist(), p["v0"].tolist()
                gap, m = p["gap"].tolist(), p["m"].tolist()
                mu = [a * b / (a + b) for a, b in zip(m, m[1:])]   # (as model._mu)
                disc = [law.init(x[k] - x[k + 1] - gap[k], v[k] - v[k + 1], self._pp[k], _PY,
                                 mu=mu[k]) for k, law in enumerate(model.laws)]
            start = (y0, model.to_python(disc))
            model.__dict__["_exact_initial"] = start
        return start[0].copy(), [dict(st) for st in start[1]]

    def is_over(self, y, disc, t=0.0, horizon=None):
        """The model's :meth:`~lsc.model.HybridModel.is_over`, asked without brakes only once
        every contact is open (never over before: its first condition), so not on the NumPy
        arrays of every segment's end; with brakes every time (a crash may end with a contact
        shut between two stuck vehicles)."""
        if not self._model.brakes and any(st["mode"] for st in disc[: self.K]):
            return False
        return self._model.is_over(y, disc, t, horizon)

    def apply_event(self, i, t, y, disc, p, xp=None):
        """As ``HybridModel.apply_event``, on Python scalars for the contact laws."""
        k, w = self._model.events[i]
        if k >= self._model.K:  # an effect (brake, bumper failure): the model's own, on NumPy
            return self._model.apply_event(i, t, y, disc, p)
        # contact k's deformation and closing rate, as HybridModel.deformation (on floats)
        N = self._model.N
        D = float(y[k]) - float(y[k + 1]) - float(p["gap"][k])
        Dd = float(y[N + k]) - float(y[N + k + 1])
        new = list(disc)
        new[k] = self._model.laws[k].on_event(w, D, Dd, disc[k], self._pp[k], _PY)
        return new


def solve(model, *, t_end=None, n_samples: int = 1000, max_events: int = 10_000):
    """Solve a two-vehicle hysteresis ``model`` exactly, segment by segment, as a Result.

    ``t_end`` [time]: simulate until then (must not cut the crash); ``n_samples``: points in the
    sampled series (every event is a sample); ``max_events``: limit on discrete events.

    Braked vehicles slide (constant friction force) or stick (held, ``a = 0``) as their
    :class:`~lsc.effects.BrakeEffect` says; the run ends when the model says the crash is over
    (a braked vehicle still sliding after the last separation produces its stop event), and
    ``v_final`` is taken at the last separation. Peaks are exact: with friction the force need
    not be monotone along a segment, so its turning points count as well. The declaration is
    checked by :func:`lsc.solvers.exact.solve`, not here.
    """
    p = model.params
    m1, m2 = (float(m) for m in p["m"])
    gap = float(p["gap"][0])
    ev_index = [model.events.index((0, w)) for w in range(3)]
    vtol = 1e-12 * model.v_scale

    law = model.laws[0]
    # the exact peaks of every segment: (t0, t1, force (1,), accelerations (2,) signed)
    spans = []
    # a declared bumper failure (of contact 0): its part, event and force
    failure = [(model.parts.index(f), model.events.index((model.parts.index(f), 0)),
                float(f.params["force"])) for f in getattr(model, "failures", [])]
    ev_index += [ev for _, ev, _ in failure]
    # declared brakes: part, vehicle, sliding friction force per direction [force], static
    # limit [force], and the events (stop, break-away: forward for the target, whose net contact
    # force F pushes it forward; backward for the bullet, pushed back by F)
    brakes = []
    for b in getattr(model, "brakes", []):
        j, m = model.parts.index(b), (m1, m2)[b.i]
        gg = float(b.params["g"])
        brakes.append((j, b.i, float(b.params["mu"]) * m * gg, float(b.params["mus"]) * m * gg,
                       model.events.index((j, 0)), model.events.index((j, 1 if b.i else 2))))
    mass = (m1, m2)

    def advance(t0, y0, disc, horizon):
        st = disc[0]
        x1, x2, v1, v2 = (float(v) for v in y0[:4])
        hold, push = [False, False], [0.0, 0.0]
        for j, i, slide, _, _, _ in brakes:
            if disc[j]["slide"]:
                push[i] = -slide * disc[j]["dir"]
            else:
                hold[i] = True
        g = _setup(x1, x2, v1, v2, m1, m2, gap, st["fa"], st["s"], st["da"], push[0], push[1],
                   hold[0], hold[1])
        armed = [ff for j, _, ff in failure if not disc[j]["failed"]]
        fail = (st["fa"], st["s"], st["da"], armed[0]) if armed else None
        tau, which, sep = _next_event(_PY, g, st["da"], st["lo"], st["wl"], st["hi"], st["vm"],
                                      vtol, fail)
        event = ev_index[which] if tau < math.inf else None
        stopped = None
        for j, i, _, limit, ev_stop, ev_break in brakes:
            if disc[j]["slide"]:
                cand = _stop_time(g, i, disc[j]["dir"], min(tau, horizon - t0))
                ev = ev_stop
            else:
                cand = _force_rise_time(_PY, g, st["fa"], st["s"], st["da"], limit, vtol)
                ev = ev_break
            if cand < tau or (cand == tau and event is not None and ev < event):
                tau, event, stopped = cand, ev, (i if ev == ev_stop else None)
        if not t0 + tau <= horizon:
            tau, event, stopped = horizon - t0, None, None
        sep = bool(sep)
        end = list(_state(_PY, tau, g, sep))
        if stopped is not None:
            end[2 + stopped] = 0.0   # the stop, exactly (held at zero while stuck)
        if not brakes:
            F = max(g.F0, _end_force(_PY, law, end[0] - end[1] - gap, st))
            spans.append((t0, t0 + tau, (F,), (-F / m1, F / m2)))
        else:
            # the force over the segment: at its ends and where D turns inside it
            Ds = [g.D0, end[0] - end[1] - gap, *_turning_deformations(g, tau)]
            Fs = [_end_force(_PY, law, D, st) for D in Ds]
            lo_f, hi_f = min(Fs), max(Fs)
            peak_a = [0.0, 0.0]
            for i, sign in ((0, -1.0), (1, 1.0)):
                if hold[i]:
                    continue
                for F in (hi_f, lo_f):
                    a = (sign * F + push[i]) / mass[i]
                    if abs(a) > abs(peak_a[i]):
                        peak_a[i] = a
            spans.append((t0, t0 + tau, (hi_f,), tuple(peak_a)))

        def dense(tt, g=g, t0=t0, t1=t0 + tau, stopped=stopped, sep=sep):
            tt = np.asarray(tt, float)
            with np.errstate(all="ignore"):
                out = np.array(_state(np, tt - t0, g, sep))
            if stopped is not None:  # at rest from the stop on, as the state is
                out[2 + stopped] = np.where(tt >= t1, 0.0, out[2 + stopped])
            return out

        ends.append((t0, t0 + tau, y0, end, disc))
        return Step(t0 + tau, np.array(end), event, dense, 1, 0)

    ends = []   # per segment: (t0, t1, state at t0, state at t1, discrete state)
    start = time.perf_counter()
    segments, events, y, disc, totals = run_segments(_ScalarTransitions(model), advance,
                                                     t_end=t_end, max_events=max_events)
    wall = time.perf_counter() - start
    stats = {"steps": totals["steps"], "rhs_evaluations": 0, "segments": len(segments),
             "wall_time": wall}
    return build_result(model, segments, events, y, disc, method="exact", tolerances={},
                        stats=stats, n_samples=n_samples, y_post=totals["y_post"], peaks=spans,
                        rows=_event_rows(model, ends) if ends else None)


class _NumPyTies(_PyMath):
    """:data:`.kernels._PY` with NumPy's ``maximum`` and ``minimum`` of two finite floats: of
    two equal values (``-0.0`` and ``0.0``) the second, where Python's ``max`` keeps the
    first."""

    maximum = staticmethod(lambda a, b: a if a > b else b)
    minimum = staticmethod(lambda a, b: a if a < b else b)


_TIES = _NumPyTies()


def _event_rows(model, ends, floats: bool = True) -> dict:
    """The rows at the event points (``t, x, v, a, deformation, force``, as
    :func:`~lsc.solvers.segments.event_rows` gives them): both ends of every segment, at the
    exact states there, each in its segment's discrete state. The force at a segment end is the
    law's at the deformation clamped to the segment's range (:func:`.kernels._end_force`: a
    rounding-level overshoot times a very steep rebound line is no force); the accelerations
    follow from it as the model's net forces and brakes make them. With no brakes, the
    deformations and forces are computed on Python floats (``floats``; the same numbers as on
    NumPy), else for all segments at once (the discrete states stacked as arrays)."""
    N, K = model.N, model.K
    t = np.array([tt for t0, t1, *_ in ends for tt in (t0, t1)])
    if floats and not model.brakes:
        gap, laws = model.params["gap"].tolist(), model.laws
        y, D, F = [], [], []
        for _, _, y0, y1, st in ends:
            for yy in (y0.tolist(), y1):
                d = [yy[k] - yy[k + 1] - gap[k] for k in range(K)]
                y.append(yy)
                D.append(d)
                F.append([_end_force(_TIES, law, d[k], st[k]) for k, law in enumerate(laws)])
        y, D, F = np.array(y, float).T, np.array(D, float).T, np.array(F, float).T
        a = model.net_forces(F) / model.params["m"][:, None]
    else:
        y = np.array([v for _, _, y0, y1, _ in ends for v in (y0, y1)], float).T   # (n, 2S)
        disc = []
        for j, part in enumerate(ends[0][4]):
            cols = np.repeat([[d[j][key] for key in part] for *_, d in ends], 2, axis=0)
            disc.append(dict(zip(part, cols.T)))
        p = dict(model.params, gap=model.params["gap"][:, None])
        D, _ = model.deformation(y, p)
        F = np.array([_end_force(np, law, D[k], disc[k]) for k, law in enumerate(model.laws)])
        net = model.net_forces(F)
        a = net / p["m"][:, None]
        for j, b in enumerate(model.brakes):
            a[b.i] = b.accel(net[b.i], p["m"][b.i], disc[K + j], p["brakes"][j])
    return {"t": t, "x": y[:N].T, "v": y[N:2 * N].T, "a": a.T, "deformation": D.T,
            "force": F.T}
