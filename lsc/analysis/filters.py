"""SAE J211-1 / ISO 6487 channel frequency class (CFC) filter for crash-test channels.

The CFC filter is the 4-pole phaseless Butterworth low-pass of SAE J211-1 Appendix C: a 2-pole
Butterworth difference equation run forward and then backward over the data,

    Y[t] = a0 X[t] + a1 X[t-1] + a2 X[t-2] + b1 Y[t-1] + b2 Y[t-2]

with, for sample period ``T`` [s], ``ωd = 2π · CFC · 2.0775``, ``ωa = sin(ωd T/2) / cos(ωd T/2)``
and ``a0 = ωa² / (1 + √2 ωa + ωa²)``, ``a1 = 2 a0``, ``a2 = a0``,
``b1 = -2 (ωa² - 1) / (1 + √2 ωa + ωa²)``, ``b2 = (-1 + √2 ωa - ωa²) / (1 + √2 ωa + ωa²)``.
Two passes of a 2nd-order Butterworth of corner ``2.0775 CFC`` put the combined -3 dB point at
``5/3 CFC`` (100 Hz for CFC 60) and keep the pass band flat up to ``CFC`` (-0.45 dB there).

Start-up: the data are extended at both ends (by default an odd reflection about the end points,
``padlen`` samples) and each pass starts from the filter's steady state for its first sample, so a
channel that starts at rest has no start-up transient; the extension is removed afterwards.
J211 asks for pre- and post-event data beyond the interval of interest regardless.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["cfc_filter", "cfc_coefficients", "cfc_response", "j211_corridor", "CFC_CLASSES",
           "J211_FREQUENCIES"]

#: The standard channel frequency classes.
CFC_CLASSES = (60, 180, 600, 1000)

#: CFC → (F_H, F_N) [Hz]: the pass-band end and the -3 dB frequency of the J211-1 corridor.
J211_FREQUENCIES = {60: (60.0, 100.0), 180: (180.0, 300.0), 600: (600.0, 1000.0), 1000: (1000.0, 1650.0)}

_DESIGN = 2.0775  # ωd / (2π CFC), J211-1 Appendix C


def _rate(fs, dt) -> float:
    if (fs is None) == (dt is None):
        raise ValueError("give the sample rate fs [Hz] or the sample period dt [s]")
    rate = float(fs) if fs is not None else 1.0 / float(dt)
    if not (math.isfinite(rate) and rate > 0):
        raise ValueError(f"the sample rate must be a positive number of Hz, got {rate:g}")
    return rate


def cfc_coefficients(cfc: float, fs: float | None = None, *, dt: float | None = None):
    """``(b, a)`` of one pass: ``b = [a0, a1, a2]``, ``a = [1, -b1, -b2]`` in J211's notation.

    ``cfc`` [Hz-class number, e.g. 60], ``fs`` sample rate [Hz] (or ``dt`` [s]).
    """
    rate = _rate(fs, dt)
    cfc = float(cfc)
    if not (math.isfinite(cfc) and cfc > 0):
        raise ValueError(f"the channel frequency class must be a positive number, got {cfc:g}")
    T = 1.0 / rate
    wd = 2.0 * math.pi * cfc * _DESIGN
    if not wd * T / 2.0 < math.pi / 2.0:
        raise ValueError(f"CFC {cfc:g} needs a sample rate above {2 * _DESIGN * cfc:g} Hz (its design "
                         f"frequency {_DESIGN * cfc:g} Hz must lie below Nyquist); got {rate:g} Hz")
    wa = math.sin(wd * T / 2.0) / math.cos(wd * T / 2.0)
    den = 1.0 + math.sqrt(2.0) * wa + wa * wa
    a0 = wa * wa / den
    a1, a2 = 2.0 * a0, a0
    b1 = -2.0 * (wa * wa - 1.0) / den
    b2 = (-1.0 + math.sqrt(2.0) * wa - wa * wa) / den
    return np.array([a0, a1, a2]), np.array([1.0, -b1, -b2])


def _extend(x: np.ndarray, n: int, pad: str | None) -> np.ndarray:
    """``x`` (time on the last axis) extended by ``n`` samples at each end."""
    if pad is None or n == 0:
        return x
    left, right = x[..., n:0:-1], x[..., -2:-n - 2:-1]
    if pad == "odd":
        left = 2.0 * x[..., :1] - left
        right = 2.0 * x[..., -1:] - right
    elif pad == "constant":
        left = np.repeat(x[..., :1], n, axis=-1)
        right = np.repeat(x[..., -1:], n, axis=-1)
    elif pad != "even":
        raise ValueError(f'pad is "odd", "even", "constant" or None, got {pad!r}')
    return np.concatenate([left, x, right], axis=-1)


def cfc_filter(x, cfc: float, fs: float | None = None, *, dt: float | None = None, axis: int = -1,
               pad: str | None = "odd", padlen: int | None = None) -> np.ndarray:
    """A channel filtered by the J211 CFC filter (4-pole, phaseless), in the channel's units.

    Parameters
    ----------
    x : array
        The channel (e.g. acceleration [any unit]) sampled at ``fs``; time along ``axis``.
    cfc : float
        Channel frequency class (60, 180, 600, 1000 are the standard ones).
    fs : float
        Sample rate [Hz] (or give ``dt`` [s]).
    pad : ``"odd"``, ``"even"``, ``"constant"`` or None
        How the data are extended at both ends before filtering (see the module docstring).
    padlen : int, optional
        Samples added at each end (default: ten time constants of one pass,
        ``10 fs / (√2 π · 2.0775 CFC)``, at most the channel length minus one).

    Returns
    -------
    array
        The filtered channel, same shape as ``x``.
    """
    from scipy.signal import lfilter, lfilter_zi

    rate = _rate(fs, dt)
    b, a = cfc_coefficients(cfc, rate)
    x = np.moveaxis(np.asarray(x, float), axis, -1)
    n = x.shape[-1]
    if n < 3:
        raise ValueError("a channel needs at least 3 samples")
    if padlen is None:
        padlen = int(math.ceil(10.0 * rate / (math.sqrt(2.0) * math.pi * _DESIGN * float(cfc))))
        padlen = min(padlen, n - 1)
    padlen = 0 if pad is None else int(padlen)
    if not 0 <= padlen <= n - 1:
        raise ValueError(f"padlen must lie in [0, {n - 1}] for {n} samples, got {padlen}")
    ext = _extend(x, padlen, pad)
    zi = lfilter_zi(b, a)
    y, _ = lfilter(b, a, ext, axis=-1, zi=zi * ext[..., :1])            # forward pass
    y = y[..., ::-1]
    y, _ = lfilter(b, a, y, axis=-1, zi=zi * y[..., :1])                # backward pass
    y = y[..., ::-1]
    if padlen:
        y = y[..., padlen:-padlen]
    return np.moveaxis(y, -1, axis)


def cfc_response(f, cfc: float, fs: float | None = None, *, dt: float | None = None) -> np.ndarray:
    """Gain of the two-pass (4-pole, phaseless) CFC filter at frequencies ``f`` [Hz], in dB:
    ``20 log10 |H(e^{i 2π f / fs})|²`` of one pass's transfer function ``H``."""
    from scipy.signal import freqz

    rate = _rate(fs, dt)
    b, a = cfc_coefficients(cfc, rate)
    _, h = freqz(b, a, worN=np.atleast_1d(np.asarray(f, float)), fs=rate)
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(np.abs(h) ** 2)


