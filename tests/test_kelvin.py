"""The Kelvin law ``F = max(0, k D + c Ḋ)`` of two vehicles in closed form
(:mod:`lsc.solvers.kelvin`): against the formulas of DESIGN.md §1 (under-damped), against
40-digit solutions of the same ODE from its characteristic roots (every regime), and against
the tightest SciPy solve; momentum and energy balance."""

import mpmath as mp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import lsc
from lsc.contact import kelvin_restitution
from lsc.model import HybridModel
from lsc.solvers import kelvin

M1, M2 = 1400.0, 1000.0
MU = M1 * M2 / (M1 + M2)
K = 2.0e5


def scene(zeta=None, v1=3.0, v2=0.0, m1=M1, m2=M2, k=K, gap=0.0, failure=None, **law):
    """Two cars with a Kelvin contact of damping ratio ``zeta`` (or the law's keys)."""
    if zeta is not None:
        law["damping"] = 2.0 * zeta * np.sqrt(k * m1 * m2 / (m1 + m2))
    contact = {"law": "kelvin", "stiffness": k, "gap": gap, **law}
    if failure is not None:
        contact["failure"] = {"force": failure}
    return {"units": "SI", "vehicles": [{"mass": m1, "speed": v1}, {"mass": m2, "speed": v2}],
            "contacts": [contact]}


def model(sc) -> HybridModel:
    return HybridModel(lsc.Scene.load(sc))


def design_formulas(zeta, v0, w):
    """DESIGN.md §1, under-damped: ``D = (v0/ω_d) e^{-ζωt} sin ω_d t``, max crush at
    ``arccos ζ/ω_d``, force zero at ``2 arccos ζ/ω_d``, and the closing rate there
    (``1 - ζ²`` evaluated as ``(1 - ζ)(1 + ζ)``, exact near ζ = 1)."""
    wd = w * np.sqrt((1 - zeta) * (1 + zeta))
    t_m, t_s = np.arccos(zeta) / wd, 2 * np.arccos(zeta) / wd
    D = v0 / wd * np.exp(-zeta * w * t_m) * np.sin(wd * t_m)
    Dd_s = v0 / wd * np.exp(-zeta * w * t_s) * (wd * np.cos(wd * t_s) - zeta * w * np.sin(wd * t_s))
    return t_m, D, t_s, -Dd_s / v0


def roots_solution(zeta, w=1.0, v0=1.0, dps=40):
    """The same motion in ``dps``-digit arithmetic from the characteristic roots
    ``s = -ζω ± ω√(ζ²-1)``: ``D = v0 (e^{s1 t} - e^{s2 t})/(s1 - s2)`` (``v0 t e^{-ωt}``
    critically damped), and ``F/μ = ω² D + 2ζω Ḋ``; returns (D, Ḋ, F/μ) as functions of t."""
    mp.mp.dps = dps
    z, w, v0 = mp.mpf(zeta), mp.mpf(w), mp.mpf(v0)
    if z == 1:
        D = lambda t: v0 * t * mp.exp(-w * t)                          # noqa: E731
        Dd = lambda t: v0 * (1 - w * t) * mp.exp(-w * t)               # noqa: E731
    else:
        r = w * mp.sqrt(mp.mpc(z * z - 1))
        s1, s2 = -z * w + r, -z * w - r
        D = lambda t: mp.re(v0 * (mp.exp(s1 * t) - mp.exp(s2 * t)) / (s1 - s2))            # noqa
        Dd = lambda t: mp.re(v0 * (s1 * mp.exp(s1 * t) - s2 * mp.exp(s2 * t)) / (s1 - s2))  # noqa
    return D, Dd, lambda t: w * w * D(t) + 2 * z * w * Dd(t)


def bisect(f, lo, hi, n=200):
    """The sign change of ``f`` in ``[lo, hi]`` (mpmath numbers), by bisection."""
    flo = f(lo)
    for _ in range(n):
        mid = (lo + hi) / 2
        if (f(mid) > 0) == (flo > 0):
            lo, flo = mid, f(mid)
        else:
            hi = mid
    return (lo + hi) / 2


