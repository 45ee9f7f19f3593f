"""RINEX clock files (2.00, 3.00-3.04): satellite (AS) and receiver (AR) clock offsets as time x id arrays.

`read_rinex_clock(source)` returns `ClockData` with satellite clocks `clock_s (n_epochs, n_sats)` and, kept
separately, receiver clocks `receiver_clock_s (n_receiver_epochs, n_receivers)`; NaN where an id has no record at
an epoch. The parse is vectorised: the data lines are cut into fixed columns as one numpy byte matrix, so a 24 h
30-s CODE file (~120 000 records) takes well under a second.

Implements: RINEX clock 2.00 (Ray & Gurtner 1999) and 3.04 (IGS 2017), data record `A2,1X,A4|A9,1X,I4,4(1X,I2),
F10.6,I3,3X,2(E19.12,1X)` - the clock name is A4 up to 3.02 and A9 from 3.04 on (everything after shifts by 5
columns); values 1-2 (clock bias s, its sigma s) on the first line, values 3-6 on a continuation line (read
past; rate/acceleration are not used here). Record types CR, DR, MS are counted and skipped.
Neglects: clock rates/accelerations (values 3-6); satellite clock epochs in a time system other than GPS are
converted (UTC + leap seconds, TAI - 19 s, BDT + 14 s) with a warning.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.io.errors import ParseError, ParseWarning
from gnssatt.gnss.io.rinex_nav import gps_minus_utc_s, read_source_text
from gnssatt.gnss.time import GpsTime

__all__ = ["ClockData", "read_rinex_clock", "summarize_rinex_clock"]

_RECORD_TYPES = (b"AR", b"AS", b"CR", b"DR", b"MS")
_DIGITS = np.frombuffer(b"0123456789 ", dtype=np.uint8)
_FLOAT_CHARS = np.frombuffer(b"0123456789 .+-Ee", dtype=np.uint8)


@dataclass
class ClockData:
    """A RINEX clock file.

    - `time` (n_epochs,) GpsTime of satellite (AS) records; `sats` ids ('G01'); `clock_s`, `sigma_s`
      (n_epochs, n_sats) seconds, NaN where absent (sigma also NaN when the record has only one value).
    - `receiver_time`, `receivers` (station names as written), `receiver_clock_s`, `receiver_sigma_s`: the same
      for AR records.
    - `version`, `time_system` (as written, 'GPS' if absent), `analysis_center`, `leap_seconds`,
      `data_types` (from '# / TYPES OF DATA'), `skipped` (record type -> count), `warnings`.
    """

    name: str
    version: float
    time_system: str
    analysis_center: str
    leap_seconds: int | None
    data_types: list[str]
    time: GpsTime
    sats: list[str]
    clock_s: np.ndarray
    sigma_s: np.ndarray
    receiver_time: GpsTime
    receivers: list[str]
    receiver_clock_s: np.ndarray
    receiver_sigma_s: np.ndarray
    skipped: dict[str, int] = field(default_factory=dict)
    warnings: list[ParseWarning] = field(default_factory=list)


def _version_line(name: str, lines: list[bytes]) -> tuple[float, int]:
    """(version, label column) of line 1: labels in columns 61-80 (2.00-3.02, and 3.04 files written that way)
    or in columns 66-85 with the file type in column 22 (the RINEX clock 3.04 layout: F4.2,17X,A1,20X,A1)."""
    first = lines[0].decode("latin-1") if lines else ""
    if first[60:80].strip() == "RINEX VERSION / TYPE":
        label_col, type_col = 60, 20
    elif first[65:85].strip() == "RINEX VERSION / TYPE":
        label_col, type_col = 65, 21
    else:
        raise ParseError(name, 1, "'RINEX VERSION / TYPE' in columns 61-80 (RINEX clock 2.00-3.02) or 66-85 (3.04) "
                         "of the first line", first, 61)
    try:
        version = float(first[0:9])
    except ValueError:
        raise ParseError(name, 1, "the format version (F9.2, or F4.2 in 3.04) in columns 1-9", first, 1) from None
    if not (2.0 <= version < 4.0) or first[type_col:type_col + 1] != "C":
        raise ParseError(name, 1, f"a RINEX clock file: version 2.xx or 3.0x in columns 1-9 and 'C' in column "
                         f"{type_col + 1}", first, 1)
    if label_col == 65 and version < 3.04:
        raise ParseError(name, 1, "header labels in columns 66-85 only from RINEX clock 3.04 on", first, 66)
    return version, label_col


def _header(name: str, lines: list[bytes]):
    version, label_col = _version_line(name, lines)
    time_system, ac, leap, types = "GPS", "", None, []
    odd: list[tuple[str, str, int]] = []   # (code, message, line) of header quirks
    for i in range(0, len(lines)):
        ln = lines[i].decode("latin-1")
        label = ln[label_col:].strip()
        if len(ln) > label_col + 20 and ln[label_col + 20:].strip():
            odd.append(("header-text-beyond-label", f"text after column {label_col + 20} of a header line "
                        "(ignored)", i + 1))
            label = ln[label_col:label_col + 20].strip()
        if "\t" in ln or not label:
            odd.append(("header-line-without-label", "a header line without a label (ignored)", i + 1))
        if label == "END OF HEADER" or ln[65:].strip() == "END OF HEADER":
            if not types:
                odd.append(("missing-header-record", "no '# / TYPES OF DATA' header record", i + 1))
            return version, time_system, ac, leap, types, i, odd
        if label == "TIME SYSTEM ID":
            time_system = ln[0:6].strip() or "GPS"
        elif label == "ANALYSIS CENTER":
            ac = ln[0:3].strip()
        elif label == "LEAP SECONDS":
            try:
                leap = int(ln[0:6])
            except ValueError:
                pass
        elif label == "# / TYPES OF DATA":
            types += ln[6:60].split()
    raise ParseError(name, len(lines), "an 'END OF HEADER' line", lines[-1].decode("latin-1") if lines else "")


def _bad_line(name, rows, line_nos, bad_mask, expected, lines_all):
    r = int(np.argmax(bad_mask))
    ln = int(line_nos[r])
    return ParseError(name, ln, expected, lines_all[ln - 1].decode("latin-1"))


def _parse_records(name: str, recs: list[bytes], line_nos: np.ndarray, shift: int, lines_all):
    """(GpsTime (n,), names (n,) bytes, value1 (n,), value2 (n,) NaN if absent) of record lines, vectorised."""
    n = len(recs)
    if n == 0:
        return GpsTime(np.zeros(0, dtype=np.int64)), np.zeros(0, dtype="S9"), np.zeros(0), np.zeros(0), 0
    width = max(max(len(r) for r in recs), 79 + shift)
    m = np.frombuffer(b"".join(r.ljust(width) for r in recs), dtype=np.uint8).reshape(n, width)
    s = shift
    int_cols = [(8 + s, 12 + s, "year (I4)"), (13 + s, 15 + s, "month (I2)"), (16 + s, 18 + s, "day (I2)"),
                (19 + s, 21 + s, "hour (I2)"), (22 + s, 24 + s, "minute (I2)"), (34 + s, 37 + s,
                                                                                  "number of values (I3)")]
    ints = []
    for a, b, what in int_cols:
        block = m[:, a:b]
        bad = ~np.isin(block, _DIGITS).all(axis=1) | (block == 32).all(axis=1)
        if bad.any():
            raise _bad_line(name, recs, line_nos, bad, f"epoch {what} in columns {a + 1}-{b}", lines_all)
        digits = np.where(block == 32, 0, block.astype(np.int64) - 48)
        val = np.zeros(n, dtype=np.int64)
        for k in range(b - a):
            val = val * 10 + digits[:, k]
        ints.append(val)
    y, mo, d, h, mi, nval = ints
    bad = (mo < 1) | (mo > 12) | (d < 1) | (d > 31) | (h > 24) | (mi > 60) | (y < 1980) | (nval < 1) | (nval > 6)
    if bad.any():
        raise _bad_line(name, recs, line_nos, bad, "a valid epoch and 1-6 data values", lines_all)

    def floats(a, b, rows, what):
        block = m[rows, a:b].copy()
        block[block == ord("D")] = ord("E")
        bad_chars = ~np.isin(block, _FLOAT_CHARS).all(axis=1) | (block == 32).all(axis=1)
        if bad_chars.any():
            raise _bad_line(name, recs, line_nos[rows], bad_chars, f"{what} in columns {a + 1}-{b}", lines_all)
        try:
            return np.ascontiguousarray(block).view(f"S{b - a}").ravel().astype(np.float64)
        except ValueError:
            for r in range(len(block)):
                try:
                    float(bytes(block[r]))
                except ValueError:
                    ln = int(line_nos[rows][r])
                    raise ParseError(name, ln, f"{what} in columns {a + 1}-{b}",
                                     lines_all[ln - 1].decode("latin-1"), a + 1) from None
            raise
    misplaced = _misplaced_values(m, nval, s)
    sec = floats(24 + s, 34 + s, np.arange(n), "epoch seconds (F10.6)")
    if np.any((sec < 0) | (sec > 61)):
        raise _bad_line(name, recs, line_nos, (sec < 0) | (sec > 61), "epoch seconds 0-60", lines_all)
    v1 = floats(40 + s, 59 + s, np.arange(n), "clock bias (E19.12)")
    v2 = np.full(n, np.nan)
    two = np.flatnonzero(nval >= 2)
    if two.size:
        v2[two] = floats(60 + s, 79 + s, two, "clock bias sigma (E19.12)")
    for r in np.flatnonzero(misplaced):
        v1[r], v2[r] = _values_by_tokens(name, recs[r], int(line_nos[r]), int(nval[r]), s)
    names = np.ascontiguousarray(m[:, 3:3 + 4 + s]).view(f"S{4 + s}").ravel()
    t = GpsTime.from_calendar(y, mo, d, h, mi, sec)
    return t, names, v1, v2, int(misplaced.sum())


def _misplaced_values(m: np.ndarray, nval: np.ndarray, s: int) -> np.ndarray:
    """Rows whose E19.12 values are not in their columns (a non-blank just before or after a field): read by
    whitespace-separated tokens instead, so a value one column off is never cut into a wrong number."""
    def edge_not_blank(col: int) -> np.ndarray:
        return m[:, col] != 32 if col < m.shape[1] else np.zeros(len(m), bool)
    bad = edge_not_blank(39 + s) | edge_not_blank(59 + s)
    bad |= (nval >= 2) & edge_not_blank(79 + s)
    return bad


def _values_by_tokens(name: str, rec: bytes, line_no: int, nval: int, s: int) -> tuple[float, float]:
    """(value 1, value 2 or NaN) of a record whose values are misplaced but unambiguous: min(nval, 2) numbers."""
    toks = rec[37 + s:].replace(b"D", b"E").split()
    want = min(nval, 2)
    try:
        vals = [float(t) for t in toks]
    except ValueError:
        vals = []
    if len(vals) != want:
        raise ParseError(name, line_no, f"{want} clock value(s) (E19.12) after the number of values, in columns "
                         f"{41 + s}-{59 + s}" + (f" and {61 + s}-{79 + s}" if want == 2 else ""),
                         rec.decode("latin-1"), 41 + s)
    return vals[0], (vals[1] if want == 2 else np.nan)


def _to_matrix(name, t: GpsTime, names, v1, v2, line_nos, lines_all):
    key = t.s * 1_000_000 + np.round(t.frac * 1e6).astype(np.int64)   # microsecond epoch key
    ukey, e_idx = np.unique(key, return_inverse=True)
    unames, s_idx = np.unique(names, return_inverse=True)
    pair = e_idx.astype(np.int64) * len(unames) + s_idx
    order = np.argsort(pair, kind="stable")
    dup = np.flatnonzero(np.diff(pair[order]) == 0)
    if dup.size:
        ln = int(line_nos[order[dup[0] + 1]])
        raise ParseError(name, ln, "one record per clock name and epoch (this one repeats an earlier record)",
                         lines_all[ln - 1].decode("latin-1"))
    clk = np.full((len(ukey), len(unames)), np.nan)
    sig = np.full((len(ukey), len(unames)), np.nan)
    clk[e_idx, s_idx] = v1
    sig[e_idx, s_idx] = v2
    first = np.zeros(len(ukey), dtype=np.int64)
    first[e_idx[::-1]] = np.arange(len(e_idx))[::-1]
    times = t[first] if len(ukey) else GpsTime(np.zeros(0, dtype=np.int64))
    return times, [u.decode("latin-1").strip() for u in unames], clk, sig


def _norm_sat(s: str) -> str:
    """'G 1' -> 'G01'; anything else unchanged (only ASCII digits count: str.strip() also eats control characters
    such as \\x1c and str.isdigit() accepts '²', neither of which int() takes)."""
    rest = s[1:].strip(" ")
    if len(s) >= 2 and s[0].isalpha() and rest.isascii() and rest.isdigit():
        return f"{s[0]}{int(rest):02d}"
    return s


def read_rinex_clock(source, *, name: str | None = None) -> ClockData:
    """Satellite (AS) and receiver (AR) clocks of a RINEX clock 2.00/3.0x file (path or bytes, any compression).

    Returns `ClockData` (see its docstring). Raises `ParseError` naming the line for a broken record.
    Implements: RINEX clock 2.00 / 3.04 data records (module docstring).
    """
    text, display = read_source_text(source, name)
    raw = text.encode("latin-1")
    lines = raw.split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    lines = [ln[:-1] if ln.endswith(b"\r") else ln for ln in lines]
    version, time_system, ac, leap, types, end, odd = _header(display, lines)
    shift = 5 if version >= 3.04 else 0
    body = lines[end + 1:]
    heads = [ln[:2] for ln in body]
    as_idx = [i for i, h in enumerate(heads) if h == b"AS"]
    ar_idx = [i for i, h in enumerate(heads) if h == b"AR"]
    skipped: dict[str, int] = {}
    prev_n = 0
    for i, (h, ln) in enumerate(zip(heads, body)):
        if h in (b"AS", b"AR"):
            continue
        if h in _RECORD_TYPES:
            k = h.decode()
            skipped[k] = skipped.get(k, 0) + 1
            continue
        if not ln.strip():
            continue
        # A continuation line (values 3-6) follows a record with more than 2 values: blank-led numbers.
        prev = body[i - 1] if i else b""
        if prev[:2] in _RECORD_TYPES and ln[:1] in (b" ", b"-") and len(prev) >= 37:
            continue
        prev_n += 1
        raise ParseError(display, end + 2 + i, "a clock record (AR, AS, CR, DR, MS in columns 1-2) or the "
                         "continuation line of the record before it", ln.decode("latin-1"), 1)
    counted: dict[str, list] = {}
    for code, msg, ln in odd:   # one warning per code, counted (first line kept)
        counted.setdefault(code, [0, msg, ln])[0] += 1
    warnings = [ParseWarning(code, f"{msg} ({n} time{'s' if n != 1 else ''})", ln)
                for code, (n, msg, ln) in counted.items()]
    if not as_idx and not ar_idx:
        warnings.append(ParseWarning("no-records", "the file holds no AS or AR clock record", end + 1))
    base = end + 2  # 1-based line number of body[0]
    as_lines = np.array(as_idx, dtype=np.int64) + base
    ar_lines = np.array(ar_idx, dtype=np.int64) + base
    for rec_lines, idx in ((as_lines, as_idx), (ar_lines, ar_idx)):
        short = [i for i in idx if len(body[i]) < 59 + shift]
        if short:
            raise ParseError(display, base + short[0], f"a clock record of at least {59 + shift} columns (epoch, "
                             "number of values, E19.12 clock bias)", body[short[0]].decode("latin-1"))
    t_as, n_as, v1_as, v2_as, mis_as = _parse_records(display, [body[i] for i in as_idx], as_lines, shift, lines)
    t_ar, n_ar, v1_ar, v2_ar, mis_ar = _parse_records(display, [body[i] for i in ar_idx], ar_lines, shift, lines)
    if mis_as + mis_ar:
        warnings.append(ParseWarning("misplaced-values", f"{mis_as + mis_ar} clock records have values off their "
                                     "E19.12 columns; read as whitespace-separated numbers",
                                     int((as_lines if mis_as else ar_lines)[0])))
    ts = time_system.strip().upper()
    if ts in ("UTC", "GLO", "TAI", "BDT"):
        warnings.append(ParseWarning("time-system-converted", f"{ts} epochs converted to GPS time"))
        conv = {"TAI": lambda t: t - 19.0, "BDT": lambda t: t + 14.0}
        f = conv.get(ts, lambda t: GpsTime(t.s + gps_minus_utc_s(t.s), t.frac))
        t_as, t_ar = f(t_as), f(t_ar)
    elif ts not in ("GPS", "GAL", "QZS", "IRN", ""):
        raise ParseError(display, None, "TIME SYSTEM ID GPS/GAL/QZS/BDT/UTC/TAI", time_system)
    time, sats, clk, sig = _to_matrix(display, t_as, n_as, v1_as, v2_as, as_lines, lines)
    rtime, recv, rclk, rsig = _to_matrix(display, t_ar, n_ar, v1_ar, v2_ar, ar_lines, lines)
    sats = [_norm_sat(s) for s in sats]
    if len(set(sats)) != len(sats):
        raise ParseError(display, None, "distinct satellite names", ", ".join(sats))
    order = np.argsort(sats, kind="stable")
    sats = [sats[i] for i in order]
    clk, sig = clk[:, order], sig[:, order]
    for k, v in skipped.items():
        warnings.append(ParseWarning("skipped-records", f"{v} {k} records not read"))
    return ClockData(name=display, version=version, time_system=time_system, analysis_center=ac, leap_seconds=leap,
                     data_types=types, time=time, sats=sats, clock_s=clk, sigma_s=sig, receiver_time=rtime,
                     receivers=recv, receiver_clock_s=rclk, receiver_sigma_s=rsig, skipped=skipped,
                     warnings=warnings)


def summarize_rinex_clock(source, *, name: str | None = None) -> dict:
    """JSON-ready summary of a RINEX clock file for upload validation (ParseError if broken)."""
    c = read_rinex_clock(source, name=name)
    n = len(c.time)
    steps = np.diff(c.time - c.time[0]) if n > 1 else np.zeros(0)
    return {
        "format": "RINEX clock",
        "name": c.name,
        "version": c.version,
        "time_system": c.time_system,
        "analysis_center": c.analysis_center,
        "n_epochs": n,
        "interval_s": float(np.median(steps)) if steps.size else None,
        "satellites": c.sats,
        "n_receivers": len(c.receivers),
        "n_receiver_epochs": len(c.receiver_time),
        "time_span_gps": [c.time[0].iso(3), c.time[n - 1].iso(3)] if n else None,
        "valid_satellite_clocks": int(np.isfinite(c.clock_s).sum()),
        "skipped": dict(c.skipped),
        "warnings": [w.to_dict() for w in c.warnings],
    }
