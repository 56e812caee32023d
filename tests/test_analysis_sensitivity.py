"""lsc.analysis.sensitivity: forward-mode autodiff through the diffrax solve, events included,
against the closed form (linear scenes) and against finite differences of the exact backends
(tables, damping laws, brakes, chains)."""

from dataclasses import dataclass

import numpy as np
import pytest

import lsc
from helpers import HARD, NONLINEAR, paper_scene, two_cars
from lsc.analysis import default_params, sensitivity
from lsc.contact import kelvin_restitution
from lsc.curves import Curve
from lsc.laws import Param, SpringDashpotLaw, register_law, unregister_law

pytest.importorskip("diffrax")

from lsc.solvers import diffrax_ode as dx  # noqa: E402

ALL = ("delta_v", "peak_acceleration", "duration", "peak_force", "max_deformation")

# measured-like (SI: m, N): a soft start, a plateau, a dip (a failing bar), then a stiff rise
TABLE = NONLINEAR["table"]


def table_scene(v1=6.0, e=0.3, m1=1500.0, m2=1100.0):
    return {"name": "table", "units": "SI",
            "vehicles": [{"name": "bullet", "mass": m1, "speed": v1},
                         {"name": "target", "mass": m2, "speed": 0.5}],
            "contacts": [{"loading": {"table": TABLE}, "unloading": {"restitution": e}}]}


def assert_matches(a, b, metrics=ALL, rel=1e-6):
    """Each derivative of ``a`` equals ``b``'s to ``rel`` relative; a derivative whose elasticity
    is below 1e-3 (a parameter that hardly matters) to 1e-9 in elasticity instead."""
    assert a.params == b.params
    for m in metrics:
        da, db = np.asarray(a.derivatives[m]), np.asarray(b.derivatives[m])
        ea, eb = np.asarray(a.elasticities[m]), np.asarray(b.elasticities[m])
        small = np.abs(eb) < 1e-3
        assert np.all(np.where(small, np.abs(ea - eb) <= 1e-9,
                               np.abs(da - db) <= rel * np.abs(db))), (m, da, db)
        assert np.asarray(a.metrics[m]) == pytest.approx(np.asarray(b.metrics[m]), rel=1e-8)


