"""The peaks inside the segments of an exact chain (lsc/solvers/exact_chain/_peaks.py: every
segment searched after the loop in one stacked pass): each segment's largest contact forces and
accelerations of largest magnitude against a dense brute force on the model's own forces,
evaluated on the segment's closed-form motion, on random chains (tables with a plateau, gaps,
restitutions 0.05 to 1), on a falling table piece (hyperbolic modes) and on the pile-up of
scripts/bench_chain.py (a force whose derivative starts within rounding of zero, after a max
deformation: searched from where its Taylor bound clears it).
"""

from __future__ import annotations

import numpy as np
from hypothesis import Phase, example, given, settings

import lsc
from lsc.model import HybridModel

from helpers import HARD
from test_exact_chain import chains

#: Random chains in the default run.
CASES = 60 if HARD else 5
NO_SHRINK = (Phase.explicit, Phase.reuse, Phase.generate)
#: Dense samples per segment of the brute force.
DENSE = 4_001

PILE_UP = {
    "units": "US",
    "vehicles": [{"weight": 3500, "speed": "15 mph"}, {"weight": 2800, "speed": 0},
                 {"weight": 4200, "speed": 0}],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}},
                 {"loading": {"stiffness": 50000}, "unloading": {"restitution": 0.3},
                  "gap": 0.1}]}

#: A front contact whose table falls after 0.05 ft (a hyperbolic mode while on that piece).
FALLING = {
    "units": "US",
    "vehicles": [{"mass": 300.0, "speed": 25.0}, {"mass": 150.0, "speed": 0.0},
                 {"mass": 400.0, "speed": 0.0}],
    "contacts": [{"loading": {"table": [[0, 0], [0.05, 2000.0], [0.1, 1200.0],
                                        [1000.0, 1200.0 + 1e7]]},
                  "unloading": {"restitution": 0.3}, "gap": 0.02},
                 {"loading": {"stiffness": 1e5}, "unloading": {"restitution": 0.6}}]}


def _segments(scene):
    """The chain's segments and the peaks the stacked pass finds in each."""
    from lsc.solvers.exact_chain._solve import _Chain, _transitions
    from lsc.solvers.segments import run_segments

    model = HybridModel(lsc.Scene.load(scene))
    chain = _Chain(model)
    segments, *_ = run_segments(_transitions(model), chain.advance)   # (the solve's own limit)
    return model, segments, chain.spans()


def _dense(model, segment):
    """The model's contact forces (K, n) and accelerations (N, n) on DENSE points of the
    segment's motion (its ends included)."""
    tt = np.linspace(segment.t0, segment.t1, DENSE)
    Y = segment.dense(tt)
    p = dict(model.params, gap=np.asarray(model.params["gap"], float)[:, None])
    F, _, acc = model.accelerations(Y, segment.disc, p)
    return np.broadcast_to(F, (model.K, DENSE)), acc


def _grid_error(values):
    """How far the largest value of each row (rows, n) of equally spaced samples may lie above
    its samples: ``max|f''| h²/8``, ``max|f''| h²`` from the second differences (twice, as a
    margin)."""
    return np.abs(np.diff(values, 2, axis=1)).max(axis=1) / 4.0


def _check(scene):
    model, segments, spans = _segments(scene)
    assert len(spans) == len(segments) > 0
    F_all, a_all = zip(*(_dense(model, s) for s in segments))
    f_scale = max(float(np.max(np.abs(F))) for F in F_all) or 1.0
    a_scale = max(float(np.max(np.abs(a))) for a in a_all) or 1.0
    for seg, (t0, t1, force, acc), F, a in zip(segments, spans, F_all, a_all):
        assert (t0, t1) == (seg.t0, seg.t1)
        # no peak missed: at least every dense sample (to the rounding of the deformations,
        # differences of positions) ...
        assert np.all(force >= F.max(axis=1) - 1e-9 * f_scale), (force, F.max(axis=1))
        assert np.all(np.abs(acc) >= np.abs(a).max(axis=1) - 1e-9 * a_scale)
        # ... and a value the motion takes: above the dense samples by their grid's error only
        over = _grid_error(F) + 1e-9 * f_scale
        assert np.all(force <= F.max(axis=1) + over), (force, F.max(axis=1), over)
        j = np.argmax(np.abs(a), axis=1)
        dense_acc = a[np.arange(a.shape[0]), j]
        over = _grid_error(a) + 1e-9 * a_scale
        assert np.all(np.abs(acc - dense_acc) <= over), (acc, dense_acc, over)


