"""The sampling uncertainty of an error / sigma ratio over a correlated series (gnssatt.gyro.truth)."""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from gnssatt.gyro.truth import ratio_sampling_sd


def _ar1(rng, n, tau_s):
    phi = np.exp(-1.0 / tau_s)
    return lfilter([np.sqrt(1 - phi ** 2)], [1, -phi], rng.normal(size=n))


def test_ratio_sd_follows_the_correlation_time():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 5864.0)
    for tau_s in (30.0, 300.0):
        rms, sd = zip(*(ratio_sampling_sd(_ar1(rng, len(t), tau_s), t) for _ in range(40)))
        expected = np.sqrt(tau_s / 2 / len(t))         # integral of exp(-2u/tau) is tau / 2
        # 40 series: the scatter of the rms estimates the sd to ~12 %; the estimator's own median within 25 %
        assert 0.75 * expected < np.std(rms) < 1.3 * expected, (tau_s, np.std(rms), expected)
        assert 0.75 * expected < np.median(sd) < 1.25 * expected, (tau_s, np.median(sd), expected)
