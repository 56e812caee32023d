"""The model's scales, crash horizon, segment frame, default tolerances, longest step and
end-of-crash test, written once as array code for NumPy and jax.numpy (issue 12, item 3).

On random scenes (2 to 5 vehicles, every contact law, brakes, gaps, failures) each model function
gives (a) on NumPy the numbers the SciPy backend and the model computed before, bit for bit (their
NumPy formulas, kept below as ``_before_*``); (b) on jax.numpy the numbers of the diffrax
backend's own copies before issue 12 (its jnp formulas, kept below as ``_before_dx_*``), to
1e-15; (c) on a batch of
parameters (leading member axis, NumPy, or jax.vmap / jax.jit), each member's numbers alone.
"""

from __future__ import annotations

import numpy as np
import pytest

import lsc
from lsc.contact import HysteresisLaw
from lsc.effects import BrakeEffect
from lsc.model import MAX_ANGLE, OVER_TOL, HybridModel

from helpers import HARD

LAWS = ("ifd-restitution", "ifd-stiffness", "ifd-table", "ifd-unloading-table", "ifd-series",
        "ifd-post-failure", "kelvin", "hunt-crossley", "brach")
#: Random scenes: each law once in the default run (contact 0's law cycles with the seed; seed 11
#: draws two vehicles), twice with --hard.
SEEDS = range(2 * len(LAWS)) if HARD else [*range(len(LAWS)), 11]


