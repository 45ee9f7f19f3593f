"""Simulated accelerometer, magnetometer and GNSS velocity logs with their truth, for the single-antenna
methods: seed 001's airborne manoeuvres (sec. V), a static user and a LEO in free fall (sec. VI).

Truth at `truth_rate_hz`: the trajectory (geodetic integration of speed, heading and flight-path angle with
a first-order lag on the commanded rates, so accelerations are continuous), ECEF position, velocity and
acceleration by a cubic spline of the positions, the attitude (yaw = heading, pitch = flight-path angle,
roll = coordinated-turn bank), the body rate relative to inertial space and its derivative. Sensors:
accelerometer = seed 001 sec. VI model (lever arm, rate terms, bias, white noise of a given power spectral
density: sigma = sqrt(psd * rate), Simulink's band-limited white noise), optional quantisation; magnetometer
= the true field (IGRF-14 plus a constant NED model error, seed 001: 140/140/200 nT) in body axes plus
white noise, quantised to its resolution; GNSS velocity = truth plus white noise per ECEF axis.

Implements: seed 001 sec. V (manoeuvre list) and VI (sensor models and parameters); CONVENTIONS.md sensor
log formats (docs/formats/inertial_csv.md).
Neglects: wind and angle of attack (the body x axis is along the velocity), time-correlated GNSS velocity
errors, the gravity model's own errors (truth and estimator share the J2 field).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.gnss.frames import R_ned_from_ecef, geodetic_to_ecef
from gnssatt.gnss.rotations import euler321_to_dcm
from gnssatt.gnss.time import GpsTime

G0_M_S2 = 9.80665
MG_M_S2 = 1e-3 * G0_M_S2


@dataclass(frozen=True)
class SensorParams:
    """Seed 001 sec. VI values by default: accelerometer bias 3.5/3.5/4.0 mg, lever arm (0, 0, 5) cm, noise
    power 0.001 (m/s^2)^2/Hz at 10 Hz; magnetometer 2 nT RMS, 25 nT resolution, 10 Hz, model error 1-sigma
    140/140/200 nT (N/E/D); GNSS velocity at 1 Hz with the per-axis sigma whose plain first difference has the
    acceleration errors of seed 001 Fig. 9 (0.007, 0.004, 0.003 m/s^2 in ECEF x, y, z)."""

    accel_bias_m_s2: tuple = (3.5 * MG_M_S2, 3.5 * MG_M_S2, 4.0 * MG_M_S2)
    accel_lever_body_m: tuple = (0.0, 0.0, 0.05)
    accel_noise_psd_m2_s4_hz: float = 0.001
    accel_rate_hz: float = 10.0
    accel_resolution_m_s2: float = 0.0
    mag_noise_nT: float = 2.0
    mag_resolution_nT: float = 25.0
    mag_rate_hz: float = 10.0
    mag_model_error_sigma_ned_nT: tuple = (140.0, 140.0, 200.0)
    velocity_rate_hz: float = 1.0
    velocity_sigma_ecef_m_s: tuple = (0.007 / np.sqrt(2), 0.004 / np.sqrt(2), 0.003 / np.sqrt(2))


@dataclass
class InertialTruth:
    """Truth at the truth rate: time (n,), r/v/a_ecef (n, 3), R_body_from_ecef (n, 3, 3), omega_body_rad_s and
    omega_dot_body_rad_s2 (n, 3) (relative to inertial space, body axes), f_ecef_m_s2 (n, 3) specific force at
    the body origin (the antenna), kind, and the magnetic model error drawn (ned, nT)."""

    time: GpsTime
    r_ecef_m: np.ndarray
    v_ecef_m_s: np.ndarray
    a_ecef_m_s2: np.ndarray
    R_body_from_ecef: np.ndarray
    omega_body_rad_s: np.ndarray
    omega_dot_body_rad_s2: np.ndarray
    f_ecef_m_s2: np.ndarray
    kind: str
    mag_error_ned_nT: np.ndarray = field(default_factory=lambda: np.zeros(3))


#: seed 001 sec. V: (name, duration or None (until done), speed change m/s, heading change deg, height change m)
AIRBORNE_MANOEUVRES = (
    ("slow acceleration", 20.0, 60.0, 0.0, 0.0),
    ("climb", None, 0.0, 0.0, 300.0),
    ("acceleration turn", None, 30.0, 125.0, 0.0),
    ("acceleration", 120.0, 120.0, 0.0, 0.0),
    ("straight", 950.0, 0.0, 0.0, 0.0),
)
#: climb rate (8 m/s) and the lateral / normal acceleration of the climb and turn entries (1 g to 1.5 g)
CLIMB_RATE_M_S = 8.0
LATERAL_G = (1.0, 1.5)
#: time constant of the first-order lag on commanded rates (s): continuous accelerations, bounded jerk
LAG_S = 1.0


def _commands(dt: float) -> list[tuple[float, float, float]]:
    """Per truth step the commanded (speed rate m/s^2, heading rate rad/s, target flight-path angle rad), by a
    state machine over AIRBORNE_MANOEUVRES (the v0 = 0 start is a take-off roll)."""
    cmds = []
    v, psi_done, h_done = 0.0, 0.0, 0.0
    for name, dur, dv, dpsi, dh in AIRBORNE_MANOEUVRES:
        if dh:
            n_seg = int(np.ceil(dh / CLIMB_RATE_M_S / dt))
            gamma = np.arcsin(CLIMB_RATE_M_S / max(v, 1.0))
            cmds += [(0.0, 0.0, gamma)] * n_seg
        elif dpsi:
            turn = np.radians(dpsi)
            psi_done = 0.0
            while psi_done < turn:
                frac = psi_done / turn
                a_lat = G0_M_S2 * (LATERAL_G[0] + (LATERAL_G[1] - LATERAL_G[0]) * frac)
                rate = a_lat / max(v, 1.0)
                dur_est = turn / rate
                cmds.append((dv / dur_est, rate, 0.0))
                v += dv / dur_est * dt
                psi_done += rate * dt
        else:
            n_seg = int(round(dur / dt))
            cmds += [(dv / dur, 0.0, 0.0)] * n_seg
            v += dv
    return cmds


def airborne_truth(t0: GpsTime, lat_deg: float = 50.0 + 25.21 / 60, lon_deg: float = -(4.0 + 5.994 / 60),
                   h_m: float = 140.0, truth_rate_hz: float = 100.0) -> InertialTruth:
    """Seed 001's dynamic airborne user (sec. V): start 50 deg 25.21' N, 4 deg 5.994' W, 140 m, heading north."""
    dt = 1.0 / truth_rate_hz
    cmds = np.array(_commands(dt))
    n = len(cmds)
    a_lag = dt / (LAG_S + dt)
    st = np.zeros((n, 6))     # v, psi, gamma, lat, lon, h
    st[0, 3:] = np.radians(lat_deg), np.radians(lon_deg), h_m
    rates = np.zeros(3)
    psidot = np.zeros(n)
    for k in range(1, n):
        v, psi, gam, lat, lon, h = st[k - 1]
        rates += a_lag * (np.array([cmds[k, 0], cmds[k, 1], (cmds[k, 2] - gam) / LAG_S]) - rates)
        psidot[k] = rates[1]
        v, psi, gam = v + rates[0] * dt, psi + rates[1] * dt, gam + rates[2] * dt
        Rm = 6378137.0 * (1 - 0.00669438) / (1 - 0.00669438 * np.sin(lat) ** 2) ** 1.5 + h
        Rn = 6378137.0 / np.sqrt(1 - 0.00669438 * np.sin(lat) ** 2) + h
        st[k] = v, psi, gam, lat + v * np.cos(gam) * np.cos(psi) / Rm * dt, \
            lon + v * np.cos(gam) * np.sin(psi) / (Rn * np.cos(lat)) * dt, h + v * np.sin(gam) * dt
    bank = np.arctan2(st[:, 0] * np.cos(st[:, 2]) * psidot, G0_M_S2)
    t = t0 + np.arange(n) * dt
    R_body_from_ned = euler321_to_dcm(np.degrees(st[:, 1]), np.degrees(st[:, 2]), np.degrees(bank))
    return _truth_from_path(t, st[:, 3], st[:, 4], st[:, 5], R_body_from_ned, "terrestrial")


