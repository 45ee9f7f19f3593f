"""RINEX observation files (2.10/2.11, 3.00-3.05, 4.00-4.02) into dense numpy arrays, fast and value-exact.

Public API:
    read_rinex_obs(source, *, name=None) -> RinexObs
    summarize_rinex_obs(source, *, name=None) -> dict
    rinex3_code(system, code, version) -> str
    RinexObs.get(code3, system='G') -> (n_epochs, n_sats) float64

How (docs/design/rinex_reader.md has the long form): the file is decompressed in memory
(`compression.read_text_bytes`), the header is read line by line (it is small), and the data section is never
parsed field by field in Python. Lines are located with numpy over the raw bytes; every observation record
(RINEX 3: one line; RINEX 2: the 1 + (n_types-1)//5 lines of one satellite, each padded to 80 columns) becomes
one row of a fixed-width uint8 matrix, and all F14.3 fields of all rows are converted at once by digit
arithmetic: a lookup table turns bytes into digit values and a matrix product with place-value weights gives
each field in integer thousandths, exactly (all partial sums are integers below 2**53). Dividing that integer
by 1000.0 is one correctly rounded IEEE operation, so the result is bit-identical to `float(text)`.
The layout of every field (characters allowed, one '.', at column 11 of the field, a '-' only at the start,
no embedded blanks, right-justified) is checked with the same kind of matrix product over character classes;
a malformed field raises ParseError with its line and column.

Epoch times keep the seconds as written: F11.7 seconds become whole seconds plus an exact count of 1e-7 s,
so 59.999 s or 15.188 s epochs are never rounded.

Implements: RINEX 2.11 (Gurtner & Estey 2007) Tables A1-A2; RINEX 3.04 (IGS/RTCM 2018) sec. 5, Tables A1-A3
(header, epoch record, observation record, event flags 0-6 of Table A3); RINEX 3.05 and 4.00-4.02 observation
records (identical data layout to 3.04); RINEX 2 -> 3 code mapping after RINEX 3.04 Tables 4-9 (see
`rinex3_code`).
Neglects: header records inside flag-4 events are kept as text (a change of observation types mid-file is
refused); epochs are returned in the file's time system (GPS for nearly all files; a warning says otherwise).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.gnss.io.compression import read_text_bytes
from gnssatt.gnss.io.errors import ParseError, ParseWarning
from gnssatt.gnss.time import SECONDS_PER_DAY, GpsTime, days_from_civil

__all__ = ["ObsHeader", "ObsEvent", "RinexObs", "read_rinex_obs", "summarize_rinex_obs", "rinex3_code",
           "SUPPORTED_VERSIONS"]

#: Versions whose observation layout this reader knows, -> major layout. Anything else is refused.
SUPPORTED_VERSIONS: dict[float, int] = {
    2.0: 2, 2.01: 2, 2.1: 2, 2.11: 2,
    3.0: 3, 3.01: 3, 3.02: 3, 3.03: 3, 3.04: 3, 3.05: 3,
    4.0: 4, 4.01: 4, 4.02: 4,
}
_SYSTEMS = "GRECJSI"
_GPS_EPOCH_UNIX_DAYS = 3657  # 1970-01-01 -> 1980-01-06, as in gnssatt.gnss.time
#: Characters converted per block (~15 MB of temporaries) whatever the file size.
_CHUNK_ELEMENTS = 2**20

_V3_EPOCH_LAYOUT = ("> yyyy mm dd hh mm ss.sssssss  f nnn      [receiver clock offset F15.12]  "
                    "(RINEX 3.04 Table A3: A1,1X,I4,4(1X,I2.2),F11.7,2X,I1,I3,6X,F15.12)")
_V2_EPOCH_LAYOUT = (" yy mm dd hh mm ss.sssssss  fnnnG01G02...(12 sats)  [clock offset F12.9]  "
                    "(RINEX 2.11 Table A2: 1X,I2.2,4(1X,I2),F11.7,2X,I1,I3,12(A1,I2),F12.9)")


# --- data model ----------------------------------------------------------------------------------

@dataclass
class ObsHeader:
    """Header of a RINEX observation file, as written, plus the quirks found (warnings).

    obs_types: per system letter, the observation codes in file order (RINEX 2 codes stay 'C1', 'L1', 'P2';
    a RINEX 2 file's single list is given for every system present in the data, or for the header's system).
    approx_position_ecef_m: (3,) or None when absent or written as 0 0 0 (unknown, e.g. spaceborne files).
    antenna_delta_hen_m: (3,) height, east, north of the antenna reference point above the marker, or None.
    glonass_slots: 'R01' -> frequency channel number k (-7..6) from GLONASS SLOT / FRQ #.
    """

    version: float
    file_type: str
    satellite_system: str
    marker_name: str | None = None
    marker_number: str | None = None
    receiver_number: str | None = None
    receiver_type: str | None = None
    receiver_version: str | None = None
    antenna_number: str | None = None
    antenna_type: str | None = None
    approx_position_ecef_m: np.ndarray | None = None
    antenna_delta_hen_m: np.ndarray | None = None
    interval_s: float | None = None
    time_first: GpsTime | None = None
    time_last: GpsTime | None = None
    time_system: str = "GPS"
    obs_types: dict[str, list[str]] = field(default_factory=dict)
    glonass_slots: dict[str, int] = field(default_factory=dict)
    signal_strength_unit: str | None = None
    comments: list[str] = field(default_factory=list)
    n_header_lines: int = 0
    warnings: list[ParseWarning] = field(default_factory=list)


@dataclass
class ObsEvent:
    """A non-observation epoch record (event flag 2-6) and the special records that follow it.

    flag: 2 start moving, 3 new site occupation, 4 header information follows, 5 external event,
    6 cycle-slip records follow (RINEX 3.04 Table A3). time: GpsTime, or None when the event line has no date.
    line_no: 1-based line number of the event line. records: the following lines, as text.
    """

    flag: int
    line_no: int
    time: GpsTime | None
    records: list[str]

    def to_dict(self) -> dict:
        return {"flag": self.flag, "line": self.line_no, "time": None if self.time is None else self.time.iso(7),
                "records": list(self.records)}


@dataclass
class RinexObs:
    """Observations of one RINEX file as dense arrays.

    time: GpsTime (n_epochs,) of the epochs with observations (flags 0 and 1), in file order, as written.
    epoch_flag: int8 (n_epochs,) 0 OK, 1 power failure since the previous epoch.
    clock_offset_s: float64 (n_epochs,) receiver clock offset from the epoch line, NaN when absent.
    sats: sorted satellite ids ('C01' < 'E11' < 'G01' < 'R02').
    codes: union of the observation codes over systems, in order of first appearance in the header
        (for RINEX 2 the single list of the file, e.g. ['C1', 'L1', 'L2', 'P2']).
    values: float64 (n_epochs, n_sats, n_codes); NaN where the field is blank or the satellite not observed;
        0.0 where the file says 0.000. Units as in the file (m, cycles, Hz, dB-Hz or the SSI unit).
    lli: int8, same shape: loss-of-lock indicator digit 0-9, or -1 where the field is blank / not observed.
    ssi: int8, same shape: signal strength indicator digit 1-9 (0 = unknown), -1 where blank / not observed.
    events: ObsEvent for each epoch record with flag 2-6.
    """

    header: ObsHeader
    time: GpsTime
    epoch_flag: np.ndarray
    clock_offset_s: np.ndarray
    sats: list[str]
    codes: list[str]
    values: np.ndarray
    lli: np.ndarray
    ssi: np.ndarray
    events: list[ObsEvent] = field(default_factory=list)
    name: str = ""

    @property
    def warnings(self) -> list[ParseWarning]:
        return self.header.warnings

    def code_index(self, code3: str, system: str = "G") -> int | None:
        """Index into `codes` of the RINEX 3 signal `code3` (e.g. 'L1C') of `system`, or None if absent.

        RINEX 2 files are searched through `rinex3_code` (e.g. 'C1W' finds 'P1' in a GPS file).
        """
        types = self.header.obs_types.get(system, [])
        if code3 in types:
            return self.codes.index(code3)
        if self.header.version < 3:
            for c in types:
                try:
                    if rinex3_code(system, c, self.header.version) == code3:
                        return self.codes.index(c)
                except ValueError:
                    continue
        return None

    def get(self, code3: str, system: str = "G") -> np.ndarray:
        """(n_epochs, n_sats) float64 of signal `code3` (RINEX 3 code) for the satellites of `system`.

        Columns follow `sats`; satellites of other systems, and epochs without the signal, are NaN.
        Raises KeyError when the file has no such signal for that system.
        """
        k = self.code_index(code3, system)
        if k is None:
            raise KeyError(f"{self.name or 'file'} has no {code3} observations for system {system}")
        out = np.full(self.values.shape[:2], np.nan)
        mask = np.array([s[0] == system for s in self.sats], dtype=bool)
        out[:, mask] = self.values[:, mask, k]
        return out

    def sat_mask(self, system: str) -> np.ndarray:
        """Boolean (n_sats,) selecting the satellites of one system letter."""
        return np.array([s[0] == system for s in self.sats], dtype=bool)


# --- RINEX 2 -> 3 codes --------------------------------------------------------------------------

def rinex3_code(system: str, code: str, version: float) -> str:
    """RINEX 3 observation code (type + band + attribute, e.g. 'C1W') of a RINEX 2 code ('P1') of `system`.

    Args:
        system: satellite system letter G, R, E, J, S, C.
        code: a 2-character RINEX 2 code (C1, P1, L1, D1, S1, C2, P2, L2, ..., C5, L5, ...); a 3-character code
            is returned unchanged.
        version: the file's RINEX version (2.10 / 2.11 semantics; 2.12 'A'/'B'/'C'/'D' codes are not mapped).

    Implements: RINEX 3.04 sec. 5.1, Tables 4 (GPS), 5 (GLONASS), 6 (Galileo), 7 (SBAS), 8 (QZSS), 9 (BDS):
    a RINEX 2.11 observable is mapped to the RINEX 3 tracking mode it stood for:
    GPS C1 -> C1C (L1 C/A), P1 -> C1W and P2 -> C2W (P(Y) under anti-spoofing: Z-tracking 'W'), C2 -> C2X
    (L2C, RINEX 2.11 sec. 5.1), L1/D1/S1 -> ?1C, L2/D2/S2 -> ?2W, band 5 -> ?5X; GLONASS C1 -> C1C, P1 -> C1P,
    P2 -> C2P, C2 -> C2C, L1/D1/S1 -> ?1C, L2/D2/S2 -> ?2P; Galileo band 1 -> ?1X, 5/6/7/8 -> ?5X ?6X ?7X ?8X;
    SBAS band 1 -> ?1C, 5 -> ?5X; QZSS band 1 -> ?1C, 2 -> ?2X, 5 -> ?5X, 6 -> ?6X; BDS 2 -> ?2X, 6 -> ?6X,
    7 -> ?7X. These are the choices of RTKLIB 2.4.3 `convcode()` (rinex.c) for versions below 2.12, so the
    comparison with RTKLIB in bench/ is like for like.
    Raises ValueError when the code has no RINEX 3 equivalent for that system.
    """
    if len(code) == 3:
        return code
    if len(code) != 2:
        raise ValueError(f"not a RINEX observation code: {code!r}")
    kind, band = code[0], code[1]
    sys = system.upper()
    if kind == "P":
        if band in "12" and sys == "G":
            return f"C{band}W"
        if band in "12" and sys == "R":
            return f"C{band}P"
        raise ValueError(f"RINEX 2 code {code} has no RINEX 3 equivalent for system {system}")
    if kind not in "CLDS":
        raise ValueError(f"RINEX 2 code {code} has no RINEX 3 equivalent for system {system}")
    if kind == "C" and band == "2":
        attr = {"G": "X", "R": "C", "J": "X", "C": "X"}.get(sys)
    elif band == "1":
        attr = {"G": "C", "R": "C", "E": "X", "J": "C", "S": "C"}.get(sys)
    elif band == "2":
        attr = {"G": "W", "R": "P", "J": "X", "C": "X"}.get(sys)
    elif band == "5":
        attr = {"G": "X", "E": "X", "J": "X", "S": "X"}.get(sys)
    elif band == "6":
        attr = {"E": "X", "J": "X", "C": "X"}.get(sys)
    elif band == "7":
        attr = {"E": "X", "C": "X"}.get(sys)
    elif band == "8":
        attr = {"E": "X"}.get(sys)
    else:
        attr = None
    if attr is None:
        raise ValueError(f"RINEX 2 code {code} has no RINEX 3 equivalent for system {system}")
    return f"{kind}{band}{attr}"


# --- lookup tables for the vectorised field conversion ------------------------------------------

_DIGIT_F64 = np.zeros(256, dtype=np.float64)
_DIGIT_F64[48:58] = np.arange(10)
# LLI / SSI digits: '0'-'9' -> 0..9, blank -> -1, anything else -> -2 (an error).
_FLAG_I8 = np.full(256, -2, dtype=np.int8)
_FLAG_I8[32] = -1
_FLAG_I8[48:58] = np.arange(10, dtype=np.int8)


def _pad_rows(lines: list[bytes], idx, width: int) -> np.ndarray:
    """(len(idx), width) uint8 matrix of the given lines, cut or blank-padded to `width` columns."""
    joined = b"".join([lines[i][:width].ljust(width) for i in idx])
    return np.frombuffer(joined, dtype=np.uint8).reshape(-1, width) if joined else np.zeros((0, width), np.uint8)


def _slot_rows(lines: list[bytes], idx, lead: int, width: int) -> np.ndarray:
    """(len(idx), lead + width) uint8 matrix: `lead` blanks, then the line cut or blank-padded to `width`.

    Built with one join: each line is padded with `lead` trailing blanks and the whole buffer is shifted by
    `lead` bytes, so the blanks of line i-1 become the lead of line i (no per-line concatenation).
    """
    row = lead + width
    if len(idx) == 0:
        return np.zeros((0, row), np.uint8)
    joined = b" " * lead + b"".join([lines[i][:width].ljust(row) for i in idx])
    return np.frombuffer(joined, dtype=np.uint8, count=len(idx) * row).reshape(-1, row)


def _slot_rows_of_buffer(buf: np.ndarray, starts: np.ndarray, lens: np.ndarray, idx, lead: int,
                         width: int) -> np.ndarray:
    """_slot_rows of lines given as a buffer (_split_lines: line i is buf[starts[i]:starts[i] + lens[i]]): the
    same matrix, gathered row by row from a sliding window over the buffer in one fancy index instead of one
    bytes slice and ljust per line (~76k records per file of a 106-minute 1 Hz pass)."""
    row = lead + width
    idx = np.asarray(idx, np.int64)
    out = np.empty((len(idx), row), np.uint8)
    out[:, :lead] = 32
    if len(idx) == 0:
        return out
    padded = np.concatenate((buf, np.full(width, 32, np.uint8)))      # a last line shorter than width
    out[:, lead:] = np.lib.stride_tricks.sliding_window_view(padded, width)[starts[idx]]
    short = np.flatnonzero(lens[idx] < width)
    if short.size:                     # past each short line's end (its newline, the next line): blanks
        cut = np.arange(width)[None, :] >= lens[idx][short][:, None]
        block = out[short, lead:]
        block[cut] = 32
        out[short, lead:] = block
    return out


_U64 = np.dtype("<u8")
_PACK_BITS = np.uint64(0x0102040810204080)  # (w * this) >> 56 packs the low bit of each of 8 bytes into 8 bits
_LOW14 = np.uint64(0x3FFF)


def _bits16(mask: np.ndarray) -> np.ndarray:
    """uint64 bitmask (bit p = character p) of the first 14 characters of each 16-byte slot; mask: (N, 16) bool."""
    w = mask.view(_U64)
    return (((w[:, 0] * _PACK_BITS) >> np.uint64(56)) | (((w[:, 1] * _PACK_BITS) >> np.uint64(56)) << np.uint64(8))
            ) & _LOW14


def _swar8(w: np.ndarray) -> np.ndarray:
    """Decimal value of 8 digit bytes (0..9, first byte most significant) packed little-endian in uint64.

    SWAR ("SIMD within a register"): pairs, then quads, then the 8-digit value, 3 multiply-add-mask steps.
    """
    w = (w * np.uint64(10) + (w >> np.uint64(8))) & np.uint64(0x00FF00FF00FF00FF)
    w = (w * np.uint64(100) + (w >> np.uint64(16))) & np.uint64(0x0000FFFF0000FFFF)
    return (w * np.uint64(10000) + (w >> np.uint64(32))) & np.uint64(0xFFFFFFFF)


def _decode_slots(mat: np.ndarray, use: np.ndarray, locate, name: str):
    """(values float64, lli int8, ssi int8), each (n_rows, len(use)), of the F14.3,I1,I1 fields of `mat`.

    Args:
        mat: (n_rows, 16 * n_slots) uint8, C-contiguous; slot k holds columns 16k..16k+15 of a row: an F14.3
            observation, the LLI digit and the SSI digit (RINEX 2.11 Table A2, RINEX 3.04 Table A3).
        use: slot numbers to convert, in output order.
        locate: callable(row, slot) -> (line_no, column_1based, line_text) for error messages.

    A field is accepted only as Fortran F14.3 output looks: blank, or right-justified with no embedded blank,
    characters [0-9.-] only, exactly one '.' as 11th character, at most one '-' and then as first character.
    Values are integer thousandths from digit arithmetic, divided once by 1000.0 (exact to float(text)).
    Implements: RINEX 2.11 sec. 6.4 / 3.04 sec. 6.7 blank fields (-> NaN; blank LLI/SSI -> -1).
    """
    n_rows = mat.shape[0]
    n_slots = mat.shape[1] // 16
    n_use = len(use)
    values = np.empty((n_rows, n_use))
    lli = np.empty((n_rows, n_use), dtype=np.int8)
    ssi = np.empty((n_rows, n_use), dtype=np.int8)
    rows_per_chunk = max(16, _CHUNK_ELEMENTS // (16 * n_slots))
    for r0 in range(0, n_rows, rows_per_chunk):
        # every slot of the chunk is converted (a contiguous view, no gather); unused slots are dropped after
        g = mat[r0:r0 + rows_per_chunk].reshape(-1, 16)
        d = g - np.uint8(48)
        is_digit = d < 10
        nsb = _bits16(g != 32)
        dig_b = _bits16(is_digit)
        minus_b = _bits16(g == 45)
        dot_b = _bits16(g == 46)
        blank = nsb == 0
        gap = _LOW14 ^ nsb  # leading blanks must be bits 0..k-1 exactly: gap & (gap + 1) == 0
        lowest = nsb & (~nsb + np.uint64(1))
        good = blank | ((nsb == (dig_b | minus_b | dot_b)) & ((gap & (gap + np.uint64(1))) == 0)
                        & (dot_b == np.uint64(1 << 10)) & ((minus_b == 0) | (minus_b == lowest)))
        good = good.reshape(-1, n_slots)[:, use]
        if not good.all():
            r, k = np.argwhere(~good)[0]
            line_no, col, text = locate(r0 + int(r), int(use[k]))
            raise ParseError(name, line_no, f"an F14.3 observation (right-justified, 3 decimals) or blanks in "
                             f"columns {col}-{col + 13}", text, column=col)
        w = (d * is_digit).view(_U64)  # digits, anything else 0 (np.where here is ~15x slower)
        hi = _swar8(w[:, 0].copy())  # first 8 integer digits
        b = w[:, 1]
        # bytes of b: d8 d9 '.' d11 d12 d13 LLI SSI -> d8 d9 d11 d12 d13 0 0 0 (drop the '.', LLI and SSI)
        lo = _swar8((b & np.uint64(0xFFFF)) | ((b >> np.uint64(8)) & np.uint64(0x000000FFFFFF0000)))
        thousandths = hi * np.uint64(100000) + lo // np.uint64(1000)
        v = thousandths.astype(np.float64) / 1000.0  # one correctly rounded division: identical to float(text)
        np.negative(v, out=v, where=minus_b != 0)
        v[blank] = np.nan
        sl = slice(r0, r0 + rows_per_chunk)
        values[sl] = v.reshape(-1, n_slots)[:, use]
        lli[sl] = _FLAG_I8[g[:, 14]].reshape(-1, n_slots)[:, use]
        ssi[sl] = _FLAG_I8[g[:, 15]].reshape(-1, n_slots)[:, use]
    for arr, what, shift in ((lli, "loss-of-lock indicator (digit or blank)", 14),
                             (ssi, "signal strength indicator (digit or blank)", 15)):
        bad = arr == -2
        if bad.any():
            r, k = np.argwhere(bad)[0]
            line_no, col, text = locate(int(r), int(use[k]))
            raise ParseError(name, line_no, f"a {what} in column {col + shift}", text, column=col + shift)
    return values, lli, ssi


# --- header --------------------------------------------------------------------------------------

def _f(text: str) -> float | None:
    text = text.strip().replace("D", "E").replace("d", "e")
    return float(text) if text else None


def _header_time(line: str) -> tuple[GpsTime, str]:
    """GpsTime and time system of TIME OF FIRST/LAST OBS (5I6, F13.7, 5X, A3)."""
    y, mo, d, h, mi = (int(line[6 * i:6 * i + 6]) for i in range(5))
    sec_txt = line[30:43].strip()
    whole, _, frac = sec_txt.partition(".")
    t = GpsTime.from_calendar(y, mo, d, h, mi, float(int(whole or "0")))
    frac_s = int(frac) / 10 ** len(frac) if frac.strip() else 0.0
    return GpsTime(t.s, frac_s), line[48:51].strip() or "GPS"


class _HeaderCursor:
    """Read position in the header lines while one record is parsed (multi-line records advance it)."""

    def __init__(self, lines: list[bytes], name: str, major: int):
        self.lines = lines
        self.name = name
        self.major = major
        self.i = 1
        self.line = ""
        self.v2_types: list[str] = []

    @property
    def line_no(self) -> int:
        return self.i + 1

    def next_line(self) -> str | None:
        """The next header line (a continuation), or None at the end of the header lines."""
        self.i += 1
        if self.i >= len(self.lines):
            return None
        self.line = self.lines[self.i].decode("latin-1")
        return self.line


def _parse_version_line(lines: list[bytes], name: str, h0: int = 0) -> ObsHeader:
    """ObsHeader holding version, file type and system of line 1 (RINEX 3.05 Table A1 'RINEX VERSION / TYPE').

    h0: index of line 1 (blank lines before it are a quirk, counted by the caller).
    Raises ParseError for an empty file, a Hatanaka file that was not decoded, a missing label, an unreadable or
    unsupported version, or a file type other than 'O'.
    """
    if not lines or not lines[h0].strip():
        raise ParseError(name, 1 if lines else None, "a RINEX observation file (first line RINEX VERSION / TYPE)",
                         "an empty file")
    first = lines[h0].decode("latin-1")
    if first[60:80].strip() != "RINEX VERSION / TYPE":
        if "CRINEX" in first:
            raise ParseError(name, h0 + 1, "plain RINEX (Hatanaka decoding failed)", first)
        raise ParseError(name, h0 + 1, "'RINEX VERSION / TYPE' in columns 61-80 of line 1 (F9.2,11X,A1,19X,A1,19X)",
                         first if first.isprintable() else repr(lines[h0][:80]))
    try:
        version = round(float(first[0:9]), 2)
    except ValueError:
        raise ParseError(name, h0 + 1, "the format version (F9.2) in columns 1-9", first, column=1) from None
    if version not in SUPPORTED_VERSIONS:
        raise ParseError(name, h0 + 1, "a RINEX observation version in " + ", ".join(
            f"{v:.2f}" for v in SUPPORTED_VERSIONS) + " (other layouts are refused)", first, column=1)
    file_type = first[20:21]
    if file_type.upper() != "O":
        raise ParseError(name, h0 + 1, "file type 'O' (observation data) in column 21", first, column=21)
    system = first[40:41].strip().upper() or "G"
    return ObsHeader(version=version, file_type="O", satellite_system=system)


def _h_comment(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    hdr.comments.append(cur.line[:60].rstrip())


def _h_marker_name(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    hdr.marker_name = cur.line[:60].strip() or None


def _h_marker_number(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    hdr.marker_number = cur.line[:20].strip() or None


def _h_receiver(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    """REC # / TYPE / VERS: 3A20."""
    line = cur.line
    hdr.receiver_number = line[0:20].strip() or None
    hdr.receiver_type = line[20:40].strip() or None
    hdr.receiver_version = line[40:60].strip() or None