# --------------------------------------------------------------------------- random scenes
def _structure(seed: int) -> dict:
    """What a scene is made of (members of one batch share it): number of vehicles, each
    contact's law (contact 0's cycles through :data:`LAWS` with the seed), table lengths, which
    vehicles brake, which contacts have a gap and a failure force."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 6))
    laws = [LAWS[seed % len(LAWS)]] + [str(rng.choice(LAWS)) for _ in range(n - 2)]
    return {"n": n, "laws": laws, "points": [int(rng.integers(2, 5)) for _ in laws],
            "brakes": [bool(rng.random() < 0.3) for _ in range(n)],
            "gaps": [bool(rng.random() < 0.5) for _ in laws],
            "failures": [bool(rng.random() < 0.3) and law.startswith("ifd") and law != "ifd-post-failure"
                         for law in laws]}


def _table(rng, points: int) -> list:
    """A loading table from the origin: ``points`` breakpoints, rising deformation and force."""
    d = np.cumsum(rng.uniform(0.02, 0.2, points))
    f = np.cumsum(rng.uniform(1000.0, 8000.0, points))
    return [[0.0, 0.0]] + [[float(a), float(b)] for a, b in zip(d, f)]


def _contact(rng, law: str, points: int, gap: bool, failure: bool) -> dict:
    """One contact of kind ``law`` with random numbers (US units)."""
    k = float(rng.uniform(5e3, 4e5))
    e = float(rng.uniform(0.05, 0.95))
    if law in ("kelvin", "hunt-crossley", "brach"):
        c = {"law": law, "stiffness": k, "restitution": e}
        if law == "hunt-crossley":
            c["exponent"] = float(rng.uniform(1.0, 2.0))
    else:
        c = {"loading": {"stiffness": k}, "unloading": {"restitution": e}}
        if law == "ifd-stiffness":
            c["unloading"] = {"stiffness": k * float(rng.uniform(1.5, 20.0))}
        elif law in ("ifd-table", "ifd-post-failure"):
            c["loading"] = {"table": _table(rng, points)}
        elif law == "ifd-unloading-table":
            c["unloading"] = {"table": [[0.3, 1.0], [float(rng.uniform(0.05, 0.25)), 0.0]]}
        elif law == "ifd-series":
            c["loading"] = {"series": [{"stiffness": k}, {"table": _table(rng, points)}]}
        if law == "ifd-post-failure":
            first = c["loading"]["table"][1][1]   # (fails on the first piece: one splice)
            c["failure"] = {"force": float(rng.uniform(0.3, 0.9)) * first,
                            "post_failure": {"table": [[0.0, 500.0], [1.0, 30000.0]]}}
        elif failure:
            c["failure"] = {"force": float(rng.uniform(2000.0, 20000.0))}
    if gap:
        c["gap"] = float(rng.uniform(0.01, 0.5))
    return c


def _scene(seed: int, member: int = 0) -> dict:
    """A scene of structure ``seed`` with random numbers (``member``: which draw); speeds fall
    from rear to front, the first two sometimes equal (no closing speed there)."""
    structure = _structure(seed)
    rng = np.random.default_rng([seed, member, 12])
    n = structure["n"]
    v = np.sort(rng.uniform(0.0, 45.0, n))[::-1]
    if n > 2 and rng.random() < 0.3:
        v[1] = v[0]
    vehicles = [{"weight": float(rng.uniform(1000.0, 6000.0)), "speed": float(s)} for s in v]
    for veh, brake in zip(vehicles, structure["brakes"]):
        if brake:
            veh["brake"] = {"mu": float(rng.uniform(0.3, 0.8))}
    contacts = [_contact(rng, law, pts, gap, fail) for law, pts, gap, fail in
                zip(structure["laws"], structure["points"], structure["gaps"],
                    structure["failures"])]
    return {"units": "US", "vehicles": vehicles, "contacts": contacts}


def _model(seed: int, member: int = 0) -> HybridModel:
    return HybridModel(lsc.Scene.load(_scene(seed, member)))


def _discs(model):
    """Discrete states to try: the initial one and each that one armed event leads to."""
    y0, disc0 = model.initial()
    out = [disc0]
    for i in model.active_events(disc0):
        new = model.apply_event(i, 0.0, y0, disc0, model.params)
        if not any(int(st.get("status", 0)) for st in new[: model.K]):
            out.append(new)
    return out


def _states(model, rng, count=4):
    """Continuous states (n,): vehicles apart and closing, apart and parting, and overlapping."""
    N, n = model.N, model.n_state
    out = []
    for j in range(count):
        y = np.zeros(n)
        y[:N] = np.cumsum(rng.uniform(0.5, 3.0, N)) * (1.0 if j % 3 else -0.01)
        y[N:2 * N] = rng.uniform(-20.0, 20.0, N)
        y[2 * N:] = rng.uniform(0.0, 100.0, n - 2 * N)
        out.append(y)
    return out


def _stack(trees):
    """Pytrees of one structure (dicts, lists, arrays) stacked along a new leading axis."""
    first = trees[0]
    if isinstance(first, dict):
        return {k: _stack([t[k] for t in trees]) for k in first}
    if isinstance(first, (list, tuple)):
        return [_stack([t[i] for t in trees]) for i in range(len(first))]
    return np.stack([np.asarray(t, float) for t in trees])


# --------------------------------------------------------------------------- before issue 12
# The NumPy formulas the model (time_scale, horizon, is_over) and the SciPy backend (_atol,
# _event_scales, _Frame, _max_step) used before they were written once: the model's functions
# must give these numbers bit for bit.
def _before_time_scale(model, slowest=False, loading=False):
    m = model.params["m"]
    mus = m[:-1] * m[1:] / (m[:-1] + m[1:])
    mu = np.max(mus) if slowest else np.min(mus)
    slopes = []
    for law in model.laws:
        for key in (("ls", "k") if loading else ("ls", "su", "k")):
            val = np.asarray(law.params.get(key, []), float).reshape(-1)
            slopes.extend(np.abs(val[np.isfinite(val)]))
    slopes = [s for s in slopes if s > 0] or [1.0]
    return float(np.sqrt(mu / (min(slopes) if slowest else max(slopes))))


def _before_horizon(model):
    v = model.scene.speeds
    v_scale = float(max(np.max(np.abs(v)), np.max(np.abs(np.diff(v))), 1e-300))
    w = -np.diff(np.asarray(model.params["v0"], float))
    w = w[w > 1e-12 * v_scale]
    w_min = float(np.min(w)) if w.size else v_scale
    extent = float(np.sum(model.params["gap"]))
    for law in model.laws:
        for key in ("ld", "ud"):
            val = np.abs(np.asarray(law.params.get(key, []), float).reshape(-1))
            val = val[val < 1e299]
            extent += float(np.max(val)) if val.size else 0.0
    return 1e6 * _before_time_scale(model, slowest=True) + 4.0 * extent / w_min + 1.0


def _before_natural_frequency(model, disc):
    """Gershgorin: ``ω² <= max_i (2 |slope| of each loaded contact at vehicle i) / m_i``, the
    slope the IF-D law's active piece ``s`` or a Kelvin or Brach spring ``k``."""
    def slope(k):
        law, st = model.laws[k], disc[k]
        if int(st["mode"]) == 0 or ("s" not in st and law.name not in ("kelvin", "brach")):
            return 0.0
        return 2.0 * abs(float(st["s"] if "s" in st else st["k"]))
    w2 = []
    for i in range(model.N):
        load = 0.0
        for k in (i - 1, i):   # (the contacts behind and ahead of it, in that order)
            if 0 <= k < model.K:
                load += slope(k)
        w2.append(load / model.params["m"][i])
    return np.sqrt(max(w2))


