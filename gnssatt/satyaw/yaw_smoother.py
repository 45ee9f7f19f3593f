"""Optional smoothing of an epoch-wise yaw series with a yaw-rate-limited process model (seed 004 sec. 2.4:
QZS-2/-4 turn at most 0.055 deg/s).

Random walk of the unwrapped yaw with increment sigma = rate_limit x dt (a step at the limit rate is one
sigma), measurements the epoch-wise estimates with their sigmas; Kalman filter forward, Rauch-Tung-Striebel
smoother backward (Rauch, Tung & Striebel 1965), scalar and vectorised over nothing but time (numpy loop).
Faster slews (0.5 deg/s out of orbit normal, Fig. 8) are smoothed over: keep the epoch-wise series for them.
"""
from __future__ import annotations

import numpy as np

from gnssatt.satyaw.attitude_models import wrap_deg

__all__ = ["smooth_yaw"]


def smooth_yaw(t_s, yaw_deg, sigma_deg, rate_limit_deg_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(smoothed yaw (T,), sigma (T,)) in degrees; NaN inputs are prediction-only epochs."""
    t = np.asarray(t_s, dtype=np.float64)
    ok = np.isfinite(yaw_deg) & np.isfinite(sigma_deg)
    if not ok.any():
        return np.full(len(t), np.nan), np.full(len(t), np.nan)
    y = np.full(len(t), np.nan)
    y[ok] = np.degrees(np.unwrap(np.radians(np.asarray(yaw_deg)[ok])))
    r = np.where(ok, np.asarray(sigma_deg) ** 2, np.inf)
    n = len(t)
    xf, pf, xp, pp = (np.zeros(n) for _ in range(4))
    first = int(np.argmax(ok))
    x, p = y[first], r[first]
    for k in range(n):
        q = (rate_limit_deg_s * (t[k] - t[k - 1])) ** 2 if k else 0.0
        xp[k], pp[k] = x, p + q
        if ok[k]:
            g = pp[k] / (pp[k] + r[k])
            x, p = xp[k] + g * (y[k] - xp[k]), (1 - g) * pp[k]
        else:
            x, p = xp[k], pp[k]
        xf[k], pf[k] = x, p
    xs, ps = xf.copy(), pf.copy()
    for k in range(n - 2, -1, -1):
        c = pf[k] / pp[k + 1]
        xs[k] = xf[k] + c * (xs[k + 1] - xp[k + 1])
        ps[k] = pf[k] + c * c * (ps[k + 1] - pp[k + 1])
    return wrap_deg(xs), np.sqrt(ps)