# ---------------------------------------------------------------------------- closed form
def test_linear_scene_against_the_closed_form():
    """Two vehicles, linear k, restitution e: ΔV2 = (1+e) m1 vc/(m1+m2), pulse π(1+e)/(2ω),
    F_max = vc √(kμ), D_max = vc/ω; every derivative by hand."""
    m1, m2, v1, v2, k, e = 1500.0, 1100.0, 5.0, 1.0, 2.4e5, 0.4
    s = sensitivity(two_cars(m1, m2, v1, v2, {"stiffness": k}, {"restitution": e}), metrics=ALL)
    assert s.params == ("vehicles.0.mass", "vehicles.0.speed", "vehicles.1.mass",
                        "vehicles.1.speed", "contacts.0.loading.stiffness",
                        "contacts.0.unloading.restitution")
    vc, M = v1 - v2, m1 + m2
    mu = m1 * m2 / M
    w = np.sqrt(k / mu)
    dmu = np.array([(m2 / M) ** 2, (m1 / M) ** 2])  # dμ/dm1, dμ/dm2
    # columns: m1, v1, m2, v2, k, e
    dv2 = [(1 + e) * vc * m2 / M**2, (1 + e) * m1 / M, -(1 + e) * vc * m1 / M**2,
           -(1 + e) * m1 / M, 0.0, m1 * vc / M]
    dv1 = [(1 + e) * vc * m2 / M**2, -(1 + e) * m2 / M, -(1 + e) * vc * m1 / M**2,
           (1 + e) * m2 / M, 0.0, -m2 * vc / M]
    T = np.pi * (1 + e) / (2 * w)                     # ∝ √μ (1+e) / √k
    dT = [T / (2 * mu) * dmu[0], 0.0, T / (2 * mu) * dmu[1], 0.0, -T / (2 * k), np.pi / (2 * w)]
    F = vc * np.sqrt(k * mu)
    dF = [F / (2 * mu) * dmu[0], np.sqrt(k * mu), F / (2 * mu) * dmu[1], -np.sqrt(k * mu),
          F / (2 * k), 0.0]
    D = vc / w                                        # vc √(μ/k)
    dD = [D / (2 * mu) * dmu[0], 1 / w, D / (2 * mu) * dmu[1], -1 / w, -D / (2 * k), 0.0]
    # peak accelerations -F/m1, F/m2
    da1 = -np.array(dF) / m1 + np.array([F / m1**2, 0, 0, 0, 0, 0])
    da2 = np.array(dF) / m2 - np.array([0, 0, F / m2**2, 0, 0, 0])
    assert s.metrics["delta_v"] == pytest.approx([-(1 + e) * m2 * vc / M, (1 + e) * m1 * vc / M],
                                                 rel=1e-12)
    assert s.metrics["duration"] == pytest.approx(T, rel=1e-10)

    def close(got, want, rel=1e-9):
        got, want = np.asarray(got), np.asarray(want, float)
        scale = np.max(np.abs(want))
        assert np.all(np.abs(got - want) <= rel * np.maximum(np.abs(want), 1e-3 * scale)), (got, want)

    close(s.derivatives["delta_v"][0], dv1)
    close(s.derivatives["delta_v"][1], dv2)
    close(s.derivatives["duration"], dT)
    close(s.derivatives["peak_force"][0], dF)
    close(s.derivatives["max_deformation"][0], dD)
    close(s.derivatives["peak_acceleration"][0], da1)
    close(s.derivatives["peak_acceleration"][1], da2)
    # elasticities: ΔV ∝ vc, pulse ∝ k^-1/2, F ∝ k^1/2, e/(1+e) for ΔV
    assert s.elasticity("delta_v", "vehicles.0.speed", 1) == pytest.approx(v1 / vc, rel=1e-9)
    assert s.elasticity("duration", "contacts.0.loading.stiffness") == pytest.approx(-0.5, rel=1e-9)
    assert s.elasticity("peak_force", "contacts.0.loading.stiffness", 0) == pytest.approx(0.5, rel=1e-9)
    assert s.elasticity("delta_v", "contacts.0.unloading.restitution", 1) == \
        pytest.approx(e / (1 + e), rel=1e-9)


def test_weight_is_per_unit_of_weight_and_a_second_call_does_not_retrace():
    """The paper's scene gives weights: the default parameter is the weight, its derivative that
    of the mass over g; the same structure with other numbers reuses the compiled code."""
    base = sensitivity(paper_scene(), metrics=("delta_v",))
    traces = dx.TRACES["core"]
    assert default_params(paper_scene())[0] == "vehicles.0.weight"
    s = sensitivity(paper_scene(**{"vehicles.0.speed": 7}),
                    ["vehicles.0.weight", "vehicles.0.mass", "vehicles.1.speed"],
                    metrics=("delta_v", "peak_acceleration", "peak_acceleration_g"))
    assert dx.TRACES["core"] == traces
    assert s.derivative("delta_v", "vehicles.0.weight") == \
        pytest.approx(s.derivative("delta_v", "vehicles.0.mass") / 32.2, rel=1e-12)
    # ΔV2 = 1.4 v1 W1/(W1+W2): dΔV2/dW1 = 1.4 v1 W2/(W1+W2)^2
    assert s.derivative("delta_v", "vehicles.0.weight") == pytest.approx(1.4 * 7 * 3500 / 7000**2,
                                                                         rel=1e-10)
    assert s.units["peak_acceleration_g"] == "g"
    assert s.derivatives["peak_acceleration_g"] == pytest.approx(
        s.derivatives["peak_acceleration"] / 32.2, rel=1e-12)
    assert base.values[0] == 3500.0 and base.param_units[0] == "lbf"


def test_finite_differences_of_the_closed_form_agree():
    """The no-JAX method on the same linear scene: fourth-order differences of the closed form."""
    scene = two_cars(1500.0, 1100.0, 5.0, 1.0, {"stiffness": 2.4e5}, {"restitution": 0.4})
    a = sensitivity(scene, metrics=ALL)
    b = sensitivity(scene, metrics=ALL, method="finite-difference")
    assert "closed-form" in b.method and b.stats["solves"] == 1 + 4 * len(b.params)
    assert_matches(a, b, rel=1e-7)