def rel(a, b) -> float:
    return float(abs(mp.mpf(float(a)) - b) / abs(b))


# ------------------------------------------------------------------ DESIGN.md, under-damped
UNDER = [0.0, 1e-6, 0.05, 0.3, 0.5, 0.7, 0.95, 0.999, 1 - 1e-9]


@pytest.mark.parametrize("zeta", UNDER)
def test_underdamped_metrics_match_the_design_formulas(zeta):
    v0, w = 3.0, np.sqrt(K / MU)
    t_m, D_max, t_s, e = design_formulas(zeta, v0, w)
    met = kelvin.metrics(M1, M2, v0, 0.0, K, zeta)
    assert met["max_deformation_time"] == pytest.approx(t_m, rel=1e-13, abs=0)
    assert met["max_deformation"] == pytest.approx(D_max, rel=1e-13, abs=0)
    assert met["duration"] == pytest.approx(t_s, rel=1e-13, abs=0)
    assert met["separation_time"] == pytest.approx(t_s, rel=1e-13, abs=0)
    assert met["restitution"] == pytest.approx(e, rel=1e-13, abs=1e-15)
    assert met["restitution"] == pytest.approx(kelvin_restitution(zeta), rel=1e-14, abs=0)


@given(zeta=st.one_of(st.just(0.0), st.floats(1e-6, 0.999)), v0=st.floats(0.1, 30.0),
       m1=st.floats(500, 5000),
       m2=st.floats(500, 5000), k=st.floats(1e4, 1e7),
       gap=st.one_of(st.just(0.0), st.floats(1e-6, 0.2)))
@settings(max_examples=40)
def test_underdamped_result_matches_the_design_formulas(zeta, v0, m1, m2, k, gap):
    m = model(scene(zeta, v0, 0.0, m1, m2, k, gap))
    r = kelvin.solve(m)
    z = kelvin.parameters(m)["zeta"]   # the scene's own ratio (c rounded through the loader)
    w = np.sqrt(k * (m1 + m2) / (m1 * m2))
    t_m, D_max, t_s, e = design_formulas(z, v0, w)
    t_c = gap / v0
    times = {ev.kind: ev.time for ev in r.events}
    assert times["contact"] == t_c
    assert times["max_deformation"] - t_c == pytest.approx(t_m, rel=1e-13)
    assert r.duration == pytest.approx(t_s, rel=1e-13)
    assert r.max_deformation[0] == pytest.approx(D_max, rel=1e-13)
    assert r.restitution[0] == pytest.approx(e, rel=1e-12)   # from the speeds of the series
    assert r.restitution_energy[0] == pytest.approx(e, rel=1e-13)
    # the series follows D(t) of DESIGN.md through the contact
    wd = w * np.sqrt((1 - z) * (1 + z))
    inside = (r.t > t_c) & (r.t < t_c + t_s)
    tau = r.t[inside] - t_c
    D = v0 / wd * np.exp(-z * w * tau) * np.sin(wd * tau)
    assert np.max(np.abs(r.deformation[inside, 0] - D)) <= 1e-13 * D_max


def test_critical_damping_closed_form():
    # ζ = 1: D = v0 t e^{-ωt}: max crush v0/(eω) at 1/ω, force zero at 2/ω, e = e^{-2}
    v0, w = 3.0, np.sqrt(K / MU)
    met = kelvin.metrics(M1, M2, v0, 0.0, K, 1.0)
    assert met["max_deformation_time"] == pytest.approx(1 / w, rel=1e-15)
    assert met["max_deformation"] == pytest.approx(v0 / (np.e * w), rel=1e-15)
    assert met["duration"] == pytest.approx(2 / w, rel=1e-15)
    assert met["restitution"] == pytest.approx(np.exp(-2.0), rel=1e-15)
    assert met["peak_force"] == pytest.approx(2 * np.sqrt(K * MU) * v0, rel=1e-15)


# ------------------------------------------------------------------ every regime, 40 digits
REGIMES = [0.0, 0.1, 0.3, 0.49, 0.5, 0.51, 0.9, 1 - 1e-9, 1.0, 1 + 1e-9, 1.001, 1.5, 3.0,
           10.0, 100.0]


