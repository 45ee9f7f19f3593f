"""The reader corpus: third-party GNSS files labelled valid / quirk / broken (tests/corpus/manifest.csv), read by
gnssatt's readers and checked value for value against an independent raw-line re-read written here (tokens, not
the readers' fixed-column code), georinex and RTKLIB (pyrtklib). Used by tests/corpus/test_corpus.py (a fixed
subset) and bench/bench_corpus.py (every row). georinex and pyrtklib are test/bench dependencies only.

    rows = load_manifest()
    outcome = read_row(row)              # Outcome(result | error, seconds)
    n_cells = raw_check(row, outcome.result)   # AssertionError on the first disagreement

Implements: RINEX 2.11 / 3.05 / 4.01 observation and navigation record layouts, SP3-a..d P records, RINEX clock
AS/AR records, ANTEX NOAZI rows, re-read as whitespace/regex tokens.
"""
from __future__ import annotations

import csv
import re
import signal
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.real_sets import REAL_DATA_DIR

__all__ = ["MANIFEST", "THIRD_PARTY_DIR", "Row", "Outcome", "load_manifest", "read_row", "raw_check",
           "decompressed_text", "warning_codes", "READ_TIME_LIMIT_S"]

MANIFEST = Path(__file__).resolve().parents[1] / "tests" / "corpus" / "manifest.csv"
THIRD_PARTY_DIR = REAL_DATA_DIR.parent / "third_party" / "files"
#: A reader that takes longer than this on one corpus file counts as hung (the largest file reads in ~1.5 s
#: on the shared 2-core machine).
READ_TIME_LIMIT_S = 20.0


@dataclass(frozen=True)
class Row:
    """One manifest row: file (under THIRD_PARTY_DIR), provenance, kind, version, label and expectation."""

    path: str
    project: str
    commit: str
    kind: str          # obs, nav, sp3, clk, atx
    version: str
    compression: str
    label: str         # valid, quirk, broken
    expect: str        # quirk: ';'-joined warning codes; broken: 'line=N;text' of the ParseError
    reference: str     # georinex, rtklib, raw (the independent check that reads this file)
    in_test: bool      # part of the fixed subset tests/corpus runs
    note: str

    @property
    def file(self) -> Path:
        return THIRD_PARTY_DIR / self.path


def load_manifest(path: Path = MANIFEST) -> list[Row]:
    with open(path, newline="") as fh:
        return [Row(r["path"], r["project"], r["commit"], r["kind"], r["version"], r["compression"], r["label"],
                    r["expect"], r["reference"], r["in_test"] == "1", r["note"]) for r in csv.DictReader(fh)]


@dataclass
class Outcome:
    result: object = None
    error: Exception | None = None
    seconds: float = 0.0


class _Hung(Exception):
    pass


def _alarm(signum, frame):
    raise _Hung()


def read_row(row: Row, limit_s: float = READ_TIME_LIMIT_S) -> Outcome:
    """Read one corpus file with gnssatt's reader for its kind, bounded in time (SIGALRM; main thread)."""
    from gnssatt.gnss.io.antex import read_antex
    from gnssatt.gnss.io.errors import ParseError
    from gnssatt.gnss.io.rinex_clock import read_rinex_clock
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs
    from gnssatt.gnss.io.sp3 import read_sp3

    readers = {"obs": read_rinex_obs, "nav": read_rinex_nav, "sp3": read_sp3, "clk": read_rinex_clock}
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, limit_s)
    t0 = time.perf_counter()
    out = Outcome()
    try:
        if row.kind == "atx":
            warns: list = []
            out.result = (read_antex(row.file, warnings=warns), warns)
        else:
            out.result = readers[row.kind](row.file)
    except ParseError as exc:
        out.error = exc
    except _Hung:
        out.error = TimeoutError(f"{row.path}: no result within {limit_s} s")
    except Exception as exc:   # a crash: reported, never hidden
        out.error = exc
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
        out.seconds = time.perf_counter() - t0
    return out