# ---------------------------------------------------------------------------- tables
def test_table_scene_against_finite_differences_of_the_exact_backend():
    """A non-monotone measured-like table, a moving target: breakpoint events, the common velocity
    and the separation all move with the parameters."""
    scene = table_scene()
    a = sensitivity(scene, metrics=ALL)
    r = lsc.solve(scene, method="exact")
    assert sum(ev.kind == "breakpoint" for ev in r.events) >= 3
    assert a.params[4] == "contacts.0.loading.scale"
    b = sensitivity(scene, metrics=ALL, method="finite-difference", backend="exact")
    assert_matches(a, b)


def test_peak_force_on_a_plateau_before_a_dip():
    """When the crush ends in the dip, the peak force is the plateau's 40 kN, reached at a
    breakpoint event: it does not depend on the speed or the masses, and scales with the curve."""
    c = Curve.table(TABLE)
    m1, m2 = 1500.0, 1100.0
    mu = m1 * m2 / (m1 + m2)
    vc = np.sqrt(2 * float(c.energy(0.255)) / mu)     # D_max = 0.255 m, in the dip
    s = sensitivity(table_scene(v1=0.5 + vc), metrics=("peak_force", "max_deformation"))
    assert s.metrics["max_deformation"][0] == pytest.approx(0.255, rel=1e-9)
    assert s.metrics["peak_force"][0] == pytest.approx(40000.0, rel=1e-12)
    d = s.derivatives["peak_force"][0]
    assert d[[0, 1, 2, 3, 5]] == pytest.approx(np.zeros(5), abs=1e-6)
    assert s.derivative("peak_force", "contacts.0.loading.scale", 0) == pytest.approx(40000.0,
                                                                                      rel=1e-10)
    # D_max: the work-energy balance ½ μ vc² = E(D_max) gives dD/dvc = μ vc / F(D_max)
    F = float(c.force(0.255))
    assert s.derivative("max_deformation", "vehicles.0.speed", 0) == pytest.approx(mu * vc / F,
                                                                                   rel=1e-9)


# ---------------------------------------------------------------------------- other laws
def kelvin(**law):
    return {"units": "US", "g": "32.2 ft/s^2",
            "vehicles": [{"name": "bullet", "weight": 3500, "speed": 10},
                         {"name": "target", "weight": 3000, "speed": 0}],
            "contacts": [dict({"law": "kelvin", "stiffness": 24000}, **law)]}


@pytest.mark.parametrize("law", [{"restitution": 0.4}, {"damping": 300}])
def test_kelvin_against_finite_differences(law):
    """Peaks inside a segment (envelope theorem) and the force-zero separation; ζ from the
    restitution by the law's relation, or from c = 2ζ√(kμ) held while k and the masses move."""
    scene = kelvin(**law)
    a = sensitivity(scene, metrics=ALL)
    b = sensitivity(scene, metrics=ALL, method="finite-difference", backend="scipy", rtol=1e-13)
    assert_matches(a, b)


@pytest.mark.skipif(not HARD, reason="hard-case mode (--hard): one more compile each")
@pytest.mark.parametrize("case", ["hunt-crossley", "braked", "chain"])
def test_more_effects_against_finite_differences(case):
    if case == "hunt-crossley":
        scene = {"units": "US", "vehicles": [{"weight": 3500, "speed": 10}, {"weight": 3000, "speed": 0}],
                 "contacts": [{"law": "hunt-crossley", "stiffness": 60000, "exponent": 1.5,
                               "restitution": 0.5}]}
        params = None
    elif case == "braked":
        scene = {"units": "SI", "vehicles": [{"mass": 1500, "speed": 3.0},
                                             {"mass": 1200, "speed": 0.0,
                                              "brake": {"mu": 0.7, "mu_static": 0.8}}],
                 "contacts": [{"loading": {"stiffness": 2e5}, "unloading": {"restitution": 0.4}}]}
        params = default_params(scene) + ["vehicles.1.brake.mu_static"]
        assert "vehicles.1.speed" not in params                # braked at rest: stick-slip
    else:
        scene = {"units": "SI", "vehicles": [{"mass": m, "speed": v} for m, v in
                                             ((1500, 3.0), (1200, 0.0), (1000, 0.0))],
                 "contacts": [{"loading": {"stiffness": 1e5}, "unloading": {"restitution": 0.5}},
                              {"loading": {"table": [[0, 0], [0.05, 3000], [0.5, 60000]]},
                               "unloading": {"restitution": 0.3}, "gap": 0.05}]}
        params = default_params(scene) + ["contacts.1.gap"]
    metrics = ("delta_v", "peak_acceleration", "duration", "peak_force")
    a = sensitivity(scene, params, metrics=metrics)
    b = sensitivity(scene, params, metrics=metrics, method="finite-difference", backend="scipy",
                    rtol=1e-13)
    assert_matches(a, b, metrics)


