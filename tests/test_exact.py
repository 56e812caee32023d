"""The exact piecewise backend against the closed form, SciPy, itself batched, and conservation."""

import functools
import itertools
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import lsc
from lsc.contact import STATUS, HysteresisLaw
from lsc.curves import Curve
from lsc.model import HybridModel
from lsc.scene import (Contact, Hysteresis, Restitution, Scene, UnloadingStiffness,
                       UnloadingTable, Vehicle)
from lsc.solvers import closed_form, exact, pick, scipy_ode
from conftest import two_cars

# (what each metric is compared against: a scale of its own kind)
SCALES = {"delta_v": "v", "v_final": "v", "peak_acceleration": "a", "duration": "t",
          "max_deformation": "d", "permanent_deformation": "d", "peak_force": "f",
          "restitution": 1.0, "restitution_energy": 1.0, "energy_absorbed": "E",
          "energy_returned": "E"}


def scene(m1, m2, v1, v2, loading: Curve, unloading, gap=0.0) -> Scene:
    """A two-vehicle SI scene built from the dataclasses."""
    return Scene(name="t", units="SI", g=9.80665,
                 vehicles=(Vehicle("bullet", m1, v1), Vehicle("target", m2, v2)),
                 contacts=(Contact(Hysteresis(loading, unloading), gap=gap),))


def scales(m, ref) -> dict:
    """Scales of each kind of quantity for one result ``ref`` (a Result or a metrics dict)."""
    get = (lambda k: ref[k]) if isinstance(ref, dict) else (lambda k: getattr(ref, k))
    v0 = float(np.max(np.abs(np.asarray(get("delta_v")))))
    f = float(np.max(get("peak_force")))
    return {"v": v0, "t": float(get("duration")), "d": float(np.max(get("max_deformation"))),
            "f": f, "a": f / min(m), "E": float(np.max(get("energy_absorbed")))}


def assert_metrics_close(got, ref, m, tol, names=tuple(SCALES)):
    sc = scales(m, ref)
    get_r = (lambda k: ref[k]) if isinstance(ref, dict) else (lambda k: getattr(ref, k))
    get_g = (lambda k: got[k]) if isinstance(got, dict) else (lambda k: getattr(got, k))
    for name in names:
        a, b = np.asarray(get_g(name), float), np.asarray(get_r(name), float)
        kind = SCALES[name]
        scale = kind if isinstance(kind, float) else sc[kind]
        err = np.max(np.abs(a - b)) / scale
        assert err <= tol, f"{name}: {a} vs {b} (error {err:.2e} of its scale)"


# --------------------------------------------------------------------------- closed form
GRID = list(itertools.product([0.1, 0.4, 1.0, 3.0, 10.0], [0.0, 0.3, 1.0], [1e3, 2.4e4, 1e6]))


@pytest.mark.parametrize("ratio, e, k", GRID)
def test_exact_matches_closed_form(ratio, e, k):
    m1, m2, v1, v2 = 1500.0 * ratio, 1500.0, 5.0, 1.0
    sc = scene(m1, m2, v1, v2, Curve.linear(k), Restitution(e))
    r = exact.solve(HybridModel(sc))
    cf = closed_form.metrics(m1, m2, v1, v2, k, e)
    for name in ("delta_v", "v_final", "duration", "peak_force", "max_deformation",
                 "energy_absorbed", "peak_acceleration"):
        a, b = np.asarray(getattr(r, name)), np.asarray(cf[name])
        assert np.max(np.abs(a - b) / np.abs(b)) <= 1e-12, (name, a, b)
    # quantities that may be zero: relative to their natural scale
    assert (abs(r.permanent_deformation[0] - cf["permanent_deformation"])
            <= 1e-12 * cf["max_deformation"])
    assert abs(r.energy_returned[0] - cf["energy_returned"]) <= 1e-12 * cf["energy_absorbed"]
    assert r.restitution[0] == pytest.approx(e, abs=1e-12)
    assert r.restitution_energy[0] == pytest.approx(e, abs=1e-12)
    kinds = [ev.kind for ev in r.events]
    assert kinds == (["contact", "max_deformation+separation"] if e == 0 else
                     ["contact", "max_deformation", "separation"])
    assert r.method == "exact"


