"""gnssatt.estimation.ekf against textbook formulas and a generic RK4."""
from __future__ import annotations

import numpy as np

from gnssatt.estimation.ekf import (joseph_update, joseph_update_sparse, rk4_integrate,
                                   rotation_rk4_stm, sparse_rows_to_dense)
from gnssatt.gnss.rotations import skew


def _problem(rng, n=12, m=7, k=4):
    A = rng.normal(size=(n, n))
    P = A @ A.T + n * np.eye(n)
    cols = np.stack([rng.choice(n, size=k, replace=False) for _ in range(m)])
    cols[0, -1] = -1                                    # an unused slot
    coef = rng.normal(size=(m, k))
    R = rng.uniform(0.1, 2.0, size=m)
    return rng.normal(size=n), P, cols, coef, R, rng.normal(size=m)


def test_joseph_equals_textbook_kalman_update():
    rng = np.random.default_rng(0)
    x, P, cols, coef, R, v = _problem(rng)
    H = sparse_rows_to_dense(cols, coef, x.size)
    S = H @ P @ H.T + np.diag(R)
    K = P @ H.T @ np.linalg.inv(S)
    x_ref = x + K @ v
    P_ref = P - K @ H @ P
    x1, P1, _ = joseph_update(x, P, H, R, v)
    x2, P2, _, ok = joseph_update_sparse(x, P, cols, coef, R, v)
    assert ok
    for xx, PP in ((x1, P1), (x2, P2)):
        assert np.allclose(xx, x_ref, atol=1e-10)
        assert np.allclose(PP, P_ref, atol=1e-10)
        assert np.allclose(PP, PP.T)


def test_joseph_zero_variance_pseudo_measurement_keeps_psd():
    """A fix is a zero-variance constraint: the constrained combination must end with ~0 variance, P stays PSD."""
    rng = np.random.default_rng(1)
    x, P, _, _, _, _ = _problem(rng)
    cols = np.array([[3, 4], [5, 4]])
    coef = np.array([[1.0, -1.0], [1.0, -1.0]])
    x1, P1, _, ok = joseph_update_sparse(x, P, cols, coef, np.full(2, 1e-12), np.array([2.0, -1.0]) - (x[[3, 5]] - x[4]))
    assert ok
    assert abs((x1[3] - x1[4]) - 2.0) < 1e-6 and abs((x1[5] - x1[4]) + 1.0) < 1e-6
    d = np.zeros(x.size)
    d[3], d[4] = 1, -1
    assert d @ P1 @ d < 1e-9
    assert np.linalg.eigvalsh(P1).min() > -1e-9


def test_rotation_rk4_closed_form_equals_generic_rk4_with_variational_equations():
    rng = np.random.default_rng(2)
    b = rng.normal(size=(3, 3))
    w = rng.normal(size=3) * 0.05
    nb = b.shape[0]
    Wx = skew(w)

    def f(y):
        yb, pb, pw = y[:, :3], y[:, 3:12].reshape(nb, 3, 3), y[:, 12:21].reshape(nb, 3, 3)
        return np.concatenate([yb @ Wx.T, (Wx @ pb).reshape(nb, 9), (Wx @ pw - skew(yb)).reshape(nb, 9)], 1)

    for dt in (1.0, 2.5, 0.3):
        y, pbb, pbw = rotation_rk4_stm(b, w, dt, 1.0)
        y0 = np.concatenate([b, np.tile(np.eye(3).ravel(), (nb, 1)), np.zeros((nb, 9))], 1)
        y1 = rk4_integrate(f, y0, dt, 1.0)
        assert np.allclose(y, y1[:, :3], atol=1e-14)
        assert np.allclose(pbb, y1[:, 3:12].reshape(nb, 3, 3), atol=1e-14)
        assert np.allclose(pbw, y1[:, 12:21].reshape(nb, 3, 3), atol=1e-13)


def test_rotation_rk4_stm_matches_finite_differences_and_exact_rotation():
    b = np.array([[1.0, 0.2, -0.1]])
    w = np.radians([0.5, -1.0, 2.0])            # deg/s, a slew
    y, _, pbw = rotation_rk4_stm(b, w, 1.0)
    # exact solution: rotation about w by |w| dt (active), Rodrigues
    th = np.linalg.norm(w)
    k = w / th
    K = skew(k)
    R = np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K
    assert np.allclose(y[0], R @ b[0], atol=1e-10)        # RK4 error ~ (w dt)^5 / 120
    eps = 1e-7
    for i in range(3):
        dw = np.zeros(3)
        dw[i] = eps
        yp, _, _ = rotation_rk4_stm(b, w + dw, 1.0)
        ym, _, _ = rotation_rk4_stm(b, w - dw, 1.0)
        assert np.allclose((yp - ym)[0] / (2 * eps), pbw[0][:, i], atol=1e-7)