@pytest.mark.parametrize("zeta", REGIMES)
def test_every_regime_against_the_characteristic_roots(zeta):
    # ω = 1, v0 = 1, μ = 1/2: times in 1/ω, crush in v0/ω, force in μ ω v0
    D, Dd, F = roots_solution(zeta)
    t_m = bisect(Dd, mp.mpf(0), mp.mpf(2))   # (the first zero: t_m <= π/2 < 2 < the next)
    t_s = bisect(F, t_m, 2 * t_m + 1)   # F > 0 at t_m (F = k D_max), and its zero comes after
    if zeta > 0:   # the force reaches zero before the deformation does (undamped: with it)
        assert D(t_s) > 0
    met = kelvin.metrics(1.0, 1.0, 1.0, 0.0, 0.5, zeta)
    assert rel(met["max_deformation_time"], t_m) <= 1e-14
    assert rel(met["max_deformation"], D(t_m)) <= 1e-14
    assert rel(met["duration"], t_s) <= 1e-14
    # (the velocity restitution, from the speeds: absolute error in units of the closing speed)
    assert abs(met["restitution"] + Dd(t_s)) <= 1e-15
    assert abs(met["permanent_deformation"] - D(t_s)) <= 1e-14 * D(t_m)
    assert rel(kelvin_restitution(zeta), -Dd(t_s)) <= 1e-14
    assert rel(met["energy_absorbed"], mp.mpf(1) / 4) <= 1e-15   # ½ μ v0², all of it at t_m


@pytest.mark.parametrize("zeta", REGIMES)
def test_peak_force_and_its_time(zeta):
    # the force peaks inside the pulse for ζ < 1/2 (where F' = 0), at touch (c v0) otherwise
    D, Dd, F = roots_solution(zeta)
    met = kelvin.metrics(1.0, 1.0, 1.0, 0.0, 0.5, zeta)
    scale = mp.mpf(1) / 2   # μ (ω = v0 = 1)
    if zeta < 0.5:
        dF = lambda t: mp.diff(F, t)   # noqa: E731
        t_p = bisect(dF, mp.mpf(0), bisect(Dd, mp.mpf(0), mp.mpf(2)), n=120)
        assert rel(met["peak_force_time"], t_p) <= 1e-12
        assert rel(met["peak_force"], scale * F(t_p)) <= 1e-14
    else:
        assert met["peak_force_time"] == 0.0
        assert rel(met["peak_force"], scale * F(mp.mpf(0))) <= 1e-14
        # falling from the jump on: below it all through the pulse
        pulse = 2 * float(met["max_deformation_time"])
        assert max(F(t) for t in mp.linspace(1e-6, pulse, 60)) < F(0)


@pytest.mark.parametrize("zeta, level", [(0.1, 0.5), (0.1, 0.19), (0.3, 0.7), (0.45, 0.91),
                                         (0.7, 1.3), (2.0, 3.9)])
def test_failure_time(zeta, level):
    # the force (in μ ω v0) first exceeds `level`: at touch when c v0 = 2ζ does, else on its rise
    D, Dd, F = roots_solution(zeta)
    met = kelvin.metrics(1.0, 1.0, 1.0, 0.0, 0.5, zeta, failure_force=level / 2)
    if 2 * zeta > level:
        assert met["failure_time"] == 0.0
    else:
        t_f = bisect(lambda t: F(t) - level, mp.mpf(0), mp.mpf(float(met["peak_force_time"])))
        # to rounding, times the root's condition number: a level near the peak, where F is
        # flat, is crossed at a time that a rounding of F moves by a rounding over F'
        cond = max(1.0, float(level / (t_f * abs(mp.diff(F, t_f)))))
        assert rel(met["failure_time"], t_f) <= 1e-14 * cond
    above = kelvin.metrics(1.0, 1.0, 1.0, 0.0, 0.5, zeta, failure_force=met["peak_force"] * 1.01)
    assert np.isnan(above["failure_time"])