def test_exact_matches_closed_form_with_gap_and_unloading_stiffness():
    k, su = 5e4, 5e4 / 0.36  # e = 0.6
    sc = scene(1500.0, 1000.0, 6.0, 1.0, Curve.linear(k), UnloadingStiffness(su), gap=0.25)
    r = exact.solve(HybridModel(sc))
    cf = closed_form.metrics(1500.0, 1000.0, 6.0, 1.0, k, 0.6, gap=0.25)
    for name in ("delta_v", "duration", "peak_force", "max_deformation", "permanent_deformation"):
        assert np.max(np.abs(np.asarray(getattr(r, name)) - cf[name]) / np.abs(cf[name])) <= 1e-12
    contact = [ev for ev in r.events if ev.kind == "contact"][0]
    assert contact.time == pytest.approx(0.25 / 5.0, rel=1e-15)


def test_series_through_the_api():
    """`method="exact"` through lsc.solve, on a scene dict (series of two lines = a line)."""
    d = two_cars(1200.0, 1500.0, 4.0, 0.0, {"series": [{"stiffness": 8e4}, {"stiffness": 1.2e5}]},
                 {"restitution": 0.4})
    r = lsc.solve(d, method="exact")
    cf = closed_form.metrics(1200.0, 1500.0, 4.0, 0.0, 1 / (1 / 8e4 + 1 / 1.2e5), 0.4)
    assert np.max(np.abs(r.delta_v - cf["delta_v"]) / np.abs(cf["delta_v"])) <= 1e-12
    assert r.duration == pytest.approx(cf["duration"], rel=1e-12)


# --------------------------------------------------------------------------- random tables
@st.composite
def tables(draw, n_seg=None, extends=None):
    """A loading curve with a plateau (zero slope) and a falling (negative slope) segment."""
    n = draw(st.integers(3, 6)) if n_seg is None else n_seg
    widths = draw(st.lists(st.floats(0.005, 0.08), min_size=n, max_size=n))
    slopes = draw(st.lists(st.floats(2e4, 1e6), min_size=n, max_size=n))
    flat, fall = draw(st.permutations(range(1, n)))[:2]
    drop = draw(st.floats(0.1, 0.9))
    f = [0.0]
    for i in range(n):
        s = 0.0 if i == flat else (-drop * f[-1] / widths[i] if i == fall else slopes[i])
        f.append(max(f[-1] + s * widths[i], 0.0))
    d = np.concatenate([[0.0], np.cumsum(widths)])
    ext = draw(st.booleans()) if extends is None else extends
    end = draw(st.floats(1e5, 2e6)) if ext else None
    return Curve(d, np.array(f), end)


# (restitutions between 0 and 0.05 are left out: their unloading line is so stiff that the
# permanent set lies a few ulps below D_max, beyond what SciPy resolves to 1e-10)
restitutions = st.sampled_from([0.0, 0.1, 0.4, 0.7, 1.0]) | st.floats(0.05, 1.0)
unloadings = st.one_of(
    st.builds(Restitution, restitutions),
    st.builds(UnloadingStiffness, st.floats(3e6, 3e7)),
    st.just(UnloadingTable(np.array([0.5, 0.45, 0.38, 0.3]), np.array([1e4, 5e3, 1e3, 0.0]))),
)


@st.composite
def table_scenes(draw, n_seg=None, extends=None, unloading=unloadings):
    return scene(draw(st.floats(500.0, 3000.0)), draw(st.floats(500.0, 3000.0)),
                 draw(st.floats(1.0, 10.0)), draw(st.floats(-2.0, 0.9)),
                 draw(tables(n_seg, extends)), draw(unloading),
                 gap=draw(st.sampled_from([0.0, 0.0, 0.05])))


def _table_ends_first(sc) -> bool:
    """Exact criterion: the loading table ends before the common velocity iff the relative
    kinetic energy at contact, (1/2) μ (v1 - v2)², exceeds the energy under the whole table."""
    curve = sc.contacts[0].law.loading
    m1, m2 = sc.masses
    v1, v2 = sc.speeds
    return not curve.extends and 0.5 * m1 * m2 / (m1 + m2) * (v1 - v2) ** 2 > curve.cum_energy[-1]


