"""ANTEX 1.4 antenna phase-centre files: read and write, with an exact round trip.

`read_antex(source)` returns one `AntennaPattern` per `START OF ANTENNA ... END OF ANTENNA` block; each holds its
frequency blocks (`FrequencyPattern`: phase-centre offset NORTH/EAST/UP in mm, the NOAZI PCV row and, when
DAZI > 0, the azimuth-dependent PCV grid, all mm) and the optional `START OF FREQ RMS` blocks.
`write_antex(patterns)` writes them back; `read_antex(write_antex(p)) == p` holds exactly for every pattern whose
values lie on the format's 0.01 mm grid (all values read from a file do; the writer rounds others to it).
NaN values (a bin without data in a differential PCV map, CONVENTIONS.md "null") are written as `NaN` in the
F8.2 field and read back as NaN; standard ANTEX never contains them.

Implements: ANTEX 1.4 (Rothacher & Schmid, IGS, 2010), sec. "ANTEX format description": TYPE / SERIAL NO
(A20,A20,A10,A10), METH / BY / # / DATE (A20,A20,I6,4X,A10), DAZI (2X,F6.1), ZEN1 / ZEN2 / DZEN (2X,3F6.1),
# OF FREQUENCIES (I6), VALID FROM/UNTIL (5I6,F13.7), SINEX CODE (A10), START OF FREQUENCY (3X,A1,I2),
NORTH / EAST / UP (3F10.2), NOAZI row (3X,A5,mF8.2), azimuth rows (F8.1,mF8.2), fixed columns throughout.
Neglects: nothing in the 1.4 layout; header lines other than version/system, PCV type/reference antenna and
comments are kept only as comments.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.io.errors import ParseError, ParseWarning
from gnssatt.gnss.io.rinex_nav import _split_lines, read_source_text
from gnssatt.gnss.time import GpsTime

__all__ = ["FrequencyPattern", "AntennaPattern", "read_antex", "write_antex", "summarize_antex"]

_F_RE = re.compile(r" *(?:[+-]?(?:[0-9]+\.[0-9]*|\.[0-9]+|[0-9]+)|NaN|nan) *")
_INT_RE = re.compile(r" *[+-]?[0-9]+ *")
_FREQ_RE = re.compile(r"[A-Z][ 0-9][0-9]")


def _arr_eq(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=True))


@dataclass(eq=False)
class FrequencyPattern:
    """One frequency block of an antenna (or its RMS block).

    - `code`: 'G01', 'E05', ... (system letter + frequency number, ANTEX 1.4 Table "frequency codes").
    - `neu_mm`: (3,) phase-centre offset north, east, up (receiver antennas; x, y, z for satellite antennas), mm.
    - `noazi_mm`: (n_zen,) non-azimuth-dependent PCV at zenith ZEN1, ZEN1+DZEN, ..., ZEN2, mm.
    - `pcv_mm`: (n_azi, n_zen) PCV at azimuth 0, DAZI, ..., 360 (rows) and the zeniths above (columns), mm;
      None when DAZI = 0.
    """

    code: str
    neu_mm: np.ndarray
    noazi_mm: np.ndarray
    pcv_mm: np.ndarray | None = None

    def __eq__(self, other) -> bool:
        return (isinstance(other, FrequencyPattern) and self.code == other.code
                and _arr_eq(self.neu_mm, other.neu_mm) and _arr_eq(self.noazi_mm, other.noazi_mm)
                and _arr_eq(self.pcv_mm, other.pcv_mm))


@dataclass(eq=False)
class AntennaPattern:
    """One ANTEX antenna block.

    - `antenna_type` (A20, radome in columns 17-20 included, trailing blanks removed), `serial` (A20; for
      satellites the PRN such as 'G01'), `svn_code` (A10), `cospar_id` (A10).
    - `method`, `agency`, `n_individual` (None when blank), `date` (as written): METH / BY / # / DATE.
    - `dazi_deg` (0 = no azimuth dependence), `zen1_deg`, `zen2_deg`, `dzen_deg`: the grid, degrees.
    - `valid_from`, `valid_until`: GpsTime or None. `sinex_code`: str ('' if absent).
    - `comments`: COMMENT lines inside the block. `frequencies`, `rms`: lists of `FrequencyPattern`.
    Properties: `zenith_deg` (n_zen,), `azimuth_deg` (n_azi,) or empty.
    """

    antenna_type: str
    serial: str = ""
    svn_code: str = ""
    cospar_id: str = ""
    method: str = ""
    agency: str = ""
    n_individual: int | None = None
    date: str = ""
    dazi_deg: float = 0.0
    zen1_deg: float = 0.0
    zen2_deg: float = 90.0
    dzen_deg: float = 5.0
    valid_from: GpsTime | None = None
    valid_until: GpsTime | None = None
    sinex_code: str = ""
    comments: list[str] = field(default_factory=list)
    frequencies: list[FrequencyPattern] = field(default_factory=list)
    rms: list[FrequencyPattern] = field(default_factory=list)

    @property
    def zenith_deg(self) -> np.ndarray:
        n = int(round((self.zen2_deg - self.zen1_deg) / self.dzen_deg)) + 1
        return self.zen1_deg + self.dzen_deg * np.arange(n)

    @property
    def azimuth_deg(self) -> np.ndarray:
        if self.dazi_deg <= 0:
            return np.zeros(0)
        return self.dazi_deg * np.arange(int(round(360.0 / self.dazi_deg)) + 1)

    def __eq__(self, other) -> bool:
        if not isinstance(other, AntennaPattern):
            return False
        for name in ("antenna_type", "serial", "svn_code", "cospar_id", "method", "agency", "n_individual",
                     "date", "dazi_deg", "zen1_deg", "zen2_deg", "dzen_deg", "sinex_code", "comments",
                     "frequencies", "rms"):
            if getattr(self, name) != getattr(other, name):
                return False
        for name in ("valid_from", "valid_until"):
            a, b = getattr(self, name), getattr(other, name)
            if (a is None) != (b is None) or (a is not None and not bool(np.all(a == b))):
                return False
        return True


# --- reading ------------------------------------------------------------------------------------------

class _Reader:
    def __init__(self, name, lines):
        self.name = name
        self.lines = lines
        self.counts: dict[str, list] = {}

    def warn(self, code: str, message: str, line_no: int | None) -> None:
        """A quirk read as documented in docs/reader_policy.md; a repeated code is counted (first message kept)."""
        self.counts.setdefault(code, [0, line_no, message])[0] += 1

    def flush(self) -> list[ParseWarning]:
        return [ParseWarning(code, f"{msg} ({n} time{'s' if n != 1 else ''})", ln)
                for code, (n, ln, msg) in self.counts.items()]

    def err(self, i, expected, column=None):
        return ParseError(self.name, i + 1, expected, self.lines[i] if i < len(self.lines) else "<end of file>",
                          column)

    def flt(self, i, a, b, what):
        t = self.lines[i][a:b]
        if _F_RE.fullmatch(t) is None:
            raise self.err(i, f"{what}: a number in columns {a + 1}-{b}", a + 1)
        return float(t)

    def int_(self, i, a, b, what, blank_ok=False):
        t = self.lines[i][a:b]
        if blank_ok and not t.strip():
            return None
        if _INT_RE.fullmatch(t) is None:
            raise self.err(i, f"{what}: an integer in columns {a + 1}-{b}", a + 1)
        return int(t)

    def values(self, i, start, n, what):
        ln = self.lines[i]
        out = np.empty(n)
        for k in range(n):
            a = start + 8 * k
            out[k] = self.flt(i, a, a + 8, f"{what} value {k + 1} of {n} (F8.2)")
        if ln[start + 8 * n:].strip():
            raise self.err(i, f"{what}: exactly {n} F8.2 values (ZEN1/ZEN2/DZEN), nothing after column "
                           f"{start + 8 * n}", start + 8 * n + 1)
        return out


def _label(line: str) -> str:
    return line[60:80].strip()


def _epoch(r: _Reader, i: int, what: str) -> GpsTime:
    y = r.int_(i, 0, 6, f"{what} year")
    mo = r.int_(i, 6, 12, f"{what} month")
    d = r.int_(i, 12, 18, f"{what} day")
    h = r.int_(i, 18, 24, f"{what} hour")
    mi = r.int_(i, 24, 30, f"{what} minute")
    s = r.flt(i, 30, 43, f"{what} second (F13.7)")
    if not (1980 <= y <= 2200 and 1 <= mo <= 12 and 1 <= d <= 31 and 0 <= h <= 24 and 0 <= mi <= 60
            and 0 <= s <= 61):
        raise r.err(i, f"a valid {what} date (5I6,F13.7)", 1)
    return GpsTime.from_calendar(y, mo, d, h, mi, s)


def _read_frequency(r: _Reader, i: int, ant: AntennaPattern, end_label: str):
    """Parse one frequency (or RMS) block starting at line i (its START line); return (pattern, next index)."""
    code_txt = r.lines[i][3:6]
    if _FREQ_RE.fullmatch(code_txt) is None:
        raise r.err(i, "a frequency code (3X,A1,I2 such as '   G01')", 4)
    code = f"{code_txt[0]}{int(code_txt[1:]):02d}"
    zen = ant.zenith_deg
    azi = ant.azimuth_deg
    n_zen = len(zen)
    neu = None
    noazi = None
    rows: list[np.ndarray] = []
    i += 1
    while i < len(r.lines):
        ln = r.lines[i]
        lab = _label(ln)
        if lab == end_label:
            if ln[3:6] != code_txt:
                raise r.err(i, f"'{end_label}' of frequency {code_txt.strip()}", 4)
            if neu is None or noazi is None:
                raise r.err(i, "NORTH / EAST / UP and a NOAZI row before the end of the frequency block")
            if ant.dazi_deg > 0 and not rows:
                # quirk (gnssant_ext.atx): DAZI > 0 but only the NOAZI row; it is the whole pattern then
                r.warn("azimuth-rows-missing", f"frequency {code} of {ant.antenna_type!r} has no azimuth rows "
                       f"although DAZI is {ant.dazi_deg:g}: its NOAZI row is used for every azimuth", i + 1)
            elif ant.dazi_deg > 0 and len(rows) != len(azi):
                raise r.err(i, f"{len(azi)} azimuth rows (0 to 360 by DAZI {ant.dazi_deg})")
            pcv = np.vstack(rows) if rows else None
            return FrequencyPattern(code, neu, noazi, pcv), i + 1
        if lab == "NORTH / EAST / UP":
            neu = np.array([r.flt(i, 10 * k, 10 * k + 10, "NORTH / EAST / UP (3F10.2)") for k in range(3)])
        elif ln[3:8] == "NOAZI":
            if ln[:3].strip():
                raise r.err(i, "a NOAZI row '   NOAZI' (3X,A5,mF8.2)", 1)
            noazi = r.values(i, 8, n_zen, "NOAZI")
        elif lab in ("START OF FREQUENCY", "START OF FREQ RMS", "END OF ANTENNA", "START OF ANTENNA"):
            raise r.err(i, f"'{end_label}' before a new block")
        elif ln.strip() and not (lab == "COMMENT"):
            if ant.dazi_deg <= 0:
                raise r.err(i, "no azimuth rows when DAZI is 0.0", 1)
            if noazi is None:
                raise r.err(i, "the NOAZI row before the azimuth rows", 1)
            a = r.flt(i, 0, 8, "azimuth (F8.1)")
            k = len(rows)
            if k >= len(azi) or abs(a - azi[k]) > 1e-6:
                raise r.err(i, f"the azimuth row for {azi[k] if k < len(azi) else 'none (past 360)'} deg", 1)
            rows.append(r.values(i, 8, n_zen, f"azimuth {a:g} row"))
        i += 1
    raise r.err(len(r.lines) - 1, f"'{end_label}' of frequency {code}")


def _parse(source, name):
    text, display = read_source_text(source, name)
    lines = _split_lines(text)
    r = _Reader(display, lines)
    if not lines or _label(lines[0]) != "ANTEX VERSION / SYST":
        raise r.err(0, "'ANTEX VERSION / SYST' in columns 61-80 of the first line", 61)
    version = r.flt(0, 0, 8, "ANTEX version (F8.1)")
    if not 1.0 <= version < 2.0:
        raise r.err(0, "ANTEX version 1.x", 1)
    header = {"version": version, "system": lines[0][20:21].strip(), "pcv_type": "", "ref_antenna": "",
              "ref_serial": "", "comments": []}
    i = 1
    while i < len(lines) and _label(lines[i]) != "END OF HEADER":
        ln = lines[i]
        lab = _label(ln)
        if lab == "PCV TYPE / REFANT":
            header["pcv_type"] = ln[0:1]
            if header["pcv_type"] not in ("A", "R"):
                raise r.err(i, "PCV type 'A' (absolute) or 'R' (relative) in column 1", 1)
            header["ref_antenna"] = ln[20:40].rstrip()
            header["ref_serial"] = ln[40:60].rstrip()
        elif lab == "COMMENT":
            header["comments"].append(ln[:60].rstrip())
        i += 1
    if i >= len(lines):
        raise r.err(len(lines) - 1 if lines else 0, "an 'END OF HEADER' line")
    i += 1
    patterns: list[AntennaPattern] = []
    while i < len(lines):
        ln = lines[i]
        lab = _label(ln)
        if not ln.strip():
            i += 1
            continue
        if lab != "START OF ANTENNA":
            raise r.err(i, "'START OF ANTENNA' (columns 61-80)", 61)
        i, ant = _read_antenna(r, i + 1)
        patterns.append(ant)
    return header, patterns, r.flush()


def _read_antenna(r: _Reader, i: int):
    lines = r.lines
    ant = None
    n_freq_declared = None
    freqs: list[FrequencyPattern] = []
    rms: list[FrequencyPattern] = []
    grid_seen = {"DAZI": False, "ZEN1 / ZEN2 / DZEN": False}
    while i < len(lines):
        ln = lines[i]
        lab = _label(ln)
        if lab == "TYPE / SERIAL NO":
            ant = AntennaPattern(antenna_type=ln[0:20].rstrip(), serial=ln[20:40].rstrip(),
                                 svn_code=ln[40:50].rstrip(), cospar_id=ln[50:60].rstrip())
        elif ant is None and lab not in ("COMMENT",):
            raise r.err(i, "'TYPE / SERIAL NO' as the first line of an antenna block", 61)
        elif lab == "METH / BY / # / DATE":
            ant.method, ant.agency = ln[0:20].rstrip(), ln[20:40].rstrip()
            ant.n_individual = r.int_(i, 40, 46, "number of individual antennas (I6)", blank_ok=True)
            ant.date = ln[50:60].rstrip()
        elif lab == "DAZI":
            ant.dazi_deg = r.flt(i, 2, 8, "DAZI (2X,F6.1)")
            if ant.dazi_deg < 0 or ant.dazi_deg > 360 or (ant.dazi_deg > 0 and
                                                          abs(360.0 / ant.dazi_deg - round(360.0 / ant.dazi_deg))
                                                          > 1e-9):
                raise r.err(i, "DAZI 0.0 or a divisor of 360 degrees", 3)
            grid_seen["DAZI"] = True
        elif lab == "ZEN1 / ZEN2 / DZEN":
            ant.zen1_deg = r.flt(i, 2, 8, "ZEN1 (2X,3F6.1)")
            ant.zen2_deg = r.flt(i, 8, 14, "ZEN2")
            ant.dzen_deg = r.flt(i, 14, 20, "DZEN")
            span = ant.zen2_deg - ant.zen1_deg
            if ant.dzen_deg <= 0 or span < 0 or span > 180 or abs(span / ant.dzen_deg - round(span / ant.dzen_deg)) > 1e-9:
                raise r.err(i, "ZEN1 <= ZEN2 and (ZEN2 - ZEN1) a multiple of DZEN > 0", 3)
            grid_seen["ZEN1 / ZEN2 / DZEN"] = True
        elif lab == "# OF FREQUENCIES":
            n_freq_declared = r.int_(i, 0, 6, "# OF FREQUENCIES (I6)")
        elif lab == "VALID FROM":
            ant.valid_from = _epoch(r, i, "VALID FROM")
        elif lab == "VALID UNTIL":
            ant.valid_until = _epoch(r, i, "VALID UNTIL")
        elif lab == "SINEX CODE":
            ant.sinex_code = ln[0:10].rstrip()
        elif lab == "COMMENT":
            if ant is not None:
                ant.comments.append(ln[:60].rstrip())
        elif lab in ("START OF FREQUENCY", "START OF FREQ RMS"):
            missing = [k for k, v in grid_seen.items() if not v]
            if missing:
                raise r.err(i, f"{' and '.join(missing)} before the first frequency block")
            end_label = "END OF FREQUENCY" if lab == "START OF FREQUENCY" else "END OF FREQ RMS"
            fp, i = _read_frequency(r, i, ant, end_label)
            (freqs if lab == "START OF FREQUENCY" else rms).append(fp)
            continue
        elif lab == "END OF ANTENNA":
            if ant is None:
                raise r.err(i, "'TYPE / SERIAL NO' before 'END OF ANTENNA'")
            if n_freq_declared is None:
                raise r.err(i, "'# OF FREQUENCIES' in the antenna block")
            _check_frequency_count(r, i, ant, n_freq_declared, freqs)
            ant.frequencies, ant.rms = freqs, rms
            return i + 1, ant
        elif lab == "START OF ANTENNA":
            if ant is None or not freqs or n_freq_declared is None:
                raise r.err(i, "'END OF ANTENNA' before the next 'START OF ANTENNA'", 61)
            # quirk (igs14_small.atx): a complete block whose END OF ANTENNA line is missing
            r.warn("missing-end-of-antenna", f"antenna {ant.antenna_type!r} ends without 'END OF ANTENNA'; it was "
                   f"closed at the next 'START OF ANTENNA'", i + 1)
            _check_frequency_count(r, i, ant, n_freq_declared, freqs)
            ant.frequencies, ant.rms = freqs, rms
            return i, ant
        elif ln.strip():
            raise r.err(i, "an antenna-block header line (label in columns 61-80)", 61)
        i += 1
    raise r.err(len(lines) - 1, "'END OF ANTENNA'")


def _check_frequency_count(r: _Reader, i: int, ant: AntennaPattern, n_declared: int, freqs: list) -> None:
    """'# OF FREQUENCIES' against the blocks present: a disagreement is a quirk (the blocks are what is read)."""
    if n_declared != len(freqs):
        r.warn("frequency-count-mismatch", f"antenna {ant.antenna_type!r}: '# OF FREQUENCIES' says {n_declared}, "
               f"the block holds {len(freqs)} frequency blocks (those are read)", i + 1)


def read_antex(source, *, name: str | None = None, warnings: list | None = None) -> list[AntennaPattern]:
    """The antenna blocks of an ANTEX 1.x file (path or bytes, any supported compression), in file order.

    Raises `ParseError` with the line and the expected layout for a broken file; quirks read anyway
    (docs/reader_policy.md) are appended as `ParseWarning`s to `warnings` when a list is given.
    Implements: ANTEX 1.4 (module docstring).
    """
    header, patterns, found = _parse(source, name)
    if warnings is not None:
        warnings.extend(found)
    return patterns


# --- writing ------------------------------------------------------------------------------------------

def _line(content: str, label: str) -> str:
    """One labelled line: content in columns 1-60 (cut at 60), label in columns 61-80."""
    return f"{content:<60.60s}{label:<20s}\n"


def _f8(v: float) -> str:
    return "     NaN" if np.isnan(v) else f"{v:8.2f}"


def _epoch_text(t: GpsTime) -> str:
    y, mo, d, h, mi, s = (np.asarray(v).item() for v in t.calendar())
    return f"{int(y):6d}{int(mo):6d}{int(d):6d}{int(h):6d}{int(mi):6d}{float(s):13.7f}"


def write_antex(patterns: list[AntennaPattern], *, pcv_type: str = "A", system: str = "M",
                comments: tuple[str, ...] = ()) -> str:
    """ANTEX 1.4 text of `patterns` (values rounded to the format's 0.01 mm; NaN written as 'NaN').

    Raises ValueError when a text field is longer than its fixed-width column (it would not read back).

    Args:
        patterns: antenna blocks; pcv_type: 'A' absolute or 'R' relative; system: header system letter;
        comments: header COMMENT lines (each <= 60 characters).
    Implements: ANTEX 1.4 layout (module docstring), the inverse of `read_antex`.
    """
    for a in patterns:
        for fname, width in (("antenna_type", 20), ("serial", 20), ("svn_code", 10), ("cospar_id", 10),
                             ("method", 20), ("agency", 20), ("date", 10), ("sinex_code", 10)):
            if len(getattr(a, fname)) > width:
                raise ValueError(f"{fname} {getattr(a, fname)!r} is longer than its ANTEX field ({width} columns)")
        if any(len(c) > 60 for c in a.comments):
            raise ValueError("ANTEX COMMENT lines hold at most 60 characters")
    out = [_line(f"{1.4:8.1f}            {system:1s}", "ANTEX VERSION / SYST"),
           _line(f"{pcv_type:1s}", "PCV TYPE / REFANT")]
    out += [_line(c, "COMMENT") for c in comments]
    out.append(_line("", "END OF HEADER"))
    for a in patterns:
        out.append(_line("", "START OF ANTENNA"))
        out.append(_line(f"{a.antenna_type:<20.20s}{a.serial:<20.20s}{a.svn_code:<10.10s}{a.cospar_id:<10.10s}",
                         "TYPE / SERIAL NO"))
        n_ind = "" if a.n_individual is None else str(a.n_individual)
        out.append(_line(f"{a.method:<20.20s}{a.agency:<20.20s}{n_ind:>6s}    {a.date:<10.10s}",
                         "METH / BY / # / DATE"))
        out.append(_line(f"  {a.dazi_deg:6.1f}", "DAZI"))
        out.append(_line(f"  {a.zen1_deg:6.1f}{a.zen2_deg:6.1f}{a.dzen_deg:6.1f}", "ZEN1 / ZEN2 / DZEN"))
        out.append(_line(f"{len(a.frequencies):6d}", "# OF FREQUENCIES"))
        if a.valid_from is not None:
            out.append(_line(_epoch_text(a.valid_from), "VALID FROM"))
        if a.valid_until is not None:
            out.append(_line(_epoch_text(a.valid_until), "VALID UNTIL"))
        if a.sinex_code:
            out.append(_line(f"{a.sinex_code:<10.10s}", "SINEX CODE"))
        out += [_line(c, "COMMENT") for c in a.comments]
        azi = a.azimuth_deg
        for blocks, start, end in ((a.frequencies, "START OF FREQUENCY", "END OF FREQUENCY"),
                                   (a.rms, "START OF FREQ RMS", "END OF FREQ RMS")):
            for fp in blocks:
                code = f"   {fp.code[0]}{int(fp.code[1:]):2d}"
                out.append(_line(code, start))
                out.append(_line("".join(f"{v:10.2f}" for v in fp.neu_mm), "NORTH / EAST / UP"))
                out.append("   NOAZI" + "".join(_f8(v) for v in fp.noazi_mm) + "\n")
                if fp.pcv_mm is not None:
                    for az, row in zip(azi, fp.pcv_mm):
                        out.append(f"{az:8.1f}" + "".join(_f8(v) for v in row) + "\n")
                out.append(_line(code, end))
        out.append(_line("", "END OF ANTENNA"))
    return "".join(out)


def summarize_antex(source, *, name: str | None = None) -> dict:
    """JSON-ready summary of an ANTEX file for upload validation (ParseError if broken)."""
    header, pats, warnings = _parse(source, name)
    return {
        "format": "ANTEX",
        "version": header["version"],
        "pcv_type": header["pcv_type"],
        "n_antennas": len(pats),
        "antennas": [{"type": p.antenna_type, "serial": p.serial,
                      "frequencies": [f.code for f in p.frequencies],
                      "azimuth_dependent": p.dazi_deg > 0} for p in pats[:200]],
        "warnings": [w.to_dict() for w in warnings],
    }
