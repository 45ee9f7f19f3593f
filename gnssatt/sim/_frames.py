"""Earth-fixed / celestial / local frames for the simulator (private until gnssatt/gnss/frames.py lands).

Implements: IAU 2006/2000A CIO-based GCRS->ITRS as ERFA computes it (erfa.c2i06a, erfa.era00,
erfa.c2tcio) with polar motion and UT1-UTC taken as zero (CONVENTIONS.md "Frames"); TT = GPS + 51.184 s;
UTC from the leap-second table (gnssatt.gnss.leap_seconds via `_constants`). WGS 84 geodetic <-> ECEF; NED at
a geodetic point.
Neglects: EOP (xp = yp = 0, UT1 = UTC); the CIO-based precession-nutation matrix is interpolated
linearly over 60 s nodes (its rate is < 1e-9 rad/s, so the error is < 1e-13 rad); the rotation angle is exact.
"""
from __future__ import annotations

import erfa
import numpy as np

from gnssatt.gnss.constants import JD_GPS_EPOCH as _JD_GPS_EPOCH, TT_MINUS_GPS_S as _TT_MINUS_GPS_S
from gnssatt.sim._constants import R_EARTH_M, WGS84_F, gps_minus_utc_s

_NODE_S = 60.0


class EarthRotation:
    """R_ecef_from_gcrf(t) for times t = t0 + dt_s, dt_s in seconds (float64) near a reference t0.

    Args:
        t0_gps_s: whole GPS seconds since 1980-01-06 of the reference time (int).
        span_s: (min, max) of the dt_s that will be asked for (nodes are laid over it with a margin).
    """

    def __init__(self, t0_gps_s: int, span_s: tuple[float, float]):
        self.t0 = int(t0_gps_s)
        self.leap_s = gps_minus_utc_s(float(self.t0))
        lo = np.floor(span_s[0] / _NODE_S) - 2
        hi = np.ceil(span_s[1] / _NODE_S) + 2
        self.node_dt = np.arange(lo, hi + 1) * _NODE_S
        tt1, tt2 = self._jd(self.node_dt, _TT_MINUS_GPS_S)
        self.c2i_nodes = erfa.c2i06a(tt1, tt2)  # (n, 3, 3), GCRS -> CIRS (celestial-to-intermediate)

    def _jd(self, dt_s, offset_s):
        day0 = self.t0 // 86400
        sod = (self.t0 - day0 * 86400) + np.asarray(dt_s, dtype=np.float64) + offset_s
        return np.full(np.shape(sod), _JD_GPS_EPOCH + day0), sod / 86400.0

    def R_ecef_from_gcrf(self, dt_s) -> np.ndarray:
        """Rotation matrices (..., 3, 3) taking GCRF components to ECEF components at t0 + dt_s."""
        dt = np.asarray(dt_s, dtype=np.float64)
        flat = dt.ravel()
        idx = np.clip(np.searchsorted(self.node_dt, flat) - 1, 0, len(self.node_dt) - 2)
        w = ((flat - self.node_dt[idx]) / _NODE_S)[:, None, None]
        c2i = self.c2i_nodes[idx] * (1 - w) + self.c2i_nodes[idx + 1] * w
        u1, u2 = self._jd(flat, -float(self.leap_s))  # UT1 = UTC
        era = erfa.era00(u1, u2)
        c, s = np.cos(era), np.sin(era)
        R3 = np.zeros((flat.size, 3, 3))
        R3[:, 0, 0] = c
        R3[:, 0, 1] = s
        R3[:, 1, 0] = -s
        R3[:, 1, 1] = c
        R3[:, 2, 2] = 1.0
        return (R3 @ c2i).reshape(dt.shape + (3, 3))


def ecef_from_geodetic(lat_deg, lon_deg, h_m) -> np.ndarray:
    """WGS 84 ECEF position (..., 3) in metres of geodetic latitude/longitude (deg) and ellipsoidal height (m)."""
    lat = np.radians(lat_deg)
    lon = np.radians(lon_deg)
    e2 = WGS84_F * (2 - WGS84_F)
    n = R_EARTH_M / np.sqrt(1 - e2 * np.sin(lat) ** 2)
    return np.stack([(n + h_m) * np.cos(lat) * np.cos(lon), (n + h_m) * np.cos(lat) * np.sin(lon),
                     (n * (1 - e2) + h_m) * np.sin(lat)], axis=-1)


def geodetic_from_ecef(r_ecef_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lat_deg, lon_deg, h_m) on WGS 84 of ECEF positions (..., 3) (Bowring, then 3 fixed-point steps)."""
    r = np.asarray(r_ecef_m, dtype=np.float64)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    e2 = WGS84_F * (2 - WGS84_F)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1 - e2))
    for _ in range(5):
        n = R_EARTH_M / np.sqrt(1 - e2 * np.sin(lat) ** 2)
        h = p / np.cos(lat) - n
        lat = np.arctan2(z, p * (1 - e2 * n / (n + h)))
    n = R_EARTH_M / np.sqrt(1 - e2 * np.sin(lat) ** 2)
    h = p / np.cos(lat) - n
    return np.degrees(lat), np.degrees(np.arctan2(y, x)), h


def R_ned_from_ecef(lat_deg, lon_deg) -> np.ndarray:
    """Rotation (..., 3, 3) taking ECEF components to north-east-down components at a geodetic point."""
    lat = np.radians(lat_deg)
    lon = np.radians(lon_deg)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    R = np.empty(np.shape(lat) + (3, 3))
    R[..., 0, :] = np.stack([-sl * co, -sl * so, cl], -1)
    R[..., 1, :] = np.stack([-so, co, np.zeros_like(so)], -1)
    R[..., 2, :] = np.stack([-cl * co, -cl * so, -sl], -1)
    return R


def R_orbital_from_inertial(r_m: np.ndarray, v_m_s: np.ndarray) -> np.ndarray:
    """Rows x_o, y_o, z_o (..., 3, 3) of the orbital frame (CONVENTIONS.md) in the frame of r and v.

    z_o = -r/|r| (nadir), y_o = -(r x v)/|r x v|, x_o = y_o x z_o.
    """
    z = -r_m / np.linalg.norm(r_m, axis=-1, keepdims=True)
    h = np.cross(r_m, v_m_s)
    y = -h / np.linalg.norm(h, axis=-1, keepdims=True)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=-2)