def _scipy(model):
    """The tightest SciPy solve: DOP853 at rtol 1e-13 (at 1e-12 SciPy itself errs by up to
    ~1.2e-10 on slow scenes; its error falls with rtol towards the exact values), with steps of
    at most a tenth of the contact time scale (on a plateau the motion is a parabola, DOP853's
    error estimate vanishes and its steps grow until they straddle the next breakpoint)."""
    h = model.time_scale() / 10
    with mock.patch.object(scipy_ode, "solve_ivp", functools.partial(solve_ivp, max_step=h)):
        return scipy_ode.solve(model, rtol=1e-13)


def _scipy_stepped_over_a_breakpoint(sc, sp) -> bool:
    """SciPy finds an event by a sign change between two steps: when the deformation passes a
    breakpoint and comes back within one step (max deformation just past it), it misses it."""
    n_sp = sum(e.kind == "breakpoint" for e in sp.events)
    d = sc.contacts[0].law.loading.d
    return np.sum(d < sp.max_deformation[0]) - 1 > n_sp


def _energy_check(sc, ex):
    """At the common velocity all relative kinetic energy at contact is in the bumpers."""
    m1, m2 = sc.masses
    v1, v2 = sc.speeds
    e_rel = 0.5 * m1 * m2 / (m1 + m2) * (v1 - v2) ** 2
    curve = sc.contacts[0].law.loading
    assert ex.energy_absorbed[0] == pytest.approx(e_rel, rel=1e-12)
    assert float(curve.energy(ex.max_deformation[0])) == pytest.approx(e_rel, rel=1e-12)


def _solve_both(sc):
    """(exact, scipy) results, or (None, None) when the physics cannot complete: then the exact
    backend raises what SciPy raises (a table end is checked by the energy criterion instead).
    Examples where SciPy misses a breakpoint are left out (after checking the exact solve)."""
    model = HybridModel(sc)
    ends = _table_ends_first(sc)
    ex_err = None
    try:
        ex = exact.solve(model)
    except lsc.SimulationError as err:
        ex, ex_err = None, str(err).split(": ", 1)[1]
        if STATUS[1] in ex_err:
            assert ends
            return None, None
    else:
        assert not ends
        _energy_check(sc, ex)
    try:
        sp = _scipy(model)
    except lsc.SimulationError as err:
        assert ex is None, f"SciPy failed ({err}) where the exact backend did not"
        assert str(err).split(": ", 1)[1] == ex_err
        return None, None
    if _scipy_stepped_over_a_breakpoint(sc, sp):
        assume(False)
    assert ex is not None, f"the exact backend failed ({ex_err}) where SciPy did not"
    return ex, sp


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(table_scenes())
def test_exact_matches_scipy_on_random_tables(sc):
    ex, sp = _solve_both(sc)
    if ex is None:
        return
    assert_metrics_close(ex, sp, sc.masses, 1e-10)
    assert [e.kind for e in ex.events] == [e.kind for e in sp.events]
    for a, b in zip(ex.events, sp.events):
        assert abs(a.time - b.time) <= 1e-10 * sp.duration


def test_exact_does_not_step_over_a_breakpoint():
    """Max deformation 0.5 mm past the start of a plateau: SciPy's step straddles the excursion
    past the breakpoint (no sign change at its ends); the exact backend stops there, and the
    SciPy backend finds the crossing it stepped over (see scipy_ode._missed)."""
    f1 = 24539.09375
    sc = scene(875.0, 2034.0, 1.125, 0.0,
               Curve.table([[0, 0], [0.03125, f1], [0.09375, f1], [0.15625, 12269.5]]),
               UnloadingStiffness(3e6))
    model = HybridModel(sc)
    ex, sp = exact.solve(model), scipy_ode.solve(model, rtol=1e-12)
    assert [e.kind for e in ex.events] == ["contact", "breakpoint", "max_deformation",
                                           "separation"]
    assert [e.kind for e in sp.events] == [e.kind for e in ex.events]
    assert 0.03125 < ex.max_deformation[0] < 0.0315
    assert ex.peak_force[0] == pytest.approx(f1, rel=1e-15)   # the plateau force, exactly
    assert sp.peak_force[0] == pytest.approx(f1, rel=1e-12)   # not beyond the table's largest
    assert sp.max_deformation[0] == pytest.approx(ex.max_deformation[0], rel=1e-10)
    # on the plateau the force is constant: D_max = d1 + (closing speed at d1)² μ / (2 f1)
    mu = 875.0 * 2034.0 / (875.0 + 2034.0)
    w1 = np.sqrt(1.125**2 - f1 * 0.03125 / mu)   # energy: (1/2) μ w² = (1/2) μ v0² - f1 d1 / 2
    assert ex.max_deformation[0] == pytest.approx(0.03125 + mu * w1**2 / (2 * f1), rel=1e-12)