# ---------------------------------------------------------------------------- result, errors
def test_result_views_and_text():
    s = sensitivity(paper_scene(), metrics=("delta_v", "duration"))
    ranked = s.ranked("delta_v", "target")
    assert {p for p, _, _ in ranked[:2]} == {"vehicles.0.speed", "vehicles.1.speed"}
    assert abs(ranked[-1][2]) < 1e-12                     # the stiffness does not change ΔV
    assert s.reference[s.params.index("vehicles.1.speed")] == 10.0   # zero speed: the closing one
    text = s.summary()
    assert "delta_v, target = 7 ft/s" in text and "ft/s/lbf" in text and "elasticity" in text
    d = s.to_dict()
    assert d["params"] == list(s.params) and np.shape(d["derivatives"]["delta_v"]) == (2, 6)
    assert d["derivatives"]["duration"][s.params.index("contacts.0.unloading.restitution")] == \
        pytest.approx(np.pi / 2 / np.sqrt(24000 / (3500 / 32.2 / 2)), rel=1e-9)


@pytest.mark.parametrize("kwargs, match", [
    ({"params": ["vehicles.0.colour"]}, "not a differentiable parameter"),
    ({"params": ["vehicles.3.speed"]}, "2 vehicles"),
    ({"params": ["contacts.0.unloading.stiffness"]}, "does not unload by a stiffness"),
    ({"params": ["vehicles.0.speed", "vehicles[0].speed"]}, "twice"),
    ({"params": ["vehicles.0.brake.mu"]}, "no brake"),
    ({"metrics": ("delta_vee",)}, "unknown metric"),
    ({"method": "adjoint"}, "unknown sensitivity method"),
])
def test_bad_arguments(kwargs, match):
    with pytest.raises(lsc.SceneError, match=match):
        sensitivity(paper_scene(), **kwargs)


def test_stiffness_of_a_table_and_brach_restitution_are_refused():
    with pytest.raises(lsc.SceneError, match="loading.scale"):
        sensitivity(table_scene(), ["contacts.0.loading.stiffness"])
    brach = {"units": "SI", "vehicles": [{"mass": 1500, "speed": 3}, {"mass": 1200, "speed": 0}],
             "contacts": [{"law": "brach", "stiffness": 2e5, "damping": 1e4, "restitution": 0.4}]}
    with pytest.raises(lsc.SceneError, match="finite-difference"):
        sensitivity(brach)
    s = sensitivity(brach, ["vehicles.0.speed", "contacts.0.restitution"], method="finite-difference",
                    metrics=("delta_v",))
    # ΔV2 = (1+e) m1 vc/(m1+m2) whatever the law, as long as it reaches its restitution
    assert s.derivative("delta_v", "contacts.0.restitution") == pytest.approx(1500 * 3 / 2700,
                                                                              rel=1e-6)


