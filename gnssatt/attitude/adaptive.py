"""Adaptive angular-velocity noise (dynamic mode, option `adaptive_omega_noise`): causal manoeuvre detection by a
bank of constant-angular-acceleration hypotheses on the (omega, baselines) sub-state.

Table 1's random walk of omega lags an angular acceleration a by ~a / sqrt(q / r) (q its rate, r the one-epoch
attitude variance per second; 0.8 deg at the 0.08 deg/s^2 of seed 000 Fig. 6's pitch-up). The detector
(generalised likelihood ratio of a jump in a linear system, Willsky & Jones 1976, IEEE TAC 21(1), run as a bank of
filters over candidate onset times; the estimate mixed by the hypotheses' posterior weights as in multiple-model
estimation, Bar-Shalom, Li & Kirubarajan 2001 sec. 11.6):

- every measurement update of the main filter is condensed to an equivalent measurement of the baselines: with
  the baselines' prior and posterior covariance P-_bb, P+_bb and means b-, b+ (the update only sees b, so the b
  marginal is updated exactly by it) J = (P+_bb)^-1 - (P-_bb)^-1, i = (P+_bb)^-1 b+ - (P-_bb)^-1 b-;
- the null hypothesis H0 (a copy of the sub-state filter with Table 1's random walk q0) and, started every
  STRIDE updates from H0's posterior and kept for MAX_AGE updates, alternatives H1(tau): the same model plus a
  constant angular acceleration alpha from tau, alpha ~ N(0, sigma_acc^2 I), are updated with (J, i); each keeps
  its log-likelihood ratio against H0 over its life, L(tau) = sum (D0 - D1) / 2 with D = -2 log p(measurement |
  hypothesis) up to a common constant (information form, no inverse of J: D = -2 b-^T i + b-^T J b- - g^T P+_bb g
  + log det(I + J P-_bb), g = i - J b-);
- the output between detections is H0's sub-state moved towards the best alternative's by its posterior weight
  p = 1 / (1 + exp(mix_at - L)) (mixture mean and covariance; below p = P_MIN the main filter is left alone);
- L > `threshold`: a manoeuvre. The main filter takes the alternative's (omega, baselines) and covariance (its
  covariance only grows: the increase is clipped to be positive semi-definite), H0 restarts from it, the bank
  empties, and for `hold` updates the main filter's random walk is raised to sigma_hi along the estimated
  acceleration axis (Table 1's on the other two). A continuing acceleration is detected again and extends it.

Everything at update k uses the data up to k (causal). With the smoother on, only the raised random walk is applied
(the smoother's model must explain every change of the state). The models run only while every baseline is fixed (the
caller's condition); a gap of more than MAX_GAP_S or a reset of omega / the fix restarts them.
"""
from __future__ import annotations

import numpy as np

from gnssatt.estimation.ekf_kernels import propagate_rotation_cov, rotation_rk4_stm_kernel
from gnssatt.gnss.rotations import skew

__all__ = ["ManoeuvreDetector"]

STRIDE = 3          # updates between the onsets of two alternatives
MAX_AGE = 15        # updates an alternative lives (onsets up to 15 s back)
P_MIN = 0.1         # posterior weight of the alternative below which the main filter is left alone
MAX_GAP_S = 3.0     # a longer gap between updates restarts the models


def _psd_part(D: np.ndarray) -> np.ndarray:
    """The positive semi-definite part of a symmetric matrix (negative eigenvalues set to 0)."""
    lam, V = np.linalg.eigh(0.5 * (D + D.T))
    return (V * np.clip(lam, 0.0, None)) @ V.T


def rw_noise(b1: np.ndarray, q: float, dt: float) -> np.ndarray:
    """(3 + 3 n_b) square discrete noise of an isotropic omega random walk of rate q over dt and its effect on the
    baselines b1 (n_b, 3); the Q of gnssatt.estimation.ekf_kernels.propagate_rotation_cov (Van Loan 1978)."""
    nb = b1.shape[0]
    Q = np.zeros((3 + 3 * nb, 3 + 3 * nb))
    Q[0:3, 0:3] = np.eye(3) * q * dt
    B = [-skew(b) for b in b1]
    for j in range(nb):
        r = 3 + 3 * j
        Q[r:r + 3, 0:3] = B[j] * q * dt ** 2 / 2
        Q[0:3, r:r + 3] = Q[r:r + 3, 0:3].T
        for i in range(nb):
            Q[r:r + 3, 3 + 3 * i:6 + 3 * i] = B[j] @ B[i].T * q * dt ** 3 / 3
    return Q


