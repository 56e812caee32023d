"""Every batch path of ``lsc.sweep`` gives, member by member, the metrics of a single
``lsc.solve`` of that member: the vectorised closed form, the vectorised exact stepper, the
vmapped diffrax solve and the loop, on scenes that use every effect (bumper failure, also at a
preloaded table's force step, gaps, tables, series, unloading rules, braking, post-failure
curves, damping laws, chains). Metrics are compared generically, for every name in
:data:`lsc.result.METRICS`; members that fail carry the single solve's own message."""

import numpy as np
import pytest

import lsc
from lsc.result import METRICS

SPEEDS = {"vehicles.0.speed": [3.0, 9.0, 17.0]}


def _scene(vehicles, contacts):
    return {"units": "US", "g": "32.2 ft/s^2", "vehicles": vehicles, "contacts": contacts}


def _two(contact, brake=None):
    target = {"weight": 2500, "speed": 0}
    if brake:
        target["brake"] = brake
    return _scene([{"weight": 3000, "speed": 10}, target], [contact])


# The scene: a preloaded table (6000 lbf at first touch) over a 5000 lbf failure force,
# 0.5 ft apart: the bumper fails the instant the contact closes (a force step, not a crossing).
PRELOADED = _two({"loading": {"table": [[0, 6000], [0.5, 20000]]},
                  "unloading": {"restitution": 0.4}, "gap": 0.5, "failure": {"force": 5000}})


def _assert_members_equal(s, base, params, method, rtol, **options):
    """Each member of sweep ``s`` (or of any answer with ``status`` and ``metrics``, such as a
    backend's ``solve_batch``) against ``lsc.solve`` of that member alone, to ``rtol`` of
    the metric's largest magnitude over the sweep (a restitution of 0 is 0 to rounding).
    Returns the number of members solved."""
    n = len(next(iter(params.values())))
    singles = {}
    for j in range(n):
        member = lsc.Scene.load(base).with_values({p: float(v[j]) for p, v in params.items()})
        try:
            singles[j] = lsc.solve(member, method=method, **options)
        except lsc.SimulationError as e:
            assert s.status[j] == f"SimulationError: {e}"
            assert all(np.isnan(s.metrics[name][j]).all() for name in METRICS)
    for name in METRICS:
        want = {j: np.asarray(getattr(r, name), float) for j, r in singles.items()}
        scale = max((np.nanmax(np.abs(w), initial=0.0) for w in want.values()), default=0.0)
        for j, w in want.items():
            assert s.status[j] == "ok", s.status[j]
            np.testing.assert_allclose(np.asarray(s.metrics[name][j], float), w, rtol=rtol,
                                       atol=rtol * scale, equal_nan=True,
                                       err_msg=f"member {j}, {name}")
    return len(singles)


def test_preloaded_table_failure_time_in_the_exact_batch():
    s = lsc.sweep(PRELOADED, {"vehicles.0.speed": [10.0, 12.0]})
    assert s.method == "exact"
    # first touch (and failure) when the 0.5 ft gap has closed at the initial closing speed
    np.testing.assert_allclose(s.failure_time[:, 0], [0.05, 0.5 / 12.0], rtol=1e-15)
    r = lsc.solve(PRELOADED)
    assert r.failure_time[0] == pytest.approx(0.05, rel=1e-15)


def test_preloaded_table_failure_at_t0_in_the_exact_batch():
    touching = lsc.Scene.load(PRELOADED).with_values({"contacts.0.gap": 0.0})
    s = lsc.sweep(touching, {"vehicles.0.speed": [10.0, 12.0]})
    assert s.method == "exact" and list(s.failure_time[:, 0]) == [0.0, 0.0]


CLOSED_FORM = _two({"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4},
                    "gap": 0.2, "failure": {"force": 8000}})


def test_closed_form_batch_equals_single_solves():
    params = {**SPEEDS, "contacts.0.unloading.restitution": [0.0, 0.4, 1.0]}
    s = lsc.sweep(CLOSED_FORM, params)
    assert s.method == "closed-form"
    assert np.isfinite(s.failure_time[1:, 0]).all() and np.isnan(s.failure_time[0, 0])
    assert _assert_members_equal(s, CLOSED_FORM, params, None, 1e-14) == 3


EXACT_BATCH = {
    "preloaded table, gap, failure at the step": PRELOADED,
    "table, gap, unloading stiffness, failure at a crossing": _two(
        {"loading": {"table": [[0, 0], [0.1, 9000], [0.3, 12000], [0.5, 30000]]},
         "unloading": {"stiffness": 150000}, "gap": 0.1, "failure": {"force": 11000}}),
    "series, unloading table (fails for the slowest member)": _two(
        {"loading": {"series": [{"stiffness": 48000},
                                {"table": [[0, 0], [0.2, 8000], [0.6, 60000]]}]},
         "unloading": {"table": [[0.3, 1], [0.1, 0]]}}),
}


