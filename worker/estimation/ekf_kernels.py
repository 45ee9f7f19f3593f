"""Compiled (numba) kernels of the EKF building blocks in worker.estimation.ekf: the sparse-row gathers of the
Joseph update.

Each kernel is a small pure function over arrays that replaces a handful of numpy calls on small arrays (a few
microseconds of call overhead each, ~10^4 calls per pass); tests/attitude/test_ekf_kernels.py compares every
kernel with the straightforward numpy version on random inputs. Compiled with ``cache=True``: the first call in
a fresh environment compiles (see `warm_up` and docs/attitude.md "Speed"), later processes load the cache.

Implements: nothing new; each kernel cites the equation of the numpy code it replaces.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["gather_AHt", "gather_HA", "warm_up"]


@njit(cache=True, nogil=True)
def gather_AHt(A, cols, coef):
    """A H^T (n, m) for H given by sparse rows: out[i, r] = sum_j coef[r, j] A[i, cols[r, j]] over cols >= 0.

    A (n, n_state) C-contiguous; cols (m, k) int64 (-1 = no term); coef (m, k). The gather
    `np.einsum("nmk,mk->nm", A[:, c], w)` of worker.estimation.ekf.joseph_update_sparse (P H^T, (A P) H^T).
    """
    n = A.shape[0]
    m, kk = cols.shape
    out = np.zeros((m, n))                # returned transposed: Fortran order, as the einsum it replaces
    for r in range(m):
        for i in range(n):
            acc = 0.0
            for j in range(kk):
                c = cols[r, j]
                if c >= 0:
                    acc += coef[r, j] * A[i, c]
            out[r, i] = acc
    return out.T


@njit(cache=True, nogil=True)
def gather_HA(A, cols, coef):
    """H A (m, n) for H given by sparse rows: out[r, :] = sum_j coef[r, j] A[cols[r, j], :] over cols >= 0.

    The row gather `np.einsum("mkj,mk->mj", A[c, :], w)` of worker.estimation.ekf.joseph_update_sparse
    (S = H (P H^T)).
    """
    m, kk = cols.shape
    n = A.shape[1]
    out = np.zeros((m, n))
    for r in range(m):
        for j in range(kk):
            c = cols[r, j]
            if c >= 0:
                w = coef[r, j]
                for i in range(n):
                    out[r, i] += w * A[c, i]
    return out


def warm_up() -> None:
    """Compile (or load from the cache) every kernel once on tiny inputs: at worker start or image build, so a
    job does not pay the compilation."""
    P = np.eye(9)
    cols = np.array([[0, 1, -1]], dtype=np.int64)
    gather_HA(gather_AHt(P, cols, np.ones((1, 3))), cols, np.ones((1, 3)))
