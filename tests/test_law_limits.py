"""The spring–dashpot laws at the ends of their target restitution: below the smallest normal
float64 (``MIN_RESTITUTION``) their dampings overflow (Hunt–Crossley's ``a ≈ 1/e``, Kelvin's
``ζ`` past where ``ζ²`` does), so the loader and a sweep refuse such a restitution with a
SceneError on its field; at the limit every law converts it, or Brach's law (whose ``c2 ≈ k/(e
v0)`` overflows there) says that it cannot with a SimulationError, never another exception."""

import math

import numpy as np
import pytest

import lsc
from lsc.laws.relations import MIN_RESTITUTION, hunt_crossley_a, kelvin_zeta

LAWS = ["hunt-crossley", "kelvin", "brach"]


def _scene(law, e):
    return {"vehicles": [{"mass": 1000, "speed": 5}, {"mass": 1500, "speed": 0}],
            "contacts": [{"law": law, "stiffness": 1e6, "restitution": e}]}


def _refusal(e):
    return (f"contacts[0].restitution: a damping law's target restitution must be in "
            f"[2.2250738585072014e-308, 1] (e = 0 needs an infinite damping; below the smallest "
            f"normal float64 the laws' dampings overflow: Hunt-Crossley's a tends to 1/e, "
            f"Kelvin's ratio to 1/(2 sqrt(e))), got {e!r}")


def test_the_limit_is_the_smallest_normal_float():
    assert MIN_RESTITUTION == 2.2250738585072014e-308 == np.finfo(float).tiny


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("e", [1e-310, 5e-324, np.nextafter(MIN_RESTITUTION, 0)])
def test_subnormal_restitution_is_a_scene_error_on_its_field(law, e):
    with pytest.raises(lsc.SceneError) as info:
        lsc.Scene.load(_scene(law, float(e)))
    assert info.value.path == "contacts[0].restitution"
    assert str(info.value) == _refusal(float(e))


@pytest.mark.parametrize("law", ["hunt-crossley", "kelvin"])
def test_sweep_member_with_a_subnormal_restitution_fails_alone(law):
    r = lsc.sweep(_scene(law, 0.5), {"contacts[0].restitution": [0.5, 1e-310]})
    assert r.status[0] == "ok"
    assert r.status[1] == "SceneError: " + _refusal(1e-310)
    assert r.metrics["restitution"][0, 0] == pytest.approx(0.5, rel=1e-6)


@pytest.mark.parametrize("fn, law", [(hunt_crossley_a, "Hunt-Crossley"), (kelvin_zeta, "Kelvin")])
def test_relations_refuse_a_subnormal_restitution(fn, law):
    with pytest.raises(ValueError) as info:
        fn(1e-310)
    assert str(info.value) == (f"the {law} target restitution must be at least MIN_RESTITUTION "
                               "= 2.2250738585072014e-308 (its damping overflows below it), "
                               "got 1e-310")


def test_relations_at_the_limit_are_finite_and_solve_their_relations():
    e = MIN_RESTITUTION
    a = hunt_crossley_a(e)   # a (1 + e) = ln(1 + a) + L, a e = 1 - exp(-L): a -> 1/e
    assert math.isfinite(a) and a == pytest.approx(1 / e, rel=1e-12)
    z = kelvin_zeta(e)       # ln e = -2ζ arccosh ζ / √(ζ² - 1), ≈ -2 ln(2ζ) for large ζ
    assert math.isfinite(z)
    assert -2 * math.log(2 * z) == pytest.approx(math.log(e), rel=1e-12)


def test_brach_restitution_whose_c2_overflows_is_a_simulation_error():
    """``c2 = x k / (e v0)`` with ``x < 1`` is 1e6 / (5 · 2.2e-308): past the float range."""
    with pytest.raises(lsc.SimulationError) as info:
        lsc.solve(_scene("brach", MIN_RESTITUTION), method="scipy")
    assert str(info.value) == "contact 0 at t = 0 s: " + lsc.laws._common.STATUS[4]