@pytest.mark.parametrize("name", list(EXACT_BATCH))
def test_exact_batch_equals_single_solves(name):
    base = EXACT_BATCH[name]
    s = lsc.sweep(base, SPEEDS)
    assert s.method == "exact"
    assert _assert_members_equal(s, base, SPEEDS, None, 1e-14) >= 2


LOOPED = {
    "braked target, gap (exact, one by one)": (_two(
        {"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}, "gap": 0.5},
        brake={"mu": 0.7}), None),
    "post-failure curve (exact, one by one)": (_two(
        {"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4},
         "failure": {"force": 5000, "post_failure": {"table": [[0, 2000], [1, 30000]]}}}), None),
    "kelvin (scipy)": (_two({"law": "kelvin", "stiffness": 24000, "restitution": 0.4}), None),
    "brach (scipy)": (_two({"law": "brach", "stiffness": 24000, "restitution": 0.4}), None),
    "chain, hunt-crossley, gap (scipy)": (_scene(
        [{"weight": 3000, "speed": 15}, {"weight": 2500, "speed": 0},
         {"weight": 2000, "speed": 0}],
        [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}},
         {"law": "hunt-crossley", "stiffness": 30000, "restitution": 0.5, "gap": 0.2}]), None),
    "reference": (_two({"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}),
                  "reference"),
}


@pytest.mark.parametrize("name", list(LOOPED))
def test_looped_sweep_equals_single_solves(name):
    base, method = LOOPED[name]
    s = lsc.sweep(base, SPEEDS, method=method)
    assert _assert_members_equal(s, base, SPEEDS, method, 0.0) == 3


def test_diffrax_batch_equals_single_solves():
    pytest.importorskip("diffrax")
    # a chain with every effect diffrax batches: a preloaded table with a failure at its step,
    # gaps, a braked middle car, a Hunt-Crossley contact
    base = _scene(
        [{"weight": 3000, "speed": 15}, {"weight": 2500, "speed": 0, "brake": {"mu": 0.7}},
         {"weight": 2000, "speed": 0}],
        [{"loading": {"table": [[0, 6000], [0.5, 20000]]}, "unloading": {"restitution": 0.4},
          "gap": 0.1, "failure": {"force": 5000}},
         {"law": "hunt-crossley", "stiffness": 30000, "restitution": 0.5, "gap": 0.2}])
    # (at 17 ft/s the table ends before the common velocity: a SimulationError of both paths,
    # checked too, but every member here is to be solved)
    speeds = {"vehicles.0.speed": [3.0, 9.0, 15.0]}
    s = lsc.sweep(base, speeds, method="diffrax")
    assert s.method == "diffrax"
    assert _assert_members_equal(s, base, speeds, "diffrax", 1e-9) == 3
    s = lsc.sweep(base, {"vehicles.0.speed": [17.0]}, method="diffrax")
    assert s.status[0].startswith("SimulationError: contact 0 at t = ") \
        and "the loading table ends before the vehicles reach a common velocity" in s.status[0]


def _random_table_scene(rng):
    """Two vehicles, a random loading table (preloaded or not, alone or in series with a line),
    restitution
    or an unloading stiffness, a gap or none, a failure force or none, a moving target."""
    n = int(rng.integers(2, 6))
    d = np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 0.3, n - 1))])
    f = np.concatenate([[rng.choice([0.0, rng.uniform(0, 8000)])], rng.uniform(1000, 30000, n - 1)])
    loading = {"table": np.column_stack([d, f]).tolist()}
    if rng.random() < 0.3:   # (a series needs a rising table)
        loading = {"table": np.column_stack([d, np.sort(f)]).tolist()}
        loading = {"series": [{"stiffness": float(rng.uniform(2e4, 2e5))}, loading]}
    contact = {"loading": loading, "gap": float(rng.choice([0.0, rng.uniform(0, 0.3)])),
               "unloading": ({"restitution": float(rng.uniform(0, 1))} if rng.random() < 0.5
                             else {"stiffness": 5e5})}
    if rng.random() < 0.7:
        contact["failure"] = {"force": float(rng.uniform(1000, 20000))}
    return _scene([{"weight": 3000, "speed": 10},
                   {"weight": float(rng.uniform(1000, 5000)), "speed": float(rng.uniform(-2, 2))}],
                  [contact])


def test_exact_batch_equals_single_solves_on_random_tables():
    rng = np.random.default_rng(5)
    checked = 0
    for _ in range(40):
        base = _random_table_scene(rng)
        params = {"vehicles.0.speed": rng.uniform(3, 20, 4)}
        s = lsc.sweep(base, params)
        assert s.method == "exact"
        checked += _assert_members_equal(s, base, params, None, 1e-12)
    assert checked > 80