def _before_atol(model, rtol, disc):
    v = rtol * model.v_scale
    w = _before_natural_frequency(model, disc)
    t_load = _before_time_scale(model, loading=True)
    T = float(np.where(w * t_load > 1.0, 1.0 / np.where(w > 0, w, 1.0), t_load))
    e = v * model.v_scale * float(np.min(model.params["m"]))
    return np.concatenate([np.full(model.N, v * T), np.full(model.N, v),
                           np.full(len(model.work), e)])


def _before_scipy_event_scales(model):
    L, V = model.v_scale * _before_time_scale(model), model.v_scale
    out = np.zeros(len(model.events))
    for i, (j, w) in enumerate(model.events):
        part = model.parts[j]
        if isinstance(part, HysteresisLaw):
            out[i] = V if part.event_kinds[w] == "vmax" else L
        elif isinstance(part, BrakeEffect) and w == 0:
            out[i] = V
    return out


def _before_frame(model, t0, y_abs):
    """The SciPy backend's frame: (V, the frame's gaps, its start state, to_abs(t, u))."""
    N, m, p = model.N, np.asarray(model.params["m"], float), model.params
    x0 = y_abs[:N].copy()
    V = 0.0 if model.brakes else float(m @ y_abs[N:2 * N] / m.sum())
    gap = -(x0[:-1] - x0[1:] - np.asarray(p["gap"], float))
    u0 = y_abs.copy()
    u0[:N] = 0.0
    u0[N:2 * N] -= V

    def to_abs(t, u):
        y = np.array(u, float)
        t = np.asarray(t, float)
        y[:N] += (x0 if y.ndim == 1 else x0[:, None]) + V * (t - t0)
        y[N:2 * N] += V
        return y
    return V, gap, u0, to_abs


def _before_is_over(model, y, disc, t, horizon):
    if any(int(st["mode"]) != 0 for st in disc[model.K: model.K + len(model.brakes)]):
        return False
    D, Dd = model.deformation(np.asarray(y), model.params)
    modes = np.stack([np.asarray(st["mode"]) for st in disc[: model.K]])
    gaps = np.stack([np.asarray(law.closing_gap(D[k], disc[k]), dtype=float)
                     for k, law in enumerate(model.laws)])
    late = gaps > Dd * (horizon - t)
    return bool(np.all(modes == 0) & np.all((Dd <= OVER_TOL * model.v_scale) | late))


