"""The time series of a plan: satellites in common view, DOPs, ADOP, CRLB and the expected Euler sigmas.

Per epoch t of a Track: the attitude profile gives R_body_from_ecef; a GNSS satellite is used when it is
above the local-horizon mask, above the antenna-frame mask of every antenna and not behind the Earth. The
baseline DOPs (gnssatt.planning.baseline_dop) are those of single-difference phases with a clock term; the
expected sigmas are seed 000 eq. 3-4 per baseline and the all-baseline snapshot, ADOP and sigma_R are seed
001 eq. 5 (sigma_range = sigma_Phi), the CRLB of eq. 4 is combined over satellites per baseline.

Implements: seed 000 sec. 4.1 eq. 3-4; seed 001 eq. 4-5; CONVENTIONS.md frames (orbital frame, NED) and
Euler 3-2-1 angles.
Neglects: light time (GNSS positions at the epoch itself: ~70 ms of satellite motion, 0.3 km), signal
tracking (C/N0 masks: every satellite above the masks is assumed tracked), multipath.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from gnssatt.gnss.constants import WGS84_A_M
from gnssatt.gnss.frames import R_ned_from_ecef, R_orbital_from_ecef, ecef_to_geodetic
from gnssatt.gnss.rotations import Rx, Ry, euler321_to_dcm
from gnssatt.gnss.time import GpsTime
from gnssatt.planning.baseline_dop import baseline_dop, euler_sigma_from_dops, snapshot_covariance_rad2
from gnssatt.planning.filter_steady_state import filtered_sigma_deg
from gnssatt.planning.bounds import L1_WAVELENGTH_M, adop, crlb_aoa_var_rad2
from gnssatt.planning.trajectory import Track

#: GNSS satellite positions at GPS times: t (n,) -> (sats, r_ecef_m (n, m, 3), NaN where unknown)
SatPositions = Callable[[GpsTime], tuple[list[str], np.ndarray]]
#: a line of sight passing lower than this above the WGS 84 equatorial radius is Earth-blocked (m): the
#: ionosphere and troposphere make grazing rays unusable well above the surface
EARTH_BLOCK_HEIGHT_M = 100e3


@dataclass(frozen=True)
class PlanPlatform:
    """Antennas in the body frame: positions_m {id: (3,)}, boresight {id: (3,)}, baselines [(from, to)]."""

    positions_m: dict
    boresight: dict
    baselines: list


@dataclass(frozen=True)
class PlanSettings:
    """Attitude profile (reference 'orbital' or 'ned' and fixed yaw/pitch/roll offsets, deg), masks (deg),
    constellations (system letters), the single-difference phase sigma (m), the C/N0 (dB-Hz) and integration
    time (s) that set the SNR of eq. 4, and the receiver's channels (max_sats: the highest in the first
    antenna's frame are kept; None: all), and the filter's epoch interval and angular-velocity random walk
    (seed 000 Table 1: 0.03 deg/s per 1 s) for its steady-state sigma."""

    reference: str = "orbital"
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    roll_deg: float = 0.0
    horizon_mask_deg: float = -90.0
    antenna_mask_deg: float = 0.0
    systems: tuple = ("G",)
    sigma_phase_m: float = 0.003
    cn0_dbhz: float = 45.0
    integration_s: float = 1.0
    max_sats: int | None = None
    interval_s: float = 1.0
    sigma_omega_deg_s: float = 0.03
    tau_omega_s: float = 1.0


@dataclass
class PlanSeries:
    """Per epoch (n,): n_sats, hdop, vdop, pdop, adop; per baseline (n, k): sigma_h_m, sigma_v_m, sigma_yaw_deg,
    sigma_tilt_deg (eq. 3-4), sigma_r_eq5_deg, crlb_deg; snapshot sigma (n, 3) of (yaw, pitch, roll) in
    sigma_euler_deg, and the filter's steady state of it (gnssatt.planning.filter_steady_state) in
    sigma_filter_deg; baseline names and lengths."""

    time: GpsTime
    n_sats: np.ndarray
    hdop: np.ndarray
    vdop: np.ndarray
    pdop: np.ndarray
    adop: np.ndarray
    baselines: list
    baseline_m: np.ndarray
    sigma_h_m: np.ndarray
    sigma_v_m: np.ndarray
    sigma_yaw_deg: np.ndarray
    sigma_tilt_deg: np.ndarray
    sigma_r_eq5_deg: np.ndarray
    crlb_deg: np.ndarray
    sigma_euler_deg: np.ndarray
    sigma_filter_deg: np.ndarray
    notes: list = field(default_factory=list)


def reference_from_ecef(track: Track, reference: str) -> np.ndarray:
    """R_ref_from_ecef (n, 3, 3): the orbital frame of the track's state, or NED at its position."""
    if reference == "orbital":
        return R_orbital_from_ecef(track.r_ecef_m, track.v_ecef_m_s)
    lat, lon, _ = ecef_to_geodetic(track.r_ecef_m)
    return R_ned_from_ecef(lat, lon)


def euler_jacobian(yaw_deg: float, pitch_deg: float, roll_deg: float) -> np.ndarray:
    """B (3, 3) with dtheta_body = B (d_roll, d_pitch, d_yaw) for R = Rx(roll) Ry(pitch) Rz(yaw)."""
    r, p = np.radians(roll_deg), np.radians(pitch_deg)
    e = np.eye(3)
    return np.stack([e[0], Rx(r) @ e[1], Rx(r) @ Ry(p) @ e[2]], axis=-1)