def static_truth(t0: GpsTime, duration_s: float, lat_deg: float = 46.0 + 59.4 / 60, lon_deg: float = 6.94,
                 h_m: float = 400.0, yaw_deg: float = 30.0, truth_rate_hz: float = 100.0) -> InertialTruth:
    """Seed 001's static Earth user (Neuchatel, 400 m), level, at a fixed heading."""
    n = int(duration_s * truth_rate_hz) + 1
    t = t0 + np.arange(n) / truth_rate_hz
    R = np.broadcast_to(euler321_to_dcm(yaw_deg, 0.0, 0.0), (n, 3, 3))
    return _truth_from_path(t, np.full(n, np.radians(lat_deg)), np.full(n, np.radians(lon_deg)), np.full(n, h_m),
                            R, "terrestrial")


def _truth_from_path(t: GpsTime, lat, lon, h, R_body_from_ned, kind: str) -> InertialTruth:
    from scipy.interpolate import CubicSpline

    from gnssatt.single_antenna.accelerometer import angular_rate_from_attitude
    from gnssatt.single_antenna.gravity import specific_force_ecef_m_s2

    ts = np.asarray(t - t[0], dtype=np.float64)
    r = np.asarray(geodetic_to_ecef(lat, lon, h), dtype=np.float64)
    cs = CubicSpline(ts, r, axis=0)
    v, a = cs(ts, 1), cs(ts, 2)
    R = np.einsum("nij,njk->nik", R_body_from_ned, R_ned_from_ecef(lat, lon))
    w = angular_rate_from_attitude(ts, R)
    wd = np.gradient(w, ts, axis=0)
    return InertialTruth(t, r, v, a, R, w, wd, specific_force_ecef_m_s2(r, v, a), kind)