def _reference_40_digits(m1, m2, v0, d, f, end_slope, e):
    """An independent 40-digit reference for a table that extends with ``end_slope`` and
    restitution unloading (target at rest, no gap): the common velocity from its own closed form
    per segment, breakpoints by bisection on ``D(t)``, the unloading half-period analytically.
    Returns (event times, D_max, absorbed energy, final speeds)."""
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 40
    m1, m2, v0, e = (mp.mpf(x) for x in (m1, m2, v0, e))
    d, f = [mp.mpf(x) for x in d], [mp.mpf(x) for x in f]
    mu = m1 * m2 / (m1 + m2)
    slopes = [(f[i + 1] - f[i]) / (d[i + 1] - d[i]) for i in range(len(d) - 1)]
    slopes.append(mp.mpf(end_slope))

    def motion(D0, W0, A0, kappa, t):
        if kappa > 0:
            w = mp.sqrt(kappa)
            return D0 + W0 * mp.sin(w * t) / w + A0 * (1 - mp.cos(w * t)) / kappa
        if kappa < 0:
            w = mp.sqrt(-kappa)
            return D0 + W0 * mp.sinh(w * t) / w + A0 * (mp.cosh(w * t) - 1) / -kappa
        return D0 + W0 * t + A0 * t * t / 2

    D, W, t, ec, times = mp.mpf(0), v0, mp.mpf(0), mp.mpf(0), []
    for seg, s in enumerate(slopes):
        F0 = f[seg] + s * (D - d[seg])
        A0, kappa = -F0 / mu, s / mu
        if kappa > 0:                      # time to the common velocity, D' = 0
            tv = mp.atan2(W * mp.sqrt(kappa), -A0) / mp.sqrt(kappa)
        elif kappa == 0:
            tv = -W / A0
        else:
            x = W * mp.sqrt(-kappa) / -A0
            tv = mp.atanh(x) / mp.sqrt(-kappa) if 0 < x < 1 else mp.inf
        if seg + 1 < len(d) and (tv == mp.inf or motion(D, W, A0, kappa, tv) > d[seg + 1]):
            lo, hi = mp.mpf(0), tv if tv < mp.inf else mp.mpf(10)
            for _ in range(150):
                mid = (lo + hi) / 2
                lo, hi = (mid, hi) if motion(D, W, A0, kappa, mid) < d[seg + 1] else (lo, mid)
            t += hi
            ec += (f[seg] + f[seg + 1]) / 2 * (d[seg + 1] - d[seg])
            W = mp.sqrt(2 * (mu * v0 * v0 / 2 - ec) / mu)  # energy balance on loading
            D = d[seg + 1]
            times.append(t)
            continue
        D = motion(D, W, A0, kappa, tv)
        t += tv
        times.append(t)
        ec = mu * v0 * v0 / 2                 # all relative kinetic energy absorbed
        break
    fmax = f[seg] + s * (D - d[seg])
    w_u = mp.sqrt(fmax * fmax / (2 * e * e * ec) / mu) if e > 0 else None
    if e > 0:
        t += mp.pi / (2 * w_u)
        times.append(t)
    vcm = m1 * v0 / (m1 + m2)
    W_end = -e * v0                           # energy restitution
    return ([float(x) for x in times], float(D), float(ec),
            [float(vcm + m2 / (m1 + m2) * W_end), float(vcm - m1 / (m1 + m2) * W_end)])