# --------------------------------------------------------------------------- (a) NumPy
def _same(a, b):
    """Equal to the last bit (NaN where both are NaN), shapes included."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True), (a, b)


def test_every_law_and_vehicle_count_is_drawn():
    drawn = [_structure(s) for s in SEEDS]
    assert {law for s in drawn for law in s["laws"]} == set(LAWS)
    assert {s["n"] for s in drawn} == {2, 3, 4, 5}


@pytest.mark.parametrize("seed", SEEDS)
def test_scales_and_horizon_are_the_numbers_computed_before_bit_for_bit(seed):
    model = _model(seed)
    for slowest in (False, True):
        for loading in (False, True):
            _same(model.time_scale(slowest, loading), _before_time_scale(model, slowest, loading))
    _same(model.horizon(), _before_horizon(model))
    assert model.crash_horizon == _before_horizon(model)
    _same(model.speed_scale(), model.v_scale)
    _same(np.where(_before_scipy_event_scales(model) > 0, model.event_scales(), 0.0),
          _before_scipy_event_scales(model))


@pytest.mark.parametrize("seed", SEEDS)
def test_tolerances_steps_and_frames_are_the_scipy_backend_numbers_bit_for_bit(seed):
    model = _model(seed)
    rng = np.random.default_rng(seed)
    for disc in _discs(model):
        w = _before_natural_frequency(model, disc)
        _same(model.natural_frequency(disc), w)
        _same(model.max_step(disc), MAX_ANGLE / w if w > 0 else np.inf)
        for rtol in (1e-6, 1e-10, 1e-13):
            _same(model.default_atol(rtol, disc), _before_atol(model, rtol, disc))
    for y in _states(model, rng):
        t0 = float(rng.uniform(0.0, 0.2))
        V, gap, u0, to_abs = _before_frame(model, t0, y)
        frame = model.frame(t0, y)
        _same(frame.V, V)
        _same(frame.params(model.params)["gap"], gap)
        _same(frame.to_frame(t0, y), u0)
        u = y + rng.normal(0.0, 1.0, y.size)
        ts = t0 + rng.uniform(0.0, 0.1, 5)
        _same(frame.to_abs(ts[0], u), to_abs(ts[0], u))
        us = u[:, None] + rng.normal(0.0, 1.0, (y.size, 5))
        _same(frame.to_abs(ts, us), to_abs(ts, us))
        # and back (to a rounding of the positions)
        back = frame.to_frame(ts, frame.to_abs(ts, us))
        np.testing.assert_allclose(back, us, rtol=0, atol=1e-12 * np.max(np.abs(y)) + 1e-15)


@pytest.mark.parametrize("seed", SEEDS)
def test_end_of_crash_test_is_the_one_computed_before(seed):
    model = _model(seed)
    rng = np.random.default_rng(seed + 1000)
    for disc in _discs(model):
        for y in _states(model, rng):
            for t, horizon in ((0.0, model.crash_horizon), (1.0, 2.0), (0.0, 1e30)):
                assert model.is_over(y, disc, t, horizon) == \
                    _before_is_over(model, y, disc, t, horizon)


def test_end_of_crash_test_sees_a_contact_that_closes_again_only_before_the_horizon():
    """Two cars 1 ft apart, the rear one 1 ft/s faster: every contact is open, yet it closes
    again after 1 s, so the crash is over only with a horizon under 1 s."""
    model = HybridModel(lsc.Scene.load({
        "units": "US", "vehicles": [{"weight": 3000, "speed": 11.0}, {"weight": 3000, "speed": 10.0}],
        "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4},
                      "gap": 1.0}]}))
    y0, disc = model.initial()
    assert not model.is_over(y0, disc, 0.0, 1.5) and model.is_over(y0, disc, 0.0, 0.5)
    assert model.is_over(y0, disc, 1.0, 1.5)   # at t = 1 s the closing is 0.5 s away


# --------------------------------------------------------------------------- (c) batches
def _batch(seed, members=4):
    """A batch model, its stacked parameters and the members' own models."""
    models = [_model(seed, j) for j in range(members)]
    return models[0], _stack([m.params for m in models]), models


@pytest.mark.parametrize("seed", SEEDS)
def test_batch_scales_and_horizon_are_each_members(seed):
    model, p, members = _batch(seed)
    for name, own in (("speed_scale", lambda m: m.speed_scale()),
                      ("force_scale", lambda m: m.force_scale()),
                      ("event_scales", lambda m: m.event_scales()),
                      ("horizon", lambda m: m.horizon())):
        _same(getattr(model, name)(p), np.stack([own(m) for m in members]))
    for slowest in (False, True):
        for loading in (False, True):
            _same(model.time_scale(slowest, loading, p),
                  [m.time_scale(slowest, loading) for m in members])
    for rtol in (1e-6, 1e-12):
        _same(model.default_atol(rtol, p=p), np.stack([m.default_atol(rtol) for m in members]))


