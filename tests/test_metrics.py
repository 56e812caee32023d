"""One metrics function (lsc.metrics) for every backend, and a Result that samples its series
only when they are read.

The metrics of a Result are those of :func:`lsc.metrics.metrics` applied to a first-impact record
computed here independently, from the event list and the sampled series; the record helpers
(init, event update, fold) walked along the events give that same record; on jax.numpy, with
batch axes and under jit, the function gives the same numbers; a solve read only for its metrics
never calls the sampler, and the series, when read, hold every event and the exact motion.
"""

import numpy as np
import pytest

import lsc
from lsc import metrics as M
from lsc.result import METRICS

from helpers import HARD
from lsc.solvers import segments

RNG_SEEDS = range(6)


def two_vehicle_scene(seed):
    """A random two-vehicle IF-D scene (SI): linear or table loading, a gap or none, the target
    braked or not."""
    rng = np.random.default_rng(seed)
    if seed % 2:
        d = np.cumsum(rng.uniform(0.02, 0.05, 3))
        f = np.cumsum(rng.uniform(2e4, 8e4, 3))
        points = [[0, 0], *map(list, zip(d.tolist(), f.tolist()))]
        loading = {"table": points + [[points[-1][0] + 0.5, points[-1][1] + 1e7]]}
    else:
        loading = {"stiffness": float(rng.uniform(2e5, 2e6))}
    target = {"mass": float(rng.uniform(800, 2500)), "speed": float(rng.uniform(-1, 0.5))}
    if seed % 3 == 0:
        target["brake"] = {"mu": 0.7}
    return {"units": "SI",
            "vehicles": [{"mass": float(rng.uniform(800, 2500)),
                          "speed": float(rng.uniform(2, 8))}, target],
            "contacts": [{"loading": loading,
                          "unloading": {"restitution": float(rng.uniform(0.05, 0.95))},
                          "gap": float(rng.choice([0.0, rng.uniform(0.01, 0.3)]))}]}


def chain_scene(seed):
    """A random three-car chain (SI), IF-D contacts with gaps: impacts can repeat."""
    rng = np.random.default_rng(100 + seed)
    return {"units": "SI",
            "vehicles": [{"mass": float(rng.uniform(800, 2500)), "speed": float(rng.uniform(3, 8))},
                         {"mass": float(rng.uniform(300, 2500)), "speed": float(rng.uniform(0, 1))},
                         {"mass": float(rng.uniform(800, 2500)), "speed": 0.0}],
            "contacts": [{"loading": {"stiffness": float(rng.uniform(2e5, 1e6))},
                          "unloading": {"restitution": float(rng.uniform(0.1, 0.9))},
                          "gap": float(rng.uniform(0.0, 0.3))} for _ in range(2)]}


def _kinds(ev):
    return set(ev.kind.split("+"))


def record_from_events(r):
    """The first-impact record of ``r`` from its event list and its sampled series alone: per
    contact its first "contact" event, the first "separation" after it, the speeds then (the
    samples of the segment inside the impact, where an event time is sampled twice), and the
    peaks over the samples between them."""
    t, v, a, F = r.t, r.v, r.a, r.force
    K = F.shape[1]
    rec = {"contact_time": np.full(K, np.nan), "v_touch": np.full((K, 2), np.nan),
           "first_end": np.full(K, np.nan), "v_sep": np.full((K, 2), np.nan),
           "peak_force": np.zeros(K), "peak_acc": np.zeros((K, 2)),
           "v_max": np.max(np.abs(v))}
    for k in range(K):
        touch = next((ev.time for ev in r.events if "contact" in _kinds(ev) and ev.index == k),
                     None)
        if touch is None:
            continue
        end = next((ev.time for ev in r.events if "separation" in _kinds(ev) and ev.index == k
                    and ev.time >= touch), None)
        rec["contact_time"][k] = touch
        rec["v_touch"][k] = (np.asarray(r.scene.speeds)[[k, k + 1]] if touch == 0.0
                             else v[np.searchsorted(t, touch, side="right") - 1, [k, k + 1]])
        inside = (t >= touch) & (t <= (t[-1] if end is None else end))
        if end is not None:
            rec["first_end"][k] = end
            rec["v_sep"][k] = (r.v_final[[k, k + 1]] if end == r.separation_time.max(initial=0)
                               and end == max(m.t_end for m in r.impacts)
                               else v[np.searchsorted(t, end), [k, k + 1]])
        rec["peak_force"][k] = F[inside, k].max()
        for side, i in enumerate((k, k + 1)):
            rec["peak_acc"][k, side] = a[inside, i][np.argmax(np.abs(a[inside, i]))]
    return rec


