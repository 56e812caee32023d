"""lsc.analysis.cfc_filter: the SAE J211-1 / ISO 6487 CFC filter against its definition."""

import numpy as np
import pytest
from scipy.signal import butter, filtfilt

from lsc.analysis import CFC_CLASSES, cfc_coefficients, cfc_filter, cfc_response, j211_corridor
from lsc.analysis.filters import J211_FREQUENCIES


def rate_for(cfc):
    """A sample rate well above J211's minimum for the class (as test labs use)."""
    return {60: 10_000.0, 180: 20_000.0, 600: 50_000.0, 1000: 100_000.0}[cfc]


@pytest.mark.parametrize("cfc", CFC_CLASSES)
@pytest.mark.parametrize("fs", [5_000.0, 20_000.0, 100_000.0])
def test_coefficients_are_a_butterworth_at_2_0775_cfc(cfc, fs):
    if 2.0775 * cfc >= fs / 2:
        pytest.skip("below Nyquist only")
    b, a = cfc_coefficients(cfc, fs)
    bb, aa = butter(2, 2.0775 * cfc, fs=fs)
    assert b == pytest.approx(bb, rel=1e-12, abs=1e-15)
    assert a == pytest.approx(aa, rel=1e-12, abs=1e-15)
    assert b.sum() / a.sum() == pytest.approx(1.0, rel=1e-12)  # unit DC gain


@pytest.mark.parametrize("cfc", CFC_CLASSES)
def test_minus_3_db_at_five_thirds_cfc_and_flat_passband(cfc):
    fs = rate_for(cfc)
    assert cfc_response(5 / 3 * cfc, cfc, fs)[0] == pytest.approx(-3.0, abs=0.05)
    fh, fn = J211_FREQUENCIES[cfc]
    f = np.geomspace(0.1, fh, 200)
    g = cfc_response(f, cfc, fs)
    assert np.all(g <= 1e-9) and np.all(g >= -0.5)             # flat to F_H within 0.5 dB
    assert cfc_response(fn, cfc, fs)[0] == pytest.approx(-3.0, abs=0.15)


@pytest.mark.parametrize("cfc", CFC_CLASSES)
def test_response_inside_the_j211_corridor(cfc):
    fs = rate_for(cfc)
    fn = J211_FREQUENCIES[cfc][1]
    f = np.geomspace(0.1, min(16 * fn, fs / 4), 400)
    g = cfc_response(f, cfc, fs)
    lo, hi = j211_corridor(cfc, f)
    assert np.all(g >= lo) and np.all(g <= hi)


def measured_gain(f, cfc, fs, T=2.0):
    """Filter a sinusoid and fit amplitude and phase in the middle (away from the ends)."""
    t = np.arange(0, T, 1 / fs)
    x = np.sin(2 * np.pi * f * t)
    y = cfc_filter(x, cfc, fs)
    mid = slice(t.size // 4, 3 * t.size // 4)
    A = np.column_stack([np.sin(2 * np.pi * f * t[mid]), np.cos(2 * np.pi * f * t[mid])])
    (s, c), *_ = np.linalg.lstsq(A, y[mid], rcond=None)
    return 20 * np.log10(np.hypot(s, c)), np.arctan2(c, s)


@pytest.mark.parametrize("f", [5.0, 30.0, 60.0, 100.0, 150.0, 300.0])
def test_filtering_sinusoids_cfc60(f):
    fs = 10_000.0
    gain, phase = measured_gain(f, 60, fs)
    assert gain == pytest.approx(cfc_response(f, 60, fs)[0], abs=0.01)
    assert abs(phase) < 1e-6                                   # phaseless: forward and backward
    lo, hi = j211_corridor(60, f)
    assert lo <= gain <= hi
    if f == 100.0:
        assert gain == pytest.approx(-3.0, abs=0.05)           # -3 dB near 100 Hz
    if f <= 60.0:
        assert gain > -0.5


def test_against_scipy_filtfilt_on_a_crash_pulse():
    fs, cfc = 10_000.0, 60
    t = np.arange(-0.02, 0.25, 1 / fs)
    rng = np.random.default_rng(0)
    pulse = np.where((t > 0) & (t < 0.15), 1.4 * np.sin(np.pi * t / 0.15), 0.0)
    x = pulse + 0.3 * np.sin(2 * np.pi * 400 * t) + 0.05 * rng.normal(size=t.size)
    b, a = butter(2, 2.0775 * cfc, fs=fs)
    for pad, padlen in (("odd", 200), ("even", 50), ("constant", 300)):
        ref = filtfilt(b, a, x, padtype=pad, padlen=padlen)
        assert cfc_filter(x, cfc, fs, pad=pad, padlen=padlen) == pytest.approx(ref, abs=1e-12)
    y = cfc_filter(x, cfc, fs)
    inside = (t > 0.02) & (t < 0.13)
    assert np.max(np.abs(y - pulse)[inside]) < 0.05            # noise and 400 Hz removed


def test_rest_dc_axis_and_errors():
    fs = 10_000.0
    assert cfc_filter(np.zeros(100), 60, fs) == pytest.approx(np.zeros(100), abs=0)
    assert cfc_filter(np.full(100, 3.5), 180, dt=1e-4) == pytest.approx(np.full(100, 3.5), rel=1e-12)
    x = np.random.default_rng(1).normal(size=(3, 500))
    y = cfc_filter(x, 600, 20_000.0)
    y0 = cfc_filter(x.T, 600, 20_000.0, axis=0)
    assert y0.T == pytest.approx(y, abs=1e-14)
    assert y[1] == pytest.approx(cfc_filter(x[1], 600, 20_000.0), abs=1e-14)
    with pytest.raises(ValueError, match="sample rate above"):
        cfc_filter(x[0], 1000, 4000.0)
    with pytest.raises(ValueError, match="fs"):
        cfc_filter(x[0], 60)
    with pytest.raises(ValueError, match="tabulated"):
        j211_corridor(100, 50.0)
