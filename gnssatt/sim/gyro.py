"""Simulated MEMS gyro logs: true body rates from a sampled true attitude, plus the gyro error model.

The true rate over each sample interval comes from consecutive true GCRF->body attitudes (a passive rotation
R(t + dt) = exp(-[theta x]) R(t), theta = omega dt; exact for a rate constant over the interval), and the log
holds, per axis, the mean rate over the interval that ends at the sample's time tag:

    omega_m = omega + b0 + b_gm(t) + b_fault(t) + n_arw,     n_arw ~ N(0, N^2 / dt),
    b_gm: first-order Gauss-Markov, sigma `drift_sigma_rad_s`, time constant `drift_tau_s` (stationary start),

then the angle increments omega_m dt are quantised to `quantum_rad` with the remainder carried over (an
integrating gyro's output). Implements: seed 002 sec. 2.2 (gyro model: drift as first-order Gauss-Markov plus a
white noise) and Table 1 (long-term stability 48 urad/s = 10 deg/h, random walk 20 urad/sqrt(s) = 0.066
deg/sqrt(h), 10 Hz); IEEE Std 952-1997 for the ARW / quantisation terms. A drift fault adds a step or a ramp
of `fault.size_rad_s` on one axis (seed 002 sec. 4.3: "gyro drift higher than its specified level").
Neglects: scale-factor and misalignment errors, g-sensitivity, temperature effects (temperature is written as a
constant).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss import rotations as rot

__all__ = ["GyroErrorModel", "DriftFault", "true_rates", "simulate_gyro"]

DEG_H = np.pi / 180.0 / 3600.0          # 1 deg/h in rad/s


@dataclass(frozen=True)
class DriftFault:
    """An extra drift on one axis from start_s to end_s (seconds after the log's first sample): a step of size,
    or a linear ramp reaching size after ramp_s."""

    axis: int = 2
    start_s: float = 0.0
    end_s: float = float("inf")
    size_rad_s: float = 10 * 48e-6
    ramp_s: float = 0.0


@dataclass(frozen=True)
class GyroErrorModel:
    """Seed 002 Table 1 gyro: 10 deg/h stability (Gauss-Markov sigma), 0.066 deg/sqrt(h) random walk."""

    bias_rad_s: tuple = (0.0, 0.0, 0.0)       # constant turn-on bias (added to the Gauss-Markov drift)
    drift_sigma_rad_s: float = 10.0 * DEG_H   # 48.5 urad/s
    drift_tau_s: float = 1800.0
    arw_rad_sqrt_s: float = 0.066 * np.pi / 180.0 / 60.0   # 19.2 urad/sqrt(s)
    quantum_rad: float = 1e-6
    temperature_c: float = 20.0
    faults: tuple = field(default_factory=tuple)          # DriftFault, ...


def true_rates(dt_s: np.ndarray, q_body_from_gcrf: np.ndarray) -> np.ndarray:
    """Mean body rates (n-1, 3) rad/s over each interval between consecutive true attitudes (n, 4)."""
    q_prev_inv = rot.quat_conjugate(q_body_from_gcrf[:-1])
    dq = rot.quat_multiply(q_body_from_gcrf[1:], q_prev_inv)        # R(t+dt) R(t)^T = exp(-[theta x])
    return rot.quat_to_rotvec(dq) / np.diff(dt_s)[:, None]


def _gauss_markov(rng, n: int, dt_s: float, sigma: float, tau_s: float) -> np.ndarray:
    """(n, 3) stationary first-order Gauss-Markov sequences of standard deviation sigma."""
    phi = np.exp(-dt_s / tau_s)
    from scipy.signal import lfilter

    w = rng.standard_normal((n, 3)) * sigma * np.sqrt(1 - phi * phi)
    x0 = rng.standard_normal(3) * sigma
    y, _ = lfilter([1.0], [1.0, -phi], w, axis=0, zi=(phi * x0)[None, :])
    return y


def fault_drift(model: GyroErrorModel, t_s: np.ndarray) -> np.ndarray:
    """(n, 3) extra drift of the model's faults at times t_s (s after the first sample)."""
    out = np.zeros((len(t_s), 3))
    for f in model.faults:
        on = (t_s >= f.start_s) & (t_s <= f.end_s)
        grow = np.ones_like(t_s) if f.ramp_s <= 0 else np.clip((t_s - f.start_s) / f.ramp_s, 0.0, 1.0)
        out[:, f.axis] += np.where(on, f.size_rad_s * grow, 0.0)
    return out


def simulate_gyro(t_s: np.ndarray, q_body_from_gcrf: np.ndarray, model: GyroErrorModel,
                  rng: np.random.Generator) -> tuple[np.ndarray, dict]:
    """(measured rates (n-1, 3) rad/s at t_s[1:], truth dict: true rate, drift, fault drift) of a gyro log.

    Args: t_s (n,) seconds of a uniform grid; q_body_from_gcrf (n, 4) the true attitude on it.
    """
    dt = float(np.median(np.diff(t_s)))
    w_true = true_rates(t_s, q_body_from_gcrf)
    n = len(w_true)
    drift = np.asarray(model.bias_rad_s, float)[None, :] + _gauss_markov(rng, n, dt, model.drift_sigma_rad_s,
                                                                        model.drift_tau_s)
    extra = fault_drift(model, t_s[1:] - t_s[0])
    arw = rng.standard_normal((n, 3)) * model.arw_rad_sqrt_s / np.sqrt(dt)
    angle = (w_true + drift + extra + arw) * dt
    if model.quantum_rad > 0:
        cum = np.cumsum(angle, axis=0)                   # quantise the running angle: remainder carried over
        qcum = np.round(cum / model.quantum_rad) * model.quantum_rad
        angle = np.diff(np.vstack([np.zeros((1, 3)), qcum]), axis=0)
    return angle / dt, {"true_rate_rad_s": w_true, "drift_rad_s": drift, "fault_drift_rad_s": extra}
