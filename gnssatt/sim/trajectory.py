"""Platform motion: centre-of-mass trajectory and attitude as smooth functions of true GPS time.

Orbits: Keplerian elements + J2 integrated numerically in GCRF (DOP853), a TLE through SGP4 (TEME ->
ECEF by GMST 1982, CONVENTIONS frames thereafter), or an SP3 of the platform (9th-order Lagrange);
terrestrial: a static point or a trajectory CSV. Attitude: Earth pointing (body = orbital frame) with
sinusoidal wobble, minimum-jerk slerp slews between Euler-angle waypoints, a quaternion CSV; NED-relative
heading/pitch/roll for terrestrial platforms.

All times are float seconds `dt_s` since the scenario's reference epoch t0 (whole GPS second), which
keeps ~1e-12 s resolution over a day.

Implements: Vallado, "Fundamentals of Astrodynamics", 4th ed., eq. 8-31 (J2 acceleration) and
Algorithm 10 (Keplerian elements -> r, v); Hoots & Roehrich 1980 / Vallado et al. 2006 (SGP4 via the
sgp4 package); Flash & Hogan 1985 (minimum-jerk profile).
Neglects: higher gravity harmonics, drag and third bodies for the Keplerian+J2 orbit (the simulation is
self-consistent: the truth is the integrated orbit).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicHermiteSpline

from gnssatt.sim import _rot
from gnssatt.sim._constants import GM_EARTH_M3_S2, J2, OMEGA_E_RAD_S, R_EARTH_M
from gnssatt.sim._frames import (EarthRotation, R_ned_from_ecef, R_orbital_from_inertial,
                                ecef_from_geodetic, geodetic_from_ecef)

_GRID_S = 2.0  # Hermite node spacing: interpolation error < 1e-6 m for a LEO (h^4/384 |r''''|)


def _j2_rhs(_t, y):
    r = y[:3]
    rn = np.linalg.norm(r)
    z2 = (r[2] / rn) ** 2
    k = -GM_EARTH_M3_S2 / rn ** 3
    f = 1.5 * J2 * (R_EARTH_M / rn) ** 2
    a = k * r * np.array([1 + f * (1 - 5 * z2), 1 + f * (1 - 5 * z2), 1 + f * (3 - 5 * z2)])
    return np.concatenate([y[3:], a])


def kepler_to_rv(a_m, e, i_deg, raan_deg, argp_deg, m_deg):
    """GCRF position (m) and velocity (m/s) of osculating Keplerian elements (two-body, Vallado Alg. 10)."""
    M = np.radians(m_deg)
    E = M
    for _ in range(30):
        E = E - (E - e * np.sin(E) - M) / (1 - e * np.cos(E))
    nu = 2 * np.arctan2(np.sqrt(1 + e) * np.sin(E / 2), np.sqrt(1 - e) * np.cos(E / 2))
    p = a_m * (1 - e * e)
    r_pf = p / (1 + e * np.cos(nu)) * np.array([np.cos(nu), np.sin(nu), 0.0])
    v_pf = np.sqrt(GM_EARTH_M3_S2 / p) * np.array([-np.sin(nu), e + np.cos(nu), 0.0])
    O, i, w = np.radians(raan_deg), np.radians(i_deg), np.radians(argp_deg)
    cO, sO, ci, si, cw, sw = np.cos(O), np.sin(O), np.cos(i), np.sin(i), np.cos(w), np.sin(w)
    Q = np.array([[cO * cw - sO * sw * ci, -cO * sw - sO * cw * ci, sO * si],
                  [sO * cw + cO * sw * ci, -sO * sw + cO * cw * ci, -cO * si],
                  [sw * si, cw * si, ci]])
    return Q @ r_pf, Q @ v_pf


class CenterOfMass:
    """Platform centre of mass: r_gcrf(dt), v_gcrf(dt), r_ecef(dt) (arrays (..., 3))."""

    def __init__(self, earth: EarthRotation, dt_nodes: np.ndarray, r_gcrf: np.ndarray, v_gcrf: np.ndarray):
        self.earth = earth
        self._rs = CubicHermiteSpline(dt_nodes, r_gcrf, v_gcrf, axis=0)
        self._vs = self._rs.derivative()

    def r_gcrf(self, dt):
        return self._rs(np.asarray(dt, dtype=np.float64))

    def v_gcrf(self, dt):
        return self._vs(np.asarray(dt, dtype=np.float64))

    def r_ecef(self, dt):
        return np.einsum("...ij,...j->...i", self.earth.R_ecef_from_gcrf(dt), self.r_gcrf(dt))


def orbit_kepler_j2(earth: EarthRotation, span_s, *, perigee_alt_km, apogee_alt_km, inclination_deg, raan_deg,
                    argp_deg, mean_anomaly_deg) -> CenterOfMass:
    """Centre of mass on a Keplerian + J2 orbit whose osculating elements hold at dt = 0 (GCRF axes)."""
    rp = R_EARTH_M + perigee_alt_km * 1e3
    ra = R_EARTH_M + apogee_alt_km * 1e3
    a, e = (rp + ra) / 2, (ra - rp) / (ra + rp)
    r0, v0 = kepler_to_rv(a, e, inclination_deg, raan_deg, argp_deg, mean_anomaly_deg)
    lo = np.floor(span_s[0] / _GRID_S) * _GRID_S - 2 * _GRID_S
    hi = np.ceil(span_s[1] / _GRID_S) * _GRID_S + 2 * _GRID_S
    nodes_f = np.arange(0.0, hi + _GRID_S / 2, _GRID_S)
    nodes_b = np.arange(0.0, lo - _GRID_S / 2, -_GRID_S)
    ys = []
    for nodes in (nodes_b, nodes_f):
        if len(nodes) < 2:
            ys.append(np.zeros((0, 6)))
            continue
        sol = solve_ivp(_j2_rhs, (nodes[0], nodes[-1]), np.concatenate([r0, v0]), method="DOP853",
                        t_eval=nodes, rtol=1e-12, atol=1e-6)
        ys.append(sol.y.T)
    dt = np.concatenate([nodes_b[::-1][:-1], nodes_f]) if len(nodes_b) >= 2 else nodes_f
    y = np.concatenate([ys[0][::-1][:-1], ys[1]]) if len(nodes_b) >= 2 else ys[1]
    return CenterOfMass(earth, dt, y[:, :3], y[:, 3:])


def orbit_tle(earth: EarthRotation, span_s, t0_gps_s: int, leap_s: int, line1: str, line2: str) -> CenterOfMass:
    """Centre of mass from a TLE: SGP4 in TEME, rotated to ECEF by GMST82 (polar motion 0), then to GCRF.

    Implements: Vallado et al. 2006 (AIAA 2006-6753) sec. on TEME -> PEF via GMST 1982.
    """
    from sgp4.api import Satrec

    sat = Satrec.twoline2rv(line1, line2)
    lo = np.floor(span_s[0] / _GRID_S) * _GRID_S - 2 * _GRID_S
    hi = np.ceil(span_s[1] / _GRID_S) * _GRID_S + 2 * _GRID_S
    dt = np.arange(lo, hi + _GRID_S / 2, _GRID_S)
    day0 = t0_gps_s // 86400
    sod_utc = (t0_gps_s - day0 * 86400) - leap_s + dt
    jd = np.full(dt.shape, 2444244.5 + day0)
    fr = sod_utc / 86400.0
    err, r_km, v_km_s = sat.sgp4_array(jd, fr)
    if np.any(err):
        raise ValueError(f"SGP4 failed for this TLE (error code {int(err[err != 0][0])})")
    tut1 = ((jd - 2451545.0) + fr) / 36525.0
    gmst = np.radians((67310.54841 + (876600 * 3600 + 8640184.812866) * tut1 + 0.093104 * tut1 ** 2
                       - 6.2e-6 * tut1 ** 3) % 86400 / 240.0)
    c, s = np.cos(gmst), np.sin(gmst)
    r_t, v_t = np.asarray(r_km) * 1e3, np.asarray(v_km_s) * 1e3
    r_e = np.stack([c * r_t[:, 0] + s * r_t[:, 1], -s * r_t[:, 0] + c * r_t[:, 1], r_t[:, 2]], -1)
    v_e = np.stack([c * v_t[:, 0] + s * v_t[:, 1], -s * v_t[:, 0] + c * v_t[:, 1], v_t[:, 2]], -1)
    v_e = v_e - np.cross([0, 0, OMEGA_E_RAD_S], r_e)
    return _com_from_ecef(earth, dt, r_e, v_e)


def _com_from_ecef(earth, dt, r_e, v_e) -> CenterOfMass:
    R = earth.R_ecef_from_gcrf(dt)
    Rt = np.swapaxes(R, -1, -2)
    r_i = np.einsum("nij,nj->ni", Rt, r_e)
    v_i = np.einsum("nij,nj->ni", Rt, v_e + np.cross([0, 0, OMEGA_E_RAD_S], r_e))
    return CenterOfMass(earth, dt, r_i, v_i)


def orbit_from_sp3_file(earth: EarthRotation, span_s, t0_gps_s: int, path: str | Path) -> CenterOfMass:
    """Centre of mass from the first satellite of an SP3 file (gnssatt.gnss.io.sp3 reader, degree-9 Lagrange
    interpolation of gnssatt.gnss.orbits.sp3_interp for position and velocity), moved to GCRF."""
    from gnssatt.gnss.io.sp3 import read_sp3
    from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity
    from gnssatt.gnss.time import GpsTime

    sp3 = read_sp3(path)
    sat = sp3.sats[0]
    lo = np.floor(span_s[0] / _GRID_S) * _GRID_S - 2 * _GRID_S
    hi = np.ceil(span_s[1] / _GRID_S) * _GRID_S + 2 * _GRID_S
    dt = np.arange(lo, hi + _GRID_S / 2, _GRID_S)
    t = GpsTime(t0_gps_s) + dt
    r_e = np.asarray(interpolate_sp3(sp3, [sat], t)[0])[:, 0, :]
    v_e = np.asarray(interpolate_sp3_velocity(sp3, [sat], t))[:, 0, :]
    if not (np.all(np.isfinite(r_e)) and np.all(np.isfinite(v_e))):
        raise ValueError(f"SP3 {path} does not cover the scenario span {lo:.0f}..{hi:.0f} s around the start "
                         f"(with 5 sampling points of margin)")
    return _com_from_ecef(earth, dt, r_e, v_e)


class Terrestrial:
    """A ground/sea/air platform: ECEF position (static or from a trajectory), NED-relative attitude."""

    def __init__(self, earth: EarthRotation, dt_nodes, r_ecef_nodes):
        self.earth = earth
        self.static = len(dt_nodes) == 1
        if self.static:
            self._r = np.asarray(r_ecef_nodes[0], dtype=np.float64)
        else:
            from scipy.interpolate import CubicSpline
            self._spl = CubicSpline(dt_nodes, r_ecef_nodes, axis=0)

    def r_ecef(self, dt):
        dt = np.asarray(dt, dtype=np.float64)
        if self.static:
            return np.broadcast_to(self._r, dt.shape + (3,)).copy()
        return self._spl(dt)


def terrestrial_static(earth, lat_deg, lon_deg, height_m) -> Terrestrial:
    return Terrestrial(earth, np.array([0.0]), ecef_from_geodetic(lat_deg, lon_deg, height_m)[None])


def terrestrial_from_csv(earth, t0_gps_s: int, path) -> Terrestrial:
    """Trajectory CSV with header `time_gps,lat_deg,lon_deg,height_m` (GPS ISO times)."""
    from gnssatt.gnss.time import GpsTime

    rows = [ln.split(",") for ln in Path(path).read_text().splitlines()[1:] if ln.strip()]
    t = np.array([GpsTime.from_iso(r[0]) - GpsTime(t0_gps_s) for r in rows])
    llh = np.array([[float(v) for v in r[1:4]] for r in rows])
    return Terrestrial(earth, t, ecef_from_geodetic(llh[:, 0], llh[:, 1], llh[:, 2]))


# --------------------------------------------------------------------------------------------- attitude
@dataclass
class AttitudeProfile:
    """Body attitude relative to a reference frame (orbital for spacecraft, NED for terrestrial).

    kind: "fixed" (constant Euler angles + wobble), "waypoints" (minimum-jerk slerp between
    [t_s, yaw, pitch, roll] rows; before the first / after the last row the end orientations hold),
    or "quaternion-csv" (q_body_from_gcrf or ECEF samples from a CONVENTIONS reference-attitude CSV).
    """

    kind: str = "fixed"
    euler_deg: tuple = (0.0, 0.0, 0.0)
    wobble_amp_deg: tuple = (0.0, 0.0, 0.0)
    wobble_period_s: tuple = (600.0, 900.0, 700.0)
    wobble_phase_rad: tuple = (0.0, 0.0, 0.0)
    waypoints: tuple = ()
    csv_times_s: np.ndarray | None = None
    csv_q: np.ndarray | None = None
    csv_frame: str = "GCRF"

    def R_body_from_ref(self, dt) -> np.ndarray:
        dt = np.asarray(dt, dtype=np.float64)
        if self.kind == "waypoints":
            R = self._waypoint_dcm(dt)
        else:
            R = np.broadcast_to(_rot.dcm_from_euler321_deg(*self.euler_deg), dt.shape + (3, 3))
        if any(self.wobble_amp_deg):
            a, P, ph = self.wobble_amp_deg, self.wobble_period_s, self.wobble_phase_rad
            w = [a[k] * np.sin(2 * np.pi * dt / P[k] + ph[k]) for k in range(3)]
            R = _rot.dcm_from_euler321_deg(*w) @ R
        return R

    def _waypoint_dcm(self, dt):
        wp = np.asarray(self.waypoints, dtype=np.float64)
        q = _rot.quat_from_dcm(_rot.dcm_from_euler321_deg(wp[:, 1], wp[:, 2], wp[:, 3]))
        out = np.empty(dt.shape + (4,))
        flat = dt.ravel()
        res = np.empty((flat.size, 4))
        seg = np.clip(np.searchsorted(wp[:, 0], flat, side="right") - 1, 0, max(len(wp) - 2, 0))
        if len(wp) == 1:
            res[:] = q[0]
        else:
            for k in np.unique(seg):
                m = seg == k
                tau = (flat[m] - wp[k, 0]) / (wp[k + 1, 0] - wp[k, 0])
                res[m] = _rot.slerp(q[k], q[k + 1], _rot.min_jerk(tau))
        out[...] = res.reshape(out.shape)
        return _rot.dcm_from_quat(out)

    def R_body_from_csv_frame(self, dt) -> np.ndarray:
        """Quaternion CSV attitude (slerp between samples) as R_body_from_<csv_frame>."""
        dt = np.asarray(dt, dtype=np.float64).ravel()
        tt, q = self.csv_times_s, self.csv_q
        k = np.clip(np.searchsorted(tt, dt, side="right") - 1, 0, len(tt) - 2)
        res = np.empty((dt.size, 4))
        for j in np.unique(k):
            m = k == j
            res[m] = _rot.slerp(q[j], q[j + 1], np.clip((dt[m] - tt[j]) / (tt[j + 1] - tt[j]), 0, 1))
        return _rot.dcm_from_quat(res)


def read_quaternion_csv(path, t0_gps_s: int):
    """(times_s since t0, q (n,4), frame) of a CONVENTIONS reference-attitude CSV (one frame throughout)."""
    from gnssatt.gnss.time import GpsTime

    lines = Path(path).read_text().splitlines()
    head = [h.strip() for h in lines[0].split(",")]
    ix = {h: i for i, h in enumerate(head)}
    rows = [ln.split(",") for ln in lines[1:] if ln.strip()]
    t = np.array([GpsTime.from_iso(r[ix["time_gps"]]) - GpsTime(t0_gps_s) for r in rows])
    q = np.array([[float(r[ix[c]]) for c in ("qw", "qx", "qy", "qz")] for r in rows])
    frames = {r[ix["frame"]].strip() for r in rows}
    if len(frames) != 1:
        raise ValueError(f"quaternion CSV {path}: one frame expected, found {sorted(frames)}")
    return t, q / np.linalg.norm(q, axis=1, keepdims=True), frames.pop()


class Platform:
    """Rigid platform motion: centre of mass + attitude. Spacecraft attitude is relative to the orbital frame."""

    def __init__(self, kind: str, com, attitude: AttitudeProfile, earth: EarthRotation):
        self.kind = kind
        self.com = com
        self.attitude = attitude
        self.earth = earth

    def state(self, dt):
        """(r_com_ecef_m (...,3), R_ecef_from_body (...,3,3), R_ecef_from_gcrf (...,3,3)) at true times t0+dt."""
        dt = np.asarray(dt, dtype=np.float64)
        R_e_i = self.earth.R_ecef_from_gcrf(dt)
        if self.kind == "spacecraft":
            r_i, v_i = self.com.r_gcrf(dt), self.com.v_gcrf(dt)
            r_e = np.einsum("...ij,...j->...i", R_e_i, r_i)
            if self.attitude.kind == "quaternion-csv":
                R_b_f = self.attitude.R_body_from_csv_frame(dt).reshape(dt.shape + (3, 3))
                R_b_e = R_b_f if self.attitude.csv_frame == "ECEF" else R_b_f @ np.swapaxes(R_e_i, -1, -2)
            else:
                R_b_i = self.attitude.R_body_from_ref(dt) @ R_orbital_from_inertial(r_i, v_i)
                R_b_e = R_b_i @ np.swapaxes(R_e_i, -1, -2)
        else:
            r_e = self.com.r_ecef(dt)
            lat, lon, _ = geodetic_from_ecef(r_e)
            if self.attitude.kind == "quaternion-csv":
                R_b_f = self.attitude.R_body_from_csv_frame(dt).reshape(dt.shape + (3, 3))
                R_b_e = R_b_f if self.attitude.csv_frame == "ECEF" else R_b_f @ np.swapaxes(R_e_i, -1, -2)
            else:
                R_b_e = self.attitude.R_body_from_ref(dt) @ R_ned_from_ecef(lat, lon)
        return r_e, np.swapaxes(R_b_e, -1, -2), R_e_i

    def reference_dcm(self, dt):
        """R_ref_from_ecef (orbital frame or NED) at t0+dt, for Euler angles."""
        dt = np.asarray(dt, dtype=np.float64)
        R_e_i = self.earth.R_ecef_from_gcrf(dt)
        if self.kind == "spacecraft":
            return R_orbital_from_inertial(self.com.r_gcrf(dt), self.com.v_gcrf(dt)) @ np.swapaxes(R_e_i, -1, -2)
        lat, lon, _ = geodetic_from_ecef(self.com.r_ecef(dt))
        return R_ned_from_ecef(lat, lon)
