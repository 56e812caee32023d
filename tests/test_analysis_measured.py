"""lsc.analysis.measured: force–deflection data in any units → loading curves; series of two."""

import numpy as np
import pytest

import lsc
from lsc.analysis import curve_table, measured_curve, read_measured, series_measured
from lsc.curves import Curve

LBF = 4.4482216152605  # N


def test_csv_in_inches_and_newtons_to_us(tmp_path):
    f = tmp_path / "edge.csv"
    f.write_text("# quasi-static test\nDeflection (in); Force (N)\n0;0\n1.2;" + f"{1000 * LBF!r}\n"
                 "2.4;" + f"{3000 * LBF!r}\n")
    c = read_measured(f, deformation="in", force="N", units="US")
    assert c.d == pytest.approx([0, 0.1, 0.2])
    assert c.f == pytest.approx([0, 1000, 3000])
    assert not c.extends
    c2 = read_measured(f, deformation="in", force="N", units="SI", columns=("Force (N)", "Deflection (in)"))
    # columns picked by name (here swapped): the first is the deformation, in the given unit
    assert c2.d[-1] == pytest.approx(3000 * LBF * 0.0254) and c2.f[-1] == pytest.approx(2.4)
    with pytest.raises(lsc.SceneError, match="no column named"):
        read_measured(f, columns=("x", "y"))


def test_loading_branch_zero_and_noise():
    # a test in time order: starts at an offset, jitters, loads to the max, then unloads
    d = np.array([0.5, 0.52, 0.51, 0.6, 0.7, 0.69, 0.8, 0.75, 0.6])
    f = np.array([-3.0, 10, 12, 50, 100, 98, 150, 90, 0])
    c = measured_curve(d, f)
    assert c.d == pytest.approx([0, 0.02, 0.1, 0.2, 0.3])
    assert c.f == pytest.approx([0, 10, 50, 100, 150])   # negative force → 0; backward steps dropped
    call = measured_curve(d, f, branch="all")
    assert call.d[-1] == pytest.approx(0.3)  # the unloading samples do not advance the deformation


def test_cut_resample_step():
    d = np.linspace(0, 0.1, 11)
    f = np.array([0, 1, 3, 6, 8, 9, 8.5, 8, 9.5, 11, 12.0]) * 1000
    c = measured_curve(d, f, cut="max-force")
    assert c.d[-1] == pytest.approx(0.1) and c.f[-1] == 12000
    c = measured_curve(d, f, cut=0.055)
    assert c.d[-1] == pytest.approx(0.055) and c.f[-1] == pytest.approx(8750)
    c = measured_curve(d * 39.37007874015748, f, deformation="in", cut="2.165354330708661 in")
    assert c.d[-1] == pytest.approx(0.055)
    c = measured_curve(d, f, resample=21)
    assert c.d.size == 21 and c.f[1] == pytest.approx(500)
    c = measured_curve(d, f, step=0.03)
    assert c.d == pytest.approx([0, 0.03, 0.06, 0.09, 0.1])
    assert c.f == pytest.approx(np.interp([0, 0.03, 0.06, 0.09, 0.1], d, f))
    c = measured_curve(d, f, cut="max-force", resample=5)
    assert c.d == pytest.approx(np.linspace(0, 0.1, 5))


def test_smoothing():
    rng = np.random.default_rng(0)
    d = np.linspace(0, 0.2, 401)
    truth = 50000 * d + 2e5 * d ** 2
    f = truth + rng.normal(0, 150, d.size)
    raw = measured_curve(d, f)
    sg = measured_curve(d, f, smooth="savgol", window=31, polyorder=2)
    ma = measured_curve(d, f, smooth="moving", window=15)
    err = lambda c: np.sqrt(np.mean((c.f - np.interp(c.d, d, truth)) ** 2))
    assert err(sg) < err(raw) / 3 and err(ma) < err(raw) / 2
    # Savitzky–Golay of order 2 keeps a quadratic exactly (edges included)
    exact = measured_curve(d, truth, smooth="savgol", window=31, polyorder=2)
    assert exact.f == pytest.approx(truth, abs=1e-6)
    with pytest.raises(lsc.SceneError, match="smooth"):
        measured_curve(d, f, smooth="median")
    with pytest.raises(lsc.SceneError, match="polyorder"):
        measured_curve(d, f, smooth="savgol", window=3, polyorder=3)


def test_series_of_two_lines_is_eq11():
    d = np.linspace(0, 0.5, 6)
    edge, kia = Curve.table(np.column_stack([d, 48000 * d])), Curve.table(np.column_stack([d, 30000 * d]))
    s = series_measured(edge, kia)
    k = 1 / (1 / 48000 + 1 / 30000)
    assert s.f[-1] == pytest.approx(min(48000, 30000) * 0.5)   # up to the lower top force
    assert s.f == pytest.approx(k * s.d)
    s10 = series_measured(edge, kia, force_limit=10000)
    assert s10.f[-1] == 10000 and s10.d[-1] == pytest.approx(10000 / k)


def test_series_of_failing_bumpers_uses_the_envelope():
    """A bumper whose bar fails (force drops) in series with a stiffer one: below the failure force
    the deformations add; at the plateau of the envelope the failing bumper crushes at constant force."""
    a = Curve.table([[0, 0], [0.02, 400], [0.1, 6000], [0.12, 5000], [0.2, 9000]])
    b = Curve.table([[0, 0], [0.1, 12000]])
    with pytest.raises(lsc.SceneError, match="falls after a peak"):
        series_measured(a, b, monotone="error")
    s = series_measured(a, b)
    for F in (200.0, 3000.0, 5999.0):
        assert s.deformation_at(F) == pytest.approx(a.deformation_at(F) + F / 120000)
    # the envelope holds 6000 from D_a = 0.1 to where the measured force climbs back to 6000
    d_back = 0.12 + (6000 - 5000) / (9000 - 5000) * 0.08   # 0.14
    assert s.energy(s.d[-1]) > 0
    plateau = s.d[(s.f == 6000)]
    assert plateau.max() - plateau.min() == pytest.approx(d_back - 0.1)
    for F in (7000.0, 8500.0):  # above the old peak the measured curve is followed again
        assert s.deformation_at(F) == pytest.approx(0.12 + (F - 5000) / 4000 * 0.08 + F / 120000)
    s_lim = series_measured(a, b, force_limit=5500)
    assert s_lim.f[-1] == 5500 and np.all(np.diff(s_lim.f) >= 0)


def test_measured_curve_in_a_scene():
    d = np.linspace(0, 0.6, 61)
    c = measured_curve(d, 24000 * d)
    sc = {"units": "US", "g": "32.2 ft/s^2",
          "vehicles": [{"weight": 3500, "speed": 10}, {"weight": 3500, "speed": 0}],
          "contacts": [{"loading": {"table": curve_table(c)}, "unloading": {"restitution": 0.4}}]}
    r = lsc.solve(sc)
    lin = lsc.solve({**sc, "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}]})
    assert r.delta_v == pytest.approx(lin.delta_v, rel=1e-9)
    assert r.peak_force == pytest.approx(lin.peak_force, rel=1e-9)


def test_bad_input():
    with pytest.raises(lsc.SceneError, match="same number"):
        measured_curve([0, 1], [0])
    with pytest.raises(lsc.SceneError, match="unit system"):
        measured_curve([0, 1], [0, 1], units="imperial")
    with pytest.raises(lsc.SceneError):
        measured_curve([0, 1], [0, 1], deformation="lbf")
    with pytest.raises(lsc.SceneError, match="cut"):
        measured_curve([0, 1], [0, 1], cut=2.0)
