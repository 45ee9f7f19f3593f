"""The attitude filter's time update in readable numpy (the "propagate" box of seed 000 Fig. 2): the dynamic
mode rotates the baselines with the common angular velocity (RK4) and propagates P with its transition and the
omega random-walk noise; the kinematic mode lets the baselines random-walk; both then reset the white-noise
clocks (a new receiver clock difference every epoch).

This is the specification of the compiled kernels gnssatt.attitude.qc_kernels.propagate_dynamic /
propagate_kinematic / reset_white_clocks (tests/attitude/test_qc_kernels.py). Plain numpy, no numba.

Implements: seed 000 sec. 2 eq. 2 (b' = omega x b, omega' = 0 + noise) with its "fixed step Runge-Kutta
integrator"; the clocks as white noise (seed 000 Table 1: re-initialised each epoch).
"""
from __future__ import annotations

import numpy as np

from gnssatt.estimation.ekf_reference import propagate_rotation_covariance, rotation_rk4_stm

__all__ = ["reset_white_clocks", "propagate_dynamic", "propagate_kinematic"]


def reset_white_clocks(x: np.ndarray, P: np.ndarray, white: np.ndarray,
                       var_m2: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, P) copies with the white-noise clock states `white` set to 0, uncorrelated, of variance var_m2."""
    x, P = x.copy(), P.copy()
    x[white] = 0.0
    P[white, :] = 0.0
    P[:, white] = 0.0
    P[white, white] = var_m2
    return x, P


def propagate_dynamic(x: np.ndarray, P: np.ndarray, b_idx: np.ndarray, Qw_rad2_s3: np.ndarray, dt_s: float,
                      max_step_s: float, white: np.ndarray, var_clock_m2: float):
    """(x, P, Phi_bb, Phi_bw) after dt_s in the dynamic mode: omega x[0:3], baselines x[b_idx] (n_b, 3) rotated
    by RK4 (steps <= max_step_s), P <- Phi P Phi^T + Q, then the white clocks reset. Phi_bb (n_b, 3, 3) and
    Phi_bw (n_b, 3, 3) are the transition blocks (the smoother's input).
    Implements: seed 000 sec. 2 eq. 2 (gnssatt.estimation.ekf_reference.rotation_rk4_stm,
    propagate_rotation_covariance)."""
    x = x.copy()
    b1, Phi_bb, Phi_bw = rotation_rk4_stm(x[b_idx.ravel()].reshape(-1, 3), x[0:3], dt_s, max_step_s)
    x[b_idx.ravel()] = b1.ravel()
    P = propagate_rotation_covariance(P, np.arange(3), b_idx, Phi_bb[0], Phi_bw, Qw_rad2_s3, b1, dt_s)
    x, P = reset_white_clocks(x, P, white, var_clock_m2)
    return x, P, Phi_bb, Phi_bw


def propagate_kinematic(x: np.ndarray, P: np.ndarray, b_flat: np.ndarray, q_dt_m2: float, white: np.ndarray,
                        var_clock_m2: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, P) after one step of the kinematic mode: each baseline coordinate b_flat gains q_dt_m2 of variance
    (random walk), then the white clocks reset. Implements: seed 000 sec. 2 (kinematic alternative)."""
    P = P.copy()
    P[b_flat, b_flat] += q_dt_m2
    return reset_white_clocks(x, P, white, var_clock_m2)
