"""Frames of CONVENTIONS.md: ECEF <-> GCRF (IAU 2006/2000A via ERFA), orbital, NED/ENU, WGS 84 geodetic.

Every rotation is a matrix `R_target_from_source` with shape (..., 3, 3) that maps vector components:
`v_target = R_target_from_source @ v_source`. Vectors have xyz on the last axis.

ECEF (ITRS as realised by the broadcast/SP3 orbits) -> GCRF follows the CIO-based chain of IERS Conventions
(2010) ch. 5 as ERFA computes it: r_gcrs = C(X, Y, s)^T R3(-ERA) W^T r_itrs with
X, Y from `erfa.xy06` (+ dX, dY), s from `erfa.s06`, ERA from `erfa.era00(UT1)`, W = `erfa.pom00(xp, yp, s')`,
assembled by `erfa.c2tcio`. With dX = dY = 0 this equals `erfa.c2t06a` to ~1e-11 rad (series vs. matrix
route to X, Y). EOP come from a `gnssatt.gnss.eop.EopSource` (zero unless a file is supplied, CONVENTIONS.md).
"""
from __future__ import annotations

import erfa
import numpy as np

from gnssatt.gnss.constants import OMEGA_EARTH_RAD_S, WGS84_A_M, WGS84_F
from gnssatt.gnss.eop import EopSource, EopValues
from gnssatt.gnss.time import GpsTime

# Precession-nutation (X, Y, s) changes slowly: its fastest sizeable term (13.66 d, ~0.1") interpolated by a
# cubic at 1 h nodes errs by ~(2 pi h / 13.66 d)^4 / 384 * 0.1" ~ 4e-11" (2e-16 rad). ERA and polar motion are
# still evaluated per epoch. ERFA's full series costs ~20 us per epoch (2 s for one day at 1 Hz);
# interpolation makes that ~1000x cheaper for dense epochs. None = evaluate X, Y, s at every epoch.
PN_NODE_STEP_S = 3600.0


def _xys(t: GpsTime, dx_rad, dy_rad, pn_step_s: float | None):
    """(X, Y, s) of the CIP / CIO at epochs t (IAU 2006/2000A, erfa.xy06 / erfa.s06), + dX, dY."""
    tt1, tt2 = t.to_jd_tt()
    flat1, flat2 = np.ravel(tt1), np.ravel(tt2)
    n = flat1.size
    shp = np.shape(tt1)
    dx = np.ravel(np.broadcast_to(dx_rad, shp))
    dy = np.ravel(np.broadcast_to(dy_rad, shp))
    direct = pn_step_s is None or n < 64
    if not direct:
        # Seconds from the first epoch (two-part difference keeps sub-ns), nodes every pn_step_s over the span.
        t_flat = GpsTime(np.ravel(t.s), np.ravel(t.frac))
        t0 = t_flat[0]
        dt_s = t_flat - t0
        k0 = int(np.floor(dt_s.min() / pn_step_s)) - 2
        k1 = int(np.ceil(dt_s.max() / pn_step_s)) + 2
        direct = (k1 - k0 + 1) * 2 > n  # sparse epochs: the series at each epoch is cheaper
    if direct:
        x, y = erfa.xy06(flat1, flat2)
        x, y = x + dx, y + dy
        s = erfa.s06(flat1, flat2, x, y)
        return x.reshape(shp), y.reshape(shp), s.reshape(shp)
    node_dt = np.arange(k0, k1 + 1, dtype=np.float64) * pn_step_s
    nodes = t0 + node_dt
    nj1, nj2 = nodes.to_jd_tt()
    nx, ny = erfa.xy06(nj1, nj2)
    ns_plus_xy2 = erfa.s06(nj1, nj2, nx, ny) + nx * ny / 2.0  # smooth part: s = -XY/2 + (slow series)
    u = (dt_s - node_dt[0]) / pn_step_s  # fractional node index
    x = _cubic_uniform(nx, u)
    y = _cubic_uniform(ny, u)
    s_smooth = _cubic_uniform(ns_plus_xy2, u)
    x, y = x + dx, y + dy
    # erfa.s06 is (a series in time) - X Y / 2 (IERS Conventions 2010 eq. 5.13); the series part is
    # interpolated, the -XY/2 term recomputed with the interpolated, offset X, Y: the same as s06(x, y).
    s = s_smooth - x * y / 2.0
    return x.reshape(shp), y.reshape(shp), s.reshape(shp)