def metrics_of(r, rec, xp=np):
    """:func:`lsc.metrics.metrics` of the record ``rec`` with ``r``'s contact records."""
    records = {"dmax": r.max_deformation, "dperm": r.permanent_deformation,
               "ec": r.energy_absorbed, "er": r.energy_returned}
    args = [{k: xp.asarray(v) for k, v in rec.items()}, {k: xp.asarray(v) for k, v in
                                                          records.items()},
            xp.asarray(r.v_final), r.scene.g, xp.asarray(r.failure_time), r.t[-1],
            xp.asarray(r.v[-1])]
    return {k: np.asarray(v) for k, v in M.metrics(*args, xp=xp).items()}


def assert_metrics_equal(got, r, rel, peak_rel):
    for name in METRICS:
        tol = peak_rel if name.startswith("peak") else rel
        np.testing.assert_allclose(got[name], getattr(r, name), rtol=tol, atol=0,
                                   equal_nan=True, err_msg=name)


def solved(kind, seed):
    if kind == "two":
        return lsc.solve(two_vehicle_scene(seed), method="exact")
    return lsc.solve(chain_scene(seed), method="scipy", rtol=1e-10)


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_two_vehicle_metrics_are_the_one_function_of_the_event_record(seed):
    r = solved("two", seed)
    # two vehicles, IF-D: the force is monotone between events, its peaks are samples
    assert_metrics_equal(metrics_of(r, record_from_events(r)), r, rel=1e-12, peak_rel=1e-12)


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_chain_metrics_are_the_one_function_of_the_event_record(seed):
    r = solved("chain", seed)
    got = metrics_of(r, record_from_events(r))
    # the middle car's peak lies between samples: the Result's (located on the dense output)
    # is at least every sample's and within the sampling error of the largest
    assert_metrics_equal(got, r, rel=1e-12, peak_rel=1e-3)
    assert np.all(np.abs(r.peak_acceleration) >= np.abs(got["peak_acceleration"]) * (1 - 1e-12))


def walk_events(r):
    """The first-impact record from the record helpers, walked along the events of a two-vehicle
    IF-D result (peaks at the events: the states at both sides of each event)."""
    t, v, a, F = r.t, r.v, r.a, r.force
    closed0 = np.array([any(ev.time == 0.0 and "contact" in _kinds(ev) and ev.index == k
                            for ev in r.events) for k in range(F.shape[1])])
    rec = M.first_impacts_init(closed0, np.asarray(r.scene.speeds, float), F[0], a[0])
    for ev in r.events:
        if ev.time == 0.0 and "contact" in _kinds(ev):
            continue
        before = np.searchsorted(t, ev.time, side="left")
        after = np.searchsorted(t, ev.time, side="right") - 1
        rec = M.fold_peaks(rec, F[before], a[before], M.ongoing(rec))
        K = F.shape[1]
        at = np.arange(K) == ev.index
        rec = M.event_update(rec, ev.time, v[before], at & ("contact" in _kinds(ev)),
                             at & ("separation" in _kinds(ev)))
        rec = M.fold_peaks(rec, F[after], a[after], M.ongoing(rec))
    return rec


