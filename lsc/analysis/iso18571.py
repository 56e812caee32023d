"""ISO/TS 18571 objective rating of a time history against a reference (test) time history.

Four sub-scores, each in [0, 1], and their weighted sum (ISO/TS 18571:2014, non-ambiguous
signals, with the standard's default parameters):

- **corridor** ``Z``: the mean over samples of a per-sample score that is 1 inside an inner corridor
  ``|C - T| <= a0 · max|T|`` (``a0 = 0.05``), 0 outside an outer one ``b0 · max|T|``
  (``b0 = 0.5``) and ``((δo - |C - T|) / (δo - δi))^kz`` (``kz = 2``) between them; computed on
  the signals as given (not shifted).
- **phase** ``E_P``: the candidate is shifted against the reference by ``n`` samples (up to
  ``ε_p N``, ``ε_p = 0.2``) to the shift with the largest correlation coefficient of the overlapping
  parts (the smallest shift, left first, on ties); ``E_P = ((ε_p N - |n|) / (ε_p N))^kp``, ``kp = 1``.
- **magnitude** ``E_M``: on the shifted signals, warped by dynamic time warping (squared
  difference cost, steps (1,0), (0,1), (1,1) of weight 1, Sakoe–Chiba band of 10 % of the length),
  ``e = ‖C_w - T_w‖₁ / ‖T_w‖₁`` and ``E_M = ((ε_m - e) / ε_m)^km``, ``ε_m = 0.5``, ``km = 1``
  (0 when ``e > ε_m``).
- **slope** ``E_S``: on the shifted signals, the derivatives by central differences averaged over
  9 samples (1, 3, 5, 7 samples at the ends), ``e = ‖C' - T'‖₁ / ‖T'‖₁`` and
  ``E_S = (ε_s - e) / ε_s``, ``ε_s = 2`` (0 when ``e >= ε_s``).
- **total** ``R = 0.4 Z + 0.2 E_P + 0.2 E_M + 0.2 E_S``.

The standard asks for both signals on one time base sampled at 10 kHz over the interval of
interest; :func:`iso18571` takes them as given (same length, uniform spacing), and
:func:`resample` puts a pair of channels on such a base.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["ISO18571Rating", "iso18571", "resample", "ISO18571_RATE"]

#: The sample rate [Hz] ISO/TS 18571 asks for.
ISO18571_RATE = 10_000.0

_A0, _B0, _KZ = 0.05, 0.5, 2           # corridor: inner and outer half widths, exponent
_EPS_P, _KP = 0.2, 1                   # phase: largest shift (fraction of N), exponent
_EPS_M, _KM, _DTW_BAND = 0.5, 1, 0.1   # magnitude: largest error, exponent, warping band
_EPS_S = 2.0                           # slope: largest error
_WEIGHTS = (0.4, 0.2, 0.2, 0.2)        # corridor, phase, magnitude, slope


@dataclass(frozen=True)
class ISO18571Rating:
    """The four ISO/TS 18571 sub-scores and their weighted total, each in [0, 1];
    ``shift`` [s] is the time shift of the candidate that the phase score found (positive: the
    candidate lags the reference)."""

    corridor: float
    phase: float
    magnitude: float
    slope: float
    total: float
    shift: float

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def resample(t, values, t_start: float, t_end: float, rate: float = ISO18571_RATE) -> tuple:
    """``(t, values)`` linearly interpolated onto a uniform base of ``rate`` [Hz] from ``t_start``
    to ``t_end`` [s] (both within ``t``)."""
    n = int(np.floor((t_end - t_start) * rate + 1e-9)) + 1
    grid = t_start + np.arange(n) / rate
    return grid, np.interp(grid, np.asarray(t, float), np.asarray(values, float))


def iso18571(reference, candidate, t=None, *, dt: float | None = None) -> ISO18571Rating:
    """ISO/TS 18571 rating of ``candidate`` (e.g. a simulation) against ``reference`` (the test).

    Both are sampled on the same uniform time base: ``t`` [s] (or the sample period ``dt`` [s];
    the standard asks for 10 kHz, see :func:`resample`). Raises ``ValueError`` for signals of
    different length, fewer than 10 samples, non-finite values or a reference that is zero.
    """
    ref = np.asarray(reference, float).ravel()
    cand = np.asarray(candidate, float).ravel()
    step = _sample_period(t, dt, len(ref))
    if ref.shape != cand.shape:
        raise ValueError(f"the reference has {ref.size} samples and the candidate {cand.size}; "
                         "put both on one time base first (lsc.analysis.iso18571.resample)")
    if ref.size < 10:
        raise ValueError(f"ISO/TS 18571 needs at least 10 samples, got {ref.size}")
    if not (np.all(np.isfinite(ref)) and np.all(np.isfinite(cand))):
        raise ValueError("the signals must be finite (no NaN or inf)")
    if not np.any(ref):
        raise ValueError("the reference signal is zero everywhere: no ISO/TS 18571 rating is defined")
    z = corridor_score(ref, cand)
    shift, ref_s, cand_s = _best_shift(ref, cand)
    limit = _EPS_P * ref.size
    e_p = 0.0 if abs(shift) >= limit else ((limit - abs(shift)) / limit) ** _KP
    e_m = magnitude_score(ref_s, cand_s)
    e_s = slope_score(ref_s, cand_s, step)
    total = float(np.dot(_WEIGHTS, (z, e_p, e_m, e_s)))
    return ISO18571Rating(z, float(e_p), e_m, e_s, total, shift * step)


def _sample_period(t, dt, n) -> float:
    if (t is None) == (dt is None):
        raise ValueError("give the time base t [s] or the sample period dt [s]")
    if dt is not None:
        return float(dt)
    t = np.asarray(t, float)
    if t.shape != (n,):
        raise ValueError(f"t has shape {t.shape}, the signals {n} samples")
    steps = np.diff(t)
    if not (np.all(steps > 0) and np.ptp(steps) <= 1e-6 * steps.mean()):
        raise ValueError("t must be uniformly spaced and increasing (see resample)")
    return float(steps.mean())


def corridor_score(ref: np.ndarray, cand: np.ndarray) -> float:
    """The corridor score ``Z`` of the unshifted signals."""
    norm = np.max(np.abs(ref))
    inner, outer = _A0 * norm, _B0 * norm
    diff = np.abs(cand - ref)
    score = np.clip((outer - diff) / (outer - inner), 0.0, 1.0) ** _KZ
    return float(np.mean(score))


def _best_shift(ref: np.ndarray, cand: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """The shift ``n`` [samples] with the largest correlation (positive: candidate lags), and the
    overlapping parts of reference and candidate at that shift."""
    best, best_rho = 0, _corr(ref, cand)
    for k in range(1, int(np.floor(_EPS_P * ref.size)) + 1):
        for n in (k, -k):  # the candidate lagging first, then leading
            rho = _corr(*_overlap(ref, cand, n))
            if rho > best_rho:
                best, best_rho = n, rho
    return (best, *_overlap(ref, cand, best))


def _overlap(ref: np.ndarray, cand: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    if n > 0:
        return ref[:-n], cand[n:]
    if n < 0:
        return ref[-n:], cand[:n]
    return ref, cand


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    den = np.sqrt(np.dot(a, a) * np.dot(b, b))
    return float(np.dot(a, b) / den) if den > 0 else -np.inf


def magnitude_score(ref: np.ndarray, cand: np.ndarray) -> float:
    """The magnitude score ``E_M`` of the (shifted) signals, after dynamic time warping."""
    path_ref, path_cand = dtw_path(ref, cand, band=max(1, int(np.ceil(_DTW_BAND * ref.size))))
    ref_w, cand_w = ref[path_ref], cand[path_cand]
    den = np.sum(np.abs(ref_w))
    error = np.sum(np.abs(cand_w - ref_w)) / den if den > 0 else np.inf
    return float(((_EPS_M - error) / _EPS_M) ** _KM) if error <= _EPS_M else 0.0


def dtw_path(a: np.ndarray, b: np.ndarray, band: int) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs ``(i, j)`` of the least-cost warping path between ``a`` and ``b`` (cost
    ``(a_i - b_j)²``, steps (1,0), (0,1), (1,1) of weight 1, ``|i - j| < band``); on ties the
    diagonal step is preferred. Memory: ``len(a) × (2 band - 1)`` accumulated costs."""
    cost = _BandedCost(a.size, b.size, band)
    prev = None
    for i in range(a.size):
        lo, hi = cost.lo[i], cost.hi[i]
        step = (a[i] - b[lo:hi]) ** 2
        if prev is None:
            row = np.cumsum(step)
        else:
            best = step + np.minimum(cost.row_values(i - 1, lo, hi), cost.row_values(i - 1, lo - 1, hi - 1))
            # along the row: C[j] = min(best[j], step[j] + C[j-1]) = S[j] + min_{k<=j}(best[k] - S[k])
            csum = np.cumsum(step)
            row = csum + np.minimum.accumulate(best - csum)
        cost.rows.append(row)
        prev = row
    return _backtrack(cost)