def _cubic_uniform(values: np.ndarray, u: np.ndarray) -> np.ndarray:
    """4-point Lagrange interpolation on unit-spaced nodes `values[k]` at fractional indices u (1 <= u <= n-3)."""
    i = np.clip(np.floor(u).astype(np.int64), 1, len(values) - 3)
    f = u - i
    v0, v1, v2, v3 = values[i - 1], values[i], values[i + 1], values[i + 2]
    # Lagrange weights for nodes at -1, 0, 1, 2
    return (-f * (f - 1) * (f - 2) / 6.0 * v0 + (f + 1) * (f - 1) * (f - 2) / 2.0 * v1
            - (f + 1) * f * (f - 2) / 2.0 * v2 + (f + 1) * f * (f - 1) / 6.0 * v3)


def _eop(eop: EopSource | None) -> EopSource:
    return EopSource.zero() if eop is None else eop


def _itrs_from_gcrs(t: GpsTime, eop: EopSource | None, pn_step_s: float | None):
    """(rc2t (..., 3, 3), rpom (..., 3, 3), EopValues): ITRS-from-GCRS matrix by the CIO-based chain."""
    v = _eop(eop).at(t)
    x, y, s = _xys(t, v.dx_rad, v.dy_rad, pn_step_s)
    rc2i = erfa.c2ixys(x, y, s)
    tai1, tai2 = t.to_jd_tai()
    tt1, tt2 = t.to_jd_tt()
    with np.errstate(invalid="ignore"):  # NaN EOP outside the table: already one EopWarning, NaN out
        era = erfa.era00(tai1, tai2 + v.ut1_minus_tai_s / 86400.0)  # UT1 = TAI + (UT1 - TAI)
        rpom = erfa.pom00(v.xp_rad, v.yp_rad, erfa.sp00(tt1, tt2))
        rc2t = erfa.c2tcio(rc2i, era, rpom)
    return rc2t, rpom, v


def R_gcrf_from_ecef(t: GpsTime, eop: EopSource | None = None,
                     pn_step_s: float | None = PN_NODE_STEP_S) -> np.ndarray:
    """Rotation matrices GCRF <- ECEF, shape t.shape + (3, 3).

    Args:
        t: GPS times (any shape).
        eop: EOP source; None = zero EOP (CONVENTIONS.md). Epochs outside its table give NaN matrices.
        pn_step_s: node spacing for interpolating the precession-nutation X, Y, s (see PN_NODE_STEP_S);
            None evaluates the IAU 2006/2000A series at every epoch.
    Implements: IERS Conventions (2010) eq. 5.1 (CIO based), via erfa xy06, s06, c2ixys, era00, sp00, pom00,
        c2tcio; TT = GPS + 51.184 s, UT1 = TAI + (UT1 - TAI).
    Neglects: sub-daily tidal EOP terms (see gnssatt.gnss.eop).
    """
    rc2t, _, _ = _itrs_from_gcrs(t, eop, pn_step_s)
    return np.swapaxes(rc2t, -1, -2)


def R_ecef_from_gcrf(t: GpsTime, eop: EopSource | None = None,
                     pn_step_s: float | None = PN_NODE_STEP_S) -> np.ndarray:
    """Rotation matrices ECEF <- GCRF, shape t.shape + (3, 3) (transpose of R_gcrf_from_ecef)."""
    rc2t, _, _ = _itrs_from_gcrs(t, eop, pn_step_s)
    return rc2t


