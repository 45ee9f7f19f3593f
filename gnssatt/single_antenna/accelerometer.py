"""The accelerometer model of seed 001 sec. VI and its inversion: the lever-arm and angular-rate terms.

A_meas = A_b + omega x (omega x d) + omega_dot x d + A_bias + noise, with A_b the specific force at the
body origin (here the GNSS antenna's phase centre: the point whose velocity the GNSS gives), d the lever arm
from it to the accelerometer (body frame), omega the angular rate of the body relative to inertial space
(body axes) and omega_dot its time derivative. Also the angular rate from a series of attitudes (when no
gyro is given): with R = R_body_from_ecef, dR/dt = -[w_eb x] R, and omega = w_eb + R omega_E.

Implements: seed 001 sec. VI (after its ref. 34), the rigid-body transport of acceleration (Savage 1998 eq.
6.2.1-1); the finite-difference angular rate is the skew part of R_{k+1} R_k^T over the step.
Neglects: scale-factor and misalignment errors of the accelerometer, its sensitivity to the gyro rate.
"""
from __future__ import annotations

import numpy as np

from gnssatt.single_antenna.gravity import OMEGA_ECEF_RAD_S


def lever_arm_terms_m_s2(omega_body_rad_s, omega_dot_body_rad_s2, lever_body_m) -> np.ndarray:
    """omega x (omega x d) + omega_dot x d (..., 3), body axes, m/s^2."""
    w = np.asarray(omega_body_rad_s, dtype=np.float64)
    d = np.asarray(lever_body_m, dtype=np.float64)
    return np.cross(w, np.cross(w, d)) + np.cross(np.asarray(omega_dot_body_rad_s2, dtype=np.float64), d)


def accelerometer_model_m_s2(f_origin_body_m_s2, omega_body_rad_s, omega_dot_body_rad_s2, lever_body_m,
                             bias_m_s2=0.0) -> np.ndarray:
    """Noise-free reading (..., 3) of an accelerometer at lever arm d: seed 001 sec. VI's A_meas without noise."""
    return (np.asarray(f_origin_body_m_s2, dtype=np.float64)
            + lever_arm_terms_m_s2(omega_body_rad_s, omega_dot_body_rad_s2, lever_body_m) + bias_m_s2)


def angular_rate_from_attitude(t_s: np.ndarray, R_body_from_ecef: np.ndarray) -> np.ndarray:
    """omega (n, 3) rad/s of the body relative to inertial space in body axes from a series of attitudes.

    Central differences inside, one-sided at the ends; NaN attitudes give NaN rates around them.
    """
    t = np.asarray(t_s, dtype=np.float64)
    R = np.asarray(R_body_from_ecef, dtype=np.float64)
    n = len(t)
    w = np.full((n, 3), np.nan)
    if n < 2:
        return w
    i0 = np.clip(np.arange(n) - 1, 0, n - 1)
    i1 = np.clip(np.arange(n) + 1, 0, n - 1)
    i0[0], i1[-1] = 0, n - 1
    dR = R[i1] @ np.swapaxes(R[i0], -1, -2)                     # ~ I - [w x] dt
    dt = (t[i1] - t[i0])[:, None]
    skew = 0.5 * (np.swapaxes(dR, -1, -2) - dR)                  # [w x] dt
    w_eb = np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], -1) / dt
    return w_eb + np.einsum("nij,j->ni", R, OMEGA_ECEF_RAD_S)
