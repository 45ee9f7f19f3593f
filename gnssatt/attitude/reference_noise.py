"""The attitude filter's noise model in readable numpy: the C/N0 and multipath variance factors and the two on-line
estimators (the C/N0-growth exponent gamma and the white noise of one single difference) fed by the triple
differences of the quality control.

This is the specification of the compiled kernels gnssatt.attitude.kernels.cn0_growth_samples /
cn0_growth_update / white_noise_update and gnssatt.attitude.update_kernels.cn0_factor / mp_var (the filter runs
the kernels; tests/attitude/test_attitude_kernels.py and test_update_kernels.py check them against this module
with tolerances). Plain numpy, no numba.

Implements: seed 000 Table 1 (white noise of code and phase, 45 dB-Hz reference) and the noise model of
docs/attitude.md (variance ~ C/N0 factor^gamma, gamma from the slope of ln|e| on ln factor; the MAD of the
median-referenced triple differences / 0.6745 = sqrt(2) x the sigma of one SD; multipath growing with the square
of the off-boresight angle).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["cn0_variance_factor", "multipath_variance_m2", "NoiseEstimates", "NoiseSettings", "update_cn0_growth",
           "cn0_weights", "update_white_noise", "CODE_RESIDUAL_MAX_M"]

#: code triple differences off their median by this much or more are not samples of the gamma regression (m)
CODE_RESIDUAL_MAX_M = 5.0


def cn0_variance_factor(cn0_dbhz: np.ndarray) -> np.ndarray:
    """Variance factor 10^((45 - C/N0) / 10) clipped to [0.25, 16]; NaN C/N0 counts as 45 dB-Hz.

    Implements: seed 000 Table 1 (sigmas at 45 dB-Hz); the sigma doubles per -6 dB of C/N0 (variance ~ 1 / (C/N0)).
    """
    cn0 = np.where(np.isnan(cn0_dbhz), 45.0, cn0_dbhz)
    return np.clip(10.0 ** ((45.0 - cn0) / 10.0), 0.25, 16.0)


def multipath_variance_m2(off_boresight_rad: np.ndarray, sigma_boresight_m: float,
                          sigma_horizon_m: float) -> np.ndarray:
    """Variance (m^2) of the time-correlated (multipath) error of one SD: its sigma grows from sigma_boresight_m
    with the square of the off-boresight angle to sigma_horizon_m at 90 deg, capped at 120 deg; NaN -> 90 deg.

    Implements: the multipath model of docs/attitude.md (gnssatt.attitude.update_kernels.mp_var).
    """
    th = np.where(np.isnan(off_boresight_rad), np.pi / 2, off_boresight_rad)
    x = np.clip(th / (np.pi / 2), 0.0, 4.0 / 3.0)
    return (sigma_boresight_m + (sigma_horizon_m - sigma_boresight_m) * x * x) ** 2


@dataclass(frozen=True)
class NoiseSettings:
    """Memory and thresholds of the estimators (gnssatt.attitude.settings: noise_epochs, noise_min_epochs)."""
    memory_epochs: float = 300.0            # exponential memory of the running means
    min_epochs: int = 10                    # epochs of samples before gamma is estimated
    min_var_ln_factor: float = 0.05         # spread of ln(factor) needed for a slope


@dataclass
class NoiseEstimates:
    """State of the estimators per (kind 0 code / 1 phase, signal f).

    moments (2, n_sig, 4): running means of x, y, x^2, x y (x = ln factor, y = ln|TD - median|);
    n_growth (2, n_sig): epochs with samples; gamma (2, n_sig): the exponent (1 = variance ~ factor);
    var_code_m2, var_phase_m2 (n_sig,): white variance of one SD; n_white (n_sig,): epochs in those means.
    """
    moments: np.ndarray
    n_growth: np.ndarray
    gamma: np.ndarray
    var_code_m2: np.ndarray
    var_phase_m2: np.ndarray
    n_white: np.ndarray

    @classmethod
    def initial(cls, n_sig: int, var_code_m2: float, var_phase_m2: float) -> "NoiseEstimates":
        return cls(np.zeros((2, n_sig, 4)), np.zeros((2, n_sig)), np.ones((2, n_sig)), np.full(n_sig, var_code_m2),
                   np.full(n_sig, var_phase_m2), np.zeros(n_sig))

    def copy(self) -> "NoiseEstimates":
        return NoiseEstimates(*(np.array(a, dtype=np.float64) for a in (
            self.moments, self.n_growth, self.gamma, self.var_code_m2, self.var_phase_m2, self.n_white)))


def _nz(a: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(a), 0.0, a)


def update_cn0_growth(td, ln_factor: np.ndarray, wavelength_m: np.ndarray, est: NoiseEstimates,
                      settings: NoiseSettings) -> None:
    """In place on est.moments / n_growth / gamma: one epoch of the C/N0-growth regression.

    td: gnssatt.attitude.reference_qc.TripleDifferences of the epoch; ln_factor (n_bl, n_sat, n_sig) = ln of
    cn0_variance_factor. Per (kind, signal): the |TD - median| of the TDs passing their mask, kept when
    0 < r < 5 m (code) or < one wavelength (phase); with >= 3 samples the running means of x = ln factor and
    y = ln r are updated (memory settings.memory_epochs) and, after min_epochs, gamma = clip(2 cov(x, y) / var(x),
    0, 1.5) (E ln|e| = ln sigma + const for Gaussian e, so the slope of y on x is gamma / 2).
    """
    for f in range(wavelength_m.size):
        for kind, values, ok, median, big in ((0, td.code_m, td.code_ok, td.median_code_m, CODE_RESIDUAL_MAX_M),
                                              (1, td.phase_m, td.phase_ok, td.median_phase_m, wavelength_m[f])):
            sel = ok[..., f]
            r = np.abs((values[..., f] - _nz(median[:, f])[:, None])[sel])
            x = ln_factor[..., f][sel]
            keep = (r < big) & (r > 0)
            if keep.sum() < 3:
                continue
            x, y = x[keep], np.log(r[keep])
            a = 1.0 / min(est.n_growth[kind, f] + 1.0, settings.memory_epochs)
            sample = np.array([x.mean(), y.mean(), (x * x).mean(), (x * y).mean()])
            est.moments[kind, f] += a * (sample - est.moments[kind, f])
            est.n_growth[kind, f] += 1
            m = est.moments[kind, f]
            var_x = m[2] - m[0] ** 2
            if est.n_growth[kind, f] >= settings.min_epochs and var_x > settings.min_var_ln_factor:
                est.gamma[kind, f] = np.clip(2.0 * (m[3] - m[0] * m[1]) / var_x, 0.0, 1.5)


def cn0_weights(gamma: np.ndarray, ln_factor: np.ndarray) -> np.ndarray:
    """(2, n_bl, n_sat, n_sig) variance factors factor^gamma of code (0) and phase (1) = exp(gamma ln factor)."""
    return np.exp(gamma[:, None, None, :] * ln_factor[None])


def update_white_noise(td, weights: np.ndarray, est: NoiseEstimates, settings: NoiseSettings) -> None:
    """In place on est.var_code_m2 / var_phase_m2 / n_white: one epoch of the white-noise estimator.

    The median-referenced TDs normalised by sqrt(weights) (cn0_weights); for a signal with >= 3 code and >= 3
    phase TDs the variance of one SD (MAD / 0.6745)^2 / 2 (a TD of SDs has twice their variance) enters an
    exponential mean of memory settings.memory_epochs.
    """
    d_code = (td.code_m - _nz(td.median_code_m)[:, None, :]) / np.sqrt(weights[0])
    d_phase = (td.phase_m - _nz(td.median_phase_m)[:, None, :]) / np.sqrt(weights[1])
    for f in range(est.var_code_m2.size):
        dc, dp = d_code[..., f][td.code_ok[..., f]], d_phase[..., f][td.phase_ok[..., f]]
        if dp.size < 3 or dc.size < 3:
            continue
        a = 1.0 / min(est.n_white[f] + 1.0, settings.memory_epochs)
        var_p = (np.median(np.abs(dp)) / 0.6745) ** 2 / 2.0
        var_c = (np.median(np.abs(dc)) / 0.6745) ** 2 / 2.0
        est.var_phase_m2[f] += a * (var_p - est.var_phase_m2[f])
        est.var_code_m2[f] += a * (var_c - est.var_code_m2[f])
        est.n_white[f] += 1
