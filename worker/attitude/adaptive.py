"""Adaptive process noise of the angular velocity (dynamic mode): covariance matching of the state corrections.

Innovation-based adaptive estimation (Mohamed & Schwarz 1999, J. Geodesy 73, eq. 20-21; Sage & Husa 1969): in
steady state the mean of the omega corrections d_omega d_omega^T (d_omega = K v, the change of the omega estimate in
a measurement update) equals the omega block of P- - P+, which is the process noise Q added since the last update.
When the platform accelerates, the random walk of Table 1 is too stiff: the filter lags, every update pulls omega
the same way and the corrections exceed what the filter predicted. The excess over a short window,

    E_k = mean_{window} (d_omega d_omega^T - (P-_ww - P+_ww)) / dt,

is added (scaled by `gain`, eigenvalues clipped at 0) to the configured noise rate for the next propagation; with
no excess (steady state, or after a covariance reset where P- - P+ is large too) the filter is Table 1's.
A chi-square gate keeps noise out: the normalised corrections sum_window d_omega^T (P-_ww - P+_ww)^-1 d_omega are
chi-square with 3 x window degrees of freedom while the model holds; below their `gate` quantile nothing is added.
"""
from __future__ import annotations

import numpy as np
from scipy.stats import chi2

__all__ = ["OmegaNoiseAdapter"]


class OmegaNoiseAdapter:
    """Running window of omega corrections; `q_rate` gives the 3x3 angular-velocity noise rate (rad^2/s^3)."""

    def __init__(self, q_rate_rad2_s3: float, window: int = 10, gain: float = 1.0, gate: float = 0.99,
                 max_factor: float = 1.0e4):
        self.q0 = float(q_rate_rad2_s3)
        self.window = int(window)
        self.gain = float(gain)
        self.max_rate = max_factor * self.q0
        self.limit = float(chi2.ppf(gate, 3 * self.window)) if gate > 0 else 0.0
        self._excess: list[np.ndarray] = []
        self._nis: list[float] = []

    def observe(self, d_omega: np.ndarray, P_ww_prior: np.ndarray, P_ww_post: np.ndarray, dt_s: float) -> None:
        """One measurement update's omega correction (3,) and the omega covariance before/after it (3, 3)."""
        if not dt_s > 0:
            return
        d = np.asarray(d_omega, float)
        M = P_ww_prior - P_ww_post
        self._excess.append((np.outer(d, d) - M) / dt_s)
        try:
            self._nis.append(float(d @ np.linalg.solve(M, d)))
        except np.linalg.LinAlgError:
            self._nis.append(0.0)
        if len(self._excess) > self.window:
            self._excess.pop(0)
            self._nis.pop(0)

    def reset(self) -> None:
        """Forget the window (after a covariance reset of omega or a withdrawn fix)."""
        self._excess.clear()
        self._nis.clear()

    def q_rate(self) -> np.ndarray:
        """(3, 3) noise rate: the configured isotropic rate plus gain x the positive part of the mean excess."""
        q = np.eye(3) * self.q0
        if len(self._excess) < self.window or sum(self._nis) < self.limit:
            return q
        m = np.mean(self._excess, axis=0)
        m = 0.5 * (m + m.T)
        lam, V = np.linalg.eigh(m)
        lam = np.clip(self.gain * lam, 0.0, self.max_rate)
        return q + (V * lam) @ V.T