def warning_codes(row: Row, result) -> set[str]:
    warns = result[1] if row.kind == "atx" else result.warnings
    return {w.code for w in warns}


# --- the independent raw-line re-read -------------------------------------------------------------------------

def decompressed_text(path: Path) -> str:
    """The file's text, decompressed by the hatanaka package (gzip/.Z/bz2/zip and CRINEX), not gnssatt's code."""
    import hatanaka

    data = path.read_bytes()
    if data[:2] in (b"\x1f\x8b", b"\x1f\x9d") or data[:3] == b"BZh" or data[:4] == b"PK\x03\x04" \
            or b"CRINEX VERS" in data[:80]:
        data = hatanaka.decompress(data)
    return data.decode("latin-1").replace("\r\n", "\n")


def _num(text: str) -> float:
    t = text.strip().replace("D", "E").replace("d", "e")
    return float(t) if t else np.nan


def _same(ours: float, raw: float, what: str) -> None:
    """Exact equality (both are float() of the same text), NaN meaning blank on both sides."""
    if np.isnan(raw):
        assert np.isnan(ours), f"{what}: ours {ours!r}, raw blank"
    else:
        assert ours == raw, f"{what}: ours {ours!r}, raw {raw!r}"


def _header_end(lines: list[str]) -> int:
    return next(i for i, ln in enumerate(lines) if ln[60:73] == "END OF HEADER" or "END OF HEADER" in ln[60:])


def _obs_types(lines: list[str], end: int, v3: bool) -> dict[str, list[str]]:
    types: dict[str, list[str]] = {}
    cur = None
    for ln in lines[:end]:
        lab = ln[60:80].strip()
        if v3 and lab == "SYS / # / OBS TYPES":
            if ln[0] != " ":
                cur = ln[0]
                types[cur] = []
            types[cur] += ln[7:60].split()
        elif not v3 and lab == "# / TYPES OF OBSERV":
            types.setdefault("_", []).extend(ln[6:60].split())
    return types


def _is_comment(ln: str) -> bool:
    return ln[60:67] == "COMMENT"


def _raw_obs_v3(lines: list[str], end: int):
    """Yield (epoch index, sat, {code: value}) of every observation record, by tokens of fixed 16-char slots."""
    types = _obs_types(lines, end, True)
    e = -1
    i = end + 1
    while i < len(lines):
        ln = lines[i]
        if not ln.startswith(">"):
            i += 1
            continue
        flag, n = int(ln[31:32]), int(ln[32:35])
        recs, j = [], i + 1
        while len(recs) < n and j < len(lines):
            if not (flag <= 1 and _is_comment(lines[j]) and not lines[j][:3].strip()[:1].isalpha()) \
                    and not (flag <= 1 and not lines[j].strip()):
                recs.append(lines[j])
            j += 1
        if flag <= 1 and len(recs) == n:
            e += 1
            for rec in recs:
                sat = rec[0:3].replace(" ", "0")
                codes = types.get(sat[0])
                if codes is None:
                    continue
                yield e, sat, {c: _num(rec[3 + 16 * k:3 + 16 * k + 14]) for k, c in enumerate(codes)}
        i = j