def test_no_rebound_gives_the_one_sided_restitution_derivative():
    """e = 0 separates at the common velocity; ΔV2 = (1+e) v0/2 and the pulse π(1+e)/(2ω) are
    linear in e, so the derivative from above is exact: v0/2 and π/(2ω)."""
    scene = paper_scene(**{"contacts.0.unloading.restitution": 0.0})
    a = sensitivity(scene, metrics=("delta_v", "duration"))
    assert a.stats["one_sided"] == ["contacts.0.unloading.restitution"]
    w = np.sqrt(24000 / (3500 / 32.2 / 2))
    assert a.derivative("delta_v", "contacts.0.unloading.restitution") == pytest.approx(5.0, rel=1e-8)
    assert a.derivative("duration", "contacts.0.unloading.restitution") == \
        pytest.approx(np.pi / (2 * w), rel=1e-8)
    assert a.metrics["duration"] == pytest.approx(np.pi / (2 * w), rel=1e-10)
    assert "one-sided" in a.summary()
    b = sensitivity(scene, metrics=("delta_v", "duration"), method="finite-difference")
    assert b.stats["solves"] == 1 + 4 * 5 + 4                # a forward stencil for e
    assert_matches(a, b, ("delta_v", "duration"))


def test_non_differentiable_points_are_refused():
    braked = {"units": "SI", "vehicles": [{"mass": 1500, "speed": 3.0},
                                          {"mass": 1200, "speed": 0.0, "brake": {"mu": 0.7}}],
              "contacts": [{"loading": {"stiffness": 2e5}, "unloading": {"restitution": 0.4}}]}
    with pytest.raises(lsc.SceneError, match="stands braked") as info:
        sensitivity(braked, ["vehicles.1.speed"], method="finite-difference")
    assert info.value.path == "vehicles.1.speed"
    with pytest.raises(lsc.SceneError, match="gap > 0"):
        sensitivity(paper_scene(), ["contacts.0.gap"], method="finite-difference")


@pytest.mark.parametrize("e", [0.2, 0.6, 0.95, 1.0])
def test_restitution_to_coefficient_derivatives(e):
    """The tangent of Kelvin's ζ(e) and Hunt–Crossley's a(e) (the laws' own relations, by the
    implicit function theorem) against differences of the converters (one-sided at e = 1)."""
    from lsc.analysis.sensitivity import _describe, _tangent
    from lsc.contact import hunt_crossley_a, kelvin_zeta
    from lsc.model import HybridModel
    h = 1e-6
    for law, conv, key in (("kelvin", kelvin_zeta, "zeta"), ("hunt-crossley", hunt_crossley_a, "a")):
        sc = lsc.Scene.load({"units": "SI", "vehicles": [{"mass": 1000, "speed": 3},
                                                         {"mass": 1000, "speed": 0}],
                             "contacts": [{"law": law, "stiffness": 1e5, "restitution": e}]})
        t = _tangent(HybridModel(sc), sc, _describe(sc, "contacts.0.restitution"))
        if e == 1:  # second-order one-sided
            want = (3 * conv(e) - 4 * conv(e - 10 * h) + conv(e - 20 * h)) / (20 * h)
        else:
            want = (conv(e + h) - conv(e - h)) / (2 * h)
        assert float(t["contacts"][0][key]) == pytest.approx(want, rel=1e-6)


@pytest.mark.parametrize("step", [0, -1e-3, 1.5, float("nan"), True, "1e-3"])
def test_bad_finite_difference_step_is_refused(step):
    # (step 0 divided by zero: derivatives of inf and nan, without a word)
    with pytest.raises(lsc.SceneError) as e:
        sensitivity(paper_scene(), method="finite-difference", step=step)
    assert str(e.value) == ("step: step must be a number in (0, 1) (relative to each "
                            f"parameter's value), got {step!r}")


def test_unknown_keyword_is_a_type_error_naming_it():
    with pytest.raises(TypeError, match="unexpected keyword argument 'rtoll'"):
        sensitivity(paper_scene(), rtoll=1e-13)


def test_sensitivity_reaches_the_diffrax_backend_only_by_its_public_names():
    """The analysis modules read nothing of the diffrax backend but the names its public
    surface (``lsc.solvers.diffrax_ode.api.__all__``) gives."""
    import ast
    from pathlib import Path

    from lsc.solvers.diffrax_ode import api

    folder = Path(lsc.__file__).parent / "analysis"
    used = {}
    for path in folder.glob("*sensitivity*.py"):
        tree = ast.parse(path.read_text())
        aliases = {a.asname or a.name for node in ast.walk(tree)
                   if isinstance(node, ast.ImportFrom) and (node.module or "").endswith("solvers")
                   for a in node.names if a.name == "diffrax_ode"}
        used[path.name] = {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)
                           and isinstance(node.value, ast.Name) and node.value.id in aliases}
    assert any(used.values())   # the autodiff path does use the backend
    for name, attrs in used.items():
        assert attrs <= set(api.__all__), (name, attrs - set(api.__all__))