def info_update(x: np.ndarray, P: np.ndarray, o: int, J: np.ndarray, i: np.ndarray):
    """(x+, P+, D) of the information-form update of the baselines (state rows o..) with J, i: P+ = P - P_:b (I +
    J P_bb)^-1 J P_b:, x+ = x + P+_:b (i - J b); D = -2 log-likelihood of the measurement up to a constant common to
    all models (module doc)."""
    C = P[o:, o:]
    b = x[o:]
    A = np.eye(J.shape[0]) + J @ C
    PH = P[:, o:]
    P1 = P - PH @ np.linalg.solve(A, J) @ PH.T
    P1 = 0.5 * (P1 + P1.T)
    g = i - J @ b
    x1 = x + P1[:, o:] @ g
    D = -2.0 * b @ i + b @ J @ b - g @ P1[o:, o:] @ g + np.linalg.slogdet(A)[1]
    return x1, P1, D


def equivalent_measurement(xp: np.ndarray, Pp: np.ndarray, xf: np.ndarray, Pf: np.ndarray, o: int = 3):
    """(J, i) of one update of the baselines (rows o..) from the prior and posterior: information added, with J's
    negative eigenvalues (round-off) clipped; None if a covariance is singular."""
    try:
        Ip = np.linalg.inv(Pp[o:, o:])
        If = np.linalg.inv(Pf[o:, o:])
    except np.linalg.LinAlgError:
        return None
    return _psd_part(If - Ip), If @ xf[o:] - Ip @ xp[o:]