def _raw_obs_v2(lines: list[str], end: int, default_sys: str):
    types = _obs_types(lines, end, False)["_"]
    lps = 1 + (len(types) - 1) // 5
    e = -1
    i = end + 1
    while i < len(lines):
        ln = lines[i]
        if not ln.strip() or _is_comment(ln):
            i += 1
            continue
        flag, n = int(ln[28:29]), int(ln[29:32])
        if 2 <= flag <= 5:
            i += 1 + n
            continue
        sats_txt = ln[32:68]
        j = i + 1
        for _ in range((n - 1) // 12 if n else 0):
            sats_txt += lines[j][32:68]
            j += 1
        body = []
        while len(body) < n * lps and j < len(lines):
            if not _is_comment(lines[j]):
                body.append(lines[j])
            j += 1
        if len(body) < n * lps:
            return   # a truncated last epoch: dropped
        if flag <= 1:
            e += 1
            for s in range(n):
                sid = sats_txt[3 * s:3 * s + 3]
                sat = (sid[0] if sid[0] != " " else default_sys) + sid[1:].replace(" ", "0")
                text = "".join(b.ljust(80)[:80] for b in body[s * lps:(s + 1) * lps])
                yield e, sat, {c: _num(text[16 * k:16 * k + 14]) for k, c in enumerate(types)}
        i = j


def _check_obs(text: str, obs) -> int:
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()   # the final newline ends the last line; it opens no empty line
    end = _header_end(lines)
    h0 = next(k for k, ln in enumerate(lines) if ln.strip())
    v3 = float(lines[h0][0:9]) >= 3
    sys_letter = lines[h0][40:41].strip() or "G"
    gen = _raw_obs_v3(lines, end) if v3 else _raw_obs_v2(lines, end, "G" if sys_letter == "M" else sys_letter)
    n = 0
    sat_idx = {s: k for k, s in enumerate(obs.sats)}
    code_idx = {c: k for k, c in enumerate(obs.codes)}
    seen = 0
    for e, sat, vals in gen:
        assert e < len(obs.time), f"raw epoch {e} beyond the {len(obs.time)} epochs read"
        j = sat_idx.get(sat)
        assert j is not None, f"epoch {e}: {sat} has a record but is not among the satellites read"
        for c, v in vals.items():
            k = code_idx.get(c)   # RINEX 2 codes are kept as written (C1, P2, L5, ...)
            if k is None:
                continue
            _same(float(obs.values[e, j, k]), v, f"epoch {e} {sat} {c}")
            n += int(not np.isnan(v))
        seen = max(seen, e + 1)
    assert seen == len(obs.time) or seen == 0 and len(obs.time) == 0, f"{seen} raw epochs, {len(obs.time)} read"
    assert n == int(np.count_nonzero(~np.isnan(obs.values))), "the reader holds values no raw record has"
    return n


_D19 = re.compile(r"[+-]?(?:\d+\.\d*|\.\d+)(?:[DdEe][+-]?\d+)?")


def _check_nav(text: str, nav) -> int:
    """Every Kepler record's first 20 words (clock, orbits 1-4, idot: never blank) and every GLONASS record's 15,
    re-read as regex tokens of the record's lines (so fields that run together are split by their exponents)."""
    lines = text.split("\n")
    n = 0
    kep_names = ["af0_s", "af1_s_s", "af2_s_s2", "iode", "crs_m", "delta_n_rad_s", "m0_rad", "cuc_rad", "e",
                 "cus_rad", "sqrt_a_sqrt_m", "toe_sow", "cic_rad", "omega0_rad", "cis_rad", "i0_rad", "crc_m",
                 "omega_rad", "omega_dot_rad_s", "idot_rad_s"]
    for sys, eph in nav.kepler.items():
        for r, ln0 in enumerate(eph.line_no):
            first = lines[ln0 - 1]
            clk = first[23:] if first[:1].isalpha() else first[22:]   # 'G01 2020 ..' / 'J 1 12 ..' / ' 5 18 ..'
            toks = _D19.findall(clk) + [t for k in range(1, 6) for t in _D19.findall(lines[ln0 - 1 + k][3:])]
            for k, name in enumerate(kep_names):
                raw = float(toks[k].replace("D", "E").replace("d", "e"))
                ours = getattr(eph, name)[r]
                if name == "iode":
                    assert ours == int(round(raw)), f"{eph.sat[r]} line {ln0} iode: {ours} vs {raw}"
                else:
                    _same(float(ours), raw, f"{eph.sat[r]} line {ln0} {name}")
                n += 1
    g = nav.glonass
    for r, ln0 in enumerate(getattr(g, "line_no", [])):
        first = lines[ln0 - 1]
        clk = first[22:] if not first[:1].isalpha() else first[23:]
        toks = _D19.findall(clk) + [t for k in range(1, 4) for t in _D19.findall(lines[ln0 - 1 + k][3:])]
        vals = [float(t.replace("D", "E").replace("d", "e")) for t in toks[:15]]
        pos = [vals[3], vals[7], vals[11]]
        vel = [vals[4], vals[8], vals[12]]
        for a in range(3):
            _same(float(g.position_m[r, a]), pos[a] * 1000.0, f"{g.sat[r]} line {ln0} position")
            _same(float(g.velocity_m_s[r, a]), vel[a] * 1000.0, f"{g.sat[r]} line {ln0} velocity")
        n += 6
    return n + _check_nav_sbas_and_messages(lines, nav)


def _check_nav_sbas_and_messages(lines: list[str], nav) -> int:
    """SBAS state vectors (15 words) and every RINEX 4 message's numbers (blanks are NaN in ours, absent in the
    tokens), re-read as regex tokens of the record's lines."""
    n = 0
    s = getattr(nav, "sbas", None)
    for r, ln0 in enumerate(getattr(s, "line_no", [])):
        toks = _D19.findall(lines[ln0 - 1][23:])
        toks += [t for k in range(1, 4) for t in _D19.findall(lines[ln0 - 1 + k][3:])]
        vals = [float(t.replace("D", "E").replace("d", "e")) for t in toks[:15]]
        for a in range(3):
            _same(float(s.position_m[r, a]), vals[3 + 4 * a] * 1000.0, f"{s.sat[r]} line {ln0} position")
            _same(float(s.velocity_m_s[r, a]), vals[4 + 4 * a] * 1000.0, f"{s.sat[r]} line {ln0} velocity")
        _same(float(s.af0_s[r]), vals[0], f"{s.sat[r]} line {ln0} af0")
        n += 7
    for m in getattr(nav, "messages", []):
        k = m.line_no   # the '>' line (1-based) = index of the record's first line
        first = lines[k]
        toks = _D19.findall(first[23:]) if m.kind != "STO" else []
        j = k + 1
        while j < len(lines) and not lines[j].startswith(">") and lines[j].strip():
            toks += _D19.findall(lines[j][3:])
            j += 1
        ours = [float(v) for v in m.values if v == v]
        assert len(ours) == len(toks), f"{m.kind} {m.sat} {m.msg_type} line {m.line_no}: {len(ours)} vs {len(toks)}"
        for o, t in zip(ours, toks):
            _same(o, float(t.replace("D", "E").replace("d", "e")), f"{m.kind} {m.sat} line {m.line_no}")
        n += len(ours)
    return n


def _check_sp3(text: str, sp3) -> int:
    lines = text.split("\n")
    e = -1
    n = 0
    idx = {s: k for k, s in enumerate(sp3.sats)}
    for ln in lines:
        if ln.startswith("*") and ln[1:3] == "  ":
            e += 1
        elif ln.startswith("P") and e >= 0:
            sid = ln[1:4]
            sat = f"G{int(sid):02d}" if sid[0] == " " else f"{sid[0]}{int(sid[1:]):02d}"
            toks = ln[4:].split()
            if len(toks) < 3 or not all(_D19.fullmatch(t) for t in toks[:3]):
                continue   # fields that run together: the fixed-column reading is the only one
            x = [float(t) for t in toks[:3]]
            j = idx[sat]
            if any(v == 0.0 or abs(v) >= 999999.0 for v in x):
                assert np.isnan(sp3.position_ecef_m[e, j]).all(), f"{sat} epoch {e}: bad position not NaN"
            else:
                for a in range(3):
                    _same(float(sp3.position_ecef_m[e, j, a]), x[a] * 1000.0, f"{sat} epoch {e} axis {a}")
            if len(toks) > 3 and _D19.fullmatch(toks[3]):
                c = float(toks[3])
                if abs(c) >= 999999.0:
                    assert np.isnan(sp3.clock_s[e, j]), f"{sat} epoch {e}: bad clock not NaN"
                else:
                    _same(float(sp3.clock_s[e, j]), c * 1e-6, f"{sat} epoch {e} clock")
            n += 4
    return n


def _check_clk(text: str, clk) -> int:
    """AS records: (satellite, epoch) -> bias (and sigma), re-read as tokens."""
    from gnssatt.gnss.time import GpsTime

    lines = text.split("\n")
    end = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln)
    sat_idx = {s: k for k, s in enumerate(clk.sats)}
    key = clk.time.s * 1_000_000 + np.round(clk.time.frac * 1e6).astype(np.int64)
    n = 0
    for ln in lines[end + 1:]:
        if not ln.startswith("AS "):
            continue
        toks = ln[3:].split()
        sat = toks[0]
        sat = f"{sat[0]}{int(sat[1:]):02d}" if len(sat) >= 2 and sat[1:].isdigit() else sat
        y, mo, d, h, mi = (int(t) for t in toks[1:6])
        t = GpsTime.from_calendar(y, mo, d, h, mi, float(toks[6]))
        nval = int(toks[7])
        if clk.time_system.strip().upper() not in ("GPS", "GAL", "QZS", "IRN", ""):
            continue   # converted epochs: the reader's conversion is tested in tests/gnss/test_rinex_clock.py
        e = int(np.searchsorted(key, t.s * 1_000_000 + round(t.frac * 1e6)))
        j = sat_idx[sat]
        _same(float(clk.clock_s[e, j]), float(toks[8].replace("D", "E")), f"{sat} {ln[8:30]}")
        if nval >= 2 and len(toks) > 9:
            _same(float(clk.sigma_s[e, j]), float(toks[9].replace("D", "E")), f"{sat} {ln[8:30]} sigma")
        n += 1
    return n


