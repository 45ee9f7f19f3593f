"""The platform's trajectory for a plan: ECEF position and velocity at given GPS times, from a TLE (SGP4),
Keplerian elements (two-body with the J2 secular drift), an SP3 file of the platform, a ground position, or a
sampled trajectory (e.g. a vehicle's velocity.csv with its position columns).

Implements: SGP4 (Vallado et al. 2006, AIAA 2006-6753, via the sgp4 package) with TEME -> ECEF by the GMST
1982 rotation (Vallado 2013 sec. 3.7, erfa.gmst82, UT1 = UTC); Kepler's equation by Newton; the J2 secular
rates of the node and perigee (Vallado 2013 eq. 9-41); GCRF -> ECEF of gnssatt.gnss.frames; SP3 Lagrange
interpolation of gnssatt.gnss.orbits.sp3_interp.
Neglects: polar motion in TEME -> ECEF (~10 m), the short-periodic J2 terms of the Keplerian propagation
(~10 km along track over an orbit: irrelevant to DOPs), atmospheric drag outside SGP4.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.constants import GM_EARTH_M3_S2, OMEGA_EARTH_RAD_S, WGS84_A_M
from gnssatt.gnss.time import GpsTime

J2_EARTH = 1.08262668e-3   # EGM2008 / WGS 84 unnormalised C20 (NIMA TR8350.2 Table 3.4: -C20 sqrt(5))


@dataclass(frozen=True)
class Track:
    """Platform states: time (n,) GpsTime, r_ecef_m (n, 3), v_ecef_m_s (n, 3), kind 'spacecraft'|'terrestrial'."""

    time: GpsTime
    r_ecef_m: np.ndarray
    v_ecef_m_s: np.ndarray
    kind: str


def _omega_cross(r: np.ndarray) -> np.ndarray:
    return np.cross(np.array([0.0, 0.0, OMEGA_EARTH_RAD_S]), r)


def track_from_tle(line1: str, line2: str, t: GpsTime) -> Track:
    """SGP4 states of a two-line element set at GPS times t, in ECEF; ValueError with the SGP4 error text
    for an epoch SGP4 refuses (e.g. decayed orbit)."""
    import erfa
    from sgp4.api import Satrec

    from gnssatt.gnss.leap_seconds import jd_utc

    sat = Satrec.twoline2rv(line1, line2)
    jd1, jd2 = jd_utc(t)
    err, r_km, v_km_s = sat.sgp4_array(np.atleast_1d(jd1).astype(float), np.atleast_1d(jd2).astype(float))
    if np.any(err):
        from sgp4.api import SGP4_ERRORS

        raise ValueError(f"SGP4 error {int(err[err != 0][0])}: {SGP4_ERRORS.get(int(err[err != 0][0]), '')}")
    theta = erfa.gmst82(np.atleast_1d(jd1), np.atleast_1d(jd2))
    c, s = np.cos(theta), np.sin(theta)
    Rz = np.zeros((len(theta), 3, 3))
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, s, -s, c, 1.0
    r = np.einsum("nij,nj->ni", Rz, r_km * 1e3)
    v = np.einsum("nij,nj->ni", Rz, v_km_s * 1e3) - _omega_cross(r)
    return Track(t, r, v, "spacecraft")


@dataclass(frozen=True)
class Keplerian:
    """Osculating elements in GCRF at `epoch`: semi-major axis (m), eccentricity, inclination, RAAN, argument
    of perigee and mean anomaly (deg)."""

    epoch: GpsTime
    a_m: float
    e: float
    i_deg: float
    raan_deg: float
    argp_deg: float
    m0_deg: float


def track_from_keplerian(el: Keplerian, t: GpsTime, j2: bool = True) -> Track:
    """Two-body states (with the J2 secular node and perigee drift when j2) at t, converted to ECEF."""
    from gnssatt.gnss.frames import gcrf_to_ecef_pv

    dt = np.atleast_1d(np.asarray(t - el.epoch, dtype=np.float64))
    a, e, inc = el.a_m, el.e, np.radians(el.i_deg)
    n = np.sqrt(GM_EARTH_M3_S2 / a ** 3)
    p = a * (1 - e * e)
    k = 1.5 * n * J2_EARTH * (WGS84_A_M / p) ** 2 if j2 else 0.0
    raan = np.radians(el.raan_deg) - k * np.cos(inc) * dt                       # Vallado eq. 9-41
    argp = np.radians(el.argp_deg) + k * (2.0 - 2.5 * np.sin(inc) ** 2) * dt
    M = np.radians(el.m0_deg) + n * dt
    E = M.copy()
    for _ in range(30):                                                           # Newton on Kepler's equation
        E = E - (E - e * np.sin(E) - M) / (1 - e * np.cos(E))
    nu = 2 * np.arctan2(np.sqrt(1 + e) * np.sin(E / 2), np.sqrt(1 - e) * np.cos(E / 2))
    r_mag = a * (1 - e * np.cos(E))
    r_pf = np.stack([r_mag * np.cos(nu), r_mag * np.sin(nu), np.zeros_like(nu)], -1)
    v_pf = np.sqrt(GM_EARTH_M3_S2 / p) * np.stack([-np.sin(nu), e + np.cos(nu), np.zeros_like(nu)], -1)
    cO, sO, cw, sw, ci, si = np.cos(raan), np.sin(raan), np.cos(argp), np.sin(argp), np.cos(inc), np.sin(inc)
    Rm = np.stack([np.stack([cO * cw - sO * sw * ci, -cO * sw - sO * cw * ci, np.full_like(cO, 0) + sO * si], -1),
                   np.stack([sO * cw + cO * sw * ci, -sO * sw + cO * cw * ci, -cO * si], -1),
                   np.stack([sw * si, cw * si, np.full_like(cO, ci)], -1)], -2)
    r_i = np.einsum("nij,nj->ni", Rm, r_pf)
    v_i = np.einsum("nij,nj->ni", Rm, v_pf)
    r_e, v_e = gcrf_to_ecef_pv(r_i, v_i, t)
    return Track(t, np.asarray(r_e), np.asarray(v_e), "spacecraft")


def track_from_sp3(sp3, sat: str, t: GpsTime) -> Track:
    """States of satellite `sat` of an SP3 file (the platform's own orbit) at t; NaN outside its span."""
    from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

    r, _ = interpolate_sp3(sp3, [sat], t)
    v = interpolate_sp3_velocity(sp3, [sat], t)
    return Track(t, r[:, 0], v[:, 0], "spacecraft")


def track_ground(lat_deg: float, lon_deg: float, h_m: float, t: GpsTime) -> Track:
    """A static ground platform at a WGS 84 geodetic position."""
    from gnssatt.gnss.frames import geodetic_to_ecef

    r = np.asarray(geodetic_to_ecef(np.radians(lat_deg), np.radians(lon_deg), h_m), dtype=np.float64)
    n = len(np.atleast_1d(np.asarray(t.s)))
    return Track(t, np.tile(r, (n, 1)), np.zeros((n, 3)), "terrestrial")


def track_from_samples(t_samples: GpsTime, r_ecef_m: np.ndarray, v_ecef_m_s: np.ndarray, t: GpsTime,
                       kind: str = "terrestrial") -> Track:
    """A ground (or any) trajectory given as samples: positions by cubic Hermite interpolation with the sampled
    velocities, velocities linearly; NaN outside the samples' span."""
    from scipy.interpolate import CubicHermiteSpline

    x = np.asarray(t_samples - t_samples[0], dtype=np.float64)
    xi = np.atleast_1d(np.asarray(t - t_samples[0], dtype=np.float64))
    r = CubicHermiteSpline(x, r_ecef_m, v_ecef_m_s, axis=0, extrapolate=False)(xi)
    v = np.stack([np.interp(xi, x, v_ecef_m_s[:, k], left=np.nan, right=np.nan) for k in range(3)], -1)
    return Track(t, r, v, kind)