def omega_earth_ecef_rad_s(t: GpsTime, eop: EopSource | None = None) -> np.ndarray:
    """Earth angular velocity vector in ECEF (rad/s), shape t.shape + (3,).

    omega = d(ERA)/dt * W e_z: the CIP axis in ITRS (polar motion matrix W = pom00) times the rate of the Earth
    rotation angle per SI second, 2 pi 1.00273781191135448 / 86400 * (1 + d(UT1-TAI)/dt) (i.e. consistent
    with the length of day of the EOP source; 7.292115146707e-5 rad/s for zero EOP).
    Implements: IERS Conventions (2010) eq. 5.15; Petit & Luzum (2010) sec. 5.4.
    """
    e = _eop(eop)
    v = e.at(t)
    tt1, tt2 = t.to_jd_tt()
    rpom = erfa.pom00(v.xp_rad, v.yp_rad, erfa.sp00(tt1, tt2))
    return rpom[..., :, 2] * np.asarray(v.omega_earth_rad_s)[..., None]


def _apply(R, r):
    return np.einsum("...ij,...j->...i", R, r)


def ecef_to_gcrf(r_ecef_m, t: GpsTime, eop: EopSource | None = None,
                 pn_step_s: float | None = PN_NODE_STEP_S) -> np.ndarray:
    """Positions in GCRF (m), shape (..., 3), of ECEF positions r_ecef_m (..., 3) at times t (broadcasting)."""
    return _apply(R_gcrf_from_ecef(t, eop, pn_step_s), np.asarray(r_ecef_m, dtype=np.float64))


def gcrf_to_ecef(r_gcrf_m, t: GpsTime, eop: EopSource | None = None,
                 pn_step_s: float | None = PN_NODE_STEP_S) -> np.ndarray:
    """Positions in ECEF (m), shape (..., 3), of GCRF positions r_gcrf_m (..., 3) at times t."""
    return _apply(R_ecef_from_gcrf(t, eop, pn_step_s), np.asarray(r_gcrf_m, dtype=np.float64))


def ecef_to_gcrf_pv(r_ecef_m, v_ecef_m_s, t: GpsTime, eop: EopSource | None = None,
                    pn_step_s: float | None = PN_NODE_STEP_S) -> tuple[np.ndarray, np.ndarray]:
    """(r_gcrf_m, v_gcrf_m_s) of an ECEF state: v_gcrf = R (v_ecef + omega x r_ecef).

    Implements: time derivative of eq. 5.1 of IERS Conventions (2010) with omega from
    `omega_earth_ecef_rad_s` (LOD-consistent). Neglects: the rates of precession-nutation (~1e-11 rad/s,
    ~0.1 mm/s at GNSS radius) and of polar motion.
    """
    r = np.asarray(r_ecef_m, dtype=np.float64)
    v = np.asarray(v_ecef_m_s, dtype=np.float64)
    rc2t, rpom, ev = _itrs_from_gcrs(t, eop, pn_step_s)
    omega = rpom[..., :, 2] * np.asarray(ev.omega_earth_rad_s)[..., None]
    R = np.swapaxes(rc2t, -1, -2)
    return _apply(R, r), _apply(R, v + np.cross(omega, r))


def gcrf_to_ecef_pv(r_gcrf_m, v_gcrf_m_s, t: GpsTime, eop: EopSource | None = None,
                    pn_step_s: float | None = PN_NODE_STEP_S) -> tuple[np.ndarray, np.ndarray]:
    """(r_ecef_m, v_ecef_m_s) of a GCRF state: v_ecef = R^T v_gcrf - omega x r_ecef (inverse of ecef_to_gcrf_pv)."""
    rc2t, rpom, ev = _itrs_from_gcrs(t, eop, pn_step_s)
    omega = rpom[..., :, 2] * np.asarray(ev.omega_earth_rad_s)[..., None]
    r_e = _apply(rc2t, np.asarray(r_gcrf_m, dtype=np.float64))
    v_e = _apply(rc2t, np.asarray(v_gcrf_m_s, dtype=np.float64)) - np.cross(omega, r_e)
    return r_e, v_e


# --- orbital frame -------------------------------------------------------------------------------------