@pytest.mark.parametrize("seed", [s for s in RNG_SEEDS if s % 3])  # (unbraked: no turning point)
def test_record_helpers_walked_along_the_events_give_the_record(seed):
    r = solved("two", seed)
    rec, ref = walk_events(r), record_from_events(r)
    for key in ("contact_time", "first_end", "peak_force", "peak_acc", "v_touch"):
        np.testing.assert_allclose(rec[key], ref[key], rtol=1e-12, err_msg=key)
    # (the speeds at the last separation: the Result's v_final, the post-crash state)
    np.testing.assert_allclose(rec["v_sep"], r.v_final[None, :], rtol=1e-9)


def test_pushed_shut_contact_and_untouched_vehicle():
    # contact 1 touches at t = 0 with no closing speed (pushed shut); a contact never touching
    first = {"contact_time": np.array([0.0, 0.0, np.nan]),
             "v_touch": np.array([[3.0, 0.0], [0.0, 0.0], [np.nan, np.nan]]),
             "first_end": np.array([0.1, 0.2, np.nan]),
             "v_sep": np.array([[1.0, 2.5], [2.0, 2.2], [np.nan, np.nan]]),
             "peak_force": np.array([9.0, 4.0, 0.0]),
             "peak_acc": np.array([[-3.0, 5.0], [-2.0, 1.0], [0.0, 0.0]]), "v_max": np.float64(3)}
    h = M.headline(first, 1.0, np.array([1.0, 2.0, 2.2, 0.0]))
    np.testing.assert_array_equal(h["restitution"], [0.5, np.nan, np.nan])
    # vehicle 1: contacts 0 and 1 touched together, the lower index (its rear contact) wins
    np.testing.assert_array_equal(h["delta_v"], [-2.0, 2.5, 2.2, 0.0])
    np.testing.assert_array_equal(h["peak_acceleration"], [-3.0, 5.0, 1.0, 0.0])
    assert h["duration"] == 0.1


# ------------------------------------------------------------------ jax.numpy, batches, jit
@pytest.mark.parametrize("kind", ["two", "chain"])
def test_jax_numpy_gives_the_same_metrics_batched_and_compiled(kind):
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    jnp = jax.numpy
    results = [solved(kind, s) for s in RNG_SEEDS[:3]]
    recs = [record_from_events(r) for r in results]
    for r, rec in zip(results, recs):
        np.testing.assert_allclose(
            np.asarray(metrics_of(r, rec, jnp)["delta_v"]), metrics_of(r, rec)["delta_v"],
            rtol=1e-15)
    # a batch axis: the records and the run's values stacked, one compiled call
    stack = {k: jnp.asarray(np.stack([rec[k] for rec in recs])) for k in recs[0]}
    records = {k: jnp.asarray(np.stack([getattr(r, n) for r in results])) for k, n in
               (("dmax", "max_deformation"), ("dperm", "permanent_deformation"),
                ("ec", "energy_absorbed"), ("er", "energy_returned"))}
    run = {"v_final": np.stack([r.v_final for r in results]),
           "g": np.array([r.scene.g for r in results]),
           "failure_time": np.stack([r.failure_time for r in results]),
           "t_last": np.array([r.t[-1] for r in results]),
           "v_last": np.stack([r.v[-1] for r in results])}
    batched = jax.jit(lambda first, records, run: M.metrics(
        first, records, run["v_final"], run["g"], run["failure_time"], run["t_last"],
        run["v_last"], xp=jnp))(stack, records, {k: jnp.asarray(v) for k, v in run.items()})
    for j, r in enumerate(results):
        single = metrics_of(r, recs[j])
        for name in METRICS:
            np.testing.assert_allclose(np.asarray(batched[name])[j], single[name], rtol=1e-14,
                                       equal_nan=True, err_msg=name)