def test_metrics_are_vectorised():
    zeta = np.array(REGIMES)
    v0 = np.linspace(1.0, 5.0, zeta.size)
    gap = np.linspace(0.0, 0.1, zeta.size)
    met = kelvin.metrics(M1, M2, v0, 0.0, K, zeta, gap, failure_force=1e4)
    for i, z in enumerate(zeta):
        one = kelvin.metrics(M1, M2, v0[i], 0.0, K, z, gap[i], failure_force=1e4)
        for name, value in one.items():
            np.testing.assert_array_equal(met[name][i], value, err_msg=name)


# ------------------------------------------------------------------ against SciPy
def assert_metrics_close(ours: dict, theirs: lsc.Result, rel=1e-9):
    """Every metric within ``rel``, or ``1e-12`` of its scale where it is about zero (a
    permanent deformation on the scale of the max crush, a time on the pulse's)."""
    scale = {"permanent_deformation": theirs.max_deformation, "failure_time": theirs.duration}
    for name in lsc.result.METRICS:
        want = getattr(theirs, name)
        ref = scale.get(name, want)
        np.testing.assert_allclose(ours[name], want, rtol=rel,
                                   atol=1e-12 * np.max(np.abs(ref), initial=0), err_msg=name)


@given(zeta=st.one_of(st.floats(1e-6, 3.0), st.sampled_from([0.0, 0.5, 1.0, 1 - 1e-7, 1 + 1e-7])),
       v1=st.floats(0.5, 20.0), v2=st.floats(-5.0, 0.4), m1=st.floats(300, 5000),
       m2=st.floats(300, 5000), k=st.floats(1e4, 1e7), gap=st.sampled_from([0.0, 0.01, 0.1]),
       failure=st.sampled_from([None, 0.5, 0.9, 1.5]))
@settings(max_examples=30)
def test_every_regime_against_scipy(zeta, v1, v2, m1, m2, k, gap, failure):
    mu = m1 * m2 / (m1 + m2)
    fail = None if failure is None else failure * np.sqrt(k * mu) * (v1 - v2)
    sc = scene(zeta, v1, v2, m1, m2, k, gap, fail)
    r = kelvin.solve(model(sc))
    s = lsc.solve(sc, method="scipy", rtol=1e-12)
    # (a failure at touch, where the force jumps past the failure force, is an event here;
    # SciPy reports it by failure_time alone when it starts the segment failed)
    ours = [ev for ev in r.events if not (ev.kind == "failure" and ev.time == r.contact_time[0])]
    theirs = [ev for ev in s.events if ev.kind != "failure" or ev.time > s.contact_time[0]]
    assert [(ev.kind, ev.index) for ev in ours] == [(ev.kind, ev.index) for ev in theirs]
    for a, b in zip(ours, theirs):
        assert a.time == pytest.approx(b.time, rel=1e-9, abs=1e-12 * s.duration)
    assert_metrics_close(r.metrics(), s)


# ------------------------------------------------------------------ conservation
@pytest.mark.parametrize("zeta", REGIMES)
def test_momentum_and_energy_balance(zeta):
    sc = scene(zeta, 4.0, -1.0, gap=0.05)
    r = kelvin.solve(model(sc))
    m, v0 = np.array([M1, M2]), np.array([4.0, -1.0])
    p0 = m @ v0
    assert abs(m @ r.v_final - p0) <= 1e-14 * abs(p0)
    assert np.max(np.abs(r.v @ m - p0)) <= 1e-14 * abs(p0) * 4   # the series too
    ke0, ke1 = 0.5 * m @ v0**2, 0.5 * m @ r.v_final**2
    assert abs((ke0 - ke1) - (r.energy_absorbed[0] - r.energy_returned[0])) <= 1e-12 * ke0


