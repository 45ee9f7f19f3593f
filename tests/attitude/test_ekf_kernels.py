"""worker.estimation.ekf_kernels (numba) against the straightforward numpy versions they replace, on random inputs:
bit for bit where the filter's results must not change."""
from __future__ import annotations

import numpy as np

from worker.estimation.ekf_kernels import gather_AHt, gather_HA, warm_up


def _rows(rng, n, m, k):
    cols = np.stack([rng.choice(n, size=k, replace=False) for _ in range(m)]).astype(np.int64)
    cols[rng.random((m, k)) < 0.2] = -1                  # unused slots (their coefficients are ignored)
    return cols, rng.normal(size=(m, k))


def test_gathers_equal_numpy_einsum_bit_for_bit():
    rng = np.random.default_rng(3)
    for n, m, k in ((5, 1, 1), (12, 7, 4), (57, 54, 5), (60, 80, 5)):
        A = rng.normal(size=(n, n))
        cols, coef = _rows(rng, n, m, k)
        c, w = np.where(cols >= 0, cols, 0), np.where(cols >= 0, coef, 0.0)
        ref = np.einsum("nmk,mk->nm", A[:, c], w)             # A H^T
        out = gather_AHt(A, cols, coef)
        assert out.shape == (n, m) and np.array_equal(out, ref)
        # same memory order as the einsum (Fortran): the BLAS products after it then give the same bits
        assert out.flags.f_contiguous == ref.flags.f_contiguous and out.flags.c_contiguous == ref.flags.c_contiguous
        H = np.zeros((m, n))
        for r in range(m):
            for j in range(k):
                if cols[r, j] >= 0:
                    H[r, cols[r, j]] += coef[r, j]
        assert np.allclose(out, A @ H.T, rtol=1e-12, atol=1e-12)
        B = rng.normal(size=(n, 9))
        ref2 = np.einsum("mkj,mk->mj", B[c, :], w)             # H B
        assert np.array_equal(gather_HA(B, cols, coef), ref2)
        assert np.allclose(gather_HA(B, cols, coef), H @ B, rtol=1e-12, atol=1e-12)


def test_warm_up_runs():
    warm_up()