def _before_horizons(model, p: dict) -> np.ndarray:
    """:meth:`HybridModel.horizon` of every member (n,) [s] of the batched parameters ``p``: a
    million contact times on the softest slope and the heaviest pair, plus four times what
    closing every gap and crossing every table takes at the slowest initial closing speed."""
    m, v0 = p["m"], p["v0"]
    n = m.shape[0]
    mu = np.max(m[:, :-1] * m[:, 1:] / (m[:, :-1] + m[:, 1:]), axis=1)
    slopes = [np.abs(np.reshape(c[key], (n, -1))) for c in p["contacts"]
              for key in ("ls", "su", "k") if key in c]
    if slopes:
        s = np.concatenate(slopes, axis=1)
        s = np.where(np.isfinite(s) & (s > 0), s, np.inf)
        k = np.min(s, axis=1)
        k = np.where(np.isfinite(k), k, 1.0)
    else:
        k = np.ones(n)
    v_scale = np.maximum(np.maximum(np.max(np.abs(v0), axis=1),
                                    np.max(np.abs(np.diff(v0, axis=1)), axis=1)), 1e-300)
    w = -np.diff(v0, axis=1)
    w = np.where(w > 1e-12 * v_scale[:, None], w, np.inf)
    w_min = np.min(w, axis=1)
    w_min = np.where(np.isfinite(w_min), w_min, v_scale)
    extent = np.sum(p["gap"], axis=1)
    for c in p["contacts"]:
        for key in ("ld", "ud"):
            if key in c:
                val = np.abs(np.reshape(c[key], (n, -1)))
                val = np.where(val < 1e299, val, 0.0)
                extent = extent + np.max(val, axis=1)
    return 1e6 * np.sqrt(mu / k) + 4.0 * extent / w_min + 1.0


@pytest.mark.parametrize("seed", SEEDS)
def test_batch_horizon_is_the_sweeps(seed):
    """The horizon of a batch is the one ``sweep`` gave the diffrax batch (its ``_horizons``,
    kept here as it was before the model took it over)."""
    model, p, _ = _batch(seed)
    _same(model.horizon(p), _before_horizons(model, p))


@pytest.mark.parametrize("seed", SEEDS)
def test_batch_steps_and_tolerances_in_a_batch_of_discrete_states_are_each_members(seed):
    model, p, members = _batch(seed)
    discs = [m.initial()[1] for m in members]
    disc = _stack(discs)
    _same(model.natural_frequency(disc, p), [m.natural_frequency(d) for m, d in zip(members, discs)])
    _same(model.max_step(disc, p), [m.max_step(d) for m, d in zip(members, discs)])
    _same(model.default_atol(1e-10, disc, p),
          np.stack([m.default_atol(1e-10, d) for m, d in zip(members, discs)]))


# --------------------------------------------------------------------------- (b) jax.numpy
@pytest.fixture(scope="module")
def dx():
    """jax.numpy with float64 switched on (by importing the diffrax backend's compiled module)."""
    pytest.importorskip("diffrax")
    import jax.numpy as jnp

    import lsc.solvers.diffrax_ode.compiled  # noqa: F401
    return jnp


# The diffrax backend's jnp formulas before issue 12 (core.py's _event_unit, _time_scale,
# _scales, _frame_of / SegmentLoop._frame, _dtmax, _over and the default atol of _run): the
# model's functions on jax.numpy must give these numbers.
_BEFORE_DX_UNITS = {"vmax": "velocity", "turn": "velocity", "recompress": "velocity",
                    "stop": "velocity", "break_forward": "force", "break_backward": "force",
                    "failure": "force"}


def _before_dx_event_unit(part, kind):
    if kind == "separate" and getattr(part, "name", "") == "kelvin":
        return "force"
    return _BEFORE_DX_UNITS.get(kind, "length")