# (table loading; 3: the target braked; 1 too with --hard: one more compile)
@pytest.mark.parametrize("seed", [1, 3] if HARD else [3])
def test_the_diffrax_batch_gives_each_member_the_metrics_of_its_record(seed):
    """The diffrax backend's compiled metrics solve carries the first-impact record through its
    segment loop and ends with :func:`lsc.metrics.metrics`, each member with its own ``g``:
    its metrics are the one function's of the record built here from each member's exact solve
    (its events and series), to the integrator's tolerance."""
    pytest.importorskip("diffrax")
    from lsc.model import HybridModel
    from lsc.solvers import backend
    scene = lsc.Scene.load(two_vehicle_scene(seed))
    values = {"vehicles.0.speed": np.array([2.5, 5.0, 7.5]), "g": np.array([3.7, 9.81, 24.8])}
    out = backend("diffrax").solve_batch(HybridModel(scene), values, rtol=1e-12)
    assert list(out["status"]) == ["ok"] * 3
    for j in range(3):
        r = lsc.solve(scene.with_values({path: float(v[j]) for path, v in values.items()}),
                      method="exact")
        want = metrics_of(r, record_from_events(r))
        for name in METRICS:
            np.testing.assert_allclose(out["metrics"][name][j], want[name], rtol=1e-8,
                                       atol=1e-12 * np.max(np.abs(want[name]), initial=1.0),
                                       equal_nan=True, err_msg=name)
        np.testing.assert_allclose(out["metrics"]["peak_acceleration_g"][j],
                                   out["metrics"]["peak_acceleration"][j] / values["g"][j],
                                   rtol=1e-15)


# ------------------------------------------------------------------ series sampled on demand
@pytest.fixture
def sampler_calls(monkeypatch):
    """Counts the calls of the segment backends' sampler."""
    calls = []
    call = segments._Sampler.__call__

    def counted(self):
        calls.append(1)
        return call(self)

    monkeypatch.setattr(segments._Sampler, "__call__", counted)
    return calls


@pytest.mark.parametrize("method", ["exact", "scipy", "closed-form"])
def test_a_metrics_only_solve_samples_no_series(method, sampler_calls):
    r = lsc.solve(two_vehicle_scene(2), method=method)   # (linear, unbraked: any backend)
    r.metrics(), r.impacts, r.summary(), r.to_dict()
    assert "_series" not in vars(r) and not sampler_calls
    v = r.v
    assert "_series" in vars(r) and r.v is v   # sampled once, then kept
    assert len(sampler_calls) == (method != "closed-form")
    assert v.shape == (r.t.size, 2) and r.t.size > 1000


@pytest.mark.parametrize("method", ["exact", "scipy"])
def test_series_hold_every_event_and_the_exact_motion(method):
    scene = two_vehicle_scene(2)   # linear loading, gap, unbraked: the closed form applies
    r, cf = lsc.solve(scene, method=method), lsc.solve(scene, method="closed-form")
    for ev in r.events:
        assert np.count_nonzero(r.t == ev.time) >= (1 if ev.time in (0.0, r.t[-1]) else 2), ev
    exact = cf.sampler.rows(r.t)
    for name in ("x", "v", "a", "deformation", "force"):
        scale = np.max(np.abs(exact[name]))
        tol = 1e-12 if method == "exact" else 1e-8
        np.testing.assert_allclose(getattr(r, name), exact[name], rtol=0, atol=tol * scale,
                                   err_msg=name)


@pytest.mark.parametrize("method", ["exact", "scipy"])
def test_a_reloaded_contact_peaks_inside_its_segment_are_located_not_sampled(method):
    # the braked target struck a second time: the contact is reloaded along its unloading line
    # and turns back on it with no event, so its second impact's peak force, crush and peak
    # accelerations lie inside a segment; they must be those of a fine sampling (1000 samples
    # were 1.5e-4 low)
    scene = two_vehicle_scene(3)
    r = lsc.solve(scene, method=method)
    second = [m for m in r.impacts if m.contact == 0][1]
    fine = lsc.solve(scene, method="exact", n_samples=400_000)
    inside = (fine.t >= second.t_start) & (fine.t <= second.t_end)
    tol = 1e-9 if method == "exact" else 1e-7
    assert second.peak_force == pytest.approx(fine.force[inside, 0].max(), rel=tol)
    assert second.max_deformation == pytest.approx(fine.deformation[inside, 0].max(), rel=tol)
    for side in (0, 1):
        a = fine.a[inside, side]
        assert second.peak_acceleration[side] == pytest.approx(a[np.argmax(np.abs(a))], rel=tol)
    # the headline (first impact) is unchanged: its peaks are at events
    assert r.peak_force[0] == pytest.approx(fine.force[fine.t <= r.impacts[0].t_end, 0].max(),
                                            rel=1e-12 if method == "exact" else 1e-9)


