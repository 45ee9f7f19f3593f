"""GLONASS satellite position, velocity and clock from broadcast state vectors (RINEX GLONASS navigation records).

A GLONASS record gives the satellite's position, velocity and lunisolar acceleration at t_b in the rotating PZ-90
frame; the user integrates the equations of motion to the time of interest (at most 15 min from t_b inside the
record's validity, 30 min here as RTKLIB's MAXDTOE_GLO).

Implements: GLONASS ICD edition 5.1 (2008) Appendix A.3.1.2 (simplified equations of motion in the rotating PZ-90
frame: central term, the second zonal harmonic J2^0, centrifugal and Coriolis terms, and the broadcast lunisolar
acceleration held constant) integrated by fourth-order Runge-Kutta with steps of at most 60 s (as RTKLIB 2.4.3
geph2pos, TSTEP = 60 s); sec. 3.3.3 and A.3.1.2 (satellite clock dt_sv = -tau_n + gamma_n (t - t_b), relativity
already in the broadcast clock). Constants: ICD 5.1 Table 3.2 (GM 398 600.4418 km^3/s^2, a_e 6 378 136 m,
J2^0 1082.62575e-6, omega_E 7.292115e-5 rad/s).
Neglects: the PZ-90.11 -> ITRF/WGS 84 transformation (a few cm since PZ-90.11, 2014), the GLONASS-GPS system time
offset tau_GPS (a few tens of ns: a receiver inter-system bias for positioning, cancelled in between-receiver
single differences).
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.time import GpsTime

__all__ = ["GM_GLONASS_M3_S2", "glonass_state_ecef", "glonass_deriv", "select_glonass"]

GM_GLONASS_M3_S2 = 398600.4418e9
AE_GLONASS_M = 6378136.0
J2_GLONASS = 1082.62575e-6
OMEGA_EARTH_GLONASS_RAD_S = 7.292115e-5
STEP_MAX_S = 60.0


def glonass_deriv(y: np.ndarray, acc_ls_m_s2: np.ndarray) -> np.ndarray:
    """d/dt of states y (n, 6) = (r, v) in the rotating PZ-90 frame: GLONASS ICD 5.1 eq. A.3.1.2 (J2, rotation,
    broadcast lunisolar acceleration acc_ls_m_s2 (n, 3))."""
    r, v = y[:, :3], y[:, 3:]
    r2 = np.einsum("ij,ij->i", r, r)
    rn = np.sqrt(r2)
    a = 1.5 * J2_GLONASS * GM_GLONASS_M3_S2 * AE_GLONASS_M ** 2 / (r2 * r2 * rn)    # 3/2 J2 mu ae^2 / r^5
    b = 5.0 * r[:, 2] ** 2 / r2
    c = -GM_GLONASS_M3_S2 / (r2 * rn) - a * (1.0 - b)
    w2 = OMEGA_EARTH_GLONASS_RAD_S ** 2
    out = np.empty_like(y)
    out[:, :3] = v
    out[:, 3] = (c + w2) * r[:, 0] + 2.0 * OMEGA_EARTH_GLONASS_RAD_S * v[:, 1] + acc_ls_m_s2[:, 0]
    out[:, 4] = (c + w2) * r[:, 1] - 2.0 * OMEGA_EARTH_GLONASS_RAD_S * v[:, 0] + acc_ls_m_s2[:, 1]
    out[:, 5] = (c - 2.0 * a) * r[:, 2] + acc_ls_m_s2[:, 2]
    return out


def glonass_state_ecef(eph, idx, t: GpsTime):
    """(r_ecef_m (n, 3), v_ecef_m_s (n, 3), clock_s (n,), clock_rate_s_s (n,)) of GLONASS records idx at GPS times t.

    Args:
        eph: gnssatt.gnss.io.rinex_nav.GlonassEphemeris (toc in GPS time; position/velocity/acceleration in m).
        idx: (n,) record indices (-1 gives NaN rows); t: GpsTime (n,) or scalar.
    Implements: GLONASS ICD 5.1 A.3.1.2 by RK4, steps of at most 60 s, all satellites at once (each with its own
    step dt_i / n_steps); clock dt_sv = -tau_n + gamma_n (t - t_b) (sec. 3.3.3).
    """
    idx = np.atleast_1d(np.asarray(idx, dtype=np.int64))
    n = idx.size
    bad = idx < 0
    j = np.where(bad, 0, idx)
    ts = np.broadcast_to(np.asarray(t.s), idx.shape)
    tf = np.broadcast_to(np.asarray(t.frac), idx.shape)
    toc = eph.toc[j] if n else eph.toc
    dt = (ts - np.asarray(toc.s)).astype(np.float64) + (tf - np.asarray(toc.frac))
    y = np.concatenate([np.asarray(eph.position_m, float)[j], np.asarray(eph.velocity_m_s, float)[j]], axis=1)
    acc = np.asarray(eph.acceleration_m_s2, float)[j]
    n_steps = int(np.ceil(np.max(np.abs(dt)) / STEP_MAX_S)) if n and np.all(np.isfinite(dt)) else 0
    if n_steps:
        h = (dt / n_steps)[:, None]
        for _ in range(n_steps):
            k1 = glonass_deriv(y, acc)
            k2 = glonass_deriv(y + 0.5 * h * k1, acc)
            k3 = glonass_deriv(y + 0.5 * h * k2, acc)
            k4 = glonass_deriv(y + h * k3, acc)
            y = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    gamma = np.asarray(eph.gamma_n, float)[j]
    clock = -np.asarray(eph.tau_n_s, float)[j] + gamma * dt
    y[bad] = np.nan
    clock = np.where(bad, np.nan, clock)
    rate = np.where(bad, np.nan, gamma)
    return y[:, :3], y[:, 3:], clock, rate


def select_glonass(eph, sat: str, t: GpsTime, max_age_s: float, allow_unhealthy: bool = False) -> np.ndarray:
    """(n,) record index per time: the record of `sat` with the nearest t_b within max_age_s (healthy, B_n = 0,
    unless allow_unhealthy), -1 where none (as RTKLIB 2.4.3 selgeph)."""
    nt = len(np.atleast_1d(t.s))
    cand = np.flatnonzero(np.asarray(eph.sat) == sat)
    if not allow_unhealthy:
        cand = cand[np.asarray(eph.health)[cand] == 0]
    if cand.size == 0:
        return np.full(nt, -1, dtype=np.int64)
    toc = eph.toc[cand]
    d = np.abs((np.atleast_1d(t.s)[:, None] - np.asarray(toc.s)[None, :]).astype(np.float64)
               + (np.atleast_1d(t.frac)[:, None] - np.asarray(toc.frac)[None, :]))
    best = np.argmin(d, axis=1)
    ok = d[np.arange(nt), best] <= max_age_s
    return np.where(ok, cand[best], -1)
