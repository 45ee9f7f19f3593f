"""Extended Kalman filter building blocks: Joseph-form measurement update (dense and sparse-row), RK4.

The attitude filter (gnssatt.attitude.filter) keeps a fixed-layout state with index maps and calls these with
measurement matrices whose rows touch only a few states (a baseline, a clock, one ambiguity). `joseph_update_sparse`
exploits that: H is given as (m, k) column indices and (m, k) coefficients, so P H^T and H P H^T are gathers, not
dense products, and only the O(n^2 m) products of the Joseph form remain (bench/design notes in docs/attitude.md).
The textbook forms (dense Joseph update, RK4 rotation) live in gnssatt.estimation.ekf_reference, re-exported here.

Implements: Kalman (1960) update; Joseph form P+ = (I - K H) P (I - K H)^T + K R K^T (Bucy & Joseph 1968;
Gelb 1974 eq. 4.2-21), valid for any gain, so it also serves the zero-variance ambiguity pseudo-measurement;
classical fourth-order Runge-Kutta with a fixed step (Butcher 2008, eq. 235a).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.linalg.lapack import dpotrf as _potrf, dpotrs as _potrs

from gnssatt.estimation.ekf_kernels import gather_AHt, gather_HA, joseph_combine, symmetric_plus_diag
# the textbook numpy forms live in ekf_reference (the specification the kernels are tested against); re-exported
from gnssatt.estimation.ekf_reference import joseph_update, rotation_rk4_stm, sparse_rows_to_dense  # noqa: F401

__all__ = ["joseph_update", "joseph_update_sparse", "rk4_step", "rk4_integrate", "rotation_rk4_stm",
           "sparse_rows_to_dense"]


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
