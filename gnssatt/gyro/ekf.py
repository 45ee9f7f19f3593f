"""Multiplicative quaternion EKF of GPS attitude and gyro rates (seed 002 sec. 2.2; Lefferts, Markley & Shuster
1982, the "reduced covariance" of its reference [13]).

Attitude: q_body_from_gcrf (CONVENTIONS.md passive quaternion), propagated with the drift-compensated gyro
between GPS samples by eq. 9, q(t + dt) = exp(theta) (x) q(t), theta = (omega_m - beta_omega) dt (the closed form
of eq. 3 for a rate constant over the sample). Error state (9): the body-frame small rotation dtheta
(R_true = (I - [dtheta x]) R_est), the gyro drift beta_omega and the GPS attitude's Gauss-Markov part beta_theta:

    d(dtheta)/dt = -[omega x] dtheta - d(beta_omega) - e_omega,      e_omega: white, N^2 (angle random walk)
    d(beta_omega)/dt = -beta_omega / tau_omega + w_omega,             stationary sigma: the drift stability
    d(beta_theta)/dt = -beta_theta / tau_theta + w_theta,             stationary covariance: the snapshot's
                                                                      multipath part (gnssatt.gyro.snapshot)
    Z = dtheta + beta_theta + e_theta,                                e_theta: the snapshot's white part,

with Z the rotation vector of q_gps (x) q_est^-1. Update in Joseph form, then the reset
q <- exp(dtheta_hat) (x) q, beta_omega += d(beta_omega)_hat, dtheta_hat = 0.
The propagation kernels are compiled (numba); `propagate_reference` is their readable numpy form (tests compare).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = ["FilterState", "NoiseRates", "propagate", "propagate_reference", "update", "quat_exp", "quat_mul",
           "rotvec_of"]

N_STATE = 9


@dataclass
class NoiseRates:
    """Process noise of one interval: arw2 (rad^2/s), drift sigma (rad/s) and tau (s), beta_theta (3, 3) rad^2
    stationary covariance and its tau (s)."""

    arw2: float
    drift_sigma: float
    drift_tau: float
    gm_cov: np.ndarray
    gm_tau: float


@dataclass
class FilterState:
    q: np.ndarray            # (4,) q_body_from_gcrf
    bias: np.ndarray         # (3,) beta_omega estimate, rad/s
    beta_theta: np.ndarray   # (3,) GPS Gauss-Markov estimate, rad
    P: np.ndarray            # (9, 9)


@njit(cache=True)
def quat_mul(p, q):
    """p (x) q with R(p (x) q) = R(p) R(q) (gnssatt.gnss.rotations.quat_multiply, without the sign flip)."""
    out = np.empty(4)
    out[0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3]
    out[1] = p[0] * q[1] + q[0] * p[1] - (p[2] * q[3] - p[3] * q[2])
    out[2] = p[0] * q[2] + q[0] * p[2] - (p[3] * q[1] - p[1] * q[3])
    out[3] = p[0] * q[3] + q[0] * p[3] - (p[1] * q[2] - p[2] * q[1])
    return out


@njit(cache=True)
def quat_exp(th0, th1, th2):
    """Quaternion of rotation vector theta: R = exp(-[theta x]) (gnssatt.gnss.rotations.quat_from_rotvec)."""
    a = math.sqrt(th0 * th0 + th1 * th1 + th2 * th2)
    s = 0.5 - a * a / 48.0 if a < 1e-4 else math.sin(0.5 * a) / a
    out = np.empty(4)
    out[0] = math.cos(0.5 * a)
    out[1] = s * th0
    out[2] = s * th1
    out[3] = s * th2
    return out


@njit(cache=True)
def _phi_q(th, dt, f_w, f_t):
    Phi = np.eye(9)
    a = math.sqrt(th[0] ** 2 + th[1] ** 2 + th[2] ** 2)
    K = np.zeros((3, 3))
    K[0, 1], K[0, 2], K[1, 2] = -th[2], th[1], -th[0]
    K[1, 0], K[2, 0], K[2, 1] = th[2], -th[1], th[0]
    if a < 1e-9:
        E = np.eye(3) - K
    else:
        E = np.eye(3) - math.sin(a) / a * K + (1 - math.cos(a)) / (a * a) * (K @ K)
    Phi[0:3, 0:3] = E                      # exp(-[omega dt x])
    for i in range(3):
        Phi[i, 3 + i] = -dt
        Phi[3 + i, 3 + i] = f_w
        Phi[6 + i, 6 + i] = f_t
    return Phi


@njit(cache=True)
def propagate(q, bias, P, rates, dts, arw2, drift_sigma, drift_tau, gm_cov, gm_tau, out_q, out_P3):
    """Propagate (q, P) over the gyro samples (rates (n, 3) rad/s, dts (n,) s); fills out_q (n, 4) and out_P3
    (n, 3, 3) (the attitude block) after each sample; returns (q, P, Phi_total, Q_total) of the whole interval."""
    Phi_tot = np.eye(9)
    Q_tot = np.zeros((9, 9))
    for i in range(rates.shape[0]):
        dt = dts[i]
        th = (rates[i] - bias) * dt
        q = quat_mul(quat_exp(th[0], th[1], th[2]), q)
        f_w = math.exp(-dt / drift_tau)
        f_t = math.exp(-dt / gm_tau)
        Phi = _phi_q(th, dt, f_w, f_t)
        Q = np.zeros((9, 9))
        for a in range(3):
            Q[a, a] = arw2 * dt
            Q[3 + a, 3 + a] = drift_sigma * drift_sigma * (1 - f_w * f_w)
            for b in range(3):
                Q[6 + a, 6 + b] = gm_cov[a, b] * (1 - f_t * f_t)
        P = Phi @ P @ Phi.T + Q
        Q_tot = Phi @ Q_tot @ Phi.T + Q
        Phi_tot = Phi @ Phi_tot
        out_q[i] = q
        out_P3[i] = P[0:3, 0:3]
    return q, 0.5 * (P + P.T), Phi_tot, Q_tot


@njit(cache=True)
def propagate_attitude(q, bias, rates, dts):
    """q after the gyro samples with the drift `bias` removed (eq. 9), no covariance: a delayed propagator."""
    for i in range(rates.shape[0]):
        th = (rates[i] - bias) * dts[i]
        q = quat_mul(quat_exp(th[0], th[1], th[2]), q)
    return q


@njit(cache=True)
def propagate_covariance(P, Phis, Qs):
    """P after the intervals: P <- Phi_l P Phi_l' + Q_l for l in order."""
    for k in range(Phis.shape[0]):
        P = Phis[k] @ P @ Phis[k].T + Qs[k]
    return P