def _check_atx(text: str, result) -> int:
    """Every NOAZI row, in file order, against the patterns' noazi_mm (tokens of the row)."""
    pats = result[0]
    rows = [ln for ln in text.split("\n") if ln[3:8] == "NOAZI"]
    ours = [f.noazi_mm for p in pats for f in list(p.frequencies) + list(p.rms)]
    # a block order: frequencies then rms within an antenna; the file interleaves them the same way per antenna
    raw_rows = [np.array([float(t) for t in r[8:].split()]) for r in rows]
    assert len(raw_rows) == len(ours), f"{len(raw_rows)} NOAZI rows in the file, {len(ours)} read"
    n = 0
    for a, b in zip(sorted(map(tuple, ours)), sorted(map(tuple, raw_rows))):
        np.testing.assert_array_equal(np.array(a), np.array(b))
        n += len(a)
    return n


def raw_check(row: Row, result) -> int:
    """Compare the reader's values with the independent raw re-read; the number of values compared."""
    text = decompressed_text(row.file)
    return {"obs": _check_obs, "nav": _check_nav, "sp3": _check_sp3, "clk": _check_clk,
            "atx": _check_atx}[row.kind](text, result)


# --- the expectation of a row ---------------------------------------------------------------------------------

def check_expectation(row: Row, out: Outcome) -> None:
    """valid: read without warnings; quirk: read with exactly the manifest's warning codes; broken: a ParseError
    at the manifest's line whose 'expected' starts with the manifest's text. AssertionError otherwise."""
    from gnssatt.gnss.io.errors import ParseError

    if row.label == "broken":
        assert isinstance(out.error, ParseError), f"{row.path}: expected a ParseError, got {out.error!r}"
        line, _, text = row.expect.partition(";")
        want_line = None if line == "line=None" else int(line.removeprefix("line="))
        assert out.error.line_no == want_line, f"{row.path}: error on line {out.error.line_no}, not {want_line}"
        assert out.error.expected.startswith(text), f"{row.path}: {out.error.expected!r} vs {text!r}"
        assert out.error.path == row.file.name, "the error names the file as the user knows it"
        return
    assert out.error is None, f"{row.path}: {row.label} file refused: {out.error}"
    codes = warning_codes(row, out.result)
    want = set(row.expect.split(";")) if row.expect else set()
    assert codes == want, f"{row.path}: warnings {sorted(codes)}, manifest says {sorted(want)}"