def j211_corridor(cfc: int, f) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper limits [dB] of the J211-1 / ISO 6487 frequency-response corridor at ``f`` [Hz].

    As tabulated for the standard classes (``J211_FREQUENCIES``): ±0.5 dB up to ``F_H``; at
    ``F_H`` +0.5/-1 dB; at ``F_N`` +0.5/-4 dB (lower limit straight on a log-frequency axis
    between them); above ``F_N`` the upper limit falls 9 dB/octave down to -30 dB and the lower
    one 24 dB/octave.
    """
    if cfc not in J211_FREQUENCIES:
        raise ValueError(f"the corridor is tabulated for CFC {', '.join(map(str, CFC_CLASSES))}; got {cfc!r}")
    fh, fn = J211_FREQUENCIES[cfc]
    f = np.asarray(f, float)
    oct_n = np.log2(np.maximum(f, 1e-300) / fn)
    upper = np.where(f <= fn, 0.5, np.maximum(0.5 - 9.0 * oct_n, -30.0))
    ramp = -1.0 - 3.0 * np.log(np.maximum(f, 1e-300) / fh) / np.log(fn / fh)
    lower = np.where(f < fh, -0.5, np.where(f <= fn, ramp, -4.0 - 24.0 * oct_n))
    return lower, upper