def test_record_helpers_compile_with_jax_and_agree_with_numpy():
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    jnp = jax.numpy
    closed0 = np.array([True, False])
    v0, F0, a0 = np.array([5.0, 0.0, 0.0]), np.array([0.0, 0.0]), np.zeros(3)

    def walk(xp, closed0, v0, F0, a0):
        rec = M.first_impacts_init(closed0, v0, F0, a0, xp)
        rec = M.fold_peaks(rec, xp.asarray([900.0, 0.0]), xp.asarray([-0.6, 0.9, 0.0]),
                           M.ongoing(rec, xp), xp)
        # contact 1 closes at t = 0.05, contact 0 separates at t = 0.08
        rec = M.event_update(rec, 0.05, xp.asarray([3.0, 2.0, 0.5]),
                             xp.asarray([False, True]), xp.asarray([False, False]), xp)
        rec = M.fold_peaks(rec, xp.asarray([400.0, 700.0]), xp.asarray([-0.3, -0.2, 1.1]),
                           M.ongoing(rec, xp), xp)
        rec = M.event_update(rec, 0.08, xp.asarray([1.0, 3.0, 1.0]),
                             xp.asarray([False, False]), xp.asarray([True, False]), xp)
        rec = M.fold_peaks(rec, xp.asarray([0.0, 800.0]), xp.asarray([0.0, -1.5, 1.3]),
                           M.ongoing(rec, xp), xp)
        return rec

    ref = walk(np, closed0, v0, F0, a0)
    got = jax.jit(lambda *a: walk(jnp, *a))(*map(jnp.asarray, (closed0, v0, F0, a0)))
    for key in M.FIRST_KEYS:
        np.testing.assert_array_equal(np.asarray(got[key]), ref[key], err_msg=key)
    # by hand: contact 0 touched at 0 (5, 0) and ended at 0.08 (1, 3), its peaks before then;
    # contact 1 touched at 0.05 (2, 0.5), still open, its peaks after its touch
    np.testing.assert_array_equal(ref["contact_time"], [0.0, 0.05])
    np.testing.assert_array_equal(ref["first_end"], [0.08, np.nan])
    np.testing.assert_array_equal(ref["v_sep"][0], [1.0, 3.0])
    np.testing.assert_array_equal(ref["peak_force"], [900.0, 800.0])
    np.testing.assert_array_equal(ref["peak_acc"], [[-0.6, 0.9], [-1.5, 1.3]])
    assert ref["v_max"] == 5.0


def test_a_non_finite_series_is_refused_when_sampled():
    r = lsc.solve(two_vehicle_scene(2), method="exact")
    rows = {k: np.asarray(getattr(r, k)) for k in ("t", "v", "a", "deformation", "force")}
    series = {**rows, "x": r.x, "v": np.where(r.t[:, None] > r.t[5], np.nan, r.v)}
    lazy = lsc.Result.build(
        r.scene, rows=rows, sampler=lambda: series, events=r.events, v_final=r.v_final,
        method="exact", tolerances={}, stats={},
        contacts=[{"dmax": d, "fmax": f, "dperm": p, "ec": c, "er": q} for d, f, p, c, q in
                  zip(r.max_deformation, r.peak_force, r.permanent_deformation,
                      r.energy_absorbed, r.energy_returned)])
    assert lazy.delta_v.tolist() == r.delta_v.tolist()
    with pytest.raises(lsc.SimulationError, match=r"non-finite values in v\b"):
        lazy.v


