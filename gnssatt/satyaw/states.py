"""Sun and satellite states at the epochs of a yaw or baseline estimation (ECEF, GPS time).

The Sun moves by 0.25 deg/min in ECEF; it is evaluated by ERFA (gnssatt.gnss.satellite_antenna) every
SUN_STEP_S and interpolated linearly, then renormalised to its distance: the direction error is < 1e-6 rad,
far below what a yaw estimate resolves.
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.time import GpsTime

__all__ = ["sun_ecef_m", "satellite_states", "SUN_STEP_S"]

#: node spacing of the Sun's ECEF position (s): chord error (0.25 deg/min * 5 min)^2 / 8 ~ 2e-6 rad
SUN_STEP_S = 300.0


def sun_ecef_m(t: GpsTime) -> np.ndarray:
    """(n, 3) geocentric Sun position (m, ECEF) at GPS times t (n,): ERFA nodes every SUN_STEP_S, linear."""
    from gnssatt.gnss.satellite_antenna import sun_position_ecef_m

    t = GpsTime(np.atleast_1d(t.s), np.atleast_1d(t.frac))
    x = (t.s - t.s.min()).astype(np.float64) + t.frac
    n_nodes = int(np.ceil(x.max() / SUN_STEP_S)) + 2 if len(x) else 0
    nodes = GpsTime(t.s.min() + (np.arange(n_nodes) * SUN_STEP_S).astype(np.int64), np.zeros(n_nodes))
    sun_nodes = sun_position_ecef_m(nodes)
    xn = np.arange(n_nodes) * SUN_STEP_S
    out = np.stack([np.interp(x, xn, sun_nodes[:, i]) for i in range(3)], axis=-1)
    dist = np.interp(x, xn, np.linalg.norm(sun_nodes, axis=-1))
    return out * (dist / np.linalg.norm(out, axis=-1))[:, None]


def satellite_states(ephemeris, sat: str, t: GpsTime) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(r_ecef_m (n, 3), v_ecef_m_s (n, 3), valid (n,)) of satellite `sat` at times t from a
    BroadcastEphemeris or PreciseEphemeris (gnssatt.gnss.ephemeris).

    Neglects: the signal's light time (0.12 s; at 3 km/s the line of sight turns by < 1e-5 rad).
    """
    st = ephemeris.state(np.full(len(t), sat), t)
    valid = np.all(np.isfinite(st.r_ecef_m), axis=-1) & np.all(np.isfinite(st.v_ecef_m_s), axis=-1)
    return st.r_ecef_m, st.v_ecef_m_s, valid   # the clock is not needed (an SP3 may leave it blank)