# ------------------------------------------------------------------ the Result
def test_series_at_touch_separation_and_after():
    zeta, gap = 0.2, 0.1
    sc = scene(zeta, gap=gap)
    m = model(sc)
    c = 2 * kelvin.parameters(m)["zeta"] * np.sqrt(K * MU)
    r = kelvin.solve(m, t_end=0.5)
    t_c, t_s = gap / 3.0, r.separation_time[0]
    i = np.flatnonzero(r.t == t_c)
    assert i.size == 2   # before and after the jump of the force to c v0 (the known flaw)
    assert r.force[i[0], 0] == 0.0 and r.force[i[1], 0] == pytest.approx(c * 3.0, rel=1e-15)
    assert np.all(r.force >= 0.0)
    assert r.force[r.t == t_s, 0] == 0.0
    after = r.t >= t_s
    np.testing.assert_array_equal(r.v[after], np.broadcast_to(r.v_final, r.v[after].shape))
    assert r.t[-1] == 0.5
    assert np.all(np.diff(r.deformation[r.t > t_s, 0]) < 0)   # opening: no contact again
    assert r.method == "closed-form"


def test_end_time_before_separation_is_refused():
    m = model(scene(0.2))
    t_s = float(kelvin.metrics(**kelvin.parameters(m))["separation_time"])
    with pytest.raises(lsc.SimulationError, match="comes before the crash is over"):
        kelvin.solve(m, t_end=0.5 * t_s)


def test_restitution_given_as_target():
    r = kelvin.solve(model(scene(restitution=0.4)))
    assert r.restitution[0] == pytest.approx(0.4, rel=1e-13)


@pytest.mark.parametrize("sc, applies", [
    (scene(0.3), True),
    (scene(0.3, gap=0.1, failure=1e4), True),
    (scene(restitution=0.5), True),
    (dict(scene(0.3), contacts=[{"law": "hunt-crossley", "stiffness": K, "restitution": 0.5}]),
     False),
    (dict(scene(0.3), vehicles=[{"mass": M1, "speed": 3.0},
                                {"mass": M2, "speed": 0.0, "brake": {"mu": 0.7}}]), False),
    ({"vehicles": [{"mass": M1, "speed": 3.0}, {"mass": M2, "speed": 0.0},
                   {"mass": M2, "speed": 0.0}],
      "contacts": [{"law": "kelvin", "stiffness": K, "damping": 1e3}] * 2}, False),
    ({"vehicles": [{"mass": M1, "speed": 3.0}, {"mass": M2, "speed": 0.0}],
      "contacts": [{"loading": {"stiffness": K}, "unloading": {"restitution": 0.5}}]}, False),
])
def test_applies_to_two_car_kelvin_scenes_only(sc, applies):
    m = model(sc)
    assert kelvin.applies(m) is applies
    if not applies:
        with pytest.raises(lsc.SceneError, match="Kelvin closed form does not apply"):
            kelvin.solve(m)


# ------------------------------------------------------------------ batches
@pytest.mark.parametrize("law, values", [
    ({"damping": 3000.0}, {"vehicles.0.speed": [1.0, 3.0, 8.0],
                           "vehicles.1.mass": [500.0, 1000.0, 4000.0],
                           "contacts.0.gap": [0.0, 0.02, 0.1]}),
    ({"restitution": 0.3}, {"vehicles.0.mass": [700.0, 1400.0, 9000.0]}),
    ({"damping": 3000.0}, {"contacts.0.damping": [0.0, 2e4, 1e5],
                           "contacts.0.stiffness": [1e5, 2e5, 3e5]}),
    ({"restitution": 0.3}, {"contacts.0.restitution": [0.05, 0.5, 1.0]}),
])
def test_batch_equals_single_solves(law, values):
    # a damping c is the scene's for every member, whatever its masses (ζ follows μ)
    sc = scene(gap=0.01, failure=2e4, **law)
    values = {p: np.asarray(v, float) for p, v in values.items()}
    done = []
    out = kelvin.solve_batch(model(sc), values, progress=done.append)
    assert done == [3] and list(out["status"]) == ["ok"] * 3
    assert set(out["metrics"]) == set(lsc.result.METRICS)
    base = lsc.Scene.load(sc)
    for j in range(3):
        one = lsc.solve(base.with_values({p: float(v[j]) for p, v in values.items()}),
                        method="scipy", rtol=1e-12)
        assert_metrics_close({name: out["metrics"][name][j] for name in out["metrics"]}, one)
