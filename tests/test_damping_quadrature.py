"""Hunt–Crossley and Brach impacts: the integrators (SciPy; diffrax in two cases) against the
laws' exact energy relations and quadratures (tests/hard/damping_quadrature.py)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.integrate import quad

import lsc
from lsc.contact import brach_restitution, hunt_crossley_a
from hard import damping_quadrature as dq
from helpers import HARD

M1, M2 = 1400.0, 1000.0
MU = M1 * M2 / (M1 + M2)
#: (reference name, Result name) of the metrics compared
COMPARED = ("max_deformation", "restitution", "peak_force", "duration", "energy_absorbed",
            "energy_returned")


def scene(law, v1=3.0, v2=0.0, m1=M1, m2=M2, **keys):
    return {"units": "SI", "vehicles": [{"mass": m1, "speed": v1}, {"mass": m2, "speed": v2}],
            "contacts": [{"law": law, **keys}]}


def check(ref: dq.Impact, r: lsc.Result, rel=1e-8):
    """Every compared metric of ``r`` within ``rel`` of the reference's."""
    for name in COMPARED:
        assert float(getattr(r, name)[0] if name != "duration" else r.duration) == \
            pytest.approx(ref[name], rel=rel, abs=0), name
    np.testing.assert_allclose(r.delta_v, ref["delta_v"], rtol=rel, atol=0)
    # the peak acceleration is the peak force over each mass
    np.testing.assert_allclose(np.abs(r.peak_acceleration) * [M1, M2],
                               [ref["peak_force"]] * 2, rtol=rel, atol=0)


# ------------------------------------------------------------------ the reference itself
@pytest.mark.parametrize("alpha", [0.0, 1e-9, 1e-4, 0.3, 2.0, -0.9])
@pytest.mark.parametrize("v", [-0.4, 1e-3, 0.4])
def test_energy_is_the_first_integral(alpha, v):
    # G_α(v) = ∫_0^v μ u du/(1 + α u), in closed form, against the quadrature
    if 1 + alpha * v <= 0:
        pytest.skip("outside the law's range")
    exact = quad(lambda u: MU * u / (1 + alpha * u), 0.0, v, epsabs=0, epsrel=2e-14)[0]
    assert dq.energy(MU, alpha, v) == pytest.approx(exact, rel=1e-13)


@pytest.mark.parametrize("a", [1e-6, 0.05, 0.5, 1.0, 3.0])
@pytest.mark.parametrize("n", [1.0, 1.5, 2.0])
def test_hunt_crossley_rebound_solves_its_restitution_relation(a, n):
    # the rebound from the energy relation is the root of a (1+e) = ln[(1+a)/(1-ae)], any n,
    # which the loader's conversion solves for a target restitution
    v0 = 2.0
    ref = dq.hunt_crossley(M1, M2, v0, 1e6, n, a / v0)
    e = ref["restitution"]
    assert a * (1 + e) == pytest.approx(math.log((1 + a) / (1 - a * e)), rel=1e-12)
    assert hunt_crossley_a(e) == pytest.approx(a, rel=1e-9)


@pytest.mark.parametrize("c1, c2", [(0.0, 4e4), (2e4, 8e4), (5e4, 5e4), (3e4, 0.0)])
def test_brach_rebound_matches_its_energy_integral(c1, c2):
    k, v0 = 2.0e5, 3.0
    ref = dq.brach(M1, M2, v0, k, c1, c2)
    assert ref["restitution"] == pytest.approx(brach_restitution(k, c1, c2, v0, MU), rel=1e-12)