class ManoeuvreDetector:
    """Bank of constant-acceleration hypotheses against Table 1's random walk (module doc). State order of the
    sub-state: omega (3), then the baselines (3 each); q rates in rad^2/s^3, sigma_acc in rad/s^2. replace_state
    False: only the raised random walk after a detection (no mixing, no state taken over), for the fixed-interval
    smoother, whose backward pass needs every change of the state to come from the dynamics and the measurements."""

    def __init__(self, q0_rate: float, q_hi_rate: float, n_bl: int, threshold: float = 5.0, mix_at: float = 0.0,
                 sigma_acc_rad_s2: float = 0.05 * np.pi / 180, hold_updates: int = 30, rk4_step_s: float = 1.0,
                 replace_state: bool = True):
        self.q0, self.q_hi = float(q0_rate), float(q_hi_rate)
        self.n_bl = int(n_bl)
        self.threshold, self.mix_at = float(threshold), float(mix_at)
        self.var_acc = float(sigma_acc_rad_s2) ** 2
        self.hold_updates = int(hold_updates)
        self.rk4 = float(rk4_step_s)
        self.replace_state = bool(replace_state)
        self.w_idx = np.arange(3)
        self.b_idx = 3 + np.arange(3 * self.n_bl).reshape(self.n_bl, 3)
        self.detections: list = []          # times (as given to observe) of the detected manoeuvres
        self.reset()

    def reset(self) -> None:
        """Forget the models (after an omega or fix reset); they restart from the next posterior."""
        self.active = False
        self.hold = 0
        self.axis = None
        self.bank: list[list] = []          # per alternative: [x (6 + 3 n_bl), P, log-likelihood ratio, age]
        self.n_upd = 0
        self.last_t = None

    # ---- propagation ----
    def _prop_null(self, x, P, dt):
        b1, Pbb, Pbw = rotation_rk4_stm_kernel(np.ascontiguousarray(x[3:].reshape(self.n_bl, 3)),
                                               np.ascontiguousarray(x[0:3]), dt, self.rk4)
        x = np.concatenate([x[0:3], b1.ravel()])
        P = P.copy()
        propagate_rotation_cov(P, self.w_idx, self.b_idx, Pbb, Pbw, np.eye(3) * self.q0, b1, float(dt))
        return x, P

    def _prop_acc(self, x, P, dt):
        """omega + alpha dt; b rotated with the mean omega of the step; Table 1's random walk on omega."""
        w, a = x[0:3], x[3:6]
        b1, Pbb, Pbw = rotation_rk4_stm_kernel(np.ascontiguousarray(x[6:].reshape(self.n_bl, 3)),
                                               np.ascontiguousarray(w + a * dt / 2), dt, self.rk4)
        n = x.size
        Phi = np.eye(n)
        Phi[0:3, 3:6] = np.eye(3) * dt
        for j in range(self.n_bl):
            r = 6 + 3 * j
            Phi[r:r + 3, r:r + 3] = Pbb
            Phi[r:r + 3, 0:3] = Pbw[j]
            Phi[r:r + 3, 3:6] = Pbw[j] * dt / 2
        P1 = Phi @ P @ Phi.T
        sub = np.r_[0:3, 6:n]
        P1[np.ix_(sub, sub)] += rw_noise(b1, self.q0, dt)
        return np.concatenate([w + a * dt, a, b1.ravel()]), P1

    def q_rate(self, dt_s: float) -> np.ndarray:
        """Propagate the models over dt_s; the (3, 3) omega noise rate (rad^2/s^3) of the main filter for it."""
        if self.active and dt_s > 0:
            self.xq, self.Pq = self._prop_null(self.xq, self.Pq, dt_s)
            for m in self.bank:
                m[0], m[1] = self._prop_acc(m[0], m[1], dt_s)
        q = np.eye(3) * self.q0
        if self.hold > 0 and self.axis is not None:
            q += (self.q_hi - self.q0) * np.outer(self.axis, self.axis)
        return q

    # ---- update ----
    def observe(self, xp: np.ndarray, Pp: np.ndarray, xf: np.ndarray, Pf: np.ndarray, t_s: float):
        """One measurement update of the main filter: the sub-state prior (xp, Pp) and posterior (xf, Pf) at time
        t_s. Returns None (keep the posterior) or the (x, P) the main filter's sub-state takes instead."""
        if self.active and self.last_t is not None and t_s - self.last_t > MAX_GAP_S:
            self.reset()
        self.last_t = t_s
        if not self.active:
            self.xq, self.Pq = xf.copy(), Pf.copy()
            self.active = True
            return None
        em = equivalent_measurement(xp, Pp, xf, Pf)
        if em is None:
            self.reset()
            return None
        J, i = em
        self.n_upd += 1
        self.xq, self.Pq, D0 = info_update(self.xq, self.Pq, 3, J, i)
        for m in self.bank:
            m[0], m[1], D1 = info_update(m[0], m[1], 6, J, i)
            m[2] += 0.5 * (D0 - D1)
            m[3] += 1
        self.bank = [m for m in self.bank if m[3] <= MAX_AGE]
        if self.hold > 0:
            self.hold -= 1
        out = None
        best = max(self.bank, key=lambda m: m[2]) if self.bank else None
        if best is not None:
            sub = np.r_[0:3, 6:best[0].size]
            x1, P1 = best[0][sub], best[1][np.ix_(sub, sub)]
            if best[2] > self.threshold:
                # a manoeuvre: the main filter and H0 restart from the alternative
                self.detections.append(t_s)
                self.hold = self.hold_updates
                self.axis = best[0][3:6] / max(np.linalg.norm(best[0][3:6]), 1e-30)
                out = x1, Pf + _psd_part(P1 - Pf)
                self.xq, self.Pq = x1.copy(), P1.copy()
                self.bank = []
            elif self.hold == 0:
                p = 1.0 / (1.0 + np.exp(min(self.mix_at - best[2], 700.0)))
                if p > P_MIN:
                    d = x1 - self.xq
                    Pm = (1 - p) * self.Pq + p * P1 + p * (1 - p) * np.outer(d, d)
                    out = self.xq + p * d, Pf + _psd_part(Pm - Pf)
        if self.n_upd % STRIDE == 0:
            n = self.xq.size + 3
            x = np.concatenate([self.xq[0:3], np.zeros(3), self.xq[3:]])
            P = np.zeros((n, n))
            sub = np.r_[0:3, 6:n]
            P[np.ix_(sub, sub)] = self.Pq
            P[3:6, 3:6] = np.eye(3) * self.var_acc
            self.bank.append([x, P, 0.0, 0])
        return out if self.replace_state else None
