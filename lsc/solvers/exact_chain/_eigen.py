"""The eigenproblems of a segment's modes, each solved to the accuracy its grading allows:
the eigenvectors block by block of coupled vehicles (:func:`_block_eigh`), the eigenvalues as
squared singular values of the stiffness factor (:func:`_factor_kappa`, shared with the batch)."""

from __future__ import annotations

import numpy as np


def _block_eigh(A, R):
    """``eigh`` of ``A`` (n, n) one block of coupled vehicles at a time (a contact of zero slope
    couples nothing, :func:`_blocks`), each block's eigenvalues of least magnitude, as many as
    its rigid modes (columns of ``R``, each a non-zero translation), NaN: one ``eigh`` of all
    gives each vector to rounding of the largest eigenvalue over the gap, and a soft group
    beside a line 1e18 times stiffer lost its mode."""
    n = A.shape[0]
    lam, V = np.full(n, np.nan), np.zeros((n, n))
    blocks = _blocks(A)
    if blocks is None:   # (one block: all coupled)
        values, vectors = np.linalg.eigh(A)
        keep = np.argsort(np.abs(values))[R.shape[1]:]
        lam[keep] = values[keep]
        V[:, keep] = vectors[:, keep]
        return lam, V
    for idx in blocks:
        values, vectors = np.linalg.eigh(A[np.ix_(idx, idx)])
        rigid = int(np.count_nonzero(np.any(R[idx] != 0, axis=0)))
        keep = np.argsort(np.abs(values))[rigid:]
        lam[idx[keep]] = values[keep]
        V[np.ix_(idx, idx[keep])] = vectors[:, keep]
    return lam, V


def _blocks(A) -> list | None:
    """The index arrays of the blocks of coupled vehicles of ``A`` (n, n), ``None`` where all
    are one block: where ``A`` is tridiagonal (a chain: a contact couples two neighbours), its
    runs split where the coupling to the next is zero; else the connected components of
    ``A != 0``. (On Python floats: a handful of vehicles, NumPy's calls cost more.)"""
    rows, n = A.tolist(), A.shape[0]
    if not any(rows[i][j] for i in range(n) for j in range(i + 2, n)):
        cuts = [i + 1 for i in range(n - 1) if rows[i][i + 1] == 0]
        return [np.arange(a, b) for a, b in zip([0] + cuts, cuts + [n])] if cuts else None
    blocks, seen, coupled = [], np.zeros(n, bool), A != 0
    for start in range(n):
        if seen[start]:
            continue
        block, grow = np.zeros(n, bool), np.arange(n) == start
        while grow.any():   # (the vehicles reached through couplings)
            block |= grow
            grow = coupled[grow].any(axis=0) & ~block
        seen |= block
        blocks.append(np.flatnonzero(block))
    return blocks if len(blocks) > 1 else None


def _factor_kappa(B, n: int):
    """The ``n`` largest eigenvalues (ascending) [1/s²] of ``Bᵀ B``: the squared singular
    values of ``B`` (..., K, N), each to near full relative accuracy (SVD of ``Bᵀ``, whose
    columns carry the stiffnesses' grading: within 4e-15 of a 50-digit eigensolve on chains of
    masses 1:1000 and slopes 1:1e11, where ``eigh`` of ``Bᵀ B`` is up to 1e-5 off; the SVD of
    ``B`` itself 4e-11). Stacked ``B`` (the batch's members) give each member's values as one
    alone would: one LAPACK call per matrix. An open contact's zero row adds a zero singular
    value only, below the ``n`` kept."""
    sigma = np.linalg.svd(np.swapaxes(B, -1, -2), compute_uv=False)   # (descending)
    return sigma[..., :n][..., ::-1] ** 2
