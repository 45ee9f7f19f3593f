"""The GNSS signal table: carrier frequencies (Hz), wavelengths (m) and RINEX 3 observation codes, per system.

This is the project's one table of signals; every module (positioning, alignment, attitude, calibration, ttff,
simulator, satellite antennas, benchmarks) reads its frequencies and codes here. Frequencies are the exact
values the interface documents define (multiples of f0 = 10.23 MHz for GPS/QZSS/Galileo/BeiDou); wavelengths
are `C_M_S / f` with c = 299 792 458 m/s exactly.

Systems: G GPS, E Galileo, C BeiDou, J QZSS, R GLONASS, S SBAS, I NavIC (RINEX 3 letters).

Sources:
- IS-GPS-200N (2022) sec. 3.3.1.1: L1 = 154 f0 = 1575.42 MHz, L2 = 120 f0 = 1227.60 MHz; IS-GPS-705J sec.
  3.3.1.1: L5 = 115 f0 = 1176.45 MHz.
- Galileo OS SIS ICD issue 2.1 (2023) sec. 2.3 Table 2 (E1 1575.42, E5a 1176.45, E5b 1207.14, E5 AltBOC
  1191.795 MHz); Galileo HAS SIS ICD 1.0 (E6 1278.75 MHz).
- BDS-SIS-ICD-B1I 3.0 (2019) sec. 4.2 (B1I 1561.098 MHz), BDS-SIS-ICD-B3I 1.0 sec. 4.2 (B3I 1268.52 MHz),
  BDS-SIS-ICD-B1C 1.0 (B1C 1575.42 MHz), BDS-SIS-ICD-B2a 1.0 (B2a 1176.45 MHz), BDS-SIS-ICD 2.1 (B2I 1207.14 MHz,
  as B2b).
- IS-QZSS-PNT-005 (2022) sec. 3.1 (L1, L2, L5 as GPS); IS-QZSS-L6-005 (L6 1278.75 MHz).
- GLONASS ICD edition 5.1 (2008) sec. 3.3.1.4 (FDMA G1/G2: 1602 + k 0.5625, 1246 + k 0.4375 MHz); GLONASS CDMA
  ICDs 2016 (L1OC 1600.995, L2OC 1248.06, L3OC 1202.025 MHz).
- RTCA DO-229 (SBAS L1, L5); NavIC SPS ICD 1.1 (L5 1176.45 MHz, S 2492.028 MHz).
- RINEX 3.04 / 3.05 (IGS/RTCM-SC104) sec. 5.1 Table 4 and Appendix A2-A9: band numbers per system and the
  attribute letters of the observation codes (BeiDou B1I is band "2", B2I band "7", B3I band "6").
"""
from __future__ import annotations

from gnssatt.gnss.constants import C_M_S

__all__ = [
    "FREQ_BY_SYSTEM_BAND_HZ", "SIGNALS", "SIGNAL_ALIASES", "SYSTEM_SIGNALS", "antex_frequency_hz",
    "glonass_frequency_hz", "glonass_wavelength_m", "is_fdma", "wavelength_m",
]

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
FREQ_BDS_B2_HZ = 1191.795e6  # B2 (B2a + B2b) AltBOC centre
FREQ_BDS_B3I_HZ = 1268.52e6
FREQ_QZS_L1_HZ = 1575.42e6
FREQ_QZS_L2_HZ = 1227.60e6
FREQ_QZS_L5_HZ = 1176.45e6
FREQ_QZS_L6_HZ = 1278.75e6
FREQ_GLO_L1OC_HZ = 1600.995e6  # GLONASS CDMA (band 4)
FREQ_GLO_L2OC_HZ = 1248.06e6  # band 6
FREQ_GLO_L3OC_HZ = 1202.025e6  # band 3
FREQ_IRN_S_HZ = 2492.028e6  # NavIC S band (band 9)
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