def _before_dx_time_scale(jnp, p, keys):
    m = p["m"]
    mu = jnp.min(m[:-1] * m[1:] / (m[:-1] + m[1:]))
    slopes = [jnp.abs(jnp.reshape(c[key], (-1,))) for c in p["contacts"]
              for key in keys if key in c]
    k = jnp.max(jnp.concatenate([jnp.where(jnp.isfinite(s), s, 0.0) for s in slopes])) \
        if slopes else jnp.asarray(0.0)
    return jnp.sqrt(mu / jnp.where(k > 0, k, 1.0))


def _before_dx_scales(jnp, p):
    """Speed, contact time, force scale and the loading slopes' contact time."""
    v = p["v0"]
    v_scale = jnp.maximum(jnp.maximum(jnp.max(jnp.abs(v)), jnp.max(jnp.abs(jnp.diff(v)))),
                          1e-300)
    m = p["m"]
    mu = jnp.min(m[:-1] * m[1:] / (m[:-1] + m[1:]))
    t_scale = _before_dx_time_scale(jnp, p, ("ls", "su", "k"))
    return v_scale, t_scale, mu * v_scale / t_scale, _before_dx_time_scale(jnp, p, ("ls", "k"))


def _before_dx_frame(jnp, model, t0, y, p):
    """(frame state, frame gaps, to_abs(t, u) for u (B, n) at t (B,), V)."""
    N = model.N
    V = jnp.asarray(0.0) if model.brakes else jnp.sum(p["m"] * y[N:2 * N]) / jnp.sum(p["m"])
    x0 = y[:N]
    gap = -(x0[:-1] - x0[1:] - p["gap"])

    def to_abs(t, u):
        return u.at[..., :N].add(x0 + V * (jnp.asarray(t)[..., None] - t0)).at[..., N:2 * N].add(V)
    return y.at[:N].set(0.0).at[N:2 * N].add(-V), gap, to_abs, V


def _before_dx_dtmax(jnp, model, disc, p):
    w = model.natural_frequency(disc, p, jnp)
    return jnp.where(w > 0, MAX_ANGLE / jnp.where(w > 0, w, 1.0), jnp.inf)


def _before_dx_over(jnp, model, t, y, disc, p, v_scale, horizon):
    apart = model.contacts_apart(y, disc, t, horizon, p, jnp, v_scale)
    for st in disc[model.K: model.K + len(model.brakes)]:
        apart = apart & (st["mode"] == 0)
    return apart


