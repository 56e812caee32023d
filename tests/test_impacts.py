"""Impacts: each touch → separation episode of a contact, and the headline metrics they define.

The headline ΔV, peak acceleration, peak force, restitution and duration are those of the first
impact (each vehicle's and each contact's), measured from the speeds at touch, never from t = 0;
totals over the whole run are named as such; MER starts from the speeds at first contact; an
impact the absolute times cannot resolve, or a NaN/inf where a number is expected, is refused.
"""

import json

import numpy as np
import pytest

import lsc
from lsc.result import Result

G_US = 32.2


def two_cars(v1, v2, *, w1=3500.0, w2=3000.0, k=24000.0, e=0.4, gap=0.0, brake1=None,
             brake2=None):
    veh = [{"weight": w1, "speed": v1}, {"weight": w2, "speed": v2}]
    for v, b in zip(veh, (brake1, brake2)):
        if b is not None:
            v["brake"] = b
    return {"units": "US", "g": f"{G_US} ft/s^2", "vehicles": veh,
            "contacts": [{"loading": {"stiffness": k}, "unloading": {"restitution": e},
                          "gap": gap}]}


def braked_bullet_impact(v_touch, m1, m2, k, e, mu1, g):
    """Hand closed form of one IF-D impact (linear loading k, unloading k/e² to the energy set)
    with the bullet braked (Coulomb μ1) throughout: (ΔV1, ΔV2, duration) from the speed at touch
    (target at rest, unbraked). Relative motion D'' = -F/μ - μ1 g."""
    mu = m1 * m2 / (m1 + m2)
    w = np.sqrt(k / mu)
    d = mu1 * g / w**2
    t_m = np.arctan2(v_touch / w, d) / w
    d_max = -d + np.hypot(v_touch / w, d)
    ku = k / e**2
    wu = np.sqrt(ku / mu)
    du = mu1 * g / wu**2
    amp = d_max - d_max * (1 - e**2) + du
    tau = np.arccos(du / amp) / wu
    impulse = k * (-d * t_m + v_touch / w**2 * (1 - np.cos(w * t_m)) + d / w * np.sin(w * t_m)) \
        + ku * (-du * tau + amp * np.sin(wu * tau) / wu)
    T = t_m + tau
    return -impulse / m1 - mu1 * g * T, impulse / m2, T


# ------------------------------------------------------------------ braking before the touch
@pytest.mark.parametrize("method, tol", [("exact", 1e-11), ("scipy", 1e-8)])
def test_braked_bullet_delta_v_is_over_the_impact_from_the_speed_at_touch(method, tol):
    v0, mu1, gap, k, e = 12.0, 0.7, 2.0, 24000.0, 0.4
    scene = two_cars(v0, 0.0, k=k, e=e, gap=gap, brake1={"mu": mu1})
    opts = {"rtol": 1e-12} if method == "scipy" else {}
    r = lsc.solve(scene, method=method, **opts)
    m1, m2 = 3500.0 / G_US, 3000.0 / G_US
    v_touch = np.sqrt(v0**2 - 2 * mu1 * G_US * gap)  # the bullet slides over the gap
    dv1, dv2, T = braked_bullet_impact(v_touch, m1, m2, k, e, mu1, G_US)
    (imp,) = r.impacts
    assert imp.t_start == pytest.approx((v0 - v_touch) / (mu1 * G_US), rel=tol)
    assert imp.closing_speed == pytest.approx(v_touch, rel=tol)
    assert r.delta_v == pytest.approx([dv1, dv2], rel=tol)
    assert imp.delta_v == pytest.approx((dv1, dv2), rel=tol)
    assert r.duration == pytest.approx(T, rel=tol)
    # a constant friction force leaves the velocity restitution of a linear line at e
    assert r.restitution[0] == pytest.approx(e, rel=tol)
    # the whole run, from t = 0, is a separately named total
    assert r.delta_v_total == pytest.approx(r.v_final - [v0, 0.0], rel=1e-12)
    assert r.delta_v_total[0] < r.delta_v[0] - 1.0


def test_struck_car_braking_to_a_stop_before_the_impact():
    # the target brakes from 10 ft/s to rest, then the bullet (5 ft/s) closes the gap: its ΔV
    # and restitution are those of the same impact solved from the touch, not v_final - 10
    brake = {"mu": 0.7, "mu_static": 0.8}
    r = lsc.solve(two_cars(5.0, 10.0, gap=1.0, brake2=brake), method="exact")
    first = r.impacts[0]
    assert first.v_start == pytest.approx((5.0, 0.0), abs=1e-12)
    fresh = lsc.solve(two_cars(5.0, 0.0, brake2=brake), method="exact")
    ref = fresh.impacts[0]
    assert first.delta_v == pytest.approx(ref.delta_v, rel=1e-12)
    assert first.duration == pytest.approx(ref.duration, rel=1e-9)
    assert r.delta_v == pytest.approx(fresh.delta_v, rel=1e-12)
    assert r.peak_acceleration == pytest.approx(fresh.peak_acceleration, rel=1e-9)
    assert r.restitution == pytest.approx(fresh.restitution, rel=1e-9)
    assert np.all(np.isfinite(r.restitution))
    assert r.delta_v_total[1] == pytest.approx(-10.0, abs=1e-12)  # it ends at rest
    # the bullet catches the stopped target again: a second impact of the same contact
    assert len(r.impacts) == 2 and r.impacts[1].contact == 0
    assert r.impacts[1].t_start > first.t_end


