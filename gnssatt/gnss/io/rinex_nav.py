"""RINEX 2 / 3 / 4 navigation files: broadcast Keplerian (GPS, QZSS, Galileo, BeiDou) and GLONASS records.

`read_rinex_nav(source)` returns a `NavData`: per system letter a `KeplerEphemeris` (a dataclass of equal-length
numpy arrays, one element per record, file order kept) and a `GlonassEphemeris`; header ionosphere (Klobuchar
alpha/beta, Galileo NeQuick ai), time-system corrections and leap seconds. `select_ephemeris` picks the record to
use for a satellite at a time.

Implements:
- RINEX 2.10/2.11 (Gurtner & Estey, IGS/RTCM), sec. 5 and Tables A3/A4 (GPS nav), A10/A11 (GLONASS nav); the
  2.12 drafts' Galileo ('E', 'L') and QZSS ('J', 'Q', or 'N' with 'J' in column 41) files with the system's
  RINEX 3 record, in the PRN (I2, 3X orbit lines) or letter-id (A1,I2, 4X) layout (warning rinex2-extension).
- Quirks read with a warning and errors: docs/reader_policy.md.
- RINEX 3.02-3.05 (IGS/RTCM-SC104), sec. 5.4 and Tables A6-A17 (GPS, Galileo, GLONASS, QZSS, BDS records).
- RINEX 3.03-3.05 NavIC (Table A18, the GPS layout with IRN week; `kepler['I']`, usable by the ephemeris layer
  with the GPS/WGS-84 constants the IRNSS ICD uses) and SBAS (Table A16; `NavData.sbas`, a `SbasEphemeris`).
- RINEX 4.00-4.02, sec. 5 and Tables A31ff.: records dispatched on the `> EPH sss TYPE` line; G/J LNAV,
  E INAV/FNAV, C D1/D2, R FDMA and I LNAV become ephemerides, S SBAS state vectors; every other record (CNAV,
  CNV1-3, L1NV, L1OC, STO, EOP, ION, ...) is kept as read in `NavData.messages` (gnssatt.gnss.io.nav_messages).
  An unknown '>' record kind is an error.
- Fixed columns (D19.12 fields at columns 4/5 + 19k), so fields that run into each other ("1.0D-05-2.0D-06")
  are read as the format defines them; `D` exponents accepted. Extra spare lines after the last defined line of
  a record (some converters write them) are checked to be numeric and ignored (counted warning).

Time scales (kept as the file gives them, see each dataclass):
- GPS, QZSS, Galileo: `toc` is a `GpsTime` (QZSST and GST are steered to GPS time; the GGTO offset is ns-level).
  The week of GPS/QZSS/Galileo records is the continuous GPS-aligned week (RINEX 3 sec. 8.1.3); a week written
  modulo 1024 (or as GST week) is corrected from the epoch and reported (``week-rollover-fixed``).
- BeiDou: `toc` holds the BDT calendar epoch *as written* (BDT = GPST - 14 s), `week` is the BDT week and
  `toe_sow` seconds of the BDT week (BDT week 0 starts at GPS week 1356). Use `KeplerEphemeris.toe_gpst()` /
  `toc_gpst()` for GPS-time values.
- GLONASS: RINEX gives the epoch in UTC (RINEX-QUIRKS "GLONASS ephemeris times are UTC"); it is converted to GPS
  time with the leap seconds (the project's table gnssatt.gnss.leap_seconds, the header `LEAP SECONDS` after the
  table's expiry `LEAP_TABLE_EXPIRES`; a header that disagrees with the table is reported).

Neglects: evaluating the CNAV-type RINEX 4 ephemerides.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field, fields
from functools import partial

import numpy as np

from gnssatt.gnss.constants import BDT_MINUS_GPST_S, BDT_WEEK_OFFSET
from gnssatt.gnss.io.compression import read_text_bytes
from gnssatt.gnss.io.errors import ParseError, ParseWarning
from gnssatt.gnss.io.nav_messages import NavMessage, SbasEphemeris, build_sbas, int_column, sbas_records_in_metres
from gnssatt.gnss.leap_seconds import EXPIRES as LEAP_TABLE_EXPIRES, gps_minus_utc_at_utc_s
from gnssatt.gnss.time import SECONDS_PER_WEEK, GpsTime

__all__ = [
    "KeplerEphemeris", "GlonassEphemeris", "NavData", "read_rinex_nav", "summarize_rinex_nav",
    "select_ephemeris", "gps_minus_utc_s", "LEAP_TABLE_EXPIRES", "BDT_WEEK0_GPS_WEEK",
    "BDT_MINUS_GPST_S", "read_source_text",
]

# --- constants -------------------------------------------------------------------------------------

#: BDT week 0 begins 2006-01-01T00:00:00 BDT = GPS week 1356 + 14 s (BDS-SIS-ICD-2.0 sec. 4.2); BDT - GPST in
#: seconds (BDT started 14 s behind GPST and has no leap seconds since): gnssatt.gnss.constants.
BDT_WEEK0_GPS_WEEK = BDT_WEEK_OFFSET

# Default half validity of a broadcast ephemeris around its toe, per system, in seconds. GPS/QZSS: half the
# nominal 4 h curve-fit interval (IS-GPS-200 sec. 20.3.4.4; IS-QZSS-PNT sec. 4.1.2); Galileo 4 h and BeiDou
# 6 h and GLONASS 30 min as RTKLIB's MAXDTOE_* (src/rtklib.h) - the upload rates of those systems.
MAX_AGE_S = {"G": 7200.0, "J": 7200.0, "E": 14400.0, "C": 21600.0, "R": 1800.0, "I": 7200.0, "S": 600.0}

# One D19.12 field as RINEX writes it: sign, mantissa, exponent with 2-3 digits (a field cut short by a column
# shift ends in a one-digit exponent and is refused rather than misread).
_NUM_RE = re.compile(r" *[+-]?(?:[0-9]+\.[0-9]*|\.[0-9]+|[0-9]+)(?:[EeDd][+-]?[0-9]{2,3})? *")
_INT_RE = re.compile(r" *[0-9]+ *")
_FIELD_W = 19


# --- source --------------------------------------------------------------------------------------------

def read_source_text(source, name: str | None = None) -> tuple[str, str]:
    """(decoded text, display name) of a path or bytes, decompressed by magic bytes.

    Uses `gnssatt.gnss.io.compression.read_text_bytes` (gzip, .Z, zip, bzip2, Hatanaka; ParseError on damage).
    Text is decoded as latin-1 so any byte sequence decodes and the parser, not the decoder, reports what is
    wrong (with its line number).
    """
    display = name if name is not None else (
        "<bytes>" if isinstance(source, (bytes, bytearray, memoryview)) else os.path.basename(str(source)))
    if isinstance(source, (bytearray, memoryview)):
        source = bytes(source)
    data = read_text_bytes(source, name=display)
    return bytes(data).decode("latin-1"), display


def _split_lines(text: str) -> list[str]:
    """Lines of text split on LF only (CR stripped), so line numbers match what an editor shows."""
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    return [ln[:-1] if ln.endswith("\r") else ln for ln in lines]


# --- leap seconds ----------------------------------------------------------------------------------------

#: GPS-UTC (int64 s) at UTC instants given as whole seconds of the UTC calendar since 1980-01-06: the one
#: leap-second table's `gps_minus_utc_at_utc_s` (gnssatt.gnss.leap_seconds, IERS Bulletin C, with `EXPIRES`).
gps_minus_utc_s = gps_minus_utc_at_utc_s


# --- dataclasses -----------------------------------------------------------------------------------------

@dataclass
class KeplerEphemeris:
    """Broadcast Keplerian ephemerides of one system: equal-length arrays, one element per record (file order).

    Field names carry units (`_s`, `_rad`, `_rad_s`, `_m`, `_h`); angles are radians (RINEX writes radians);
    `e` is unitless. Integer-valued words (iode, week, health, iodc, data_sources) are int64; a blank optional
    word is NaN in float fields, -1 in integer ones.

    - `iode`: GPS/QZSS IODE, Galileo IODnav, BeiDou AODE. `iodc`: GPS/QZSS IODC, BeiDou AODC, Galileo -1.
    - `week`: GPS/QZSS/Galileo: continuous GPS week of toe; BeiDou: BDT week (see module docstring).
    - `health`: GPS/QZSS SV health word, Galileo SV health bit field, BeiDou SatH1; 0 = healthy.
    - `tgd_s`: GPS/QZSS TGD; BeiDou TGD1 (B1/B3); Galileo the BGD matching the clock (E5b/E1 when data_sources
      bit 9 is set, else E5a/E1). `tgd2_s`: BeiDou TGD2 (B2/B3), NaN elsewhere.
    - `accuracy_m`: GPS/QZSS URA, Galileo SISA, BeiDou URA, in metres (RINEX 3 writes metres).
    - `transmission_sow`: transmission time of message, seconds of the record's week (may be negative).
    - `fit_interval_h`: GPS curve-fit interval in hours (a written flag 0 becomes 4 h; 1, the IS-GPS-200 "more
      than 4 h" flag, becomes 6 h); QZSS flag 0 -> 2 h, 1 -> 4 h (IS-QZSS-PNT Table 4.1.2-4); NaN for E and C.
    - `bgd_e5a_e1_s`, `bgd_e5b_e1_s`, `data_sources`: Galileo only (NaN / -1 elsewhere).
    - `line_no`: 1-based line of the record's epoch line.
    """

    sat: np.ndarray
    toc: GpsTime
    af0_s: np.ndarray
    af1_s_s: np.ndarray
    af2_s_s2: np.ndarray
    iode: np.ndarray
    crs_m: np.ndarray
    delta_n_rad_s: np.ndarray
    m0_rad: np.ndarray
    cuc_rad: np.ndarray
    e: np.ndarray
    cus_rad: np.ndarray
    sqrt_a_sqrt_m: np.ndarray
    toe_sow: np.ndarray
    cic_rad: np.ndarray
    omega0_rad: np.ndarray
    cis_rad: np.ndarray
    i0_rad: np.ndarray
    crc_m: np.ndarray
    omega_rad: np.ndarray
    omega_dot_rad_s: np.ndarray
    idot_rad_s: np.ndarray
    week: np.ndarray
    health: np.ndarray
    tgd_s: np.ndarray
    iodc: np.ndarray
    transmission_sow: np.ndarray
    fit_interval_h: np.ndarray
    accuracy_m: np.ndarray
    line_no: np.ndarray
    bgd_e5a_e1_s: np.ndarray
    bgd_e5b_e1_s: np.ndarray
    data_sources: np.ndarray
    tgd2_s: np.ndarray
    system: str = "G"
    time_system: str = "GPST"

    def __len__(self) -> int:
        return len(self.sat)

    def toe_gpst(self) -> GpsTime:
        """Time of ephemeris as GPS time (BeiDou: BDT week/sow moved to GPST)."""
        if self.system == "C":
            return GpsTime.from_week_sow(self.week + BDT_WEEK0_GPS_WEEK, self.toe_sow) - BDT_MINUS_GPST_S
        return GpsTime.from_week_sow(self.week, self.toe_sow)

    def toc_gpst(self) -> GpsTime:
        """Clock reference epoch as GPS time (BeiDou: BDT epoch + 14 s)."""
        if self.system == "C":
            return self.toc - BDT_MINUS_GPST_S
        return self.toc

    def transmission_gpst(self) -> GpsTime:
        """Transmission time of message as GPS time (week of toe; RINEX allows negative sow for the week before)."""
        week = self.week + (BDT_WEEK0_GPS_WEEK if self.system == "C" else 0)
        sow = np.where(np.isfinite(self.transmission_sow), self.transmission_sow, np.nan)
        # A transmission more than half a week after toe belongs to the previous week (IS-GPS-200 week crossing).
        sow = np.where(sow - self.toe_sow > SECONDS_PER_WEEK / 2, sow - SECONDS_PER_WEEK, sow)
        t = GpsTime.from_week_sow(week, np.nan_to_num(sow, nan=-1e12))
        return t - BDT_MINUS_GPST_S if self.system == "C" else t

    def take(self, index) -> "KeplerEphemeris":
        """The records at `index` (int array or boolean mask), same system."""
        kw = {}
        for f in fields(self):
            v = getattr(self, f.name)
            kw[f.name] = v[index] if isinstance(v, (np.ndarray, GpsTime)) else v
        return KeplerEphemeris(**kw)


@dataclass
class GlonassEphemeris:
    """GLONASS broadcast ephemerides (PZ-90 state vectors), one element per record, file order.

    - `toc`: epoch t_b converted from UTC (as RINEX writes it) to GPS time; `leap_s` the GPS-UTC used.
    - `tau_n_s`, `gamma_n`: GLONASS ICD tau_n and gamma_n (RINEX writes -tau_n); the satellite clock offset
      from GLONASS system time is dt_sv(t) = -tau_n_s + gamma_n * (t - toc) (GLONASS ICD 5.1 sec. 3.3.3).
    - `message_frame_time_s`: t_k as written (RINEX 3: seconds of the UTC week; RINEX 2 may be of day).
    - `position_m`, `velocity_m_s`, `acceleration_m_s2`: (n, 3) PZ-90 (km, km/s, km/s^2 in the file).
    - `health` (Bn, 0 = OK), `frequency_number` (k), `age_days` (E_n).
    - `status_flags`, `delta_tau_l1l2_s`, `urai`, `health_flags`: RINEX 3.05/4 fourth line, NaN/-1 when absent.
    """

    sat: np.ndarray
    toc: GpsTime
    leap_s: np.ndarray
    tau_n_s: np.ndarray
    gamma_n: np.ndarray
    message_frame_time_s: np.ndarray
    position_m: np.ndarray
    velocity_m_s: np.ndarray
    acceleration_m_s2: np.ndarray
    health: np.ndarray
    frequency_number: np.ndarray
    age_days: np.ndarray
    status_flags: np.ndarray
    delta_tau_l1l2_s: np.ndarray
    urai: np.ndarray
    health_flags: np.ndarray
    line_no: np.ndarray

    def __len__(self) -> int:
        return len(self.sat)


@dataclass
class NavData:
    """A navigation file: ephemerides per system plus what the header says.

    - `kepler`: system letter ('G', 'J', 'E', 'C', 'I') -> `KeplerEphemeris` (only systems with records).
    - `glonass`: GLONASS records (possibly empty).
    - `iono`: header ionosphere words by RINEX 3 label ('GPSA', 'GPSB', 'GAL', 'QZSA', 'BDSA', ...; RINEX 2
      ION ALPHA/BETA become 'GPSA'/'GPSB'), each an array of 4 (GAL: 3 used); `klobuchar_alpha`/`_beta` are
      GPSA/GPSB (s, s/semicircle, s/semicircle^2, s/semicircle^3 and s, s/semicircle, ...) or None.
    - `time_corrections`: label ('GPUT', 'GAGP', ...) -> (a0_s, a1_s_s, t_ref_sow, week).
    - `leap_seconds`: header LEAP SECONDS (GPS-UTC now), or None.
    - `skipped`: record kind -> count of records not read (unsupported types), also in `warnings`.
    - `sbas`: SBAS state vectors (`SbasEphemeris`, RINEX 3 and 4). NavIC records are `kepler['I']`.
    - `messages`: the RINEX 4 records kept as read (`NavMessage`: CNAV/CNV1-3/L1NV/... ephemerides, STO, EOP,
      ION), file order.
    """

    name: str
    version: float
    file_type: str
    system: str
    kepler: dict[str, KeplerEphemeris]
    glonass: GlonassEphemeris
    iono: dict[str, np.ndarray]
    klobuchar_alpha: np.ndarray | None
    klobuchar_beta: np.ndarray | None
    time_corrections: dict[str, tuple[float, float, int, int]]
    leap_seconds: int | None
    program: str
    warnings: list[ParseWarning] = field(default_factory=list)
    skipped: dict[str, int] = field(default_factory=dict)
    sbas: SbasEphemeris | None = None
    messages: list[NavMessage] = field(default_factory=list)


# --- low-level field reading ------------------------------------------------------------------------------

class _Ctx:
    """Per-file parse state: display name and warning counters."""

    def __init__(self, name: str):
        self.name = name
        self.warnings: list[ParseWarning] = []
        self.counts: dict[str, list] = {}  # code -> [count, first line, message]

    def warn_counted(self, code: str, message: str, line_no: int | None):
        entry = self.counts.setdefault(code, [0, line_no, message])
        entry[0] += 1

    def error(self, line_no, expected, found="", column=None):
        return ParseError(self.name, line_no, expected, found, column)

    def flush(self):
        for code, (n, line_no, message) in self.counts.items():
            self.warnings.append(ParseWarning(code, f"{message} ({n} time{'s' if n != 1 else ''})", line_no))
        self.counts = {}


def _num(ctx: _Ctx, text: str, line_no: int, col0: int, what: str, line: str) -> float:
    """Float of one fixed-column field ('D' exponents allowed), NaN when blank; ParseError when malformed."""
    if not text.strip():
        return np.nan
    if _NUM_RE.fullmatch(text) is None:
        raise ctx.error(line_no, f"{what}: a D19.12 number in columns {col0 + 1}-{col0 + len(text)}", line,
                        col0 + 1)
    return float(text.replace("D", "E").replace("d", "e"))


def _int(ctx: _Ctx, text: str, line_no: int, col0: int, what: str, line: str) -> int:
    if _INT_RE.fullmatch(text) is None:
        raise ctx.error(line_no, f"{what}: an integer in columns {col0 + 1}-{col0 + len(text)}", line, col0 + 1)
    return int(text)


def _fields_ok(line: str, start: int) -> bool:
    rest = line[start:]
    for k in range(0, len(rest), _FIELD_W):
        t = rest[k:k + _FIELD_W]
        if t.strip() and _NUM_RE.fullmatch(t) is None:
            return False
    return True


def _orbit_line(ctx: _Ctx, line: str, line_no: int, start: int, what: str) -> list[float]:
    """The up-to-4 D19.12 values of a BROADCAST ORBIT line starting at column `start` (0-based)."""
    if line[:start].strip():
        raise ctx.error(line_no, f"{what}: a BROADCAST ORBIT line ({start} blanks, then 4D19.12)", line, 1)
    if not _fields_ok(line[:start + 4 * _FIELD_W], start):
        for alt in (start + 1, start - 1):
            if 0 < alt and not line[:alt].strip() and _fields_ok(line, alt):
                ctx.warn_counted("column-shift", f"BROADCAST ORBIT lines start in column {alt + 1}, "
                                 f"not {start + 1}; read one column shifted", line_no)
                start = alt
                break
    vals = []
    for k in range(4):
        c = start + k * _FIELD_W
        vals.append(_num(ctx, line[c:c + _FIELD_W], line_no, c, what, line))
    tail = line[start + 4 * _FIELD_W:]
    if tail.strip():
        raise ctx.error(line_no, f"{what}: at most 4 D19.12 fields (nothing after column {start + 4 * _FIELD_W})",
                        line, start + 4 * _FIELD_W + 1)
    return vals


# --- header ---------------------------------------------------------------------------------------------

# RINEX 2 navigation file types: the 2.11 standard's N/G/H, and those of the 2.12 drafts and writers
# (teqc 'E', RTKLIB 'L' for Galileo; 'J'/'Q' or 'N' with 'J' in column 41 for QZSS, as RTKLIB writes .q files).
_V2_TYPES = {"N": "G", "G": "R", "H": "S", "E": "E", "L": "E", "J": "J", "Q": "J"}


def _v2_system(ctx: _Ctx, first: str, file_type: str, sys_char: str) -> str:
    """System letter of a RINEX 2 navigation file; the non-2.11 types are read with a warning (2.12 drafts)."""
    if file_type not in _V2_TYPES:
        raise ctx.error(1, "a navigation file type 'N' (GPS), 'G' (GLONASS), 'H' (SBAS) or, as RINEX 2.12 drafts "
                        "write them, 'E'/'L' (Galileo) or 'J'/'Q' (QZSS) in column 21", first, 21)
    system = _V2_TYPES[file_type]
    if file_type == "N" and sys_char in ("J", "E", "C"):
        system = sys_char
    if file_type not in ("N", "G", "H") or system != "G" and file_type == "N":
        ctx.warnings.append(ParseWarning("rinex2-extension", f"RINEX {first[0:9].strip()} navigation of system "
                                         f"{system} (file type {file_type!r}, column 41 {sys_char!r}): not in RINEX "
                                         "2.11, read with the RINEX 2 layout and the system's RINEX 3 record", 1))
    return system

_SUPPORTED_VERSIONS = ("2", "3", "4")
# Navigation versions whose layouts are read: 2.00-2.12 (2.12: the drafts' Galileo/QZSS files), 3.00-3.05,
# 4.00-4.02; any other (e.g. '3.33') is refused loudly, not read with a guessed layout (RINEX-QUIRKS).
_NAV_VERSIONS = (2.0, 2.01, 2.1, 2.11, 2.12, 3.0, 3.01, 3.02, 3.03, 3.04, 3.05, 4.0, 4.01, 4.02)


def _parse_header(ctx: _Ctx, lines: list[str]):
    h0 = next((k for k, ln in enumerate(lines) if ln.strip()), 0)   # blank lines before line 1: a quirk
    if not lines or not lines[h0].strip():
        raise ctx.error(1, "a RINEX navigation header ('RINEX VERSION / TYPE' in columns 61-80)", "")
    first = lines[h0]
    if first[60:80].strip() != "RINEX VERSION / TYPE":
        raise ctx.error(h0 + 1, "'RINEX VERSION / TYPE' in columns 61-80 of the first line", first, 61)
    if h0:
        ctx.warnings.append(ParseWarning("leading-blank-lines", f"{h0} blank line(s) before the first header line "
                                         "were skipped", h0 + 1))
    try:
        version = float(first[0:9])
    except ValueError:
        raise ctx.error(h0 + 1, "the format version (F9.2) in columns 1-9", first, 1) from None
    major = int(version) if np.isfinite(version) else -1
    if str(major) not in _SUPPORTED_VERSIONS or round(version, 2) not in _NAV_VERSIONS:
        raise ctx.error(h0 + 1, "a RINEX navigation version in " + ", ".join(f"{v:.2f}" for v in _NAV_VERSIONS)
                        + " in columns 1-9 (other layouts are refused)", first, 1)
    file_type = first[20:21]
    sys_char = first[40:41]
    if major == 2:
        system = _v2_system(ctx, first, file_type, sys_char)
    else:
        if file_type == "N":
            system = sys_char if sys_char.strip() else "G"
        elif file_type in ("G", "H"):  # some RINEX 3.00/3.01 writers
            system = {"G": "R", "H": "S"}[file_type]
        else:
            raise ctx.error(h0 + 1, "file type 'N' (navigation) in column 21", first, 21)
        if system not in "GRECJSIM":
            raise ctx.error(h0 + 1, "a satellite system G/R/E/C/J/S/I/M in column 41", first, 41)
    iono: dict[str, np.ndarray] = {}
    corr: dict[str, tuple[float, float, int, int]] = {}
    leap = None
    program = ""
    end = None
    for i in range(h0, len(lines)):
        ln = lines[i]
        label = ln[60:80].strip()
        if ln[80:].strip():
            ctx.warn_counted("header-text-beyond-80", "header lines with text after column 80 (ignored)", i + 1)
        if i == h0:
            continue
        if label == "END OF HEADER":
            end = i
            break
        try:
            if label == "PGM / RUN BY / DATE":
                program = ln[0:20].strip()
            elif label in ("ION ALPHA", "ION BETA"):
                iono["GPSA" if label == "ION ALPHA" else "GPSB"] = np.array(
                    [float(ln[2 + 12 * k:14 + 12 * k].replace("D", "E") or "nan") for k in range(4)])
            elif label == "IONOSPHERIC CORR":
                key = ln[0:4].strip()
                iono[key] = np.array([float(ln[5 + 12 * k:17 + 12 * k].replace("D", "E") or "nan")
                                      for k in range(4)])
            elif label == "DELTA-UTC: A0,A1,T,W":
                corr["GPUT"] = (float(ln[3:22].replace("D", "E")), float(ln[22:41].replace("D", "E")),
                                int(ln[41:50]), int(ln[50:59]))
            elif label == "TIME SYSTEM CORR":
                corr[ln[0:4].strip()] = (float(ln[5:22].replace("D", "E")), float(ln[22:38].replace("D", "E")),
                                         int(ln[38:45]), int(ln[45:50]))
            elif label == "CORR TO SYSTEM TIME":
                # RINEX 2 GLONASS: year, month, day, -tau_c (s).
                corr["GLUT"] = (float(ln[21:40].replace("D", "E")), 0.0, 0, 0)
            elif label == "LEAP SECONDS":
                leap = int(ln[0:6])
        except ValueError:
            ctx.warnings.append(ParseWarning("header-line-unreadable", f"header line '{label}' could not be read "
                                             "and is ignored", i + 1))
    if end is None:
        raise ctx.error(len(lines), "an 'END OF HEADER' line (columns 61-80)", lines[-1] if lines else "")
    return version, file_type, system, iono, corr, leap, program, end


# --- records ---------------------------------------------------------------------------------------------

_KEPLER_SYSTEMS = "GJECI"
_N_ORBIT_LINES = {"G": 7, "J": 7, "E": 7, "C": 7, "I": 7, "R": 3, "S": 3}
# Minimum number of BROADCAST ORBIT lines a record must have: GPS-like need line 7 (transmission time).
_REQUIRED_KEPLER = list(range(0, 20)) + [21]


def _sat_id(ctx: _Ctx, sys: str, prn_text: str, line_no: int, line: str, col0: int) -> str:
    if _INT_RE.fullmatch(prn_text) is None:
        raise ctx.error(line_no, "a satellite number (I2) after the system letter", line, col0 + 1)
    prn = int(prn_text)
    if not 0 < prn < 100:
        raise ctx.error(line_no, "a satellite number 01-99", line, col0 + 1)
    return f"{sys}{prn:02d}"


def _epoch_v3(ctx: _Ctx, line: str, line_no: int):
    """(sat, (y, m, d, h, mi, s), three values) of a RINEX 3/4 SV / EPOCH / SV CLK line."""
    sat = _sat_id(ctx, line[0], line[1:3], line_no, line, 1)
    if line[3:4] != " " or len(line) < 23:
        raise ctx.error(line_no, "SV / EPOCH / SV CLK: 'sNN yyyy mm dd hh mm ss' then 3D19.12 (A1,I2.2,1X,I4,"
                        "5(1X,I2.2),3D19.12)", line, 4)
    parts = []
    for a, b, what in ((4, 8, "year"), (9, 11, "month"), (12, 14, "day"), (15, 17, "hour"), (18, 20, "minute"),
                       (21, 23, "second")):
        parts.append(_int(ctx, line[a:b], line_no, a, f"epoch {what}", line))
    vals = [_num(ctx, line[c:c + _FIELD_W], line_no, c, "SV clock word", line) for c in (23, 42, 61)]
    if line[80:].strip():
        raise ctx.error(line_no, "nothing after column 80 of the SV / EPOCH / SV CLK line", line, 81)
    return sat, parts, vals


def _epoch_v2(ctx: _Ctx, line: str, line_no: int, sys: str):
    """(sat, (y, m, d, h, mi, s), three values) of a RINEX 2 PRN / EPOCH / SV CLK line (I2,5(1X,I2),F5.1,3D19.12),
    or of the 2.12-draft layout with a system letter (A1,I2,5(1X,I2),F5.1,3D19.12: RTKLIB's QZSS/Galileo)."""
    o = 1 if line[:1].isalpha() else 0
    if o:
        if line[0] != sys:
            raise ctx.error(line_no, f"records of system {sys} as the header says", line, 1)
        sat = _sat_id(ctx, sys, line[1:3], line_no, line, 1)
    else:
        sat = _sat_id(ctx, sys, line[0:2], line_no, line, 0)
    if len(line) < 22 + o:
        raise ctx.error(line_no, "PRN / EPOCH / SV CLK: I2,5(1X,I2),F5.1 then 3D19.12", line, 1)
    parts = []
    for a, b, what in ((2, 5, "year"), (5, 8, "month"), (8, 11, "day"), (11, 14, "hour"), (14, 17, "minute")):
        parts.append(_int(ctx, line[a + o:b + o], line_no, a + o, f"epoch {what}", line))
    sec_txt = line[17 + o:22 + o]
    if _NUM_RE.fullmatch(sec_txt) is None or not sec_txt.strip():
        raise ctx.error(line_no, f"epoch seconds (F5.1) in columns {18 + o}-{22 + o}", line, 18 + o)
    parts.append(float(sec_txt))
    y = parts[0]
    parts[0] = y + (1900 if y >= 80 else 2000) if y < 100 else y
    vals = [_num(ctx, line[c:c + _FIELD_W], line_no, c, "SV clock word", line) for c in (22 + o, 41 + o, 60 + o)]
    if line[79 + o:].strip():
        raise ctx.error(line_no, f"nothing after column {79 + o} of the PRN / EPOCH / SV CLK line", line, 80 + o)
    return sat, parts, vals


def _check_epoch(ctx: _Ctx, parts, line_no: int, line: str):
    y, mo, d, h, mi, s = parts
    if not (1980 <= y <= 2200 and 1 <= mo <= 12 and 1 <= d <= 31 and 0 <= h <= 24 and 0 <= mi <= 60
            and 0 <= s <= 61):
        raise ctx.error(line_no, "a valid epoch (year 1980-2200, month 1-12, day 1-31, hour 0-23, ...)", line)


def _fit_hours(system: str, raw: float) -> float:
    if system == "G":
        if not np.isfinite(raw) or raw == 0:
            return 4.0
        return 6.0 if raw == 1 else raw
    if system == "J":
        if not np.isfinite(raw) or raw == 0:
            return 2.0
        return 4.0 if raw == 1 else raw
    return np.nan


def _iter_records(ctx: _Ctx, lines: list[str], start: int, major: int):
    """Yield (kind, sat_or_None, first_line_index, [lines...]) for each record after the header.

    kind: 'EPH' for ephemerides (RINEX 2/3: all records), or the RINEX 4 record type ('STO', 'EOP', ...).
    """
    i = start
    n = len(lines)
    if major == 4:
        cur = None
        while i < n:
            ln = lines[i]
            if ln.startswith(">"):
                if cur is not None:
                    yield cur
                toks = ln[1:].split()
                if len(toks) < 2 or toks[0] not in ("EPH", "STO", "EOP", "ION"):
                    raise ctx.error(i + 1, "a RINEX 4 record line '> EPH|STO|EOP|ION sNN TYPE'", ln, 1)
                cur = (toks[0], toks[1], toks[2] if len(toks) > 2 else "", i, [])
            elif not ln.strip():
                ctx.warn_counted("blank-line", "blank lines in the data section were ignored", i + 1)
            else:
                if cur is None:
                    raise ctx.error(i + 1, "a RINEX 4 record line starting with '>'", ln, 1)
                cur[4].append((i, ln))
            i += 1
        if cur is not None:
            yield cur
        return
    cur = None
    while i < n:
        ln = lines[i]
        if not ln.strip():
            ctx.warn_counted("blank-line", "blank lines in the data section were ignored", i + 1)
            i += 1
            continue
        is_start = bool(ln[0:2].strip()) if major == 2 else ln[0] != " "
        if is_start:
            if cur is not None:
                yield cur
            cur = ("EPH", None, "", i, [(i, ln)])
        else:
            if cur is None:
                raise ctx.error(i + 1, "a record's first line (satellite and epoch)", ln, 1)
            cur[4].append((i, ln))
        i += 1
    if cur is not None:
        yield cur


_V4_SUPPORTED = {("G", "LNAV"), ("J", "LNAV"), ("E", "INAV"), ("E", "FNAV"), ("C", "D1"), ("C", "D2"),
                 ("R", "FDMA"), ("I", "LNAV"), ("S", "SBAS")}


def _v4_message(ctx: _Ctx, kind: str, sat: str, msg_type: str, i0: int, body) -> NavMessage:
    """A RINEX 4 record kept as a NavMessage (RINEX 4.01 sec. 5.3-5.6): the epoch of its first line (EPH: 'sNN'
    then the epoch; STO/EOP/ION: 4 blanks then the epoch), STO's labels, and every D19.12 number in file order."""
    if not body:
        raise ctx.error(i0 + 1, f"the first line of the '> {kind} {sat} {msg_type}' record", "")
    fi, first = body[0]
    # STO/EOP/ION lines carry no satellite (and '> STO E   IFNV' may name only the system): parse the epoch
    # behind a placeholder id, keep the announced one
    head = first[:4] if kind == "EPH" else "G01 "
    if kind != "EPH" and first[:4].strip():
        raise ctx.error(fi + 1, f"4 blanks before the epoch of a {kind} record", first, 1)
    if kind == "STO":
        _, parts, _ = _epoch_v3(ctx, head + first[4:23], fi + 1)
        label, vals = " ".join(first[23:].split()), []
    else:
        got, parts, vals = _epoch_v3(ctx, head + first[4:], fi + 1)
        if kind == "EPH" and got != _sat_norm(sat):
            raise ctx.error(fi + 1, f"satellite {sat} as announced on line {i0 + 1}", first, 1)
        label = ""
    _check_epoch(ctx, parts, fi + 1, first)
    for k, (oi, ol) in enumerate(body[1:]):
        vals.extend(_orbit_line(ctx, ol, oi + 1, 4, f"line {k + 2} of the {kind} {sat} {msg_type} record"))
    y, mo, d, h, mi, sec = parts
    epoch = GpsTime.from_calendar(int(y), int(mo), int(d), int(h), int(mi), float(sec))
    return NavMessage(kind=kind, sat=_sat_norm(sat), msg_type=msg_type, epoch=epoch,
                      values=np.array(vals, dtype=np.float64), line_no=i0 + 1, label=label)


def read_rinex_nav(source, *, name: str | None = None) -> NavData:
    """Ephemerides and header of a RINEX 2/3/4 navigation file (path or bytes, any supported compression).

    Args:
        source: path (str/Path) or the file's bytes; gzip/.Z/zip/Hatanaka are detected by magic bytes.
        name: the file name as the user knows it, used in errors (default: the path's base name).
    Returns: `NavData`. Raises `ParseError` (file, line, column, what was expected) for anything broken.
    Implements: RINEX 2.11 Tables A3/A4/A10/A11, RINEX 3.05 Tables A6-A17, RINEX 4.01 sec. 5 (see module doc).
    """
    text, display = read_source_text(source, name)
    ctx = _Ctx(display)
    lines = _split_lines(text)
    version, file_type, system, iono, corr, leap, program, end = _parse_header(ctx, lines)
    major = int(version)

    rows: dict[str, list] = {s: [] for s in "GJECIRS"}
    skipped: dict[str, int] = {}
    messages: list[NavMessage] = []
    start_col = 3 if major == 2 else 4
    for kind, v4_sat, v4_type, i0, body in _iter_records(ctx, lines, end + 1, major):
        if major == 4:
            key = f"{kind} {v4_sat[:1]} {v4_type}".strip()
            if kind != "EPH" or (v4_sat[:1], v4_type) not in _V4_SUPPORTED:
                messages.append(_v4_message(ctx, kind, v4_sat, v4_type, i0, body))
                continue
            if not body:
                raise ctx.error(i0 + 1, "the SV / EPOCH / SV CLK line after '> EPH'", lines[i0])
        first_i, first = body[0]
        ln1 = first_i + 1
        if major == 2:
            sat, parts, clk = _epoch_v2(ctx, first, ln1, system)
            start_col = 4 if first[:1].isalpha() else 3
        else:
            sat, parts, clk = _epoch_v3(ctx, first, ln1)
            if major == 4 and sat != _sat_norm(v4_sat):
                raise ctx.error(ln1, f"satellite {v4_sat} as announced on line {i0 + 1}", first, 1)
            if system != "M" and sat[0] != system and not (system == "G" and sat[0] == "G"):
                ctx.warn_counted("system-mismatch", f"records of system {sat[0]} in a file declared {system}", ln1)
        _check_epoch(ctx, parts, ln1, first)
        sys = sat[0]
        if sys not in _N_ORBIT_LINES:
            key = f"EPH {sys}"
            skipped[key] = skipped.get(key, 0) + 1
            ctx.warn_counted(f"unsupported-record:{key}", f"navigation records of system {sys} were skipped", ln1)
            continue
        need = _N_ORBIT_LINES[sys]
        orbit_lines = body[1:]
        if len(orbit_lines) < need:
            last_i = body[-1][0]
            nxt = lines[last_i + 1] if last_i + 1 < len(lines) else "<end of file>"
            raise ctx.error(last_i + 2, f"BROADCAST ORBIT - {len(orbit_lines) + 1} of the {sat} record begun on line "
                            f"{ln1} ({need} orbit lines)", nxt)
        vals = list(clk)
        for k, (oi, ol) in enumerate(orbit_lines):
            v = _orbit_line(ctx, ol, oi + 1, start_col, f"BROADCAST ORBIT - {k + 1} of {sat}")
            if k < need + (1 if sys == "R" else 0):
                vals.extend(v)
        if sys == "R":
            extra = len(orbit_lines) - (need + 1)
        else:
            extra = len(orbit_lines) - need
        if extra > 0:
            ctx.warn_counted("extra-spare-lines", "records with extra spare lines (ignored)", ln1)
        rows[sys].append((sat, parts, vals, ln1))

    kepler = {}
    for sys in _KEPLER_SYSTEMS:
        if rows[sys]:
            kepler[sys] = _build_kepler(ctx, sys, rows[sys], lines)
    glonass = _build_glonass(ctx, rows["R"], leap)
    for r in np.flatnonzero(sbas_records_in_metres(rows["S"])):
        ctx.warn_counted("sbas-position-in-metres", "SBAS position words written in metres, not km (read as metres)",
                         rows["S"][r][3])
    sbas = build_sbas(rows["S"])
    ctx.flush()
    alpha = iono.get("GPSA")
    beta = iono.get("GPSB")
    return NavData(name=display, version=version, file_type=file_type, system=system, kepler=kepler,
                   glonass=glonass, iono=iono, klobuchar_alpha=alpha, klobuchar_beta=beta, time_corrections=corr,
                   leap_seconds=leap, program=program, warnings=ctx.warnings, skipped=skipped, sbas=sbas,
                   messages=messages)


def _sat_norm(text: str) -> str:
    t = text.strip()
    rest = t[1:].strip(" ")
    if len(t) >= 2 and rest.isascii() and rest.isdigit():   # ASCII only: int() refuses '²' and control chars
        return f"{t[0]}{int(rest):02d}"
    return t


def _week_from_epoch(ctx: _Ctx, sys: str, toc: GpsTime, toe_sow: np.ndarray, week: np.ndarray,
                     toc_week: np.ndarray, bad: np.ndarray, line_no: np.ndarray) -> np.ndarray:
    """Weeks that are neither the epoch's week nor a 1024-rollover of it (gnsstk's BDS test files write week 1 in
    2014, BDT week 435): the week of toe follows from toc and toe's seconds of week, as RTKLIB's adjweek does."""
    toc_sow = toc.week_sow()[1]
    derived = toc_week + np.round((toc_sow - toe_sow) / SECONDS_PER_WEEK).astype(np.int64)
    r = int(np.argmax(bad))
    ctx.warn_counted("week-from-epoch", f"{sys} records whose week (BROADCAST ORBIT - 5, word 3; e.g. "
                     f"{int(week[r])}) is not the {'BDT' if sys == 'C' else 'GPS'} week of their epoch "
                     f"({int(toc_week[r])}): the week was taken from the epoch and toe", int(line_no[r]) + 5)
    return np.where(bad & np.isfinite(toe_sow), derived, week)


def _build_kepler(ctx: _Ctx, sys: str, rows, lines) -> KeplerEphemeris:
    n = len(rows)
    v = np.full((n, 31), np.nan)
    cal = np.zeros((n, 6))
    sats = []
    line_no = np.empty(n, dtype=np.int64)
    for r, (sat, parts, vals, ln) in enumerate(rows):
        m = min(len(vals), 31)
        v[r, :m] = vals[:m]
        cal[r] = parts
        sats.append(sat)
        line_no[r] = ln
        missing = [k for k in _REQUIRED_KEPLER if not np.isfinite(v[r, k])]
        if missing:
            k = missing[0]
            orbit = 0 if k < 3 else (k - 3) // 4 + 1
            raise ctx.error(ln + orbit, f"a value in word {k - 3 - 4 * (orbit - 1) + 1 if orbit else k + 1} of "
                            f"{'SV / EPOCH / SV CLK' if not orbit else f'BROADCAST ORBIT - {orbit}'} of {sat} "
                            "(blank)", lines[ln + orbit - 1] if ln + orbit - 1 < len(lines) else "")
    toc = GpsTime.from_calendar(cal[:, 0].astype(np.int64), cal[:, 1].astype(np.int64), cal[:, 2].astype(np.int64),
                                cal[:, 3].astype(np.int64), cal[:, 4].astype(np.int64), cal[:, 5])

    ints = partial(int_column, v)

    week = ints(21)
    # Week as written vs. the week of the epoch (BDT week for BeiDou); fix a 1024-multiple (mod-1024 or GST week).
    toc_week = toc.week_sow()[0] - (BDT_WEEK0_GPS_WEEK if sys == "C" else 0)
    off = toc_week - week
    k1024 = np.round(off / 1024.0).astype(np.int64)
    fix = (k1024 != 0) & (np.abs(off - 1024 * k1024) <= 1)
    if fix.any():
        week = week + 1024 * np.where(fix, k1024, 0)
        ctx.warn_counted("week-rollover-fixed", f"{sys} week numbers written modulo 1024 (or as GST week) were "
                         "made continuous from the record epochs", int(line_no[np.argmax(fix)]))
    bad_week = np.abs(toc_week - week) > 1
    if bad_week.any():
        week = _week_from_epoch(ctx, sys, toc, v[:, 11], week, toc_week, bad_week, line_no)
    nan = np.full(n, np.nan)
    neg = np.full(n, -1, dtype=np.int64)
    if sys == "E":
        ds = ints(20)
        bgd_a, bgd_b = v[:, 25].copy(), v[:, 26].copy()
        tgd = np.where((ds >= 0) & ((ds >> 9) & 1 == 1), bgd_b, bgd_a)
        iodc, tgd2, fit = neg, nan, nan
    elif sys == "C":
        ds, bgd_a, bgd_b = neg, nan, nan
        tgd, tgd2, iodc, fit = v[:, 25].copy(), v[:, 26].copy(), ints(28), nan
    else:
        ds, bgd_a, bgd_b, tgd2 = neg, nan, nan, nan
        tgd, iodc = v[:, 25].copy(), ints(26)
        fit = np.array([_fit_hours(sys, x) for x in v[:, 28]])
    time_system = {"G": "GPST", "J": "QZSST", "E": "GST", "C": "BDT", "I": "IRNWT"}[sys]
    return KeplerEphemeris(
        sat=np.array(sats, dtype=np.str_), toc=toc, af0_s=v[:, 0].copy(), af1_s_s=v[:, 1].copy(),
        af2_s_s2=v[:, 2].copy(), iode=ints(3), crs_m=v[:, 4].copy(), delta_n_rad_s=v[:, 5].copy(),
        m0_rad=v[:, 6].copy(), cuc_rad=v[:, 7].copy(), e=v[:, 8].copy(), cus_rad=v[:, 9].copy(),
        sqrt_a_sqrt_m=v[:, 10].copy(), toe_sow=v[:, 11].copy(), cic_rad=v[:, 12].copy(),
        omega0_rad=v[:, 13].copy(), cis_rad=v[:, 14].copy(), i0_rad=v[:, 15].copy(), crc_m=v[:, 16].copy(),
        omega_rad=v[:, 17].copy(), omega_dot_rad_s=v[:, 18].copy(), idot_rad_s=v[:, 19].copy(), week=week,
        health=ints(24), tgd_s=tgd, iodc=iodc, transmission_sow=v[:, 27].copy(), fit_interval_h=fit,
        accuracy_m=v[:, 23].copy(), line_no=line_no, bgd_e5a_e1_s=bgd_a, bgd_e5b_e1_s=bgd_b, data_sources=ds,
        tgd2_s=tgd2, system=sys, time_system=time_system)


def _build_glonass(ctx: _Ctx, rows, header_leap: int | None) -> GlonassEphemeris:
    n = len(rows)
    v = np.full((n, 19), np.nan)
    cal = np.zeros((n, 6))
    sats = []
    line_no = np.empty(n, dtype=np.int64)
    for r, (sat, parts, vals, ln) in enumerate(rows):
        m = min(len(vals), 19)
        v[r, :m] = vals[:m]
        cal[r] = parts
        sats.append(sat)
        line_no[r] = ln
        if not np.all(np.isfinite(v[r, :15])):
            raise ctx.error(ln, f"all words of the {sat} GLONASS record's epoch line and BROADCAST ORBIT - 1..3 "
                            "(a blank was found)", "")
    toc_utc = GpsTime.from_calendar(cal[:, 0].astype(np.int64), cal[:, 1].astype(np.int64),
                                    cal[:, 2].astype(np.int64), cal[:, 3].astype(np.int64),
                                    cal[:, 4].astype(np.int64), cal[:, 5])
    leap = gps_minus_utc_s(toc_utc.s)
    expires = GpsTime.from_calendar(LEAP_TABLE_EXPIRES.year, LEAP_TABLE_EXPIRES.month, LEAP_TABLE_EXPIRES.day).s
    after = toc_utc.s >= expires
    if n and after.any():
        if header_leap is None:
            ctx.warnings.append(ParseWarning("leap-table-expired", "GLONASS epochs after the leap-second table "
                                             f"expiry {LEAP_TABLE_EXPIRES.isoformat()} and no LEAP SECONDS in the "
                                             f"header: GPS-UTC = {int(leap[-1])} s assumed", int(line_no[0])))
        else:
            ctx.warnings.append(ParseWarning("leap-table-expired", "GLONASS epochs after the leap-second table "
                                             f"expiry {LEAP_TABLE_EXPIRES.isoformat()}: header LEAP SECONDS "
                                             f"{header_leap} used", int(line_no[0])))
            leap = np.where(after, header_leap, leap)
    if n and header_leap is not None and not after.all() and header_leap != int(leap[~after][-1]):
        ctx.warnings.append(ParseWarning("leap-seconds-mismatch", f"header LEAP SECONDS {header_leap} differs from "
                                         f"GPS-UTC {int(leap[~after][-1])} s at the GLONASS epochs; the table "
                                         "value was used", None))
    toc = GpsTime(toc_utc.s + leap, toc_utc.frac)

    ints = partial(int_column, v)

    km = 1000.0
    return GlonassEphemeris(
        sat=np.array(sats, dtype=np.str_), toc=toc, leap_s=leap.astype(np.int64), tau_n_s=-v[:, 0],
        gamma_n=v[:, 1].copy(), message_frame_time_s=v[:, 2].copy(),
        position_m=v[:, [3, 7, 11]] * km, velocity_m_s=v[:, [4, 8, 12]] * km,
        acceleration_m_s2=v[:, [5, 9, 13]] * km, health=ints(6), frequency_number=ints(10),
        age_days=v[:, 14].copy(), status_flags=ints(15), delta_tau_l1l2_s=v[:, 16].copy(), urai=ints(17),
        health_flags=ints(18), line_no=line_no)


# --- selection -------------------------------------------------------------------------------------------

def healthy_records(kepler: KeplerEphemeris, idx: np.ndarray) -> np.ndarray:
    """(n,) bool: records idx are healthy for an L1/L2 user: health == 0; QZSS ignores the least significant bit
    of its 6-bit LNAV health word (the L6/LEX signal, not L1 C/A or L2C: IS-QZSS-PNT-005 sec. 4.1.2.3; RTKLIB
    2.4.3 satexclude masks it the same way, svh & 0xFE)."""
    h = np.asarray(kepler.health)[idx]
    if getattr(kepler, "system", "G") == "J":
        return (h & ~1) == 0
    return h == 0


def select_ephemeris(kepler: KeplerEphemeris, sat: str, t: GpsTime, *, max_age_s: float | None = None,
                     allow_unhealthy: bool = False):
    """Index of the record of `sat` to use at GPS time(s) `t`, or -1 where none qualifies (int or (n,) int64).

    Rules, deterministic:
    1. only records of `sat`; only healthy ones (`healthy_records`) unless `allow_unhealthy`;
    2. only records with |t - toe| <= max age: `max_age_s` if given, else half the curve-fit interval for
       GPS/QZSS (IS-GPS-200 sec. 20.3.4.4: toe sits mid-fit; at least 2 h) and `MAX_AGE_S` for E/C;
    3. among the records already transmitted at `t`, the latest transmission (the upload a receiver would
       hold: a fresh upload with a new IODE beats an older data set with a nearer toe, e.g. G02 on
       2007-03-21 at 14:00: IODE 58 (toe 13:59:44, sent 12:40:48) is 0.4 m from the precise orbit, IODE 32
       (toe 14:00:00, sent 12:11:48) 16 m); where none was transmitted yet, or transmission times are
       missing or absurd, the smallest |t - toe|; ties go to the later toe, later transmission, later in file.
    Args:
        kepler: records of one system; sat: e.g. 'G05'; t: GpsTime scalar or (n,).
    Implements: IS-GPS-200N sec. 20.3.4.4 (fit interval), 20.3.4.5 (toe at the centre of the fit interval).
    """
    cand = np.flatnonzero(kepler.sat == sat)
    scalar = np.ndim(t.s) == 0
    t1 = GpsTime(np.atleast_1d(t.s), np.atleast_1d(t.frac))
    out = np.full(len(t1), -1, dtype=np.int64)
    if not allow_unhealthy:
        cand = cand[healthy_records(kepler, cand)]
    if cand.size:
        sub = kepler.take(cand)
        toe = sub.toe_gpst()
        trans = sub.transmission_gpst()
        # Candidate order encodes the tie-breakers: later toe, later transmission, later in file first.
        order = np.lexsort((-cand, -(trans - toe), -(toe - toe[0])))
        cand, toe, trans = cand[order], toe[order], trans[order]
        if max_age_s is not None:
            max_age = np.full(len(cand), float(max_age_s))
        elif kepler.system in ("G", "J"):
            fit = kepler.fit_interval_h[cand]
            max_age = np.maximum(np.where(np.isfinite(fit), fit, 4.0) * 1800.0, MAX_AGE_S[kepler.system])
        else:
            max_age = np.full(len(cand), MAX_AGE_S.get(kepler.system, 7200.0))
        # dt[i, j] = t_i - toe_j in seconds, part by part (two-part time).
        dt = (t1.s[:, None] - toe.s[None, :]).astype(np.float64) + (t1.frac[:, None] - toe.frac[None, :])
        dist = np.abs(dt)
        dist = np.where(dist <= max_age[None, :], dist, np.inf)
        nearest = np.argmin(dist, axis=1)  # first minimum = preferred by the candidate order
        since_tx = (t1.s[:, None] - trans.s[None, :]).astype(np.float64) + (t1.frac[:, None] - trans.frac[None, :])
        tx_sane = np.abs((trans.s - toe.s).astype(np.float64)) < 7 * 86400.0
        sent = np.isfinite(dist) & tx_sane[None, :] & (since_tx >= 0.0)
        latest = np.argmax(np.where(sent, -since_tx, -np.inf), axis=1)
        best = np.where(sent.any(axis=1), latest, nearest)
        ok = np.isfinite(dist[np.arange(len(t1)), best])
        out = np.where(ok, cand[best], -1)
    return int(out[0]) if scalar else out


# --- summary --------------------------------------------------------------------------------------------

def summarize_rinex_nav(source, *, name: str | None = None) -> dict:
    """JSON-ready summary for upload validation: format, version, systems, records, satellites, span, warnings.

    Raises ParseError like `read_rinex_nav` (the whole file is read: navigation files are small).
    """
    nav = read_rinex_nav(source, name=name)
    n_records = {s: len(k) for s, k in nav.kepler.items()}
    sats = {s: sorted(set(k.sat.tolist())) for s, k in nav.kepler.items()}
    times = [k.toc_gpst() for k in nav.kepler.values()]
    if len(nav.glonass):
        n_records["R"] = len(nav.glonass)
        sats["R"] = sorted(set(nav.glonass.sat.tolist()))
        times.append(nav.glonass.toc)
    if nav.sbas is not None and len(nav.sbas):
        n_records["S"] = len(nav.sbas)
        sats["S"] = sorted(set(nav.sbas.sat.tolist()))
        times.append(nav.sbas.toc)
    messages: dict[str, int] = {}
    for m in nav.messages:
        key = f"{m.kind} {m.sat[:1]} {m.msg_type}"
        messages[key] = messages.get(key, 0) + 1
    span = None
    if times:
        allt = GpsTime.concatenate(times)
        order = np.argsort(allt - allt[0])
        span = [allt[order[0]].iso(3), allt[order[-1]].iso(3)]
    return {
        "format": "RINEX navigation",
        "name": nav.name,
        "version": nav.version,
        "file_type": nav.file_type,
        "declared_system": nav.system,
        "systems": sorted(n_records),
        "n_records": n_records,
        "satellites": sats,
        "time_span_gps": span,
        "leap_seconds": nav.leap_seconds,
        "has_klobuchar": nav.klobuchar_alpha is not None and nav.klobuchar_beta is not None,
        "messages": messages,
        "skipped": dict(nav.skipped),
        "warnings": [w.to_dict() for w in nav.warnings],
    }
