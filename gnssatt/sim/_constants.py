"""Physical constants of the simulator: the project's definitions, re-read from the one table of each.

The simulator keeps its own implementations of frames, rotations and orbits (an independent truth model),
but a constant that is a definition (c, GM, Omega_E, F, the WGS 84 ellipsoid, the carrier frequencies, the
leap seconds) is the same number everywhere, so it is taken from gnssatt.gnss.constants (IS-GPS-200 Table
20-IV, NIMA TR8350.2), gnssatt.gnss.signals (IS-GPS-200 sec. 3.3.1.1) and gnssatt.gnss.leap_seconds (IERS
Bulletin C). Only the simulator's own model constants are defined here (EGM96 J2, the ionosphere's 40.3).
"""
from __future__ import annotations

from gnssatt.gnss import leap_seconds as _leap
from gnssatt.gnss.constants import (  # noqa: F401  (names the simulator's modules import from here)
    C_M_S, F_REL_S_SQRT_M, GM_GPS_M3_S2, GM_WGS84_M3_S2 as GM_EARTH_M3_S2, OMEGA_EARTH_RAD_S as OMEGA_E_RAD_S,
    WGS84_A_M as R_EARTH_M, WGS84_F,
)
from gnssatt.gnss.signals import FREQ_GPS_L1_HZ as F_L1_HZ, FREQ_GPS_L2_HZ as F_L2_HZ
from gnssatt.gnss.time import GpsTime

J2 = 1.08262668e-3                  # EGM96 unnormalised J2 (platform orbit model)
GAMMA_L2 = (F_L1_HZ / F_L2_HZ) ** 2  # IS-GPS-200 sec. 20.3.3.3.3.2
IONO_K_M3_S2 = 40.3                 # first-order ionospheric constant: delay_m = 40.3 TEC / f^2

#: Expiry (ISO date) of the leap-second table the simulated files were written with.
LEAP_TABLE_EXPIRES = _leap.EXPIRES.isoformat()


def gps_minus_utc_s(gps_seconds: float) -> int:
    """GPS - UTC in whole seconds at a GPS time given as seconds since 1980-01-06 (gnssatt.gnss.leap_seconds)."""
    return int(_leap.gps_minus_utc_s(GpsTime(gps_seconds)))


def leap_expiry_warning(gps_seconds: float) -> str | None:
    """The leap-second table's expiry warning for a simulated time (None while the table is valid)."""
    return _leap.expiry_warning(GpsTime(gps_seconds))
