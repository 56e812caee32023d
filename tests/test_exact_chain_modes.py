"""The modes of exact-chain's segments (lsc/solvers/exact_chain/_modes.py) on graded chains:
every eigenvalue to high relative accuracy (against a 50-digit eigensolve), and the energy of a
long segment behind a very stiff line.

``eigh`` of ``A = M^{-1/2} Cᵀ diag(s) C M^{-1/2}`` gives every eigenvalue to rounding of the
largest: a slow mode behind an unloading line 1e10 times stiffer than its contact was 1.1e-6 off,
and a chain that spent 1.3 s pressed on such a line lost 3.7e-8 of its energy (the --hard run of
test_exact_chain_locks.py drew it). The eigenvalues are now the squared singular values of the
factor ``diag(√s) C M^{-1/2}`` (an SVD of its transpose, to near full relative accuracy), in
the single solve and the batch alike.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

import lsc
from hard.common import check_result, energy_error, momentum_error
from lsc.solvers.exact_chain._modes import Shape, deformation_map


def _exact_kappa(m, slope, held=()):
    """The non-zero eigenvalues of the free vehicles' ``A`` to 50 digits (ascending)."""
    mp.mp.dps = 50
    free = [i for i in range(len(m)) if i not in held]
    C = deformation_map(len(m))
    A = mp.matrix(len(free), len(free))
    for a, i in enumerate(free):
        for b, j in enumerate(free):
            A[a, b] = mp.fsum(mp.mpf(C[k, i]) * mp.mpf(s) * mp.mpf(C[k, j]) for k, s in
                              enumerate(slope)) / mp.sqrt(mp.mpf(m[i]) * mp.mpf(m[j]))
    values = sorted(mp.eigsy(A)[0], key=abs)
    return [float(v) for v in values]


@pytest.mark.parametrize("m,slope,held", [
    ([796.8, 604.4, 36.6], [100.0, 6.2e12], ()),                 # the locked chain's segment
    ([50.0, 900.0, 70.0, 400.0, 35.0], [1e3, 4e12, 2e2, 9e11], ()),
    ([120.0, 60.0, 300.0, 45.0], [5e2, 3e12, 0.0], ()),          # an open contact: two groups
    ([120.0, 60.0, 300.0, 45.0], [5e2, 3e12, 8e1], (3,)),       # a held front car: grounded
])
def test_every_eigenvalue_of_a_graded_chain_to_high_relative_accuracy(m, slope, held):
    m, slope = np.asarray(m), np.asarray(slope)
    shape = Shape(m, slope, -deformation_map(m.size).T, held)
    kappa = np.sort(shape.modes.kappa)
    exact = np.sort(_exact_kappa(m, slope, held))
    elastic = np.abs(exact) > 1e-20 * np.max(np.abs(exact))
    assert np.array_equal(kappa == 0, ~elastic)     # (the rigid modes exactly)
    assert np.max(np.abs(kappa[elastic] / exact[elastic] - 1)) <= 1e-13


#: The --hard draw: contact 0 (e = 1e-6) locks at once, contact 2 (a table, e = 1.8e-4) sits
#: on its unloading line (6.2e12 lbf/ft) for 1.3 s while the soft contact 1 (100 lbf/ft)
#: pushes.
STIFF_LINE_CHAIN = {
    "units": "US",
    "vehicles": [{"mass": 662.8168645059184, "speed": 36.603082676320774},
                 {"mass": 133.95944331434407, "speed": 0.00331512373195696},
                 {"mass": 604.42203981978, "speed": 0.0}, {"mass": 36.599767552588816, "speed": 0.0}],
    "contacts": [
        {"loading": {"stiffness": 108975.91113928046}, "unloading": {"restitution": 1e-6},
         "gap": 0.0},
        {"loading": {"stiffness": 100.0023026116027},
         "unloading": {"restitution": 0.030640487412450908}, "gap": 0.0},
        {"loading": {"table": [[0, 0], [0.1121106408827589, 23623.39394607045],
                               [0.2242212817655178, 23623.39394607045],
                               [1000, 2106701178.033842]]},
         "unloading": {"restitution": 0.00018383909696099749}, "gap": 0.0}]}


def test_a_long_segment_behind_a_very_stiff_line_keeps_its_energy():
    r = lsc.solve(STIFF_LINE_CHAIN)
    assert r.method == "exact-chain"
    assert energy_error(r) <= 1e-12      # (was 3.7e-8)
    assert momentum_error(r) <= 1e-14
    check_result(r)


@pytest.mark.parametrize("m,slope", [([796.8, 604.4, 36.6], [100.0, 6.2e12]),
                                     ([50.0, 900.0, 70.0, 400.0, 35.0], [1e3, 4e12, 2e2, 9e11])])
def test_the_batch_takes_the_same_eigenvalues(m, slope):
    """The batch's modes (stacked members) have the single solve's eigenvalues: the same SVD
    of each member's factor (eigh's and its Rayleigh quotients parted them by 2e-10)."""
    from lsc.solvers.exact_chain._batch_modes import BatchMotion

    m, slope = np.asarray(m), np.asarray(slope)
    C = deformation_map(m.size)
    single = np.sort(Shape(m, slope, -C.T).modes.kappa)
    stacked = np.repeat(m[None], 3, axis=0), np.repeat(slope[None], 3, axis=0)
    zeros = np.zeros_like(stacked[0])
    batch = BatchMotion(stacked[0], zeros, zeros, stacked[1], np.zeros_like(stacked[1]), C)
    for kappa in batch.kappa:
        assert np.array_equal(np.sort(kappa), single)


def test_the_blocks_of_coupled_vehicles_are_eigensolved_apart():
    """``_eigen._block_eigh``: a chain whose middle contact carries no slope (tridiagonal, its
    runs split) and a matrix coupling vehicles 0 and 2 only (the general components): each
    block's eigenpairs are its own ``eigh``'s, one rigid mode per block left out (NaN)."""
    from lsc.solvers.exact_chain._eigen import _block_eigh

    chain = np.array([[2.0, -2.0, 0.0, 0.0], [-2.0, 2.0, 0.0, 0.0],
                      [0.0, 0.0, 5e18, -5e18], [0.0, 0.0, -5e18, 5e18]])
    apart = np.array([[3.0, 0.0, -3.0], [0.0, 0.0, 0.0], [-3.0, 0.0, 3.0]])
    for A, blocks in ((chain, [[0, 1], [2, 3]]), (apart, [[0, 2], [1]])):
        n = A.shape[0]
        R = np.zeros((n, len(blocks)))
        for c, b in enumerate(blocks):
            R[b, c] = 1 / np.sqrt(len(b))
        lam, V = _block_eigh(A, R)
        assert np.count_nonzero(np.isnan(lam)) == len(blocks)
        for b in blocks:
            values, _ = np.linalg.eigh(A[np.ix_(b, b)])
            got = np.sort(lam[b][~np.isnan(lam[b])])
            np.testing.assert_array_equal(got, np.sort(values[np.argsort(np.abs(values))[1:]]))
            for j in np.flatnonzero(~np.isnan(lam)):   # (A v = λ v; zero off its block)
                np.testing.assert_allclose(A @ V[:, j], lam[j] * V[:, j], atol=1e-9 * abs(lam[j]))
        assert np.allclose(V.T @ V, np.diag(~np.isnan(lam)), atol=1e-15)
