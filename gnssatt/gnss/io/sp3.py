"""SP3-a/b/c/d precise orbit (and clock) files.

`read_sp3(source)` returns `Sp3Data`: epochs as `GpsTime`, the header's satellite list, positions (ECEF of the
file's coordinate system, metres) and clocks (seconds) as (n_epochs, n_sats[, 3]) arrays with NaN where a value
is absent or flagged bad, velocities when the file has them.

Implements: SP3-a (Remondi 1989), SP3-b (Spofford & Remondi 1998), SP3-c (Hilla 2010), SP3-d (Hilla 2016,
IGS/NGS): line 1 `#cP yyyy mm dd hh mm ss.ssssssss nnnnnnn dddddd ccccc ooo aaaa`, line 2 `##` GPS week/sow/
interval, `+` satellite-id lines (17 ids per line, at least 5 lines; SP3-d: as many as the satellite count needs,
so more than 85 satellites are read, the count being I3 in columns 4-6), `++` accuracy lines, `%c` (file type,
time system in columns 10-12), `%f`, `%i`, `/*` comments (SP3-d: any number), then `*` epoch lines, `P`
position/clock records (km, km, km, microseconds; F14.6 fixed columns), optional `V` velocity records
(dm/s and 1e-4 microseconds/s), `EP`/`EV` correlation records (skipped), `EOF`.

Bad or absent values, as the SP3 formats define them: a position component of 0.000000 (the whole position is
then NaN), a clock of 999999.999999 (or larger), likewise for velocities and clock rates.

Quirks read with a warning (docs/reader_policy.md): an epoch line with seconds 60.000 rolls over into the next
minute; a satellite in the body that the '+' lines do not list is added under its own record id (records are
matched by id, never by position, so nothing is swapped); a listed satellite without any record is dropped;
missing velocity records become NaN; blank lines and lines holding only an elision mark ('   *', the SP3-a
examples) are skipped; blank lines before line 1 are skipped; the oldest SP3 (no version letter in column 2, no
P/V flag in column 3) is read as SP3-a.

Time scale: `time` is GPS time. Files in GAL/QZS/IRN time (steered to GPS) are taken as is; TAI, UTC (GLO taken as
UTC) and BDT epochs are converted (TAI - 19 s; UTC + leap seconds; BDT + 14 s) and a warning says so.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.io.errors import ParseError, ParseWarning
from gnssatt.gnss.io.rinex_nav import _split_lines, gps_minus_utc_s, read_source_text
from gnssatt.gnss.time import GpsTime

__all__ = ["Sp3Data", "read_sp3", "summarize_sp3", "BAD_CLOCK_US"]

#: Clock value that means "bad or absent" (microseconds; SP3-c/d sec. "Bad or absent values").
BAD_CLOCK_US = 999999.0

_F_RE = re.compile(r" *[+-]?(?:[0-9]+\.[0-9]*|\.[0-9]+) *")   # F14.6 (a decimal point is required)
_INT_RE = re.compile(r" *[0-9]+ *")
_SAT_RE = re.compile(r"[A-Z][ 0-9][0-9]|[ ]{2}[0-9]|[ ][ 0-9][0-9]")


@dataclass
class Sp3Data:
    """An SP3 file.

    - `time`: (n_epochs,) GpsTime, strictly increasing.
    - `sats`: satellite ids as listed in the header ('G01', 'R24', 'L09'; SP3-a numbers become 'G..').
    - `position_ecef_m`: (n_epochs, n_sats, 3), metres, in `coordinate_system` (e.g. IGS05); NaN if absent/bad.
    - `clock_s`: (n_epochs, n_sats) satellite clock offset, seconds; NaN if absent/bad.
    - `velocity_ecef_m_s`, `clock_rate_s_s`: same shapes, or None when the file has no velocity records.
    - `version` 'a'..'d', `pos_vel_flag` 'P'/'V', `data_used`, `coordinate_system`, `orbit_type`, `agency`,
      `time_system` (as written; 'GPS' for SP3-a/b), `file_type` ('G', 'R', 'M', ...), `interval_s`,
      `n_epochs_header` (line 1), `comments` (the `/*` lines).
    """

    name: str
    version: str
    pos_vel_flag: str
    time: GpsTime
    sats: list[str]
    position_ecef_m: np.ndarray
    clock_s: np.ndarray
    velocity_ecef_m_s: np.ndarray | None
    clock_rate_s_s: np.ndarray | None
    data_used: str
    coordinate_system: str
    orbit_type: str
    agency: str
    time_system: str
    file_type: str
    interval_s: float
    n_epochs_header: int
    comments: list[str] = field(default_factory=list)
    warnings: list[ParseWarning] = field(default_factory=list)


class _Ctx:
    def __init__(self, name, line_offset: int = 0):
        self.name = name
        self.line_offset = line_offset   # lines skipped before line 1 (leading blank lines)
        self.warnings: list[ParseWarning] = []
        self.counts: dict[str, list] = {}

    def _ln(self, line_no):
        return None if line_no is None else line_no + self.line_offset

    def error(self, line_no, expected, found="", column=None):
        return ParseError(self.name, self._ln(line_no), expected, found, column)

    def warn(self, code, message, line_no):
        self.warnings.append(ParseWarning(code, message, self._ln(line_no)))

    def count(self, code, message, line_no):
        e = self.counts.setdefault(code, [0, self._ln(line_no), message])
        e[0] += 1

    def flush(self):
        for code, (n, ln, msg) in self.counts.items():
            self.warnings.append(ParseWarning(code, f"{msg} ({n} time{'s' if n != 1 else ''})", ln))


def _int(ctx, line, a, b, ln, what):
    t = line[a:b]
    if _INT_RE.fullmatch(t) is None:
        raise ctx.error(ln, f"{what} (integer) in columns {a + 1}-{b}", line, a + 1)
    return int(t)


def _flt(ctx, line, a, b, ln, what):
    t = line[a:b]
    if _F_RE.fullmatch(t) is None:
        raise ctx.error(ln, f"{what} (a fixed-point number) in columns {a + 1}-{b}", line, a + 1)
    return float(t)


def _sat_id(ctx, text: str, ln: int, line: str, col0: int) -> str | None:
    """Normalised id of a 3-character SP3 satellite field; None for an empty slot ('  0')."""
    if _SAT_RE.fullmatch(text) is None:
        raise ctx.error(ln, "a satellite id (A1,I2 such as 'G01', or I3 in SP3-a)", line, col0 + 1)
    if text[0] == " ":
        n = int(text)
        return None if n == 0 else f"G{n:02d}"
    return f"{text[0]}{int(text[1:]):02d}"


def _epoch(ctx, line, ln):
    if len(line) < 31 or line[1:3] != "  ":
        raise ctx.error(ln, "an epoch line '*  yyyy mm dd hh mm ss.ssssssss' (A2,1X,I4,4(1X,I2),1X,F11.8)", line, 1)
    y = _int(ctx, line, 3, 7, ln, "year")
    mo = _int(ctx, line, 8, 10, ln, "month")
    d = _int(ctx, line, 11, 13, ln, "day")
    h = _int(ctx, line, 14, 16, ln, "hour")
    mi = _int(ctx, line, 17, 19, ln, "minute")
    s = _flt(ctx, line, 20, 31, ln, "seconds")
    if not (1980 <= y <= 2200 and 1 <= mo <= 12 and 1 <= d <= 31 and h <= 24 and mi <= 60 and s <= 61.0):
        raise ctx.error(ln, "a valid epoch (year 1980-2200, month 1-12, day 1-31, hour <= 23, ...)", line, 4)
    return y, mo, d, h, mi, s


def _convert_time(ctx: _Ctx, t: GpsTime, time_system: str) -> GpsTime:
    ts = time_system.strip().upper()
    if ts in ("GPS", "GAL", "QZS", "IRN", "", "CCC"):
        return t
    if ts == "TAI":
        ctx.warn("time-system-converted", "TAI epochs converted to GPS time (-19 s)", None)
        return t - 19.0
    if ts == "BDT":
        ctx.warn("time-system-converted", "BDT epochs converted to GPS time (+14 s)", None)
        return t + 14.0
    if ts in ("UTC", "GLO"):
        ctx.warn("time-system-converted", f"{ts} epochs converted to GPS time with the "
                 "leap-second table (GLO taken as UTC)", None)
        return GpsTime(t.s + gps_minus_utc_s(t.s), t.frac)
    raise ctx.error(13, "a time system GPS/GLO/GAL/QZS/BDT/IRN/UTC/TAI in columns 10-12 of the first %c line",
                    time_system)


@dataclass
class _Sp3Header:
    """The SP3 header fields read_sp3 keeps (lines 1-2, '+' lines, '%c' and '/*' lines)."""

    version: str
    pos_vel_flag: str
    n_epochs_header: int
    data_used: str
    coordinate_system: str
    orbit_type: str
    agency: str
    interval_s: float
    sats: list[str] = field(default_factory=list)
    sat_line_no: int = 3  # line number of the first '+' line
    file_type: str = "G"
    time_system: str = "GPS"
    comments: list[str] = field(default_factory=list)


@dataclass
class _Sp3Body:
    """Records of the body in file units (km, microseconds, dm/s, 1e-4 microseconds/s), NaN where bad/absent."""

    epoch_lines: list[int]
    cal: np.ndarray  # (n_ep, 6) y, m, d, h, mi, s of each epoch line
    pos: np.ndarray
    clk: np.ndarray
    vel: np.ndarray
    rate: np.ndarray
    seen_p: np.ndarray
    seen_v: np.ndarray
    eof: bool = False
    unlisted: list = field(default_factory=list)   # (satellite, first line) of records not in the '+' lines


def _sp3_lines_1_2(ctx: _Ctx, lines: list[str]) -> _Sp3Header:
    """_Sp3Header of lines 1 ('#cP' start epoch, count, data used, frame, orbit type, agency) and 2 ('##')."""
    if len(lines) < 2:
        raise ctx.error(len(lines) or 1, "an SP3 header ('#a'..'#d' line 1, '##' line 2)", lines[0] if lines else "")
    l1 = lines[0]
    if l1.startswith("#  ") and len(l1) > 3 and l1[3] in "12":
        # the SP3 of Remondi (1989) before letters: '#' then the start epoch; SP3-a's layout, positions only
        ctx.warn("no-version-letter", "line 1 has no version letter (column 2) nor P/V flag (column 3): the "
                 "original SP3 layout, read as SP3-a with positions", 1)
        l1 = "#aP" + l1[3:]
    if len(l1) < 3 or l1[0] != "#" or l1[1] not in "abcd" or l1[2] not in "PV":
        raise ctx.error(1, "'#aP', '#bP', '#cP', '#dP' (or ...V) in columns 1-3", l1, 1)
    _epoch(ctx, "*  " + l1[3:], 1)  # line 1 has the epoch line's layout from column 4 on
    n_epochs_header = _int(ctx, l1, 32, 39, 1, "number of epochs")
    l2 = lines[1]
    if not l2.startswith("##"):
        raise ctx.error(2, "'##' GPS week / seconds of week / interval line", l2, 1)
    interval_s = _flt(ctx, l2, 24, 38, 2, "epoch interval")
    return _Sp3Header(version=l1[1], pos_vel_flag=l1[2], n_epochs_header=n_epochs_header,
                      data_used=l1[40:45].strip(), coordinate_system=l1[46:51].strip(),
                      orbit_type=l1[52:55].strip(), agency=l1[56:60].strip(), interval_s=interval_s)


def _sp3_satellites(ctx: _Ctx, lines: list[str], i: int, hdr: _Sp3Header) -> int:
    """Read the '+' satellite-id lines from line index `i` into hdr.sats; index of the line after them.

    Implements: SP3-d sec. "Lines 3-...": count I3 in columns 4-6, 17 ids (A1,I2) per line from column 10;
    the ids after the count must be empty ('  0').
    """
    plus: list[tuple[int, str]] = []
    while i < len(lines) and lines[i].startswith("+") and not lines[i].startswith("++"):
        plus.append((i + 1, lines[i]))
        i += 1
    if not plus:
        raise ctx.error(i + 1, "'+' satellite-id lines after line 2", lines[i] if i < len(lines) else "")
    ln0, first_plus = plus[0]
    if first_plus[6:9].strip():
        raise ctx.error(ln0, "the satellite count (I3 in columns 4-6) then blanks in columns 7-9", first_plus, 7)
    n_sats = _int(ctx, first_plus, 1, 6, ln0, "number of satellites")
    slots: list[tuple[str | None, int]] = []
    for ln, pl in plus:
        body = pl[9:60].ljust(51)
        for k in range(17):
            slots.append((_sat_id(ctx, body[3 * k:3 * k + 3], ln, pl, 9 + 3 * k), ln))
    listed = [s for s, _ in slots[:n_sats]]
    if None in listed or any(s is not None for s, _ in slots[n_sats:]):
        found = sum(s is not None for s, _ in slots)
        raise ctx.error(ln0, f"exactly {n_sats} satellite ids in the '+' lines as the count in columns 4-6 says",
                        f"{found} ids listed", 4)
    if len(set(listed)) != len(listed):
        dup = next(s for s in listed if listed.count(s) > 1)
        raise ctx.error(ln0, "each satellite listed once in the '+' lines", f"{dup} listed twice")
    hdr.sats = listed  # type: ignore[assignment]
    hdr.sat_line_no = ln0
    return i


def _sp3_descriptors(ctx: _Ctx, lines: list[str], i: int, hdr: _Sp3Header) -> int:
    """Skip '++' lines, read '%c' (file type, time system: SP3-c/d only) and '/*' comments; first body line index."""
    while i < len(lines) and lines[i].startswith("++"):
        i += 1
    n_pc = 0
    while i < len(lines) and (lines[i][:2] in ("%c", "%f", "%i", "/*", "%/") or not lines[i].strip()):
        ln = lines[i]
        if not ln.strip():
            ctx.count("blank-line", "blank lines were ignored", i + 1)
        elif ln.startswith("%c"):
            if n_pc == 0 and hdr.version in "cd":
                hdr.file_type = ln[3:5].strip() or "G"
                hdr.time_system = ln[9:12].strip()
                if hdr.time_system.lower() == "ccc" or not hdr.time_system:
                    hdr.time_system = "GPS"
            n_pc += 1
        elif ln.startswith("/*"):
            hdr.comments.append(ln[3:].rstrip())
        i += 1
    if hdr.version in "ab":
        hdr.time_system = "GPS"
    if i >= len(lines) or not lines[i].startswith("*"):
        raise ctx.error(i + 1, "the first epoch line '*  yyyy mm dd ...' after the header",
                        lines[i] if i < len(lines) else "<end of file>", 1)
    return i


def _sp3_pv_record(ctx: _Ctx, body: _Sp3Body, e: int, index: dict[str, int], ln: str, lno: int) -> None:
    """Store one 'P' (x, y, z km, clock us) or 'V' (dm/s, 1e-4 us/s) record (3F14.6, F14.6) of epoch `e`."""
    c0 = ln[:1]
    if len(ln) < 46:
        raise ctx.error(lno, f"a {c0} record with x, y, z (3F14.6) in columns 5-46", ln, len(ln) + 1)
    sat = _sat_id(ctx, ln[1:4], lno, ln, 1)
    if sat is None:
        raise ctx.error(lno, "a satellite id in columns 2-4", f"{ln[1:4]!r} in: {ln}", 2)
    j = index.get(sat)
    if j is None:
        j = _add_unlisted(body, index, sat, lno)
    xyz = (_flt(ctx, ln, 4, 18, lno, "x"), _flt(ctx, ln, 18, 32, lno, "y"), _flt(ctx, ln, 32, 46, lno, "z"))
    c_txt = ln[46:60]
    cval = _flt(ctx, ln, 46, 60, lno, "clock") if c_txt.strip() else np.nan
    bad_xyz = any(v == 0.0 or abs(v) >= BAD_CLOCK_US for v in xyz)
    bad_c = not (abs(cval) < BAD_CLOCK_US)
    seen, xyz_out, c_out = ((body.seen_p, body.pos, body.clk) if c0 == "P"
                            else (body.seen_v, body.vel, body.rate))
    if seen[e, j]:
        raise ctx.error(lno, f"one {c0} record per satellite and epoch ({sat} repeated)", ln, 2)
    seen[e, j] = True
    if not bad_xyz:
        xyz_out[e, j] = xyz
    if not bad_c:
        c_out[e, j] = cval


def _add_unlisted(body: _Sp3Body, index: dict[str, int], sat: str, lno: int) -> int:
    """Column of a satellite with records but not in the '+' lines (quirk: read under its own id)."""
    index[sat] = j = len(index)
    body.unlisted.append((sat, lno))
    for key in ("pos", "clk", "vel", "rate", "seen_p", "seen_v"):
        a = getattr(body, key)
        pad = np.full(a.shape[:1] + (1,) + a.shape[2:], False if a.dtype == bool else np.nan, dtype=a.dtype)
        setattr(body, key, np.concatenate([a, pad], axis=1))
    return j


def _sp3_body(ctx: _Ctx, lines: list[str], body_start: int, hdr: _Sp3Header) -> _Sp3Body:
    """_Sp3Body of the lines from `body_start`: '*' epochs, 'P'/'V' records, 'EP'/'EV' skipped, 'EOF'."""
    epoch_lines = [k for k in range(body_start, len(lines)) if lines[k].startswith("*")]
    n_ep = len(epoch_lines)
    if n_ep != hdr.n_epochs_header:
        ctx.warn("epoch-count-mismatch", f"line 1 announces {hdr.n_epochs_header} epochs, "
                 f"the body has {n_ep}", 1)
    index = {s: j for j, s in enumerate(hdr.sats)}
    ns = len(hdr.sats)
    body = _Sp3Body(epoch_lines, np.zeros((n_ep, 6)), np.full((n_ep, ns, 3), np.nan), np.full((n_ep, ns), np.nan),
                    np.full((n_ep, ns, 3), np.nan), np.full((n_ep, ns), np.nan), np.zeros((n_ep, ns), dtype=bool),
                    np.zeros((n_ep, ns), dtype=bool))
    e = -1
    for k in range(body_start, len(lines)):
        ln = lines[k]
        lno = k + 1
        c0 = ln[:1]
        if body.eof:
            if ln.strip():
                raise ctx.error(lno, "nothing after the 'EOF' line", ln, 1)
            continue
        if c0 == "*":
            e += 1
            body.cal[e] = _epoch(ctx, ln, lno)
            if body.cal[e, 5] >= 60.0:
                ctx.count("epoch-seconds-60", "epoch lines with seconds >= 60 were rolled over", lno)
        elif c0 == "P" or c0 == "V":
            _sp3_pv_record(ctx, body, e, index, ln, lno)
        elif ln.startswith("EOF"):
            body.eof = True
        elif c0 == "E" and ln[1:2] in ("P", "V"):
            continue
        elif not ln.strip():
            ctx.count("blank-line", "blank lines were ignored", lno)
        elif ln.strip() == "*":
            ctx.count("elision-line", "lines holding only '*' (an elision mark, no epoch) were skipped", lno)
        else:
            raise ctx.error(lno, "an epoch ('*'), 'P', 'V', 'EP', 'EV' record or 'EOF'", ln, 1)
        if e < 0 and c0 != "*":
            raise ctx.error(lno, "an epoch line before the first record", ln, 1)
    return body


def _sp3_completeness(ctx: _Ctx, body: _Sp3Body, hdr: _Sp3Header, n_lines: int) -> bool:
    """Whether velocities are present; refuses listed satellites without records, warns of missing ones."""
    if not body.eof:
        ctx.warn("missing-eof", "the file ends without an 'EOF' line (truncated?)", n_lines)
    if body.unlisted:
        ctx.warn("unlisted-satellite", f"satellites with records but not in the '+' lines, read under their own "
                 f"ids: {', '.join(s for s, _ in body.unlisted)}", body.unlisted[0][1])
        hdr.sats = hdr.sats + [s for s, _ in body.unlisted]
    absent = ~body.seen_p.any(axis=0)
    if absent.any():
        ctx.warn("listed-without-records", f"satellites listed in the '+' lines without any P record, dropped: "
                 f"{', '.join(s for s, a in zip(hdr.sats, absent) if a)}", hdr.sat_line_no)
        keep = ~absent
        hdr.sats = [s for s, k in zip(hdr.sats, keep) if k]
        for key in ("pos", "clk", "vel", "rate", "seen_p", "seen_v"):
            setattr(body, key, getattr(body, key)[:, keep])
    seen_p, seen_v = body.seen_p, body.seen_v
    missing_p = int((~seen_p).sum())
    if missing_p:
        ctx.warn("missing-records", f"{missing_p} satellite-epochs without a P record "
                 "(NaN)", None)
    has_vel = hdr.pos_vel_flag == "V" or seen_v.any()
    if has_vel:
        miss_v = int((seen_p & ~seen_v).sum())
        if miss_v:
            ctx.warn("missing-velocity", f"{miss_v} P records without a V record "
                     "(velocity NaN)", None)
    return bool(has_vel)


def _sp3_times(ctx: _Ctx, body: _Sp3Body, lines: list[str], time_system: str) -> GpsTime:
    """GpsTime of the epoch lines, refused unless strictly increasing, converted to GPS time."""
    cal = body.cal
    t = GpsTime.from_calendar(cal[:, 0].astype(np.int64), cal[:, 1].astype(np.int64), cal[:, 2].astype(np.int64),
                              cal[:, 3].astype(np.int64), cal[:, 4].astype(np.int64), cal[:, 5])
    if len(cal) > 1:
        step = t[1:] - t[:-1]
        if np.any(step <= 0):
            r = int(np.argmax(step <= 0)) + 1
            raise ctx.error(body.epoch_lines[r] + 1, "epochs in strictly increasing time order",
                            lines[body.epoch_lines[r]], 1)
    return _convert_time(ctx, t, time_system)


def read_sp3(source, *, name: str | None = None) -> Sp3Data:
    """Epochs, satellites, positions, clocks (and velocities) of an SP3-a/b/c/d file (path or bytes).

    Args:
        source: path or bytes (gzip/.Z/zip detected by magic bytes); name: file name for messages.
    Returns: `Sp3Data` (see its docstring for shapes and units). Raises `ParseError` for a broken file.
    Implements: SP3-c (Hilla 2010) / SP3-d (Hilla 2016) sec. "Format" line by line (see module docstring).
    """
    text, display = read_source_text(source, name)
    lines = _split_lines(text)
    lead = next((k for k, ln in enumerate(lines) if ln.strip()), 0)
    ctx = _Ctx(display, lead)
    if lead:
        ctx.warn("leading-blank-lines", f"{lead} blank line(s) before line 1 were skipped", 1 - lead)
        lines = lines[lead:]
    hdr = _sp3_lines_1_2(ctx, lines)
    i = _sp3_satellites(ctx, lines, 2, hdr)
    body_start = _sp3_descriptors(ctx, lines, i, hdr)
    body = _sp3_body(ctx, lines, body_start, hdr)
    has_vel = _sp3_completeness(ctx, body, hdr, len(lines))
    t = _sp3_times(ctx, body, lines, hdr.time_system)
    ctx.flush()
    return Sp3Data(
        name=display, version=hdr.version, pos_vel_flag=hdr.pos_vel_flag, time=t, sats=hdr.sats,
        position_ecef_m=body.pos * 1000.0, clock_s=body.clk * 1e-6,
        velocity_ecef_m_s=body.vel * 0.1 if has_vel else None,
        clock_rate_s_s=body.rate * 1e-10 if has_vel else None, data_used=hdr.data_used,
        coordinate_system=hdr.coordinate_system, orbit_type=hdr.orbit_type, agency=hdr.agency,
        time_system=hdr.time_system, file_type=hdr.file_type, interval_s=hdr.interval_s,
        n_epochs_header=hdr.n_epochs_header, comments=hdr.comments, warnings=ctx.warnings)


def summarize_sp3(source, *, name: str | None = None) -> dict:
    """JSON-ready summary of an SP3 file for upload validation (reads the whole file; ParseError if broken)."""
    sp3 = read_sp3(source, name=name)
    n = len(sp3.time)
    return {
        "format": f"SP3-{sp3.version}",
        "name": sp3.name,
        "version": sp3.version,
        "has_velocity": sp3.velocity_ecef_m_s is not None,
        "n_epochs": n,
        "interval_s": sp3.interval_s,
        "satellites": list(sp3.sats),
        "systems": sorted({s[0] for s in sp3.sats}),
        "time_span_gps": [sp3.time[0].iso(3), sp3.time[n - 1].iso(3)] if n else None,
        "coordinate_system": sp3.coordinate_system,
        "orbit_type": sp3.orbit_type,
        "agency": sp3.agency,
        "time_system": sp3.time_system,
        "valid_positions": int(np.isfinite(sp3.position_ecef_m[..., 0]).sum()),
        "valid_clocks": int(np.isfinite(sp3.clock_s).sum()),
        "warnings": [w.to_dict() for w in sp3.warnings],
    }
