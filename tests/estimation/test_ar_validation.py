"""Ratio test, conditional (fixed) baseline, length/angle validation, bootstrapped success rate, partial fixing."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gnssatt.estimation.ar_validation import (
    baseline_angle_test, baseline_length_test, bootstrap_success_rate, fixed_baseline, partial_fix, ratio_test,
)
from gnssatt.estimation.lambda_search import decorrelate, mlambda


def test_ratio_test():
    assert ratio_test([2.0, 7.0]) == (3.5, True)
    assert ratio_test([2.0, 5.0]) == (2.5, False)
    assert ratio_test([0.0, 1.0])[0] == math.inf
    with pytest.raises(ValueError):
        ratio_test([1.0])


def _linear_model(rng, n=6, q=3):
    """y = A a + B b + e with phase-like and code-like rows; returns the float LS solution and the parts."""
    A = np.vstack([np.eye(n), np.zeros((n, n))])
    B = rng.normal(size=(2 * n, q))
    W = np.diag(np.r_[np.full(n, 1 / 0.01**2), np.full(n, 1 / 0.5**2)])
    a_true = rng.integers(-20, 20, n)
    b_true = rng.normal(size=q)
    y = A @ a_true + B @ b_true + np.r_[rng.normal(0, 0.01, n), rng.normal(0, 0.5, n)]
    H = np.hstack([A, B])
    Qx = np.linalg.inv(H.T @ W @ H)
    x = Qx @ H.T @ W @ y
    return x[:n], x[n:], Qx[:n, :n], Qx[n:, n:], Qx[n:, :n], (y, A, B, W, a_true)


def test_fixed_baseline_equals_least_squares_with_known_integers():
    rng = np.random.default_rng(1)
    a_f, b_f, Qaa, Qbb, Qba, (y, A, B, W, a_true) = _linear_model(rng)
    b_fix, Q_cond = fixed_baseline(b_f, a_f, Qba, Qaa, a_true, Q_bb=Qbb)
    # independent: weighted LS of y - A a_true on B
    N = B.T @ W @ B
    b_ls = np.linalg.solve(N, B.T @ W @ (y - A @ a_true))
    np.testing.assert_allclose(b_fix, b_ls, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(Q_cond, np.linalg.inv(N), rtol=1e-7)
    # several candidates at once
    b2, _ = fixed_baseline(b_f, a_f, Qba, Qaa, np.vstack([a_true, a_true + 1]))
    assert b2.shape == (2, 3) and np.allclose(b2[0], b_fix)


def test_length_test():
    err, ok = baseline_length_test(np.array([[1.0, 0.0, 0.02], [0.0, 1.1, 0.0]]), [1.0, 1.0])
    assert ok.tolist() == [True, False]
    assert err[1] == pytest.approx(0.1)


def test_angle_test_rotation_invariant_and_detects_wrong_direction():
    rng = np.random.default_rng(2)
    F = np.array([[1.04653, -0.07191, 0.0], [0.0, 1.13969, 0.0], [0.5, 0.5, 0.3]])
    U, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    R = U * np.sign(np.linalg.det(U))
    err, ok = baseline_angle_test(F @ R.T, F)
    assert np.all(np.abs(err) < 1e-9) and ok.all() and err.shape == (3,)
    Bw = F @ R.T
    Bw[1] += 0.19 * R[:, 0]               # one wrong cycle along body x: ~10 deg on the 1.14 m baseline
    err, ok = baseline_angle_test(Bw, F)
    assert not ok[0] and ok[1] is not None


def test_bootstrap_success_rate_matches_monte_carlo():
    rng = np.random.default_rng(3)
    n = 5
    U, _ = np.linalg.qr(rng.normal(size=(n, n)))
    Q = (U * np.array([0.5, 0.2, 0.05, 0.02, 0.01])) @ U.T
    Q = 0.5 * (Q + Q.T)
    dec = decorrelate(Q)
    p_formula = bootstrap_success_rate(dec.d)
    # bootstrapping in the decorrelated space: sequential conditional rounding from level n-1 down
    Qz = dec.Z.T @ Q @ dec.Z
    N = 20000
    e = rng.multivariate_normal(np.zeros(n), Qz, size=N)
    L = dec.L
    ok = 0
    for k in range(N):
        zs = e[k]
        z = np.zeros(n)
        zb = np.zeros(n)
        for i in range(n - 1, -1, -1):
            zb[i] = zs[i] - L[i + 1:, i] @ (zb[i + 1:] - z[i + 1:])
            z[i] = np.floor(zb[i] + 0.5)
        ok += np.all(z == 0)
    p_mc = ok / N
    sigma = math.sqrt(p_formula * (1 - p_formula) / N)
    assert abs(p_mc - p_formula) < 4 * sigma + 1e-3, (p_mc, p_formula)


def test_partial_fix_subset_success():
    rng = np.random.default_rng(4)
    n = 8
    U, _ = np.linalg.qr(rng.normal(size=(n, n)))
    Q = (U * np.r_[5.0, 5.0 / 3, 0.5, np.full(n - 3, 5e-3)]) @ U.T
    Q = 0.5 * (Q + Q.T)
    full = bootstrap_success_rate(mlambda(np.zeros(n), Q).d)
    assert full < 0.9                     # the full set is not fixable reliably ...
    a_true = rng.integers(-50, 50, n)
    C = np.linalg.cholesky(Q)
    n_ok = n_trials = 0
    for _ in range(300):
        a = a_true + C @ rng.normal(size=n)
        pf = partial_fix(a, Q, min_success_rate=0.99)
        assert pf is not None and pf.success_rate >= 0.99
        assert 0 < pf.Z_sub.shape[1] < n  # ... but a subset is
        n_trials += 1
        n_ok += np.array_equal(pf.z_fixed[0], pf.Z_sub.T @ a_true)
        np.testing.assert_allclose(pf.Q_z, pf.Z_sub.T @ Q @ pf.Z_sub, rtol=1e-8, atol=1e-12)
    assert n_ok / n_trials >= 0.97
    assert partial_fix(np.zeros(2), np.eye(2) * 25.0, min_success_rate=0.999) is None