def _h_antenna(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    """ANT # / TYPE: 2A20."""
    hdr.antenna_number = cur.line[0:20].strip() or None
    hdr.antenna_type = cur.line[20:40].strip() or None


def _h_approx_position(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    """APPROX POSITION XYZ (3F14.4, m); 0 0 0 means unknown, a position far from the Earth is not trusted.
    Three numbers off their F14.4 columns (georinex's demo files) are read as whitespace-separated tokens."""
    xyz = _three_f14(hdr, cur, "APPROX POSITION XYZ", "approx-position-misplaced")
    if not all(v is not None for v in xyz):
        return
    pos = np.array(xyz, dtype=np.float64)
    if np.all(pos == 0.0):
        hdr.warnings.append(ParseWarning("approx-position-zero", "APPROX POSITION XYZ is 0 0 0 "
                                         "(unknown, e.g. a moving or spaceborne receiver)", cur.line_no))
        return
    hdr.approx_position_ecef_m = pos
    r = float(np.linalg.norm(pos))
    if not 6.0e6 < r < 5.0e7:
        hdr.warnings.append(ParseWarning("bad-approx-position", f"APPROX POSITION XYZ is {r:.0f} m "
                                         "from the geocentre: not trusted", cur.line_no))


def _floats_or_none(texts) -> list | None:
    try:
        return [_f(t) for t in texts]
    except ValueError:
        return None


def _three_f14(hdr: ObsHeader, cur: _HeaderCursor, label: str, code: str) -> list:
    """The 3F14.4 numbers of a header record; three numbers off their columns (georinex's demo files write them
    one column right) are read as the numbers written, with the warning `code`; anything else is a ParseError."""
    xyz = _approx_fields(cur.line)
    tokens = cur.line[:60].split()
    by_tokens = _floats_or_none(tokens) if len(tokens) == 3 else None
    if by_tokens is not None and by_tokens != xyz:
        hdr.warnings.append(ParseWarning(code, f"{label} numbers are not in their F14.4 columns (1-14, 15-28, "
                                         "29-42); read as the three numbers written", cur.line_no))
        return by_tokens
    if xyz is None:
        raise ParseError(cur.name, cur.line_no, f"three F14.4 numbers (columns 1-42) in {label}", cur.line)
    return xyz


def _approx_fields(line: str) -> list | None:
    """The three F14.4 fields as written (None entries for blanks), or None if one is not a number or the
    text around a field runs into it (a digit in the column before a field's first character)."""
    out = _floats_or_none([line[14 * k:14 * k + 14] for k in range(3)])
    if out is None or any(line[14 * k - 1:14 * k].strip() and line[14 * k:14 * k + 1].strip()
                          for k in (1, 2)) or line[42:43].strip():
        return None
    return out


def _h_antenna_delta(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    """ANTENNA: DELTA H/E/N (3F14.4, m)."""
    hen = _three_f14(hdr, cur, "ANTENNA: DELTA H/E/N", "antenna-delta-misplaced")
    if all(v is not None for v in hen):
        hdr.antenna_delta_hen_m = np.array(hen, dtype=np.float64)


def _h_interval(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    """INTERVAL (F10.3, s); a non-positive interval is dropped with a warning."""
    hdr.interval_s = _f(cur.line[0:10])
    if hdr.interval_s is not None and hdr.interval_s <= 0:
        hdr.warnings.append(ParseWarning("bad-interval", f"INTERVAL {hdr.interval_s:g} s is not positive",
                                         cur.line_no))
        hdr.interval_s = None


def _h_time_first(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    hdr.time_first, hdr.time_system = _header_time(cur.line)


def _h_time_last(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    hdr.time_last, _ = _header_time(cur.line)


def _h_signal_strength_unit(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    hdr.signal_strength_unit = cur.line[:20].strip() or None


def _type_codes(cur: _HeaderCursor, n: int, fields, blank_cols: int, so_far: str) -> list[str]:
    """The `n` observation codes of a types record and its continuation lines (same label, `blank_cols` blank).

    fields: the code fields of one line; so_far: the error's count text, '{}' for the codes read so far.
    """
    line, label = cur.line, cur.line[60:80].strip()
    codes: list[str] = []
    while True:
        codes += [c.strip() for c in fields(line)]
        codes = [c for c in codes if c]
        if len(codes) >= n:
            return codes
        line = cur.next_line()
        if line is None:
            return codes
        if line[60:80].strip() != label or line[0:blank_cols].strip():
            sep = " " if label == "SYS / # / OBS TYPES" else ", "
            raise ParseError(cur.name, cur.line_no, f"a continuation line of {label} ({n} types{sep}"
                             + so_far.format(len(codes)) + ")", line)


def _h_obs_types_v3(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    """SYS / # / OBS TYPES (A1,2X,I3,13(1X,A3), continued on lines with a blank column 1): RINEX 3.05 Table A2."""
    name, line_no, line = cur.name, cur.line_no, cur.line
    if cur.major == 2:
        raise ParseError(name, line_no, "'# / TYPES OF OBSERV' in a RINEX 2 file", line)
    sys_letter = line[0:1]
    if sys_letter not in _SYSTEMS:
        raise ParseError(name, line_no, f"a satellite system letter ({_SYSTEMS}) in column 1", line, column=1)
    n = int(line[3:6])
    codes = _type_codes(cur, n, lambda ln: [ln[7 + 4 * k:10 + 4 * k] for k in range(13)], 1,
                        f"for {sys_letter}, {{}} so far: 13 per line, columns 8-58")
    if len(codes) != n:
        raise ParseError(name, line_no, f"{n} observation types for system {sys_letter}",
                         f"{len(codes)}: {' '.join(codes)}")
    bad = [c for c in codes if not ((len(c) == 3 and c[0] in "CLDSX" and c[1].isdigit())
                                    or (len(c) == 2 and c[0] == "X" and c[1].isdigit()))]
    if bad:
        raise ParseError(name, line_no, "RINEX 3 observation codes like C1C, L2W, X1", " ".join(bad))
    if sys_letter in hdr.obs_types:
        raise ParseError(name, line_no, f"one SYS / # / OBS TYPES record for system {sys_letter}", "a second one")
    hdr.obs_types[sys_letter] = codes


def _h_obs_types_v2(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    """# / TYPES OF OBSERV (I6,9(4X,A2), continued on lines with blank columns 1-6): RINEX 2.11 Table A1."""
    name, line_no, line = cur.name, cur.line_no, cur.line
    if cur.major != 2:
        raise ParseError(name, line_no, "'SYS / # / OBS TYPES' in a RINEX 3/4 file", line)
    n = int(line[0:6])
    codes = _type_codes(cur, n, lambda ln: [ln[10 + 6 * k:12 + 6 * k] for k in range(9)], 6,
                        "{} so far: 9 per line, columns 11-60")
    if len(codes) > n:   # quirk (georinex's wrong_obs2_count.10o): the codes listed are what the body holds
        hdr.warnings.append(ParseWarning("obs-type-count-mismatch", f"# / TYPES OF OBSERV announces {n} types but "
                                         f"lists {len(codes)} ({' '.join(codes)}); the listed types are read",
                                         line_no))
    elif len(codes) != n:
        raise ParseError(name, line_no, f"{n} observation types", f"{len(codes)}: {' '.join(codes)}")
    bad = [c for c in codes if len(c) != 2 or c[0] not in "CLDSP" or not c[1].isdigit()]
    if bad:
        raise ParseError(name, line_no, "RINEX 2 observation codes like C1, P2, L1, D1, S1", " ".join(bad))
    cur.v2_types = codes


def _h_glonass_slots(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    """GLONASS SLOT / FRQ # (I3,1X,8(A1,I2.2,1X,I2,1X)): RINEX 3.05 Table A2."""
    line = cur.line
    for k in range(8):
        sat = line[4 + 7 * k:7 + 7 * k]
        if sat.strip():
            fcn = line[8 + 7 * k:10 + 7 * k].strip()
            slot = sat[1:].strip(" ")
            if (sat[0] == "R" and slot.isascii() and slot.isdigit() and fcn.isascii()
                    and fcn.lstrip("-").isdigit()):   # ASCII only: int() refuses '²' and control chars
                hdr.glonass_slots[f"R{int(slot):02d}"] = int(fcn)


def _h_glonass_biases(hdr: ObsHeader, cur: _HeaderCursor) -> None:
    if not cur.line[:60].strip():
        hdr.warnings.append(ParseWarning("empty-glonass-cod-phs-bis", "GLONASS COD/PHS/BIS is blank: "
                                         "code-phase biases unknown", cur.line_no))


#: Header record label (columns 61-80) -> the function that reads it into the ObsHeader.
_HEADER_RECORDS = {
    "COMMENT": _h_comment,
    "MARKER NAME": _h_marker_name,
    "MARKER NUMBER": _h_marker_number,
    "REC # / TYPE / VERS": _h_receiver,
    "ANT # / TYPE": _h_antenna,
    "APPROX POSITION XYZ": _h_approx_position,
    "ANTENNA: DELTA H/E/N": _h_antenna_delta,
    "INTERVAL": _h_interval,
    "TIME OF FIRST OBS": _h_time_first,
    "TIME OF LAST OBS": _h_time_last,
    "SIGNAL STRENGTH UNIT": _h_signal_strength_unit,
    "SYS / # / OBS TYPES": _h_obs_types_v3,
    "# / TYPES OF OBSERV": _h_obs_types_v2,
    "GLONASS SLOT / FRQ #": _h_glonass_slots,
    "GLONASS COD/PHS/BIS": _h_glonass_biases,
}


def _header_warnings(hdr: ObsHeader) -> None:
    """Add the warnings for missing or unusual optional header records (marker, antenna, interval, time)."""
    warn = hdr.warnings
    if hdr.marker_name is None:
        warn.append(ParseWarning("missing-marker-name", "no MARKER NAME (or a blank one): the antenna cannot be "
                                 "matched to platform.json by name"))
    if hdr.antenna_type is None or hdr.antenna_type.upper() in ("UNKNOWN", "-", "NONE"):
        warn.append(ParseWarning("unknown-antenna", f"antenna type {hdr.antenna_type or 'blank'!r}: no "
                                 "phase-centre model can be applied"))
    if hdr.interval_s is None:
        warn.append(ParseWarning("missing-interval", "no INTERVAL in the header; taken from the data"))
    if hdr.time_first is None:
        warn.append(ParseWarning("missing-time-of-first-obs", "no TIME OF FIRST OBS; time system assumed GPS"))
    if hdr.time_system not in ("GPS", ""):
        warn.append(ParseWarning("time-system-not-gps", f"epochs are in time system {hdr.time_system}, kept as "
                                 "written (not converted to GPS time)"))


def _parse_header(lines: list[bytes], name: str) -> ObsHeader:
    """ObsHeader from the header lines (lines[:n_header_lines], END OF HEADER included).

    Implements: RINEX 2.11 Table A1 and RINEX 3.05 Table A2 (observation header records); labels not listed in
    `_HEADER_RECORDS` are skipped, a line without a label is a warning.
    """
    h0 = next((k for k, ln in enumerate(lines) if ln.strip()), 0)
    hdr = _parse_version_line(lines, name, h0)
    cur = _HeaderCursor(lines, name, SUPPORTED_VERSIONS[hdr.version])
    cur.i = h0 + 1
    if h0:
        hdr.warnings.append(ParseWarning("leading-blank-lines", f"{h0} blank line(s) before the RINEX VERSION / "
                                         "TYPE line were skipped", h0 + 1))
    end = None
    while cur.i < len(lines):
        cur.line = line = lines[cur.i].decode("latin-1")
        label = line[60:80].strip()
        line_no = cur.line_no
        if label == "END OF HEADER":
            end = cur.i
            break
        try:
            handler = _HEADER_RECORDS.get(label)
            if handler is not None:
                handler(hdr, cur)
            elif not label and line.strip():
                hdr.warnings.append(ParseWarning("header-line-without-label", "a header line has no label in "
                                                 "columns 61-80; ignored", line_no))
        except ParseError:
            raise
        except (ValueError, IndexError):
            raise ParseError(name, line_no, f"a valid '{label}' header record", cur.line) from None
        cur.i += 1
    if end is None:
        raise ParseError(name, len(lines), "an 'END OF HEADER' record (columns 61-73)", "end of file")
    hdr.n_header_lines = end + 1
    if cur.major == 2:
        if not cur.v2_types:
            raise ParseError(name, end + 1, "a '# / TYPES OF OBSERV' header record before END OF HEADER", "")
        hdr.obs_types = {"_v2": cur.v2_types}  # resolved to systems once the data are read
    elif not hdr.obs_types:
        raise ParseError(name, end + 1, "'SYS / # / OBS TYPES' header records before END OF HEADER", "")
    _header_warnings(hdr)
    return hdr


# --- shared pieces -------------------------------------------------------------------------------

def _split_lines(body):
    """(list of lines, starts, lengths, buffer) of the data section; a final empty line is dropped.

    body: (data, offset, n_header_lines): the whole file and where its data section starts; the section is
    not copied (its lines are split from the whole file and the header lines dropped).
    """
    data, offset, n_header = body
    lines = data.split(b"\n")
    del lines[:n_header]
    if lines and lines[-1] == b"":
        lines.pop()
    buf = np.frombuffer(data, dtype=np.uint8, offset=offset)
    nl = np.flatnonzero(buf == 10)
    starts = np.concatenate(([0], nl + 1))[:len(lines)]
    ends = np.concatenate((nl, [len(buf)]))[:len(lines)]
    return lines, starts, ends - starts, buf


def _comment_mask(buf: np.ndarray, starts: np.ndarray, lens: np.ndarray) -> np.ndarray:
    """Boolean per line: 'COMMENT' in columns 61-67 (such a line can never be a valid data line)."""
    mask = np.zeros(len(starts), dtype=bool)
    cand = np.flatnonzero(lens >= 67)
    if len(cand):
        sub = buf[starts[cand, None] + np.arange(60, 67)]
        mask[cand] = np.all(sub == np.frombuffer(b"COMMENT", dtype=np.uint8), axis=1)
    return mask


def _sat_key(letter: int, prn: int) -> int:
    return letter * 100 + prn


def _sat_name(key: int) -> str:
    return f"{chr(key // 100)}{key % 100:02d}"


def _times_from_fields(year, month, day, hour, minute, whole_s, frac_ticks, ticks_per_s: float) -> GpsTime:
    days = days_from_civil(year, month, day) - _GPS_EPOCH_UNIX_DAYS
    s = (days * SECONDS_PER_DAY + np.asarray(hour, np.int64) * 3600 + np.asarray(minute, np.int64) * 60
         + np.asarray(whole_s, np.int64))
    return GpsTime(s, np.asarray(frac_ticks, dtype=np.float64) / ticks_per_s)


def _digits(mat: np.ndarray, cols) -> np.ndarray:
    """Integer value (int64) of the digit columns `cols` of each row; blanks count as 0."""
    out = np.zeros(len(mat), dtype=np.int64)
    for c in cols:
        out = out * 10 + _DIGIT_F64[mat[:, c]].astype(np.int64)
    return out


# --- RINEX 3 / 4 data section --------------------------------------------------------------------

_DIG = np.zeros(256, dtype=bool)
_DIG[48:58] = True
_DIG_OR_SP = _DIG.copy()
_DIG_OR_SP[32] = True


def _parse_v3_epoch_python(line: str, name: str, line_no: int):
    """(y, m, d, h, mi, whole_s, ticks_1e7, flag, n) of one epoch line; date fields None when blank (events)."""
    try:
        if line[0] != ">":
            raise ValueError
        flag = int(line[31:32])
        n = int(line[32:35] or "0")
        if not line[1:29].strip():
            if flag < 2:
                raise ValueError
            return (None,) * 7 + (flag, n)
        y, mo, d, h, mi = int(line[2:6]), int(line[7:9]), int(line[10:12]), int(line[13:15]), int(line[16:18])
        whole, frac = line[18:29].strip().split(".")
        frac = (frac + "0000000")[:7] if len(frac) <= 7 else None
        if frac is None or not (whole.isdigit() and frac.isdigit()):
            raise ValueError
        return (y, mo, d, h, mi, int(whole), int(frac), flag, n)
    except (ValueError, IndexError):
        raise ParseError(name, line_no, "an epoch line: " + _V3_EPOCH_LAYOUT, line) from None


@dataclass
class _EpochRows:
    """Per-epoch arrays of the observation epochs (flags 0-1) of a data section."""

    times: GpsTime
    clock_offset_s: np.ndarray  # (n_epochs,) float64, NaN where not written
    flags: np.ndarray  # (n_epochs,) int8


@dataclass
class _RecordRows:
    """Per-record arrays of the satellite observation records, before they are scattered into epochs."""

    keys: np.ndarray  # (n_rec,) int64 satellite key letter * 100 + prn
    epoch: np.ndarray  # (n_rec,) int64 index into the observation epochs
    sys_b: np.ndarray  # (n_rec,) uint8 system letter
    values: np.ndarray  # (n_rec, n_fields) float64
    lli: np.ndarray  # (n_rec, n_fields) int8
    ssi: np.ndarray  # (n_rec, n_fields) int8


def _v3_line_kinds(lines: list[bytes], starts: np.ndarray, lens: np.ndarray, buf: np.ndarray):
    """(is_epoch, is_comment, is_blank) per data-section line: '>' in column 1, COMMENT label, blank."""
    first = np.full(len(lines), 32, dtype=np.uint8)
    nz = lens > 0
    first[nz] = buf[starts[nz]]
    is_epoch = first == ord(">")
    is_comment = _comment_mask(buf, starts, lens)
    is_blank = lens == 0
    for i in np.flatnonzero((first == 32) & ~is_comment & ~is_blank):
        if not lines[i].strip():
            is_blank[i] = True
    return is_epoch, is_comment, is_blank


def _v3_epoch_fields(lines: list[bytes], ep_idx: np.ndarray, name: str, n0: int):
    """(fields, flag, nrec, has_date) of the epoch lines `ep_idx`: fields (n_ep, 7) int64 y, m, d, h, mi, s, 1e-7 s.

    Vectorised over the byte matrix; lines of unusual spacing or events without a date go through
    `_parse_v3_epoch_python`. Implements: RINEX 3.05 Table A3 EPOCH record (A1,1X,I4,4(1X,I2.2),F11.7,2X,I1,I3).
    """
    n_ep = len(ep_idx)
    E = _pad_rows(lines, ep_idx, 56)
    fmt_ok = (np.all(E[:, [1, 6, 9, 12, 15, 29, 30]] == 32, axis=1) & np.all(_DIG[E[:, 2:6]], axis=1)
              & np.all(_DIG_OR_SP[E[:, [7, 10, 13, 16, 18, 19]]], axis=1)
              & np.all(_DIG[E[:, [8, 11, 14, 17, 20, 31, 34]]], axis=1) & (E[:, 21] == 46)
              & np.all(_DIG[E[:, 22:29]], axis=1) & np.all(_DIG_OR_SP[E[:, 32:34]], axis=1))
    fields = np.stack([_digits(E, range(2, 6)), _digits(E, (7, 8)), _digits(E, (10, 11)), _digits(E, (13, 14)),
                       _digits(E, (16, 17)), _digits(E, (18, 19, 20)), _digits(E, range(22, 29))], axis=1)
    flag = _digits(E, (31,))
    nrec = _digits(E, (32, 33, 34))
    has_date = np.ones(n_ep, dtype=bool)
    for j in np.flatnonzero(~fmt_ok):
        li = int(ep_idx[j])
        f = _parse_v3_epoch_python(lines[li].decode("latin-1"), name, n0 + li + 1)
        if f[0] is None:
            has_date[j] = False
            fields[j] = (1980, 1, 6, 0, 0, 0, 0)
        else:
            fields[j] = f[:7]
        flag[j], nrec[j] = f[7], f[8]
    month, day, hour, minute, whole_s = fields[:, 1], fields[:, 2], fields[:, 3], fields[:, 4], fields[:, 5]
    bad_date = has_date & ((month < 1) | (month > 12) | (day < 1) | (day > 31) | (hour > 23) | (minute > 59)
                           | (whole_s > 60))
    if bad_date.any() or (flag > 6).any():
        j = int(np.flatnonzero(bad_date | (flag > 6))[0])
        raise ParseError(name, n0 + int(ep_idx[j]) + 1, "an epoch line with a valid date and flag 0-6: "
                         + _V3_EPOCH_LAYOUT, lines[ep_idx[j]].decode("latin-1"))
    return fields, flag, nrec, has_date


def _v3_events(hdr: ObsHeader, lines: list[bytes], is_epoch: np.ndarray, ep_idx: np.ndarray, epoch_fields,
               name: str):
    """(consumed, events): the special records after event lines (flags 2-6), which are not observations.

    Implements: RINEX 3.05 Table A3 event flags 2-5 (special records follow; flag 4 a header splice, flag 3 a
    new site occupation).
    """
    fields, flag, nrec, has_date = epoch_fields
    n0 = hdr.n_header_lines
    n_lines = len(lines)
    consumed = np.zeros(n_lines, dtype=bool)
    events: list[ObsEvent] = []
    for j in np.flatnonzero(flag >= 2):
        li = int(ep_idx[j])
        k = int(nrec[j])
        if li + 1 + k > n_lines or is_epoch[li + 1:li + 1 + k].any():
            raise ParseError(name, n0 + li + 1, f"{k} special records after this event line (flag {flag[j]})",
                             f"only {int(np.argmax(np.append(is_epoch[li + 1:li + 1 + k], True)))} before the "
                             "next epoch line or the end of the file")
        recs = [ln.decode("latin-1") for ln in lines[li + 1:li + 1 + k]]
        consumed[li + 1:li + 1 + k] = True
        t = _times_from_fields(*fields[j], 1e7) if has_date[j] else None
        events.append(ObsEvent(int(flag[j]), n0 + li + 1, t, recs))
        if flag[j] == 4:
            _check_splice(recs, hdr, name, n0 + li + 2)
        if flag[j] == 3:
            hdr.warnings.append(ParseWarning("new-site-occupation", "event flag 3: a new site occupation starts "
                                             "here; the file mixes sites", n0 + li + 1))
    return consumed, events


def _v3_record_owners(lines: list[bytes], obs_rows: np.ndarray, ep_idx: np.ndarray, flag: np.ndarray,
                      nrec: np.ndarray, name: str, n0: int) -> np.ndarray:
    """Index of the epoch line owning each observation record; refuses counts that differ from the epoch line's."""
    n_ep = len(ep_idx)
    if len(obs_rows) and (n_ep == 0 or obs_rows[0] < ep_idx[0]):
        li = int(obs_rows[0])
        raise ParseError(name, n0 + li + 1, "an epoch line starting with '>' before observation records "
                         "(RINEX 3 data section)", lines[li].decode("latin-1"))
    owner = np.searchsorted(ep_idx, obs_rows, side="right") - 1
    counts = np.bincount(owner, minlength=n_ep) if n_ep else np.zeros(0, np.int64)
    expected = np.where(flag <= 1, nrec, 0)
    if n_ep and not np.array_equal(counts, expected):
        j = int(np.flatnonzero(counts != expected)[0])
        li = int(ep_idx[j])
        last = j == n_ep - 1
        what = "truncated file: " if last and counts[j] < expected[j] else ""
        raise ParseError(name, n0 + li + 1, f"{what}{expected[j]} satellite records after this epoch line "
                         "(the number in columns 33-35)", f"{counts[j]} records; epoch line: "
                         + lines[li].decode("latin-1").rstrip())
    return owner


def _v3_clock_offsets(lines: list[bytes], lens: np.ndarray, epoch_lines: np.ndarray, name: str,
                      n0: int) -> np.ndarray:
    """Receiver clock offset (s, F15.12 in columns 42-56) of each epoch line, NaN where blank."""
    clock = np.full(len(epoch_lines), np.nan)
    for r in np.flatnonzero(lens[epoch_lines] > 41):
        txt = lines[epoch_lines[r]][41:56].strip()
        if txt:
            try:
                clock[r] = float(txt)
            except ValueError:
                raise ParseError(name, n0 + int(epoch_lines[r]) + 1, "a receiver clock offset (F15.12) in "
                                 "columns 42-56 or blanks", lines[epoch_lines[r]].decode("latin-1"),
                                 column=42) from None
    return clock


def _v3_records(hdr: ObsHeader, lines: list[bytes], lens: np.ndarray, obs_rows: np.ndarray,
                rec_epoch: np.ndarray, name: str, buf_starts: tuple | None = None) -> _RecordRows:
    """_RecordRows of the observation records `obs_rows` (satellite id A1,I2.2, then m(F14.3,I1,I1)).

    Each record becomes a row of 16-byte slots (slot 0 = 13 blanks + 'G01', slot k = field k) decoded at once.
    Records of a system without SYS / # / OBS TYPES are skipped with a warning; text beyond the declared
    fields is a warning. Implements: RINEX 3.05 Table A3 OBSERVATION record.
    """
    n0 = hdr.n_header_lines
    max_n = max(len(v) for v in hdr.obs_types.values())
    M = (_slot_rows(lines, obs_rows, 13, 3 + 16 * max_n) if buf_starts is None else
         _slot_rows_of_buffer(buf_starts[0], buf_starts[1], lens, obs_rows, 13, 3 + 16 * max_n))
    sys_b = M[:, 13].copy()
    prn_ok = _DIG[M[:, 15]] & _DIG_OR_SP[M[:, 14]]
    sys_ok = np.isin(sys_b, np.frombuffer(_SYSTEMS.encode(), np.uint8))
    if not (prn_ok & sys_ok).all():
        r = int(np.flatnonzero(~(prn_ok & sys_ok))[0])
        raise ParseError(name, n0 + int(obs_rows[r]) + 1, f"a satellite id like G01 (system {_SYSTEMS}, PRN "
                         "I2) in columns 1-3 of an observation record", lines[obs_rows[r]].decode("latin-1"),
                         column=1)
    prn = _digits(M, (14, 15))
    keys = sys_b.astype(np.int64) * 100 + prn

    declared = np.isin(sys_b, np.frombuffer("".join(hdr.obs_types).encode(), np.uint8))
    if not declared.all():
        missing = sorted({chr(c) for c in np.unique(sys_b[~declared])})
        hdr.warnings.append(ParseWarning("undeclared-system", f"{int((~declared).sum())} records of system(s) "
                                         f"{', '.join(missing)} have no SYS / # / OBS TYPES; skipped"))
        keep = np.flatnonzero(declared)
        M, keys, rec_epoch, obs_rows = M[keep], keys[keep], rec_epoch[keep], obs_rows[keep]
        sys_b = sys_b[keep]

    n_types_of = np.zeros(256, dtype=np.int64)
    for s_letter, codes in hdr.obs_types.items():
        n_types_of[ord(s_letter)] = len(codes)
    over = lens[obs_rows] > 3 + 16 * n_types_of[sys_b]
    if over.any():
        n_extra = sum(1 for r in np.flatnonzero(over) if lines[obs_rows[r]][3 + 16 * n_types_of[sys_b[r]]:].strip())
        if n_extra:
            hdr.warnings.append(ParseWarning("extra-fields-ignored", f"{n_extra} records carry text beyond the "
                                             "observation types declared for their system; ignored"))

    def locate(row: int, slot: int):
        li = int(obs_rows[row])
        return n0 + li + 1, 16 * slot - 13 + 1, lines[li].decode("latin-1")

    vals, lli, ssi = _decode_slots(M, np.arange(1, max_n + 1), locate, name)
    return _RecordRows(keys, rec_epoch, sys_b, vals, lli, ssi)


def _v3_last_epoch_truncated(ep_idx: np.ndarray, flag: np.ndarray, nrec: np.ndarray, obs_rows: np.ndarray) -> bool:
    """Whether only the last epoch (flag 0/1) has fewer records than announced: a file cut inside its last epoch."""
    if len(ep_idx) == 0 or flag[-1] > 1:
        return False
    n_last = int(np.sum(obs_rows > ep_idx[-1]))
    if n_last >= nrec[-1]:
        return False
    owner = np.searchsorted(ep_idx, obs_rows[obs_rows < ep_idx[-1]], side="right") - 1
    counts = np.bincount(owner, minlength=len(ep_idx) - 1) if len(owner) else np.zeros(len(ep_idx) - 1, np.int64)
    return bool(np.array_equal(counts, np.where(flag[:-1] <= 1, nrec[:-1], 0)))


def _read_body_v3(hdr: ObsHeader, body: tuple, name: str):
    """RinexObs of a RINEX 3/4 data section: epoch lines, events, then observation records.

    Implements: RINEX 3.05 sec. 5 and Table A3 (identical for 3.00-4.02).
    """
    n0 = hdr.n_header_lines  # line number offset (body line i is file line n0 + i + 1)
    lines, starts, lens, buf = _split_lines(body)
    is_epoch, is_comment, is_blank = _v3_line_kinds(lines, starts, lens, buf)
    ep_idx = np.flatnonzero(is_epoch)
    epoch_fields = _v3_epoch_fields(lines, ep_idx, name, n0)
    fields, flag, nrec, _ = epoch_fields
    consumed, events = _v3_events(hdr, lines, is_epoch, ep_idx, epoch_fields, name)

    obs_rows = np.flatnonzero(~(is_epoch | is_comment | is_blank | consumed))
    if _v3_last_epoch_truncated(ep_idx, flag, nrec, obs_rows):
        li = int(ep_idx[-1])
        hdr.warnings.append(ParseWarning("truncated-last-epoch", f"the last epoch (line {n0 + li + 1}) announces "
                                         f"{int(nrec[-1])} satellite records but the file ends after "
                                         f"{int(np.sum(obs_rows > li))}; it is dropped, the epochs before it are "
                                         "read", n0 + li + 1))
        obs_rows, ep_idx = obs_rows[obs_rows < li], ep_idx[:-1]
        fields, flag, nrec = fields[:-1], flag[:-1], nrec[:-1]
    owner = _v3_record_owners(lines, obs_rows, ep_idx, flag, nrec, name, n0)
    obs_ep = np.flatnonzero(flag <= 1)
    ep_pos = np.full(len(ep_idx), -1, dtype=np.int64)
    ep_pos[obs_ep] = np.arange(len(obs_ep))
    epochs = _EpochRows(_times_from_fields(*fields[obs_ep].T, 1e7),
                        _v3_clock_offsets(lines, lens, ep_idx[obs_ep], name, n0), flag[obs_ep].astype(np.int8))
    recs = _v3_records(hdr, lines, lens, obs_rows, ep_pos[owner], name, (buf, starts))

    codes_all: list[str] = []
    for codes in hdr.obs_types.values():
        for c in codes:
            if c not in codes_all:
                codes_all.append(c)
    return _assemble(hdr, epochs, recs, codes_all,
                     {s: [codes_all.index(c) for c in v] for s, v in hdr.obs_types.items()}, events, name)


def _check_splice(recs: list[str], hdr: ObsHeader, name: str, first_line_no: int) -> None:
    """Header records inside a flag-4 event: note marker/antenna changes; refuse observation-type changes."""
    for k, rec in enumerate(recs):
        label = rec[60:80].strip()
        if label in ("SYS / # / OBS TYPES", "# / TYPES OF OBSERV"):
            raise ParseError(name, first_line_no + k, "no change of observation types inside the data "
                             "(a flag-4 header splice that redefines them is not supported)", rec)
        if label in ("MARKER NAME", "ANT # / TYPE", "ANTENNA: DELTA H/E/N", "REC # / TYPE / VERS",
                     "APPROX POSITION XYZ"):
            hdr.warnings.append(ParseWarning("header-changed-in-data", f"{label} redefined inside the data "
                                             f"section: {rec[:60].strip()!r}", first_line_no + k))


def _assemble(hdr: ObsHeader, epochs: _EpochRows, recs: _RecordRows, codes_all: list[str],
              code_map: dict[str, list[int]], events: list[ObsEvent], name: str) -> RinexObs:
    """Scatter per-record rows into (n_epochs, n_sats, n_codes) arrays; add data-vs-header warnings.

    code_map: per system letter ('_v2' for every record of a RINEX 2 file), the column in `codes_all` of each
    field of its records.
    """
    times, keys, rec_epoch, sys_b = epochs.times, recs.keys, recs.epoch, recs.sys_b
    vals, lli, ssi = recs.values, recs.lli, recs.ssi
    n_epochs = len(times)
    uniq, sat_idx = np.unique(keys, return_inverse=True)
    sats = [_sat_name(int(k)) for k in uniq]
    shape = (n_epochs, len(sats), len(codes_all))
    values = np.full(shape, np.nan)
    lli_out = np.full(shape, -1, dtype=np.int8)
    ssi_out = np.full(shape, -1, dtype=np.int8)
    for s, cmap in code_map.items():
        sel = np.flatnonzero(sys_b == ord(s)) if s != "_v2" else np.arange(len(keys))
        if not len(sel):
            continue
        n = len(cmap)
        e = rec_epoch[sel, None]
        j = sat_idx[sel, None]
        c = np.asarray(cmap)[None, :]
        values[e, j, c] = vals[sel, :n]
        lli_out[e, j, c] = lli[sel, :n]
        ssi_out[e, j, c] = ssi[sel, :n]
    if len(keys):
        pair = rec_epoch * len(sats) + sat_idx
        n_dup = len(pair) - len(np.unique(pair))
        if n_dup:
            hdr.warnings.append(ParseWarning("duplicate-satellite-records", f"{n_dup} satellite records repeat a "
                                             "satellite within its epoch; the last one is kept"))
    _data_warnings(hdr, times)
    return RinexObs(header=hdr, time=times, epoch_flag=epochs.flags, clock_offset_s=epochs.clock_offset_s,
                    sats=sats, codes=codes_all, values=values, lli=lli_out, ssi=ssi_out, events=events, name=name)


def _data_warnings(hdr: ObsHeader, times: GpsTime) -> None:
    warn = hdr.warnings
    if len(times) == 0:
        warn.append(ParseWarning("no-epochs", "the file holds no observation epoch"))
        return
    if hdr.time_first is not None and abs(float(times[0] - hdr.time_first)) > 1e-6:
        warn.append(ParseWarning("time-of-first-obs-mismatch", f"TIME OF FIRST OBS {hdr.time_first.iso(7)} but "
                                 f"the first epoch is {times[0].iso(7)}"))
    if hdr.time_last is not None and abs(float(times[-1] - hdr.time_last)) > 1e-6:
        warn.append(ParseWarning("time-of-last-obs-mismatch", f"TIME OF LAST OBS {hdr.time_last.iso(7)} but "
                                 f"the last epoch is {times[-1].iso(7)}"))
    if len(times) > 1:
        dt = np.diff(times.s).astype(np.float64) + np.diff(times.frac)
        if np.any(dt <= 0):
            warn.append(ParseWarning("epochs-not-increasing", f"{int(np.sum(dt <= 0))} epochs do not advance "
                                     "in time (kept in file order)"))
        step = float(np.median(dt))
        if hdr.interval_s is not None and abs(step - hdr.interval_s) > 1e-3:
            warn.append(ParseWarning("interval-mismatch", f"header INTERVAL {hdr.interval_s:g} s but the data "
                                     f"step is {step:g} s"))


# --- RINEX 2 data section ------------------------------------------------------------------------

def _v2_epoch_fields(line: str, name: str, line_no: int):
    """(date tuple or None, flag, n) of a RINEX 2 epoch line; ParseError when it is not one."""
    try:
        flag = int(line[28:29])
        n = int(line[29:32])
        date_txt = line[0:26]
        if not date_txt.strip():
            if flag < 2:
                raise ValueError
            return None, flag, n
        if (line[0] != " " or line[3] != " " or line[6] != " " or line[9] != " " or line[12] != " "
                or line[18] != "." or flag > 6):
            raise ValueError
        yy = int(line[1:3])
        year = yy + (2000 if yy < 80 else 1900)
        mo, d, h, mi = int(line[4:6]), int(line[7:9]), int(line[10:12]), int(line[13:15])
        whole, frac = line[15:26].split(".")
        frac = (frac.rstrip() + "0000000")[:7]
        if whole != whole.rstrip() or " " in frac.rstrip():   # a blank inside the seconds ('0 .0000000')
            raise ValueError
        if not (1 <= mo <= 12 and 1 <= d <= 31 and h <= 23 and mi <= 59 and frac.isdigit()):
            raise ValueError
        return (year, mo, d, h, mi, int(whole), int(frac)), flag, n
    except (ValueError, IndexError):
        raise ParseError(name, line_no, "an epoch line: " + _V2_EPOCH_LAYOUT, line) from None


def _v2_sat(txt: str, default: str, name: str, line_no: int, line: str) -> int:
    letter = txt[0] if txt[0] != " " else default
    prn = txt[1:3].replace(" ", "0")
    if letter not in _SYSTEMS or not prn.isdigit():
        raise ParseError(name, line_no, "satellite ids like G01 (A1,I2) in columns 33-68", line)
    return ord(letter) * 100 + int(prn)


def _v2_truncated_tail(hdr: ObsHeader, lines: list[bytes], i: int, name: str, n0: int, error: ParseError) -> None:
    """The epoch at body line `i` runs past the end of the file: a truncated last epoch (quirk: the epochs before
    it are read, it is dropped with a warning) if no epoch line follows it; otherwise `error` (a wrong count)."""
    for k in range(i + 1, len(lines)):
        line = lines[k].decode("latin-1")
        try:
            _v2_epoch_fields(line, name, n0 + k + 1)
        except ParseError:
            continue
        if line[32:35].strip() and line[28:29] in "01":   # an epoch line with satellites: not just a cut tail
            raise error
    hdr.warnings.append(ParseWarning("truncated-last-epoch", f"the last epoch (line {n0 + i + 1}) is cut by the "
                                     f"end of the file ({error.expected}); it is dropped, the epochs before it "
                                     "are read", n0 + i + 1))


def _read_body_v2(hdr: ObsHeader, body: tuple, name: str):
    n0 = hdr.n_header_lines
    lines, starts, lens, buf = _split_lines(body)
    n_lines = len(lines)
    is_comment = _comment_mask(buf, starts, lens)
    comment_cum = np.concatenate(([0], np.cumsum(is_comment)))
    types = hdr.obs_types["_v2"]
    n_types = len(types)
    lps = 1 + (n_types - 1) // 5  # lines per satellite record
    default_sys = hdr.satellite_system if hdr.satellite_system in _SYSTEMS else "G"
    ep_fields: list[tuple] = []
    ep_flags: list[int] = []
    clock: list[float] = []
    rec_lines: list[int] = []  # first line of each satellite record
    rec_keys: list[int] = []
    rec_epoch: list[int] = []
    events: list[ObsEvent] = []
    i = 0
    while i < n_lines:
        raw = lines[i]
        if is_comment[i] or not raw.strip():
            i += 1
            continue
        line = raw.decode("latin-1")
        date, flag, n = _v2_epoch_fields(line, name, n0 + i + 1)
        if 2 <= flag <= 5:
            if i + 1 + n > n_lines:
                raise ParseError(name, n0 + i + 1, f"{n} special records after this event line (flag {flag})",
                                 f"{n_lines - i - 1} lines before the end of the file")
            recs = [ln.decode("latin-1") for ln in lines[i + 1:i + 1 + n]]
            t = _times_from_fields(*date, 1e7) if date else None
            events.append(ObsEvent(flag, n0 + i + 1, t, recs))
            if flag == 4:
                _check_splice(recs, hdr, name, n0 + i + 2)
            if flag == 3:
                hdr.warnings.append(ParseWarning("new-site-occupation", "event flag 3: a new site occupation "
                                                 "starts here; the file mixes sites", n0 + i + 1))
            i += 1 + n
            continue
        n_cont = (n - 1) // 12 if n > 0 else 0
        if i + 1 + n_cont > n_lines:
            _v2_truncated_tail(hdr, lines, i, name, n0, ParseError(
                name, n0 + i + 1, f"truncated file: {n_cont} satellite-list continuation lines after this epoch "
                "line", "end of file"))
            break
        sat_text = line[32:68].ljust(36)
        for k in range(n_cont):
            cont = lines[i + 1 + k].decode("latin-1")
            if cont[:32].strip():
                raise ParseError(name, n0 + i + 2 + k, "a satellite-list continuation line (32 blanks, then "
                                 "12(A1,I2))", cont)
            sat_text += cont[32:68].ljust(36)
        keys = [_v2_sat(sat_text[3 * k:3 * k + 3], default_sys, name, n0 + i + 1, line) for k in range(n)]
        a = i + 1 + n_cont
        b = a + n * lps
        if b > n_lines:
            _v2_truncated_tail(hdr, lines, i, name, n0, ParseError(
                name, n0 + i + 1, f"truncated file: {n} satellite records of {lps} line(s) after this epoch line",
                f"{n_lines - a} lines before the end of the file"))
            break
        block = list(range(a, b))
        if comment_cum[b] - comment_cum[a]:  # comment lines inside the block: skip them, extend the block
            block, j = [], a
            while len(block) < n * lps and j < n_lines:
                if not is_comment[j]:
                    block.append(j)
                j += 1
            if len(block) < n * lps:
                _v2_truncated_tail(hdr, lines, i, name, n0, ParseError(
                    name, n0 + i + 1, f"truncated file: {n} satellite records after this epoch line", "end of file"))
                break
            b = j
        if flag == 6:  # cycle-slip records: same layout, not observations
            events.append(ObsEvent(6, n0 + i + 1, _times_from_fields(*date, 1e7),
                                   [lines[j].decode("latin-1") for j in block]))
            i = b
            continue
        e = len(ep_fields)
        ep_fields.append(date)
        ep_flags.append(flag)
        clk = line[68:80].strip()
        try:
            clock.append(float(clk) if clk else np.nan)
        except ValueError:
            raise ParseError(name, n0 + i + 1, "a receiver clock offset (F12.9) in columns 69-80 or blanks",
                             line, column=69) from None
        rec_lines.extend(block[::lps])
        rec_keys.extend(keys)
        rec_epoch.extend([e] * n)
        i = b

    fields = np.array(ep_fields, dtype=np.int64).reshape(-1, 7)
    times = _times_from_fields(*fields.T, 1e7)
    rec_first = np.array(rec_lines, dtype=np.int64)
    line_idx = (rec_first[:, None] + np.arange(lps)[None, :]).ravel()
    # comment lines inside a block were skipped: rebuild record lines from the non-comment sequence
    if is_comment.any() and len(rec_first):
        noncomment = np.flatnonzero(~is_comment)
        pos = np.searchsorted(noncomment, rec_first)
        line_idx = noncomment[(pos[:, None] + np.arange(lps)[None, :]).ravel()]
    M = _pad_rows(lines, line_idx, 80).reshape(-1, 80 * lps)
    long_lines = line_idx[lens[line_idx] > 80]
    n_long = sum(1 for li in long_lines if lines[li][80:].strip())
    if n_long:
        hdr.warnings.append(ParseWarning("extra-fields-ignored", f"{n_long} observation lines carry text beyond "
                                         "column 80; ignored"))
    line_rows = line_idx.reshape(-1, lps) if len(line_idx) else np.zeros((0, lps), np.int64)

    def locate(row: int, slot: int):
        li = int(line_rows[row, slot // 5])
        return n0 + li + 1, (slot % 5) * 16 + 1, lines[li].decode("latin-1")

    vals, lli, ssi = _decode_slots(M, np.arange(n_types), locate, name)
    keys_arr = np.array(rec_keys, dtype=np.int64)
    sys_b = (keys_arr // 100).astype(np.uint8)
    systems = sorted({chr(c) for c in np.unique(sys_b)}) or [default_sys if hdr.satellite_system != "M" else "G"]
    hdr.obs_types = {s: list(types) for s in systems}
    epochs = _EpochRows(times, np.array(clock, dtype=np.float64), np.array(ep_flags, dtype=np.int8))
    recs = _RecordRows(keys_arr, np.array(rec_epoch, dtype=np.int64), sys_b, vals, lli, ssi)
    return _assemble(hdr, epochs, recs, list(types), {"_v2": list(range(n_types))}, events, name)


# --- entry points --------------------------------------------------------------------------------

def _load(source, name: str | None) -> tuple[bytes, str]:
    if isinstance(source, (bytes, bytearray, memoryview)):
        label = name or "<bytes>"
    else:
        label = name or Path(source).name
    data = read_text_bytes(source, name=label)
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n")
    return data, label


def read_rinex_obs(source, *, name: str | None = None) -> RinexObs:
    """RinexObs of a RINEX 2.10/2.11, 3.00-3.05 or 4.00-4.02 observation file (plain or compressed).

    Args:
        source: path (str or Path) or the file's bytes; gzip, .Z, zip, bzip2 and Hatanaka in any combination.
        name: the file's name as the user knows it, used in errors and warnings.

    Raises:
        ParseError: empty or binary file, missing/invalid mandatory header records (RINEX VERSION / TYPE,
            observation types, END OF HEADER), unsupported version, malformed epoch line or field, truncated
            file (an epoch announces more satellite records than follow), damaged compression.

    Implements: RINEX 2.11 Tables A1-A2, RINEX 3.04/3.05/4.01 Tables A1-A3 (see the module docstring).
    """
    data, label = _load(source, name)
    if not data.strip():
        raise ParseError(label, None, "a RINEX observation file", "an empty file")
    head_end = data.find(b"END OF HEADER")
    if head_end < 0:
        first = data[:80].decode("latin-1")
        if "RINEX VERSION / TYPE" not in first:
            raise ParseError(label, 1, "'RINEX VERSION / TYPE' in columns 61-80 of line 1", first
                             if first.isprintable() else repr(data[:60]))
        raise ParseError(label, None, "an 'END OF HEADER' record (columns 61-73)", "end of file")
    nl = data.find(b"\n", head_end)
    split_at = len(data) if nl < 0 else nl + 1
    header_lines = data[:split_at].split(b"\n")
    if header_lines and header_lines[-1] == b"":
        header_lines.pop()
    hdr = _parse_header(header_lines, label)
    body = (data, split_at, hdr.n_header_lines)
    if not data.endswith(b"\n") and data[split_at:].strip():
        hdr.warnings.append(ParseWarning("no-final-newline", "the file does not end with a newline: its last "
                                         "record may be cut (a record cut between fields reads as blanks)"))
    if SUPPORTED_VERSIONS[hdr.version] == 2:
        return _read_body_v2(hdr, body, label)
    return _read_body_v3(hdr, body, label)


def summarize_rinex_obs(source, *, name: str | None = None) -> dict:
    """JSON-ready summary of an observation file for upload validation (full parse; raises ParseError).

    Keys: format ('RINEX'), kind ('observation'), version, marker_name, receiver_type, antenna_type,
    approx_position_ecef_m, time_first / time_last (ISO 8601, GPS time scale, from the data),
    header_time_first / header_time_last, interval_s (median epoch step of the data), header_interval_s,
    duration_s, n_epochs, n_events, systems, signals (per system, as in the file), signals_rinex3 (per system,
    RINEX 3 codes), satellites, n_observations (non-blank values), warnings (list of dicts).
    """
    obs = read_rinex_obs(source, name=name)
    h = obs.header
    n = len(obs.time)
    interval = None
    if n > 1:
        dt = np.diff(obs.time.s).astype(np.float64) + np.diff(obs.time.frac)
        interval = float(np.round(np.median(dt), 6))
    systems = sorted({s[0] for s in obs.sats}) or sorted(h.obs_types)
    rinex3 = {}
    for s in systems:
        out = []
        for c in h.obs_types.get(s, []):
            try:
                out.append(rinex3_code(s, c, h.version))
            except ValueError:
                out.append(None)
        rinex3[s] = out
    return {
        "format": "RINEX", "kind": "observation", "version": h.version,
        "marker_name": h.marker_name, "receiver_type": h.receiver_type, "antenna_type": h.antenna_type,
        "approx_position_ecef_m": None if h.approx_position_ecef_m is None else h.approx_position_ecef_m.tolist(),
        "time_first": obs.time[0].iso() if n else None, "time_last": obs.time[-1].iso() if n else None,
        "header_time_first": h.time_first.iso() if h.time_first is not None else None,
        "header_time_last": h.time_last.iso() if h.time_last is not None else None,
        "time_system": h.time_system,
        "interval_s": interval, "header_interval_s": h.interval_s,
        "duration_s": float(obs.time[-1] - obs.time[0]) if n else 0.0,
        "n_epochs": n, "n_events": len(obs.events),
        "systems": systems, "signals": {s: list(h.obs_types.get(s, [])) for s in systems},
        "signals_rinex3": rinex3, "satellites": list(obs.sats),
        "n_observations": int(np.count_nonzero(~np.isnan(obs.values))),
        "warnings": [w.to_dict() for w in h.warnings],
    }
