"""Physical and system constants of the GNSS signal-in-space documents, with units in every name.

Each system defines its own Earth model for its broadcast orbits; using another system's GM or rotation
rate in a broadcast orbit computation gives metre-level errors, so every value names its system.

Sources:
- IS-GPS-200N (2022) sec. 20.3.3.4.3 Table 20-IV and sec. 20.3.3.3.3.1 (GM, Omega_e, F, pi).
- NIMA TR8350.2 (WGS 84) Table 3.1: a, 1/f, GM (3.986004418e14, with the atmosphere; = EGM96).
- Galileo OS SIS ICD issue 2.1 (2023) sec. 5.1.9.3 Table 65 (GM, Omega_e), sec. 5.1.4 (F).
- BeiDou ICD B1I v3.0 (2019) sec. 5.2.4 Table 5-11 (CGCS2000 GM, Omega_e), sec. 5.2.4.10 (F);
  CGCS2000 ellipsoid (a, 1/f).
- IS-QZSS-PNT-005 (2022) sec. 3.1 and 4.1.2: QZSS uses the GPS values of GM, Omega_e, F and pi.
- IERS Conventions (2010) ch. 1 Table 1.1 (c); IAU 2000 resolution B1.9 (TT - TAI).
Carrier frequencies and wavelengths: gnssatt.gnss.signals. Leap seconds: gnssatt.gnss.leap_seconds.
"""
from __future__ import annotations

import math

# --- universal -------------------------------------------------------------------------------------
C_M_S = 299792458.0  # speed of light in vacuum (exact, SI)
TT_MINUS_TAI_S = 32.184  # IAU 1991 / 2000 B1.9
TAI_MINUS_GPS_S = 19.0  # GPS time = TAI - 19 s (IS-GPS-200 sec. 3.3.4)
TT_MINUS_GPS_S = TT_MINUS_TAI_S + TAI_MINUS_GPS_S  # 51.184 s
SECONDS_PER_DAY = 86400.0
JD_GPS_EPOCH = 2444244.5  # Julian date of 1980-01-06T00:00:00 (GPS epoch)
MJD_GPS_EPOCH = 44244.0
ARCSEC_RAD = math.pi / (180.0 * 3600.0)

# --- GPS (IS-GPS-200 Table 20-IV) ------------------------------------------------------------------
GM_EARTH_M3_S2 = 3.986005e14  # WGS 84 value of GM used by the GPS broadcast orbit (IS-GPS-200)
GM_GPS_M3_S2 = GM_EARTH_M3_S2
OMEGA_EARTH_RAD_S = 7.2921151467e-5  # WGS 84 Earth rotation rate (IS-GPS-200 Table 20-IV)
OMEGA_EARTH_GPS_RAD_S = OMEGA_EARTH_RAD_S
F_REL_S_SQRT_M = -4.442807633e-10  # relativistic constant F = -2 sqrt(GM)/c^2 (IS-GPS-200 20.3.3.3.3.1)
F_REL_GPS_S_SQRT_M = F_REL_S_SQRT_M
PI_GPS = 3.1415926535898  # the value of pi IS-GPS-200 prescribes for semicircle conversions

# --- WGS 84 ellipsoid (NIMA TR8350.2 Table 3.1) -----------------------------------------------------
WGS84_A_M = 6378137.0
WGS84_INV_F = 298.257223563
WGS84_F = 1.0 / WGS84_INV_F
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)  # first eccentricity squared
WGS84_B_M = WGS84_A_M * (1.0 - WGS84_F)
GM_WGS84_M3_S2 = 3.986004418e14  # WGS 84 GM incl. the atmosphere (TR8350.2 Table 3.1) = EGM96: orbits, not
                                 # broadcast ephemerides (those use GM_GPS_M3_S2)

# --- Galileo (OS SIS ICD Table 65, sec. 5.1.4) ------------------------------------------------------
GM_GALILEO_M3_S2 = 3.986004418e14
OMEGA_EARTH_GALILEO_RAD_S = 7.2921151467e-5
F_REL_GALILEO_S_SQRT_M = -4.442807309e-10

# --- BeiDou (BDS ICD B1I v3.0 Table 5-11; CGCS2000) ------------------------------------------------
GM_BEIDOU_M3_S2 = 3.986004418e14
OMEGA_EARTH_BEIDOU_RAD_S = 7.2921150e-5
F_REL_BEIDOU_S_SQRT_M = -4.442807309e-10
CGCS2000_A_M = 6378137.0
CGCS2000_INV_F = 298.257222101
BDT_MINUS_GPST_S = -14.0  # BDT = GPST - 14 s (BDT epoch 2006-01-01T00:00:00 UTC, when GPS-UTC was 14 s)
BDT_WEEK_OFFSET = 1356  # BDT week 0 starts at GPS week 1356 (+14 s)

# --- QZSS (IS-QZSS-PNT: the GPS values) -------------------------------------------------------------
GM_QZSS_M3_S2 = GM_GPS_M3_S2
OMEGA_EARTH_QZSS_RAD_S = OMEGA_EARTH_GPS_RAD_S
F_REL_QZSS_S_SQRT_M = F_REL_GPS_S_SQRT_M

# Galileo System Time is steered to GPS time (offset GGTO, a few ns, broadcast); its week count starts
# at GPS week 1024 (1999-08-22). RINEX 3 navigation files already write GAL weeks aligned with GPS weeks.
GST_MINUS_GPST_S = 0.0
GST_WEEK_OFFSET = 1024

# Carrier frequencies, wavelengths and RINEX codes: gnssatt.gnss.signals (the one signal table).


def orbit_constants(system: str) -> tuple[float, float, float]:
    """(GM m^3/s^2, Omega_e rad/s, F s/sqrt(m)) of a system's broadcast Keplerian orbit ('G','E','C','J').

    Implements: IS-GPS-200 Table 20-IV; Galileo OS SIS ICD Table 65; BDS ICD B1I Table 5-11; IS-QZSS-PNT.
    """
    try:
        return _ORBIT_CONSTANTS[system]
    except KeyError:
        raise ValueError(f"no Keplerian broadcast orbit constants for system {system!r}") from None


_ORBIT_CONSTANTS = {
    "G": (GM_GPS_M3_S2, OMEGA_EARTH_GPS_RAD_S, F_REL_GPS_S_SQRT_M),
    "J": (GM_QZSS_M3_S2, OMEGA_EARTH_QZSS_RAD_S, F_REL_QZSS_S_SQRT_M),
    "E": (GM_GALILEO_M3_S2, OMEGA_EARTH_GALILEO_RAD_S, F_REL_GALILEO_S_SQRT_M),
    "C": (GM_BEIDOU_M3_S2, OMEGA_EARTH_BEIDOU_RAD_S, F_REL_BEIDOU_S_SQRT_M),
}