def propagate_reference(q, bias, P, rates, dts, noise: NoiseRates):
    """Numpy form of `propagate` (the specification; tests compare the kernel with it)."""
    from gnssatt.gnss import rotations as rot

    for w, dt in zip(rates, dts):
        th = (w - bias) * dt
        q = rot.quat_multiply(rot.quat_from_rotvec(th), q, canonical=False)
        f_w, f_t = np.exp(-dt / noise.drift_tau), np.exp(-dt / noise.gm_tau)
        Phi = np.eye(9)
        Phi[:3, :3] = rot.quat_to_dcm(rot.quat_from_rotvec(th))
        Phi[:3, 3:6] = -dt * np.eye(3)
        Phi[3:6, 3:6] = f_w * np.eye(3)
        Phi[6:9, 6:9] = f_t * np.eye(3)
        Q = np.zeros((9, 9))
        Q[:3, :3] = noise.arw2 * dt * np.eye(3)
        Q[3:6, 3:6] = noise.drift_sigma ** 2 * (1 - f_w ** 2) * np.eye(3)
        Q[6:9, 6:9] = noise.gm_cov * (1 - f_t ** 2)
        P = Phi @ P @ Phi.T + Q
    return q, P


def rotvec_of(q_a: np.ndarray, q_b: np.ndarray) -> np.ndarray:
    """Rotation vector of q_a (x) q_b^-1 (rad, body frame of b): the small rotation taking b to a."""
    from gnssatt.gnss import rotations as rot

    return rot.quat_to_rotvec(rot.quat_multiply(q_a, rot.quat_conjugate(q_b)))


H_GPS = np.hstack([np.eye(3), np.zeros((3, 3)), np.eye(3)])


def update(state: FilterState, q_gps: np.ndarray, R_white: np.ndarray) -> tuple[FilterState, np.ndarray, np.ndarray]:
    """(state after the GPS attitude update, innovation (3,) rad, its covariance (3, 3)). Joseph form."""
    z = rotvec_of(q_gps, state.q) - state.beta_theta
    H = H_GPS
    S = H @ state.P @ H.T + R_white
    K = state.P @ H.T @ np.linalg.inv(S)
    dx = K @ z
    IKH = np.eye(N_STATE) - K @ H
    P = IKH @ state.P @ IKH.T + K @ R_white @ K.T
    q = quat_mul(quat_exp(dx[0], dx[1], dx[2]), state.q)
    q = q / np.linalg.norm(q)
    return FilterState(q, state.bias + dx[3:6], state.beta_theta + dx[6:9], 0.5 * (P + P.T)), z, S