#: Frequency of each RINEX 3 band number per system (RINEX 3.05 sec. 5.1 Table 4), for observation codes
#: like "L1C": FREQ_BY_SYSTEM_BAND_HZ[("G", "1")]. GLONASS FDMA bands 1 and 2 need the channel number k
#: (`glonass_frequency_hz`).
FREQ_BY_SYSTEM_BAND_HZ: dict[tuple[str, str], float] = {
    ("G", "1"): FREQ_GPS_L1_HZ, ("G", "2"): FREQ_GPS_L2_HZ, ("G", "5"): FREQ_GPS_L5_HZ,
    ("E", "1"): FREQ_GAL_E1_HZ, ("E", "5"): FREQ_GAL_E5A_HZ, ("E", "7"): FREQ_GAL_E5B_HZ,
    ("E", "8"): FREQ_GAL_E5_HZ, ("E", "6"): FREQ_GAL_E6_HZ,
    ("C", "2"): FREQ_BDS_B1I_HZ, ("C", "1"): FREQ_BDS_B1C_HZ, ("C", "5"): FREQ_BDS_B2A_HZ,
    ("C", "7"): FREQ_BDS_B2I_HZ, ("C", "8"): FREQ_BDS_B2_HZ, ("C", "6"): FREQ_BDS_B3I_HZ,
    ("J", "1"): FREQ_QZS_L1_HZ, ("J", "2"): FREQ_QZS_L2_HZ, ("J", "5"): FREQ_QZS_L5_HZ,
    ("J", "6"): FREQ_QZS_L6_HZ,
    ("R", "4"): FREQ_GLO_L1OC_HZ, ("R", "6"): FREQ_GLO_L2OC_HZ, ("R", "3"): FREQ_GLO_L3OC_HZ,  # GLONASS CDMA
    ("I", "5"): FREQ_GPS_L5_HZ, ("I", "9"): FREQ_IRN_S_HZ,  # NavIC L5, S
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


def glonass_wavelength_m(band: int, k) -> float:
    """Carrier wavelength (m) c / f of GLONASS FDMA band 1 or 2 for channel k (GLONASS ICD 5.1 sec. 3.3.1.4)."""
    return C_M_S / glonass_frequency_hz(band, k)


def antex_frequency_hz(code: str) -> float | None:
    """Frequency (Hz) of an ANTEX 1.4 frequency code ('G01', 'E07', 'C02', ...), None for an unknown code.

    ANTEX writes system letter + '0' + RINEX 3 band number; GLONASS 'R01'/'R02' are the FDMA G1/G2 bands at
    channel 0 (ANTEX 1.4 sec. 'FREQUENCY': one pattern per band for all channels).
    """
    if len(code) != 3 or code[1] != "0":
        return None
    if code[0] == "R" and code[2] in "12":
        return glonass_frequency_hz(int(code[2]), 0)
    return FREQ_BY_SYSTEM_BAND_HZ.get((code[0], code[2]))


# --- named signals of the attitude filter, calibration and TTFF -----------------------------------------
#: Signals per name: system letter, (code, phase, C/N0) RINEX 3 codes in order of preference, carrier frequency
#: (Hz), wavelength (m) and the default C/N0 mask (dB-Hz, seed 000 Table 2: L1 35, L2 30; the other signals as
#: the GPS signal of their role). Names are system-qualified ("E:E5b"); "L1" and "L2" are the GPS signals under
#: their historical names (every GPS-only config, product and test keeps them). GLONASS FDMA signals ("R:G1",
#: "R:G2") carry `fdma_band`: their frequency and wavelength are those of channel 0, each satellite's own are
#: `glonass_frequency_hz(band, k)` with its channel number k (the observation file's GLONASS SLOT / FRQ #, else
#: the navigation records).
_GPS_L1 = {"system": "G", "code": ["C1C"], "phase": ["L1C"], "snr": ["S1C"], "freq_hz": FREQ_GPS_L1_HZ,
           "wavelength_m": WAVELENGTH_GPS_L1_M, "cn0_mask_dbhz": 35.0}
_GPS_L2 = {"system": "G", "code": ["C2W", "C2L", "C2X", "C2S"], "phase": ["L2W", "L2L", "L2X", "L2S"],
           "snr": ["S2W", "S2L", "S2X", "S2S"], "freq_hz": FREQ_GPS_L2_HZ, "wavelength_m": WAVELENGTH_GPS_L2_M,
           "cn0_mask_dbhz": 30.0}


def _spec(system: str, bands: str, attrs: str, cn0: float) -> dict:
    """A SIGNALS entry: every (band, attribute) pair in preference order, e.g. bands '7', attrs 'QXI'; the
    frequency is that of the band (FREQ_BY_SYSTEM_BAND_HZ)."""
    pairs = [b + a for b in bands for a in attrs]
    freq_hz = FREQ_BY_SYSTEM_BAND_HZ[(system, bands[0])]
    return {"system": system, "code": ["C" + p for p in pairs], "phase": ["L" + p for p in pairs],
            "snr": ["S" + p for p in pairs], "freq_hz": freq_hz, "wavelength_m": C_M_S / freq_hz,
            "cn0_mask_dbhz": cn0}


SIGNALS: dict[str, dict] = {
    "L1": _GPS_L1,
    "L2": _GPS_L2,
    "G:L1": _GPS_L1,
    "G:L2": _GPS_L2,
    "G:L5": _spec("G", "5", "QXI", 30.0),
    "E:E1": _spec("E", "1", "CXB", 35.0),
    "E:E5a": _spec("E", "5", "QXI", 30.0),
    "E:E5b": _spec("E", "7", "QXI", 30.0),
    "C:B1I": _spec("C", "2", "IXQ", 35.0),
    "C:B2I": _spec("C", "7", "IXQ", 30.0),
    "C:B3I": _spec("C", "6", "IXQ", 30.0),
    "J:L1": _spec("J", "1", "CXZ", 35.0),
    "J:L2": _spec("J", "2", "LXS", 30.0),
    "J:L5": _spec("J", "5", "QXI", 30.0),
    "R:G1": {"system": "R", "code": ["C1C", "C1P"], "phase": ["L1C", "L1P"], "snr": ["S1C", "S1P"],
             "freq_hz": glonass_frequency_hz(1, 0), "wavelength_m": glonass_wavelength_m(1, 0), "cn0_mask_dbhz": 35.0,
             "fdma_band": 1},
    "R:G2": {"system": "R", "code": ["C2P", "C2C"], "phase": ["L2P", "L2C"], "snr": ["S2P", "S2C"],
             "freq_hz": glonass_frequency_hz(2, 0), "wavelength_m": glonass_wavelength_m(2, 0), "cn0_mask_dbhz": 30.0,
             "fdma_band": 2},
}
#: historical names -> system-qualified names
SIGNAL_ALIASES = {"L1": "G:L1", "L2": "G:L2"}
#: the `systems` preset: per system its first two frequency slots as RTKLIB 2.4.3 numbers them ("L1+L2":
#: GPS/QZSS L1 + L2, Galileo E1 + E5b, BeiDou B1I + B2I, GLONASS G1 + G2 (FDMA, per-satellite wavelengths).
SYSTEM_SIGNALS = {"G": ("G:L1", "G:L2"), "E": ("E:E1", "E:E5b"), "C": ("C:B1I", "C:B2I"), "J": ("J:L1", "J:L2"),
                  "R": ("R:G1", "R:G2")}


def is_fdma(name: str) -> bool:
    """True for a GLONASS FDMA signal of SIGNALS (one wavelength per satellite)."""
    return "fdma_band" in SIGNALS[name]


def wavelength_m(name: str) -> float:
    """Carrier wavelength (m) of a named signal of SIGNALS (c / f)."""
    return SIGNALS[name]["wavelength_m"]
