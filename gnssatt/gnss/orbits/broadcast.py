"""Satellite position, velocity and clock from broadcast Keplerian ephemerides (GPS, QZSS, Galileo, BeiDou).

Input is a `KeplerEphemeris` (gnssatt.gnss.io.rinex_nav; any object with the same array fields works):
`sat, toc (GpsTime), af0_s, af1_s_s, af2_s_s2, crs_m, delta_n_rad_s, m0_rad, cuc_rad, e, cus_rad,
sqrt_a_sqrt_m, toe_sow, cic_rad, omega0_rad, cis_rad, i0_rad, crc_m, omega_rad, omega_dot_rad_s, idot_rad_s,
tgd_s` (+ `system`, a letter, when `sat` does not start with one). Time scales as the reader keeps them:
GPS/QZSS/Galileo `toc` in GPS time and `toe_sow` seconds of the GPS(-aligned) week; BeiDou `toc` the BDT
calendar epoch as written and `toe_sow` seconds of the BDT week (BDT = GPST - 14 s).

Implements:
- IS-GPS-200N sec. 20.3.3.4.3, Table 20-IV (user algorithm for ephemeris determination), sec. 20.3.3.3.3.1
  (SV clock correction, relativistic term F e sqrt(A) sin(E_k)) and 20.3.3.3.3.2 (L1 C/A user: minus T_GD);
  IS-QZSS-PNT-005 sec. 5.5 (the same algorithm and constants as GPS).
- Galileo OS SIS ICD 2.1 sec. 5.1.1 (Table 60: same algorithm with Galileo GM), sec. 5.1.4 (clock, relativity),
  sec. 5.1.5 (E1 single-frequency user: minus BGD(E1, E5a/E5b)).
- BDS-SIS-ICD-B1I-3.0 sec. 5.2.4.12 Table 5-11 (MEO/IGSO as Table 20-IV with CGCS2000 constants; GEO C01-C05 and
  C59-C63: orbit computed with Omega_k = Omega_0 + Omega_dot t_k - Omega_e t_oe, then rotated
  R_Z(Omega_e t_k) R_X(-5 deg)), sec. 5.2.4.10 (clock, relativity) and 5.2.4.11 (B1I user: minus T_GD1).
- Velocity: the analytic time derivative of every step above (Remondi 2004 for GPS; the GEO rotation
  differentiated here), in the rotating ECEF frame.
- Kepler's equation by Newton's method to |dE| < 1e-14 rad (not one fixed-point step).
Neglects: the GGTO (GST - GPST, a few ns) and BDT/GPST broadcast offsets beyond the fixed 14 s.
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.constants import (BDT_MINUS_GPST_S, F_REL_BEIDOU_S_SQRT_M, F_REL_GALILEO_S_SQRT_M,
                                   F_REL_GPS_S_SQRT_M, GM_BEIDOU_M3_S2, GM_GALILEO_M3_S2, GM_GPS_M3_S2,
                                   OMEGA_EARTH_BEIDOU_RAD_S, OMEGA_EARTH_GALILEO_RAD_S, OMEGA_EARTH_GPS_RAD_S)
from gnssatt.gnss.time import SECONDS_PER_WEEK, GpsTime

HALF_WEEK_S = SECONDS_PER_WEEK / 2
KEPLER_TOL_RAD = 1e-14
KEPLER_MAX_ITER = 30  # Newton from E = M converges in < 6 steps for e < 0.1; 30 covers e up to ~0.9
# BeiDou GEO satellites (BDS ICD: PRN 1-5 BDS-2, 59-63 BDS-3)
BEIDOU_GEO_PRNS = frozenset({1, 2, 3, 4, 5, 59, 60, 61, 62, 63})
_BDS_GEO_INCL_RAD = np.radians(-5.0)


def _per_record(eph, idx: np.ndarray, of_name) -> np.ndarray:
    """of_name(str name) for the `sat` of each selected record, evaluated once per distinct record (idx repeats
    each record over many epochs and satellites)."""
    idx = np.asarray(idx)
    u, inverse = np.unique(idx, return_inverse=True)
    names = np.asarray(eph.sat)[u]
    return np.array([of_name(str(s)) for s in names.ravel()])[inverse.ravel()].reshape(idx.shape)


def _systems(eph, idx: np.ndarray) -> np.ndarray:
    """System letter of each selected record: first character of `sat`, else `eph.system`."""
    sat = np.asarray(eph.sat)
    if sat.dtype.kind in "US" and np.size(idx):
        letters = _per_record(eph, idx, lambda s: s[:1])
        if np.all(np.isin(letters, list("GJECRSI"))):
            return letters
    return np.full(np.shape(idx), getattr(eph, "system", "G"))


def _prns(eph, idx: np.ndarray) -> np.ndarray:
    sat = np.asarray(eph.sat)
    if sat.dtype.kind in "US":
        if not np.size(idx):
            return np.zeros(np.shape(idx), dtype=np.int64)
        return _per_record(eph, idx, lambda s: int(s[1:]) if s[1:].strip().isdigit() else -1).astype(np.int64)
    return np.asarray(sat[idx], dtype=np.int64)


def solve_kepler(m_rad, e, tol_rad: float = KEPLER_TOL_RAD, max_iter: int = KEPLER_MAX_ITER) -> np.ndarray:
    """Eccentric anomaly E (rad) with E - e sin E = M, by Newton's method to |dE| < tol_rad (vectorised).

    Implements: Kepler's equation (IS-GPS-200 Table 20-IV); Newton E <- E - (E - e sin E - M)/(1 - e cos E)
    starting at E = M, iterated until every element converged (or max_iter; non-converged elements -> NaN).
    """
    m = np.asarray(m_rad, dtype=np.float64)
    e = np.asarray(e, dtype=np.float64)
    E = m.copy() + 0.0 * e
    for _ in range(max_iter):
        dE = (E - e * np.sin(E) - m) / (1.0 - e * np.cos(E))
        E = E - dE
        if not np.any(np.abs(dE) >= tol_rad):  # NaN inputs stay NaN and do not loop forever
            return E
    return np.where(np.abs(dE) < tol_rad, E, np.nan)


def _wrap_half_week(dt_s):
    """dt into [-302400, 302400) s: the IS-GPS-200 20.3.3.4.3 week-crossover rule for t_k and t - t_oc."""
    return np.mod(dt_s + HALF_WEEK_S, SECONDS_PER_WEEK) - HALF_WEEK_S


def kepler_position_ecef(eph, idx, t: GpsTime, *, apply_tgd: bool = True):
    """(r_ecef_m (n, 3), v_ecef_m_s (n, 3), clock_s (n,), clock_rate_s_s (n,)) of records idx at GPS times t.

    Args:
        eph: KeplerEphemeris-like record arrays (see module docstring; mixed systems allowed via `sat`).
        idx: (n,) int indices of the records to use (e.g. from rinex_nav.select_ephemeris); -1 gives NaN rows.
        t: GpsTime (n,) or scalar (broadcast) at which to evaluate (GPS time; for a pseudorange model this is
            the signal transmission time in GPS time).
        apply_tgd: subtract the group delay of the single-frequency user (GPS/QZSS L1 C/A: T_GD; Galileo E1:
            the BGD matching the clock record; BeiDou B1I: T_GD1). False gives the clock of the ionosphere-free
            reference signal pair (GPS L1/L2, Galileo E1/E5x, BeiDou B3I).
    Returns: position and velocity in the ECEF frame of the ephemeris (WGS 84 / GTRF / CGCS2000) at t, the
        satellite clock offset dt_sv (s; the satellite transmits at t_sv = t + dt_sv, so the pseudorange model
        subtracts c * dt_sv) including the relativistic eccentricity term F e sqrt(A) sin E, and its rate.
    Implements: see module docstring (IS-GPS-200 Table 20-IV, Galileo OS SIS ICD 5.1, BDS ICD 5.2.4).
    """
    idx = np.atleast_1d(np.asarray(idx, dtype=np.int64))
    n = idx.size
    bad = idx < 0
    j = np.where(bad, 0, idx)
    ts = np.broadcast_to(np.asarray(t.s), idx.shape)
    tf = np.broadcast_to(np.asarray(t.frac), idx.shape)

    sysl = _systems(eph, j)
    is_c = sysl == "C"
    is_e = sysl == "E"
    gm = np.where(is_c, GM_BEIDOU_M3_S2, np.where(is_e, GM_GALILEO_M3_S2, GM_GPS_M3_S2))
    we = np.where(is_c, OMEGA_EARTH_BEIDOU_RAD_S, np.where(is_e, OMEGA_EARTH_GALILEO_RAD_S, OMEGA_EARTH_GPS_RAD_S))
    frel = np.where(is_c, F_REL_BEIDOU_S_SQRT_M, np.where(is_e, F_REL_GALILEO_S_SQRT_M, F_REL_GPS_S_SQRT_M))
    geo = is_c & np.isin(_prns(eph, j), list(BEIDOU_GEO_PRNS))

    g = lambda name: np.asarray(getattr(eph, name), dtype=np.float64)[j]  # noqa: E731

    # Time from ephemeris reference epoch, in the system's own time (BDT for BeiDou), two-part then wrapped.
    shift_s = np.where(is_c, BDT_MINUS_GPST_S, 0.0).astype(np.int64)  # whole seconds
    sow_whole = np.mod(ts + shift_s, SECONDS_PER_WEEK).astype(np.float64)
    tk = _wrap_half_week((sow_whole - g("toe_sow")) + tf)
    # Clock: t - t_oc (toc is GPS time, or the BDT calendar epoch for BeiDou).
    toc = eph.toc[j]
    dt_clk = _wrap_half_week((ts + shift_s - toc.s).astype(np.float64) + (tf - toc.frac))

    sqrt_a = g("sqrt_a_sqrt_m")
    a = sqrt_a * sqrt_a
    e = g("e")
    n0 = np.sqrt(gm / a ** 3)  # computed mean motion (rad/s)
    nn = n0 + g("delta_n_rad_s")  # corrected mean motion
    mk = g("m0_rad") + nn * tk  # mean anomaly
    ek = solve_kepler(mk, e)  # eccentric anomaly
    sin_e, cos_e = np.sin(ek), np.cos(ek)
    one_m_ecos = 1.0 - e * cos_e
    sq1me2 = np.sqrt(1.0 - e * e)
    nu = np.arctan2(sq1me2 * sin_e, cos_e - e)  # true anomaly
    phi = nu + g("omega_rad")  # argument of latitude
    s2, c2 = np.sin(2.0 * phi), np.cos(2.0 * phi)
    cus, cuc, crs, crc, cis, cic = (g(k) for k in ("cus_rad", "cuc_rad", "crs_m", "crc_m", "cis_rad", "cic_rad"))
    du = cus * s2 + cuc * c2  # second harmonic corrections
    dr = crs * s2 + crc * c2
    di = cis * s2 + cic * c2
    u = phi + du  # corrected argument of latitude
    r = a * one_m_ecos + dr  # corrected radius
    inc = g("i0_rad") + di + g("idot_rad_s") * tk  # corrected inclination
    xp, yp = r * np.cos(u), r * np.sin(u)  # position in the orbital plane
    omega_dot = g("omega_dot_rad_s")
    toe = g("toe_sow")
    # corrected longitude of ascending node: Earth-fixed for MEO/IGSO; inertial-like for BeiDou GEO
    om_rate = np.where(geo, omega_dot, omega_dot - we)
    om = g("omega0_rad") + om_rate * tk - we * toe
    so, co, si, ci = np.sin(om), np.cos(om), np.sin(inc), np.cos(inc)
    x = xp * co - yp * ci * so
    y = xp * so + yp * ci * co
    z = yp * si

    # --- analytic rates ---
    ek_dot = nn / one_m_ecos
    nu_dot = ek_dot * sq1me2 / one_m_ecos  # = d(phi)/dt
    u_dot = nu_dot * (1.0 + 2.0 * (cus * c2 - cuc * s2))
    r_dot = a * e * sin_e * ek_dot + 2.0 * nu_dot * (crs * c2 - crc * s2)
    i_dot = g("idot_rad_s") + 2.0 * nu_dot * (cis * c2 - cic * s2)
    xp_dot = r_dot * np.cos(u) - r * u_dot * np.sin(u)
    yp_dot = r_dot * np.sin(u) + r * u_dot * np.cos(u)
    vx = xp_dot * co - yp_dot * ci * so + yp * si * so * i_dot - om_rate * y
    vy = xp_dot * so + yp_dot * ci * co - yp * si * co * i_dot + om_rate * x
    vz = yp_dot * si + yp * ci * i_dot

    pos = np.stack([x, y, z], axis=-1)
    vel = np.stack([vx, vy, vz], axis=-1)
    if np.any(geo):
        # BDS GEO: r = R_Z(we tk) R_X(-5 deg) r_GK (frame rotations as the BDS ICD defines R_X, R_Z)
        ang = we * tk
        ca, sa = np.cos(ang), np.sin(ang)
        cf, sf = np.cos(_BDS_GEO_INCL_RAD), np.sin(_BDS_GEO_INCL_RAD)
        # R_X(f) = [[1, 0, 0], [0, cf, sf], [0, -sf, cf]]
        gx, gy, gz = x, cf * y + sf * z, -sf * y + cf * z
        gvx, gvy, gvz = vx, cf * vy + sf * vz, -sf * vy + cf * vz
        # R_Z(a) = [[ca, sa, 0], [-sa, ca, 0], [0, 0, 1]]; dR_Z/dt = we [[-sa, ca, 0], [-ca, -sa, 0], [0, 0, 0]]
        rx, ry = ca * gx + sa * gy, -sa * gx + ca * gy
        rvx = ca * gvx + sa * gvy + we * (-sa * gx + ca * gy)
        rvy = -sa * gvx + ca * gvy + we * (-ca * gx - sa * gy)
        pos = np.where(geo[:, None], np.stack([rx, ry, gz], -1), pos)
        vel = np.where(geo[:, None], np.stack([rvx, rvy, gvz], -1), vel)

    # --- clock ---
    af0, af1, af2 = g("af0_s"), g("af1_s_s"), g("af2_s_s2")
    rel = frel * e * sqrt_a * sin_e  # relativistic correction (s)
    rel_rate = frel * e * sqrt_a * cos_e * ek_dot
    clock = af0 + af1 * dt_clk + af2 * dt_clk * dt_clk + rel
    if apply_tgd:
        tgd = g("tgd_s")
        clock = clock - np.where(np.isfinite(tgd), tgd, 0.0)
    clock_rate = af1 + 2.0 * af2 * dt_clk + rel_rate

    if np.any(bad):
        pos = np.where(bad[:, None], np.nan, pos)
        vel = np.where(bad[:, None], np.nan, vel)
        clock = np.where(bad, np.nan, clock)
        clock_rate = np.where(bad, np.nan, clock_rate)
    assert pos.shape == (n, 3)
    return pos, vel, clock, clock_rate


def eccentricity_relativity_s(eph, idx, t: GpsTime) -> np.ndarray:
    """The relativistic clock term F e sqrt(A) sin(E_k) (s) alone, (n,), e.g. to compare with -2 r.v / c^2."""
    _, _, clk, _ = kepler_position_ecef(_zero_clock_view(eph), idx, t, apply_tgd=False)
    return clk


class _zero_clock_view:
    """An ephemeris view with af0 = af1 = af2 = 0 (so the clock is the relativistic term only)."""

    def __init__(self, eph):
        self._eph = eph

    def __getattr__(self, name):
        v = getattr(self._eph, name)
        if name in ("af0_s", "af1_s_s", "af2_s_s2"):
            return np.zeros(np.shape(v))
        return v


class BroadcastOrbit:
    """A callable satellite-state source over one `KeplerEphemeris`: `orbit(sats, t)` -> (r, v, clk, clk_rate).

    `sats`: (n,) satellite ids ('G05'); `t`: GpsTime (n,) or scalar. The record for each (sat, t) is chosen by
    `gnssatt.gnss.io.rinex_nav.select_ephemeris` (healthy, within the fit interval, nearest toe); none -> NaN.
    This is the `sat_state` callable that gnssatt.gnss.geometry.emission_time_and_position accepts.
    """

    def __init__(self, eph, *, apply_tgd: bool = True, max_age_s: float | None = None):
        self.eph = eph
        self.apply_tgd = apply_tgd
        self.max_age_s = max_age_s

    def select(self, sats, t: GpsTime) -> np.ndarray:
        from gnssatt.gnss.io.rinex_nav import select_ephemeris

        sats = np.atleast_1d(np.asarray(sats))
        ts = GpsTime(np.broadcast_to(np.asarray(t.s), sats.shape), np.broadcast_to(np.asarray(t.frac), sats.shape))
        out = np.full(sats.shape, -1, dtype=np.int64)
        for sat in np.unique(sats):
            m = sats == sat
            out[m] = select_ephemeris(self.eph, str(sat), ts[m], max_age_s=self.max_age_s)
        return out

    def __call__(self, sats, t: GpsTime):
        return kepler_position_ecef(self.eph, self.select(sats, t), t, apply_tgd=self.apply_tgd)


__all__ = ["kepler_position_ecef", "solve_kepler", "eccentricity_relativity_s", "BroadcastOrbit",
           "BEIDOU_GEO_PRNS"]