# --- the other readers ------------------------------------------------------------------------------------------

def georinex_check(row: Row, obs) -> int:
    """Values, LLI and SSI against georinex (bench.georinex_check.compare_with_georinex); values compared."""
    from bench.georinex_check import compare_with_georinex, load_georinex

    return compare_with_georinex(obs, load_georinex(row.file))


def _rtklib_sat_id(rk, sat: int) -> str:
    buf = rk.Arr1Dchar(8)
    rk.satno2id(sat, buf)
    return str(buf.ptr) if hasattr(buf, "ptr") else str(buf)


def rtklib_nav_check(row: Row, nav, workdir: Path) -> int:
    """Kepler records (A = sqrtA^2, e, toe seconds of week, af0) matched by satellite and toc against RTKLIB's
    readrnx (which drops duplicates and unhealthy-but-kept records differently: only matched pairs compare)."""
    import pyrtklib as rk

    plain = workdir / (row.file.name.split(".gz")[0].split(".zip")[0] + ".plain")
    plain.write_text(decompressed_text(row.file), encoding="latin-1")
    obs, rnav, sta = rk.obs_t(), rk.nav_t(), rk.sta_t()
    if rk.readrnx(str(plain), 1, "", obs, rnav, sta) != 1:
        raise RuntimeError("RTKLIB readrnx refused the file")
    theirs: dict = {}
    for i in range(rnav.n):
        e = rnav.eph[i]
        theirs.setdefault((_rtklib_sat_id(rk, e.sat), round(e.toc.time + e.toc.sec)), []).append(e)
    n = 0
    gps0 = 315964800   # 1980-01-06 in Unix seconds (RTKLIB's gtime_t is Unix time in GPST)
    for sys, eph in nav.kepler.items():
        toc = eph.toc_gpst() if sys == "C" and hasattr(eph, "toc_gpst") else eph.toc
        for r in range(len(eph.sat)):
            cands = theirs.get((str(eph.sat[r]), int(toc.s[r]) + gps0 + int(round(float(toc.frac[r])))))
            if not cands:
                continue
            # several records share a toc (Galileo I/NAV and F/NAV, retransmissions): ours equals one of them
            same = [t for t in cands if t.e == eph.e[r] and t.f0 == eph.af0_s[r] and t.toes == eph.toe_sow[r]]
            assert same, f"{eph.sat[r]} toc {toc[r].iso(0)}: e/af0/toe match none of RTKLIB's {len(cands)} records"
            # A: RTKLIB squares sqrtA in its own expression; equal to 1 ulp (2.2e-16 relative)
            assert abs(same[0].A - eph.sqrt_a_sqrt_m[r] ** 2) <= 4.5e-16 * same[0].A, f"{eph.sat[r]} A"
            n += 4
    return n