@pytest.mark.parametrize("seed, e", [(0, 0.0), (1, 0.5), (2, 1.0), (3, 0.3), (4, 0.8), (5, 0.6)])
def test_exact_to_machine_precision_against_40_digits(seed, e):
    rng = np.random.default_rng(seed)
    widths = rng.uniform(0.01, 0.05, 5)
    slopes = rng.uniform(2e5, 1e6, 5)
    slopes[2], slopes[3] = 0.0, -0.5 * slopes[1]   # a plateau, then a falling segment
    d = np.concatenate([[0.0], np.cumsum(widths)])
    f = np.concatenate([[0.0], np.cumsum(slopes * widths)])
    m1, m2, v0 = rng.uniform(800, 2000), rng.uniform(800, 2000), 7.0
    sc = scene(m1, m2, v0, 0.0, Curve(d, f, 4e5), Restitution(e))
    times, dmax, ec, vf = _reference_40_digits(m1, m2, v0, d, f, 4e5, e)
    r = exact.solve(HybridModel(sc))
    got = [ev.time for ev in r.events if ev.time > 0]
    assert len(got) == len(times)
    assert r.max_deformation[0] > d[4]              # through the plateau and the fall
    assert np.max(np.abs(np.subtract(got, times))) <= 1e-13 * times[-1]
    assert r.max_deformation[0] == pytest.approx(dmax, rel=1e-13)
    assert r.energy_absorbed[0] == pytest.approx(ec, rel=1e-13)
    assert np.max(np.abs(r.v_final - vf)) <= 1e-13 * v0
    assert r.duration == pytest.approx(times[-1], rel=1e-13)


def test_random_tables_cover_every_kind_of_segment():
    """The scenes of the property test do run through harmonic, parabolic and hyperbolic
    segments (checked on a fixed example): a plateau and a falling segment are loaded."""
    sc = scene(1600.0, 1200.0, 6.0, 0.0,
               Curve.table([[0, 0], [0.02, 3000], [0.1, 25000], [0.15, 40000], [0.2, 40000],
                            [0.25, 35000], [0.4, 120000]]), Restitution(0.5))
    model = HybridModel(sc)
    ex = exact.solve(model)
    sp = scipy_ode.solve(model, rtol=1e-12)
    assert_metrics_close(ex, sp, sc.masses, 1e-10)
    segs = [float(D) for D in ex.deformation[:, 0]]
    assert max(segs) > 0.25  # through the plateau (0.15-0.2) and the fall (0.2-0.25)


# --------------------------------------------------------------------------- conservation
@settings(max_examples=25, deadline=None)
@given(table_scenes(extends=True))
def test_momentum_conserved(sc):
    try:
        r = exact.solve(HybridModel(sc))
    except lsc.SimulationError:
        return
    m = sc.masses
    p0 = m @ sc.speeds
    scale = np.abs(m) @ np.abs(sc.speeds)
    assert abs(m @ r.v_final - p0) <= 1e-12 * scale
    assert np.max(np.abs(r.v @ m - p0)) <= 1e-12 * scale
    # energy: kinetic energy lost = absorbed - returned by the bumpers
    ke = 0.5 * m @ sc.speeds**2 - 0.5 * m @ r.v_final**2
    assert ke == pytest.approx(r.energy_absorbed[0] - r.energy_returned[0],
                               abs=1e-11 * r.energy_absorbed[0])


# --------------------------------------------------------------------------- batch
def _batch_vs_single(scenes, tol=1e-12):
    out = exact.solve_batch(exact.batch_params(scenes))
    for i, sc in enumerate(scenes):
        try:
            r = exact.solve(HybridModel(sc))
        except lsc.SimulationError as err:
            assert out["status"][i] != 0
            assert STATUS[int(out["status"][i])] in str(err)
            assert np.isnan(out["duration"][i])
            continue
        assert out["status"][i] == 0
        got = {k: out[k][i] for k in SCALES}
        assert_metrics_close(got, r, sc.masses, tol)
        assert out["events"][i] == len(r.events)
        assert out["peak_acceleration_g"][i] == pytest.approx(r.peak_acceleration_g, rel=1e-12)
    return out


@settings(max_examples=10, deadline=None)
@given(st.lists(table_scenes(n_seg=4, extends=True,
                             unloading=st.builds(Restitution, st.floats(0.0, 1.0))),
                min_size=1, max_size=12))
def test_batch_equals_single_scene_solves(scenes):
    _batch_vs_single(scenes)


@pytest.mark.parametrize("unloading", [UnloadingStiffness(2e7), UnloadingTable(
    np.array([0.5, 0.45, 0.38, 0.3]), np.array([1e4, 5e3, 1e3, 0.0]))])