@settings(max_examples=CASES, deadline=None, phases=NO_SHRINK)
@given(chains(tables=True, pushed_shut=False))
@example(PILE_UP)
@example(FALLING)
def test_segment_peaks_match_a_dense_brute_force(scene):
    """Each segment's largest contact force and its vehicles' accelerations of largest magnitude
    (signed) equal those of a dense sampling of the model's forces on its motion: at least every
    sample to rounding (none missed), at most above them by the sampling's own error."""
    _check(scene)


def _closing_rates_only(monkeypatch):
    """Only the forces of the contacts whose closing rate is an armed event left unsearched
    (the rule before the unloading line's top was: those are searched too)."""
    from lsc.solvers.exact_chain._solve import _Chain

    def unsearched(self, motion, funcs, disc, force, slopes, lock):
        return {k for k, which in (self.parts.events[i] for i, _, _ in funcs)
                if which == 2 and k < self.K}

    monkeypatch.setattr(_Chain, "_unsearched", unsearched)


def test_the_pile_up_has_a_force_searched_from_its_taylor_bound(monkeypatch):
    """The pile-up of the benchmark has a segment that starts at a contact's max deformation,
    where the derivative of its force is zero to rounding: searched (with the top of the
    unloading line's rule off), its search starts where the Taylor bound clears it (later
    than 0), and the peaks are still the brute force's."""
    from lsc.solvers.exact_chain import _peaks

    _closing_rates_only(monkeypatch)
    starts = []

    def spy(d, T, rounding):
        starts.append(_roots_taylor_clear(d, T, rounding))
        return starts[-1]

    _roots_taylor_clear = _peaks._taylor_clear
    monkeypatch.setattr(_peaks, "_taylor_clear", spy)
    _check(PILE_UP)
    assert any(t > 0 for t in starts), starts


def test_a_force_from_the_top_of_its_unloading_line_is_not_searched(monkeypatch):
    """A contact that starts a segment at the top of its unloading line (just past its max
    deformation, that end armed) keeps its largest force at the start: the pile-up's two
    unloading segments that start so leave that contact's force unsearched, and every peak is
    the one the full search finds, to rounding (and the brute force's)."""
    from lsc.solvers.exact_chain._solve import _Chain, _transitions
    from lsc.solvers.segments import run_segments

    model = HybridModel(lsc.Scene.load(PILE_UP))
    chain = _Chain(model)
    run_segments(_transitions(model), chain.advance)
    # (the contacts of the segments after contact 0's and contact 1's max deformations)
    unsearched = [rec[4] for rec in chain.records]
    assert unsearched == [{0}, {0, 1}, {0, 1}, {1}, set()], unsearched
    kept = _segments(PILE_UP)[2]
    _closing_rates_only(monkeypatch)
    full = _segments(PILE_UP)[2]
    assert len(kept) == len(full) == 5
    for (t0, t1, f, a), (u0, u1, g, b) in zip(kept, full):
        assert (t0, t1) == (u0, u1)
        np.testing.assert_allclose(f, g, rtol=1e-15, atol=0)
        np.testing.assert_allclose(a, b, rtol=1e-15, atol=0)
    _check(PILE_UP)


#: A chain whose contact 2 starts a segment at the top of its unloading line while contact 3
#: holds its plateau's force: vehicle 3's acceleration, ``(F2 - F3)/m``, not searched on its
#: own (one contact with a slope), is largest in magnitude where F2 is least, inside the
#: segment (found by the hypothesis run of the rule's first version, which left F2 unsearched
#: there and gave that acceleration 3e-5 low).
PLATEAU_BESIDE = {
    "units": "US",
    "vehicles": [{"mass": 174.52809290499843, "speed": -8.999999999999998},
                 {"mass": 474.08811456927776, "speed": -8.999999999999998},
                 {"mass": 100.0, "speed": -8.999999999999998},
                 {"mass": 328.3474758272579, "speed": -9.999999999999998},
                 {"mass": 554.2528602871322, "speed": -9.999999999999998}],
    "contacts": [{"loading": {"stiffness": 2238.567620865544},
                  "unloading": {"restitution": 0.7924930023638938}, "gap": 0.03104719863891026},
                 {"loading": {"stiffness": 4774.996725488434},
                  "unloading": {"restitution": 0.6897452541174777}, "gap": 1.0},
                 {"loading": {"stiffness": 19761.565147917874},
                  "unloading": {"restitution": 0.05}, "gap": 0.0},
                 {"loading": {"table": [[0.0, 0.0], [0.017328240363770935, 2272.5038106723687],
                                        [0.03465648072754187, 2272.5038106723687],
                                        [1000.0, 1311402048.8128521]]},
                  "unloading": {"restitution": 0.7}, "gap": 0.18923829890832303}]}