def R_orbital_from_gcrf(r_gcrf_m, v_gcrf_m_s) -> np.ndarray:
    """Rotation matrices orbital <- GCRF (..., 3, 3) from the inertial position and velocity (..., 3).

    Rows are the orbital axes in GCRF: z_o = -r/|r| (nadir), y_o = -(r x v)/|r x v| (negative orbit normal),
    x_o = y_o x z_o (along track, ~ +v for a circular orbit).
    Implements: CONVENTIONS.md "Orbital frame".
    """
    r = np.asarray(r_gcrf_m, dtype=np.float64)
    v = np.asarray(v_gcrf_m_s, dtype=np.float64)
    z = -r / np.linalg.norm(r, axis=-1, keepdims=True)
    h = np.cross(r, v)
    y = -h / np.linalg.norm(h, axis=-1, keepdims=True)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=-2)


def R_orbital_from_ecef(r_ecef_m, v_ecef_m_s, omega_ecef_rad_s=None) -> np.ndarray:
    """Rotation matrices orbital <- ECEF (..., 3, 3) from an ECEF state, with v = v_ecef + omega_E x r.

    Args:
        r_ecef_m, v_ecef_m_s: (..., 3) ECEF position and (Earth-fixed) velocity.
        omega_ecef_rad_s: Earth angular velocity in ECEF (..., 3); default (0, 0, OMEGA_EARTH_RAD_S).
    Implements: CONVENTIONS.md "Orbital frame" (inertial velocity expressed in ECEF axes); equal to
        R_orbital_from_gcrf(R r, R v_inertial) @ R for R = R_gcrf_from_ecef.
    """
    r = np.asarray(r_ecef_m, dtype=np.float64)
    omega = np.array([0.0, 0.0, OMEGA_EARTH_RAD_S]) if omega_ecef_rad_s is None else np.asarray(omega_ecef_rad_s)
    v = np.asarray(v_ecef_m_s, dtype=np.float64) + np.cross(omega, r)
    return R_orbital_from_gcrf(r, v)


# --- local level frames and WGS 84 geodetic coordinates ---------------------------------------------------

def R_ned_from_ecef(lat_rad, lon_rad) -> np.ndarray:
    """Rotation matrices NED <- ECEF (..., 3, 3) at geodetic latitude / longitude (rad).

    Rows: north = (-sin(lat) cos(lon), -sin(lat) sin(lon), cos(lat)), east = (-sin(lon), cos(lon), 0),
    down = (-cos(lat) cos(lon), -cos(lat) sin(lon), -sin(lat)).
    Implements: CONVENTIONS.md "Local level frame" on the WGS 84 ellipsoid normal.
    """
    lat = np.asarray(lat_rad, dtype=np.float64)
    lon = np.asarray(lon_rad, dtype=np.float64)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    zero = np.zeros_like(sl * so)
    n = np.stack([-sl * co, -sl * so, cl + zero], axis=-1)
    e = np.stack([-so + zero, co + zero, zero], axis=-1)
    d = np.stack([-cl * co, -cl * so, -sl + zero], axis=-1)
    return np.stack([n, e, d], axis=-2)


def R_enu_from_ecef(lat_rad, lon_rad) -> np.ndarray:
    """Rotation matrices ENU <- ECEF (..., 3, 3): rows east, north, up (= rows 2, 1, -3 of NED)."""
    ned = R_ned_from_ecef(lat_rad, lon_rad)
    return np.stack([ned[..., 1, :], ned[..., 0, :], -ned[..., 2, :]], axis=-2)