def test_batch_other_unloading_rules_and_ending_tables(unloading):
    rng = np.random.default_rng(3)
    scenes = []
    for i in range(20):
        d = np.concatenate([[0.0], np.cumsum(rng.uniform(0.02, 0.1, 5))])
        f = np.concatenate([[0.0], np.cumsum(rng.uniform(1e4, 8e4, 5))])
        scenes.append(scene(rng.uniform(800, 2000), rng.uniform(800, 2000), rng.uniform(2, 9),
                            0.0, Curve.table(np.c_[d, f]), unloading,
                            gap=float(rng.choice([0.0, 0.1]))))
    out = _batch_vs_single(scenes)
    assert set(out["status"]) >= {0}


def test_batch_linear_loading_matches_closed_form():
    ratio, e, k = np.meshgrid([0.1, 1.0, 10.0], [0.0, 0.3, 1.0], [1e3, 2.4e4, 1e6])
    m1 = 1500.0 * ratio.ravel()
    out = exact.solve_batch({"m1": m1, "m2": 1500.0, "v1": 5.0, "v2": 1.0,
                             "stiffness": k.ravel(), "e": e.ravel(), "gap": 0.1})
    cf = closed_form.metrics(m1, 1500.0, 5.0, 1.0, k.ravel(), e.ravel(), gap=0.1)
    assert np.all(out["status"] == 0)
    for name in ("delta_v", "duration", "peak_force", "max_deformation", "separation_time"):
        assert np.max(np.abs(out[name] - cf[name]) / np.abs(cf[name])) <= 1e-12, name


def test_batch_law_parameters_are_the_laws():
    """The batched tables are, row by row, HysteresisLaw's own parameters."""
    rng = np.random.default_rng(7)
    scenes = [scene(1000.0, 1000.0, 3.0, 0.0, Curve(np.r_[0, np.cumsum(rng.uniform(.01, .1, 4))],
                                                   np.r_[0, np.cumsum(rng.uniform(1e3, 1e4, 4))],
                                                   1e5), Restitution(0.5)) for _ in range(5)]
    P = exact._batch_inputs(exact.batch_params(scenes))
    law, p, _ = exact._batch_law(P)
    for i, sc in enumerate(scenes):
        ref = HysteresisLaw(sc.contacts[0].law).params
        for key in ("ld", "lf", "ls", "le"):
            np.testing.assert_array_equal(p[key].c[:, i], ref[key])


def test_batch_statuses():
    sc_end = scene(1500.0, 1500.0, 8.0, 0.0, Curve.table([[0, 0], [0.05, 1e4], [0.1, 2e4]]),
                   Restitution(0.5))
    sc_ok = scene(1500.0, 1500.0, 1.0, 0.0, Curve.table([[0, 0], [0.05, 1e4], [0.1, 2e4]]),
                  Restitution(0.5))
    out = exact.solve_batch(exact.batch_params([sc_end, sc_ok, sc_end]))
    assert list(out["status"]) == [1, 0, 1]
    assert np.isnan(out["delta_v"][0]).all() and np.isfinite(out["delta_v"][1]).all()
    limited = exact.solve_batch(exact.batch_params([sc_ok]), max_events=2)
    assert limited["status"][0] == exact.EVENT_LIMIT
    with pytest.raises(ValueError, match="unloading"):
        exact.solve_batch({"m1": 1.0, "m2": 1.0, "v1": 1.0, "v2": 0.0, "stiffness": 1.0})


# --------------------------------------------------------------------------- bumper failure
def test_failure_time_matches_closed_form_and_scipy():
    """The failure force is crossed at t_c + arcsin(F_f/F_max)/ω (closed form); on a table,
    where the force passes it on a rising segment, as SciPy finds it."""
    d = two_cars(1500.0, 1000.0, 6.0, 1.0, {"stiffness": 5e4}, {"restitution": 0.3}, gap=0.2)
    d["contacts"][0]["failure"] = {"force": 2e4}
    ex, cf = lsc.solve(d, method="exact"), lsc.solve(d, method="closed-form")
    assert ex.failed[0] and cf.failed[0]
    assert ex.failure_time[0] == pytest.approx(cf.failure_time[0], rel=1e-13)
    assert [e.kind for e in ex.events] == ["contact", "failure", "max_deformation", "separation"]
    assert ex.delta_v == pytest.approx(cf.delta_v, rel=1e-13)  # failure changes no force
    d["contacts"][0]["loading"] = {"table": [[0, 0], [0.05, 8e3], [0.1, 8e3], [0.4, 1.2e5]]}
    ex, sp = lsc.solve(d, method="exact"), lsc.solve(d, method="scipy", rtol=1e-12)
    assert ex.failure_time[0] == pytest.approx(sp.failure_time[0], rel=1e-10)
    ff = lsc.Scene.load(d)
    never = ff.with_values({"contacts.0.failure.force": 1e6})
    out = exact.solve_batch(exact.batch_params([ff, never]))
    assert out["failure_time"][0] == pytest.approx(ex.failure_time[0], rel=1e-14)
    assert np.isnan(out["failure_time"][1])
    assert out["events"][0] == len(ex.events)


