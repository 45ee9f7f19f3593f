"""Geometry of every epoch, computed once for the whole pass: platform state, lines of sight, range rates.

For baselines of a few metres the line of sight to a GNSS satellite is the same for every antenna to < 1e-6 rad,
so it is computed once per epoch at the platform reference point (its centre of mass from an SP3, or the master
antenna's position).

Implements: light time with the Sagnac rotation via gnssatt.gnss.geometry.emission_time_and_position;
range rate rho_dot = u . (v_sat - v_rx) (u receiver -> satellite, both Earth-fixed velocities).
Neglects: the lever arm between the reference point and each antenna in the line of sight (< 1e-6 rad).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.frames import ecef_to_geodetic
from gnssatt.gnss.geometry import elevation_azimuth_local, emission_time_and_position
from gnssatt.gnss.time import GpsTime

__all__ = ["EpochGeometry", "platform_state_from_sp3", "compute_geometry"]


@dataclass
class EpochGeometry:
    """Per epoch (n_ep) and satellite (n_sat): los_ecef (n_ep, n_sat, 3) unit receiver -> satellite,
    range_rate_m_s (n_ep, n_sat), elevation_local_rad (n_ep, n_sat), valid (n_ep, n_sat) bool;
    r_platform_ecef_m, v_platform_ecef_m_s (n_ep, 3); platform_source: where the position came from."""

    los_ecef: np.ndarray
    range_rate_m_s: np.ndarray
    elevation_local_rad: np.ndarray
    valid: np.ndarray
    r_platform_ecef_m: np.ndarray
    v_platform_ecef_m_s: np.ndarray
    platform_source: str


def platform_state_from_sp3(sp3, t: GpsTime) -> tuple[np.ndarray, np.ndarray]:
    """(r_ecef_m (n, 3), v_ecef_m_s (n, 3)) of the first satellite of a platform SP3 at times t (NaN outside)."""
    from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

    sat = sp3.sats[0]
    pos, _ = interpolate_sp3(sp3, [sat], t)
    vel = interpolate_sp3_velocity(sp3, [sat], t)
    return pos[:, 0], vel[:, 0]


def compute_geometry(t: GpsTime, sats: list[str], observed: np.ndarray, sat_state, r_platform_ecef_m: np.ndarray,
                     v_platform_ecef_m_s: np.ndarray, platform_source: str) -> EpochGeometry:
    """EpochGeometry for epochs t (n_ep,), satellites `sats`, where `observed` (n_ep, n_sat) is True.

    Args:
        sat_state: callable (sats, t) -> (r, v, clock, ...) ECEF (see gnssatt.gnss.geometry).
        r_platform_ecef_m, v_platform_ecef_m_s: (n_ep, 3) reference point state (NaN rows -> invalid epoch).
    """
    n_ep, n_sat = observed.shape
    los = np.full((n_ep, n_sat, 3), np.nan)
    rr = np.full((n_ep, n_sat), np.nan)
    el = np.full((n_ep, n_sat), np.nan)
    ok_rx = np.isfinite(r_platform_ecef_m).all(-1)
    ie, js = np.nonzero(observed & ok_rx[:, None])
    if ie.size:
        sat_ids = np.asarray(sats)[js]
        tr = GpsTime(t.s[ie], t.frac[ie])
        res = emission_time_and_position(sat_state, sat_ids, r_platform_ecef_m[ie], tr)
        los[ie, js] = res.los_ecef
        v_rx = np.nan_to_num(v_platform_ecef_m_s[ie])
        rr[ie, js] = np.einsum("ij,ij->i", res.los_ecef, res.v_sat_ecef_m_s - v_rx)
        e, _ = elevation_azimuth_local(r_platform_ecef_m[ie], res.r_sat_ecef_m)
        el[ie, js] = e
    valid = np.isfinite(los).all(-1) & np.isfinite(rr)
    rr = np.where(valid, rr, 0.0)
    return EpochGeometry(los, rr, el, valid, r_platform_ecef_m, v_platform_ecef_m_s, platform_source)


def geodetic_of(r_ecef_m: np.ndarray):
    """(lat_rad, lon_rad, h_m) of ECEF positions (..., 3) on WGS 84."""
    return ecef_to_geodetic(r_ecef_m)
