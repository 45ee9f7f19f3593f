"""A differentiating filter of configurable bandwidth for GNSS velocity, and the matching low-pass for the
body-frame sensors, with the noise gain of each.

Per segment without gaps (steps within 1.5 times the median step), less its least-squares quadratic (added
back exactly afterwards): a zero-phase Butterworth low-pass of
order 2 (applied forward and back, so |H|^2 of order 4 and no delay) at `bandwidth_hz`, then the central
difference (np.gradient, second order) in time. A bandwidth at or above the Nyquist frequency skips the
low-pass. The white-noise gain is the 2-norm of the filter's impulse response (sigma_out = gain sigma_in).

Implements: Butterworth design by scipy.signal.butter, filtfilt with Gustafsson's initial conditions
(scipy.signal.filtfilt method "gust"); central differences of Fornberg (1988).
Neglects: non-uniform sampling within a segment (the median step is used for the design).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: a step longer than this many median steps starts a new segment
GAP_FACTOR = 1.5
#: samples within this many filter time constants (1 / bandwidth) of a segment's ends are flagged as edges: the
#: start-up transient of filtfilt has decayed below 1e-4 of the signal after 2 (measured in the tests)
EDGE_TIME_CONSTANTS = 2.0


class Filtered(NamedTuple):
    """values (n, 3) (NaN where a segment is too short), edge (n,) bool, noise_gain (unitless or 1/s)."""

    values: np.ndarray
    edge: np.ndarray
    noise_gain: float


def segments(t_s: np.ndarray) -> list[slice]:
    """Slices of t_s (increasing seconds) between gaps longer than GAP_FACTOR median steps."""
    if len(t_s) < 2:
        return [slice(0, len(t_s))]
    dt = np.diff(t_s)
    cut = np.flatnonzero(dt > GAP_FACTOR * np.median(dt)) + 1
    edges = [0, *cut.tolist(), len(t_s)]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:])]


def _lowpass(x: np.ndarray, fs_hz: float, bandwidth_hz: float) -> np.ndarray:
    from scipy.signal import butter, filtfilt

    if bandwidth_hz >= 0.5 * fs_hz:
        return x
    b, a = butter(2, bandwidth_hz / (0.5 * fs_hz))
    return filtfilt(b, a, x, axis=0, method="gust")


def _gain(fs_hz: float, bandwidth_hz: float, derivative: bool) -> float:
    n = int(max(64, 40 * fs_hz / min(bandwidth_hz, 0.5 * fs_hz)))
    imp = np.zeros((2 * n + 1, 1))
    imp[n] = 1.0
    y = _lowpass(imp, fs_hz, bandwidth_hz)
    if derivative:
        y = np.gradient(y[:, 0], 1.0 / fs_hz)
    return float(np.sqrt(np.sum(np.asarray(y) ** 2)))


def filter_series(t_s: np.ndarray, x: np.ndarray, bandwidth_hz: float, derivative: bool) -> Filtered:
    """Low-passed x (n, 3), or its time derivative when `derivative`, segment by segment (module docstring)."""
    t_s = np.asarray(t_s, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    out = np.full(x.shape, np.nan)
    edge = np.zeros(len(t_s), bool)
    step = float(np.median(np.diff(t_s))) if len(t_s) > 1 else 1.0
    fs = 1.0 / step
    for seg in segments(t_s):
        n = seg.stop - seg.start
        if n < 16:                       # too short for the filter's initial conditions and a derivative
            edge[seg] = True
            continue
        tt = t_s[seg]
        # a quadratic per axis is taken out before the filter and added back exactly (its derivative
        # analytically): the filter's start-up transients then scale with the residual, not with a LEO's
        # 8 m/s^2 turning velocity
        u = tt - tt.mean()
        coef = np.polynomial.polynomial.polyfit(u, x[seg], 2)              # (3, n_axes)
        trend = np.polynomial.polynomial.polyval(u, coef).T
        y = _lowpass(x[seg] - trend, fs, bandwidth_hz)
        if derivative:
            out[seg] = np.gradient(y, tt, axis=0) + (coef[1] + 2 * coef[2] * u[:, None])
        else:
            out[seg] = y + trend
        edge[seg] = (tt - tt[0] < EDGE_TIME_CONSTANTS / bandwidth_hz) | (tt[-1] - tt < EDGE_TIME_CONSTANTS / bandwidth_hz)
    return Filtered(out, edge, _gain(fs, bandwidth_hz, derivative))
