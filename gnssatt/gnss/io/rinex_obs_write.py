"""Write RINEX observation files (2.11, 3.0x, 4.0x) from dense arrays, fast and byte-for-byte deterministic.

Public API:
    write_rinex_obs(path, obs, version=3.04, header=None) -> bytes
    rinex_obs_bytes(obs, version=3.04, header=None) -> bytes
    ObsWriteHeader(marker_name=..., comments=..., ...): the header values

`obs` is a `RinexObs` or anything with the same array attributes (`time` GpsTime (n_epochs,), `sats`,
`codes`, `values` (n_epochs, n_sats, n_codes), optional `lli`/`ssi` int8 (-1 = blank), `epoch_flag`,
`clock_offset_s`, `header` with `obs_types`). The observations of all records are formatted at once with
integer digit arithmetic (no per-field Python formatting): a value becomes round(value * 1000) thousandths,
which reproduces exactly any value read from an F14.3 field; a NaN becomes a blank field. Only satellites
with at least one value in an epoch are written in that epoch. Same input -> byte-identical file
(PGM / RUN BY / DATE defaults to a fixed text, not the clock).

Implements: RINEX 3.04 (and 3.05 / 4.01: same observation layout) Tables A1-A3; RINEX 2.11 Tables A1-A2
(5 observations per 80-column line, 12 satellites per epoch line then continuation lines, 9 observation types
per '# / TYPES OF OBSERV' line, 13 per 'SYS / # / OBS TYPES' line).
Neglects: events (flags 2-6) are not written; values with |value| >= 1e10 cannot be written as F14.3 and
raise ValueError.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gnssatt.gnss.io.rinex_obs import rinex3_code

__all__ = ["write_rinex_obs", "rinex_obs_bytes", "ObsWriteHeader"]

_SYS_NAMES = {"G": "GPS", "R": "GLONASS", "E": "GALILEO", "C": "BEIDOU", "J": "QZSS", "S": "SBAS", "I": "IRNSS"}
_V2_CANDIDATES = ["C1", "P1", "L1", "D1", "S1", "C2", "P2", "L2", "D2", "S2", "C5", "L5", "D5", "S5",
                  "C6", "L6", "D6", "S6", "C7", "L7", "D7", "S7", "C8", "L8", "D8", "S8"]


def _hline(content: str, label: str) -> str:
    return f"{content[:60]:<60}{label}"


def _format_fields(values: np.ndarray, lli: np.ndarray, ssi: np.ndarray) -> np.ndarray:
    """(N, 16) uint8 characters of F14.3,I1,I1 fields; NaN -> blanks; lli/ssi -1 -> blank.

    Implements: Fortran F14.3 output (right-justified, 3 decimals, '-' before the first digit).
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    n = len(v)
    out = np.full((n, 16), 32, dtype=np.uint8)
    ok = ~np.isnan(v)
    if np.any(np.abs(v[ok]) >= 9999999999.9995):
        bad = v[ok][np.abs(v[ok]) >= 9999999999.9995][0]
        raise ValueError(f"value {bad!r} does not fit RINEX F14.3")
    t = np.rint(np.where(ok, v, 0.0) * 1000.0).astype(np.int64)
    neg = t < 0
    t = np.abs(t)
    q, r = np.divmod(t, 1000)
    out[:, 13] = 48 + r % 10
    out[:, 12] = 48 + (r // 10) % 10
    out[:, 11] = 48 + r // 100
    out[:, 10] = 46
    n_int = np.ones(n, dtype=np.int64)  # number of integer digits (at least one: 0.123)
    for p in range(1, 10):
        n_int += q >= 10 ** p
    if np.any(neg & (n_int >= 10)):
        raise ValueError("a negative value below -999999999.999 does not fit RINEX F14.3")
    for p in range(10):  # character 9 - p holds digit p of the integer part
        digit = (q // 10 ** p) % 10
        out[:, 9 - p] = np.where(p < n_int, 48 + digit, 32)
    minus_col = 9 - n_int
    rows = np.flatnonzero(neg & ok)
    out[rows, minus_col[rows]] = 45
    out[~ok, :14] = 32
    for col, flag in ((14, lli), (15, ssi)):
        f = np.asarray(flag, dtype=np.int64).ravel()
        out[:, col] = np.where((f >= 0) & (f <= 9), 48 + np.clip(f, 0, 9), 32)
    return out


def _epoch_text(y, mo, d, h, mi, whole, ticks) -> tuple[str, str]:
    return f"{y:4d} {mo:02d} {d:02d} {h:02d} {mi:02d}", f"{whole:3d}.{ticks:07d}"


def _calendar_ticks(time) -> tuple[np.ndarray, ...]:
    """(y, mo, d, h, mi, whole_s, ticks_1e7) of each epoch, seconds rounded to 1e-7 s with carry."""
    from gnssatt.gnss.time import GpsTime

    ticks = np.rint(np.atleast_1d(time.frac) * 1e7).astype(np.int64)
    s = np.atleast_1d(time.s) + ticks // 10_000_000
    ticks = ticks % 10_000_000
    y, mo, d, h, mi, sec = GpsTime(s).calendar()
    return y, mo, d, h, mi, np.floor(sec).astype(np.int64), ticks


def _obs_types_for(obs, codes: list[str], version: float, systems: list[str]) -> dict[str, list[str]]:
    hdr = getattr(obs, "header", None)
    given = dict(getattr(hdr, "obs_types", {}) or {})
    out: dict[str, list[str]] = {}
    values = obs.values
    sats = list(obs.sats)
    for s in systems:
        if s in given:
            out[s] = [c for c in given[s] if c in codes]
        else:
            mask = np.array([x[0] == s for x in sats])
            present = ~np.all(np.isnan(values[:, mask, :]), axis=(0, 1)) if mask.any() else np.zeros(len(codes), bool)
            out[s] = [c for c, p in zip(codes, present) if p]
    return out


@dataclass
class ObsWriteHeader:
    """Header values of a written RINEX observation file; None takes the value from `obs.header`.

    interval_s: s, default the header's or the median epoch step. run_date: PGM / RUN BY / DATE text, default
    the first epoch's date (never the clock, so the same input gives the same bytes). Implements: RINEX 3.05
    Table A2 / RINEX 2.11 Table A1 header records of the same names.
    """

    marker_name: str | None = None
    receiver_type: str | None = None
    antenna_type: str | None = None
    approx_position_ecef_m: object = None
    antenna_delta_hen_m: object = None
    interval_s: float | None = None
    program: str = "gnssatt"
    run_by: str = "gnssatt"
    run_date: str = ""
    comments: tuple[str, ...] = ()
    write_time_of_last: bool = True
    signal_strength_unit: str | None = "DBHZ"


@dataclass
class _Layout:
    """What is written: systems in header order, per system the (written column, source code index) pairs,
    and the observation types (RINEX 3: per system; RINEX 2: one list)."""

    major: int
    systems: list[str]
    col_of: dict[str, list[tuple[int, int]]]
    types: dict[str, list[str]]
    types_v2: list[str]


def _resolved_header(obs, opts: ObsWriteHeader, cal) -> ObsWriteHeader:
    """`opts` with every None filled from `obs.header` (or a default), interval and run date settled."""
    hdr = getattr(obs, "header", None)

    def pick(value, attr):
        return value if value is not None else getattr(hdr, attr, None)

    time = obs.time
    n_ep = len(time)
    interval_s = opts.interval_s
    if interval_s is None:
        interval_s = getattr(hdr, "interval_s", None)
    if interval_s is None and n_ep > 1:
        interval_s = float(np.median(np.diff(time.s).astype(np.float64) + np.diff(time.frac)))
    run_date = opts.run_date
    if not run_date:
        run_date = (f"{int(cal[0][0]):04d}{int(cal[1][0]):02d}{int(cal[2][0]):02d} 000000 UTC" if n_ep
                    else "19800106 000000 UTC")
    return replace(opts, marker_name=pick(opts.marker_name, "marker_name") or "UNKNOWN",
                   receiver_type=pick(opts.receiver_type, "receiver_type") or "",
                   antenna_type=pick(opts.antenna_type, "antenna_type") or "",
                   approx_position_ecef_m=pick(opts.approx_position_ecef_m, "approx_position_ecef_m"),
                   antenna_delta_hen_m=pick(opts.antenna_delta_hen_m, "antenna_delta_hen_m"),
                   interval_s=interval_s, run_date=run_date)


def _systems_of(obs) -> list[str]:
    """Systems present in the data: the header's order first, then RINEX order G R E C J S I."""
    hdr = getattr(obs, "header", None)
    in_data = {s[0] for s in obs.sats}
    declared = [s for s in (getattr(hdr, "obs_types", None) or {}) if s in in_data]  # keep the header's order
    return declared + sorted(in_data - set(declared), key=lambda c: "GRECJSI".find(c) % 99)


def _layout_v2(obs, values: np.ndarray, version: float, systems: list[str]) -> _Layout:
    """_Layout of a RINEX 2.11 file: one type list, RINEX 3 codes mapped back (C1C -> C1, C1W -> P1, ...)."""
    sats, codes = list(obs.sats), list(obs.codes)
    v2_names: list[str] = []
    col_of: dict[str, list[tuple[int, int]]] = {}  # system -> [(v2 column, source code index)]
    for s in systems:
        pairs = []
        for k, c in enumerate(codes):
            mask = np.array([x[0] == s for x in sats])
            if np.all(np.isnan(values[:, mask, k])):
                continue
            if len(c) == 2:
                name2 = c
            else:
                cands = [v for v in _V2_CANDIDATES if _safe_code(s, v, version) == c]
                if not cands:
                    raise ValueError(f"{s} {c} has no RINEX 2.11 observation code")
                name2 = cands[0]
            if name2 not in v2_names:
                v2_names.append(name2)
            pairs.append((v2_names.index(name2), k))
        col_of[s] = pairs
    return _Layout(2, systems, col_of, {}, v2_names)


def _layout_v3(obs, version: float, systems: list[str], major: int) -> _Layout:
    """_Layout of a RINEX 3/4 file: per system its codes (RINEX 2 names of `obs.codes` mapped to RINEX 3)."""
    codes = list(obs.codes)
    types = _obs_types_for(obs, codes, version, systems)
    for s in types:
        bad = [c for c in types[s] if len(c) != 3 and not (len(c) == 2 and c[0] == "X")]
        if bad:
            types[s] = [rinex3_code(s, c, 2.11) if len(c) == 2 and c[0] != "X" else c for c in types[s]]
    col_of = {}
    for s in systems:
        idx = []
        for j, c in enumerate(types.get(s, [])):
            if c in codes:
                idx.append((j, codes.index(c)))
            else:  # obs.codes are RINEX 2 names: find the one that maps to c
                src = [k for k, cc in enumerate(codes) if len(cc) == 2 and _safe_code(s, cc, 2.11) == c]
                idx.append((j, src[0]))
        col_of[s] = idx
    return _Layout(major, systems, col_of, types, [])


def _type_header_lines(lay: _Layout, opts: ObsWriteHeader) -> list[str]:
    """'# / TYPES OF OBSERV' (RINEX 2.11: 9 per line) or 'SYS / # / OBS TYPES' (RINEX 3: 13 per line) records."""
    h: list[str] = []
    if lay.major == 2:
        h.append(_hline(f"{1:6d}{1:6d}", "WAVELENGTH FACT L1/2"))
        types_v2 = lay.types_v2
        for i in range(0, max(1, len(types_v2)), 9):
            chunk = types_v2[i:i + 9]
            head = f"{len(types_v2):6d}" if i == 0 else " " * 6
            h.append(_hline(head + "".join(f"{c:>6}" for c in chunk), "# / TYPES OF OBSERV"))
        return h
    for s in lay.systems:
        names = lay.types.get(s, [])
        for i in range(0, max(1, len(names)), 13):
            chunk = names[i:i + 13]
            head = f"{s}  {len(names):3d}" if i == 0 else " " * 6
            h.append(_hline(head + "".join(f" {c:<3}" for c in chunk), "SYS / # / OBS TYPES"))
    if opts.signal_strength_unit:
        h.append(_hline(opts.signal_strength_unit, "SIGNAL STRENGTH UNIT"))
    return h


def _v3_tail_header_lines(obs, lay: _Layout) -> list[str]:
    """SYS / PHASE SHIFT (zero) per phase code and, with GLONASS, GLONASS SLOT / FRQ # and COD/PHS/BIS."""
    h: list[str] = []
    for s in lay.systems:
        for c in lay.types.get(s, []):
            if c[0] == "L":
                h.append(_hline(f"{s} {c:<3} {0.0:8.5f}", "SYS / PHASE SHIFT"))
    if "R" in lay.systems:
        slots = dict(getattr(getattr(obs, "header", None), "glonass_slots", {}) or {})
        items = sorted(slots.items())
        if not items:
            h.append(_hline(f"{0:3d}", "GLONASS SLOT / FRQ #"))
        for i in range(0, len(items), 8):
            head = f"{len(items):3d} " if i == 0 else " " * 4
            h.append(_hline(head + "".join(f"{sat:3} {k:2d} " for sat, k in items[i:i + 8]),
                            "GLONASS SLOT / FRQ #"))
        h.append(_hline(" C1C    0.000 C1P    0.000 C2C    0.000 C2P    0.000", "GLONASS COD/PHS/BIS"))
    return h


def _header_bytes(obs, version: float, lay: _Layout, opts: ObsWriteHeader, cal) -> bytes:
    """The header section, END OF HEADER included. Implements: RINEX 3.05 Table A2 / RINEX 2.11 Table A1."""
    major = lay.major
    h: list[str] = []
    sys_char = lay.systems[0] if len(lay.systems) == 1 else "M"
    if major == 2:
        sys_txt = {"G": "G (GPS)", "R": "R (GLONASS)", "E": "E (GALILEO)", "S": "S (GEO)", "M": "M (MIXED)"}.get(
            sys_char, "M (MIXED)")
    else:
        sys_txt = sys_char + (f": {_SYS_NAMES[sys_char]}" if sys_char in _SYS_NAMES else ": Mixed")
    h.append(_hline(f"{version:9.2f}{'':11}{'OBSERVATION DATA':<20}{sys_txt:<20}", "RINEX VERSION / TYPE"))
    h.append(_hline(f"{opts.program:<20.20}{opts.run_by:<20.20}{opts.run_date:<20.20}", "PGM / RUN BY / DATE"))
    for c in opts.comments:
        h.append(_hline(c, "COMMENT"))
    h.append(_hline(opts.marker_name, "MARKER NAME"))
    if major >= 3:
        h.append(_hline("NON_GEODETIC", "MARKER TYPE"))
    h.append(_hline(f"{'gnssatt':<20}{'gnssatt':<40}", "OBSERVER / AGENCY"))
    h.append(_hline(f"{'':<20}{opts.receiver_type:<20.20}{'':<20}", "REC # / TYPE / VERS"))
    h.append(_hline(f"{'':<20}{opts.antenna_type:<20.20}", "ANT # / TYPE"))
    pos, hen = opts.approx_position_ecef_m, opts.antenna_delta_hen_m
    p = np.zeros(3) if pos is None else np.asarray(pos, dtype=np.float64)
    h.append(_hline("".join(f"{x:14.4f}" for x in p), "APPROX POSITION XYZ"))
    e = np.zeros(3) if hen is None else np.asarray(hen, dtype=np.float64)
    h.append(_hline("".join(f"{x:14.4f}" for x in e), "ANTENNA: DELTA H/E/N"))
    h += _type_header_lines(lay, opts)
    if opts.interval_s is not None:
        h.append(_hline(f"{opts.interval_s:10.3f}", "INTERVAL"))
    if len(obs.time):
        for k, label in ((0, "TIME OF FIRST OBS"), (-1, "TIME OF LAST OBS")):
            if label == "TIME OF LAST OBS" and not opts.write_time_of_last:
                continue
            y, mo, d, hh, mi, whole, ticks = (int(a[k]) for a in cal)
            h.append(_hline(f"{y:6d}{mo:6d}{d:6d}{hh:6d}{mi:6d}{whole:5d}.{ticks:07d}{'':5}GPS",
                            label))
    if major >= 3:
        h += _v3_tail_header_lines(obs, lay)
    h.append(_hline("", "END OF HEADER"))
    return ("\n".join(h) + "\n").encode("ascii")


def _flag_array(obs, attr: str, fallback: np.ndarray, dtype) -> np.ndarray:
    value = getattr(obs, attr, None)
    return np.asarray(value if value is not None else fallback, dtype=dtype)


def _record_lines(obs, values: np.ndarray, lay: _Layout, present: np.ndarray) -> list[bytes]:
    """One text line per written (epoch, satellite) record (RINEX 2: its 80-column lines), all formatted at once.

    Implements: RINEX 3.05 Table A3 OBSERVATION record (A1,I2.2,m(F14.3,I1,I1)) / RINEX 2.11 Table A2 (5 fields
    per 80-column line).
    """
    sats = list(obs.sats)
    lli = _flag_array(obs, "lli", np.full(values.shape, -1), np.int8)
    ssi = _flag_array(obs, "ssi", np.full(values.shape, -1), np.int8)
    sys_of = np.array([s[0] for s in sats])
    if lay.major == 2:
        n_types = len(lay.types_v2)
        lps = 1 + (n_types - 1) // 5 if n_types else 1
        width = 80 * lps
    else:
        n_types = max((len(lay.types.get(s, [])) for s in lay.systems), default=0)
        width = 3 + 16 * n_types
    rec_e, rec_j = np.nonzero(present)  # epoch-major order, satellites sorted within an epoch
    n_rec = len(rec_e)
    out_vals = np.full((n_rec, n_types), np.nan)
    out_lli = np.full((n_rec, n_types), -1, dtype=np.int8)
    out_ssi = np.full((n_rec, n_types), -1, dtype=np.int8)
    rec_sys = sys_of[rec_j] if n_rec else np.array([], dtype="<U1")
    for s in lay.systems:
        sel = np.flatnonzero(rec_sys == s)
        for dst, src in lay.col_of.get(s, []):
            out_vals[sel, dst] = values[rec_e[sel], rec_j[sel], src]
            out_lli[sel, dst] = lli[rec_e[sel], rec_j[sel], src]
            out_ssi[sel, dst] = ssi[rec_e[sel], rec_j[sel], src]
    fields = _format_fields(out_vals, out_lli, out_ssi).reshape(n_rec, n_types * 16)
    if lay.major == 2:
        pad = np.full((n_rec, width), 32, dtype=np.uint8)
        pad[:, :n_types * 16] = fields
        return [row.tobytes().rstrip() for row in pad.reshape(n_rec * lps, 80)]
    mat = np.empty((n_rec, width), dtype=np.uint8)
    ids = np.frombuffer("".join(sats[j] for j in rec_j).encode("ascii"), dtype=np.uint8).reshape(-1, 3)
    mat[:, :3] = ids
    mat[:, 3:] = fields
    # a satellite of a system with fewer types than the widest: its extra slots are blank, stripped here
    return [row.tobytes().rstrip() for row in mat]


def _epoch_line(lay: _Layout, cal_k: tuple, flag: int, sat_ids: list[str], clk: float) -> bytes:
    """EPOCH record(s) of one epoch: RINEX 3.05 Table A3 ('>' line, clock F15.12) or RINEX 2.11 Table A2
    (12 satellites per line, continuation lines, clock F12.9)."""
    y, mo, d, hh, mi, whole, ticks = cal_k
    n = len(sat_ids)
    if lay.major == 2:
        head = (f" {y % 100:02d} {mo:2d} {d:2d} {hh:2d} {mi:2d}{whole:3d}.{ticks:07d}"
                f"  {flag:1d}{n:3d}")
        first = head + "".join(sat_ids[:12]).ljust(36)
        if not np.isnan(clk):
            first += f"{clk:12.9f}"
        ep_lines = [first.rstrip()]
        for i in range(12, n, 12):
            ep_lines.append((" " * 32 + "".join(sat_ids[i:i + 12])).rstrip())
        return ("\n".join(ep_lines) + "\n").encode("ascii")
    line = (f"> {y:4d} {mo:02d} {d:02d} {hh:02d} {mi:02d}{whole:3d}.{ticks:07d}"
            f"  {flag:1d}{n:3d}")
    if not np.isnan(clk):
        line += f"{'':6}{clk:15.12f}"
    return (line + "\n").encode("ascii")


def rinex_obs_bytes(obs, version: float = 3.04, header: ObsWriteHeader | None = None) -> bytes:
    """The bytes of a RINEX observation file of `obs` in `version` (2.11, 3.02-3.05 or 4.00-4.02).

    header: the header values (`ObsWriteHeader`); its None fields default to `obs.header` where it has them,
    `interval_s` to the median epoch step. RINEX 3 codes are written to a RINEX 2.11 file through the inverse
    of `rinex3_code` (C1C -> C1, C1W -> P1, L2W -> L2, ...); a code without RINEX 2 equivalent raises ValueError.
    """
    version = round(float(version), 2)
    major = int(version)
    if major not in (2, 3, 4) or (major == 2 and version not in (2.10, 2.11)):
        raise ValueError(f"cannot write RINEX observation version {version}")
    time = obs.time
    n_ep = len(time)
    values = np.asarray(obs.values, dtype=np.float64)
    cal = _calendar_ticks(time) if n_ep else None
    opts = _resolved_header(obs, header or ObsWriteHeader(), cal)
    systems = _systems_of(obs)
    lay = (_layout_v2(obs, values, version, systems) if major == 2
           else _layout_v3(obs, version, systems, major))
    header_bytes = _header_bytes(obs, version, lay, opts, cal)
    if n_ep == 0:
        return header_bytes

    flags = _flag_array(obs, "epoch_flag", np.zeros(n_ep), np.int64)
    clock = getattr(obs, "clock_offset_s", None)
    clock = np.full(n_ep, np.nan) if clock is None else np.asarray(clock, dtype=np.float64)
    present = ~np.all(np.isnan(values), axis=2)  # (n_ep, n_sats): satellite written in that epoch
    rec_lines = _record_lines(obs, values, lay, present)
    lps = 1 + (len(lay.types_v2) - 1) // 5 if major == 2 and lay.types_v2 else 1
    sats = list(obs.sats)
    rec_j = np.nonzero(present)[1]
    counts = present.sum(axis=1)
    starts = np.concatenate(([0], np.cumsum(counts)))
    cal_lists = [a.tolist() for a in cal]
    chunks: list[bytes] = [header_bytes]
    for k in range(n_ep):
        sat_ids = [sats[j] for j in rec_j[starts[k]:starts[k + 1]]]
        chunks.append(_epoch_line(lay, tuple(a[k] for a in cal_lists), int(flags[k]), sat_ids, clock[k]))
        a, b = starts[k] * lps, starts[k + 1] * lps
        if b > a:
            chunks.append(b"\n".join(rec_lines[a:b]) + b"\n")
    return b"".join(chunks)


def _safe_code(system: str, code: str, version: float) -> str | None:
    try:
        return rinex3_code(system, code, version)
    except ValueError:
        return None


def write_rinex_obs(path, obs, version: float = 3.04, header: ObsWriteHeader | None = None) -> bytes:
    """Write `obs` as a RINEX observation file at `path` (str or Path); returns the bytes written.

    Args:
        path: destination file (overwritten); the parent directory must exist.
        obs: RinexObs or an object with the same attributes (see the module docstring).
        version: 2.11, 3.02-3.05 or 4.00-4.02.
        header: `ObsWriteHeader` (marker name, receiver, antenna, position, interval, comments, ...).
    """
    data = rinex_obs_bytes(obs, version, header)
    Path(path).write_bytes(data)
    return data
