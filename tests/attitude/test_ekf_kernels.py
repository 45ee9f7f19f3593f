"""gnssatt.estimation.ekf_kernels (numba) against the textbook numpy forms of gnssatt.estimation.ekf_reference and
dense numpy products, on random inputs, through one adapter per kernel (tests/attitude/_kernel_calls.py); floats
within rounding bounds of the operations involved (stated per test), never bit equality."""
from __future__ import annotations

import numpy as np

from gnssatt.estimation.ekf_reference import (propagate_rotation_covariance, rotation_rk4_stm,
                                              sparse_rows_to_dense)
from gnssatt.gnss.rotations import skew
from tests.attitude._kernel_calls import (call_gather_AHt, call_gather_HA, call_joseph_combine,
                                          call_propagate_rotation_cov, call_rotation_rk4_stm,
                                          call_symmetric_plus_diag, close)

EPS = np.finfo(float).eps


def _rows(rng, n, m, k):
    cols = np.stack([rng.choice(n, size=k, replace=False) for _ in range(m)]).astype(np.int64)
    cols[rng.random((m, k)) < 0.2] = -1                  # unused slots (their coefficients are ignored)
    return cols, rng.normal(size=(m, k))


def test_gathers_equal_the_dense_products():
    """A H^T and H B by gathers against the dense products: within k eps (|A| |H|^T) (a sum of k products in
    any order); A H^T in the memory order of numpy's einsum (the BLAS products after it depend on it)."""
    rng = np.random.default_rng(3)
    for n, m, k in ((5, 1, 1), (12, 7, 4), (57, 54, 5), (60, 80, 5)):
        A = rng.normal(size=(n, n))
        cols, coef = _rows(rng, n, m, k)
        H = sparse_rows_to_dense(cols, coef, n)
        out = call_gather_AHt(A, cols, coef)
        assert out.shape == (n, m)
        close(out, A @ H.T, atol=k * EPS * (np.abs(A) @ np.abs(H).T).max(), what="A H^T")
        c, w = np.where(cols >= 0, cols, 0), np.where(cols >= 0, coef, 0.0)
        ref = np.einsum("nmk,mk->nm", A[:, c], w)
        assert out.flags.f_contiguous == ref.flags.f_contiguous and out.flags.c_contiguous == ref.flags.c_contiguous
        B = rng.normal(size=(n, 9))
        close(call_gather_HA(B, cols, coef), H @ B, atol=k * EPS * (np.abs(H) @ np.abs(B)).max(), what="H B")


def test_symmetrising_kernels_equal_numpy():
    """0.5 (S + S^T) + diag(R) and 0.5 (Q + Q^T), Q = AP - X + Y: within 4 eps of the magnitudes (2-3 roundings)."""
    rng = np.random.default_rng(6)
    for n in (1, 5, 57):
        S, R = rng.normal(size=(n, n)), rng.uniform(size=n)
        ref = 0.5 * (S + S.T)
        ref[np.diag_indices_from(ref)] += R
        close(call_symmetric_plus_diag(S, R), ref, atol=4 * EPS * (np.abs(S).max() + 1.0), what="S + R")
        AP, X, Y = rng.normal(size=(3, n, n))
        Q = AP - X + Y
        out = call_joseph_combine(AP, X, Y)
        close(out, 0.5 * (Q + Q.T), atol=4 * EPS * 3 * max(np.abs(AP).max(), np.abs(X).max(), np.abs(Y).max()))
        assert out.flags.c_contiguous
        close(out, out.T, atol=4 * EPS * 3 * np.abs(out).max(), what="symmetric")


def test_rotation_kernel_equals_numpy_version():
    """RK4 rotation against ekf_reference.rotation_rk4_stm: b within 1e-13 of |b| (m), Phi_bb within 1e-13
    (dimensionless), Phi_bw within 1e-13 |b| dt (m s) (a few steps of 3x3 products)."""
    rng = np.random.default_rng(4)
    for _ in range(300):
        nb = int(rng.integers(1, 4))
        b, w = rng.normal(size=(nb, 3)), rng.normal(size=3) * 10.0 ** rng.uniform(-4, -1)
        dt = float(rng.choice([1.0, 0.2, 2.0, 3.7]))
        y0, pbb0, pbw0 = rotation_rk4_stm(b, w, dt, 1.0)
        y1, pbb1, pbw1 = call_rotation_rk4_stm(b, w, dt, 1.0)
        scale = np.abs(b).max()
        close(y1, y0, atol=1e-13 * scale, what="b (m)")
        close(np.broadcast_to(pbb1, pbb0.shape), pbb0, atol=1e-13, what="Phi_bb")
        close(pbw1, pbw0, atol=1e-13 * scale * dt, what="Phi_bw")


def test_rotation_covariance_propagation_equals_numpy():
    """Phi P Phi^T + Q against ekf_reference.propagate_rotation_covariance: within 1e-13 of sigma_i sigma_j
    (products of n ~ 70 terms of O(1) conditioning)."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        nb, n = int(rng.integers(1, 4)), int(rng.integers(25, 70))
        A = rng.normal(size=(n, n))
        P = A @ A.T
        b_idx = (3 + 7 * np.arange(nb))[:, None] + np.arange(3)[None, :]
        b1, Pbb, Pbw = call_rotation_rk4_stm(rng.normal(size=(nb, 3)), rng.normal(size=3) * 1e-2, 1.0, 1.0)
        M = rng.normal(size=(3, 3))
        Qw, dt = M @ M.T * 1e-6, float(rng.choice([1.0, 2.0]))
        ref = propagate_rotation_covariance(P, np.arange(3), b_idx, Pbb, Pbw, Qw, b1, dt)
        out = call_propagate_rotation_cov(P, np.arange(3), b_idx, Pbb, Pbw, Qw, b1, dt)
        d = np.sqrt(np.diag(ref))
        assert np.max(np.abs(out - ref) / np.outer(d, d)) < 1e-13
        # and the textbook form: the full Phi of the state
        Phi = np.eye(n)
        for j in range(nb):
            Phi[np.ix_(b_idx[j], b_idx[j])], Phi[np.ix_(b_idx[j], np.arange(3))] = Pbb, Pbw[j]
        Qf = ref - Phi @ P @ Phi.T
        assert np.allclose(Qf, Qf.T, atol=1e-9) and np.allclose(Qf[:3, :3], Qw * dt, atol=1e-12)
        B = -skew(b1[0])
        assert np.allclose(Qf[b_idx[0]][:, :3], B @ Qw * dt ** 2 / 2, atol=1e-9)


def test_warm_up_runs():
    from gnssatt.estimation.ekf_kernels import warm_up

    warm_up()