def rtklib_sp3_check(row: Row, sp3, workdir: Path) -> int:
    """Positions (m) against RTKLIB's readsp3 at every epoch and satellite both hold; 0 if RTKLIB reads none."""
    import pyrtklib as rk

    plain = workdir / (row.file.name.split(".gz")[0].split(".Z")[0] + ".sp3")
    plain.write_text(decompressed_text(row.file), encoding="latin-1")
    rnav = rk.nav_t()
    rk.readsp3(str(plain), rnav, 0)
    gps0 = 315964800
    ours_t = {int(s) + gps0: k for k, s in enumerate(sp3.time.s)}
    idx = {s: j for j, s in enumerate(sp3.sats)}
    n = 0
    for i in range(rnav.ne):
        p = rnav.peph[i]
        e = ours_t.get(int(p.time.time))
        if e is None:
            continue
        for j_s, sat in enumerate(sp3.sats):
            no = rk.satid2no(sat)
            if no <= 0:
                continue
            x = [p.pos[(no - 1, a)] for a in range(3)]
            if x == [0.0, 0.0, 0.0]:
                continue
            ours = sp3.position_ecef_m[e, idx[sat]]
            if np.isnan(ours).any():
                continue
            assert np.all(np.abs(ours - np.array(x)) <= 1e-9 * np.abs(np.array(x)) + 1e-6), \
                f"{sat} epoch {e}: {ours} vs RTKLIB {x}"
            n += 3
    return n
