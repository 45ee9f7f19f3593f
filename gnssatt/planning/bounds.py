"""Bounds on attitude from short baselines: the CRLB of an angle of arrival (seed 001 eq. 4), ADOP (eq. 5)
and the attitude sigma sigma_R = ADOP sigma_range / d (eq. 5-6).

Implements: seed 001 eq. 4 (Kay 1993, Fundamentals of Statistical Signal Processing I, example 3.15: the
angle of arrival at a line array of M sensors, var(theta) >= 12 / ((2 pi)^2 SNR M(M+1)/(M-1) (L/lambda)^2
sin^2 theta) with L = d the spacing; M = 2 gives the paper's factor 6), eq. 5 (ADOP = sqrt(trace((n I -
S S^T)^-1)), S = [s_1 ... s_n] the unit lines of sight), eq. 6 (ADOP = 1).
Neglects: multipath and every systematic range error (they enter only through sigma_range).
"""
from __future__ import annotations

import numpy as np

L1_WAVELENGTH_M = 299792458.0 / 1575.42e6   # GPS L1 (0.1903 m; seed 001 rounds to 19 cm)


def crlb_aoa_var_rad2(theta_rad, snr_linear, baseline_m, wavelength_m: float = L1_WAVELENGTH_M,
                      n_antennas: int = 2) -> np.ndarray:
    """Lower bound (rad^2) of the variance of an angle of arrival theta measured by n_antennas in a line.

    var >= 12 / ((2 pi)^2 SNR M(M+1)/(M-1) (d/lambda)^2 sin^2 theta)  (seed 001 eq. 4 for M = 2).
    theta is the angle between the baseline and the line of sight; SNR the linear post-integration
    signal-to-noise ratio (e.g. C/N0 [Hz] times the integration time [s]).
    """
    m = float(n_antennas)
    theta = np.asarray(theta_rad, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return 12.0 / ((2 * np.pi) ** 2 * np.asarray(snr_linear) * m * (m + 1) / (m - 1)
                       * (np.asarray(baseline_m) / wavelength_m) ** 2 * np.sin(theta) ** 2)


def adop(los_unit, use=None) -> np.ndarray:
    """Attitude dilution of precision (...,) from unit lines of sight los_unit (..., n, 3) (seed 001 eq. 5).

    ADOP = sqrt(trace((n I - S S^T)^-1)), S (3, n) the used lines of sight, n their number. NaN where
    n I - S S^T is singular (fewer than two non-parallel lines of sight).
    """
    s = np.asarray(los_unit, dtype=np.float64)
    use = np.isfinite(s).all(-1) if use is None else (np.asarray(use, bool) & np.isfinite(s).all(-1))
    s0 = np.where(use[..., None], s, 0.0)
    n = use.sum(-1).astype(np.float64)
    M = n[..., None, None] * np.eye(3) - np.einsum("...ni,...nj->...ij", s0, s0)
    ok = np.linalg.cond(M) < 1e10
    inv = np.linalg.inv(np.where(ok[..., None, None], M, np.eye(3)))
    return np.where(ok, np.sqrt(np.trace(inv, axis1=-2, axis2=-1)), np.nan)


def sigma_attitude_rad(sigma_range_m, baseline_m, adop_value=1.0) -> np.ndarray:
    """sigma_R = ADOP sigma_range / d (rad): seed 001 eq. 5; eq. 6 with ADOP = 1."""
    return np.asarray(adop_value) * np.asarray(sigma_range_m) / np.asarray(baseline_m)
