"""Extended Kalman filter building blocks: Joseph-form measurement update (dense and sparse-row), RK4.

The attitude filter (gnssatt.attitude.filter) keeps a fixed-layout state with index maps and calls these with
measurement matrices whose rows touch only a few states (a baseline, a clock, one ambiguity). `joseph_update_sparse`
exploits that: H is given as (m, k) column indices and (m, k) coefficients, so P H^T and H P H^T are gathers, not
dense products, and only the O(n^2 m) products of the Joseph form remain (bench/design notes in docs/attitude.md).

Implements: Kalman (1960) update; Joseph form P+ = (I - K H) P (I - K H)^T + K R K^T (Bucy & Joseph 1968;
Gelb 1974 eq. 4.2-21), valid for any gain, so it also serves the zero-variance ambiguity pseudo-measurement;
classical fourth-order Runge-Kutta with a fixed step (Butcher 2008, eq. 235a).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.linalg as sla
from scipy.linalg.lapack import dpotrf as _potrf, dpotrs as _potrs

from gnssatt.estimation.ekf_kernels import gather_AHt, gather_HA, joseph_combine, symmetric_plus_diag

__all__ = ["joseph_update", "joseph_update_sparse", "rk4_step", "rk4_integrate", "rotation_rk4_stm",
           "sparse_rows_to_dense"]


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


def joseph_update_sparse(x: np.ndarray, P: np.ndarray, cols: np.ndarray, coef: np.ndarray, R: np.ndarray,
                         innovation: np.ndarray):
    """(x_plus, P_plus, S, ok) after an update whose H rows have at most k non-zeros.

    Args:
        x (n,), P (n, n): prior.
        cols (m, k) int: state index of each non-zero of each row (-1 = unused, coefficient ignored).
        coef (m, k): the non-zero partials.
        R (m,): measurement variances (diagonal R; zero allowed if S stays positive definite).
        innovation (m,): observed minus computed.
    Returns ok = False (and the prior unchanged) if S is not positive definite.
    Implements: the Joseph form as in `joseph_update`, with P H^T = sum_j coef[:, j] P[:, cols[:, j]] computed
    by gathers (O(n m k)) and the three O(n^2 m) products  A P = P - K (P H^T)^T,  (A P) A^T = A P - (A P H^T) K^T,
    and K R K^T.
    """
    P = np.ascontiguousarray(P, dtype=np.float64)
    cols = np.ascontiguousarray(cols, dtype=np.int64)
    coef = np.ascontiguousarray(coef, dtype=np.float64)
    # P H^T (n, m) and S = H P H^T + R (m, m) by compiled gathers (gnssatt.estimation.ekf_kernels)
    PHt = gather_AHt(P, cols, coef)
    R = np.broadcast_to(np.asarray(R, dtype=np.float64), (cols.shape[0],))
    S = symmetric_plus_diag(gather_HA(PHt, cols, coef), R)
    # LAPACK potrf/potrs directly: what scipy's cho_factor/cho_solve call, without their per-call wrapper cost
    L, info = _potrf(S, lower=1, clean=0)
    if info != 0:
        return x, P, S, False
    Kt, info = _potrs(L, PHt.T, lower=1)
    if info != 0:
        return x, P, S, False
    K = Kt.T                                                     # (n, m)
    AP = P - K @ PHt.T                                           # (I - K H) P
    APHt = gather_AHt(AP, cols, coef)                            # (A P) H^T
    P_new = joseph_combine(AP, APHt @ K.T, (K * R) @ K.T)        # A P A^T + K R K^T, symmetrised
    return x + K @ innovation, P_new, S, True


def rk4_step(f: Callable[[np.ndarray], np.ndarray], y: np.ndarray, h: float) -> np.ndarray:
    """y(t + h) by one classical Runge-Kutta step of the autonomous ODE y' = f(y)."""
    k1 = f(y)
    k2 = f(y + 0.5 * h * k1)
    k3 = f(y + 0.5 * h * k2)
    k4 = f(y + h * k3)
    return y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def rk4_integrate(f: Callable[[np.ndarray], np.ndarray], y: np.ndarray, dt: float, max_step: float) -> np.ndarray:
    """y(t + dt) by fixed-step RK4 with ceil(|dt| / max_step) equal steps."""
    n = max(1, int(np.ceil(abs(dt) / max_step - 1e-12)))
    h = dt / n
    for _ in range(n):
        y = rk4_step(f, y, h)
    return y


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
    W = _skew(w)
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
            Jk = -_skew_batch(yk) + np.einsum("ij,njk->nik", W, Jk)
            yk = yk @ W.T
            acc_J += coef[k] * Jk
        y = y @ T.T
        Phi_bw = acc_J
        Phi_bb = T @ Phi_bb
    return y, np.broadcast_to(Phi_bb, (nb, 3, 3)).copy(), Phi_bw


_ZEROS33 = np.zeros((3, 3))



def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _skew_batch(v: np.ndarray) -> np.ndarray:
    out = np.zeros((v.shape[0], 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out