def _one_contact_records(n=64, seed=5):
    """``n`` one-contact first-impact records (leading axis ``n``): touched and ended, touched
    and still open at the end of the run, never touched, pushed shut (no closing speed)."""
    rng = np.random.default_rng(seed)
    ct = rng.uniform(0.0, 0.1, (n, 1))
    end = ct + rng.uniform(1e-3, 0.2, (n, 1))
    ct[::5] = np.nan                   # never touched
    end[1::5] = np.nan                 # still in contact at the end of the run
    v_touch = np.stack([rng.uniform(1, 10, n), rng.uniform(-1, 1, n)], -1)[:, None, :]
    v_touch[2::5, 0, 1] = v_touch[2::5, 0, 0]   # pushed shut
    v_touch[np.isnan(ct[:, 0])] = np.nan
    v_sep = np.where(np.isnan(end)[..., None], np.nan, rng.uniform(-3, 8, (n, 1, 2)))
    return {"contact_time": ct, "first_end": end, "v_touch": v_touch, "v_sep": v_sep,
            "peak_force": rng.uniform(0, 1e5, (n, 1)),
            "peak_acc": rng.uniform(-300, 300, (n, 1, 2)), "v_max": np.full(n, 10.0)}


@pytest.mark.parametrize("resolution", [0.0, 1e-10])
def test_the_one_contact_headline_is_the_general_tie_rule_s(resolution):
    """:func:`lsc.metrics.headline` takes a shortcut for one contact (nothing can tie): it gives
    the general rule's ``delta_v``, ``peak_acceleration`` and ``duration`` exactly, for impacts
    ended, still open at the end of the run, never begun and pushed shut."""
    first = _one_contact_records()
    n = len(first["v_max"])
    t_last, v_last = np.full(n, 0.5), np.random.default_rng(6).uniform(-2, 9, (n, 2))
    got = M.headline(first, t_last, v_last, resolution=resolution)
    ct, t1 = first["contact_time"], first["first_end"]
    touched, ended = ~np.isnan(ct), ~np.isnan(t1)
    v_end = np.where(ended[..., None], first["v_sep"], M.pairs(v_last, np))
    c0 = np.where(touched, ct, 0.0)
    end = np.where(ended, t1, t_last[..., None])
    general = M._ties(first, touched, c0, end, first["v_touch"], v_end, resolution, np)
    for name, want in zip(("delta_v", "peak_acceleration", "duration"), general):
        np.testing.assert_array_equal(got[name], want, err_msg=name)
    assert np.any(got["delta_v"] != 0) and np.any(got["duration"] == 0)


#: Found by test_exact_vs_diffrax.py: the middle car's acceleration peaks at +102.70 then
#: -102.63 ft/s² in one segment; the integrators refined only their largest probe: -102.63.
TWO_PEAKS = {"units": "US", "vehicles": [{"mass": 1000.0, "speed": 10.0},
                                         {"mass": 100.0, "speed": 0.0},
                                         {"mass": 913.9816994654905, "speed": 0.0}],
             "contacts": [{"loading": {"stiffness": 22467.900918126445},
                           "unloading": {"restitution": 0.6875}, "gap": 1.0},
                          {"loading": {"stiffness": 33982.083289425595},
                           "unloading": {"restitution": 0.8828125}, "gap": 0.01}]}


@pytest.mark.parametrize("method", ["scipy", "diffrax"])
def test_of_two_near_equal_peaks_in_one_segment_the_larger_is_found(method):
    """The middle car's acceleration peaks at +102.70 and then -102.63 ft/s² in one segment
    (between contact 0's max deformation and contact 1's separation): the integrators probed 33
    points, refined only the largest probe and gave -102.63, the wrong peak with the wrong sign.
    Every local maximum of the probes is refined now: both give exact-chain's +102.70."""
    if method == "diffrax":
        pytest.importorskip("diffrax")
    exact = lsc.solve(TWO_PEAKS, method="exact-chain")
    r = lsc.solve(TWO_PEAKS, method=method)
    assert exact.peak_acceleration[1] > 102.7
    np.testing.assert_allclose(r.peak_acceleration, exact.peak_acceleration, rtol=1e-8)
