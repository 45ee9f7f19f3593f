"""Receiver-satellite geometry: light time with the Sagnac (Earth rotation) correction, local and antenna az/el.

A satellite-state source is any callable `sat_state(sats, t) -> tuple` whose element 0 is the satellite ECEF
position (n, 3) m at GPS times t (n,), element 1 the ECEF velocity (n, 3) m/s or None, and element 2 (if
present) the satellite clock offset (n,) s; `gnssatt.gnss.orbits.broadcast.BroadcastOrbit` is one, and
`sp3_state(sp3)` below wraps an SP3 file.

Implements: the light-time equation |r_sat(t_rx - tau) rotated into ECEF(t_rx) - r_rx(t_rx)| = c tau, solved by
fixed-point iteration (IS-GPS-200 sec. 20.3.3.4.3.4 "Earth rotation correction"; Kaplan & Hegarty, Understanding
GPS/GNSS 3rd ed. sec. 2.5.5.5; RTKLIB `geodist`): the satellite position at emission, given in the ECEF frame of
the emission time, is rotated by R3(omega_E tau) into the ECEF frame of the reception time.
Neglects: the relativistic (Shapiro) path delay (<= 2 cm), the atmosphere (a pseudorange model adds it).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.constants import C_M_S, OMEGA_EARTH_RAD_S
from gnssatt.gnss.frames import azimuth_elevation
from gnssatt.gnss.time import GpsTime

LIGHT_TIME_TOL_S = 1e-12  # 0.3 mm of range: below any carrier-phase noise
LIGHT_TIME_MAX_ITER = 10  # converges by a factor |v_sat - v_rx|/c ~ 1e-5 per pass: 3 passes for 1e-12 s


@dataclass(frozen=True)
class EmissionResult:
    """Light-time solution for n (satellite, reception time) pairs.

    - `t_tx`: GpsTime (n,) of emission (GPS time, satellite clock error not applied).
    - `tau_s`: (n,) signal travel time t_rx - t_tx.
    - `r_sat_ecef_m`, `v_sat_ecef_m_s`: (n, 3) satellite state at t_tx, expressed in the ECEF frame of t_rx
      (Sagnac rotation applied; velocity NaN if the source has none).
    - `range_m`: (n,) geometric range |r_sat - r_rx| = c tau (Sagnac included).
    - `los_ecef`: (n, 3) unit vector from the receiver to the satellite, ECEF at t_rx.
    - `clock_s`: (n,) satellite clock offset at t_tx from the source, NaN if it gives none.
    - `converged`: (n,) bool; NaN satellites are False.
    """

    t_tx: GpsTime
    tau_s: np.ndarray
    r_sat_ecef_m: np.ndarray
    v_sat_ecef_m_s: np.ndarray
    range_m: np.ndarray
    los_ecef: np.ndarray
    clock_s: np.ndarray
    converged: np.ndarray


def sagnac_rotate(r_ecef_m, tau_s, omega_rad_s: float = OMEGA_EARTH_RAD_S) -> np.ndarray:
    """Vectors (..., 3) given in ECEF at t - tau, expressed in ECEF at t: R3(omega tau) r.

    R3(a) = [[cos a, sin a, 0], [-sin a, cos a, 0], [0, 0, 1]] (frame rotation): the Earth has turned east by
    omega tau while the signal travelled, so the emission point appears rotated west.
    """
    r = np.asarray(r_ecef_m, dtype=np.float64)
    a = omega_rad_s * np.asarray(tau_s, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * r[..., 0] + s * r[..., 1], -s * r[..., 0] + c * r[..., 1], r[..., 2]], axis=-1)


def emission_time_and_position(sat_state, sats, r_rx_ecef_m, t_rx: GpsTime, *,
                               tau0_s=None, omega_rad_s: float = OMEGA_EARTH_RAD_S,
                               tol_s: float = LIGHT_TIME_TOL_S,
                               max_iter: int = LIGHT_TIME_MAX_ITER) -> EmissionResult:
    """EmissionResult: emission time, Sagnac-rotated satellite state and geometric range for each pair.

    Args:
        sat_state: callable (sats, t: GpsTime) -> (r (n, 3), v (n, 3) | None, clock (n,), ...), ECEF.
        sats: (n,) satellite ids (passed through to sat_state).
        r_rx_ecef_m: (n, 3) or (3,) receiver (antenna) ECEF position at t_rx, m.
        t_rx: GpsTime (n,) or scalar: reception time in GPS time (the receiver time tag minus the receiver
            clock offset, when known).
        tau0_s: initial travel time (e.g. pseudorange / c); default 0.075 s (an LEO or ground receiver, GNSS).
        omega_rad_s: Earth rotation rate for the Sagnac rotation (the orbit's system constant).
        tol_s, max_iter: stop when every |tau_k+1 - tau_k| < tol_s, or after max_iter passes.
    Implements: see module docstring. t_tx = t_rx - tau; r_sat = R3(omega tau) r_sat_ecef(t_tx);
        tau = |r_sat - r_rx| / c, iterated to tol_s (not a single pass).
    """
    sats = np.atleast_1d(np.asarray(sats))
    n = sats.size
    ts = np.broadcast_to(np.asarray(t_rx.s), (n,))
    tf = np.broadcast_to(np.asarray(t_rx.frac), (n,))
    t_rx = GpsTime(ts, tf)
    r_rx = np.broadcast_to(np.asarray(r_rx_ecef_m, dtype=np.float64), (n, 3))
    tau = np.full(n, 0.075) if tau0_s is None else np.broadcast_to(np.asarray(tau0_s, np.float64), (n,)).copy()
    converged = np.zeros(n, bool)
    out = None
    for _ in range(max_iter):
        t_tx = t_rx - np.where(np.isfinite(tau), tau, 0.075)     # a satellite without a state stays NaN below
        out = sat_state(sats, t_tx)
        r_rot = sagnac_rotate(out[0], tau, omega_rad_s)
        tau_new = np.linalg.norm(r_rot - r_rx, axis=-1) / C_M_S
        converged = np.abs(tau_new - tau) < tol_s
        tau = tau_new
        if np.all(converged | ~np.isfinite(tau)):
            break
    # final evaluation at the converged tau so position and time agree exactly
    t_tx = t_rx - np.where(np.isfinite(tau), tau, 0.075)
    out = sat_state(sats, t_tx)
    r_rot = sagnac_rotate(out[0], tau, omega_rad_s)
    v = out[1] if len(out) > 1 and out[1] is not None else np.full((n, 3), np.nan)
    v_rot = sagnac_rotate(v, tau, omega_rad_s)
    clock = np.asarray(out[2], dtype=np.float64) if len(out) > 2 and out[2] is not None else np.full(n, np.nan)
    d = r_rot - r_rx
    rng = np.linalg.norm(d, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        los = d / rng[:, None]
    converged = converged & np.isfinite(rng)
    return EmissionResult(t_tx, tau, r_rot, v_rot, rng, los, clock, converged)


def sp3_state(sp3, n_points: int = 10):
    """A sat_state callable over an Sp3Data (gnssatt.gnss.io.sp3) by gnssatt.gnss.orbits.sp3_interp.

    Returns (r (n, 3), v (n, 3), clock (n,)) for pairs (sats[i], t[i]).
    """
    from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

    def state(sats, t: GpsTime):
        sats = np.atleast_1d(np.asarray(sats))
        n = sats.size
        ts = GpsTime(np.broadcast_to(np.asarray(t.s), (n,)), np.broadcast_to(np.asarray(t.frac), (n,)))
        r = np.full((n, 3), np.nan)
        v = np.full((n, 3), np.nan)
        clk = np.full(n, np.nan)
        for sat in np.unique(sats):
            m = np.flatnonzero(sats == sat)
            pos, c = interpolate_sp3(sp3, [str(sat)], ts[m], n_points=n_points)
            vel = interpolate_sp3_velocity(sp3, [str(sat)], ts[m], n_points=n_points)
            r[m], clk[m], v[m] = pos[:, 0], c[:, 0], vel[:, 0]
        return r, v, clk

    return state


def elevation_azimuth_local(r_rx_ecef_m, r_sat_ecef_m) -> tuple[np.ndarray, np.ndarray]:
    """(elevation_rad, azimuth_rad) of r_sat seen from r_rx in the WGS 84 local level frame (..., 3) -> (...).

    Elevation up positive; azimuth clockwise from north in [0, 2 pi) (CONVENTIONS.md local level frame).
    """
    az, el = azimuth_elevation(r_rx_ecef_m, r_sat_ecef_m)
    return el, az


def R_antenna_from_body(boresight_body) -> np.ndarray:
    """Rotation matrices antenna <- body (..., 3, 3) of an antenna with boresight (..., 3) in the body frame.

    Antenna frame (CONVENTIONS.md): z along the boresight; x along body x projected onto the plane normal to z
    (body y where the boresight is parallel to body x); y = z x x. Rows are the antenna axes in body axes.
    """
    z = np.asarray(boresight_body, dtype=np.float64)
    z = z / np.linalg.norm(z, axis=-1, keepdims=True)
    ex = np.broadcast_to(np.array([1.0, 0.0, 0.0]), z.shape)
    ey = np.broadcast_to(np.array([0.0, 1.0, 0.0]), z.shape)
    px = ex - np.sum(ex * z, axis=-1, keepdims=True) * z
    npx = np.linalg.norm(px, axis=-1, keepdims=True)
    py = ey - np.sum(ey * z, axis=-1, keepdims=True) * z
    parallel = npx < 1e-9
    x = np.where(parallel, py / np.linalg.norm(py, axis=-1, keepdims=True), px / np.where(parallel, 1.0, npx))
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-2)


def azimuth_elevation_antenna(los_ecef, R_body_from_ecef, boresight_body) -> tuple[np.ndarray, np.ndarray]:
    """(azimuth_rad in [0, 2 pi), elevation_rad) of lines of sight in an antenna frame.

    Args:
        los_ecef: (..., 3) direction from the antenna to the satellite, ECEF (need not be unit).
        R_body_from_ecef: (..., 3, 3) attitude.
        boresight_body: (3,) or (..., 3) antenna boresight in the body frame.
    Azimuth is measured from antenna x towards antenna y; elevation from the antenna plane towards the
    boresight (90 deg on boresight, negative behind the antenna plane).
    Implements: CONVENTIONS.md antenna frame.
    """
    R = R_antenna_from_body(boresight_body) @ np.asarray(R_body_from_ecef, dtype=np.float64)
    d = np.einsum("...ij,...j->...i", R, np.asarray(los_ecef, dtype=np.float64))
    az = np.mod(np.arctan2(d[..., 1], d[..., 0]), 2.0 * np.pi)
    az = np.where(az >= 2.0 * np.pi, 0.0, az)  # mod of -1e-17 rounds to 2 pi
    el = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1]))
    return az, el


__all__ = ["EmissionResult", "emission_time_and_position", "sagnac_rotate", "sp3_state",
           "elevation_azimuth_local", "R_antenna_from_body", "azimuth_elevation_antenna"]