def test_a_force_that_an_acceleration_follows_is_searched():
    """A force at the top of its unloading line is searched where a vehicle's acceleration
    follows it beside another contact's constant force (its least value sets that
    acceleration's largest magnitude): the peaks are the brute force's."""
    _check(PLATEAU_BESIDE)


def test_segments_searched_in_windows_give_the_same_peaks(monkeypatch):
    """A long segment (a ringing contact's) is searched in windows of PASS samples, and the
    segments are grouped by their sizes: with windows of 3 samples, every segment of a chain
    with re-closings is cut into many, and the peaks are those of one pass to rounding (and
    still the brute force's)."""
    from lsc.solvers.exact_chain import _peaks

    scene = {"units": "US",
             "vehicles": [{"mass": 120.0, "speed": 20.0}, {"mass": 60.0, "speed": 0.0},
                          {"mass": 300.0, "speed": 0.0}, {"mass": 90.0, "speed": -3.0}],
             "contacts": [{"loading": {"stiffness": 2e4}, "unloading": {"restitution": 0.8},
                           "gap": 0.05},
                          {"loading": {"stiffness": 3e5}, "unloading": {"restitution": 0.5}},
                          {"loading": {"stiffness": 5e3}, "unloading": {"restitution": 0.9},
                           "gap": 0.2}]}
    whole = _segments(scene)[2]
    monkeypatch.setattr(_peaks, "PASS", 3)
    cut = _segments(scene)[2]
    assert len(whole) == len(cut) > 5
    for (t0, t1, f, a), (u0, u1, g, b) in zip(whole, cut):
        assert (t0, t1) == (u0, u1)
        assert np.allclose(f, g, rtol=1e-13, atol=1e-13 * np.max(np.abs(f)))
        assert np.allclose(a, b, rtol=1e-13, atol=1e-13 * np.max(np.abs(a)))
    _check(scene)


#: A six-car chain with tables the --hard run drew: 333 events (a stiff elastic front pair
#: ringing), more than the 200 this file's solve once allowed itself.
LONG = {'units': 'US',
 'vehicles': [{'mass': 659.3529614004025, 'speed': 4.121620044854488},
  {'mass': 418.810342969471, 'speed': 3.1216200448544886},
  {'mass': 315.0918580843251, 'speed': 2.1216200448544886},
  {'mass': 253.00506882388083, 'speed': 2.1216200448544886},
  {'mass': 81.89082232094619, 'speed': 0.8862818865188614},
  {'mass': 710.9155336400454, 'speed': 0.0}],
 'contacts': [{'loading': {'stiffness': 10000.0}, 'unloading': {'restitution': 0.3333333333333333}, 'gap': 0.0},
  {'loading': {'table': [[0.0, 0.0], [0.001, 606.167299938356], [0.002, 606.167299938356], [1000.0, 6061661482.204863]]}, 'unloading': {'restitution': 0.05}, 'gap': 0.08963138567930846},
  {'loading': {'table': [[0.0, 0.0], [0.00495794467922913, 314.83678041695794], [0.00991588935845826, 314.83678041695794], [1000.0, 635008728.4022748]]}, 'unloading': {'restitution': 0.2767042877544422}, 'gap': 0.3630312605103197},
  {'loading': {'table': [[0.0, 0.0], [0.1042831938424909, 29592.449392141767], [0.2085663876849818, 29592.449392141767], [1000.0, 2837138460.303626]]}, 'unloading': {'restitution': 0.7}, 'gap': 0.0},
  {'loading': {'stiffness': 4728709.054145544}, 'unloading': {'restitution': 1.0}, 'gap': 0.0}]}


def test_a_chain_of_many_events_is_checked_in_full():
    """Every one of a long chain's segments is checked (the solve's own event limit, not a
    smaller one of the test's: this chain needs 333)."""
    model, segments, _ = _segments(LONG)
    assert len(segments) > 300
    _check(LONG)
