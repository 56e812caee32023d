"""Correlated uncertain inputs: the ``correlation`` entry of an ``[uncertainty]`` table.

A Spearman rank correlation matrix over the sampled paths (or named pairs), checked, and the
Gaussian copula's normal-score correlation ``2 sin(π ρ_S / 6)`` that realises it
(:func:`lsc.analysis.sampling.correlate`).
"""

from __future__ import annotations

import numpy as np

from ..errors import SceneError

__all__ = ["rank_correlation", "correlated_pairs", "normal_scores"]


def _is_choice(dist) -> bool:
    from .sampling import _Choice

    return isinstance(dist, _Choice)


def normal_scores(rank: np.ndarray) -> np.ndarray:
    """The Pearson correlation of the copula's normal scores that gives the Spearman rank
    correlation ``rank``: ``2 sin(π ρ_S / 6)`` (Pearson's relation for a bivariate normal)."""
    return 2.0 * np.sin(np.pi * rank / 6.0)


def rank_correlation(spec, marginals: dict) -> np.ndarray:
    """The ``correlation`` entry of an ``[uncertainty]`` table as a checked Spearman rank
    correlation matrix over the sampled paths (``marginals``, in the table's order).

    Accepted: a matrix (a list of rows, one row and column per sampled path in the table's
    order; ``function`` paths are not sampled) or named pairs ``[[path_a, path_b, rho], ...]``
    (pairs left out are uncorrelated). The matrix must be symmetric with a unit diagonal and
    positive definite (also once turned into the copula's normal-score correlation), and a
    ``choice`` input (ties: no rank correlation can be set) is uncorrelated; ``SceneError`` on
    ``uncertainty.correlation`` otherwise."""
    paths = list(marginals)
    if isinstance(spec, (list, tuple)) and spec and all(
            isinstance(row, (list, tuple)) and row and isinstance(row[0], str) for row in spec):
        matrix = _pairs_matrix(spec, paths)
    else:
        matrix = _numeric_matrix(spec, paths)
    _check_correlation(matrix, paths, marginals)
    return matrix


_FIELD = "uncertainty.correlation"


def _numeric_matrix(spec, paths: list) -> np.ndarray:
    d = len(paths)
    shape = f"{d} rows of {d} numbers, one per sampled input in the table's order " \
            f"({', '.join(paths)}), or pairs [[path_a, path_b, rho], ...]"
    try:
        matrix = np.array(spec, dtype=float)
    except (TypeError, ValueError):
        raise SceneError(_FIELD, f"a correlation matrix is {shape}; got {spec!r}") from None
    if matrix.shape != (d, d):
        raise SceneError(_FIELD, f"a correlation matrix is {shape}; got shape "
                                 f"{'x'.join(map(str, matrix.shape)) or 'scalar'}")
    return matrix


def _pairs_matrix(spec, paths: list) -> np.ndarray:
    from ._common import split_path

    index = {".".join(split_path(p)): j for j, p in enumerate(paths)}
    matrix = np.eye(len(paths))
    seen = set()
    for row in spec:
        where = f"{_FIELD}[{len(seen)}]"
        if len(row) != 3 or not isinstance(row[1], str) or isinstance(row[2], (bool, str)):
            raise SceneError(where, f"a pair is [path_a, path_b, rho], got {list(row)!r}")
        ij = []
        for p in row[:2]:
            key = ".".join(split_path(p))
            if key not in index:
                raise SceneError(where, f"{p!r} is not a sampled input; the sampled inputs are "
                                        f"{', '.join(paths)}")
            ij.append(index[key])
        pair = tuple(sorted(ij))
        if pair[0] == pair[1] or pair in seen:
            raise SceneError(where, f"each pair names two different inputs once; got {list(row)!r}")
        seen.add(pair)
        try:
            rho = float(row[2])
        except (TypeError, ValueError):
            raise SceneError(where, f"rho must be a number, got {row[2]!r}") from None
        matrix[ij[0], ij[1]] = matrix[ij[1], ij[0]] = rho
    return matrix


def _check_correlation(matrix: np.ndarray, paths: list, marginals: dict) -> None:
    if not np.all(np.isfinite(matrix)):
        raise SceneError(_FIELD, "every correlation must be a finite number")
    d = len(paths)
    for i in range(d):
        if matrix[i, i] != 1:
            raise SceneError(_FIELD, f"the diagonal must be 1 (an input's correlation with "
                                     f"itself); entry [{i}][{i}] ({paths[i]}) is {matrix[i, i]:g}")
        for j in range(i + 1, d):
            if matrix[i, j] != matrix[j, i]:
                raise SceneError(_FIELD, f"the matrix must be symmetric; [{i}][{j}] = "
                                         f"{matrix[i, j]:g} but [{j}][{i}] = {matrix[j, i]:g}")
            if matrix[i, j] != 0 and any(_is_choice(marginals[paths[k]]) for k in (i, j)):
                k = i if _is_choice(marginals[paths[i]]) else j
                raise SceneError(_FIELD, f"{paths[k]} is a choice (equally likely values, with "
                                         "ties): it cannot be rank-correlated; give it a "
                                         "continuous distribution or correlation 0")
    for what, m in (("", matrix), (" once turned into the normal scores' correlation "
                                   "2 sin(pi rho/6) of the Gaussian copula", normal_scores(matrix))):
        try:
            np.linalg.cholesky(m)
        except np.linalg.LinAlgError:
            low = np.linalg.eigvalsh(m)[0]
            raise SceneError(_FIELD, f"the rank correlation matrix must be positive definite"
                                     f"{what} (its smallest eigenvalue is {low:.3g}): no inputs "
                                     "can have these correlations together") from None


def correlated_pairs(spec) -> dict:
    """``(path_a, path_b)`` → requested rank correlation, for every correlated pair."""
    if spec.rank_correlation is None:
        return {}
    paths, r = list(spec.marginals), spec.rank_correlation
    return {(paths[i], paths[j]): float(r[i, j]) for i in range(len(paths))
            for j in range(i + 1, len(paths)) if r[i, j] != 0}
