"""RINEX clock reader: the real CODE file against an independent line-by-line parse, RINEX clock 3.04 layout,
continuation lines, errors with line numbers, speed."""
from __future__ import annotations

import gzip

import numpy as np
import pytest

from tests.conftest import real_set
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.rinex_clock import read_rinex_clock, summarize_rinex_clock
from gnssatt.gnss.time import GpsTime


def _hdr(content, label):
    return f"{content:<60s}{label:<20s}"


def clock_text(version="3.04", records=()):
    name_w = 9 if version >= "3.04" else 4
    lines = [_hdr(f"{version:>9s}           C", "RINEX VERSION / TYPE"),
             _hdr("   GPS", "TIME SYSTEM ID"),
             _hdr("     2    AR    AS", "# / TYPES OF DATA"),
             _hdr("TST  test centre", "ANALYSIS CENTER"),
             _hdr("", "END OF HEADER")]
    for kind, nm, sec, vals in records:
        head = f"{kind} {nm:<{name_w}s} 2024 06 24 00 00 {sec:9.6f}{len(vals):3d}   "
        first = "".join(f"{v:19.12E} " for v in vals[:2]).rstrip()
        lines.append(head + first)
        if len(vals) > 2:
            lines.append("".join(f"{v:19.12E} " for v in vals[2:]).rstrip())
    return ("\n".join(lines) + "\n").encode()


def test_rinex_clock_304_layout_continuation_and_receivers():
    recs = [("AS", "G01", 0.0, [1.5e-4, 2.0e-11]), ("AS", "E11", 0.0, [-3.25e-5, 1.0e-11, 1e-12, 1e-13]),
            ("AR", "WSRT00NLD", 0.0, [1.25e-7, 8.8e-11]), ("AS", "G01", 30.0, [1.6e-4])]
    c = read_rinex_clock(clock_text("3.04", recs), name="t.clk")
    assert c.sats == ["E11", "G01"] and c.receivers == ["WSRT00NLD"]
    assert c.time.iso(0) == ["2024-06-24T00:00:00", "2024-06-24T00:00:30"]
    np.testing.assert_array_equal(c.clock_s, [[-3.25e-5, 1.5e-4], [np.nan, 1.6e-4]])
    np.testing.assert_array_equal(c.sigma_s, [[1.0e-11, 2.0e-11], [np.nan, np.nan]])
    assert c.receiver_clock_s.tolist() == [[1.25e-7]] and c.analysis_center == "TST"
    c2 = read_rinex_clock(clock_text("2.00", [(k, n[:4], s, v) for k, n, s, v in recs]), name="t2.clk")
    np.testing.assert_array_equal(c2.clock_s, c.clock_s)
    assert c2.receivers == ["WSRT"]


@pytest.mark.parametrize("mutate, line, what", [
    (lambda t: t.replace(b"1.500000000000E-04", b"1.50000000x000E-04"), 6, "clock bias"),
    (lambda t: t.replace(b"2024 06 24 00 00  0.000000  2", b"2024 13 24 00 00  0.000000  2", 1), 6, "valid epoch"),
    (lambda t: t + b"XX garbage\n", 9, "clock record"),
    (lambda t: t + t.split(b"\n")[5] + b"\n", 9, "one record per clock name"),
])
def test_broken_clock_files_raise_parse_error(mutate, line, what):
    recs = [("AS", "G01", 0.0, [1.5e-4, 2.0e-11]), ("AS", "E11", 0.0, [-3.25e-5, 1.0e-11]),
            ("AS", "G01", 30.0, [1.6e-4])]
    with pytest.raises(ParseError) as info:
        read_rinex_clock(mutate(clock_text("3.04", recs)), name="b.clk")
    assert info.value.line_no == line and what in str(info.value)


def _naive_as_records(path):
    """Independent reference: split each AS line on blanks (the CODE file has no fields that touch)."""
    out = {}
    with gzip.open(path, "rt", encoding="latin-1") as f:
        in_body = False
        for ln in f:
            if not in_body:
                in_body = "END OF HEADER" in ln
                continue
            if ln.startswith("AS "):
                tok = ln.split()
                t = GpsTime.from_calendar(int(tok[2]), int(tok[3]), int(tok[4]), int(tok[5]), int(tok[6]),
                                          float(tok[7]))
                out[(tok[1], int(t.s))] = float(tok[9])
    return out


def test_real_cod_clock_against_independent_parse():
    """Values against an independent line parse (the read's speed is bench/bench_nav_sp3.py's, not a test's)."""
    path = real_set("leo_grace_a_2007080") / "cod14193.clk.gz"
    c = read_rinex_clock(path)
    assert c.clock_s.shape == (2880, 30) and len(c.receivers) == 108 and c.version == 2.0
    ref = _naive_as_records(path)
    assert len(ref) == int(np.isfinite(c.clock_s).sum()) == 86400
    col = {s: j for j, s in enumerate(c.sats)}
    e_of = {int(s): i for i, s in enumerate(c.time.s)}
    got = np.array([c.clock_s[e_of[ts], col[s]] for (s, ts) in ref])
    np.testing.assert_array_equal(got, np.array(list(ref.values())))
    s = summarize_rinex_clock(path)
    assert s["interval_s"] == 30.0 and s["time_span_gps"] == ["2007-03-21T00:00:00.000", "2007-03-21T23:59:30.000"]