def _visible(track: Track, r_sat: np.ndarray, R_body_from_ecef: np.ndarray, R_ref_from_ecef: np.ndarray,
             platform: PlanPlatform, s: PlanSettings) -> tuple[np.ndarray, np.ndarray]:
    """(use (n, m), los_body (n, m, 3)) of the satellites passing every mask."""
    d = r_sat - track.r_ecef_m[:, None, :]
    e = d / np.linalg.norm(d, axis=-1, keepdims=True)
    # Earth blockage: the ray's closest approach to the centre, when it lies ahead of the platform (a ray
    # going up from the ground never is)
    tca = -np.einsum("nmi,ni->nm", e, track.r_ecef_m)
    closest = np.linalg.norm(track.r_ecef_m[:, None, :] + np.clip(tca, 0, None)[..., None] * e, axis=-1)
    use = np.isfinite(e).all(-1) & ((tca <= 0) | (closest > WGS84_A_M + EARTH_BLOCK_HEIGHT_M))
    e_ref = np.einsum("nij,nmj->nmi", R_ref_from_ecef, e)
    use &= np.degrees(np.arcsin(np.clip(-e_ref[..., 2], -1, 1))) >= s.horizon_mask_deg   # z is down / nadir
    e_body = np.einsum("nij,nmj->nmi", R_body_from_ecef, e)
    for ant, bore in platform.boresight.items():
        bore = np.asarray(bore, float) / np.linalg.norm(bore)
        use &= np.degrees(np.arcsin(np.clip(e_body @ bore, -1, 1))) >= s.antenna_mask_deg
    if s.max_sats is not None:
        bore = np.asarray(next(iter(platform.boresight.values())), float)
        el = np.where(use, e_body @ (bore / np.linalg.norm(bore)), -np.inf)
        rank = np.argsort(np.argsort(-el, axis=1), axis=1)
        use &= rank < s.max_sats
    return use, e_body


def plan_series(track: Track, sat_positions: SatPositions, platform: PlanPlatform,
                settings: PlanSettings) -> PlanSeries:
    """The plan's time series over the track's epochs (see the module docstring)."""
    sats, r_sat = sat_positions(track.time)
    keep = np.array([x[0] in settings.systems for x in sats])
    r_sat = r_sat[:, keep]
    R_ref = reference_from_ecef(track, settings.reference)
    R_body_from_ref = euler321_to_dcm(settings.yaw_deg, settings.pitch_deg, settings.roll_deg)
    R_body = np.einsum("ij,njk->nik", R_body_from_ref, R_ref)
    use, e_body = _visible(track, r_sat, R_body, R_ref, platform, settings)
    e_ref = np.einsum("ji,nmj->nmi", R_body_from_ref, e_body)
    dop_ref = baseline_dop(e_ref, use)
    dop_body = baseline_dop(e_body, use)
    bl = np.array([np.subtract(platform.positions_m[b], platform.positions_m[a]) for a, b in platform.baselines],
                  dtype=float)
    length = np.linalg.norm(bl, axis=-1)
    shape = (len(dop_ref.hdop), len(length))
    row = euler_sigma_from_dops(np.broadcast_to(dop_ref.hdop[:, None], shape),
                                np.broadcast_to(dop_ref.vdop[:, None], shape), settings.sigma_phase_m, length[None])
    a = adop(e_body, use)
    snr = 10 ** (settings.cn0_dbhz / 10) * settings.integration_s
    cos_t = np.einsum("nmi,ki->nmk", e_body, bl / length[:, None])
    var = crlb_aoa_var_rad2(np.arccos(np.clip(cos_t, -1, 1)), snr, length[None, None, :], L1_WAVELENGTH_M)
    info = np.where(use[..., None], 1.0 / var, 0.0).sum(1)
    with np.errstate(divide="ignore"):
        crlb = np.degrees(np.sqrt(1.0 / info))
    sig_euler = _euler_sigma(bl, dop_body.q_frame, settings)
    return PlanSeries(track.time, use.sum(1), dop_ref.hdop, dop_ref.vdop, dop_ref.pdop, a,
                      [f"{x}>{y}" for x, y in platform.baselines], length, row.sigma_h_m, row.sigma_v_m,
                      row.sigma_yaw_deg, row.sigma_tilt_deg,
                      np.degrees(a[:, None] * settings.sigma_phase_m / length[None]), crlb, sig_euler,
                      filtered_sigma_deg(sig_euler, settings.interval_s, settings.sigma_omega_deg_s,
                                         settings.tau_omega_s))


def _euler_sigma(bl: np.ndarray, q_body: np.ndarray, s: PlanSettings) -> np.ndarray:
    """(n, 3) sigma of (yaw, pitch, roll) deg from the body-frame snapshot covariance and the Euler Jacobian."""
    P = snapshot_covariance_rad2(bl, q_body, s.sigma_phase_m)
    Binv = np.linalg.inv(euler_jacobian(s.yaw_deg, s.pitch_deg, s.roll_deg))
    Pe = Binv @ np.where(np.isfinite(P), P, 0.0) @ Binv.T                 # (roll, pitch, yaw)
    sig = np.degrees(np.sqrt(np.diagonal(Pe, axis1=-2, axis2=-1)))[..., ::-1]
    return np.where(np.isfinite(P).all((-1, -2))[..., None], sig, np.nan)