# ------------------------------------------------------------------ chains
RATTLE = {"units": "SI", "vehicles": [{"mass": 2000, "speed": 2.0}, {"mass": 300, "speed": 0.0},
                                      {"mass": 2000, "speed": 0.0}],
          "contacts": [{"loading": {"stiffness": 1e6}, "unloading": {"restitution": 0.5}},
                       {"loading": {"stiffness": 1e6}, "unloading": {"restitution": 0.5},
                        "gap": 0.5}]}


def test_chain_contact_closing_twice_gives_two_impacts_each_conserving_momentum():
    r = lsc.solve(RATTLE, method="scipy", rtol=1e-12)
    m = np.array([2000.0, 300.0, 2000.0])
    per_contact = [sum(imp.contact == k for imp in r.impacts) for k in (0, 1)]
    assert per_contact[0] >= 2 and per_contact[1] >= 2
    spans = [(imp.t_start, imp.t_end) for imp in r.impacts]
    assert all(a[1] < b[0] for a, b in zip(spans, spans[1:])), "the impacts do not overlap"
    for imp in r.impacts:
        pair = m[list(imp.vehicles)]
        assert abs(pair @ np.array(imp.delta_v)) <= 1e-10 * (pair @ np.abs(imp.v_start))
        assert imp.separated and imp.duration > 0
    # each contact's first impact meets a virgin bumper: the closed form at the closing speed
    e = 0.5
    for k in (0, 1):
        imp = next(i for i in r.impacts if i.contact == k)
        mr, mf = m[k], m[k + 1]
        vc = imp.closing_speed
        closed = (-(1 + e) * mf * vc / (mr + mf), (1 + e) * mr * vc / (mr + mf))
        assert imp.delta_v == pytest.approx(closed, rel=1e-9)
        assert imp.restitution == pytest.approx(e, rel=1e-9)
        assert r.restitution[k] == pytest.approx(e, rel=1e-9)  # not NaN: it closed, later
    # headline: each vehicle's first impact; the lead car's is contact 1's first
    first1 = next(i for i in r.impacts if i.contact == 1)
    assert r.delta_v[2] == pytest.approx(first1.delta_v[1], rel=1e-12)
    assert r.duration == pytest.approx(r.impacts[0].duration, rel=1e-12)
    assert r.duration_total == pytest.approx(spans[-1][1], rel=1e-12)
    assert m @ r.delta_v_total == pytest.approx(0.0, abs=1e-9 * 4000.0)


def test_contact_pushed_shut_has_no_velocity_restitution():
    # no gap, the middle car at rest: contact 1 is pushed shut, not struck (closing speed 0)
    chain = {"units": "SI", "vehicles": [{"mass": 1200, "speed": 2.0}, {"mass": 1200, "speed": 0},
                                         {"mass": 1200, "speed": 0}],
             "contacts": [{"loading": {"stiffness": 1e5}, "unloading": {"restitution": 1.0}}] * 2}
    r = lsc.solve(chain, method="scipy", rtol=1e-11)
    pushed = next(i for i in r.impacts if i.contact == 1)
    assert not pushed.struck and np.isnan(pushed.restitution)
    assert np.isnan(r.restitution[1])  # documented: not applicable
    assert np.isfinite(r.restitution[0]) and r.impacts[0].struck
    assert r.restitution_energy[1] == pytest.approx(1.0, rel=1e-9)


# ------------------------------------------------------------------ the usual two-car scene
@pytest.mark.parametrize("method", ["closed-form", "exact", "scipy", "reference"])
def test_paper_scene_has_one_impact_equal_to_the_headline_metrics(method):
    scene = two_cars(10.0, 0.0, w1=3500.0, w2=3500.0)
    r = lsc.solve(scene, method=method)
    (imp,) = r.impacts
    m = 3500.0 / G_US
    dv = 1.4 * m * 10.0 / (2 * m)
    tol = 1e-9 if method != "reference" else 1e-3
    assert imp.t_start == 0.0 and imp.separated and imp.vehicles == (0, 1)
    assert imp.closing_speed == 10.0
    assert imp.delta_v == pytest.approx((-dv, dv), rel=tol)
    assert tuple(r.delta_v) == imp.delta_v and tuple(r.delta_v_total) == pytest.approx(imp.delta_v)
    assert r.duration == imp.duration == r.duration_total
    assert tuple(r.peak_acceleration) == imp.peak_acceleration
    assert r.peak_force[0] == imp.peak_force
    assert r.restitution[0] == imp.restitution == pytest.approx(0.4, rel=tol)
    assert imp.restitution_energy == r.restitution_energy[0]
    assert imp.max_deformation == pytest.approx(r.max_deformation[0], rel=1e-12)


