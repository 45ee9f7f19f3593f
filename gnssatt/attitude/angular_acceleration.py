"""Dynamic mode with an angular-acceleration state (settings.angular_acceleration_state): the constant-acceleration
model of the attitude, omega' = alpha, alpha a random walk (white angular jerk).

State: [omega (3), alpha (3), baselines ...] (FilterState with n_rate = 6). The time update over dt is split in two
linear(ised) steps, applied before the baselines' RK4 rotation:
    omega <- omega + alpha dt,   P <- A P A^T + Q_a,   A = I + dt E_omega,alpha,   Q_a = q_a dt on alpha,
then b' = omega x b with the new omega over dt (gnssatt.attitude.qc_kernels.propagate_dynamic, with Table 1's omega
random walk on top). The omega of the state is thereby the rate over the interval that follows (a discrete model
consistent with itself; the attitude is what is compared). The transition matrix of the smoother's sub-state
[omega, alpha, b_1..b_n] is Phi_rot A (`sub_transition`).

Why: with omega a random walk the fixed-interval smoother is the cubic smoothing spline, whose natural end condition
(zero angular acceleration at a run's edge) lags a manoeuvre at the start of a run (the first fixed epochs of
seed 000 Fig. 6's slews); an integrated random walk (alpha in the state) is the quintic spline, which passes a
constant angular acceleration unbiased to the edge.

Implements: the constant-acceleration (Wiener-process acceleration) model, Bar-Shalom, Li & Kirubarajan 2001,
"Estimation with Applications to Tracking and Navigation", sec. 6.3.3 (here with the continuous noise on alpha only
and its first-order discretisation q_a dt).
"""
from __future__ import annotations

import numpy as np

__all__ = ["propagate_acceleration", "sub_transition", "jerk_rate_profile"]


def propagate_acceleration(x: np.ndarray, P: np.ndarray, q_alpha: float, dt: float) -> None:
    """In place: omega x[0:3] += dt alpha x[3:6], P <- A P A^T + q_alpha dt on the alpha block (module doc);
    q_alpha in rad^2/s^5."""
    x[0:3] += dt * x[3:6]
    P[0:3, :] += dt * P[3:6, :]
    P[:, 0:3] += dt * P[:, 3:6]
    P[3:6, 3:6] += np.eye(3) * (q_alpha * dt)


def sub_transition(Phi_rot: np.ndarray, dt: float) -> np.ndarray:
    """Phi_rot A of the sub-state [omega, alpha, b...] (Phi_rot: identity but for the baselines' rows, from the RK4
    rotation; A = I + dt E_omega,alpha): the alpha columns get dt x the omega columns of Phi_rot."""
    Phi = Phi_rot.copy()
    Phi[:, 3:6] += dt * Phi_rot[:, 0:3]
    return Phi


def jerk_rate_profile(q_alpha: float, q_omega: np.ndarray, q_quiet: float, share: float) -> np.ndarray:
    """(n_ep,) angular-jerk rate per epoch (rad^2/s^5) of smoother_adaptive_noise's second pass
    (settings.smoothing.quiet_jerk_share): q_alpha x min(1, share x sqrt(lambda_max(q_omega_k) / q_quiet)), q_omega
    (n_ep, 3, 3) the pass's omega random-walk rates (gnssatt.attitude.smoother.adaptive_noise_profile), q_quiet their
    quiet level (noise_floor x the filter's rate). Where the profile says quiet, a stiffer acceleration (the
    integrated random walk's smoothing window lengthens); where it is raised to a manoeuvre's level, the configured
    rate. Ours (docs/attitude.md 'Angular-acceleration state')."""
    lam = np.linalg.eigvalsh(q_omega)[:, -1]
    return q_alpha * np.minimum(1.0, share * np.sqrt(np.maximum(lam, 0.0) / max(q_quiet, 1e-300)))