# ---------------------------------------------------------------------------- tangents
# A frozen copy of the tangents as lsc.analysis built them by hand, path by path and law by law,
# before the parameter layer gave them (issue 12, item 5): the parameter layer's must equal them.
def _old_dlne_dzeta(z):
    import math
    if abs(z - 1.0) < 1e-6:
        h = 1e-4
        return float((np.log(kelvin_restitution(z + h))
                      - np.log(kelvin_restitution(z - h))) / (2 * h))
    if z < 1:
        s2 = 1.0 - z * z
        return -2.0 * (math.acos(z) / s2 ** 1.5 - z / s2)
    s2 = z * z - 1.0
    return -2.0 * (z / s2 - math.acosh(z) / s2 ** 1.5)


def _old_zeros(tree):
    if isinstance(tree, dict):
        return {k: _old_zeros(v) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_old_zeros(v) for v in tree]
    return np.zeros(np.shape(tree))


def _old_mu(model):
    m = np.asarray(model.params["m"], float)
    return m[:-1] * m[1:] / (m[:-1] + m[1:])


def _old_kelvin_mass(model, T, i, dm):
    m = np.asarray(model.params["m"], float)
    mu = _old_mu(model)
    for k, law in enumerate(model.laws):
        if getattr(law, "name", "") != "kelvin" or law.spec.restitution is not None:
            continue
        if i not in (k, k + 1):
            continue
        other = m[k + 1] if i == k else m[k]
        dmu = (other / (m[k] + m[k + 1])) ** 2 * dm
        z = float(model.params["contacts"][k]["zeta"])
        T["contacts"][k]["zeta"] = np.asarray(float(T["contacts"][k]["zeta"]) - 0.5 * z / mu[k] * dmu)


def _old_tangent(model, sc, prm):
    import math
    p = model.params
    T = _old_zeros(p)
    parts = prm.path.split(".")
    i, rest = int(parts[1]), tuple(parts[2:])
    if parts[0] == "vehicles":
        if rest in (("mass",), ("weight",)):
            dm = 1.0 if rest[0] == "mass" else 1.0 / sc.g
            T["m"][i] = dm
            _old_kelvin_mass(model, T, i, dm)
        elif rest == ("speed",):
            T["v0"][i] = 1.0
        else:
            j = [b.i for b in model.brakes].index(i)
            src = sc.source["vehicles"][i].get("brake", {}) if sc.source else {}
            if rest[1] == "mu":
                T["brakes"][j]["mu"] = np.asarray(1.0)
                if "mu_static" not in src:
                    T["brakes"][j]["mus"] = np.asarray(1.0)
            else:
                T["brakes"][j]["mus"] = np.asarray(1.0)
        return T
    cp, ct = p["contacts"][i], T["contacts"][i]
    law = sc.contacts[i].law
    if rest == ("gap",):
        T["gap"][i] = 1.0
    elif rest in (("loading", "stiffness"), ("loading", "scale")):
        for key in ("lf", "ls", "le"):
            ct[key] = np.asarray(cp[key], float) / prm.value
    elif rest == ("unloading", "restitution"):
        ct["e"] = np.asarray(1.0)
    elif rest == ("unloading", "stiffness"):
        ct["su"] = np.asarray(1.0)
    elif rest == ("stiffness",):
        ct["k"] = np.asarray(1.0)
        if law.law == "kelvin" and law.restitution is None:
            ct["zeta"] = np.asarray(-0.5 * float(cp["zeta"]) / law.stiffness)
    elif rest == ("restitution",):
        e = law.restitution
        if law.law == "kelvin":
            ct["zeta"] = np.asarray(1.0 / (e * _old_dlne_dzeta(float(cp["zeta"]))))
        else:
            a = float(cp["a"])
            R_a = (1 + e) - 1 / (1 + a) - e / (1 - a * e)
            R_e = a - a / (1 - a * e)
            ct["a"] = np.asarray(-R_e / R_a if a > 1e-6 else -1.5)
    elif rest == ("damping",):
        if law.law == "kelvin":
            ct["zeta"] = np.asarray(float(cp["zeta"]) / law.damping if law.damping > 0 else
                                    1.0 / (2.0 * math.sqrt(law.stiffness * _old_mu(model)[i])))
        elif law.law == "hunt-crossley":
            ct["alpha"] = np.asarray(1.0)
        else:
            ct["c1"] = np.asarray(1.0)
    elif rest == ("damping_restitution",):
        ct["c2"] = np.asarray(1.0)
    elif rest == ("exponent",):
        ct["n"] = np.asarray(1.0)
    return T


