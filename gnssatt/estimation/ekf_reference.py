"""The EKF's textbook forms in plain numpy: the specification the compiled kernels of
gnssatt.estimation.ekf_kernels are tested against (tests/attitude/test_ekf_kernels.py, test_update_kernels.py), and
the readable reference of the attitude filter's propagation and update (gnssatt.attitude.reference_*).

Plain numpy and scipy, no numba: each function is written for reading, not speed.

Implements: Kalman (1960) update in the Joseph form P+ = (I - K H) P (I - K H)^T + K R K^T (Bucy & Joseph 1968;
Gelb 1974 eq. 4.2-21); seed 000 sec. 2 eq. 2 baseline rotation by RK4 with its transition matrix; the discrete
process noise of the omega random walk (Van Loan 1978, leading order in dt).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from gnssatt.gnss.rotations import skew

__all__ = ["sparse_rows_to_dense", "joseph_update", "rotation_rk4_stm", "propagate_rotation_covariance"]


def sparse_rows_to_dense(cols: np.ndarray, coef: np.ndarray, n: int) -> np.ndarray:
    """Dense H (m, n) from column indices cols (m, k) and coefficients coef (m, k) (-1 columns are skipped)."""
    m = cols.shape[0]
    H = np.zeros((m, n))
    ok = cols >= 0
    rows = np.broadcast_to(np.arange(m)[:, None], cols.shape)
    np.add.at(H, (rows[ok], cols[ok]), coef[ok])
    return H


def joseph_update(x: np.ndarray, P: np.ndarray, H: np.ndarray, R: np.ndarray, innovation: np.ndarray):
    """(x_plus (n,), P_plus (n, n), S (m, m)) after a linear(ised) update with dense H (m, n).

    Args:
        x, P: prior state and covariance.
        H: measurement partials; R: (m,) variances (diagonal) or (m, m) covariance (may be singular, e.g. 0 for
            a pseudo-measurement, as long as H P H^T + R is positive definite).
        innovation: (m,) observed minus computed at x.
    Implements: K = P H^T S^-1, S = H P H^T + R; P+ = (I - K H) P (I - K H)^T + K R K^T (Joseph).
    """
    PHt = P @ H.T
    S = H @ PHt
    Rm = np.diag(R) if np.ndim(R) == 1 else R
    S = S + Rm
    c = sla.cho_factor(S, lower=True, check_finite=False)
    K = sla.cho_solve(c, PHt.T, check_finite=False).T
    A = -K @ H
    A[np.diag_indices_from(A)] += 1.0
    P_new = A @ P @ A.T + K @ Rm @ K.T
    P_new = 0.5 * (P_new + P_new.T)
    return x + K @ innovation, P_new, S


def rotation_rk4_stm(b_m: np.ndarray, omega_rad_s: np.ndarray, dt_s: float, max_step_s: float = 1.0):
    """(b(t + dt) (n_b, 3), Phi_bb (n_b, 3, 3), Phi_bw (n_b, 3, 3)) of  b' = omega x b, omega' = 0  (seed 000 eq. 2).

    Args:
        b_m: (n_b, 3) baseline vectors (ECEF) at t; omega_rad_s: (3,) common angular velocity of the baselines
            as seen in ECEF (the platform rate relative to the Earth), constant over the step.
        dt_s: step; max_step_s: RK4 step size limit (ceil(dt / max_step) equal steps).
    Returns the propagated baselines and the state transition blocks d b(t+dt) / d b(t) and d b(t+dt) / d omega.
    Implements: seed 000 sec. 2 eq. 2 and its "fixed step Runge-Kutta integrator". With omega constant over a
    step the system is linear in b, b' = W b (W = [omega x]), and one classical RK4 step of size h is exactly
    b1 = (I + hW + (hW)^2/2 + (hW)^3/6 + (hW)^4/24) b0 (Butcher 2008 sec. 238), evaluated here by recurrence
    y_k = W y_(k-1) with the exact derivative d y_k / d omega = -[y_(k-1) x] + W d y_(k-1) / d omega (the
    variational equations integrated by the same RK4, Montenbruck & Gill 2000 sec. 7.1). tests/attitude checks
    it against `rk4_integrate` on the augmented system.
    """
    b = np.asarray(b_m, dtype=np.float64)
    w = np.asarray(omega_rad_s, dtype=np.float64)
    nb = b.shape[0]
    n = max(1, int(np.ceil(abs(dt_s) / max_step_s - 1e-12)))
    h = dt_s / n
    W = skew(w)
    # T = sum_k (hW)^k / k!, k = 0..4 (the RK4 polynomial of the linear step)
    hW = h * W
    hW2 = hW @ hW
    T = np.eye(3) + hW + hW2 / 2.0 + hW2 @ hW / 6.0 + hW2 @ hW2 / 24.0
    Phi_bb = np.eye(3)
    Phi_bw = np.zeros((nb, 3, 3))
    y = b.copy()
    coef = (1.0, h, h * h / 2.0, h ** 3 / 6.0, h ** 4 / 24.0)
    for _ in range(n):
        yk = y
        Jk = _ZEROS33[None].repeat(nb, 0)
        J1 = Phi_bw.copy()                    # d y / d omega accumulated over the previous sub-steps
        acc_J = np.einsum("ij,njk->nik", T, J1)  # d(T y0)/d omega through y0
        for k in range(1, 5):
            Jk = -skew(yk) + np.einsum("ij,njk->nik", W, Jk)
            yk = yk @ W.T
            acc_J += coef[k] * Jk
        y = y @ T.T
        Phi_bw = acc_J
        Phi_bb = T @ Phi_bb
    return y, np.broadcast_to(Phi_bb, (nb, 3, 3)).copy(), Phi_bw


_ZEROS33 = np.zeros((3, 3))


def propagate_rotation_covariance(P: np.ndarray, w_idx: np.ndarray, b_idx: np.ndarray, Phi_bb: np.ndarray,
                                  Phi_bw: np.ndarray, Qw_rad2_s3: np.ndarray, b1_m: np.ndarray,
                                  dt_s: float) -> np.ndarray:
    """Phi P Phi^T + Q (a new array) for the dynamic attitude filter's state (omega at w_idx (3,), baselines at
    b_idx (n_b, 3)); the other states are not transformed (identity rows of Phi) and get no noise.

    Phi is the identity except on the baseline rows: Phi_bb (3, 3) on b_j and Phi_bw[j] (3, 3) on omega
    (rotation_rk4_stm). Q is the discrete noise of the omega random walk of rate Qw over dt and its effect on the
    propagated baselines b1 (n_b, 3): Q_ww = Qw dt, Q_bw = B_j Qw dt^2 / 2, Q_bb = B_j Qw B_i^T dt^3 / 3 with
    B_j = -[b1_j x].
    Implements: seed 000 sec. 2 (covariance propagation of eq. 2); Van Loan (1978) to the leading order in dt.
    """
    n_b = b_idx.shape[0]
    sub = np.concatenate([np.asarray(w_idx), np.asarray(b_idx).ravel()])
    Phi = np.eye(n_b * 3 + 3)
    for j in range(n_b):
        r = 3 + 3 * j
        Phi[r:r + 3, r:r + 3], Phi[r:r + 3, 0:3] = Phi_bb, Phi_bw[j]
    P = np.array(P, dtype=np.float64)
    P[sub, :] = Phi @ P[sub, :]
    P[:, sub] = P[:, sub] @ Phi.T
    Q = np.zeros((sub.size, sub.size))
    Q[0:3, 0:3] = Qw_rad2_s3 * dt_s
    B = [-skew(b1_m[j]) for j in range(n_b)]
    for j in range(n_b):
        r = 3 + 3 * j
        Q[r:r + 3, 0:3] = B[j] @ Qw_rad2_s3 * dt_s ** 2 / 2
        Q[0:3, r:r + 3] = Q[r:r + 3, 0:3].T
        for i in range(n_b):
            Q[r:r + 3, 3 + 3 * i:6 + 3 * i] = B[j] @ Qw_rad2_s3 @ B[i].T * dt_s ** 3 / 3
    P[np.ix_(sub, sub)] += Q
    return P
