"""Standard errors of a least-squares fit (:func:`lsc.analysis.fit`) from the Jacobian of its
weighted residuals: ordinary least squares for independent residuals, or the Newey–West
(heteroscedasticity and autocorrelation consistent) sandwich for filtered test data, whose noise
is correlated over many samples.
"""

from __future__ import annotations

import numpy as np

from ..errors import SceneError

__all__ = ["covariance"]

#: Smallest ratio of the Jacobian's singular values for parameters the channels can tell apart
#: (finite differences are good to about 1e-8).
_RANK_TOLERANCE = 1e-7


def covariance(J: np.ndarray, r: np.ndarray, sizes, errors: str, params):
    """``(cov, corr, lags)`` of the parameters from the Jacobian ``J`` (n, P) of the weighted
    residuals ``r`` (n,), stacked by channel (``sizes``). ``"independent"``: ``σ² (JᵀJ)⁻¹``,
    ``σ² = SSR/(n - P)``; ``"autocorrelated"``: the Newey–West sandwich ``(JᵀJ)⁻¹ S (JᵀJ)⁻¹``,
    ``S`` the Bartlett-weighted sum of the lagged products of ``J_t r_t`` within each channel,
    over ``lags`` (per channel: twice the lag where the residuals' autocorrelation first turns
    negative), times ``n/(n - P)``."""
    n, P = J.shape
    sv = np.linalg.svd(J, compute_uv=False)
    if not sv[-1] > _RANK_TOLERANCE * sv[0]:
        raise SceneError("params", f"the channels cannot tell the parameters {list(params)} apart "
                                   f"(their Jacobian columns are dependent): fit fewer parameters")
    inv = np.linalg.inv(J.T @ J)
    if errors == "independent":
        cov, lags = (r @ r) / (n - P) * inv, [0] * len(sizes)
    else:
        meat, lags, start = np.zeros((P, P)), [], 0
        for size in sizes:
            part, lag = _lagged_products(J[start:start + size], r[start:start + size])
            meat += part
            lags.append(lag)
            start += size
        cov = inv @ meat @ inv * n / (n - P)
    se = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.where(np.outer(se, se) > 0, cov / np.outer(se, se), np.eye(P))
    return cov, corr, lags


def _lagged_products(J: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, int]:
    """One channel's Newey–West sum ``Σ_l w_l (Γ_l + Γ_lᵀ)`` (Bartlett ``w_l = 1 - l/(L+1)``) and
    its bandwidth ``L``."""
    g = J * r[:, None]
    meat = g.T @ g
    power = float(r @ r)
    if power == 0.0:
        return meat, 0
    rho = np.correlate(r, r, "full")[r.size - 1:] / power
    negative = np.nonzero(rho < 0)[0]
    lag = min(r.size // 4, 2 * int(negative[0] if negative.size else r.size))
    for l in range(1, lag + 1):
        G = g[l:].T @ g[:-l]
        meat += (1.0 - l / (lag + 1)) * (G + G.T)
    return meat, lag
