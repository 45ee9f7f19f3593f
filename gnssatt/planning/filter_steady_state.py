"""The multi-antenna filter's expected sigma from the per-epoch (snapshot) sigma: the steady state of a filter
whose attitude is driven by an angular-velocity random walk (seed 000 Table 1: 0.03 deg/s per tau = 1 s).

Per axis, the filter is an alpha-beta tracker of the discrete white-noise-acceleration model: the angle is
measured each interval T with sigma_m (the snapshot sigma), the rate takes a random step of sigma_w = sigma_omega
sqrt(T / tau) per interval. With Kalata's tracking index lambda = sigma_w T / sigma_m, the steady-state gain
alpha = -(lambda^2 + 8 lambda - (lambda + 4) sqrt(lambda^2 + 8 lambda)) / 8 and the filtered angle's variance is
alpha sigma_m^2.

Implements: Kalata (1984), "The tracking index: a generalized parameter for alpha-beta and alpha-beta-gamma
target trackers", IEEE Trans. AES 20(2) 174-182; Bar-Shalom, Li & Kirubarajan (2001) sec. 6.5.3 (DWNA model).
Neglects: the coupling of the three axes in the filter, the ambiguity states (fixed), time variation of the
geometry within the filter's memory (a few tens of epochs).
"""
from __future__ import annotations

import numpy as np


def kalata_alpha(tracking_index) -> np.ndarray:
    """Steady-state position gain alpha of the alpha-beta filter for tracking index lambda (> 0)."""
    lam = np.asarray(tracking_index, dtype=np.float64)
    r = np.sqrt(lam * lam + 8.0 * lam)
    return -(lam * lam + 8.0 * lam - (lam + 4.0) * r) / 8.0


def filtered_sigma_deg(snapshot_sigma_deg, interval_s: float, sigma_omega_deg_s: float, tau_s: float) -> np.ndarray:
    """Steady-state filtered angle sigma (deg) for per-epoch sigma (deg), epoch interval, rate random walk."""
    sm = np.asarray(snapshot_sigma_deg, dtype=np.float64)
    sigma_w = sigma_omega_deg_s * np.sqrt(interval_s / tau_s)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = sigma_w * interval_s / sm
        return np.sqrt(kalata_alpha(lam)) * sm
