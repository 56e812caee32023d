"""ISO/TS 18571 scores on signals whose scores follow by hand from the standard's definitions."""

import numpy as np
import pytest

from lsc.analysis.iso18571 import dtw_path, iso18571, resample

RATE = 10_000.0
T = np.arange(1000) / RATE


def half_sine(t, duration=0.08):
    return np.where(t < duration, np.sin(np.pi * t / duration), 0.0)


def test_identical_signals_score_one_on_every_part():
    ref = half_sine(T)
    r = iso18571(ref, ref.copy(), T)
    assert (r.corridor, r.phase, r.magnitude, r.slope, r.total, r.shift) == (1.0, 1.0, 1.0, 1.0, 1.0, 0.0)


@pytest.mark.parametrize("lag", [10, 30, -25])
def test_pure_time_shift_lowers_phase_by_its_formula_and_the_corridor_only(lag):
    ref = half_sine(T - 0.01)                       # a pulse that starts 10 ms in: room to shift
    cand = np.roll(ref, lag)                        # zeros roll round: an exact shift of the pulse
    r = iso18571(ref, cand, T)
    limit = 0.2 * T.size                            # ε_p N = 200 samples
    assert r.phase == pytest.approx((limit - abs(lag)) / limit, abs=1e-15)
    assert r.shift == pytest.approx(lag / RATE)
    assert r.magnitude == 1.0 and r.slope == 1.0    # the shifted signals coincide
    # the corridor is scored on the unshifted signals: by hand from its definition
    diff = np.abs(cand - ref)
    by_hand = np.mean(np.clip((0.5 - diff) / 0.45, 0, 1) ** 2)
    assert r.corridor == pytest.approx(by_hand, abs=1e-15) and r.corridor < 1
    assert r.total == pytest.approx(0.4 * r.corridor + 0.2 * r.phase + 0.2 + 0.2, abs=1e-15)


def test_shift_of_twenty_percent_scores_zero_phase():
    """The shift search stops at ε_p N samples; a signal that late scores E_P = 0."""
    ref = np.zeros(100)
    ref[30:40] = np.hanning(10)
    r = iso18571(ref, np.roll(ref, 20), dt=1e-4)    # 20 samples late: ε_p N = 0.2 * 100
    assert r.phase == 0.0 and r.shift == pytest.approx(20e-4)


@pytest.mark.parametrize("scale", [1.1, 0.8, 1.3])
def test_uniform_scale_of_a_rectangular_pulse(scale):
    """C = s T for a rectangular pulse T (200 of 1000 samples at 1): no warping can pair the
    pulse's samples better than one to one, so e_mag = |s - 1|; the derivatives scale too, so
    e_slope = |s - 1|; the correlation is 1 at no shift."""
    ref = np.zeros(1000)
    ref[300:500] = 1.0
    r = iso18571(ref, scale * ref, T)
    e = abs(scale - 1)
    assert r.phase == 1.0
    assert r.magnitude == pytest.approx(max(0.0, 1 - e / 0.5), abs=1e-12)
    assert r.slope == pytest.approx(1 - e / 2.0, abs=1e-12)
    inner = 1.0 if e <= 0.05 else min(1.0, max(0.0, (0.5 - e) / 0.45)) ** 2
    assert r.corridor == pytest.approx((800 + 200 * inner) / 1000, abs=1e-12)
    assert r.total == pytest.approx(0.4 * r.corridor + 0.2 * (1 + r.magnitude + r.slope), abs=1e-12)


def test_offset_inside_inner_corridor_keeps_corridor_one():
    ref = half_sine(T)
    r = iso18571(ref, ref + 0.04, T)                # |C - T| = 0.04 < a0 max|T| = 0.05
    assert r.corridor == 1.0


def test_dtw_warps_a_delayed_ramp_onto_the_reference():
    a = np.array([0.0, 1, 2, 3, 3, 3])
    b = np.array([0.0, 0, 1, 2, 3, 3])
    i, j = dtw_path(a, b, band=3)
    assert np.array_equal(a[i], b[j])               # a zero-cost path exists and is found


def test_resample_puts_signals_on_a_10_khz_grid():
    t = np.linspace(0, 0.01, 11)                    # 1 kHz
    grid, y = resample(t, 2 * t, 0.0, 0.01)
    assert grid.size == 101 and np.allclose(np.diff(grid), 1e-4) and np.allclose(y, 2 * grid)


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="the reference has 5 samples and the candidate 4"):
        iso18571(np.ones(5), np.ones(4), dt=1e-4)
    with pytest.raises(ValueError, match="zero everywhere"):
        iso18571(np.zeros(20), np.ones(20), dt=1e-4)
    with pytest.raises(ValueError, match="uniformly spaced"):
        iso18571(np.ones(20), np.ones(20), np.r_[np.arange(19), 30.0])


def plain_dtw_cost(a, b, band):
    """The least accumulated cost by the textbook O(n m) recursion (an independent solution)."""
    cost = np.full((a.size, b.size), np.inf)
    for i in range(a.size):
        for j in range(b.size):
            if abs(i - j) >= band:
                continue
            before = [cost[p] for p in ((i - 1, j), (i, j - 1), (i - 1, j - 1)) if min(p) >= 0]
            cost[i, j] = (a[i] - b[j]) ** 2 + (min(before) if before else 0.0)
    return cost[-1, -1]


@pytest.mark.parametrize("seed", range(5))
def test_banded_dtw_path_has_the_least_cost(seed):
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=40), rng.normal(size=40)
    i, j = dtw_path(a, b, band=7)
    assert np.all(np.abs(i - j) < 7) and np.all(np.diff(i) >= 0) and np.all(np.diff(j) >= 0)
    assert np.all(np.diff(i) + np.diff(j) >= 1) and (i[0], j[0], i[-1], j[-1]) == (0, 0, 39, 39)
    assert np.sum((a[i] - b[j]) ** 2) == pytest.approx(plain_dtw_cost(a, b, 7), rel=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_scores_lie_in_zero_one_and_total_is_their_weighted_sum(seed):
    rng = np.random.default_rng(seed)
    ref = half_sine(T) + 0.1 * rng.normal(size=T.size)
    cand = rng.uniform(0.3, 2.0) * np.roll(ref, rng.integers(-150, 150)) + rng.normal(0, 0.3, T.size)
    r = iso18571(ref, cand, T)
    parts = np.array([r.corridor, r.phase, r.magnitude, r.slope])
    assert np.all((0 <= parts) & (parts <= 1))
    assert r.total == pytest.approx(np.dot([0.4, 0.2, 0.2, 0.2], parts), abs=1e-15)