def test_undamped_limit_is_the_hertz_and_linear_spring():
    # α = 0: e = 1; D_max from ½ μ v0² = k D^{n+1}/(n+1); linear (n = 1): duration π/ω
    v0, k = 2.0, 1e6
    for n in (1.0, 1.5):
        ref = dq.hunt_crossley(M1, M2, v0, k, n, 0.0)
        assert ref["restitution"] == pytest.approx(1.0, rel=1e-15)
        assert ref["max_deformation"] == pytest.approx(
            ((n + 1) * 0.5 * MU * v0**2 / k) ** (1 / (n + 1)), rel=1e-15)
    assert dq.hunt_crossley(M1, M2, v0, k, 1.0, 0.0)["duration"] == pytest.approx(
        math.pi * math.sqrt(MU / k), rel=1e-12)
    # Hertz (n = 3/2): the contact time is (D_max / v0) times the classical constant
    # 2 ∫_0^1 dx/√(1 - x^{5/2}) ≈ 2.94 (energy: v² = v0² (1 - (D/D_max)^{5/2}))
    hertz = dq.hunt_crossley(M1, M2, v0, k, 1.5, 0.0)
    # (the endpoint singularity (1 - x)^{-1/2} as quad's weight)
    def smooth(x):   # √((1 - x)/(1 - x^{5/2})): 1 at 0, √(2/5) at 1
        return math.sqrt((1 - x) / -math.expm1(2.5 * math.log(x))) if 0 < x < 1 \
            else (1.0 if x <= 0 else 0.4 ** 0.5)

    const = 2 * quad(smooth, 0, 1, weight="alg", wvar=(0, -0.5), epsabs=0, epsrel=2e-14)[0]
    assert hertz["duration"] == pytest.approx(const * hertz["max_deformation"] / v0, rel=1e-12)


# ------------------------------------------------------------------ the integrators
HC_CASES = [(1.0, 0.02), (1.0, 0.3), (1.5, 0.05), (1.5, 0.5), (2.0, 0.2), (0.5, 0.1)]


@pytest.mark.parametrize("n, alpha", HC_CASES)
def test_hunt_crossley_scipy_against_the_energy_relations(n, alpha):
    v0, k = 3.0, 2e5 * 0.05 ** (1 - n)   # about the same crush for every n
    r = lsc.solve(scene("hunt-crossley", v0, stiffness=k, exponent=n, damping=alpha),
                  method="scipy", rtol=1e-12)
    check(dq.hunt_crossley(M1, M2, v0, k, n, alpha), r)


@pytest.mark.parametrize("c1, c2", [(0.0, 4e4), (2e4, 8e4), (5e4, 5e4), (3e4, 0.0),
                                    (4e5, 1e5)])
def test_brach_scipy_against_the_energy_relations(c1, c2):
    v0, k = 3.0, 2.0e5
    r = lsc.solve(scene("brach", v0, stiffness=k, damping=c1, damping_restitution=c2),
                  method="scipy", rtol=1e-12)
    check(dq.brach(M1, M2, v0, k, c1, c2), r)


def test_restitution_targets_against_the_energy_relations():
    # the law's coefficient converted from a target restitution at the closing speed at touch
    v0, k = 3.0, 2.0e5
    hc = lsc.solve(scene("hunt-crossley", v0 + 1.0, 1.0, stiffness=k, exponent=1.5,
                         restitution=0.4), method="scipy", rtol=1e-12)
    check(dq.hunt_crossley(M1, M2, v0, k, 1.5, hunt_crossley_a(0.4) / v0), hc)
    br = lsc.solve(scene("brach", v0, stiffness=k, damping=2e4, restitution=0.6),
                   method="scipy", rtol=1e-12)
    ref = dq.brach(M1, M2, v0, k, 2e4, _brach_c2(k, 2e4, 0.6, v0))
    assert ref["restitution"] == pytest.approx(0.6, rel=1e-12)
    check(ref, br)


def _brach_c2(k, c1, e, v0):
    """The restoring coefficient that gives ``e``: ``G_{c2/k}(-e v0) = G_{c1/k}(v0)``, by
    bisection on ``c2 e v0/k`` in (0, 1)."""
    g1 = dq.energy(MU, c1 / k, v0)
    lo, hi = 0.0, 1.0 - 1e-15
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if dq.energy(MU, mid / (e * v0), -e * v0) < g1 else (lo, mid)
    return 0.5 * (lo + hi) * k / (e * v0)


@given(law=st.sampled_from(["hunt-crossley", "brach"]), v0=st.floats(0.5, 10.0),
       m1=st.floats(300, 5000), m2=st.floats(300, 5000), n=st.sampled_from([1.0, 1.5, 2.0]),
       damping=st.one_of(st.just(0.0), st.floats(1e-4, 1.0)),
       restoring=st.one_of(st.just(0.0), st.floats(1e-4, 1.0)))
