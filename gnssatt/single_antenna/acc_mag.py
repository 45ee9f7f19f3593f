"""Attitude from one antenna: the GNSS-derived specific force and an accelerometer, the geomagnetic field and a
magnetometer, solved per GNSS epoch as Wahba's problem by the SVD (seed 001 sec. V-VI).

Steps: (1) GNSS velocity -> acceleration by the differentiating filter (gnssatt.single_antenna.differentiate)
-> specific force in ECEF with gravity (J2), Coriolis and centrifugal terms; (2) the accelerometer and the
magnetometer low-passed with the same bandwidth and sampled at the GNSS epochs; (3) the lever-arm and
angular-rate terms removed (rate from a gyro log, or from the previous pass's attitudes); (4) Wahba by SVD
with Markley's covariance, q-method check; (5) optionally the accelerometer bias as the mean residual,
only where the specific force turns in the body frame enough to separate it from the attitude, then
(3)-(4) again. Epochs where the specific force is too small to observe (free fall in orbit) or parallel to
the field get no attitude but a flag.

Implements: seed 001 sec. V-VI; Markley (1988) via gnssatt.single_antenna.wahba; IGRF-14 via
gnssatt.single_antenna.geomagnetic.
Neglects: time-correlated velocity errors (white noise assumed for the sigmas); the accelerometer's scale
factors and misalignment; the GNSS antenna lever arm's effect on the velocity beyond the common lever
(d = accelerometer position - antenna position).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.time import GpsTime
from gnssatt.single_antenna.accelerometer import angular_rate_from_attitude, lever_arm_terms_m_s2
from gnssatt.single_antenna.differentiate import filter_series
from gnssatt.single_antenna.gravity import OMEGA_ECEF_RAD_S, specific_force_ecef_m_s2
from gnssatt.gnss.io.sensor_csv import SensorLog
from gnssatt.single_antenna.wahba import FLAG_NEAR_PARALLEL, FLAG_TOO_FEW, wahba_svd

FLAG_NO_SPECIFIC_FORCE = 8    # |specific force| below min_specific_force_m_s2 (free fall): no attitude
FLAG_GRAVITY_ONLY = 16        # no kinematic acceleration above its noise: gravity + magnetometer (tilt-compass)
FLAG_FILTER_EDGE = 32         # within two filter time constants of a data edge or gap (kept)
FLAG_NO_SENSOR = 64           # no accelerometer or magnetometer sample around the epoch: no attitude
FLAG_BIAS_UNOBSERVABLE = 128  # bias estimation asked for but the specific force did not turn enough (kept)
#: flags that mean "no attitude at this epoch"
NO_ATTITUDE = FLAG_TOO_FEW | FLAG_NEAR_PARALLEL | FLAG_NO_SPECIFIC_FORCE | FLAG_NO_SENSOR


@dataclass(frozen=True)
class AccMagSettings:
    """Tuning of the method (each with its unit; the job's Settings document them for users)."""

    bandwidth_hz: float = 0.1
    min_specific_force_m_s2: float = 0.5
    min_angle_deg: float = 10.0
    gravity_only_sigmas: float = 3.0
    estimate_bias: bool = True
    min_bias_spread_deg: float = 10.0
    accelerometer_noise_m_s2: float = 0.1
    accelerometer_bias_sigma_m_s2: float = 0.04
    magnetometer_noise_nT: float = 2.0
    magnetic_model_sigma_nT: float = 160.0
    velocity_sigma_m_s: float = 0.005
    iterations: int = 3
    filter_in_ecef: bool = True
    gravity_only_attitude: bool = True


@dataclass(frozen=True)
class AccMagInputs:
    """GNSS: time (n,), r_ecef_m, v_ecef_m_s (n, 3) of the antenna; sensor logs in body axes (rotated by the
    caller if the sensors are mounted otherwise); lever_body_m = accelerometer position - antenna position."""

    time: GpsTime
    r_ecef_m: np.ndarray
    v_ecef_m_s: np.ndarray
    accelerometer: SensorLog
    magnetometer: SensorLog
    b_model_ecef_nT: np.ndarray
    lever_body_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gyro: SensorLog | None = None


@dataclass
class AccMagSolution:
    """Per GNSS epoch: R_body_from_ecef (n, 3, 3) and q (n, 4) (NaN without attitude), cov_body_rad2 (n, 3, 3),
    flags (n,), f_ecef_m_s2, f_body_m_s2 (n, 3), bias_m_s2 (3,) (zeros if not estimated), notes."""

    time: GpsTime
    R_body_from_ecef: np.ndarray
    q_body_from_ecef: np.ndarray
    cov_body_rad2: np.ndarray
    flags: np.ndarray
    f_ecef_m_s2: np.ndarray
    f_body_m_s2: np.ndarray
    bias_m_s2: np.ndarray
    sigma_f_m_s2: float
    notes: list = field(default_factory=list)


def sample_at(log: SensorLog, t: GpsTime, bandwidth_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(values (n, 3) low-passed at bandwidth_hz and interpolated to t, noise gain); NaN where t falls outside
    the log or in one of its gaps."""
    from gnssatt.single_antenna.differentiate import GAP_FACTOR, segments

    lp = filter_series(log.t_s, log.values, bandwidth_hz, derivative=False)
    x = np.asarray(t - log.time[0], dtype=np.float64)
    out = np.full((len(x), 3), np.nan)
    step = float(np.median(np.diff(log.t_s))) if len(log.t_s) > 1 else 0.0
    for seg in segments(log.t_s):
        ts = log.t_s[seg]
        m = (x >= ts[0] - GAP_FACTOR * step / 2) & (x <= ts[-1] + GAP_FACTOR * step / 2)
        for k in range(3):
            out[m, k] = np.interp(x[m], ts, lp.values[seg, k])
    return out, lp.noise_gain


def sample_in_ecef(log: SensorLog, t: GpsTime, R_body_from_ecef: np.ndarray, bandwidth_hz: float) -> np.ndarray:
    """Body-frame values (n, 3) at t of a body-axes log low-passed in ECEF: each sample rotated into ECEF by
    the attitude interpolated (slerp) from R_body_from_ecef at t, filtered, sampled at t and rotated back by
    R_body_from_ecef. A body turning fast within the filter window then keeps the same frequency response
    as the GNSS-derived acceleration, which is filtered in ECEF. NaN where R is NaN or outside the log."""
    from scipy.spatial.transform import Rotation, Slerp

    ok = np.isfinite(R_body_from_ecef).all((-1, -2))
    if ok.sum() < 2:
        return np.full((len(np.atleast_1d(t.s)), 3), np.nan)
    x_t = np.asarray(t - log.time[0], dtype=np.float64)
    slerp = Slerp(x_t[ok], Rotation.from_matrix(R_body_from_ecef[ok]))
    inside = (log.t_s >= x_t[ok][0]) & (log.t_s <= x_t[ok][-1])
    R_s = slerp(np.clip(log.t_s, x_t[ok][0], x_t[ok][-1])).as_matrix()
    v_ecef = np.einsum("nji,nj->ni", R_s, log.values)
    v_ecef[~inside] = np.nan
    rotated = SensorLog(log.name, log.kind, log.time, log.t_s, np.where(inside[:, None], v_ecef, 0.0))
    y_ecef, _ = sample_at(rotated, t, bandwidth_hz)
    outside = (x_t < log.t_s[inside][0]) | (x_t > log.t_s[inside][-1]) if inside.any() else np.ones(len(x_t), bool)
    y_ecef[outside] = np.nan
    return np.einsum("nij,nj->ni", np.where(ok[:, None, None], R_body_from_ecef, np.nan), y_ecef)


def gnss_specific_force(inp: AccMagInputs, s: AccMagSettings):
    """(f_ecef (n, 3), kinematic part a + 2 w x v (n, 3), sigma of one component (m/s^2), edge (n,))."""
    t_s = np.asarray(inp.time - inp.time[0], dtype=np.float64)
    acc = filter_series(t_s, inp.v_ecef_m_s, s.bandwidth_hz, derivative=True)
    f = specific_force_ecef_m_s2(inp.r_ecef_m, inp.v_ecef_m_s, acc.values)
    kin = acc.values + 2.0 * np.cross(OMEGA_ECEF_RAD_S, inp.v_ecef_m_s)
    return f, kin, acc.noise_gain * s.velocity_sigma_m_s, acc.edge


def _weights(f_norm, b_norm, sigma_f, s: AccMagSettings, gain_acc: float, gain_mag: float, bias_sigma: float):
    sig_f = np.sqrt(sigma_f ** 2 + (gain_acc * s.accelerometer_noise_m_s2) ** 2 + bias_sigma ** 2) / f_norm
    sig_b = np.hypot(s.magnetic_model_sigma_nT, gain_mag * s.magnetometer_noise_nT) / b_norm
    return np.stack([1.0 / sig_f ** 2, 1.0 / sig_b ** 2], -1)


def _rates(inp: AccMagInputs, t_s: np.ndarray, R: np.ndarray | None, bw: float) -> tuple[np.ndarray, np.ndarray]:
    """(omega, omega_dot) (n, 3) body axes: from the gyro log, or from the attitudes R (zeros before any)."""
    if inp.gyro is not None:
        w, _ = sample_at(inp.gyro, inp.time, bw)
    elif R is None:
        return np.zeros((len(t_s), 3)), np.zeros((len(t_s), 3))
    else:
        w = angular_rate_from_attitude(t_s, R)
        w = np.where(np.isfinite(w), w, 0.0)
    wd = filter_series(t_s, np.where(np.isfinite(w), w, 0.0), bw, derivative=True).values
    return np.where(np.isfinite(w), w, 0.0), np.where(np.isfinite(wd), wd, 0.0)


def solve_acc_mag(inp: AccMagInputs, s: AccMagSettings = AccMagSettings()) -> AccMagSolution:
    """The method of the module docstring over every GNSS epoch of `inp`."""
    t_s = np.asarray(inp.time - inp.time[0], dtype=np.float64)
    f_ecef, kin, sigma_f, edge = gnss_specific_force(inp, s)
    acc, gain_acc = sample_at(inp.accelerometer, inp.time, s.bandwidth_hz)
    mag, gain_mag = sample_at(inp.magnetometer, inp.time, s.bandwidth_hz)
    b_ecef = np.asarray(inp.b_model_ecef_nT, dtype=np.float64)
    flags = np.where(edge, FLAG_FILTER_EDGE, 0)
    flags |= np.where(~(np.isfinite(acc).all(-1) & np.isfinite(mag).all(-1)), FLAG_NO_SENSOR, 0)
    f_norm = np.linalg.norm(f_ecef, axis=-1)
    low = ~(f_norm >= s.min_specific_force_m_s2) | ~(np.linalg.norm(acc, axis=-1) >= s.min_specific_force_m_s2)
    flags |= np.where(low, FLAG_NO_SPECIFIC_FORCE, 0)
    flags |= np.where(np.linalg.norm(kin, axis=-1) < s.gravity_only_sigmas * sigma_f * np.sqrt(3), FLAG_GRAVITY_ONLY, 0)
    bias = np.zeros(3)
    bias_sigma = s.accelerometer_bias_sigma_m_s2
    R = None
    notes: list[str] = []
    estimate = s.estimate_bias
    for it in range(max(1, s.iterations)):
        w, wd = _rates(inp, t_s, R, s.bandwidth_hz)
        if R is not None and s.filter_in_ecef:
            acc_e = sample_in_ecef(inp.accelerometer, inp.time, R, s.bandwidth_hz)
            mag_e = sample_in_ecef(inp.magnetometer, inp.time, R, s.bandwidth_hz)
            have = np.isfinite(acc_e).all(-1) & np.isfinite(mag_e).all(-1)
            acc = np.where(have[:, None], acc_e, acc)
            mag = np.where(have[:, None], mag_e, mag)
        f_body = acc - lever_arm_terms_m_s2(w, wd, inp.lever_body_m) - bias
        wts = _weights(f_norm, np.linalg.norm(b_ecef, axis=-1), sigma_f, s, gain_acc, gain_mag, bias_sigma)
        usable = (flags & (FLAG_NO_SENSOR | FLAG_NO_SPECIFIC_FORCE)) == 0
        wts = np.where(usable[:, None], wts, 0.0)
        sol = wahba_svd(np.stack([f_body, mag], 1), np.stack([f_ecef, b_ecef], 1), wts, min_angle_deg=s.min_angle_deg)
        R = sol.R_body_from_ref
        if estimate and it < s.iterations - 1:
            bias, bias_sigma, note = _estimate_bias(acc - lever_arm_terms_m_s2(w, wd, inp.lever_body_m), f_ecef, R,
                                                    sol.flags | flags, s)
            if note:
                notes.append(note)
                flags |= FLAG_BIAS_UNOBSERVABLE
                estimate = False
    out_flags = (flags | np.where(usable, sol.flags, 0)).astype(np.int64)
    refused = NO_ATTITUDE | (0 if s.gravity_only_attitude else FLAG_GRAVITY_ONLY)
    bad = (out_flags & refused) != 0
    R = np.where(bad[:, None, None], np.nan, sol.R_body_from_ref)
    return AccMagSolution(inp.time, R, np.where(bad[:, None], np.nan, sol.q_body_from_ref),
                          np.where(bad[:, None, None], np.nan, sol.cov_body_rad2), out_flags, f_ecef, f_body, bias,
                          sigma_f, list(dict.fromkeys(notes)))


def _estimate_bias(acc_corrected: np.ndarray, f_ecef: np.ndarray, R: np.ndarray, flags: np.ndarray,
                   s: AccMagSettings) -> tuple[np.ndarray, float, str | None]:
    """(bias (3,), its sigma, note): the mean of acc - R f over epochs with attitude, when the body-frame
    specific force spans at least min_bias_spread_deg; else zeros, the a priori sigma and a note."""
    from gnssatt.single_antenna.wahba import spanned_angle_deg

    good = ((flags & NO_ATTITUDE) == 0) & np.isfinite(R).all((-1, -2))
    if good.sum() < 10:
        return np.zeros(3), s.accelerometer_bias_sigma_m_s2, "too few epochs with attitude to estimate the bias"
    f_body = np.einsum("nij,nj->ni", R[good], f_ecef[good])
    u = f_body / np.linalg.norm(f_body, axis=-1, keepdims=True)
    spread = float(spanned_angle_deg(u[None], np.ones((1, len(u)), bool))[0])
    if spread < s.min_bias_spread_deg:
        return (np.zeros(3), s.accelerometer_bias_sigma_m_s2,
                f"accelerometer bias not observable: the specific force turned only {spread:.1f} deg in the body "
                f"frame (< {s.min_bias_spread_deg} deg), so a bias cannot be told from a tilt; not estimated")
    resid = acc_corrected[good] - f_body
    bias = resid.mean(0)
    return bias, float(np.std(resid - bias, axis=0).max() / np.sqrt(good.sum())), None


def check_units(inp: AccMagInputs, s: AccMagSettings = AccMagSettings()) -> None:
    """ParseError naming the file, first data line and column when a log's magnitudes disagree with physics
    by more than a factor 3 in the median: the accelerometer against the GNSS-derived specific force (where it
    exceeds 1 m/s^2; catches g for m/s^2), the magnetometer against the model field (catches uT, gauss, pT)."""
    from gnssatt.gnss.io.errors import ParseError

    f_ecef, _, _, _ = gnss_specific_force(inp, s)
    acc, _ = sample_at(inp.accelerometer, inp.time, s.bandwidth_hz)
    mag, _ = sample_at(inp.magnetometer, inp.time, s.bandwidth_hz)
    checks = ((inp.accelerometer, acc, f_ecef, 1.0, "m/s^2 (as the GNSS-derived specific force)"),
              (inp.magnetometer, mag, inp.b_model_ecef_nT, 0.0, "nT (as the geomagnetic model)"))
    for log, meas, ref, floor, unit in checks:
        ref_n = np.linalg.norm(ref, axis=-1)
        m = np.isfinite(meas).all(-1) & (ref_n > floor) & np.isfinite(ref_n)
        if m.sum() < 3:
            continue
        ratio = float(np.median(np.linalg.norm(meas[m], axis=-1) / ref_n[m]))
        if not 1 / 3 <= ratio <= 3:
            line = int(log.line_no[0]) if len(log.line_no) else 2
            raise ParseError(log.name, line, f"{log.kind} values in {unit}; their magnitudes are {ratio:.4g} times "
                             "the expected ones (wrong unit?)", f"median ratio {ratio:.4g}", column=1)
