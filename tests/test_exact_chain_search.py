"""The exact chain's event search (lsc/solvers/exact_chain/_roots.py): the unclear intervals of
a window listed on Python lists (a short window) and by NumPy (a long one) give the same rows,
in the same order (by their first unclear interval, the first row on a tie), and the same
intervals; a search over a long window finds the same first crossing as over its halves; and
the restart rule fires at once on a touching contact pushed shut through soft contacts.
"""

from __future__ import annotations

import math

import numpy as np
import pytest


@pytest.mark.parametrize("seed", range(5))
def test_short_and_long_windows_list_the_same_unclear_intervals(monkeypatch, seed):
    from lsc.solvers.exact_chain import _roots

    rng = np.random.default_rng(seed)
    unclear = rng.random((6, 40)) < 0.05
    unclear[2] = False
    short_rows, short = _roots._unclear(unclear)
    monkeypatch.setattr(_roots, "SHORT", 0)
    long_rows, long = _roots._unclear(unclear)
    assert short_rows == long_rows and 2 not in short_rows
    firsts = [int(np.argmax(unclear[j])) for j in short_rows]
    assert firsts == sorted(firsts)
    assert all(short(j) == long(j) == np.flatnonzero(unclear[j]).tolist() for j in short_rows)


def test_a_long_window_finds_the_first_crossing_of_its_halves(monkeypatch):
    """A sum of two sinusoids with several crossings: the earliest one over the window
    [0, 1] s is the first one found over [0, 0.5] or else over [0.5, 1], with the Python lists
    and with NumPy listing the intervals."""
    from lsc.solvers.exact_chain import _roots
    from lsc.solvers.exact_chain._modes import Modes, Series

    modes = Modes([400.0, 9e4])
    g = Series(0.004, np.array([0.0, 0.3]), np.array([-2.0, 0.0]), modes)
    found = _roots.earliest([g], 0.0, 1.0)
    half = _roots.earliest([g], 0.0, 0.5)
    assert found[1] == 0 and found == (half if half[0] is not None
                                       else _roots.earliest([g], 0.5, 1.0))
    assert g(found[0]) == pytest.approx(0.0, abs=1e-15) and g(0.0) > 0
    monkeypatch.setattr(_roots, "SHORT", 0)
    assert _roots.earliest([g], 0.0, 1.0) == found


@pytest.mark.parametrize("behind", [2, 3])
def test_a_touching_contact_pushed_through_soft_contacts_fires_at_once(behind):
    """The restart rule (``_solve._start``) on the deformation of a contact touching at rest,
    ``behind`` contacts (slopes 1e3 N/m, masses 1 kg) from the rear car moving at 1 m/s, in a
    model whose stiffest contact is far stiffer (1e5 rad/s, its time scale): the deformation
    grows as ``τ^(2j+1)`` (``j = behind``) with ``D^(2j+1)(0) = v Π s/m`` (each contact passes
    the one behind it on as a force), so ``hi - D`` (the contact's piece left going down) fires
    at once and ``D - lo`` (going up) is left alone only for a while; the series agrees with
    its Taylor term at small τ (brute force, where the higher orders are negligible)."""
    from lsc.solvers.exact_chain._modes import Motion, deformation_map
    from lsc.solvers.exact_chain._solve import START_TOL, _start

    N, v, s, omega = behind + 2, 1.0, 1e3, 1e5
    slope = np.array([s] * behind + [0.0])
    x0, v0 = np.zeros(N), np.r_[v, np.zeros(N - 1)]
    motion = Motion(np.ones(N), x0, v0, slope, np.zeros(N - 1), -deformation_map(N).T)
    p = 2 * behind + 1
    tol = START_TOL * v / omega   # (the chain's: START_TOL of its length, v_scale t_scale)
    down = motion.deformation(behind, 0.0, -1.0)   # hi - D, at hi
    terms = down.derivatives_from_zero()
    d = [next(terms) for _ in range(p + 1)]
    assert d[p] == pytest.approx(-v * s ** behind, rel=1e-9)
    assert max(abs(x) for x in d[:p]) < 1e-12 * s ** behind
    tau = 2e-3   # (ω τ <= 0.13 on every mode)
    assert down(tau) == pytest.approx(d[p] * tau ** p / math.factorial(p), rel=1e-3)
    assert _start(down, tol, omega, math.inf) == 0.0
    up = motion.deformation(behind, 0.0)
    later = _start(up, tol, omega, math.inf)
    # (within a radian of the function's own fastest mode, where it is still above zero)
    assert later is not None and 0.0 < later <= 1.0 / motion.modes.fastest()
    assert up(later) > 0