def _leaves(tree, at=""):
    if isinstance(tree, dict):
        return [x for k, v in sorted(tree.items()) for x in _leaves(v, f"{at}.{k}")]
    if isinstance(tree, list):
        return [x for k, v in enumerate(tree) for x in _leaves(v, f"{at}.{k}")]
    return [(at, np.asarray(tree, float))]


def _damped(law, **keys):
    return {"units": "US", "g": "32.2 ft/s^2",
            "vehicles": [{"weight": 3500, "speed": 10}, {"weight": 3000, "speed": 0}],
            "contacts": [{"law": law, "stiffness": 24000, **keys}]}


TANGENT_SCENES = {
    "linear": (two_cars(1500.0, 1100.0, 5.0, 1.0, {"stiffness": 2.4e5}, {"restitution": 0.4},
                        gap=0.02), ["contacts.0.gap"]),
    "table": (two_cars(1500.0, 1100.0, 6.0, 0.5, {"table": TABLE, "scale": 1.3},
                       {"stiffness": 9e5}), []),
    "kelvin e": (_damped("kelvin", restitution=0.4), []),
    "kelvin e=1": (_damped("kelvin", restitution=1.0), []),
    "kelvin c": (_damped("kelvin", damping=300), []),
    "kelvin c=0": (_damped("kelvin", damping=0), []),
    "hunt-crossley e": (_damped("hunt-crossley", restitution=0.5, exponent=1.5),
                        ["contacts.0.exponent"]),
    "hunt-crossley e=1": (_damped("hunt-crossley", restitution=1.0), []),
    "hunt-crossley alpha": (_damped("hunt-crossley", damping=0.02), ["contacts.0.exponent"]),
    "brach c2": (_damped("brach", damping=20, damping_restitution=40), []),
    "braked": ({"units": "SI", "vehicles": [{"mass": 1500, "speed": 3.0,
                                             "brake": {"mu": 0.6}},
                                            {"mass": 1200, "speed": 0.0,
                                             "brake": {"mu": 0.7, "mu_static": 0.8}}],
                "contacts": [{"loading": {"stiffness": 2e5}, "unloading": {"restitution": 0.4}}]},
               ["vehicles.1.brake.mu_static", "vehicles.0.brake.mu_static"]),
    "chain": ({"units": "SI", "vehicles": [{"mass": 1500, "speed": 3.0}, {"weight": 12000, "speed": 0.0},
                                           {"mass": 1000, "speed": 0.0}],
               "contacts": [{"law": "kelvin", "stiffness": 1e5, "damping": 2000},
                            {"law": "kelvin", "stiffness": 2e5, "damping": 1000, "gap": 0.05}]},
              ["contacts.1.gap"]),
}


