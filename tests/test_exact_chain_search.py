"""The exact chain's event search (lsc/solvers/exact_chain/_roots.py): the unclear intervals of
a window listed on Python lists (a short window) and by NumPy (a long one) give the same rows,
in the same order (by their first unclear interval, the first row on a tie), and the same
intervals; and a search over a long window finds the same first crossing as over its halves.
"""

from __future__ import annotations

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