def leo_truth(t0: GpsTime, duration_s: float, truth_rate_hz: float = 10.0) -> InertialTruth:
    """Seed 001 sec. VI's orbit (a = 7014.3 km, e = 0, i = 98 deg, all angles 0) in free fall, Earth pointing:
    the true specific force is zero (drag neglected), whatever the GNSS-derived acceleration says."""
    from gnssatt.gnss.frames import R_orbital_from_ecef
    from gnssatt.planning.trajectory import Keplerian, track_from_keplerian
    from gnssatt.single_antenna.accelerometer import angular_rate_from_attitude

    n = int(duration_s * truth_rate_hz) + 1
    t = t0 + np.arange(n) / truth_rate_hz
    tr = track_from_keplerian(Keplerian(t0, 7014.3e3, 0.0, 98.0, 0.0, 0.0, 0.0), t)
    ts = np.asarray(t - t[0], dtype=np.float64)
    R = R_orbital_from_ecef(tr.r_ecef_m, tr.v_ecef_m_s)
    w = angular_rate_from_attitude(ts, R)
    return InertialTruth(t, tr.r_ecef_m, tr.v_ecef_m_s, np.gradient(tr.v_ecef_m_s, ts, axis=0), R, w,
                         np.gradient(w, ts, axis=0), np.zeros((n, 3)), "spacecraft")


def _resample(truth: InertialTruth, rate_hz: float) -> np.ndarray:
    """Indices of the truth samples at `rate_hz` (the truth rate must be a multiple)."""
    ts = np.asarray(truth.time - truth.time[0], dtype=np.float64)
    step = int(round(1.0 / (rate_hz * (ts[1] - ts[0]))))
    return np.arange(0, len(ts), max(step, 1))


def _quantise(x: np.ndarray, res: float) -> np.ndarray:
    return np.round(x / res) * res if res > 0 else x