@pytest.mark.parametrize("case", TANGENT_SCENES)
def test_tangents_of_the_parameter_layer_equal_the_hand_written_ones(case):
    """∂ model.params / ∂ path from the parameter layer (jax.jvp of the laws' and effects'
    declared numbers, the target-restitution conversions by their declared derivatives) equals
    the frozen hand-written tangent on every law and path it handled."""
    from lsc.analysis.sensitivity import _describe, _tangent
    from lsc.model import HybridModel
    scene, extra = TANGENT_SCENES[case]
    sc = lsc.Scene.load(scene)
    model = HybridModel(sc)
    for path in default_params(scene) + extra:
        prm = _describe(sc, path)
        new, old = _leaves(_tangent(model, sc, prm)), _leaves(_old_tangent(model, sc, prm))
        assert [k for k, _ in new] == [k for k, _ in old], path
        assert any(np.any(v != 0) for _, v in new), path
        for (key, a), (_, b) in zip(new, old):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=0, err_msg=f"{path}: {key}")


def test_a_post_failure_loading_curve_has_no_tangent():
    scene = two_cars(1500.0, 1100.0, 6.0, 0.5, {"table": TABLE}, {"restitution": 0.3},
                     failure={"force": 20000, "post_failure": {"stiffness": 1e5}})
    with pytest.raises(lsc.SceneError, match="finite-difference") as info:
        sensitivity(scene, ["contacts.0.loading.scale"])
    assert str(info.value).startswith("contacts.0.loading.scale: ")


@dataclass(frozen=True)
class _ZetaSpec(lsc.laws.Damping):
    """The toy law's record: a spring–dashpot description with its own key."""

    ratio: float = 0.0


class _ZetaLaw(SpringDashpotLaw):
    """A toy Kelvin law given by its damping ratio: ``F = k D + c Ḋ``, ``c = 2ζ√(kμ)`` (its
    numbers depend on the masses, through a construction declared here only)."""

    name = "toy-zeta"
    params_declared = (
        Param("stiffness", "stiffness", "k", minimum=0.0),
        Param("ratio", "dimensionless", "the damping ratio ζ", minimum=0.0))
    depends_on_mass = True
    affine_force = True

    @classmethod
    def describe(cls, values):
        return _ZetaSpec(cls.name, **values)

    @staticmethod
    def build(values, mu, xp):
        k = xp.asarray(values["stiffness"], float)
        return {"k": k, "cz": 2.0 * xp.asarray(values["ratio"], float) * xp.sqrt(k * mu)}

    def at_contact(self, st, Ddot, p, xp, mu):
        return {"c": xp.asarray(p["cz"], float)}

    def spring_force(self, D, Ddot, st):
        return st["k"] * D + st["c"] * Ddot


@pytest.fixture
def zeta_law():
    register_law(_ZetaLaw)
    yield _ZetaLaw
    unregister_law("toy-zeta")


def test_a_registered_toy_law_gets_sensitivities_without_touching_the_analyses(zeta_law):
    """A law the analyses never heard of: its tangents come from its declared numbers alone,
    and the autodiff derivatives match finite differences of the SciPy solve; ΔV and the pulse
    follow Kelvin's closed form (ζ fixed: ΔV2 = (1+e) m1 vc/(m1+m2) with e(ζ))."""
    m1, m2, v1, zeta = 1500.0, 1200.0, 4.0, 0.3
    scene = {"units": "SI", "vehicles": [{"mass": m1, "speed": v1}, {"mass": m2, "speed": 0.0}],
             "contacts": [{"law": "toy-zeta", "stiffness": 2e5, "ratio": zeta}]}
    params = default_params(scene)
    assert params == ["vehicles.0.mass", "vehicles.0.speed", "vehicles.1.mass", "vehicles.1.speed",
                      "contacts.0.stiffness", "contacts.0.ratio"]
    metrics = ("delta_v", "peak_acceleration", "duration", "peak_force", "max_deformation")
    a = sensitivity(scene, params, metrics=metrics)
    b = sensitivity(scene, params, metrics=metrics, method="finite-difference", backend="scipy",
                    rtol=1e-13)
    assert_matches(a, b, metrics)
    e = float(kelvin_restitution(zeta))
    de = e * _old_dlne_dzeta(zeta)                    # de/dζ = e · d ln e/dζ
    assert a.derivative("delta_v", "contacts.0.ratio", 1) == pytest.approx(
        m1 * v1 / (m1 + m2) * de, rel=1e-7)
    assert a.derivative("delta_v", "vehicles.0.speed", 1) == pytest.approx(
        (1 + e) * m1 / (m1 + m2), rel=1e-8)