@pytest.mark.parametrize("e", [0.999, 0.5, 0.1, 0.03, 0.01, 1e-3, 1e-6, 1e-100])
def test_hunt_crossley_slope_is_the_roots_derivative_at_low_restitution(e):
    """``da/de`` (the slope autodiff of a target restitution uses) against a central difference
    of the root; below e ≈ 0.03 ``1 - a e`` underflows to 0 and the slope is ``-a/e``."""
    from lsc.laws.damping import HuntCrossleyLaw

    h = 1e-6 * e
    fd = (hunt_crossley_a(e + h) - hunt_crossley_a(e - h)) / (2 * h)
    assert HuntCrossleyLaw.da_de(e, hunt_crossley_a(e)) == pytest.approx(fd, rel=1e-7)


@pytest.mark.parametrize("e", [0.9, 0.135, 1e-3, 1e-100, 1e-200])
def test_kelvin_slope_is_the_roots_derivative_at_low_restitution(e):
    """``dζ/de`` against a central difference of the root (ζ ≈ 1/(2√e) at a small ``e``)."""
    from lsc.laws.damping import KelvinLaw

    h = 1e-6 * e
    fd = (kelvin_zeta(e + h) - kelvin_zeta(e - h)) / (2 * h)
    assert KelvinLaw.dzeta_de(e, kelvin_zeta(e)) == pytest.approx(fd, rel=1e-7)


def test_kelvin_log_slope_at_a_huge_damping_ratio():
    """``d ln e/dζ = -2(ζ/(ζ²-1) - arccosh ζ/(ζ²-1)^1.5)`` → ``-2/ζ``: finite up to the ζ of
    MIN_RESTITUTION (``(ζ² - 1)^1.5`` itself overflows, and used to raise OverflowError)."""
    from lsc.laws.relations import kelvin_dlne_dzeta

    for z in (1e110, 1e150, kelvin_zeta(MIN_RESTITUTION)):
        assert kelvin_dlne_dzeta(z) == pytest.approx(-2 / z, rel=1e-12)


@pytest.mark.parametrize("law, e, what, asymptote", [
    ("hunt-crossley", 1e-160, "Hunt-Crossley's a", "-1/e^2"),
    ("hunt-crossley", 1e-300, "Hunt-Crossley's a", "-1/e^2"),
    ("kelvin", 1e-300, "Kelvin's damping ratio", "-1/(4 e^1.5)")])
def test_slope_past_the_float_range_is_a_simulation_error(law, e, what, asymptote):
    """``da/de ≈ -1/e²`` (Hunt–Crossley) and ``dζ/de ≈ -1/(4 e^1.5)`` (Kelvin) overflow below
    e ≈ 1.3e-154 and 1e-205: autodiff through them says so (it used to raise ZeroDivisionError
    or give inf)."""
    from lsc.laws.damping import HuntCrossleyLaw, KelvinLaw

    slope, root = ((HuntCrossleyLaw.da_de, hunt_crossley_a) if law == "hunt-crossley"
                   else (KelvinLaw.dzeta_de, kelvin_zeta))
    with pytest.raises(lsc.SimulationError) as info:
        slope(e, root(e))
    assert str(info.value) == (
        f"the derivative of {what} with respect to the target restitution (about {asymptote}) "
        f"is past the float64 range at e = {e!r}, so forward-mode autodiff through it has no "
        "derivative (nor do differences resolve one): give a larger restitution")


def test_autodiff_of_a_target_restitution_at_low_restitution():
    """Forward-mode autodiff of the conversion (what a sensitivity to a target restitution
    uses): the tangent ``-a/e`` at e = 0.01, and at e = 1e-200 the SimulationError itself, not
    JAX's runtime error around it (or, before, a ZeroDivisionError inside it)."""
    jax = pytest.importorskip("jax")
    from lsc.laws.damping import HuntCrossleyLaw, traced_root

    def a_of(v):
        return traced_root(hunt_crossley_a, HuntCrossleyLaw.da_de, v)

    with jax.enable_x64(True):
        a, da = jax.jvp(a_of, (0.01,), (1.0,))
        assert float(da) == pytest.approx(-float(a) / 0.01, rel=1e-12)
        with pytest.raises(lsc.SimulationError, match="past the float64 range at e = 1e-200"):
            jax.jvp(a_of, (1e-200,), (1.0,))
