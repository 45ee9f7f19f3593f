"""Satellite positions, velocities and clocks at arbitrary GPS times from an SP3 file.

Positions: Lagrange interpolation over a sliding window of `n_points` (default 10, i.e. degree 9) consecutive
SP3 epochs centred on each requested time, in the file's Earth-fixed frame; velocity is the time derivative of
the same interpolant. Clocks: linear interpolation between the two bracketing epochs (SP3 clocks are random-walk
like; higher order adds noise). Everything is vectorised over times and satellites.

Result is NaN where the time lies outside the file's span, where a value inside the window is absent/bad in the
file, or where the window spans a time gap (an epoch step longer than 1.5 nominal intervals).

Implements: Lagrange interpolation in product form, L_j(t) = prod_{k!=j} (t - t_k)/(t_j - t_k), and its derivative
L_j'(t) = sum_{m!=j} 1/(t_j - t_m) prod_{k!=j,m} (t - t_k)/(t_j - t_k) (the leave-one-out products come from
prefix/suffix cumulative products, so a time on a node needs no special case; O(n^2) per time, n = 10).
Degree 9 over 15-min GPS orbits follows Schenewerk (2003), "A brief review of basic GPS orbit interpolation
strategies", GPS Solutions 6:265-267 (mm-level for 15-min IGS orbits with 9-11 points).
Neglects: Earth rotation within the window (interpolating in ECEF is standard at these orders; the test on the
real CODE file measures the residual); at the first/last (n_points/2) epochs the window cannot be centred and
the interpolant is lopsided (less accurate; the test states by how much).
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.io.sp3 import Sp3Data
from gnssatt.gnss.time import GpsTime

__all__ = ["interpolate_sp3", "interpolate_sp3_velocity", "lagrange_basis"]

#: A window whose epoch steps exceed this many nominal intervals spans a gap in the file -> NaN.
GAP_FACTOR = 1.5


def lagrange_basis(d_s: np.ndarray, derivative: bool = False) -> np.ndarray:
    """Lagrange basis values L_j(t) (or dL_j/dt, 1/s) for nodes at offsets d_s = t_j - t, shape (..., n).

    Args:
        d_s: (..., n) node times minus the evaluation time, seconds; nodes distinct.
        derivative: return dL_j/dt (1/s) instead of L_j (unitless).
    Implements: product-form Lagrange basis and its derivative (see module docstring).
    """
    d = np.asarray(d_s, dtype=np.float64)
    n = d.shape[-1]
    diff = d[..., :, None] - d[..., None, :]          # t_j - t_k
    eye = np.eye(n, dtype=bool)
    diff = np.where(eye, 1.0, diff)
    a = np.where(eye, 1.0, (-d[..., None, :]) / diff)  # (t - t_k)/(t_j - t_k), 1 on the diagonal
    if not derivative:
        return np.prod(a, axis=-1)
    ones = np.ones(a.shape[:-1] + (1,))
    pre = np.concatenate([ones, np.cumprod(a[..., :-1], axis=-1)], axis=-1)                  # prod_{k<m}
    suf = np.concatenate([np.cumprod(a[..., :0:-1], axis=-1)[..., ::-1], ones], axis=-1)   # prod_{k>m}
    excl = pre * suf                                                                           # prod_{k!=m}
    inv = np.where(eye, 0.0, 1.0 / diff)
    return np.sum(excl * inv, axis=-1)


def _select(sp3: Sp3Data, sats) -> tuple[np.ndarray, np.ndarray]:
    index = {s: j for j, s in enumerate(sp3.sats)}
    cols = np.array([index.get(s, -1) for s in sats], dtype=np.int64)
    return cols, cols >= 0


def _windows(sp3: Sp3Data, t: GpsTime, n_points: int, max_step_s: float | None = None):
    """(start index (n_t,), node offsets t_j - t (n_t, n) s, usable (n_t,) bool) of the centred windows."""
    n_ep = len(sp3.time)
    t1 = GpsTime(np.atleast_1d(t.s), np.atleast_1d(t.frac))
    x = sp3.time - sp3.time[0]                     # node times since the first epoch, s (two-part difference)
    tt = t1 - sp3.time[0]
    n = min(n_points, n_ep)
    start = np.clip(np.searchsorted(x, tt, side="right") - n // 2, 0, max(n_ep - n, 0))
    idx = start[:, None] + np.arange(n)[None, :]
    d = x[idx] - tt[:, None]
    inside = (tt >= x[0]) & (tt <= x[-1]) & (n_ep >= 2)
    steps = np.diff(x)
    nominal = sp3.interval_s if sp3.interval_s > 0 else (np.median(steps) if steps.size else 0.0)
    if steps.size:
        gap_step = steps > (GAP_FACTOR * nominal if max_step_s is None else max_step_s)
        cum = np.concatenate([[0], np.cumsum(gap_step)])
        has_gap = cum[idx[:, -1]] - cum[idx[:, 0]] > 0
    else:
        has_gap = np.zeros(len(tt), dtype=bool)
    return idx, d, inside & ~has_gap, tt, x


def interpolate_sp3(sp3: Sp3Data, sats, t: GpsTime, *, n_points: int = 10,
                    max_step_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(position_ecef_m (n_t, n_s, 3), clock_s (n_t, n_s)) of satellites `sats` at GPS times `t`.

    Args:
        sp3: the file (`read_sp3`); sats: satellite ids, e.g. ['G01', 'R05'] (unknown ids give NaN);
        t: GpsTime scalar or (n_t,); n_points: Lagrange window length (degree n_points - 1);
        max_step_s: longest epoch step a window may contain, s (default 1.5 x the file's interval).
    Returns: positions in the SP3 frame (metres) by Lagrange interpolation, clocks (seconds) linearly;
        NaN outside the file span, on absent/bad values in the window, or across a time gap.
    Implements: see module docstring.
    """
    cols, known = _select(sp3, sats)
    idx, d, usable, tt, x = _windows(sp3, t, n_points, max_step_s)
    n_t, n_s = len(tt), len(cols)
    pos = np.full((n_t, n_s, 3), np.nan)
    clk = np.full((n_t, n_s), np.nan)
    if not known.any() or len(sp3.time) < 2:
        return pos, clk
    w = lagrange_basis(d)                                             # (n_t, n)
    p = sp3.position_ecef_m[:, cols[known]]                            # (n_ep, n_k, 3)
    pos_k = np.einsum("tj,tjsc->tsc", w, p[idx])
    pos_k[~usable] = np.nan
    pos[:, known] = pos_k
    # Clock: linear between the bracketing epochs.
    n_ep = len(x)
    i = np.clip(np.searchsorted(x, tt, side="right") - 1, 0, n_ep - 2)
    frac = (tt - x[i]) / (x[i + 1] - x[i])
    c = sp3.clock_s[:, cols[known]]
    clk_k = (1.0 - frac)[:, None] * c[i] + frac[:, None] * c[i + 1]
    inside = (tt >= x[0]) & (tt <= x[-1])
    clk_k[~inside] = np.nan
    clk[:, known] = clk_k
    return pos, clk


def interpolate_sp3_velocity(sp3: Sp3Data, sats, t: GpsTime, *, n_points: int = 10,
                             max_step_s: float | None = None) -> np.ndarray:
    """Velocity (n_t, n_s, 3), m/s in the SP3 (Earth-fixed) frame: time derivative of the position interpolant.

    Args: as `interpolate_sp3`. NaN where the position interpolant is NaN.
    Implements: derivative of the product-form Lagrange basis (module docstring).
    Neglects: nothing beyond the interpolant; this is the Earth-fixed velocity (no omega x r term).
    """
    cols, known = _select(sp3, sats)
    idx, d, usable, tt, _ = _windows(sp3, t, n_points, max_step_s)
    vel = np.full((len(tt), len(cols), 3), np.nan)
    if not known.any() or len(sp3.time) < 2:
        return vel
    dw = lagrange_basis(d, derivative=True)
    p = sp3.position_ecef_m[:, cols[known]]
    v = np.einsum("tj,tjsc->tsc", dw, p[idx])
    v[~usable] = np.nan
    vel[:, known] = v
    return vel
