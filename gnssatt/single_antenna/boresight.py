"""The antenna boresight from C/N0 (seed 001 sec. IV, "Signal strength measurements"): the C/N0-weighted mean
of the lines of sight, and the fit of a known gain pattern, each with a sigma; with a magnetometer, full attitude.

Weighted mean (the JPL approach, seed 001 ref. 23): b = sum w_i e_i / |sum w_i e_i|, w_i = 10^(C/N0_i / 10)
(linear C/N0); sigma by the jackknife over satellites. Pattern fit (Axelrad's approach, seed 001 ref. 21):
C/N0_i = c0 + G(angle(b, e_i)) + noise with G the antenna gain (dB) against the off-boresight angle and c0 the
unknown link-budget constant; Gauss-Newton on (b on the sphere: two tangent angles, c0) from the weighted
mean; sigma of the boresight direction from the fit's covariance (residual variance times (J^T J)^-1).

Implements: seed 001 sec. IV; Gauss-Newton with a tangent-plane parametrisation of the unit vector.
Neglects: azimuthal gain variation, the satellites' transmit-power differences and range losses (they are
the noise the sigmas carry), multipath.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: a generic GNSS patch (RHCP, ground plane): gain (dBic) against the off-boresight angle; about -3 dB at 60 deg,
#: -10 dB at the horizon (cf. manufacturers' elevation patterns of L1 patches)
PATCH_THETA_DEG = (0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0, 105.0, 120.0, 180.0)
PATCH_GAIN_DB = (4.0, 3.7, 2.8, 1.2, -1.0, -4.0, -8.0, -13.0, -18.0, -25.0)


class GainPattern(NamedTuple):
    """Gain (dB) at off-boresight angles theta_deg (increasing, 0-180), linearly interpolated."""

    theta_deg: np.ndarray
    gain_db: np.ndarray

    def gain(self, theta_deg) -> np.ndarray:
        return np.interp(theta_deg, self.theta_deg, self.gain_db)

    def slope_db_per_rad(self, theta_deg) -> np.ndarray:
        """dG/dtheta (dB/rad) by central differences of the interpolant (0.5 deg apart)."""
        h = 0.25
        return (self.gain(np.asarray(theta_deg) + h) - self.gain(np.asarray(theta_deg) - h)) / np.radians(2 * h)


PATCH = GainPattern(np.array(PATCH_THETA_DEG), np.array(PATCH_GAIN_DB))


class Boresight(NamedTuple):
    """boresight (3,) unit vector in the frame of the lines of sight, sigma_deg, c0_dbhz (NaN for the mean),
    n_sats, ok."""

    boresight: np.ndarray
    sigma_deg: float
    c0_dbhz: float
    n_sats: int
    ok: bool


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def weighted_mean(los: np.ndarray, cn0_dbhz: np.ndarray) -> Boresight:
    """The C/N0-weighted mean of unit lines of sight los (n, 3) (NaN C/N0 = not tracked), jackknife sigma."""
    use = np.isfinite(cn0_dbhz) & np.isfinite(los).all(-1)
    e, c = los[use], cn0_dbhz[use]
    n = len(c)
    if n < 2:
        return Boresight(np.full(3, np.nan), np.nan, np.nan, n, False)
    w = 10.0 ** (c / 10.0)
    b = _unit((w[:, None] * e).sum(0))
    if n >= 3:
        loo = np.array([_unit(np.delete(w[:, None] * e, i, 0).sum(0)) for i in range(n)])
        ang = np.arccos(np.clip(loo @ _unit(loo.mean(0)), -1, 1))
        sigma = np.degrees(np.sqrt((n - 1) / n * np.sum(ang ** 2)))       # jackknife variance
    else:
        sigma = np.nan
    return Boresight(b, float(sigma), np.nan, n, True)


def _tangent_basis(b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.array([1.0, 0, 0]) if abs(b[0]) < 0.9 else np.array([0, 1.0, 0])
    u = _unit(np.cross(b, a))
    return u, np.cross(b, u)


def pattern_fit(los: np.ndarray, cn0_dbhz: np.ndarray, pattern: GainPattern = PATCH, iterations: int = 20,
                start: np.ndarray | None = None) -> Boresight:
    """Gauss-Newton fit of the boresight and c0 to C/N0 = c0 + G(angle(b, e)) (module docstring)."""
    use = np.isfinite(cn0_dbhz) & np.isfinite(los).all(-1)
    e, c = los[use], cn0_dbhz[use]
    n = len(c)
    b = weighted_mean(los, cn0_dbhz).boresight if start is None else _unit(np.asarray(start, float))
    if n < 4 or not np.isfinite(b).all():
        return Boresight(np.full(3, np.nan), np.nan, np.nan, n, False)
    c0 = float(np.mean(c - pattern.gain(np.degrees(np.arccos(np.clip(e @ b, -1, 1))))))
    for _ in range(iterations):
        u, v = _tangent_basis(b)
        th = np.arccos(np.clip(e @ b, -1, 1))
        s = np.sin(th)
        slope = pattern.slope_db_per_rad(np.degrees(th))
        # d theta / d(alpha u + beta v) = -(e . u) / sin(theta), -(e . v) / sin(theta)
        with np.errstate(divide="ignore", invalid="ignore"):
            J = np.stack([slope * -(e @ u) / s, slope * -(e @ v) / s, np.ones(n)], -1)
        J = np.where(np.isfinite(J), J, 0.0)
        r = c - (c0 + pattern.gain(np.degrees(th)))
        dx, *_ = np.linalg.lstsq(J, r, rcond=None)
        b = _unit(b + dx[0] * u + dx[1] * v)
        c0 += dx[2]
        if np.hypot(dx[0], dx[1]) < 1e-9:
            break
    th = np.arccos(np.clip(e @ b, -1, 1))
    r = c - (c0 + pattern.gain(np.degrees(th)))
    dof = max(n - 3, 1)
    s2 = float(r @ r / dof)
    try:
        P = s2 * np.linalg.inv(J.T @ J)
        sigma = float(np.degrees(np.sqrt(P[0, 0] + P[1, 1])))
    except np.linalg.LinAlgError:
        sigma = np.nan
    return Boresight(b, sigma, c0, n, bool(np.isfinite(sigma)))