def _close(a, b, scale=None, rtol=1e-15):
    """Equal to ``rtol`` of ``scale`` (default: each value's own size)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, (a.shape, b.shape)
    scale = np.maximum(np.abs(a), np.abs(b)) if scale is None else scale
    with np.errstate(invalid="ignore"):   # (inf - inf: equal infinities pass as equal)
        assert np.all((a == b) | (np.abs(a - b) <= rtol * scale)), (a, b)


def _jnp_params(model):
    import jax
    import jax.numpy as jnp
    return jax.tree_util.tree_map(jnp.asarray, model.params)


@pytest.mark.parametrize("seed", SEEDS)
def test_scales_on_jax_numpy_are_the_diffrax_backends(dx, seed):
    jnp = dx
    model = _model(seed)
    p = _jnp_params(model)
    v_scale, t_scale, f_scale, t_load = _before_dx_scales(jnp, p)
    _close(model.speed_scale(p, jnp), v_scale)
    _close(model.time_scale(p=p, xp=jnp), t_scale)
    _close(model.time_scale(loading=True, p=p, xp=jnp), t_load)
    _close(model.force_scale(p, jnp), f_scale)
    _close(model.time_scale(p=p, xp=jnp), _before_dx_time_scale(jnp, p, ("ls", "su", "k")))
    units = [_before_dx_event_unit(model.parts[j], model.parts[j].event_kinds[w])
             for j, w in model.events]
    by_unit = {"length": v_scale * t_scale, "velocity": v_scale, "force": f_scale}
    _close(model.event_scales(p, jnp), [by_unit[u] for u in units])
    # and on NumPy the same numbers
    _close(model.event_scales(), model.event_scales(p, jnp))
    _close(model.horizon(), model.horizon(p, jnp))


@pytest.mark.parametrize("seed", SEEDS[::2])
def test_frames_steps_tolerances_and_end_of_crash_on_jax_numpy_are_the_diffrax_backends(dx, seed):
    jnp = dx
    model = _model(seed)
    p = _jnp_params(model)
    rng = np.random.default_rng(seed + 2000)
    v_scale, _, _, t_load = _before_dx_scales(jnp, p)
    for y in _states(model, rng, 3):
        t0 = float(rng.uniform(0.0, 0.2))
        u0, gap, to_abs, V = _before_dx_frame(jnp, model, t0, jnp.asarray(y), p)
        frame = model.frame(t0, jnp.asarray(y), p, jnp)
        speeds = float(np.max(np.abs(y[model.N:2 * model.N])))
        _close(frame.V, V, speeds)
        _close(frame.to_frame(t0, jnp.asarray(y), jnp), u0, np.max(np.abs(y)))
        _close(frame.params(p)["gap"], gap)
        us = rng.normal(0.0, 1.0, (4, y.size))
        ts = t0 + rng.uniform(0.0, 0.1, 4)
        _close(frame.to_abs(jnp.asarray(ts), jnp.asarray(us.T), jnp).T,
               to_abs(jnp.asarray(ts), jnp.asarray(us)), np.max(np.abs(y)) + 1.0)
    for disc in _discs(model):
        dj = [{k: jnp.asarray(v) for k, v in st.items()} for st in disc]
        _close(model.max_step(dj, p, jnp), _before_dx_dtmax(jnp, model, dj, p))
        # the default atol of _Core._run, per segment (positions from HybridModel.position_time)
        rv = 1e-10 * v_scale
        atol = np.concatenate([np.full(model.N, rv * model.position_time(dj, t_load, p, jnp)),
                               np.full(model.N, rv),
                               np.full(len(model.work), rv * v_scale * jnp.min(p["m"]))])
        _close(model.default_atol(1e-10, dj, p, jnp), atol)
        for y in _states(model, rng, 3):
            for t, horizon in ((0.0, model.crash_horizon), (1.0, 2.0)):
                over = _before_dx_over(jnp, model, t, jnp.asarray(y), dj, p, v_scale, horizon)
                assert bool(model.is_over(jnp.asarray(y), dj, t, horizon, p, jnp, v_scale)) \
                    == bool(over) == model.is_over(y, disc, t, horizon)


@pytest.mark.parametrize("seed", SEEDS[::3])
def test_model_functions_trace_under_jit_and_vmap_to_each_members_numbers(dx, seed):
    import jax
    import jax.numpy as jnp
    model, p, members = _batch(seed)
    pj = jax.tree_util.tree_map(jnp.asarray, p)
    discs = [m.initial()[1] for m in members]
    disc = jax.tree_util.tree_map(jnp.asarray, _stack(discs))

    def each(p, disc):
        return {"horizon": model.horizon(p, jnp), "events": model.event_scales(p, jnp),
                "atol": model.default_atol(1e-10, disc, p, jnp),
                "max_step": model.max_step(disc, p, jnp),
                "over": model.is_over(jnp.zeros(model.n_state), disc, 0.0, None, p, jnp)}

    out = jax.jit(jax.vmap(each))(pj, disc)
    _close(out["horizon"], [m.horizon() for m in members])
    _close(out["events"], np.stack([m.event_scales() for m in members]))
    _close(out["atol"], np.stack([m.default_atol(1e-10, d) for m, d in zip(members, discs)]))
    _close(out["max_step"], [m.max_step(d) for m, d in zip(members, discs)])
    assert list(np.asarray(out["over"])) == \
        [m.is_over(np.zeros(m.n_state), d) for m, d in zip(members, discs)]
    # the batch on jax.numpy without vmap: the same numbers
    _close(jax.jit(lambda p: model.horizon(p, jnp))(pj), model.horizon(p))
