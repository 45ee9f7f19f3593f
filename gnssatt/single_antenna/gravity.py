"""Gravitation with J2 and the specific force a GNSS-derived ECEF acceleration implies.

f_ecef = a_ecef + 2 omega x v_ecef + omega x (omega x r_ecef) - g_J2(r_ecef): the kinematic acceleration
in the rotating frame plus the Coriolis and centrifugal terms is the inertial acceleration, and what an
accelerometer senses is that minus the gravitation.

Implements: the J2 gravitation of Vallado (2013) eq. 8-30 (in ECEF, z the rotation axis), WGS 84 GM and
a (NIMA TR8350.2 Table 3.1), J2 = 1.08262668e-3 (TR8350.2 Table 3.4: -C20 sqrt(5)); Savage (1998) "Strapdown
Inertial Navigation Integration Algorithm Design" eq. 4.3-1 (specific force in the Earth frame).
Neglects: the higher zonal and tesseral terms (deflection of the vertical <= ~30 arcsec = 0.01 deg,
gravity anomalies ~5e-4 m/s^2), tides, the time variation of the Earth's rotation.
"""
from __future__ import annotations

import numpy as np

from gnssatt.gnss.constants import OMEGA_EARTH_RAD_S, WGS84_A_M

GM_WGS84_M3_S2 = 3.986004418e14   # NIMA TR8350.2 Table 3.1 (with the atmosphere)
J2_WGS84 = 1.08262668e-3
OMEGA_ECEF_RAD_S = np.array([0.0, 0.0, OMEGA_EARTH_RAD_S])


def gravitation_j2_ecef_m_s2(r_ecef_m) -> np.ndarray:
    """Gravitational acceleration (..., 3) in m/s^2 at ECEF positions (..., 3) (point mass + J2)."""
    r = np.asarray(r_ecef_m, dtype=np.float64)
    rn = np.linalg.norm(r, axis=-1, keepdims=True)
    z2 = (r[..., 2:3] / rn) ** 2
    k = 1.5 * J2_WGS84 * (WGS84_A_M / rn) ** 2
    fac = np.concatenate([1 - k * (5 * z2 - 1), 1 - k * (5 * z2 - 1), 1 - k * (5 * z2 - 3)], axis=-1)
    return -GM_WGS84_M3_S2 * r / rn ** 3 * fac


def specific_force_ecef_m_s2(r_ecef_m, v_ecef_m_s, a_ecef_m_s2) -> np.ndarray:
    """Specific force (..., 3) m/s^2 in ECEF axes: a + 2 w x v + w x (w x r) - g_J2(r)."""
    r = np.asarray(r_ecef_m, dtype=np.float64)
    w = OMEGA_ECEF_RAD_S
    coriolis = 2.0 * np.cross(w, np.asarray(v_ecef_m_s, dtype=np.float64))
    centrifugal = np.cross(w, np.cross(w, r))
    return np.asarray(a_ecef_m_s2, dtype=np.float64) + coriolis + centrifugal - gravitation_j2_ecef_m_s2(r)