# --------------------------------------------------------------------------- failures, dispatch
def test_table_end_raises_simulation_error():
    sc = scene(1500.0, 1500.0, 8.0, 0.0, Curve.table([[0, 0], [0.05, 1e4], [0.1, 2e4]]),
               Restitution(0.5))
    with pytest.raises(lsc.SimulationError) as err:
        exact.solve(HybridModel(sc))
    assert STATUS[1] in str(err.value)
    d = two_cars(1500.0, 1500.0, 8.0, 0.0, {"table": [[0, 0], [0.05, 1e4], [0.1, 2e4]]},
                 {"restitution": 0.5})
    with pytest.raises(lsc.SimulationError, match="loading table ends"):
        lsc.solve(d, method="exact")


@pytest.mark.parametrize("v0", [3.0, 3.9, 3.999, 4.001, 4.1, 6.0])
def test_table_end_exactly_when_the_energy_runs_out(v0):
    # E_table = 0.05 (1e4/2 + 1.5e4) = 1000 J; μ = 125 kg: the table ends first iff v0 > 4 m/s
    sc = scene(250.0, 250.0, v0, 0.0, Curve.table([[0, 0], [0.05, 1e4], [0.1, 2e4]]),
               Restitution(0.5))
    assert _table_ends_first(sc) == (v0 > 4.0)
    out = exact.solve_batch(exact.batch_params([sc]))
    assert out["status"][0] == (1 if v0 > 4.0 else 0)
    if v0 > 4.0:
        with pytest.raises(lsc.SimulationError, match="loading table ends"):
            exact.solve(HybridModel(sc))
    else:
        r = exact.solve(HybridModel(sc))
        assert r.energy_absorbed[0] == pytest.approx(0.5 * 125.0 * v0**2, rel=1e-13)


def test_t_end_and_options():
    d = two_cars(1500.0, 1200.0, 5.0, 0.0, {"table": [[0, 0], [0.05, 1e4], [0.5, 3e5]]},
                 {"restitution": 0.3})
    r = lsc.solve(d, method="exact")
    longer = lsc.solve(d, method="exact", t_end=2 * r.duration, n_samples=50)
    assert longer.t[-1] == pytest.approx(2 * r.duration, rel=1e-15)
    assert np.allclose(longer.delta_v, r.delta_v, rtol=0, atol=1e-15)
    with pytest.raises(lsc.SimulationError, match="t_end"):
        lsc.solve(d, method="exact", t_end=0.5 * r.duration)
    with pytest.raises(lsc.SceneError, match="rtol"):
        lsc.solve(d, method="exact", rtol=1e-8)


def test_auto_prefers_closed_form_then_exact():
    lin = lsc.Scene.load(two_cars(1.0, 1.0, 1.0, 0.0, {"stiffness": 1.0}, {"restitution": 0.5}))
    tab = lsc.Scene.load(two_cars(1.0, 1.0, 1.0, 0.0, {"table": [[0, 0], [1, 1], [2, 5]]},
                                  {"restitution": 0.5}))
    unl = lsc.Scene.load(two_cars(1.0, 1.0, 1.0, 0.0, {"stiffness": 1.0},
                                  {"table": [[1, 1], [0.5, 0]]}))
    assert pick(lin, "auto") == "closed-form"
    assert pick(tab, "auto") == "exact"
    assert pick(unl, "auto") == "exact"
    assert lsc.solve(tab).method == "exact"
    braked = Scene(name="b", units="SI", g=9.80665,
                   vehicles=(Vehicle("a", 1.0, 1.0, lsc.scene.Brake(0.5, 0.6)),
                             Vehicle("b", 1.0, 0.0)),
                   contacts=tab.contacts)
    assert "braking" in exact.why_not(braked)
    assert pick(braked, "auto") == "scipy"