def geodetic_to_ecef(lat_rad, lon_rad, h_m, a_m: float = WGS84_A_M, f: float = WGS84_F) -> np.ndarray:
    """ECEF position (m), shape (..., 3), of geodetic latitude, longitude (rad) and ellipsoidal height (m).

    Implements: the closed form x = (N + h) cos(lat) cos(lon), y = (N + h) cos(lat) sin(lon),
    z = (N (1 - e^2) + h) sin(lat), N = a / sqrt(1 - e^2 sin^2(lat)) (NIMA TR8350.2 eq. 4-14); WGS 84 default.
    """
    e2 = f * (2.0 - f)
    lat = np.asarray(lat_rad, dtype=np.float64)
    lon = np.asarray(lon_rad, dtype=np.float64)
    h = np.asarray(h_m, dtype=np.float64)
    sl = np.sin(lat)
    n = a_m / np.sqrt(1.0 - e2 * sl * sl)
    return np.stack(np.broadcast_arrays((n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
                                        (n * (1.0 - e2) + h) * sl), axis=-1)


def ecef_to_geodetic(r_ecef_m, a_m: float = WGS84_A_M, f: float = WGS84_F):
    """(lat_rad, lon_rad, h_m) on the ellipsoid (WGS 84 default) of ECEF positions (..., 3).

    Bowring's parametric-latitude iteration (Bowring 1976, Survey Review 23(181)), repeated to convergence
    (3 passes; each is cubically convergent, so the residual is far below 1e-12 rad for any point outside
    ~10 km of the Earth's centre); h = p cos(lat) + z sin(lat) - a sqrt(1 - e^2 sin^2(lat)), exact at the poles.
    tests/gnss/test_frames.py checks the round trip with geodetic_to_ecef to < 0.1 mm (measured ~1e-8 m)
    from -10 km to 50000 km height at all latitudes.
    Implements: Bowring (1976) eqs. 1-4; NIMA TR8350.2.
    """
    r = np.asarray(r_ecef_m, dtype=np.float64)
    e2 = f * (2.0 - f)
    b = a_m * (1.0 - f)
    ep2 = e2 / (1.0 - e2)  # second eccentricity squared
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    # initial parametric latitude
    u = np.arctan2(z * a_m, p * b)
    lat = u
    for _ in range(3):
        su, cu = np.sin(u), np.cos(u)
        lat = np.arctan2(z + ep2 * b * su ** 3, p - e2 * a_m * cu ** 3)
        u = np.arctan2((1.0 - f) * np.sin(lat), np.cos(lat))
    sl = np.sin(lat)
    h = p * np.cos(lat) + z * sl - a_m * np.sqrt(1.0 - e2 * sl * sl)
    return lat, lon, h


def enu(r_from_ecef_m, r_to_ecef_m) -> np.ndarray:
    """East, north, up components (m), shape (..., 3), of r_to - r_from in the WGS 84 local frame at r_from."""
    lat, lon, _ = ecef_to_geodetic(r_from_ecef_m)
    d = np.asarray(r_to_ecef_m, dtype=np.float64) - np.asarray(r_from_ecef_m, dtype=np.float64)
    return _apply(R_enu_from_ecef(lat, lon), d)


def azimuth_elevation(r_from_ecef_m, r_to_ecef_m) -> tuple[np.ndarray, np.ndarray]:
    """(azimuth_rad in [0, 2 pi) clockwise from north, elevation_rad up positive) of r_to seen from r_from.

    Local level frame on the WGS 84 ellipsoid normal at r_from (CONVENTIONS.md baselines.csv az/el).
    """
    e, n, u = np.moveaxis(enu(r_from_ecef_m, r_to_ecef_m), -1, 0)
    az = np.mod(np.arctan2(e, n), 2.0 * np.pi)
    az = np.where(az >= 2.0 * np.pi, 0.0, az)  # mod of -1e-17 rounds to 2 pi
    el = np.arctan2(u, np.hypot(e, n))
    return az, el


__all__ = [
    "R_gcrf_from_ecef", "R_ecef_from_gcrf", "omega_earth_ecef_rad_s", "ecef_to_gcrf", "gcrf_to_ecef",
    "ecef_to_gcrf_pv", "gcrf_to_ecef_pv", "R_orbital_from_gcrf", "R_orbital_from_ecef", "R_ned_from_ecef",
    "R_enu_from_ecef", "geodetic_to_ecef", "ecef_to_geodetic", "enu", "azimuth_elevation", "EopValues",
    "PN_NODE_STEP_S",
]
