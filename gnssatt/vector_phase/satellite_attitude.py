"""Transmitter attitude: a small default nominal yaw-steering model, and the orbit-frame axes.

The estimators and the phase model take the satellite body axes from any callable
`axes(t_gps_s, r_sat_ecef_m, v_sat_ecef_m_s) -> (x_sat_ecef, y_sat_ecef)` (arrays (..., 3)), so a project-wide
yaw model (the satellite-yaw work) can replace these later; `nominal_yaw_steering` is the default here.

- `nominal_yaw_steering`: IGS body frame, +z to the Earth's centre, +y = unit(z x e_sun), +x = y x z on the
  side of the Sun (CONVENTIONS.md satellite frame; Bar-Sever 1996 nominal attitude, no yaw-rate limit and no
  noon/midnight turn manoeuvres).
- `orbit_frame_axes`: +z to the Earth's centre, +y = -(r x v_inertial) unit (the multi-antenna simulator's
  satellite axes, gnssatt/sim/observables.satellite_axes).
- `sun_ecef_m`: low-precision Sun position (Astronomical Almanac "low precision formulas", ~0.01 deg, 1950-2050)
  rotated to ECEF by GMST (IAU 1982) about z. Neglects: precession-nutation and polar motion (< 0.5 deg of the
  Sun's direction, i.e. of the yaw angle far from the noon/midnight points), GPS-UTC (18 s).
"""
from __future__ import annotations

import numpy as np

__all__ = ["sun_ecef_m", "nominal_yaw_steering", "orbit_frame_axes", "OMEGA_EARTH_RAD_S"]

AU_M = 1.495978707e11
OMEGA_EARTH_RAD_S = 7.2921151467e-5
JD_GPS_EPOCH = 2444244.5


def sun_ecef_m(t_gps_s) -> np.ndarray:
    """Sun position (..., 3) in ECEF, m, at GPS seconds since 1980-01-06 (Astronomical Almanac C5, GMST 1982)."""
    jd = JD_GPS_EPOCH + np.asarray(t_gps_s, dtype=np.float64) / 86400.0
    n = jd - 2451545.0
    L = np.radians(280.460 + 0.9856474 * n)
    g = np.radians(357.528 + 0.9856003 * n)
    lam = L + np.radians(1.915) * np.sin(g) + np.radians(0.020) * np.sin(2 * g)
    eps = np.radians(23.439 - 4.0e-7 * n)
    dist = AU_M * (1.00014 - 0.01671 * np.cos(g) - 0.00014 * np.cos(2 * g))
    r_eci = dist[..., None] * np.stack([np.cos(lam), np.cos(eps) * np.sin(lam), np.sin(eps) * np.sin(lam)], -1)
    gmst = np.radians(np.mod(280.46061837 + 360.98564736629 * n, 360.0))
    c, s = np.cos(gmst), np.sin(gmst)
    return np.stack([c * r_eci[..., 0] + s * r_eci[..., 1], -s * r_eci[..., 0] + c * r_eci[..., 1],
                     r_eci[..., 2]], axis=-1)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def nominal_yaw_steering(t_gps_s, r_sat_ecef_m, v_sat_ecef_m_s=None) -> tuple[np.ndarray, np.ndarray]:
    """(x_sat_ecef, y_sat_ecef) (..., 3) of nominal yaw steering; t_gps_s broadcastable to r's leading shape
    (e.g. (n_ep, 1) for (n_ep, n_sv, 3)). v is not used (kept for the common signature)."""
    r = np.asarray(r_sat_ecef_m, dtype=np.float64)
    sun = sun_ecef_m(np.asarray(t_gps_s, dtype=np.float64))
    z = -_unit(r)
    y = _unit(np.cross(z, _unit(sun - r)))
    return np.cross(y, z), y


def orbit_frame_axes(t_gps_s, r_sat_ecef_m, v_sat_ecef_m_s) -> tuple[np.ndarray, np.ndarray]:
    """(x_sat_ecef, y_sat_ecef) of the orbit frame: z to the Earth's centre, y = -(r x v_inertial) unit."""
    r = np.asarray(r_sat_ecef_m, dtype=np.float64)
    v = np.asarray(v_sat_ecef_m_s, dtype=np.float64) + np.cross([0.0, 0.0, OMEGA_EARTH_RAD_S], r)
    z = -_unit(r)
    y = -_unit(np.cross(r, v))
    return np.cross(y, z), y
