"""The filter's steady-state sigma (Kalata's alpha) against an independent Riccati iteration of the same model."""
from __future__ import annotations

import numpy as np

from gnssatt.planning.filter_steady_state import filtered_sigma_deg, kalata_alpha


def _riccati_sigma(sigma_m, T, sigma_w):
    """Posterior angle sigma of a Kalman filter on x = (angle, rate), F = [[1, T], [0, 1]], DWNA process noise
    G = (T/2, 1) sigma_w (rate step sigma_w per interval), H = (1, 0), iterated to its steady state."""
    F = np.array([[1.0, T], [0.0, 1.0]])
    G = np.array([[T / 2.0], [1.0]]) * sigma_w
    P = np.eye(2) * 1e6
    for _ in range(5000):
        P = F @ P @ F.T + G @ G.T
        K = P[:, :1] / (P[0, 0] + sigma_m ** 2)
        P = P - K @ P[:1, :]
    return np.sqrt(P[0, 0])


def test_kalata_alpha_matches_the_riccati_steady_state():
    for sigma_m in (0.05, 0.1, 0.25, 1.0):
        for T in (1.0, 5.0):
            got = filtered_sigma_deg(sigma_m, T, 0.03, 1.0)
            want = _riccati_sigma(sigma_m, T, 0.03 * np.sqrt(T))
            assert abs(got / want - 1) < 1e-6, (sigma_m, T, got, want)


def test_limits():
    # no process noise: the filter averages forever (alpha -> 0); huge process noise: no averaging (alpha -> 1)
    assert kalata_alpha(1e-6) < 1e-2 and abs(kalata_alpha(1e6) - 1.0) < 1e-5