@settings(max_examples=20)
def test_scipy_against_the_energy_relations_random(law, v0, m1, m2, n, damping, restoring):
    # damping, restoring: a = α v0 (Hunt–Crossley) or c v0/k (Brach) in [0, 1]
    k = 2e5 * 0.05 ** (1 - n) if law == "hunt-crossley" else 2e5
    if law == "hunt-crossley":
        keys = dict(exponent=n, damping=damping / v0)
        ref = dq.hunt_crossley(m1, m2, v0, k, n, damping / v0)
    else:
        keys = dict(damping=damping * k / v0, damping_restitution=restoring * k / v0)
        ref = dq.brach(m1, m2, v0, k, damping * k / v0, restoring * k / v0)
    r = lsc.solve(scene(law, v0, 0.0, m1, m2, stiffness=k, **keys), method="scipy", rtol=1e-12)
    for name in COMPARED:
        value = r.duration if name == "duration" else getattr(r, name)[0]
        assert value == pytest.approx(ref[name], rel=1e-8, abs=0), name
    np.testing.assert_allclose(r.delta_v, ref["delta_v"], rtol=1e-8, atol=0)


# (Brach too with --hard: one more compile)
@pytest.mark.parametrize("case", ["hunt-crossley", "brach"] if HARD else ["hunt-crossley"])
def test_diffrax_against_the_energy_relations(case):
    pytest.importorskip("diffrax")
    v0, k = 3.0, 2.0e5
    if case == "hunt-crossley":
        sc = scene(case, v0, stiffness=k / 0.05 ** 0.5, exponent=1.5, damping=0.3)
        ref = dq.hunt_crossley(M1, M2, v0, k / 0.05 ** 0.5, 1.5, 0.3)
    else:
        sc = scene(case, v0, stiffness=k, damping=2e4, damping_restitution=8e4)
        ref = dq.brach(M1, M2, v0, k, 2e4, 8e4)
    check(ref, lsc.solve(sc, method="diffrax", rtol=1e-12))


@pytest.mark.parametrize("law, keys, e", [
    ("brach", dict(stiffness=2e5, damping=2e4), 0.05),
    ("hunt-crossley", dict(stiffness=1e6, exponent=1.5), 1e-3)])
def test_a_rebound_ended_by_rounding_is_said(law, keys, e):
    """At a small restitution the damping factor of the force (``k + c Ḋ``, ``1 + α Ḋ``), which
    by the energy relation only tends to zero, falls below the solver's rounding long before
    the deformation returns to zero: the impact's end is where rounding puts it (its duration
    moves by percent between rtol 1e-10 and 1e-12; the reference refuses such rebounds, see
    _rebound), and the deformation left at separation is most of the max. That is said, once,
    by every solve; the ΔV, (1 + e) times the plastic one, is converged. (They were given
    without a word.)"""
    loose, tight = (lsc.solve(scene(law, 3.0, restitution=e, **keys), rtol=rtol)
                    for rtol in (1e-10, 1e-12))
    assert abs(tight.duration / loose.duration - 1) > 1e-3
    np.testing.assert_allclose(loose.delta_v, tight.delta_v, rtol=1e-9)
    for r in (loose, tight):
        dsep = float(r.permanent_deformation[0])
        assert dsep > 0.5 * float(r.max_deformation[0])
        assert r.warnings == (
            f"contact 0 ({law}): its rebound ended where the force's damping factor "
            f"({'k + c dD/dt' if law == 'brach' else '1 + α dD/dt'}) reached zero to the "
            f"solver's rounding, at a deformation of {dsep:.4g} "
            f"({dsep / float(r.max_deformation[0]):.3g} of its max), where the law's force ends "
            "at zero deformation: at this restitution the force falls below the solver's "
            "resolution long before that, so the impact's duration, separation time and the "
            "deformation left at separation are where rounding put them (they change with "
            "rtol); the ΔV is not affected",)


@pytest.mark.parametrize("law, keys", [("brach", dict(stiffness=2e5, damping=2e4)),
                                       ("hunt-crossley", dict(stiffness=1e6, exponent=1.5))])
def test_a_rebound_that_ends_at_zero_deformation_has_no_warning(law, keys):
    """At e = 0.2 the rebound ends at D = 0 (the reference's duration): no warning."""
    r = lsc.solve(scene(law, 3.0, restitution=0.2, **keys))
    assert r.warnings == ()
    assert abs(float(r.permanent_deformation[0])) <= 1e-12 * float(r.max_deformation[0])
