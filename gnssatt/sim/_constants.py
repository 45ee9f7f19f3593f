"""Physical constants used by the simulator (private until gnssatt/gnss/constants.py lands).

Implements: IS-GPS-200 sec. 20.3.3.4.3 (mu, Omega_E_dot, F), sec. 3.3.1.1 (L1/L2 carriers);
WGS 84 (NIMA TR8350.2) ellipsoid; EGM96 J2.
"""
from __future__ import annotations

C_M_S = 299_792_458.0
GM_GPS_M3_S2 = 3.986005e14          # IS-GPS-200 value, for broadcast ephemerides
GM_EARTH_M3_S2 = 3.986004418e14     # WGS 84 / EGM96, for the platform orbit
OMEGA_E_RAD_S = 7.2921151467e-5     # IS-GPS-200 / WGS 84 Earth rotation rate
F_REL_S_SQRT_M = -4.442807633e-10   # IS-GPS-200 relativistic clock constant F = -2 sqrt(mu)/c^2
J2 = 1.08262668e-3                  # EGM96 unnormalised J2
R_EARTH_M = 6_378_137.0             # WGS 84 semi-major axis
WGS84_F = 1.0 / 298.257223563
F_L1_HZ = 1575.42e6
F_L2_HZ = 1227.60e6
LAMBDA_L1_M = C_M_S / F_L1_HZ
LAMBDA_L2_M = C_M_S / F_L2_HZ
GAMMA_L2 = (F_L1_HZ / F_L2_HZ) ** 2  # IS-GPS-200 sec. 20.3.3.3.3.2
IONO_K_M3_S2 = 40.3                 # first-order ionospheric constant: delay_m = 40.3 TEC / f^2
SIGNALS = {"L1": (F_L1_HZ, "1C"), "L2": (F_L2_HZ, "2W")}  # frequency, RINEX 3 signal (C/A, P(Y) Z-tracking)

# GPS - UTC (leap seconds), as (first GPS second of validity since 1980-01-06, offset_s).
# Implements: IERS Bulletin C; table expires with Bulletin C 70 (no leap second before 2026-06-30).
LEAP_TABLE_EXPIRES = "2026-06-30"
_LEAPS = [  # (year, month, day) from which GPS-UTC = value
    ((1999, 1, 1), 13), ((2006, 1, 1), 14), ((2009, 1, 1), 15), ((2012, 7, 1), 16),
    ((2015, 7, 1), 17), ((2017, 1, 1), 18),
]


def gps_minus_utc_s(gps_seconds: float) -> int:
    """GPS - UTC in whole seconds at a GPS time given as seconds since 1980-01-06 (table from 1999)."""
    from gnssatt.gnss.time import GpsTime

    value = 13
    for (y, m, d), leap in _LEAPS:
        # UTC midnight of (y, m, d) is GPS midnight + the new offset
        if gps_seconds >= float(GpsTime.from_calendar(y, m, d).s) + leap:
            value = leap
    return value
