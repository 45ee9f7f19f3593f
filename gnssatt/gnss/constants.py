"""Physical and system constants of the GNSS signal-in-space documents, with units in every name.

Each system defines its own Earth model for its broadcast orbits; using another system's GM or rotation
rate in a broadcast orbit computation gives metre-level errors, so every value names its system.

Sources:
- IS-GPS-200N (2022) sec. 20.3.3.4.3 Table 20-IV and sec. 20.3.3.3.3.1 (GM, Omega_e, F, pi);
  sec. 3.3.1.1 (L1/L2 carrier frequencies); IS-GPS-705 (L5).
- NIMA TR8350.2 (WGS 84) Table 3.1: a, 1/f.
- Galileo OS SIS ICD issue 2.1 (2023) sec. 5.1.1 Table 1 (carriers), sec. 5.1.9.3 Table 65 (GM, Omega_e),
  sec. 5.1.4 (F).
- BeiDou ICD B1I v3.0 (2019) sec. 5.2.4 Table 5-11 (CGCS2000 GM, Omega_e), sec. 5.2.4.10 (F),
  BDS ICDs B1C/B2a/B3I (carriers); CGCS2000 ellipsoid (a, 1/f).
- IS-QZSS-PNT-005 (2022) sec. 3.1 and 4.1.2: QZSS uses the GPS values of GM, Omega_e, F and pi.
- IERS Conventions (2010) ch. 1 Table 1.1 (c); IAU 2000 resolution B1.9 (TT - TAI).
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

# --- carrier frequencies (Hz) and wavelengths (m) ---------------------------------------------------
FREQ_GPS_L1_HZ = 1575.42e6
FREQ_GPS_L2_HZ = 1227.60e6
FREQ_GPS_L5_HZ = 1176.45e6
FREQ_GAL_E1_HZ = 1575.42e6
FREQ_GAL_E5A_HZ = 1176.45e6
FREQ_GAL_E5B_HZ = 1207.14e6
FREQ_GAL_E5_HZ = 1191.795e6  # E5 AltBOC centre
FREQ_GAL_E6_HZ = 1278.75e6
FREQ_BDS_B1I_HZ = 1561.098e6
FREQ_BDS_B1C_HZ = 1575.42e6
FREQ_BDS_B2A_HZ = 1176.45e6
FREQ_BDS_B2I_HZ = 1207.14e6  # also B2b
FREQ_BDS_B3I_HZ = 1268.52e6
FREQ_QZS_L1_HZ = 1575.42e6
FREQ_QZS_L2_HZ = 1227.60e6
FREQ_QZS_L5_HZ = 1176.45e6
FREQ_QZS_L6_HZ = 1278.75e6
# GLONASS FDMA: f = base + k * step, k = -7..+6 (GLONASS ICD 5.1 sec. 3.3.1.4)
FREQ_GLO_G1_BASE_HZ = 1602.0e6
FREQ_GLO_G1_STEP_HZ = 0.5625e6
FREQ_GLO_G2_BASE_HZ = 1246.0e6
FREQ_GLO_G2_STEP_HZ = 0.4375e6

WAVELENGTH_GPS_L1_M = C_M_S / FREQ_GPS_L1_HZ  # 0.190293672798 m
WAVELENGTH_GPS_L2_M = C_M_S / FREQ_GPS_L2_HZ  # 0.244210213425 m
WAVELENGTH_GPS_L5_M = C_M_S / FREQ_GPS_L5_HZ  # 0.254828048791 m
WAVELENGTH_GAL_E1_M = C_M_S / FREQ_GAL_E1_HZ
WAVELENGTH_GAL_E5A_M = C_M_S / FREQ_GAL_E5A_HZ
WAVELENGTH_GAL_E5B_M = C_M_S / FREQ_GAL_E5B_HZ
WAVELENGTH_GAL_E5_M = C_M_S / FREQ_GAL_E5_HZ
WAVELENGTH_GAL_E6_M = C_M_S / FREQ_GAL_E6_HZ
WAVELENGTH_BDS_B1I_M = C_M_S / FREQ_BDS_B1I_HZ
WAVELENGTH_BDS_B1C_M = C_M_S / FREQ_BDS_B1C_HZ
WAVELENGTH_BDS_B2A_M = C_M_S / FREQ_BDS_B2A_HZ
WAVELENGTH_BDS_B2I_M = C_M_S / FREQ_BDS_B2I_HZ
WAVELENGTH_BDS_B3I_M = C_M_S / FREQ_BDS_B3I_HZ
WAVELENGTH_QZS_L1_M = C_M_S / FREQ_QZS_L1_HZ
WAVELENGTH_QZS_L2_M = C_M_S / FREQ_QZS_L2_HZ
WAVELENGTH_QZS_L5_M = C_M_S / FREQ_QZS_L5_HZ
WAVELENGTH_QZS_L6_M = C_M_S / FREQ_QZS_L6_HZ

# Frequency of each RINEX 3 band number per system (RINEX 3.05 sec. 5.1 Table 4), for observation codes
# like "L1C": FREQ_BY_SYSTEM_BAND_HZ[("G", "1")]. GLONASS FDMA bands need the channel number k.
FREQ_BY_SYSTEM_BAND_HZ: dict[tuple[str, str], float] = {
    ("G", "1"): FREQ_GPS_L1_HZ, ("G", "2"): FREQ_GPS_L2_HZ, ("G", "5"): FREQ_GPS_L5_HZ,
    ("E", "1"): FREQ_GAL_E1_HZ, ("E", "5"): FREQ_GAL_E5A_HZ, ("E", "7"): FREQ_GAL_E5B_HZ,
    ("E", "8"): FREQ_GAL_E5_HZ, ("E", "6"): FREQ_GAL_E6_HZ,
    ("C", "2"): FREQ_BDS_B1I_HZ, ("C", "1"): FREQ_BDS_B1C_HZ, ("C", "5"): FREQ_BDS_B2A_HZ,
    ("C", "7"): FREQ_BDS_B2I_HZ, ("C", "8"): 1191.795e6, ("C", "6"): FREQ_BDS_B3I_HZ,
    ("J", "1"): FREQ_QZS_L1_HZ, ("J", "2"): FREQ_QZS_L2_HZ, ("J", "5"): FREQ_QZS_L5_HZ,
    ("J", "6"): FREQ_QZS_L6_HZ,
    ("R", "4"): 1600.995e6, ("R", "6"): 1248.06e6, ("R", "3"): 1202.025e6,  # GLONASS CDMA
    ("I", "5"): FREQ_GPS_L5_HZ, ("I", "9"): 2492.028e6,  # NavIC L5, S
    ("S", "1"): FREQ_GPS_L1_HZ, ("S", "5"): FREQ_GPS_L5_HZ,  # SBAS
}


def glonass_frequency_hz(band: int, k) -> float:
    """Carrier frequency (Hz) of GLONASS FDMA band 1 (G1) or 2 (G2) for frequency channel number k (-7..6).

    Implements: GLONASS ICD edition 5.1 (2008) sec. 3.3.1.4, eq. f_K1 = 1602 + K*0.5625 MHz,
    f_K2 = 1246 + K*0.4375 MHz.
    """
    if band == 1:
        return FREQ_GLO_G1_BASE_HZ + k * FREQ_GLO_G1_STEP_HZ
    if band == 2:
        return FREQ_GLO_G2_BASE_HZ + k * FREQ_GLO_G2_STEP_HZ
    raise ValueError(f"GLONASS FDMA band must be 1 or 2, got {band!r}")


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