# ------------------------------------------------------------------ times and non-finite values
@pytest.mark.parametrize("method", ["closed-form", "exact", "scipy"])
def test_a_large_gap_keeps_the_duration_exact(method):
    scene = two_cars(10.0, 0.0, w1=3500.0, w2=3500.0, gap=1.0e6)
    r = lsc.solve(scene, method=method)
    mu = 0.5 * 3500.0 / G_US
    T = np.pi / 2 * np.sqrt(mu / 24000.0) * 1.4
    assert r.impacts[0].t_start == pytest.approx(1.0e5, rel=1e-12)
    assert r.duration == pytest.approx(T, rel=1e-8)


@pytest.mark.parametrize("gap, method", [(1.0e12, "closed-form"), (1.0e12, "exact"),
                                         (1.0e12, "scipy"), (1.0e308, "closed-form")])
def test_an_impact_the_clock_cannot_resolve_is_refused(gap, method):
    scene = two_cars(10.0, 0.0, gap=gap)
    with pytest.raises((lsc.SimulationError, lsc.SceneError)) as info:
        lsc.solve(scene, method=method)
    if info.type is lsc.SimulationError:
        assert "too coarse to represent the impact" in str(info.value)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_an_infinite_result_is_refused():
    # speeds of 1e308 ft/s: the closed form overflows (it returned ±inf metrics before)
    with pytest.raises((lsc.SimulationError, lsc.SceneError)) as info:
        lsc.solve(two_cars(1.0e308, 0.0), method="closed-form")
    if info.type is lsc.SimulationError:
        assert "non-finite" in str(info.value)


def _rebuild(r, **change):
    """Result.build on ``r``'s raw material with some of it changed."""
    N = r.v.shape[1]
    raw = dict(t=r.t, x=r.x, v=r.v, a=r.a, deformation=r.deformation, force=r.force,
               events=r.events, v_final=r.v_final, method=r.method, tolerances=r.tolerances,
               stats=r.stats,
               contacts=[{"dmax": d, "fmax": f, "dperm": p, "ec": c, "er": q} for d, f, p, c, q in
                         zip(r.max_deformation, r.peak_force, r.permanent_deformation,
                             r.energy_absorbed, r.energy_returned)])
    raw.update(change)
    assert len(raw["v_final"]) == N
    return Result.build(r.scene, **raw)


def test_result_build_refuses_nan_in_a_series():
    r = lsc.solve(two_cars(10.0, 0.0), method="exact")
    v = r.v.copy()
    v[len(v) // 2, 0] = np.nan
    with pytest.raises(lsc.SimulationError, match=r"non-finite values in v\b"):
        _rebuild(r, v=v)
    with pytest.raises(lsc.SimulationError, match="non-finite values in .*v_final"):
        _rebuild(r, v_final=np.array([np.inf, 0.0]))


# ------------------------------------------------------------------ summary and warnings
def test_summary_shows_the_impacts_when_there_are_several_and_the_warnings():
    r = lsc.solve(RATTLE, method="scipy")
    text = r.summary()
    assert "t_start" in text and "dV rear" in text
    for j, imp in enumerate(r.impacts, 1):
        assert f"\n{j}: {imp.contact} (" in text
    assert "dV total" in text  # the headline ΔV is not the total here
    one = lsc.solve(two_cars(10.0, 0.0), method="exact")
    assert "t_start" not in one.summary() and "dV total" not in one.summary()
    assert one.warnings == ()
    warned = _rebuild(one, stats={**one.stats, "warnings": ["dt is coarse against the pulse"]})
    assert warned.warnings == ("dt is coarse against the pulse",)
    assert "warning: dt is coarse against the pulse" in warned.summary()
    assert warned.summary().count("dt is coarse") == 1  # not again among the statistics


def test_to_dict_lists_impacts_totals_and_warnings_as_json():
    r = lsc.solve(RATTLE, method="scipy")
    d = r.to_dict()
    assert len(d["impacts"]) == len(r.impacts)
    assert d["impacts"][0]["delta_v"] == list(r.impacts[0].delta_v) or \
        tuple(d["impacts"][0]["delta_v"]) == r.impacts[0].delta_v
    assert d["totals"]["duration_total"] == r.duration_total
    assert d["warnings"] == []
    json.dumps(d)


def test_an_impacts_largest_force_is_numpys_down_to_the_sign_of_zero():
    """The largest row force of an impact (on floats) is NumPy's ``max`` of the rows, the
    sign of a zero included (of equal zeros NumPy keeps the last)."""
    from lsc.impacts import _largest

    for values in ([0.0, -0.0], [-0.0, 0.0], [-0.0, -0.0, 0.0, -0.0], [1.0, -0.0], [-2.0, -1.0]):
        assert repr(_largest(values)) == repr(float(np.max(np.array(values)))), values