@dataclass
class SensorLogs:
    """The simulated logs as arrays at their own rates: accelerometer, magnetometer (each: time, values), and
    the GNSS velocity (time, r_ecef_m, v_ecef_m_s), plus the model field at the magnetometer samples."""

    acc_time: GpsTime
    acc_m_s2: np.ndarray
    mag_time: GpsTime
    mag_nT: np.ndarray
    gnss_time: GpsTime
    gnss_r_ecef_m: np.ndarray
    gnss_v_ecef_m_s: np.ndarray
    idx_gnss: np.ndarray


def simulate_sensors(truth: InertialTruth, p: SensorParams, rng: np.random.Generator, field_ecef_nT) -> SensorLogs:
    """Sensor logs from the truth (module docstring); field_ecef_nT(r (n, 3)) -> (n, 3) is the model field,
    to which the drawn model error is added to make the true field."""
    from gnssatt.gnss.frames import ecef_to_geodetic
    from gnssatt.single_antenna.accelerometer import accelerometer_model_m_s2

    ia = _resample(truth, p.accel_rate_hz)
    f_body = np.einsum("nij,nj->ni", truth.R_body_from_ecef[ia], truth.f_ecef_m_s2[ia])
    acc = accelerometer_model_m_s2(f_body, truth.omega_body_rad_s[ia], truth.omega_dot_body_rad_s2[ia],
                                   np.array(p.accel_lever_body_m), np.array(p.accel_bias_m_s2))
    acc = _quantise(acc + rng.normal(0, np.sqrt(p.accel_noise_psd_m2_s4_hz * p.accel_rate_hz), acc.shape),
                    p.accel_resolution_m_s2)
    im = _resample(truth, p.mag_rate_hz)
    err_ned = rng.normal(0, 1, 3) * np.array(p.mag_model_error_sigma_ned_nT)
    truth.mag_error_ned_nT = err_ned
    lat, lon, _ = ecef_to_geodetic(truth.r_ecef_m[im])
    b_true = field_ecef_nT(truth.r_ecef_m[im]) + np.einsum("nji,j->ni", R_ned_from_ecef(lat, lon), err_ned)
    mag = np.einsum("nij,nj->ni", truth.R_body_from_ecef[im], b_true) + rng.normal(0, p.mag_noise_nT, b_true.shape)
    mag = _quantise(mag, p.mag_resolution_nT)
    ig = _resample(truth, p.velocity_rate_hz)
    v = truth.v_ecef_m_s[ig] + rng.normal(0, 1, (len(ig), 3)) * np.array(p.velocity_sigma_ecef_m_s)
    return SensorLogs(truth.time[ia], acc, truth.time[im], mag, truth.time[ig], truth.r_ecef_m[ig], v, ig)


def write_sensor_csvs(logs: SensorLogs, out_dir: str | Path) -> dict[str, Path]:
    """accelerometer.csv, magnetometer.csv and velocity.csv (with the position columns) in out_dir."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)

    def write(name, head, time, cols, fmt):
        iso = time.iso(decimals=3)
        lines = [head] + [",".join([iso[i]] + [fmt % x for x in cols[i]]) for i in range(len(cols))]
        (out / name).write_text("\n".join(lines) + "\n")
        return out / name
    return {
        "accelerometer": write("accelerometer.csv", "time_gps,ax_m_s2,ay_m_s2,az_m_s2", logs.acc_time,
                               logs.acc_m_s2, "%.6f"),
        "magnetometer": write("magnetometer.csv", "time_gps,bx_nT,by_nT,bz_nT", logs.mag_time, logs.mag_nT, "%.1f"),
        "velocity": write("velocity.csv", "time_gps,vx_ecef_m_s,vy_ecef_m_s,vz_ecef_m_s,x_ecef_m,y_ecef_m,z_ecef_m",
                          logs.gnss_time, np.hstack([logs.gnss_v_ecef_m_s, logs.gnss_r_ecef_m]), "%.4f"),
    }
