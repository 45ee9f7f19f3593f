"""Smoothing a binned PCV map by a weighted least-squares fit of Zernike polynomials over the antenna hemisphere.

A bin mean of 30-300 samples from a few satellite tracks carries the tracks' multipath and noise (several mm at
low elevation on L2); an antenna's PCV varies over tens of degrees. The map is fitted with the Zernike
polynomials Z_n^m(rho, az) up to radial order N on the unit disk rho = (90 - el) / 90 (zenith at the centre,
antenna horizon on the rim; regular at the zenith), plus the three components of the body-frame line of sight
and a constant (so that the baseline/map split of gnssatt.calibration.decomposition commutes with the smoothing),
weighted by the bins' sample weights, with a small ridge for bins-free corners. The fitted surface replaces the
values of the filled bins only: an empty bin stays empty (null), nothing is extrapolated.

Order N = 0 keeps the bin means. Structure finer than ~90/N deg in zenith angle (and 360/N deg in azimuth at
the horizon) is smoothed away: that is the trade-off to choose (docs/calibration.md gives the measured errors).

Implements: Zernike radial polynomials R_n^m (Born & Wolf, Principles of Optics, sec. 9.2.1) and weighted
ridge least squares.
"""
from __future__ import annotations

from math import factorial

import numpy as np

__all__ = ["zernike_basis", "smooth_map"]

RIDGE = 1e-8  # relative to the mean diagonal of the normal matrix


def _radial(n: int, m: int, rho: np.ndarray) -> np.ndarray:
    """Zernike radial polynomial R_n^m(rho), n - m even, 0 <= m <= n."""
    out = np.zeros_like(rho)
    for k in range((n - m) // 2 + 1):
        c = (-1) ** k * factorial(n - k) / (factorial(k) * factorial((n + m) // 2 - k) * factorial((n - m) // 2 - k))
        out = out + c * rho ** (n - 2 * k)
    return out


def zernike_basis(az_deg: np.ndarray, el_deg: np.ndarray, order: int) -> np.ndarray:
    """(n_points, n_terms) Zernike polynomials up to radial order `order` at (az, el) in the antenna frame
    (rho = (90 - el) / 90, clipped to [0, 1]); terms cos(m az) R_n^m and sin(m az) R_n^m, n - m even."""
    az = np.radians(np.asarray(az_deg, dtype=np.float64)).ravel()
    rho = np.clip((90.0 - np.asarray(el_deg, dtype=np.float64)) / 90.0, 0.0, 1.0).ravel()
    cols = []
    for n in range(order + 1):
        for m in range(n % 2, n + 1, 2):
            r = _radial(n, m, rho)
            cols.append(r * np.cos(m * az))
            if m > 0:
                cols.append(r * np.sin(m * az))
    return np.stack(cols, axis=1)


def smooth_map(values: np.ndarray, weight: np.ndarray, az_deg: np.ndarray, el_deg: np.ndarray, order: int,
               g_body: np.ndarray | None = None) -> np.ndarray:
    """Values (same shape as `values`) of the weighted fit on the bins where `values` is finite and weight > 0;
    NaN elsewhere. order 0 returns the values unchanged.

    Args:
        values, weight: (n_bins,) or (n_el, n_az) map and bin weights; az_deg, el_deg: bin centres of the same shape.
        g_body: (n_bins, 3) body-frame line of sight per bin, added to the basis (see the module docstring).
    """
    v = np.asarray(values, dtype=np.float64)
    if order <= 0:
        return v.copy()
    flat = v.ravel()
    w = np.asarray(weight, dtype=np.float64).ravel()
    ok = np.isfinite(flat) & (w > 0)
    out = np.full(flat.shape, np.nan)
    if not np.any(ok):
        return out.reshape(v.shape)
    B = zernike_basis(np.asarray(az_deg).ravel()[ok], np.asarray(el_deg).ravel()[ok], order)
    if g_body is not None:
        B = np.concatenate([B, np.asarray(g_body, dtype=np.float64)[ok]], axis=1)
    ww = w[ok] / np.mean(w[ok])
    N = B.T @ (B * ww[:, None])
    N += np.eye(N.shape[0]) * RIDGE * np.trace(N) / N.shape[0]
    coef = np.linalg.solve(N, B.T @ (ww * flat[ok]))
    out[ok] = B @ coef
    return out.reshape(v.shape)