class _Counted(RuntimeError):
    """More evaluations than the test allows (the old search halved on, millions of them)."""


@pytest.mark.parametrize("behind,s", [(2, 10.0), (3, 10.0), (3, 30.0)])
def test_a_function_leaving_its_surface_as_a_high_power_is_searched_in_few_evaluations(
        monkeypatch, behind, s):
    """The deformation of a contact touching at rest, ``behind`` soft contacts (slope ``s``)
    from the rear car, leaves its surface as ``τ^(2j+1)``: searched from 1e-4 s (as far as the
    restart rule, ``_start``, lets it go at least), over the first windows of the segment (model's time scale 1e-4 s,
    as beside a stiff pair), no crossing, as a dense sampling shows; in a few hundred
    evaluations of the series (the chord's bound alone halved each window down to
    ``sqrt(8 g / B)``: millions, 15-50 s a segment). (Near the start the function is below
    its rounding: the dense samples only within it of zero.)"""
    from lsc.solvers.exact_chain import _roots
    from lsc.solvers.exact_chain._modes import Motion, Series, deformation_map
    from lsc.solvers.exact_chain._solve import START_TOL, _start

    N, omega = behind + 2, 1e4
    slope = np.array([s] * behind + [0.0])
    motion = Motion(np.ones(N), np.zeros(N), np.r_[1.0, np.zeros(N - 1)], slope,
                    np.zeros(N - 1), -deformation_map(N).T)
    up = motion.deformation(behind, 0.0)
    # (a start the search may be handed, as the restart rule did before it looked past the
    # model's time scale: there the function is still below its rounding)
    start = 1.0 / omega
    assert _start(up, START_TOL / omega, omega, math.inf) >= start
    fast = motion.modes.fastest()
    tt = np.linspace(start, 4 * math.pi / fast, 200_001)
    S, C = motion.modes.basis(tt)
    rounding = 64 * np.finfo(float).eps * (np.abs(S) @ np.abs(up.alpha) + np.abs(C) @ np.abs(up.gamma))
    assert np.all(up(tt) > -rounding)   # (no crossing over the windows searched)
    calls, call = [0], Series.__call__

    def counted(self, tau):
        calls[0] += 1
        if calls[0] > 500:
            raise _Counted
        return call(self, tau)

    monkeypatch.setattr(Series, "__call__", counted)
    lo, window = 0.0, 2 * math.pi / fast
    while lo < 4 * math.pi / fast:   # (the segment's windows, as _solve._earliest takes them)
        hi = min(lo + window, 4 * math.pi / fast)
        assert _roots.earliest([up], lo, hi, [max(start, lo)]) == (None, None)
        lo, window = hi, 2 * window
    assert calls[0] <= 500


@pytest.mark.parametrize("k_stiff", [1e7, 1e8])
def test_a_contact_pushed_through_soft_contacts_fires_at_once_beside_a_stiff_pair(k_stiff):
    """The same contact, three soft contacts (1e3) from the rear car, while ahead of it, beyond
    an open contact, a stiff pair (``k_stiff``, sqrt(2 k) rad/s) rings: the pair's modes do not
    enter the contact's deformation (exactly: no closed contact joins them), so its seventh
    derivative is judged by the soft modes' rounding and the function fires at once (the
    segment's fastest mode, the pair's, hid it: the contact closed 0.17-1.2 ms late)."""
    from lsc.solvers.exact_chain._modes import Motion, deformation_map
    from lsc.solvers.exact_chain._solve import START_TOL, _start

    behind, s = 3, 1e3
    N = behind + 4
    slope = np.array([s] * behind + [0.0, 0.0, k_stiff])
    v0 = np.r_[1.0, np.zeros(behind + 1), 0.5, 0.0]
    force = np.r_[np.zeros(behind + 2), 1e-3 * k_stiff]   # (the pair pressed)
    motion = Motion(np.ones(N), np.zeros(N), v0, slope, force, -deformation_map(N).T)
    omega = motion.modes.fastest()
    assert omega == pytest.approx(math.sqrt(2 * k_stiff))
    down = motion.deformation(behind, 0.0, -1.0)   # hi - D, at hi
    p = 2 * behind + 1
    terms = down.derivatives_from_zero()
    d = [next(terms) for _ in range(p + 1)]
    assert d[p] == pytest.approx(-s ** behind, rel=1e-9)
    assert _start(down, START_TOL / omega, omega, math.inf) == 0.0
