"""gnssatt.estimation.ekf_kernels (numba) against the straightforward numpy versions they replace, on random inputs:
bit for bit where the filter's results must not change."""
from __future__ import annotations

import numpy as np

from gnssatt.estimation.ekf import _skew, rotation_rk4_stm
from gnssatt.estimation.ekf_kernels import (gather_AHt, gather_HA, joseph_combine, propagate_rotation_cov,
                                          rotation_rk4_stm_kernel, symmetric_plus_diag, warm_up)


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


def test_symmetrising_kernels_equal_numpy():
    rng = np.random.default_rng(6)
    for n in (1, 5, 57):
        S, R = rng.normal(size=(n, n)), rng.uniform(size=n)
        ref = 0.5 * (S + S.T)
        ref[np.diag_indices_from(ref)] += R
        assert np.array_equal(symmetric_plus_diag(S, R), ref)
        AP, X, Y = rng.normal(size=(3, n, n))
        Q = AP - X + Y
        out = joseph_combine(AP, X, Y)
        assert np.array_equal(out, 0.5 * (Q + Q.T)) and out.flags.c_contiguous


def test_rotation_kernel_equals_numpy_version():
    rng = np.random.default_rng(4)
    for _ in range(300):
        nb = int(rng.integers(1, 4))
        b, w = rng.normal(size=(nb, 3)), rng.normal(size=3) * 10.0 ** rng.uniform(-4, -1)
        dt = float(rng.choice([1.0, 0.2, 2.0, 3.7]))
        y0, pbb0, pbw0 = rotation_rk4_stm(b, w, dt, 1.0)
        y1, pbb1, pbw1 = rotation_rk4_stm_kernel(b, w, dt, 1.0)
        assert np.array_equal(y0, y1) and np.array_equal(pbw0, pbw1)
        assert np.array_equal(pbb0, np.broadcast_to(pbb1, pbb0.shape))


def _propagate_numpy(P, b_idx, Pbb, Pbw, Qw, b1, dt):
    """The dynamic filter's covariance propagation as plain numpy (Phi P Phi^T + Q, Van Loan to leading order)."""
    nb = b_idx.shape[0]
    sub = np.concatenate([np.arange(3), b_idx.ravel()])
    Phi = np.eye(sub.size)
    for j in range(nb):
        r = 3 + 3 * j
        Phi[r:r + 3, r:r + 3], Phi[r:r + 3, 0:3] = Pbb, Pbw[j]
    P = P.copy()
    P[sub, :] = Phi @ P[sub, :]
    P[:, sub] = P[:, sub] @ Phi.T
    Q = np.zeros((sub.size, sub.size))
    Q[0:3, 0:3] = Qw * dt
    B = [-_skew(b1[j]) for j in range(nb)]
    for j in range(nb):
        r = 3 + 3 * j
        Q[r:r + 3, 0:3] = B[j] @ Qw * dt ** 2 / 2
        Q[0:3, r:r + 3] = Q[r:r + 3, 0:3].T
        for i in range(nb):
            Q[r:r + 3, 3 + 3 * i:6 + 3 * i] = B[j] @ Qw @ B[i].T * dt ** 3 / 3
    P[np.ix_(sub, sub)] += Q
    return P


def test_rotation_covariance_propagation_equals_numpy():
    rng = np.random.default_rng(5)
    for _ in range(200):
        nb, n = int(rng.integers(1, 4)), int(rng.integers(25, 70))
        A = rng.normal(size=(n, n))
        P = A @ A.T
        b_idx = (3 + 7 * np.arange(nb))[:, None] + np.arange(3)[None, :]
        b1, Pbb, Pbw = rotation_rk4_stm_kernel(rng.normal(size=(nb, 3)), rng.normal(size=3) * 1e-2, 1.0, 1.0)
        M = rng.normal(size=(3, 3))
        Qw, dt = M @ M.T * 1e-6, float(rng.choice([1.0, 2.0]))
        ref = _propagate_numpy(P, b_idx, Pbb, Pbw, Qw, b1, dt)
        out = P.copy()
        propagate_rotation_cov(out, np.arange(3), b_idx, Pbb, Pbw, Qw, b1, dt)
        assert np.array_equal(out, ref)
        # and the textbook form: the full Phi of the state
        Phi = np.eye(n)
        for j in range(nb):
            Phi[np.ix_(b_idx[j], b_idx[j])], Phi[np.ix_(b_idx[j], np.arange(3))] = Pbb, Pbw[j]
        Qf = ref - Phi @ P @ Phi.T
        assert np.allclose(Qf, Qf.T, atol=1e-9) and np.allclose(Qf[:3, :3], Qw * dt, atol=1e-12)


def test_warm_up_runs():
    warm_up()