class _BandedCost:
    """Accumulated DTW costs stored row by row inside the Sakoe–Chiba band (inf outside)."""

    def __init__(self, n: int, m: int, band: int):
        i = np.arange(n)
        self.lo = np.maximum(0, i - band + 1)
        self.hi = np.minimum(m, i + band)
        self.shape = (n, m)
        self.rows: list[np.ndarray] = []

    def row_values(self, i: int, lo: int, hi: int) -> np.ndarray:
        """Row ``i`` at columns ``lo .. hi-1`` (inf where outside the band or the matrix)."""
        out = np.full(hi - lo, np.inf)
        a, b = max(lo, self.lo[i]), min(hi, self.hi[i])
        if b > a:
            out[a - lo:b - lo] = self.rows[i][a - self.lo[i]:b - self.lo[i]]
        return out

    def __getitem__(self, ij) -> float:
        i, j = ij
        return self.rows[i][j - self.lo[i]] if self.lo[i] <= j < self.hi[i] else np.inf


def _backtrack(cost: _BandedCost) -> tuple[np.ndarray, np.ndarray]:
    i, j = cost.shape[0] - 1, cost.shape[1] - 1
    path = [(i, j)]
    while i > 0 or j > 0:
        steps = [(i - 1, j - 1), (i - 1, j), (i, j - 1)]  # diagonal first: preferred on ties
        i, j = min((s for s in steps if s[0] >= 0 and s[1] >= 0), key=lambda s: cost[s])
        path.append((i, j))
    path.reverse()
    idx = np.array(path)
    return idx[:, 0], idx[:, 1]


def _smoothed_derivative(x: np.ndarray, dt: float) -> np.ndarray:
    """Central-difference derivative averaged over 9 samples (1, 3, 5, 7 at the ends)."""
    d = np.gradient(x, dt)
    out = np.empty_like(d)
    out[4:-4] = np.convolve(d, np.ones(9) / 9.0, mode="valid")
    for k, width in enumerate((1, 3, 5, 7)):
        out[k] = d[:width].mean()
        out[-1 - k] = d[-width:].mean()
    return out


def slope_score(ref: np.ndarray, cand: np.ndarray, dt: float) -> float:
    """The slope score ``E_S`` of the (shifted) signals sampled every ``dt`` [s]."""
    d_ref, d_cand = _smoothed_derivative(ref, dt), _smoothed_derivative(cand, dt)
    den = np.sum(np.abs(d_ref))
    error = np.sum(np.abs(d_cand - d_ref)) / den if den > 0 else (0.0 if not np.any(d_cand) else np.inf)
    return float((_EPS_S - error) / _EPS_S) if error < _EPS_S else 0.0
